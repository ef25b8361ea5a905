"""The robot registry (robots.ROBOTS) and the task's view of a robot (LocoRobotConfig): the task config names its
robot, the robot's numbers fill the task's, and the task's code names no robot."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest

from cra_warp.config_io import from_data, to_data
from envs.loco_config import ROBOT_REWARD_NUMBERS, LocoConfig, RewardConfig
from robots import ROBOTS, robot_by_name
from robots.adam_lite import ADAM_LITE
from robots.adam_lite.loco import ADAM_LITE_LOCO
from robots.loco_robot import StandConfig

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "robots" / "adam_lite" / "policies").glob("*/config.json"))
ROBOT_NUMBERS = ("fall_height", *ROBOT_REWARD_NUMBERS)


def _numbers(cfg: LocoConfig) -> dict[str, float]:
    return {k: getattr(cfg, k) if k == "fall_height" else getattr(cfg.rewards, k) for k in ROBOT_NUMBERS}


def test_the_registry_holds_each_robot_under_its_own_name_and_the_default_is_in_it():
    assert ROBOTS == {"adam_lite": ADAM_LITE_LOCO} and ADAM_LITE_LOCO.robot is ADAM_LITE
    assert all(name == r.robot.name for name, r in ROBOTS.items())
    assert LocoConfig().robot in ROBOTS and robot_by_name("adam_lite") is ADAM_LITE_LOCO


@pytest.mark.parametrize("path", SHIPPED, ids=[p.parent.name for p in SHIPPED])
def test_adam_lites_task_config_is_what_the_shipped_policies_trained_with(path):
    """The numbers in each shipped config.json's env are the registry's, and its stored robot holds the groups and
    gains ADAM_LITE_LOCO has now: as `loco_robot` (rough_walk_v1 on), or, written before that (when the joint groups
    and stand gains were RobotConfig fields), in `robot` with no env.robot (which loads as the default, Adam Lite)."""
    stored = json.loads(path.read_text())
    env = stored["env"]
    cfg = from_data(LocoConfig, env)
    assert cfg.robot == "adam_lite"
    assert _numbers(cfg) == {k: getattr(ADAM_LITE_LOCO, k) for k in ROBOT_NUMBERS} == _numbers(LocoConfig())
    loco = to_data(ADAM_LITE_LOCO)
    groups = ("arm_joints", "hip_joints", "waist_joints", "torso_link", "swing_joints", "swing_profile",
              "lateral_joints", "turn_joints")
    if "loco_robot" in stored:
        assert env["robot"] == "adam_lite"
        assert {k: stored["loco_robot"][k] for k in (*groups, "stand")} == {k: loco[k] for k in (*groups, "stand")}
        return
    robot = stored["robot"]
    assert "robot" not in env
    for k in groups:
        assert robot[k] == loco[k], k
    assert (robot["stand_kp"], robot["stand_kd"], robot["ankle_pitch_joints"]) == (
        loco["stand"]["kp"], loco["stand"]["kd"], loco["stand"]["ankle_pitch_joints"])


def test_set_numbers_stay_and_another_robot_brings_its_own(monkeypatch):
    given = RewardConfig(base_height_target=0.8)
    cfg = LocoConfig(rewards=given, fall_height=0.4)
    assert (cfg.rewards.base_height_target, cfg.fall_height, cfg.rewards.contact_force_threshold) == (0.8, 0.4, 700.0)
    assert given.contact_force_threshold is None  # the RewardConfig passed in is not written into
    small = dataclasses.replace(ADAM_LITE_LOCO, robot=dataclasses.replace(ADAM_LITE, name="small"), fall_height=0.3,
                                base_height_target=0.6, feet_clearance_target=0.05, feet_min_lateral_distance=0.12,
                                contact_force_threshold=400.0)
    monkeypatch.setitem(ROBOTS, "small", small)
    assert _numbers(LocoConfig(robot="small")) == {k: getattr(small, k) for k in ROBOT_NUMBERS}
    from envs.methods import build_configs

    env_cfg, _, _ = build_configs("ours", "flat", overrides={"robot": "small", "rewards.feet_clearance_target": 0.07})
    assert env_cfg.robot == "small" and env_cfg.fall_height == 0.3 and env_cfg.rewards.feet_clearance_target == 0.07
    # a config rebuilt from stored data keeps its numbers whatever the registry says now
    assert _numbers(from_data(LocoConfig, to_data(env_cfg))) == _numbers(env_cfg)


def test_the_task_config_checks_its_joint_groups_against_the_robot():
    for bad in ((("hipRoll_Left", 1.0),), (("hipRoll_Left", 1.0), ("wristYaw_Left", 1.0)),
                (("hipRoll_Left", 1.0), ("hipRoll_Right", 0.5))):
        with pytest.raises(ValueError, match="adam_lite: lateral_joints"):
            dataclasses.replace(ADAM_LITE_LOCO, lateral_joints=bad)
    with pytest.raises(ValueError, match=r"stand.kp has 3 entries, expected 23"):
        dataclasses.replace(ADAM_LITE_LOCO, stand=StandConfig(kp=(1.0, 2.0, 3.0)))
    with pytest.raises(ValueError, match=r"hip_joints names joints that are not driven: \['wristYaw_Left'\]"):
        dataclasses.replace(ADAM_LITE_LOCO, hip_joints=("wristYaw_Left",))
    # the stand emulates stiffer legs than the drives: hip pitch, knee and ankle pitch, nothing else
    stand = ADAM_LITE_LOCO.stand
    stiffer = {n for n, s, k in zip(ADAM_LITE.joint_names, stand.kp, ADAM_LITE.kp) if s != k}
    assert stiffer == {f"{j}_{s}" for j in ("hipPitch", "kneePitch", "anklePitch") for s in ("Left", "Right")}


def test_the_task_names_no_robot():
    """envs/ reaches a robot only through LocoConfig.robot: no module imports a robot package, LocoEnv's source names
    none, and LocoConfig's only mention is the field's default."""
    envs = sorted((ROOT / "envs").glob("*.py"))
    assert len(envs) > 5
    for path in envs:
        src = path.read_text()
        assert not re.search(r"(from|import) robots\.\w+\.", src), path.name
        assert "ADAM_LITE" not in src, path.name
    assert not re.search("adam", (ROOT / "envs" / "locomotion.py").read_text(), re.I)
    lines = [line.strip() for line in (ROOT / "envs" / "loco_config.py").read_text().splitlines()
             if re.search("adam", line, re.I)]
    assert lines == ['robot: str = "adam_lite"'], lines


def test_the_env_uses_the_robot_its_config_names(monkeypatch):
    """LocoEnv builds the registered robot the config names, with its joint groups, numbers and stand (a variant of
    Adam Lite under its name: the simulators name bodies after the URDF's robot, which must be the config's name)."""
    from cra_warp.sim import WorldConfig
    from envs.locomotion import LocoEnv

    variant = dataclasses.replace(ADAM_LITE_LOCO, fall_height=0.3, hip_joints=("hipRoll_Left", "hipRoll_Right"))
    monkeypatch.setitem(ROBOTS, "adam_lite", variant)
    env = LocoEnv(LocoConfig(num_envs=1, world=WorldConfig(backend="mujoco")))
    assert env.loco_robot is variant and env.robot is ADAM_LITE and env.cfg.fall_height == 0.3
    assert env.hip_joints.tolist() == [ADAM_LITE.joint_names.index(j) for j in ("hipRoll_Left", "hipRoll_Right")]
    assert env.stand._ankles.tolist() == [ADAM_LITE.joint_names.index(j) for j in ("anklePitch_Left",
                                                                                     "anklePitch_Right")]

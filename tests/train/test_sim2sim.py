"""cra-sim2sim (train/sim2sim.py): the exported policy on the training model and the vendor's MJCF in MuJoCo C, falls
reported like training's, bad input in one line."""

import numpy as np
import pytest
import torch

from cra_warp.deploy import DeployPolicy
from envs.loco_config import LocoConfig
from envs.locomotion import LocoEnv
from tests.exports import _exported


@pytest.fixture(scope="module")
def export_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("export")
    _exported("adaptive", out)
    return out


@pytest.mark.slow
def test_sim2sim_reports_a_fall_like_training(export_dir, tmp_path):
    """An untrained policy on the training model in MuJoCo C at 1 kHz: it falls (as in training, ~1-2 s) and the
    JSON says so, with the time and a tracking error; stairs are terrain the robot stands on, not falls through."""
    import json

    from train import sim2sim

    out = tmp_path / "s2s.json"
    assert sim2sim.main([str(export_dir), "--trials", "2", "--seconds", "4", "--json", str(out)]) == 1  # FAIL
    result = json.loads(out.read_text())
    assert not result["pass"] and result["success"] == 0.0 and len(result["trials"]) == 2
    for r in result["trials"]:
        assert r["fell"] and 0.5 < r["time_survived"] < 3.0 and r["tracking_error"] > 0
    gif = tmp_path / "stairs.gif"
    assert sim2sim.main([str(export_dir), "--terrain", "stairs", "--trials", "1", "--seconds", "3",
                         "--video", str(gif)]) == 1
    from PIL import Image

    assert Image.open(gif).n_frames >= 10


def test_sim2sim_runs_the_vendor_model(export_dir, tmp_path):
    """The vendor's MJCF (meshes absent: dropped) loads with its 25 joints, the policy's 23 driven and the wrists
    held; the robot starts on the ground (not in it, not above it)."""
    from tests.conftest import REFERENCE, need_shared
    from train import sim2sim

    xml = need_shared(REFERENCE / "pnd_mujoco" / "pnd_robots" / "adam_lite" / "scene.xml")
    spec_json, _ = sim2sim.load_export(export_dir)
    args = sim2sim.Sim2SimArgs(export=export_dir, model=xml)
    model, qadr, vadr, held = sim2sim.build_model(args, spec_json)
    assert model.njnt == 26 and len(qadr) == 23 and len(held[0]) == 2 and model.nu == 25
    assert abs(model.body_mass.sum() - 58.19) < 0.05   # the vendor's MJCF mass: no geom added weight
    policy = DeployPolicy(export_dir)
    r = sim2sim.Trial(model, (qadr, vadr), held, policy, spec_json, sim2sim.Terrain(args)).run(0.5, 0.3, 0)
    assert r["time_survived"] == pytest.approx(0.3) and not r["fell"]
    # the vendor's file has rotor inertia on ankle pitch only; --export-armature adds the training's to every drive
    assert (model.dof_armature[vadr] < spec_json["pd"]["armature"]).all()
    args.export_armature = True
    model, _, vadr, _ = sim2sim.build_model(args, spec_json)
    assert (model.dof_armature[vadr] == pytest.approx(spec_json["pd"]["armature"]))


def test_sim2sim_bad_input_is_one_line(export_dir, tmp_path, capsys):
    from tests.conftest import one_line_error
    from train import sim2sim

    one_line_error(capsys, sim2sim.main([str(tmp_path)]), "found 0")
    one_line_error(capsys, sim2sim.main([str(export_dir), "--terrain", "ice"]), "--terrain")
    one_line_error(capsys, sim2sim.main([str(export_dir), "--physics-dt", "0.003"]), "divide")
    one_line_error(capsys, sim2sim.main([str(export_dir), "--video", str(tmp_path / "a.mp4")]), ".gif")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body><joint name='x'/></body></worldbody></mujoco>")
    one_line_error(capsys, sim2sim.main([str(export_dir), "--model", str(bad)]), "hipPitch_Left")


def _env_fall_times(export_dir, robots: int = 4) -> list[float]:
    """Fall times of the exported policy run by the deploy module in the training env (MuJoCo backend, 5 ms PD,
    nominal robot, no noise), each robot commanded 0.5 m/s forward with its heading held."""
    from envs.loco_config import DomainRandConfig

    cfg = LocoConfig(num_envs=robots, seed=3, randomization=DomainRandConfig(enabled=False), episode_length_s=100.0)
    cfg.world.backend, cfg.obs.noise = "mujoco", False
    env = LocoEnv(cfg)
    deps = [DeployPolicy(export_dir) for _ in range(robots)]
    fell: list[float | None] = [None] * robots
    forward = torch.tensor([0.5, 0.0]).expand(robots, 2)
    for k in range(250):
        env.hold_commands(forward, torch.zeros(robots), refresh=k == 0)
        readings = (env.commands, env.projected_gravity, env.joint_pos, env.joint_vel, env.base_ang_vel)
        a = np.stack([d.act(d.observe(*[r[i].numpy() for r in readings])) for i, d in enumerate(deps)])
        for d, ai in zip(deps, a):
            d.apply(ai)
        _, _, dones, _ = env.step(torch.as_tensor(a, dtype=torch.float32))
        for i in np.flatnonzero(dones.numpy()):
            fell[i] = fell[i] or (k + 1) * env.dt
        if all(fell):
            break
    assert all(fell), "the untrained policy should fall within 5 s in training"
    return fell


@pytest.mark.slow
def test_the_same_policy_falls_alike_in_training_and_on_the_vendor_models(export_dir):
    """The actuator model transfers: an untrained policy (near-zero actions: the robot's soft ankles let it fall
    forward) falls after the same time in the training env (explicit PD every 5 ms) and in cra-sim2sim (explicit PD
    at 1 kHz) on both vendor MJCFs (pnd_mujoco and menagerie): mean fall times within 10%."""
    from tests.conftest import REFERENCE, need_shared
    from train import sim2sim

    trained = float(np.mean(_env_fall_times(export_dir)))
    spec_json, _ = sim2sim.load_export(export_dir)
    for xml in (REFERENCE / "pnd_mujoco" / "pnd_robots" / "adam_lite" / "scene.xml",
                REFERENCE / "mujoco_menagerie" / "pndbotics_adam_lite" / "scene.xml"):
        args = sim2sim.Sim2SimArgs(export=export_dir, model=need_shared(xml))
        model, qadr, vadr, held = sim2sim.build_model(args, spec_json)
        trial = sim2sim.Trial(model, (qadr, vadr), held, DeployPolicy(export_dir), spec_json, sim2sim.Terrain(args))
        runs = [trial.run(0.5, 5.0, seed) for seed in range(4)]
        assert all(r["fell"] for r in runs), xml
        vendor = float(np.mean([r["time_survived"] for r in runs]))
        assert abs(vendor - trained) < 0.1 * trained, (xml, vendor, trained)


def test_a_stair_trial_succeeds_only_on_the_top_step():
    """On stairs, upright at the foot of the flight or halfway up is not success; on the top step it is, and the
    ground there is the flight's whole rise. On a slope (longer than a trial walks) upright is success."""
    from train import sim2sim

    stairs = sim2sim.Terrain(sim2sim.Sim2SimArgs(export=None, terrain="stairs", step_height=0.1, step_depth=0.3))
    top = stairs.top_x
    assert stairs.height(top + 0.01) == pytest.approx(10 * 0.1) and stairs.height(top - 0.01) == pytest.approx(0.9)
    upright = {"fell": False}
    assert not stairs.succeeded(upright | {"distance": 0.2})
    assert not stairs.succeeded(upright | {"distance": top - 0.5})
    assert stairs.succeeded(upright | {"distance": top + 0.1})
    assert not stairs.succeeded({"fell": True, "distance": top + 0.1})
    slope = sim2sim.Terrain(sim2sim.Sim2SimArgs(export=None, terrain="slope", slope_deg=15.0))
    assert slope.top_x is None and slope.succeeded(upright | {"distance": 0.2})
    assert slope.height(sim2sim.TERRAIN_START + 2.0) == pytest.approx(2.0 * np.tan(np.radians(15.0)))

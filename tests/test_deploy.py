"""The deploy module (numpy + onnxruntime, reads only the export) rebuilds what training fed the policy and what the
drives applied: observation parity with the env, action parity with the trained actor, torque parity with the
training actuator model."""

import sys
import subprocess

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from cra_warp.deploy import DeployError, DeployPolicy, pd_torque
from cra_warp.learning import ContrastConfig, LearnerConfig, PPOConfig, export_policy, runner_cfg
from cra_warp.sim import WorldConfig, make_world
from cra_warp.sim.config import FREE_Q
from envs.loco_config import LocoConfig
from envs.locomotion import LocoEnv
from robots.adam_lite import ADAM_LITE
from rsl_rl.runners import OnPolicyRunner
from train.export import deploy_metadata


def test_deploy_module_imports_no_training_stack():
    code = ("import sys, cra_warp.deploy; heavy = [m for m in ('torch', 'warp', 'newton', 'rsl_rl', 'envs', 'mujoco')"
            " if m in sys.modules]; assert not heavy, heavy")
    subprocess.run([sys.executable, "-c", code], check=True)


def _exported(variant: str, tmp_path, **gait):
    cfg = LocoConfig(num_envs=2, variant=variant, seed=3)
    for k, v in gait.items():
        setattr(cfg.gait, k, v)
    cfg.commands.heading_mode = False
    cfg.world.backend = "mujoco"
    cfg.obs.noise = False
    env = LocoEnv(cfg)
    torch.manual_seed(0)
    learner = LearnerConfig(num_steps_per_env=4, contrast=ContrastConfig(variant="none"),
                            ppo=PPOConfig(num_mini_batches=1))
    runner = OnPolicyRunner(env, runner_cfg(learner), log_dir=None, device="cpu")
    export_policy(runner, tmp_path, deploy_metadata(env))
    return env, runner.alg.get_policy(), DeployPolicy(tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["adaptive", "fixed_cycle", "clock_free"])
def test_observation_and_action_parity_with_the_env(variant, tmp_path):
    """For 30 control steps of the env under random actions (gait actions too), the deploy module's observation of
    robot 0, built from IMU- and encoder-like readings, equals the env's noise-free actor observation to 1e-5; and
    the exported network's action on it equals the trained actor's deterministic action (recurrent state carried)."""
    env, actor, dep = _exported(variant, tmp_path)
    gen = torch.Generator().manual_seed(1)
    actor.eval()
    actor.reset()
    obs = env.get_observations()
    for step in range(30):
        readings = (env.commands[0], env.projected_gravity[0], env.joint_pos[0], env.joint_vel[0],
                    env.base_ang_vel[0])
        o = dep.observe(*[r.numpy() for r in readings])
        np.testing.assert_allclose(o, obs["policy"][0].numpy(), atol=1e-5, err_msg=f"step {step}")
        with torch.no_grad():
            mean = actor(TensorDict({"policy": obs["policy"]}, batch_size=[env.num_envs]))[0].numpy()
        np.testing.assert_allclose(dep.act(o), dep.clip(mean), atol=1e-4, err_msg=f"step {step}")
        a = 0.5 * torch.randn(env.num_envs, env.num_actions, generator=gen)
        dep.apply(a[0].numpy())
        obs, _, dones, _ = env.step(a)
        assert not dones[0], "robot 0 fell during the parity run: the comparison would cross an episode"


@pytest.mark.parametrize("variant", ["adaptive", "fixed_cycle"])
def test_pd_target_parity_with_the_env_with_the_clock_feedforward(variant, tmp_path):
    """With the clock's swing, stride, lateral and turn feedforward on, the deploy module's PD targets (actions plus
    the clock-driven offsets, from the JSON and the observed command alone) equal the env's for 20 control steps of
    random actions, and the offsets act on the hip pitch, roll and yaw."""
    env, _, dep = _exported(variant, tmp_path, swing_feedforward=0.3, stride_feedforward=0.25,
                            lateral_feedforward=0.3, turn_feedforward=0.2)
    assert dep.feedforward == pytest.approx(0.3)
    assert [(c, g.tolist()) for _, g, c in dep.sweeps] == [(0, [-0.25, -0.25]), (1, [0.3, 0.3]), (2, [0.2, 0.2])]
    # a command held, so the sweeps act (a random one may be "stand still")
    env.hold_commands(torch.tensor([[0.5, 0.2]] * env.num_envs), torch.zeros(env.num_envs), yaw_rate=0.4)
    gen = torch.Generator().manual_seed(2)
    offsets = []
    for step in range(20):
        a = 0.5 * torch.randn(env.num_envs, env.num_actions, generator=gen)
        dep.observe(*[r[0].numpy() for r in (env.commands, env.projected_gravity, env.joint_pos, env.joint_vel,
                                             env.base_ang_vel)])
        q_target = dep.apply(a[0].numpy())
        env.step(a)
        np.testing.assert_allclose(q_target, env.joint_target[0].numpy(), atol=1e-5, err_msg=f"step {step}")
        commanded = dep.default_q + dep.action_scale * dep.clip(a[0].numpy())[:dep.num_joints]
        offsets.append(np.abs(q_target - commanded))
    hips = {name: np.max([o[dep.joint_names.index(f"{name}_Left")] for o in offsets])
            for name in ("hipPitch", "hipRoll", "hipYaw")}
    assert min(hips.values()) > 0.05, f"a feedforward never moved its hip target: {hips}"


def test_torque_parity_with_the_training_actuator():
    """On random states and targets, the deploy module's PD law with the gains the export writes (the robot's)
    equals the torque the training backend applies (nominal gains, the effort clamp active on some joints)."""
    w = make_world(ADAM_LITE, WorldConfig(sim_dt=1e-7, capture=False, backend="mujoco"), num_envs=3)
    gen = torch.Generator().manual_seed(0)
    n, J = w.num_envs, ADAM_LITE.num_joints
    q = w.default_joint_q.clone()
    q[:, 2] = 3.0                                    # in the air: no contacts
    q[:, FREE_Q:] += 0.2 * torch.randn(n, J, generator=gen)
    qd = torch.zeros(n, 6 + J)
    qd[:, 6:] = 2.0 * torch.randn(n, J, generator=gen)
    w.reset(torch.arange(n), joint_q=q, joint_qd=qd)
    w.joint_target.copy_(w.joint_pos + 0.5 * torch.randn(n, J, generator=gen))
    w.step()
    limit = np.asarray(ADAM_LITE.effort_limit)
    tau = np.stack([pd_torque(w.joint_pos[i].numpy(), w.joint_vel[i].numpy(), w.joint_target[i].numpy(),
                              ADAM_LITE.kp, ADAM_LITE.kd, limit) for i in range(n)])
    assert (np.abs(tau) >= limit - 1e-6).any(), "the clamp was never exercised"
    np.testing.assert_allclose(w.joint_torque.numpy(), tau, rtol=1e-3, atol=1e-2)


def test_incomplete_exports_are_refused_in_one_line(tmp_path):
    with pytest.raises(DeployError, match="found 0"):
        DeployPolicy(tmp_path)
    (tmp_path / "policy.json").write_text('{"format": "cra_warp-policy/1", "joint_names": ["a"]}')
    with pytest.raises(DeployError, match="lacks"):
        DeployPolicy(tmp_path)
    (tmp_path / "policy.json").write_text("{not json")
    with pytest.raises(DeployError, match="found 0"):
        DeployPolicy(tmp_path)
    with pytest.raises(DeployError, match="not a readable JSON"):
        DeployPolicy(tmp_path / "policy.json")


# ---------------------------------------------------------------- cra-sim2sim
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
    from conftest import REFERENCE, need_shared
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
    from conftest import one_line_error
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
    from conftest import REFERENCE, need_shared
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

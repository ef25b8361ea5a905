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
from cra_warp.sim import WorldConfig, make_world
from cra_warp.sim.config import FREE_Q
from robots.adam_lite import ADAM_LITE
from tests.exports import _exported


def test_deploy_module_imports_no_training_stack():
    code = ("import sys, cra_warp.deploy; heavy = [m for m in ('torch', 'warp', 'newton', 'rsl_rl', 'envs', 'mujoco')"
            " if m in sys.modules]; assert not heavy, heavy")
    subprocess.run([sys.executable, "-c", code], check=True)


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



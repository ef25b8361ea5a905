"""The left-right mirror of the actor's observation and action (envs/observations.py): the task itself is
mirror-symmetric, so the map a symmetry loss relies on must be the one the physics obeys."""

import math

import torch

from cra_warp.rotations import yaw_quat
from cra_warp.sim import WorldConfig
from cra_warp.gait import GaitClockConfig
from envs.loco_config import CommandConfig, DomainRandConfig, LocoConfig, ObsConfig
from envs.locomotion import LocoEnv
from envs.observations import action_mirror, actor_layout, actor_mirror
from robots.adam_lite import ADAM_LITE


def _maps(env):
    o_idx, o_sign = actor_mirror(env.layout, env.robot, env.cfg.uses_clock)
    a_idx, a_sign = action_mirror(env.robot, env.cfg.uses_clock)
    return (torch.tensor(o_idx), torch.tensor(o_sign)), (torch.tensor(a_idx), torch.tensor(a_sign))


def test_mirror_maps_are_involutions():
    for clock in (True, False):
        env_layout = actor_layout(ADAM_LITE.num_joints, clock)
        idx, sign = map(torch.tensor, actor_mirror(env_layout, ADAM_LITE, clock))
        x = torch.randn(5, len(idx))
        once = x[:, idx] * sign
        assert not torch.allclose(once, x)
        assert torch.allclose(once[:, idx] * sign, x)
        idx, sign = map(torch.tensor, action_mirror(ADAM_LITE, clock))
        a = torch.randn(5, len(idx))
        assert torch.allclose((a[:, idx] * sign)[:, idx] * sign, a)


def test_mirrored_robot_observes_the_mirrored_observation():
    """Two nominal robots on flat ground: robot 1 starts as robot 0's mirror image (y and yaw negated, clock half a
    cycle on), is told the mirrored command and given the mirrored action at every step. Its observation stays the
    mirror of robot 0's (the walking recipe's clock feedforward included), and a wrong sign in the map is caught."""
    gait = GaitClockConfig(alpha=5.0, beta_scale=0.1, swing_feedforward=0.25, stride_feedforward=0.5,
                           lateral_feedforward=0.25, turn_feedforward=0.2)
    env = LocoEnv(LocoConfig(num_envs=2, world=WorldConfig(backend="mujoco"), gait=gait,
                             randomization=DomainRandConfig(enabled=False), obs=ObsConfig(noise=False),
                             commands=CommandConfig(heading_mode=False)))
    (o_idx, o_sign), (a_idx, a_sign) = _maps(env)
    q = env.world.joint_q[[0]].clone()                 # robot 0 as reset: free joint (xyz, quat xyzw), joints
    yaw0 = 2 * math.atan2(float(q[0, 5]), float(q[0, 6]))
    q[0, 1] = -q[0, 1]
    q[0, 3:7] = yaw_quat(torch.tensor([-yaw0]))
    q[0, 7:] = q[0, 7:][a_idx[:env.robot.num_joints]] * a_sign[:env.robot.num_joints]
    env.world.reset(torch.tensor([1]), joint_q=q)
    env.clock.reset(torch.tensor([1]), torch.tensor([0.5 * env.cfg.gait.cycle_time]))
    env.hold_commands(torch.tensor([[0.4, 0.1], [0.4, -0.1]]), torch.zeros(2), yaw_rate=0.2)
    env.commands[1, 2] = -0.2
    env._refresh()
    env.obs = env._observations()
    g = torch.Generator().manual_seed(1)
    bad = o_sign.clone()
    bad[env.layout["joint_pos"].start + env.robot.joint_names.index("hipYaw_Left")] *= -1  # hip yaw kept: wrong
    worst, worst_bad = 0.0, 0.0
    for _ in range(10):  # 0.2 s: the vendor's model is symmetric to ~1 mm, so the two drift apart slowly
        obs = env.get_observations()["policy"]
        worst = max(worst, float((obs[1] - obs[0, o_idx] * o_sign).abs().max()))
        worst_bad = max(worst_bad, float((obs[1] - obs[0, o_idx] * bad).abs().max()))
        a0 = 0.3 * torch.randn(env.num_actions, generator=g)
        env.step(torch.stack([a0, a0[a_idx] * a_sign]))
    assert worst < 1e-2, worst
    assert worst_bad > 5 * worst, (worst_bad, worst)

"""A scripted stand: PD targets, recomputed every control step, that keep the robot standing at its reference pose.

The robot's drives run tau = kp (q* - q) - kd qd (clamped); its ankle pitch gains are too soft for a passive stand.
Two parts, both acting through the targets q* only (the PD law stays the robot's):

- every driven joint but the ankles emulates the stand gains (Ks, Ds) of its StandConfig about q_ref:
  q* = q + (Ks (q_ref - q) - (Ds - kd) qd) / kp, so that kp (q* - q) - kd qd = Ks (q_ref - q) - Ds qd
  (q* = q_ref where the stand gains are the robot's own; joints with kp = 0 get q_ref);
- each ankle pitch joint pushes the whole-body CoM over the sole centres: tau = K e + D de/dt, e = forward
  distance (heading frame) from the mean sole centre to the CoM, with K = 2 m g / (ankles) per metre, twice the
  gravity torque gradient, and D = K / 4 s.

It uses the simulator's CoM (a scripted stand, not a deployable controller). Between control steps the drives'
own gains act, so it holds where joints move slowly next to the control period, i.e. a robot standing on its feet;
it does not recover from pushes. Tests and cra-eval's floor use it where a zero action no longer stands.
"""

from __future__ import annotations

import torch

from cra_warp.rotations import quat_rotate, quat_rotate_inv, yaw, yaw_quat
from robots.loco_robot import StandConfig
from robots.robot_config import RobotConfig

GRAVITY = 9.81


class ScriptedStand:
    """``targets(world) -> q*`` [N, J] for the robots of a world (any object with the World views): ``robot`` as the
    world drives it (its kp, kd), ``stand`` the gains to emulate and the ankles that balance."""

    def __init__(self, robot: RobotConfig, stand: StandConfig, device: str | torch.device = "cpu"):
        d = dict(device=device, dtype=torch.float32)
        self.q_ref = torch.tensor(robot.default_q, **d)
        kp, kd = torch.tensor(robot.kp, **d), torch.tensor(robot.kd, **d)
        stand_kp = torch.tensor(stand.kp or robot.kp, **d)
        stand_kd = torch.tensor(stand.kd or robot.kd, **d)
        self._driven = kp > 0
        self._inv_kp = torch.where(self._driven, 1.0 / kp.clamp(min=1e-9), 0.0)
        self._stiff = stand_kp * self._inv_kp          # Ks / kp
        self._damp = (stand_kd - kd) * self._inv_kp    # (Ds - kd) / kp
        self._ankles = torch.tensor([robot.joint_names.index(n) for n in stand.ankle_pitch_joints], device=device,
                                    dtype=torch.long)
        self._foot_links = robot.foot_links
        self._sole = torch.tensor(robot.sole_offset, **d)

    def targets(self, world, q_ref: torch.Tensor | None = None) -> torch.Tensor:
        """q* [N, J] that hold ``q_ref`` ([N, J] or [J]; default the robot's reference pose)."""
        q, qd = world.joint_pos, world.joint_vel
        q_ref = self.q_ref if q_ref is None else q_ref
        q_star = torch.where(self._driven, q + self._stiff * (q_ref - q) - self._damp * qd, q_ref.expand_as(q)).clone()
        if len(self._ankles):
            feet = [world.body_index[n] for n in self._foot_links]
            soles = world.body_pos[:, feet] + quat_rotate(world.body_quat[:, feet], self._sole)
            com, com_vel = world.com()
            heading = yaw_quat(yaw(world.root_quat))
            e = quat_rotate_inv(heading, com - soles.mean(1))[:, 0]          # [N] CoM ahead of the soles [m]
            e_dot = quat_rotate_inv(heading, com_vel)[:, 0]
            k = 2.0 * world.body_mass.sum(1) * GRAVITY / len(self._ankles)
            tau = k * (e + 0.25 * e_dot)                                      # [N] per ankle
            q_star[:, self._ankles] = q_ref[..., self._ankles] + tau.unsqueeze(-1) * self._inv_kp[self._ankles]
        return q_star

    def actions(self, world, action_scale: float | torch.Tensor) -> torch.Tensor:
        """The joint actions [N, J] that produce these targets: q* = q_ref + action_scale * a."""
        return (self.targets(world) - self.q_ref) / action_scale

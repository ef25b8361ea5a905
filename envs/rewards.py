"""The 30 reward terms of the paper's Table I, each a small function of the env's per-step tensors, and the shaping
terms we add beyond it (at the end, weight 0 by default).

Every term returns r_i [N]; the env multiplies by the weight w_i (envs/loco_config.py, DEFAULT_WEIGHTS) and sums.
Read this file next to Table I: same names, same order, the equation beside each. Where Table I's sign or form
contradicts a term's intent, the term follows the intent and says so.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import torch

if TYPE_CHECKING:
    from envs.locomotion import LocoEnv


def sq(x: torch.Tensor) -> torch.Tensor:
    return (x * x).sum(-1)


# ---- tracking and base motion
def lin_vel_tracking(e: LocoEnv):      # exp(-|v_cmd_xy - v_xy|^2 / sigma)
    return torch.exp(-sq(e.commands[:, :2] - e.base_lin_vel[:, :2]) / e.cfg.rewards.tracking_sigma)


def ang_vel_tracking(e: LocoEnv):      # exp(-(w_cmd_yaw - w_yaw)^2 / sigma)
    return torch.exp(-(e.commands[:, 2] - e.base_ang_vel[:, 2]) ** 2 / e.cfg.rewards.tracking_sigma)


def lin_vel_z(e: LocoEnv):             # v_z^2
    return e.base_lin_vel[:, 2] ** 2


def ang_vel_xy(e: LocoEnv):            # |w_xy|^2
    return sq(e.base_ang_vel[:, :2])


def orientation(e: LocoEnv):           # |g_xy|^2
    return sq(e.projected_gravity[:, :2])


def torso_orientation(e: LocoEnv):     # exp(-|g_torso_xy|^2 / sigma)
    return torch.exp(-sq(e.torso_gravity[:, :2]) / e.cfg.rewards.torso_sigma)


# ---- joints and energy
def joint_acc(e: LocoEnv):             # |q_ddot|^2
    return sq(e.joint_acc)


def joint_power(e: LocoEnv):           # |tau|.|q_dot| / (|v|^2 + 0.2 |w|^2)
    speed = sq(e.base_lin_vel) + 0.2 * sq(e.base_ang_vel)
    # The ratio is unbounded for a robot standing still; a floor keeps standing costs finite.
    return (e.torques.abs() * e.joint_vel.abs()).sum(-1) / speed.clamp(min=e.cfg.rewards.power_floor)


def body_height(e: LocoEnv):           # (h_target - h)^2, h = pelvis above the mean sole height
    # Table I gives this squared error a positive weight; rewarding the error cannot be the intent, so the
    # config's weight is negative (a penalty).
    h = e.root_pos[:, 2] - e.sole_centres[:, :, 2].mean(1)
    return (e.cfg.rewards.base_height_target - h) ** 2


def feet_clearance(e: LocoEnv):        # sum_feet (p_z_target - p_z)^2 * |v_xy|
    err = (e.cfg.rewards.feet_clearance_target - e.sole_height) ** 2
    return (err * e.feet_lin_vel[..., :2].norm(dim=-1)).sum(-1)


def action_rate(e: LocoEnv):           # |a_t - a_t-1|^2
    return sq(e.actions - e.last_actions)


def smoothness(e: LocoEnv):            # |a_t - 2 a_t-1 + a_t-2|^2
    return sq(e.actions - 2.0 * e.last_actions + e.last_last_actions)


def feet_stumble(e: LocoEnv):          # 1{exists i: |F_xy_i| > 3 F_z_i}
    f = e.foot_forces
    return (f[..., :2].norm(dim=-1) > 3.0 * f[..., 2].abs()).any(-1).float()


def torques(e: LocoEnv):               # sum (tau_i / kP_i)^2 over the joints with a stiffness (kP > 0)
    return sq(torch.where(e.kp > 0, e.torques / e.kp.clamp(min=1e-6), 0.0))


def joint_velocity(e: LocoEnv):        # sum q_dot_i^2
    return sq(e.joint_vel)


def joint_tracking_error(e: LocoEnv):  # sum (q_i - q_target_i)^2
    return sq(e.joint_pos - e.joint_target)


def arm_joint_deviation(e: LocoEnv):   # sum_arm (q_i - q_default_i)^2
    return sq((e.joint_pos - e.default_q)[:, e.arm_joints])


def hip_joint_deviation(e: LocoEnv):   # sum_hip roll/yaw (q_i - q_default_i)^2 (hip pitch must swing to walk)
    return sq((e.joint_pos - e.default_q)[:, e.hip_joints])


def waist_joint_deviation(e: LocoEnv): # sum_waist (q_i - q_default_i)^2
    return sq((e.joint_pos - e.default_q)[:, e.waist_joints])


def joint_pos_limits(e: LocoEnv):      # sum out_i: distance beyond the soft position limits
    below = (e.soft_pos_lower - e.joint_pos).clamp(min=0.0)
    above = (e.joint_pos - e.soft_pos_upper).clamp(min=0.0)
    return (below + above).sum(-1)


def joint_vel_limits(e: LocoEnv):      # sum ReLU(|q_dot_i| - q_dot_max_i)
    return (e.joint_vel.abs() - e.soft_vel_limit).clamp(min=0.0).sum(-1)


def torque_limits(e: LocoEnv):         # sum ReLU(|tau_i| - tau_max_i)
    return (e.torques.abs() - e.soft_torque_limit).clamp(min=0.0).sum(-1)


# ---- feet and contacts
def no_fly(e: LocoEnv):                # 1{only one foot on the ground}: single support, as the equation says
    return (e.contact.sum(-1) == 1).float()


def feet_lateral_distance(e: LocoEnv): # |d_left - d_right| - d_min, lateral in the base yaw frame
    # Table I's form rewards ever wider feet under its positive weight; the intent is a minimum width, so the
    # term is clipped at 0: zero when the feet are d_min apart or more, negative when closer.
    return ((e.feet_pos_yaw[:, 0, 1] - e.feet_pos_yaw[:, 1, 1]).abs()
            - e.cfg.rewards.feet_min_lateral_distance).clamp(max=0.0)


def feet_slip(e: LocoEnv):             # sum |v_foot_i| * 1{new contact}
    return (e.feet_lin_vel.norm(dim=-1) * e.first_contact.float()).sum(-1)


def feet_ground_parallel(e: LocoEnv):  # sum_feet Var(H_i), H_i = heights of the sole corners above the ground
    return e.sole_corner_height.var(dim=-1, unbiased=False).sum(-1)


def feet_contact_force(e: LocoEnv):    # sum ReLU(F_z_i - F_th)
    return (e.foot_forces[..., 2] - e.cfg.rewards.contact_force_threshold).clamp(min=0.0).sum(-1)


def feet_parallel(e: LocoEnv):         # Var(D), D = horizontal distances between matching sole corners of the feet
    d = (e.sole_corners[:, 0, :, :2] - e.sole_corners[:, 1, :, :2]).norm(dim=-1)  # [N, 4]
    return d.var(dim=-1, unbiased=False)


def contact_momentum(e: LocoEnv):      # sum |v_z_i * F_z_i|
    return (e.feet_lin_vel[..., 2] * e.foot_forces[..., 2]).abs().sum(-1)


def contact_pattern(e: LocoEnv):       # exp(-|m_stance(t) - c_actual(t)|^2)
    return torch.exp(-sq(e.clock.stance_mask.float() - e.contact.float()))


contact_pattern.needs_clock = True     # the clock-free variant has no stance mask: the env skips the term


# ---- beyond Table I (weight 0 unless a run sets one; the README's learning-efficiency A/Bs say what they did)
def swing_reference(e: LocoEnv):       # exp(-|q_swing - q_ref(clock)| / scale)
    # Dense shaping towards stepping in time with the clock: each leg's pitch joints follow a reference that lifts
    # the foot while the clock has it in swing (depth 0 at the stance threshold gamma, 1 at the swing's middle) and
    # holds the default pose in stance. Table I only rewards the contact outcome, which standing half satisfies.
    depth = e.clock.swing_depth                                                             # [N, feet]
    ref = e.default_q[e.swing_joints] + e.cfg.rewards.swing_amplitude * depth.unsqueeze(-1) * e.swing_profile
    err = (e.joint_pos[:, e.swing_joints] - ref).flatten(1).norm(dim=-1)
    return torch.exp(-err / e.cfg.rewards.swing_scale)


swing_reference.needs_clock = True


def yaw_bias(e: LocoEnv):              # (low-passed (w_cmd_yaw - w_yaw))^2
    # ang_vel_tracking is per step: a steady 0.1 rad/s turn beside the command costs it ~4% (sigma 0.25) and hides in
    # the gait's yaw sway (~0.4 rad/s per step), and long rough runs drifted so. Low-passed (rewards.yaw_bias_tau)
    # the sway averages out and the steady error is what is left.
    return e.slow_yaw_error ** 2


def stall(e: LocoEnv):                 # 1{|v_cmd_xy| > v_min and v_xy . v_cmd_xy / |v_cmd_xy| < |v_cmd_xy| / 2}
    # Under lin_vel_tracking's kernel a robot standing still keeps exp(-|v_cmd|^2 / sigma) of it: 37% when told
    # 0.5 m/s, 2-8% when told 0.8-1.0. rough_walk_v0 stops at the foot of a slope when told 0.5 m/s and climbs it when
    # told 0.8. This indicator costs the same for going less than half as fast as told at any commanded speed.
    cmd = e.commands[:, :2]
    speed = cmd.norm(dim=-1)
    along = (e.base_lin_vel[:, :2] * cmd).sum(-1) / speed.clamp(min=1e-6)
    return ((speed > e.cfg.rewards.stall_min_command) & (along < 0.5 * speed)).float()


TERMS: dict[str, Callable[[LocoEnv], torch.Tensor]] = {f.__name__: f for f in (
    lin_vel_tracking, ang_vel_tracking, lin_vel_z, ang_vel_xy, orientation, torso_orientation, joint_acc,
    joint_power, body_height, feet_clearance, action_rate, smoothness, feet_stumble, torques, joint_velocity,
    joint_tracking_error, arm_joint_deviation, hip_joint_deviation, waist_joint_deviation, joint_pos_limits,
    joint_vel_limits, torque_limits, no_fly, feet_lateral_distance, feet_slip, feet_ground_parallel,
    feet_contact_force, feet_parallel, contact_momentum, contact_pattern, swing_reference, yaw_bias, stall)}

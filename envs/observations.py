"""Observation layouts: the one place that says which slice of which group holds what.

Actor ("policy", the paper's o_t: 84 = 3+3+23+23+26+3+1+2 for a robot of 23 joints with the clock):
    command (vx, vy, yaw rate, scaled) | projected gravity | joint positions - q_ref | joint velocities (scaled) |
    previous action | base angular velocity (scaled) | average angular speed (filtered yaw rate, scaled) |
    gait phase (sin, cos of the global phase 2 pi phi / T_cycle; the leg offsets are in the previous action)
Clock-free: no gait actions in the previous action and no gait phase (79 for 23 joints).

Critic "privileged" (the paper's s_t): base linear velocity (base frame, scaled) | whole-body CoM relative to the
base (base frame) | two 5x5 foot-level height maps (left, right; heights relative to the sole) | foot contact
states | foot contact forces (world frame, / body weight) | randomised parameters: mass offset (fraction),
base CoM offset, motor strength, PD stiffness and damping scales per joint, friction, current external force
(/ 50 N) | the actor observation without noise.
Critic "height_map": [N, 1, 17, 11] heights of the ground relative to the base on a yaw-aligned grid.
"""

from __future__ import annotations


def _layout(parts: list[tuple[str, int]]) -> dict[str, slice]:
    out, i = {}, 0
    for name, n in parts:
        out[name] = slice(i, i + n)
        i += n
    return out


def actor_layout(num_joints: int, uses_clock: bool) -> dict[str, slice]:
    """Name -> slice of the actor observation."""
    num_actions = num_joints + (3 if uses_clock else 0)
    parts = [("command", 3), ("gravity", 3), ("joint_pos", num_joints), ("joint_vel", num_joints),
             ("prev_action", num_actions), ("ang_vel", 3), ("avg_ang_speed", 1)]
    return _layout(parts + ([("gait_phase", 2)] if uses_clock else []))


def privileged_layout(num_joints: int, num_feet: int, foot_map_cells: int, actor_dim: int) -> dict[str, slice]:
    """Name -> slice of the critic's privileged observation."""
    return _layout([
        ("base_lin_vel", 3), ("com_pos", 3), ("foot_height_maps", num_feet * foot_map_cells),
        ("foot_contact", num_feet), ("foot_forces", 3 * num_feet), ("mass_offset", 1), ("com_offset", 3),
        ("motor_strength", num_joints), ("kp_scale", num_joints),
        ("kd_scale", num_joints), ("friction", 1), ("external_force", 3), ("actor", actor_dim)])


def size(layout: dict[str, slice]) -> int:
    return max(s.stop for s in layout.values())


# The left-right mirror (sagittal plane) of the actor's inputs and actions, for symmetry losses and augmentation: the
# mirrored robot's observation is sign * obs[index]. Velocities and gravity: y flips; angular velocities are axial,
# so x and z flip. The clock: the legs swap when the global phase moves half a cycle (psi = 0.5) and the offsets
# d1, d2 trade places, so (sin, cos) of the phase change sign and d0 keeps its value.
_VECTOR_SIGNS = {"command": (1.0, -1.0, -1.0), "gravity": (1.0, -1.0, 1.0), "ang_vel": (-1.0, 1.0, -1.0),
                 "avg_ang_speed": (-1.0,), "gait_phase": (-1.0, -1.0)}


def action_mirror(robot, uses_clock: bool) -> tuple[list[int], list[float]]:
    """(index, sign) per action: the mirrored robot's action is sign * a[index] (joint offsets, then d0, d1, d2)."""
    index, sign = robot.mirror_joints()
    if uses_clock:
        j = robot.num_joints
        index, sign = index + [j, j + 2, j + 1], sign + [1.0, 1.0, 1.0]
    return index, sign


def actor_mirror(layout: dict[str, slice], robot, uses_clock: bool) -> tuple[list[int], list[float]]:
    """(index, sign) per actor input of ``layout`` (actor_layout's) for ``robot``."""
    joints = robot.mirror_joints()
    parts = {"joint_pos": joints, "joint_vel": joints, "prev_action": action_mirror(robot, uses_clock)}
    index, sign = [0] * size(layout), [1.0] * size(layout)
    for name, sl in layout.items():
        part_index, part_sign = parts.get(name) or (list(range(sl.stop - sl.start)), list(_VECTOR_SIGNS[name]))
        if len(part_index) != sl.stop - sl.start:
            raise ValueError(f"mirror of {name!r}: {len(part_index)} entries for a slice of {sl.stop - sl.start}")
        for k, (i, s) in enumerate(zip(part_index, part_sign)):
            index[sl.start + k], sign[sl.start + k] = sl.start + i, s
    return index, sign

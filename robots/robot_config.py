"""The robot config type: what the library needs to know about a robot beyond its URDF."""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class RobotConfig:
    """One robot as the simulator and kinematics see it: what it is, not how a task uses it (the locomotion task's
    joint groups, stand gains and numbers are its LocoRobotConfig, robots/loco_robot.py).

    Every per-joint tuple is in the canonical order of ``joint_names`` (the driven joints). Joints of the
    description that are not driven are listed in ``fixed_joints``: the simulator and the kinematics weld them at 0.
    """

    name: str
    urdf_path: Path
    base_link: str
    foot_links: tuple[str, ...]                 # left first
    joint_names: tuple[str, ...]                # canonical order of the driven joints
    default_q: tuple[float, ...]                # reference standing pose q_ref [rad]
    kp: tuple[float, ...]                       # PD stiffness [N m / rad]
    kd: tuple[float, ...]                       # PD damping [N m s / rad]
    effort_limit: tuple[float, ...]             # [N m]
    velocity_limit: tuple[float, ...]           # [rad / s]
    pos_lower: tuple[float, ...]                # [rad]
    pos_upper: tuple[float, ...]                # [rad]
    action_scale: float                         # q* = q_ref + action_scale * a
    base_height: float                          # pelvis height above flat ground at the standing pose [m]
    sole_offset: tuple[float, float, float]     # sole centre in the foot link frame [m]
    sole_half_size: tuple[float, float]         # sole half length (x) and half width (y) [m]
    fixed_joints: tuple[str, ...] = ()          # joints of the description held at 0: fixed in sim and kinematics
    armature: float = 0.0                       # reflected rotor inertia added to every joint [kg m^2]
    # The left-right mirror through the sagittal (x-z) plane: joints named <j>_Left and <j>_Right swap, and the
    # joints listed here by name without side (roll and yaw axes on this kind of robot) change sign; the rest keep
    # their angle (tests check it through forward kinematics).
    mirror_negated: tuple[str, ...] = ()

    def __post_init__(self):
        n = len(self.joint_names)
        for f in ("default_q", "kp", "kd", "effort_limit", "velocity_limit", "pos_lower", "pos_upper"):
            if len(getattr(self, f)) != n:
                raise ValueError(f"RobotConfig.{f} has {len(getattr(self, f))} entries, expected {n} (one per joint)")
        bases = {n.rsplit("_", 1)[0] for n in self.joint_names} | set(self.joint_names)
        unknown = [j for j in self.mirror_negated if j not in bases]
        if unknown:
            raise ValueError(f"RobotConfig.mirror_negated names no driven joint: {unknown}")
        missing = [n for n in self.joint_names if n.endswith(("_Left", "_Right")) and
                   (n.rsplit("_", 1)[0] + ("_Right" if n.endswith("_Left") else "_Left")) not in self.joint_names]
        if missing:
            raise ValueError(f"RobotConfig.joint_names: {missing} have no joint on the other side")

    def mirror_joints(self) -> tuple[list[int], list[float]]:
        """(index, sign) per joint: joint i of the mirrored robot is sign[i] x joint index[i] of this one."""
        def partner(n: str) -> str:
            side = n.rsplit("_", 1)
            if len(side) == 2 and side[1] in ("Left", "Right"):
                return f"{side[0]}_{'Right' if side[1] == 'Left' else 'Left'}"
            return n

        index = [self.joint_names.index(partner(n)) for n in self.joint_names]
        sign = [-1.0 if n.rsplit("_", 1)[0] in self.mirror_negated or n in self.mirror_negated else 1.0
                for n in self.joint_names]
        return index, sign

    def joint_ids(self, names: tuple[str, ...]) -> list[int]:
        """Canonical indices of ``names``."""
        return [self.joint_names.index(n) for n in names]

    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    def with_gains(self, gains: dict[str, tuple[float, float]]) -> RobotConfig:
        """This robot with other PD gains: {joint: (kp, kd)}; a key without the side suffix ("ankleRoll") sets
        every joint named ``key_<side>``."""
        kp, kd = list(self.kp), list(self.kd)
        for key, (p, d) in gains.items():
            ids = [i for i, n in enumerate(self.joint_names) if n == key or n.rsplit("_", 1)[0] == key]
            if not ids:
                raise ValueError(f"joint gains: {key!r} names no driven joint of {self.name}")
            if p < 0 or d < 0:
                raise ValueError(f"joint gains: {key!r} needs kp, kd >= 0, got ({p}, {d})")
            for i in ids:
                kp[i], kd[i] = float(p), float(d)
        return dataclasses.replace(self, kp=tuple(kp), kd=tuple(kd))


def robot_urdf_text(robot: RobotConfig) -> str:
    """The robot's URDF as the simulator and kinematics load it: joints the policy does not drive become fixed."""
    text = robot.urdf_path.read_text()
    for name in robot.fixed_joints:
        text, n = re.subn(rf'(<joint name="{name}" type=")\w+(")', r"\1fixed\2", text)
        if n != 1:
            raise ValueError(f"{robot.urdf_path.name}: joint {name!r} listed in fixed_joints is not in the URDF")
    return text

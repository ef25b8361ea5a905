"""The robot config type: what the library needs to know about a robot beyond its URDF."""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class RobotConfig:
    """One robot as the simulator, kinematics and tasks see it.

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
    # Gains the scripted stand emulates through its PD targets (cra_warp.stand); empty = kp / kd (a passive stand).
    stand_kp: tuple[float, ...] = ()
    stand_kd: tuple[float, ...] = ()
    ankle_pitch_joints: tuple[str, ...] = ()    # the scripted stand balances the CoM over the soles through these
    # Joint groups and bodies the task's reward terms read (Table I's arm / hip / waist deviation, torso orientation)
    arm_joints: tuple[str, ...] = ()
    hip_joints: tuple[str, ...] = ()            # hip roll and yaw: hip pitch must swing to walk
    waist_joints: tuple[str, ...] = ()
    torso_link: str = ""
    # The swing_reference shaping term (not in Table I): per foot, the pitch joints that lift it, and how far each
    # moves (rad per rad of the reward's swing amplitude) from default_q at the top of the swing.
    swing_joints: tuple[tuple[str, ...], ...] = ()
    swing_profile: tuple[float, ...] = ()
    # The clock's lateral and turn feedforward (cra_warp.gait): per foot, the joint that moves the sole sideways and
    # the one that turns it about the vertical, each with the sign (+-1) of the angle that moves the sole to +y (left)
    # or turns its toes anticlockwise seen from above.
    lateral_joints: tuple[tuple[str, float], ...] = ()
    turn_joints: tuple[tuple[str, float], ...] = ()
    # The left-right mirror through the sagittal (x-z) plane: joints named <j>_Left and <j>_Right swap, and the
    # joints listed here by name without side (roll and yaw axes on this kind of robot) change sign; the rest keep
    # their angle (tests check it through forward kinematics).
    mirror_negated: tuple[str, ...] = ()

    def __post_init__(self):
        n = len(self.joint_names)
        for f in ("default_q", "kp", "kd", "effort_limit", "velocity_limit", "pos_lower", "pos_upper", "stand_kp",
                  "stand_kd"):
            if len(getattr(self, f)) != n and not (f.startswith("stand_") and not getattr(self, f)):
                raise ValueError(f"RobotConfig.{f} has {len(getattr(self, f))} entries, expected {n} (one per joint)")
        for f in ("ankle_pitch_joints", "arm_joints", "hip_joints", "waist_joints"):
            unknown = [j for j in getattr(self, f) if j not in self.joint_names]
            if unknown:
                raise ValueError(f"RobotConfig.{f} names joints that are not driven: {unknown}")
        if self.swing_joints and (len(self.swing_joints) != len(self.foot_links)
                                  or any(len(leg) != len(self.swing_profile) for leg in self.swing_joints)
                                  or any(j not in self.joint_names for leg in self.swing_joints for j in leg)):
            raise ValueError(f"RobotConfig.swing_joints needs one tuple of driven joints per foot, each as long as "
                             f"swing_profile {self.swing_profile}, got {self.swing_joints}")
        for f in ("lateral_joints", "turn_joints"):
            legs = getattr(self, f)
            if legs and (len(legs) != len(self.foot_links) or any(j not in self.joint_names or abs(sign) != 1
                                                                  for j, sign in legs)):
                raise ValueError(f"RobotConfig.{f} needs one (driven joint, +-1) per foot, got {legs}")
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

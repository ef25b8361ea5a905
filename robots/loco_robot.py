"""The locomotion task's view of one robot: what envs/ reads of it beyond its physics (RobotConfig).

RobotConfig says what the robot is (joints, pose, drives, limits, feet); LocoRobotConfig says how the locomotion task
uses it: the joint groups its reward terms and its gait clock read, the gains the scripted stand emulates, and the
task's numbers that scale with the robot (heights, distances, forces). Each robot package holds one
(robots/<robot>/loco.py) and robots.ROBOTS registers it under the name LocoConfig.robot gives. Plain data: no
simulation code.
"""

from __future__ import annotations

from dataclasses import dataclass

from robots.robot_config import RobotConfig


@dataclass(frozen=True)
class StandConfig:
    """What the scripted stand (cra_warp.stand) emulates through its PD targets."""

    kp: tuple[float, ...] = ()                  # per joint; empty = the robot's own kp (a passive stand)
    kd: tuple[float, ...] = ()                  # per joint; empty = the robot's own kd
    ankle_pitch_joints: tuple[str, ...] = ()    # the stand balances the CoM over the soles through these


@dataclass(frozen=True)
class LocoRobotConfig:
    """One robot as the locomotion task (LocoEnv, its rewards and clock) sees it. Joint names are the robot's driven
    joints; per-foot tuples follow ``robot.foot_links`` (left first)."""

    robot: RobotConfig
    # The task's numbers at this robot's size: LocoConfig takes each where it leaves the field of the same name unset
    # (rewards.<name>, or fall_height at the top level).
    base_height_target: float                   # [m] pelvis above the soles that body_height rewards
    feet_clearance_target: float                # [m] swing-foot sole height above the ground (feet_clearance)
    feet_min_lateral_distance: float            # [m] d_min of feet_lateral_distance
    contact_force_threshold: float              # [N] F_th of feet_contact_force
    fall_height: float                          # [m] a pelvis lower than this above the ground has fallen
    stand: StandConfig = StandConfig()
    # Table I's arm / hip / waist deviation terms and torso orientation read these joints and this body.
    arm_joints: tuple[str, ...] = ()
    hip_joints: tuple[str, ...] = ()
    waist_joints: tuple[str, ...] = ()
    torso_link: str = ""
    # The swing_reference shaping term and the clock's swing feedforward: per foot, the pitch joints that lift it,
    # and how far each moves (rad per rad of amplitude) from default_q at the top of the swing. The clock's stride
    # feedforward moves each leg's first swing joint with the sign of its profile (the thigh forward).
    swing_joints: tuple[tuple[str, ...], ...] = ()
    swing_profile: tuple[float, ...] = ()
    # The clock's lateral and turn feedforward (cra_warp.gait): per foot, the joint that moves the sole sideways and
    # the one that turns it about the vertical, each with the sign (+-1) of the angle that moves the sole to +y (left)
    # or turns its toes anticlockwise seen from above.
    lateral_joints: tuple[tuple[str, float], ...] = ()
    turn_joints: tuple[tuple[str, float], ...] = ()

    def __post_init__(self):
        r = self.robot
        for f in ("kp", "kd"):
            gains = getattr(self.stand, f)
            if gains and len(gains) != r.num_joints:
                raise ValueError(f"{r.name}: stand.{f} has {len(gains)} entries, expected {r.num_joints} (one per "
                                 f"joint) or none")
        for f, joints in (("stand.ankle_pitch_joints", self.stand.ankle_pitch_joints), ("arm_joints", self.arm_joints),
                          ("hip_joints", self.hip_joints), ("waist_joints", self.waist_joints)):
            unknown = [j for j in joints if j not in r.joint_names]
            if unknown:
                raise ValueError(f"{r.name}: {f} names joints that are not driven: {unknown}")
        feet = len(r.foot_links)
        if self.swing_joints and (len(self.swing_joints) != feet
                                  or any(len(leg) != len(self.swing_profile) for leg in self.swing_joints)
                                  or any(j not in r.joint_names for leg in self.swing_joints for j in leg)):
            raise ValueError(f"{r.name}: swing_joints needs one tuple of driven joints per foot, each as long as "
                             f"swing_profile {self.swing_profile}, got {self.swing_joints}")
        for f in ("lateral_joints", "turn_joints"):
            legs = getattr(self, f)
            if legs and (len(legs) != feet or any(j not in r.joint_names or abs(sign) != 1 for j, sign in legs)):
                raise ValueError(f"{r.name}: {f} needs one (driven joint, +-1) per foot, got {legs}")
        for f in ("base_height_target", "feet_clearance_target", "feet_min_lateral_distance",
                  "contact_force_threshold", "fall_height"):
            if not getattr(self, f) >= 0:
                raise ValueError(f"{r.name}: {f} must be >= 0, got {getattr(self, f)}")

    @property
    def name(self) -> str:
        return self.robot.name

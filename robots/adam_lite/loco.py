"""Adam Lite in the locomotion task: the joint groups its rewards and gait clock read, the scripted stand's gains and
the task's numbers at Adam Lite's size (robots.ROBOTS registers it as "adam_lite"). Every shipped policy trained with
these; their config.json files hold the numbers (tests/robots/test_robots.py checks both agree).
"""

from __future__ import annotations

from robots.adam_lite.config import ADAM_LITE
from robots.loco_robot import LocoRobotConfig, StandConfig

_SIDES = ("Left", "Right")

# The scripted stand emulates stiffer legs than the drives have: hip pitch, knee and ankle pitch 610/6, 610/6, 500/10
# (kp/kd), the gains that held a passive 5 s stand under implicit PD (FACTS.md); every other joint keeps its own.
_STAND = ADAM_LITE.with_gains({"hipPitch": (610.0, 6.0), "kneePitch": (610.0, 6.0), "anklePitch": (500.0, 10.0)})

ADAM_LITE_LOCO = LocoRobotConfig(
    robot=ADAM_LITE,
    base_height_target=0.88,            # the vendor's reward target (the standing pose's pelvis height)
    feet_clearance_target=0.08,
    feet_min_lateral_distance=0.2,
    contact_force_threshold=700.0,      # ~1.2 x body weight (58.5 kg)
    fall_height=0.45,                   # about half the standing pelvis height
    stand=StandConfig(kp=_STAND.kp, kd=_STAND.kd, ankle_pitch_joints=tuple(f"anklePitch_{s}" for s in _SIDES)),
    arm_joints=tuple(f"{j}_{s}" for s in _SIDES for j in ("shoulderPitch", "shoulderRoll", "shoulderYaw", "elbow")),
    hip_joints=("hipRoll_Left", "hipYaw_Left", "hipRoll_Right", "hipYaw_Right"),  # hip pitch must swing to walk
    waist_joints=("waistRoll", "waistPitch", "waistYaw"),
    torso_link="torso",
    # hip -A, knee +2A, ankle -A: the sole rises (9 cm at A = 0.25, pytorch-kinematics) and stays nearly level
    swing_joints=tuple(tuple(f"{j}_{s}" for j in ("hipPitch", "kneePitch", "anklePitch")) for s in _SIDES),
    swing_profile=(-1.0, 2.0, -1.0),
    # both hip roll axes point forward-ish and both hip yaw axes up: on either leg a positive angle moves the sole
    # left and turns its toes left (tests/envs/test_locomotion.py checks it through forward kinematics)
    lateral_joints=(("hipRoll_Left", 1.0), ("hipRoll_Right", 1.0)),
    turn_joints=(("hipYaw_Left", 1.0), ("hipYaw_Right", 1.0)),
)

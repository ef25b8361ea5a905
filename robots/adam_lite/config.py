"""Adam Lite robot config: the 23 driven joints in canonical order, standing pose, PD gains, limits.

Canonical order = the vendor's motor order (URDF order without the wristYaw joints): left leg, right leg,
waist (roll, pitch, yaw), left arm, right arm. Limits come from our description (URDF figures).

PD gains: the vendor's 23-joint real-robot set (pnd_rl_gym lite_run), run as the robot runs them: an explicit PD
tau = clamp(kp (q* - q) - kd qd, +-effort) evaluated at every physics step (cra_warp.sim: MuJoCo's Euler
integrator, no implicit damping), but for the ankles. The vendor's Lite set has ankle pitch 25/2.5 and ankle roll
0/0.35 (roll not driven: the foot rolls freely). We drive both ankle axes with the gains of the vendor's Adam SP
config (pitch 130/3.5, roll 70/2), whose legs have the Lite's kinematics and inertia: in a 2-seed A/B of 100 flat
iterations (N=256) the episodes lasted 93 vs 80 steps (tools/results/ab_ankle.json). The Lite's ankle torque limits
(40 and 12 N m) stay; the deploy JSON carries the gains, which the robot's drives must be set to. A zero action
is still no stand (the CoM is ~3.6 cm ahead of the ankle: FACTS.md); balancing is the policy's job. Tests and the
evaluation floor use a scripted stand instead (cra_warp.stand, its gains in loco.py).

What the locomotion task reads of the robot beyond this (joint groups, stand gains, its numbers at this robot's size)
is in loco.py.

wristYaw joints are in the description (25 revolute joints) but not driven by the policy: the vendor's deploy stack
holds them at 0, so the simulator and the kinematics weld them at 0 (fixed joints). That keeps the 23 driven joints
contiguous in Newton's arrays (zero-copy canonical views), saves two dofs per robot and avoids a stiff PD on the
wrist's tiny yaw inertia (0.0003 kg m^2), which would need a smaller time step.
"""

from __future__ import annotations

from robots.adam_lite.description import JOINT_BY_NAME, SOLE, URDF_PATH
from robots.robot_config import RobotConfig

_LEG = ("hipPitch", "hipRoll", "hipYaw", "kneePitch", "anklePitch", "ankleRoll")
_ARM = ("shoulderPitch", "shoulderRoll", "shoulderYaw", "elbow")
JOINT_NAMES = (
    *(f"{j}_Left" for j in _LEG), *(f"{j}_Right" for j in _LEG),
    "waistRoll", "waistPitch", "waistYaw",
    *(f"{j}_Left" for j in _ARM), *(f"{j}_Right" for j in _ARM),
)

#            hipP   hipR  hipY  knee  ankP   ankR
_LEG_Q_L = (-0.32, 0.0, -0.18, 0.66, -0.39, 0.0)
_LEG_Q_R = (-0.32, 0.0, 0.18, 0.66, -0.39, 0.0)
_LEG_KP = (305.0, 700.0, 405.0, 305.0, 130.0, 70.0)
_LEG_KD = (6.1, 30.0, 6.1, 6.1, 3.5, 2.0)
#            shP   shR   shY   elbow
_ARM_Q_L = (0.0, 0.1, 0.0, -0.3)
_ARM_Q_R = (0.0, -0.1, 0.0, -0.3)
_ARM_KP = (18.0, 9.0, 9.0, 9.0)
_ARM_KD = (0.9, 0.9, 0.9, 0.9)
_WAIST_KP = (405.0, 405.0, 205.0)   # roll, pitch, yaw
_WAIST_KD = (6.1, 6.1, 4.1)

ADAM_LITE = RobotConfig(
    name="adam_lite",
    urdf_path=URDF_PATH,
    base_link="pelvis",
    foot_links=("toeLeft", "toeRight"),
    joint_names=JOINT_NAMES,
    default_q=(*_LEG_Q_L, *_LEG_Q_R, 0.0, 0.0, 0.0, *_ARM_Q_L, *_ARM_Q_R),
    kp=(*_LEG_KP, *_LEG_KP, *_WAIST_KP, *_ARM_KP, *_ARM_KP),
    kd=(*_LEG_KD, *_LEG_KD, *_WAIST_KD, *_ARM_KD, *_ARM_KD),
    effort_limit=tuple(JOINT_BY_NAME[n].effort for n in JOINT_NAMES),
    velocity_limit=tuple(JOINT_BY_NAME[n].velocity for n in JOINT_NAMES),
    pos_lower=tuple(JOINT_BY_NAME[n].limits[0] for n in JOINT_NAMES),
    pos_upper=tuple(JOINT_BY_NAME[n].limits[1] for n in JOINT_NAMES),
    action_scale=0.5,  # the vendor's deploy convention: q* = q_ref + 0.5 a
    base_height=0.88,  # pelvis above the soles at default_q (checked against FK in tests)
    sole_offset=(SOLE.xyz[0], SOLE.xyz[1], SOLE.xyz[2] - SOLE.size[2] / 2),
    sole_half_size=(SOLE.size[0] / 2, SOLE.size[1] / 2),
    fixed_joints=("wristYaw_Left", "wristYaw_Right"),
    # every roll and yaw axis points the same way on both sides (x forward, z up), so mirrored they change sign
    mirror_negated=("hipRoll", "hipYaw", "ankleRoll", "waistRoll", "waistYaw", "shoulderRoll", "shoulderYaw"),
    # Reflected rotor inertia. The vendor files carry none (but 0.001 on ankle pitch); QDD rotors reflect about
    # 0.01 kg m^2 or more through their gears. It also keeps the explicit PD stable at 5 ms on the light foot:
    # ankle pitch kd dt / I = 3.5 x 0.005 / (0.0043 + 0.01) = 1.2 with it, 4.1 without (explicit damping diverges
    # above 2). The deploy JSON carries it.
    armature=0.01,
)

"""Our Adam Lite description, written out as robots/adam_lite/adam_lite.urdf.

Figures (kinematic tree, joint origins and axes, limits, masses, CoMs, inertia tensors) are the published
PNDbotics ones (pnd_mujoco, BSD-3-Clause; see ../shared/reference/adam_lite/NOTES.md). Where the vendor URDF and
MJCF disagree we follow the URDF, for everything: it is the file the vendor's Isaac Gym training (and so the
paper) used, and it carries full inertia tensors. Differences from the vendor files:
- collision geometry is ours: capsules, one sphere and the 0.24 x 0.10 m sole boxes; no meshes, no visuals;
- the 1 g imu_link is dropped (the IMU sits at the pelvis origin);
- the wristYaw joints are `revolute` with +-pi limits instead of `continuous`: they stay in the tree (25
  revolute joints) but are not driven by the policy; the simulator holds them at 0 like the vendor's deploy
  stack does (see config.py).

Regenerate with `python -m robots.adam_lite.description` (tests check the committed file matches).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

URDF_PATH = Path(__file__).with_name("adam_lite.urdf")


@dataclass(frozen=True)
class Shape:
    kind: str                        # "box" | "capsule" | "sphere"
    size: tuple[float, ...]          # box: full extents; capsule: (radius, cylinder length along z); sphere: (radius,)
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Link:
    name: str
    mass: float                                            # [kg]
    com: tuple[float, float, float]                        # [m], link frame
    inertia: tuple[float, float, float, float, float, float]  # ixx ixy ixz iyy iyz izz [kg m^2] about the CoM
    shapes: tuple[Shape, ...] = field(default=())


@dataclass(frozen=True)
class Joint:
    name: str
    parent: str
    xyz: tuple[float, float, float]   # origin in the parent frame
    roll: float                       # origin rotation: every Adam Lite joint frame is rolled about x only
    axis: str                         # "x" | "y" | "z"
    limits: tuple[float, float]       # [rad]
    effort: float                     # [N m]
    velocity: float                   # [rad / s]
    child: Link


# Sole: 0.24 x 0.10 x 0.03 box whose bottom face lies 0.065 m below the ankle axes, front 0.167 m ahead of them.
SOLE = Shape("box", (0.24, 0.10, 0.03), (0.047, 0.0, -0.05))
_ARM = dict(
    roll=Shape("capsule", (0.035, 0.04), (-0.035, 0.0, 0.0), (0.0, math.pi / 2, 0.0)),
    upper=Shape("capsule", (0.03, 0.12), (0.0, 0.0, -0.08)),
    forearm=Shape("capsule", (0.03, 0.26), (0.0, 0.0, -0.15)),
)


def _thigh(side: float) -> Shape:
    return Shape("capsule", (0.06, 0.16), (0.0, -0.01 * side, -0.14), (-0.087 * side, 0.0, 0.0))


SHIN = Shape("capsule", (0.04, 0.22), (0.0, 0.0, -0.2))

ROOT = Link("pelvis", 10.35646604, (-0.00034724, 0.0, -0.00735759),
            (0.06211831, -1.03e-06, -7.613e-05, 0.03451514, 2e-07, 0.06877943),
            (Shape("capsule", (0.1, 0.08), (0.0, 0.0, 0.0), (math.pi / 2, 0.0, 0.0)),))

JOINTS: tuple[Joint, ...] = (
    # left leg
    Joint("hipPitch_Left", "pelvis", (0.0, 0.096192, -0.033241), -0.61087, "y", (-2.164, 2.164), 230.0, 15.0,
          Link("hipPitchLeft", 2.23379987, (-0.0566022, 0.05761439, -0.00077159),
               (0.00362189, -0.00107609, 2.179e-05, 0.00439139, 4.441e-05, 0.00515496))),
    Joint("hipRoll_Left", "hipPitchLeft", (-0.0255, 0.069, 0.0), 0.61087, "x", (-0.733, 1.605), 160.0, 8.0,
          Link("hipRollLeft", 1.35107789, (0.03924162, 4.107e-05, -0.01032916),
               (0.00122242, -4.63e-06, -7.104e-05, 0.00129116, -7.67e-06, 0.00138754))),
    Joint("hipYaw_Left", "hipRollLeft", (0.044, 0.0, -0.0525), 0.0, "z", (-0.785, 0.785), 105.0, 8.0,
          Link("thighLeft", 6.43432838, (0.00244052, -0.00866423, -0.13433631),
               (0.05827182, -0.00024775, -0.00135721, 0.06333936, 0.0055147, 0.01331159), (_thigh(1.0),))),
    Joint("kneePitch_Left", "thighLeft", (0.0, -0.0355, -0.369), 0.0, "y", (0.052, 2.391), 230.0, 15.0,
          Link("shinLeft", 2.25363003, (-0.00053135, 0.00081959, -0.14538124),
               (0.0215135, -1.764e-05, 0.0003226, 0.02158746, 4.329e-05, 0.00136992), (SHIN,))),
    Joint("anklePitch_Left", "shinLeft", (0.0, 0.0, -0.37), 0.0, "y", (-1.0, 0.35), 40.0, 20.0,
          Link("anklePitchLeft", 0.0301423, (0.0, 0.0, 0.0), (3.14e-06, 0.0, 0.0, 3.14e-06, 0.0, 2.04e-06))),
    Joint("ankleRoll_Left", "anklePitchLeft", (0.0, 0.0, 0.0), 0.0, "x", (-0.3491, 0.3491), 12.0, 20.0,
          Link("toeLeft", 0.63479601, (0.03749965, -4.016e-05, -0.04196743),
               (0.00045636, 1.603e-05, -0.00020108, 0.00226894, 1.8e-06, 0.00231317), (SOLE,))),
    # right leg
    Joint("hipPitch_Right", "pelvis", (0.0, -0.096192, -0.033241), 0.61087, "y", (-2.164, 2.164), 230.0, 15.0,
          Link("hipPitchRight", 2.23477271, (-0.05661792, -0.05759336, -0.00078211),
               (0.00362315, 0.00107435, 2.228e-05, 0.00439419, -4.505e-05, 0.00515804))),
    Joint("hipRoll_Right", "hipPitchRight", (-0.0255, -0.069, 0.0), -0.61087, "x", (-1.605, 0.733), 160.0, 8.0,
          Link("hipRollRight", 1.35169943, (0.03925975, -5.814e-05, -0.01032408),
               (0.00122275, 5.01e-06, -7.267e-05, 0.00129208, 8.35e-06, 0.00138861))),
    Joint("hipYaw_Right", "hipRollRight", (0.044, 0.0, -0.0525), 0.0, "z", (-0.785, 0.785), 105.0, 8.0,
          Link("thighRight", 6.43084152, (0.00245598, 0.00865064, -0.13433188),
               (0.05823192, 0.00024481, -0.00134046, 0.06331326, -0.00551858, 0.01331917), (_thigh(-1.0),))),
    Joint("kneePitch_Right", "thighRight", (0.0, 0.0355, -0.369), 0.0, "y", (0.052, 2.391), 230.0, 15.0,
          Link("shinRight", 2.25459286, (-0.00052844, -0.00082152, -0.14533361),
               (0.02149493, 1.649e-05, 0.00032142, 0.02156785, -4.501e-05, 0.00137005), (SHIN,))),
    Joint("anklePitch_Right", "shinRight", (0.0, 0.0, -0.37), 0.0, "y", (-1.0, 0.35), 40.0, 20.0,
          Link("anklePitchRight", 0.0301423, (0.0, 0.0, 0.0), (3.14e-06, 0.0, 0.0, 3.14e-06, 0.0, 2.04e-06))),
    Joint("ankleRoll_Right", "anklePitchRight", (0.0, 0.0, 0.0), 0.0, "x", (-0.3491, 0.3491), 12.0, 20.0,
          Link("toeRight", 0.63480789, (0.03750226, 4.002e-05, -0.04196714),
               (0.00045639, -1.603e-05, -0.00020109, 0.00226894, -1.81e-06, 0.00231317), (SOLE,))),
    # waist and torso
    Joint("waistRoll", "pelvis", (0.0, 0.0, 0.044), 0.0, "x", (-0.226, 0.226), 110.0, 8.0,
          Link("waistRoll", 2.36268465, (0.00093826, 0.00093832, 0.03999995),
               (0.00543041, -1.71e-06, -6.791e-05, 0.00543044, 6.793e-05, 0.00184993))),
    Joint("waistPitch", "waistRoll", (0.0, 0.0, 0.08), 0.0, "y", (-0.785, 1.308), 110.0, 8.0,
          Link("waistPitch", 0.56353776, (-8.401e-05, 0.00189362, 0.02548321),
               (0.0015147, 1.037e-05, 4.44e-06, 0.00067279, -1.192e-05, 0.00155907))),
    Joint("waistYaw", "waistPitch", (0.0, 0.0005, 0.053), 0.0, "z", (-0.78, 0.78), 110.0, 8.0,
          Link("torso", 12.89652496, (0.000143, 0.00050556, 0.1833692),
               (0.19855642, -0.00036714, 0.003319, 0.16612827, -0.00021516, 0.06625123),
               (Shape("sphere", (0.13,), (0.0, 0.0, 0.15)),))),
    # left arm
    Joint("shoulderPitch_Left", "torso", (0.0, 0.16011, 0.25742), 0.34907, "y", (-3.56, 1.989), 65.0, 8.0,
          Link("shoulderPitchLeft", 0.2031, (-0.00150404, 0.02688841, 0.00010848),
               (0.0001702, -4.61e-06, -6.4e-07, 0.00028895, 4.2e-07, 0.00034385))),
    Joint("shoulderRoll_Left", "shoulderPitchLeft", (0.0335, 0.0435, 0.0), -0.34907, "x", (-0.575, 2.74), 65.0, 8.0,
          Link("shoulderRollLeft", 0.7248, (-0.02860447, 0.01104245, -0.01405309),
               (0.00090812, -2.621e-05, 3.997e-05, 0.00071197, -0.00025129, 0.00060954), (_ARM["roll"],))),
    Joint("shoulderYaw_Left", "shoulderRollLeft", (-0.0335, 0.034, -0.0585), 0.0, "z", (-2.53, 2.53), 65.0, 8.0,
          Link("shoulderYawLeft", 0.6963, (-0.00069813, 0.00102049, -0.06842313),
               (0.00317887, 5.9e-07, 5.528e-05, 0.00310433, -9.472e-05, 0.00039452), (_ARM["upper"],))),
    Joint("elbow_Left", "shoulderYawLeft", (0.0, -0.0285, -0.20415), 0.0, "y", (-2.443, 0.174), 30.0, 8.0,
          Link("elbowLeft", 0.854, (-0.02164423, 0.02776208, -0.04469642),
               (0.00072987, -1.38e-05, 0.00015644, 0.0008041, -2.763e-05, 0.00047565))),
    Joint("wristYaw_Left", "elbowLeft", (-0.025, 0.0285, -0.0729), 0.0, "z", (-math.pi, math.pi), 6.4, 4.9218,
          Link("wristYawLeft", 0.7346, (1.826e-05, -0.00013856, -0.15608944),
               (0.00772306, 0.0, 1.98e-06, 0.00772311, 1.414e-05, 0.00029992), (_ARM["forearm"],))),
    # right arm
    Joint("shoulderPitch_Right", "torso", (0.0, -0.16011, 0.25742), -0.34907, "y", (-3.56, 1.989), 65.0, 8.0,
          Link("shoulderPitchRight", 0.2031, (-0.00150404, -0.02687227, 0.00010766),
               (0.00017009, 4.47e-06, -6.4e-07, 0.00028895, -4.3e-07, 0.00034374))),
    Joint("shoulderRoll_Right", "shoulderPitchRight", (0.0335, -0.0435, 0.0), 0.34907, "x", (-2.74, 0.575), 65.0, 8.0,
          Link("shoulderRollRight", 0.7248, (-0.02860454, -0.01104592, -0.01404986),
               (0.00090814, 2.628e-05, 3.99e-05, 0.00071184, 0.00025129, 0.00060969), (_ARM["roll"],))),
    Joint("shoulderYaw_Right", "shoulderRollRight", (-0.0335, -0.034, -0.0585), 0.0, "z", (-2.53, 2.53), 65.0, 8.0,
          Link("shoulderYawRight", 0.6963, (-0.00089274, -0.00096643, -0.06980518),
               (0.00304636, -7e-07, 5.211e-05, 0.00297764, 8.904e-05, 0.00041751), (_ARM["upper"],))),
    Joint("elbow_Right", "shoulderYawRight", (0.0, 0.0285, -0.20415), 0.0, "y", (-2.443, 0.174), 30.0, 8.0,
          Link("elbowRight", 0.854, (-0.01212328, -0.02629569, -0.02658404),
               (0.00099546, 2.241e-05, 0.00027937, 0.00111379, 4.82e-05, 0.00053993))),
    Joint("wristYaw_Right", "elbowRight", (-0.025, -0.0285, -0.0729), 0.0, "z", (-math.pi, math.pi), 6.4, 4.9218,
          Link("wristYawRight", 0.7346, (1.64e-05, 0.00018166, -0.17795217),
               (0.00787989, 0.0, 2.02e-06, 0.00788003, -1.563e-05, 0.00031258), (_ARM["forearm"],))),
)

JOINT_BY_NAME = {j.name: j for j in JOINTS}
TOTAL_MASS = ROOT.mass + sum(j.child.mass for j in JOINTS)
AXES = {"x": "1 0 0", "y": "0 1 0", "z": "0 0 1"}


def _v(t) -> str:
    return " ".join(f"{x:.8g}" for x in t)


def _link_xml(link: Link) -> list[str]:
    ixx, ixy, ixz, iyy, iyz, izz = link.inertia
    out = [f'  <link name="{link.name}">',
           "    <inertial>",
           f'      <origin xyz="{_v(link.com)}" rpy="0 0 0"/>',
           f'      <mass value="{link.mass:.8g}"/>',
           f'      <inertia ixx="{ixx:.8g}" ixy="{ixy:.8g}" ixz="{ixz:.8g}" iyy="{iyy:.8g}" iyz="{iyz:.8g}" izz="{izz:.8g}"/>',
           "    </inertial>"]
    for s in link.shapes:
        if s.kind == "box":
            geom = f'<box size="{_v(s.size)}"/>'
        elif s.kind == "capsule":  # Newton reads `height`, other parsers `length`: write both
            geom = f'<capsule radius="{s.size[0]:.8g}" length="{s.size[1]:.8g}" height="{s.size[1]:.8g}"/>'
        else:
            geom = f'<sphere radius="{s.size[0]:.8g}"/>'
        out += ["    <collision>", f'      <origin xyz="{_v(s.xyz)}" rpy="{_v(s.rpy)}"/>',
                f"      <geometry>{geom}</geometry>", "    </collision>"]
    return out + ["  </link>"]


def urdf_text() -> str:
    """The URDF of the description above (25 revolute joints, primitive collision shapes, no visuals)."""
    lines = ['<?xml version="1.0"?>',
             "<!-- Generated by robots/adam_lite/description.py from PNDbotics' published figures; do not edit. -->",
             '<robot name="adam_lite">', *_link_xml(ROOT)]
    for j in JOINTS:
        lines += [f'  <joint name="{j.name}" type="revolute">',
                  f'    <origin xyz="{_v(j.xyz)}" rpy="{j.roll:.8g} 0 0"/>',
                  f'    <parent link="{j.parent}"/>', f'    <child link="{j.child.name}"/>',
                  f'    <axis xyz="{AXES[j.axis]}"/>',
                  f'    <limit lower="{j.limits[0]:.8g}" upper="{j.limits[1]:.8g}" effort="{j.effort:.8g}" velocity="{j.velocity:.8g}"/>',
                  "  </joint>", *_link_xml(j.child)]
    return "\n".join(lines + ["</robot>", ""])


if __name__ == "__main__":
    URDF_PATH.write_text(urdf_text())
    print(f"wrote {URDF_PATH} ({len(JOINTS)} joints, {TOTAL_MASS:.3f} kg)")

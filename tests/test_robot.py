"""The Adam Lite description and config against the published figures."""

import xml.etree.ElementTree as ET

import pytest

from conftest import REFERENCE, need_shared
from robots.adam_lite import ADAM_LITE
from robots.adam_lite.description import JOINTS, TOTAL_MASS, URDF_PATH, urdf_text


def test_committed_urdf_matches_description():
    assert URDF_PATH.read_text() == urdf_text(), "run `python -m robots.adam_lite.description` to regenerate"


def test_mass_matches_reference_total():
    ref = ET.parse(need_shared(REFERENCE / "pnd_mujoco/pnd_robots/adam_lite/adam_lite.urdf")).getroot()
    ref_total = sum(float(l.find("inertial/mass").get("value")) for l in ref.findall("link"))
    assert abs(TOTAL_MASS - ref_total) / ref_total < 0.01
    ours = ET.fromstring(urdf_text())
    assert abs(sum(float(m.get("value")) for m in ours.iter("mass")) - ref_total) / ref_total < 0.01


def test_joint_tree_matches_reference():
    ref = ET.parse(need_shared(REFERENCE / "pnd_mujoco/pnd_robots/adam_lite/adam_lite.urdf")).getroot()
    ref_joints = {j.get("name"): j for j in ref.findall("joint") if j.get("type") != "fixed"}
    assert len(JOINTS) == 25 == len(ref_joints)
    for j in JOINTS:
        r = ref_joints[j.name]
        assert r.find("parent").get("link") == j.parent and r.find("child").get("link") == j.child.name
        assert [float(x) for x in r.find("origin").get("xyz").split()] == list(j.xyz)


def test_driven_joints_are_23_in_canonical_order():
    r = ADAM_LITE
    assert r.num_joints == 23
    assert set(r.fixed_joints) == {"wristYaw_Left", "wristYaw_Right"}
    urdf_order = [j.name for j in JOINTS if j.name not in r.fixed_joints]
    assert list(r.joint_names) == urdf_order  # the vendor's motor order = URDF order without the wrists
    assert r.joint_names[:6] == ("hipPitch_Left", "hipRoll_Left", "hipYaw_Left", "kneePitch_Left",
                                 "anklePitch_Left", "ankleRoll_Left")
    for lo, q, hi in zip(r.pos_lower, r.default_q, r.pos_upper):
        assert lo < q < hi


def test_with_gains_sets_both_sides_and_names_unknown_joints():
    stiff = ADAM_LITE.with_gains({"ankleRoll": (40.0, 1.0), "kneePitch_Left": (400.0, 8.0)})
    for side in ("Left", "Right"):
        i = ADAM_LITE.joint_names.index(f"ankleRoll_{side}")
        assert (stiff.kp[i], stiff.kd[i]) == (40.0, 1.0) != (ADAM_LITE.kp[i], ADAM_LITE.kd[i])
    left, right = (ADAM_LITE.joint_names.index(f"kneePitch_{s}") for s in ("Left", "Right"))
    assert (stiff.kp[left], stiff.kp[right]) == (400.0, ADAM_LITE.kp[right])
    with pytest.raises(ValueError, match="'ankle' names no driven joint"):
        ADAM_LITE.with_gains({"ankle": (1.0, 1.0)})


def test_mirror_map_is_the_robots_left_right_symmetry():
    """Joint angles mirrored by RobotConfig.mirror_joints put every link where the mirror image (y -> -y) of the
    original pose has it, position and orientation, for random poses: the map is the robot's own symmetry."""
    import torch

    from cra_warp.kinematics import Kinematics

    kin = Kinematics(ADAM_LITE)
    index, sign = ADAM_LITE.mirror_joints()
    links = kin.chain.get_frame_names()
    other = [links.index(n.replace("Left", "#").replace("Right", "Left").replace("#", "Right")) for n in links]
    g = torch.Generator().manual_seed(0)
    q = 0.6 * (2 * torch.rand(16, ADAM_LITE.num_joints, generator=g) - 1)
    q_mirror = q[:, index] * torch.tensor(sign)
    base, quat = torch.zeros(16, 3), torch.tensor([[0.0, 0.0, 0.0, 1.0]]).expand(16, 4)
    pos, rot = kin.link_frames(base, quat, q, links)
    pos_m, rot_m = kin.link_frames(base, quat, q_mirror, links)
    M = torch.diag(torch.tensor([1.0, -1.0, 1.0]))
    assert torch.allclose(pos_m[:, other], pos @ M, atol=2e-3)
    assert torch.allclose(rot_m[:, other], M @ rot @ M, atol=1e-3)
    # and a wrong sign is caught: ankle roll kept instead of negated
    bad = list(sign)
    bad[ADAM_LITE.joint_names.index("ankleRoll_Left")] = 1.0
    _, rot_bad = kin.link_frames(base, quat, q[:, index] * torch.tensor(bad), links)
    assert not torch.allclose(rot_bad[:, other], M @ rot @ M, atol=1e-3)

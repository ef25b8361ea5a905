"""The Adam Lite description and config against the published figures."""

import xml.etree.ElementTree as ET

from tests.conftest import REFERENCE, need_shared
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

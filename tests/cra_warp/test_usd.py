"""URDF -> USD converter (cra_warp.usd; its command line, cra-urdf2usd: tests/tools/test_urdf2usd.py).

Round trip through Newton: add_usd(converted) must build the same robot as add_urdf(original): bodies, masses,
inertias, joint axes and limits, FK at random joint positions, and (from the robot config) drive gains.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.conftest import OUR_URDF, REFERENCE, need_shared

import newton
import warp as wp
from pxr import Usd, UsdPhysics

from cra_warp.usd import ConversionError, convert, parse_urdf
from robots.adam_lite.config import ADAM_LITE

VENDOR_URDF = REFERENCE / "pnd_mujoco" / "pnd_robots" / "adam_lite" / "adam_lite.urdf"

# A small robot exercising what Adam Lite does not: tilted and negative axes, continuous, prismatic and fixed
# joints, an inertial frame with rpy, box and cylinder shapes.
TOY_URDF = """<?xml version="1.0"?>
<robot name="toy">
  <link name="base">
    <inertial><origin xyz="0.01 0 0.02" rpy="0.3 -0.2 0.5"/><mass value="3"/>
      <inertia ixx="0.03" ixy="0.002" ixz="-0.001" iyy="0.02" iyz="0.003" izz="0.025"/></inertial>
    <collision><origin xyz="0 0 0.1" rpy="0.1 0.2 0.3"/><geometry><box size="0.3 0.2 0.1"/></geometry></collision>
  </link>
  <joint name="tilted" type="revolute"><origin xyz="0.1 0.2 0.3" rpy="0.4 0.5 0.6"/>
    <parent link="base"/><child link="a"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-1.2" upper="0.7" effort="50" velocity="3"/></joint>
  <link name="a">
    <inertial><origin xyz="0 0.05 0" rpy="1.0 0 0"/><mass value="1.5"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.012" iyz="0" izz="0.005"/></inertial>
    <collision><origin xyz="0 0 -0.1" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="0.03" length="0.2"/></geometry></collision>
  </link>
  <joint name="minus_x" type="continuous"><origin xyz="0 0 -0.2" rpy="0 0 0"/>
    <parent link="a"/><child link="b"/><axis xyz="-1 0 0"/></joint>
  <link name="b">
    <inertial><mass value="0.7"/><inertia ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.004"/></inertial>
  </link>
  <joint name="slide" type="prismatic"><origin xyz="0.05 0 0" rpy="0 0.3 0"/>
    <parent link="b"/><child link="c"/><axis xyz="0 0 -1"/>
    <limit lower="-0.1" upper="0.2" effort="100" velocity="1"/></joint>
  <link name="c">
    <inertial><mass value="0.4"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
  </link>
  <joint name="weld" type="fixed"><origin xyz="0 0.1 0" rpy="0 0 1.0"/><parent link="c"/><child link="d"/></joint>
  <link name="d">
    <inertial><mass value="0.2"/><inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.0006" iyz="0" izz="0.0007"/></inertial>
  </link>
</robot>
"""


def _load_physics(path: Path) -> dict:
    """UsdPhysics' own parse of a stage (a cheap validator): {object type: (paths, descriptors)}."""
    stage = Usd.Stage.Open(str(path))
    # usd-core 26 renamed LoadUsdPhysicsFromRange (still there, deprecated)
    load = getattr(UsdPhysics, "UsdPhysicsLoadStageFromPrimRange", None) or UsdPhysics.LoadUsdPhysicsFromRange
    return load(stage, ["/"])


def _name(label: str) -> str:
    return label.rsplit("/", 1)[-1]


def _rot(q_xyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = q_xyzw
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _finalize(load) -> newton.Model:
    b = newton.ModelBuilder()
    load(b)
    return b.finalize(device="cpu")


def _pair(urdf: Path, usd: Path) -> tuple[newton.Model, newton.Model]:
    """(from URDF, from the converted USD), both floating."""
    return (_finalize(lambda b: b.add_urdf(str(urdf), floating=True)),
            _finalize(lambda b: b.add_usd(str(usd))))


def _fk(model: newton.Model, q_by_name: dict[str, float], base: np.ndarray) -> dict[str, np.ndarray]:
    """Body poses (name -> 7: p, q xyzw) at the given joint positions and base pose."""
    q = model.joint_q.numpy().copy()
    starts, types = model.joint_q_start.numpy(), model.joint_type.numpy()
    for i, label in enumerate(model.joint_label):
        if types[i] == newton.JointType.FREE:
            q[starts[i]:starts[i] + 7] = base
        elif _name(label) in q_by_name:
            q[starts[i]] = q_by_name[_name(label)]
    state = model.state()
    newton.eval_fk(model, wp.array(q, dtype=wp.float32, device="cpu"), model.joint_qd, state)
    return {_name(n): p for n, p in zip(model.body_label, state.body_q.numpy(), strict=True)}


def _dofs(model: newton.Model) -> dict[str, int]:
    """Joint name -> its (first) dof index, for the 1-dof joints."""
    starts, types = model.joint_qd_start.numpy(), model.joint_type.numpy()
    one_dof = (newton.JointType.REVOLUTE, newton.JointType.PRISMATIC)
    return {_name(n): int(starts[i]) for i, n in enumerate(model.joint_label) if types[i] in one_dof}


def _world_axes(model: newton.Model) -> dict[str, np.ndarray]:
    """Joint name -> joint axis in the world frame at q = 0 (base at the origin)."""
    body_q = _fk(model, {}, np.array([0, 0, 0, 0, 0, 0, 1.0]))
    names = [_name(n) for n in model.body_label]
    X_p, axis, parent = model.joint_X_p.numpy(), model.joint_axis.numpy(), model.joint_parent.numpy()
    out = {}
    for name, dof in _dofs(model).items():
        j = [_name(n) for n in model.joint_label].index(name)
        R_parent = _rot(body_q[names[parent[j]]][3:]) if parent[j] >= 0 else np.eye(3)
        out[name] = R_parent @ _rot(X_p[j][3:]) @ axis[dof]
    return out


def _check_round_trip(urdf: Path, m_urdf: newton.Model, m_usd: newton.Model, seed: int = 0) -> None:
    """Same bodies, masses, inertias, joint axes, limits and FK (the checks shared by our URDF and the vendor's)."""
    names_f = [_name(n) for n in m_urdf.body_label]
    names_u = [_name(n) for n in m_usd.body_label]
    assert sorted(names_u) == sorted(names_f)
    mass_f = dict(zip(names_f, m_urdf.body_mass.numpy(), strict=True))
    mass_u = dict(zip(names_u, m_usd.body_mass.numpy(), strict=True))
    com_f = dict(zip(names_f, m_urdf.body_com.numpy(), strict=True))
    com_u = dict(zip(names_u, m_usd.body_com.numpy(), strict=True))
    I_f = dict(zip(names_f, m_urdf.body_inertia.numpy(), strict=True))
    I_u = dict(zip(names_u, m_usd.body_inertia.numpy(), strict=True))
    for n in names_f:
        assert mass_u[n] == pytest.approx(mass_f[n], rel=1e-6), n
        np.testing.assert_allclose(com_u[n], com_f[n], atol=1e-7, err_msg=n)
        # Both are about the CoM in the link frame (the USD body frame is the URDF link frame). The USD side went
        # through float32 principal values + a float32 quaternion: allow 2e-6 of the tensor's largest entry.
        np.testing.assert_allclose(I_u[n], I_f[n], rtol=0, atol=2e-6 * np.abs(I_f[n]).max(), err_msg=n)

    dof_f, dof_u = _dofs(m_urdf), _dofs(m_usd)
    assert dof_u.keys() == dof_f.keys()
    ax_f, ax_u = _world_axes(m_urdf), _world_axes(m_usd)
    lo_f, hi_f = m_urdf.joint_limit_lower.numpy(), m_urdf.joint_limit_upper.numpy()
    lo_u, hi_u = m_usd.joint_limit_lower.numpy(), m_usd.joint_limit_upper.numpy()
    joints = {j.name: j for j in parse_urdf(urdf).joints}
    for n in dof_f:
        np.testing.assert_allclose(ax_u[n], ax_f[n], atol=1e-6, err_msg=n)
        if joints[n].lower is not None:  # continuous joints: no limit in USD, Newton's own default from URDF
            assert lo_u[dof_u[n]] == pytest.approx(lo_f[dof_f[n]], abs=1e-5), n
            assert hi_u[dof_u[n]] == pytest.approx(hi_f[dof_f[n]], abs=1e-5), n
            assert lo_u[dof_u[n]] == pytest.approx(joints[n].lower, abs=1e-5), n
        else:
            assert lo_u[dof_u[n]] < -1e3 and hi_u[dof_u[n]] > 1e3, n
        vel_u, vel_f = m_usd.joint_velocity_limit.numpy()[dof_u[n]], m_urdf.joint_velocity_limit.numpy()[dof_f[n]]
        assert vel_u == pytest.approx(vel_f, rel=1e-6), n

    rng = np.random.default_rng(seed)
    for _ in range(4):
        q = {}
        for n in dof_f:
            lo, hi = (joints[n].lower, joints[n].upper) if joints[n].lower is not None else (-np.pi, np.pi)
            q[n] = rng.uniform(lo, hi)
        quat = rng.normal(size=4)
        base = np.concatenate([rng.uniform(-1, 1, 3), quat / np.linalg.norm(quat)])
        fk_f, fk_u = _fk(m_urdf, q, base), _fk(m_usd, q, base)
        for n in names_f:
            np.testing.assert_allclose(fk_u[n][:3], fk_f[n][:3], atol=1e-5, err_msg=n)
            np.testing.assert_allclose(_rot(fk_u[n][3:]), _rot(fk_f[n][3:]), atol=1e-5, err_msg=n)


# ---------------------------------------------------------------- our Adam Lite


@pytest.fixture(scope="module")
def ours(tmp_path_factory):
    out = tmp_path_factory.mktemp("usd") / "adam_lite.usda"
    counts = convert(OUR_URDF, out, ADAM_LITE)
    return out, counts


@pytest.fixture(scope="module")
def our_models(ours):
    return _pair(OUR_URDF, ours[0])


def test_counts(ours):
    _, c = ours
    assert (c.links, c.joints, c.drives, c.shapes, c.skipped_meshes) == (26, 25, 23, 14, 0)


def test_usdphysics_parses_the_stage(ours):
    found = _load_physics(ours[0])
    count = {t: len(found[t][0]) for t in found}
    assert count[UsdPhysics.ObjectType.RevoluteJoint] == 25
    assert count[UsdPhysics.ObjectType.Articulation] == 1
    assert count[UsdPhysics.ObjectType.RigidBody] == 26
    assert UsdPhysics.ObjectType.FixedJoint not in count  # floating base: the root body has no joint to the world
    # every revolute joint is valid and limited; drives only on the 23 config joints
    descs = found[UsdPhysics.ObjectType.RevoluteJoint][1]
    assert all(d.isValid and d.limit.enabled for d in descs)
    assert sum(d.drive.enabled for d in descs) == 23


def test_round_trip_through_newton(our_models):
    _check_round_trip(OUR_URDF, *our_models)


def test_shapes_match(our_models):
    """Same primitive collision shapes (type, size, pose in the body frame) on every body."""
    def shapes(m):
        names = [_name(n) for n in m.body_label]
        rows = zip(m.shape_body.numpy(), m.shape_type.numpy(), m.shape_scale.numpy(), m.shape_transform.numpy(),
                   strict=True)
        return sorted((names[b], int(t), tuple(np.round(s, 6)), tuple(np.round(x[:3], 6)), _rot(x[3:]))
                      for b, t, s, x in rows)
    a, b = shapes(our_models[0]), shapes(our_models[1])
    assert len(a) == len(b) == 14
    for sa, sb in zip(a, b, strict=True):
        assert sa[:4] == sb[:4]
        np.testing.assert_allclose(sa[4], sb[4], atol=1e-6)


def test_drive_gains_read_back(our_models):
    """Newton's USD importer divides per-degree gains by pi/180: it must read back the config's per-radian kp/kd."""
    m = our_models[1]
    dof = _dofs(m)
    ke, kd = m.joint_target_ke.numpy(), m.joint_target_kd.numpy()
    mode, eff, arm = m.joint_target_mode.numpy(), m.joint_effort_limit.numpy(), m.joint_armature.numpy()
    target = m.joint_target_q.numpy()
    q_start = {_name(n): int(s) for n, s in zip(m.joint_label, m.joint_target_q_start.numpy(), strict=False)}
    for k, n in enumerate(ADAM_LITE.joint_names):
        d = dof[n]
        assert ke[d] == pytest.approx(ADAM_LITE.kp[k], rel=1e-6), n
        assert kd[d] == pytest.approx(ADAM_LITE.kd[k], rel=1e-6), n
        assert target[q_start[n]] == pytest.approx(ADAM_LITE.default_q[k], abs=1e-6), n
        assert eff[d] == pytest.approx(ADAM_LITE.effort_limit[k]), n
        assert arm[d] == pytest.approx(ADAM_LITE.armature), n
        # a drive without stiffness (ankle roll: kp 0) is a damper: Newton reads it back as a velocity drive
        want = newton.JointTargetMode.POSITION if ADAM_LITE.kp[k] > 0 else newton.JointTargetMode.VELOCITY
        assert mode[d] == want, n
    for n in ADAM_LITE.fixed_joints:  # in the stage as revolute joints, but undriven
        assert ke[dof[n]] == 0.0 and kd[dof[n]] == 0.0 and mode[dof[n]] == newton.JointTargetMode.NONE


def test_no_config_no_drives(tmp_path):
    out = tmp_path / "bare.usda"
    assert convert(OUR_URDF, out).drives == 0
    found = _load_physics(out)
    assert not any(d.drive.enabled for d in found[UsdPhysics.ObjectType.RevoluteJoint][1])


# ---------------------------------------------------------------- other URDFs


def test_toy_robot_axes_and_joint_types(tmp_path):
    urdf, out = tmp_path / "toy.urdf", tmp_path / "toy.usda"
    urdf.write_text(TOY_URDF)
    c = convert(urdf, out)
    assert (c.links, c.joints, c.drives, c.shapes) == (5, 4, 0, 2)
    found = _load_physics(out)
    assert [len(found[t][0]) for t in (UsdPhysics.ObjectType.RevoluteJoint, UsdPhysics.ObjectType.PrismaticJoint,
                                       UsdPhysics.ObjectType.FixedJoint)] == [2, 1, 1]
    _check_round_trip(urdf, *_pair(urdf, out), seed=1)


@pytest.mark.filterwarnings("ignore:Asset file .* does not exist")  # Newton's add_urdf on the absent vendor meshes
def test_vendor_urdf_without_meshes(tmp_path):
    urdf = need_shared(VENDOR_URDF)
    out = tmp_path / "vendor.usda"
    warnings: list[str] = []
    c = convert(urdf, out, warn=warnings.append)
    # the only collision meshes are the two feet; their files are absent: one line per file
    assert len(warnings) == 2 and all("not found" in w and "\n" not in w for w in warnings)
    xml_links, xml_joints = urdf.read_text().count("<link "), urdf.read_text().count("<joint ")
    assert (c.links, c.joints, c.skipped_meshes) == (xml_links, xml_joints, 2)
    found = _load_physics(out)
    assert len(found[UsdPhysics.ObjectType.RigidBody][0]) == xml_links
    assert len(found[UsdPhysics.ObjectType.RevoluteJoint][0]) == 25  # incl. the two continuous wristYaw joints
    assert len(found[UsdPhysics.ObjectType.FixedJoint][0]) == 1      # imu_joint
    _check_round_trip(urdf, *_pair(urdf, out), seed=2)




def test_library_errors_are_conversion_errors(tmp_path):
    urdf = tmp_path / "cycle.urdf"
    urdf.write_text("<robot name='x'><link name='a'/><link name='b'/>"
                    "<joint name='j1' type='fixed'><parent link='a'/><child link='b'/></joint>"
                    "<joint name='j2' type='fixed'><parent link='b'/><child link='a'/></joint></robot>")
    with pytest.raises(ConversionError, match="root link"):
        parse_urdf(urdf)

"""URDF -> USD converter written on usd-core's UsdPhysics (no Isaac/urdf-usd-converter code).

Layout of the stage (Z up, metres, kilograms):
    /<robot>                Xform, UsdPhysics.ArticulationRootAPI (default prim)
    /<robot>/<link>         one Xform per link at its world pose at q = 0, RigidBodyAPI + MassAPI
    /<robot>/<link>/collision_<i>   primitive collision shapes (CollisionAPI), posed in the link frame
    /<robot>/joints/<joint> RevoluteJoint / PrismaticJoint / FixedJoint, DriveAPI from a RobotConfig
    /physicsScene           gravity -Z 9.81
The hierarchy is flat (links are siblings): UsdPhysics reads every rigid body's world pose, so nesting would add
nothing but an ambiguity about which body a shape belongs to. Visuals are not written (collision geometry only).

Quaternions: math here uses numpy 3x3 rotation matrices; USD gets Gf.Quatd/Quatf, built as (real, imag) = (w, x, y, z).
Units as UsdPhysics wants them: revolute limits, drive targets and velocity limits in DEGREES, angular drive
stiffness/damping per DEGREE (N m / deg): a gain in N m / rad is multiplied by pi / 180.
"""

from __future__ import annotations

import math
import re
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdPhysics

try:  # registers Newton's USD schemas (NewtonJointAPI) with usd-core's plugin registry
    import newton_usd_schemas  # noqa: F401

    HAVE_NEWTON_SCHEMAS = True
except ImportError:
    HAVE_NEWTON_SCHEMAS = False

RAD2DEG = 180.0 / math.pi
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")


class ConversionError(ValueError):
    """The URDF cannot be converted (malformed, inconsistent or unsupported). The message is one line."""


# ---------------------------------------------------------------- URDF model


@dataclass
class Collision:
    kind: str                   # "box" | "sphere" | "cylinder" | "capsule" | "mesh"
    params: dict[str, object]   # box: size (3,); sphere: radius; cylinder: radius, length; capsule: radius, length
    pose: np.ndarray            # 4x4, shape frame in the link frame


@dataclass
class Inertial:
    mass: float
    com: np.ndarray             # (3,) in the link frame
    inertia: np.ndarray         # 3x3 about the CoM, in the LINK frame (the inertial origin rpy already applied)


@dataclass
class Link:
    name: str
    inertial: Inertial | None
    collisions: list[Collision] = field(default_factory=list)


@dataclass
class Joint:
    name: str
    type: str                   # one of JOINT_TYPES
    parent: str
    child: str
    origin: np.ndarray          # 4x4, child link frame in the parent link frame at q = 0
    axis: np.ndarray            # (3,) unit, in the child (= joint) frame
    lower: float | None         # [rad] or [m]; None: unlimited
    upper: float | None
    effort: float | None        # [N m] or [N]
    velocity: float | None      # [rad/s] or [m/s]


@dataclass
class Urdf:
    name: str
    path: Path
    links: dict[str, Link]      # in file order
    joints: list[Joint]         # in file order
    root: str                   # the floating base link


def _floats(text: str | None, n: int, default: float, what: str) -> np.ndarray:
    if text is None:
        return np.full(n, default)
    try:
        v = np.array([float(x) for x in text.split()])
    except ValueError:
        raise ConversionError(f"{what}: {text!r} is not {n} numbers") from None
    if v.shape != (n,):
        raise ConversionError(f"{what}: {text!r} is not {n} numbers")
    return v


def _float(el: ET.Element, attr: str, what: str, default: float | None = None) -> float | None:
    text = el.get(attr)
    if text is None:
        return default
    try:
        return float(text)
    except ValueError:
        raise ConversionError(f"{what}: {attr}={text!r} is not a number") from None


def rpy_matrix(rpy) -> np.ndarray:
    """URDF rpy: fixed-axis roll about x, then pitch about y, then yaw about z, i.e. R = Rz(y) Ry(p) Rx(r)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _origin(el: ET.Element, what: str) -> np.ndarray:
    """4x4 pose of an <origin> child of el (identity when absent)."""
    o = el.find("origin")
    T = np.eye(4)
    if o is not None:
        T[:3, :3] = rpy_matrix(_floats(o.get("rpy"), 3, 0.0, f"{what} origin rpy"))
        T[:3, 3] = _floats(o.get("xyz"), 3, 0.0, f"{what} origin xyz")
    return T


def _collision(el: ET.Element, what: str) -> Collision | None:
    geom = el.find("geometry")
    g = geom[0] if geom is not None and len(geom) else None
    if g is None:
        raise ConversionError(f"{what}: <collision> without geometry")
    pose = _origin(el, what)
    if g.tag == "box":
        return Collision("box", {"size": _floats(g.get("size"), 3, 0.0, f"{what} box size")}, pose)
    if g.tag == "sphere":
        return Collision("sphere", {"radius": _float(g, "radius", what, 0.0)}, pose)
    if g.tag in ("cylinder", "capsule"):
        length, height = _float(g, "length", what), _float(g, "height", what)
        if length is not None and height is not None and abs(length - height) > 1e-12:
            raise ConversionError(f"{what}: {g.tag} length={length} and height={height} disagree")
        length = length if length is not None else height
        if length is None:
            raise ConversionError(f"{what}: {g.tag} without length")
        return Collision(g.tag, {"radius": _float(g, "radius", what, 0.0), "length": length}, pose)
    if g.tag == "mesh":
        scale = _floats(g.get("scale"), 3, 1.0, f"{what} mesh scale")
        return Collision("mesh", {"filename": g.get("filename", ""), "scale": scale}, pose)
    raise ConversionError(f"{what}: unknown geometry <{g.tag}>")


def _inertial(el: ET.Element | None, what: str) -> Inertial | None:
    if el is None:
        return None  # URDF: no <inertial> = massless link; USD leaves mass unauthored (see write_stage)
    m = el.find("mass")
    mass = _float(m, "value", what, 0.0) if m is not None else 0.0
    T = _origin(el, what)
    i = el.find("inertia")
    I = np.zeros((3, 3))
    if i is not None:
        ixx, ixy, ixz, iyy, iyz, izz = (_float(i, k, what, 0.0) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
        I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    R = T[:3, :3]
    return Inertial(mass, T[:3, 3].copy(), R @ I @ R.T)  # tensor rotated from the inertial frame into the link frame


def _joint(el: ET.Element) -> Joint:
    name = el.get("name") or "<unnamed>"
    what = f"joint {name}"
    jtype = el.get("type")
    if jtype not in JOINT_TYPES:
        raise ConversionError(f"{what}: unsupported joint type {jtype!r} (supported: {', '.join(JOINT_TYPES)})")
    parent, child = el.find("parent"), el.find("child")
    if parent is None or child is None or not parent.get("link") or not child.get("link"):
        raise ConversionError(f"{what}: needs <parent link=...> and <child link=...>")
    axis_el = el.find("axis")
    axis = _floats(axis_el.get("xyz", "1 0 0") if axis_el is not None else "1 0 0", 3, 0.0, f"{what} axis")
    if jtype != "fixed":
        n = np.linalg.norm(axis)
        if n < 1e-9:
            raise ConversionError(f"{what}: zero axis")
        axis = axis / n
    lim = el.find("limit")
    lower = upper = effort = velocity = None
    if lim is not None:
        effort, velocity = _float(lim, "effort", what), _float(lim, "velocity", what)
        if jtype in ("revolute", "prismatic"):
            lower, upper = _float(lim, "lower", what, 0.0), _float(lim, "upper", what, 0.0)
    return Joint(name, jtype, parent.get("link"), child.get("link"), _origin(el, what), axis,
                 lower, upper, effort, velocity)


def parse_urdf(path: str | Path) -> Urdf:
    """Read a URDF. Raises OSError (unreadable), ET.ParseError (malformed XML) or ConversionError."""
    path = Path(path)
    root = ET.parse(path).getroot()
    if root.tag != "robot":
        raise ConversionError(f"root element is <{root.tag}>, not <robot>")
    links: dict[str, Link] = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise ConversionError("a <link> has no name")
        if name in links:
            raise ConversionError(f"link {name} is defined twice")
        what = f"link {name}"
        links[name] = Link(name, _inertial(el.find("inertial"), what),
                           [_collision(c, what) for c in el.findall("collision")])
    if not links:
        raise ConversionError("no <link> elements")
    joints = [_joint(el) for el in root.findall("joint")]
    children: dict[str, str] = {}
    for j in joints:
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in links:
                raise ConversionError(f"joint {j.name}: {role} link {link!r} does not exist")
        if j.child in children:
            raise ConversionError(f"link {j.child} is the child of two joints ({children[j.child]}, {j.name})")
        children[j.child] = j.name
    roots = [n for n in links if n not in children]
    if len(roots) != 1:
        raise ConversionError(f"expected one root link, found {len(roots)}: {', '.join(roots) or 'a cycle'}")
    urdf = Urdf(root.get("name") or path.stem, path, links, joints, roots[0])
    if len(world_poses(urdf)) != len(links):
        raise ConversionError("the joints form a cycle: some links are not reachable from the root")
    return urdf


def world_poses(urdf: Urdf) -> dict[str, np.ndarray]:
    """4x4 world pose of every link at q = 0 with the root link at the origin."""
    poses = {urdf.root: np.eye(4)}
    by_parent: dict[str, list[Joint]] = {}
    for j in urdf.joints:
        by_parent.setdefault(j.parent, []).append(j)
    stack = [urdf.root]
    while stack:
        p = stack.pop()
        for j in by_parent.get(p, []):
            poses[j.child] = poses[p] @ j.origin
            stack.append(j.child)
    return poses


# ---------------------------------------------------------------- math helpers


def quat_wxyz(R: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method, numerically safe)."""
    m = R
    t = np.trace(m)
    if t > 0.0:
        s = 2.0 * math.sqrt(1.0 + t)
        q = (0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = ((m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s)
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s)
    q = np.array(q) / np.linalg.norm(q)
    return tuple(float(x) for x in (q if q[0] >= 0 else -q))


def rotation_x_to(axis: np.ndarray) -> np.ndarray:
    """A rotation taking +X to the unit vector `axis` (UsdPhysics joints only turn about X, Y or Z)."""
    x = np.array([1.0, 0.0, 0.0])
    c = float(np.dot(x, axis))
    if c < -1.0 + 1e-12:
        return np.diag([-1.0, -1.0, 1.0])  # axis = -X: half turn about Z
    v = np.cross(x, axis)
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1.0 + c)  # Rodrigues with sin = |v|, cos = c


def principal_inertia(I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigen-decomposition I = R diag(d) R^T with R a proper rotation (det +1), as MassAPI stores it."""
    d, R = np.linalg.eigh(0.5 * (I + I.T))
    if np.linalg.det(R) < 0:
        R[:, 2] *= -1.0
    return d, R


def _axis_frame(axis: np.ndarray) -> tuple[str, np.ndarray]:
    """USD axis token and the rotation to put into both joint frames so that token's axis is the URDF axis.
    +X/+Y/+Z map to themselves (readable USD); any other direction is rotated onto X."""
    for token, unit in (("X", (1, 0, 0)), ("Y", (0, 1, 0)), ("Z", (0, 0, 1))):
        if np.allclose(axis, unit, atol=1e-12):
            return token, np.eye(3)
    return "X", rotation_x_to(axis)


def _quatf(R: np.ndarray) -> Gf.Quatf:
    w, x, y, z = quat_wxyz(R)
    return Gf.Quatf(w, x, y, z)


def _set_pose(prim: Usd.Prim, T: np.ndarray, scale=None) -> None:
    """translate + orient (+ scale) xformOps in double precision (joint chains add up float rounding)."""
    xf = UsdGeom.Xformable(prim)
    xf.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*T[:3, 3].tolist()))
    xf.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(*quat_wxyz(T[:3, :3])))
    if scale is not None:
        xf.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*[float(s) for s in scale]))


class _Names:
    """Valid, unique USD prim names among siblings (URDF names may hold '-', '.', or start with a digit)."""

    def __init__(self, taken=()):
        self.taken = set(taken)

    def __call__(self, name: str) -> str:
        base = Tf.MakeValidIdentifier(name)
        out, i = base, 1
        while out in self.taken:
            out, i = f"{base}_{i}", i + 1
        self.taken.add(out)
        return out


# ---------------------------------------------------------------- USD writer


@dataclass
class Counts:
    links: int = 0
    joints: int = 0
    drives: int = 0
    shapes: int = 0
    skipped_meshes: int = 0

    def __str__(self) -> str:
        s = f"{self.links} links, {self.joints} joints, {self.drives} drives, {self.shapes} shapes"
        return s + (f" ({self.skipped_meshes} mesh shapes skipped)" if self.skipped_meshes else "")


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr)


def _resolve_mesh(urdf: Urdf, filename: str) -> Path:
    """Mesh path: relative to the URDF's folder; package://pkg/rest is looked up as rest beside the URDF."""
    if filename.startswith("package://"):
        filename = filename[len("package://"):].partition("/")[2]
    elif filename.startswith("file://"):
        filename = filename[len("file://"):]
    p = Path(filename)
    return p if p.is_absolute() else urdf.path.parent / p


def _write_shape(stage: Usd.Stage, path: Sdf.Path, c: Collision) -> None:
    if c.kind == "box":
        g = UsdGeom.Cube.Define(stage, path)
        g.CreateSizeAttr(1.0)  # unit cube scaled to the box's full extents
        g.CreateExtentAttr([(-0.5, -0.5, -0.5), (0.5, 0.5, 0.5)])
        _set_pose(g.GetPrim(), c.pose, scale=c.params["size"])
    elif c.kind == "sphere":
        g = UsdGeom.Sphere.Define(stage, path)
        r = float(c.params["radius"])
        g.CreateRadiusAttr(r)
        g.CreateExtentAttr([(-r, -r, -r), (r, r, r)])
        _set_pose(g.GetPrim(), c.pose)
    else:  # cylinder / capsule along the shape's z axis; capsule height = the cylinder part (URDF length)
        g = (UsdGeom.Cylinder if c.kind == "cylinder" else UsdGeom.Capsule).Define(stage, path)
        r, h = float(c.params["radius"]), float(c.params["length"])
        g.CreateRadiusAttr(r)
        g.CreateHeightAttr(h)
        g.CreateAxisAttr(UsdGeom.Tokens.z)
        hz = h / 2 + (r if c.kind == "capsule" else 0.0)
        g.CreateExtentAttr([(-r, -r, -hz), (r, r, hz)])
        _set_pose(g.GetPrim(), c.pose)
    UsdPhysics.CollisionAPI.Apply(g.GetPrim())


def _write_mass(prim: Usd.Prim, inertial: Inertial | None) -> None:
    mass_api = UsdPhysics.MassAPI.Apply(prim)
    if inertial is None or inertial.mass <= 0.0:
        return  # mass left unauthored; UsdPhysics treats 0 as "unspecified" anyway
    d, R = principal_inertia(inertial.inertia)
    mass_api.CreateMassAttr(float(inertial.mass))
    mass_api.CreateCenterOfMassAttr(Gf.Vec3f(*inertial.com.tolist()))
    mass_api.CreateDiagonalInertiaAttr(Gf.Vec3f(*np.maximum(d, 0.0).tolist()))
    mass_api.CreatePrincipalAxesAttr(_quatf(R))


def _newton_joint_attr(prim: Usd.Prim, name: str, value: float) -> None:
    """An attribute of newton-usd-schemas' NewtonJointAPI (written as plain metadata if the schema is absent)."""
    if HAVE_NEWTON_SCHEMAS:
        prim.ApplyAPI("NewtonJointAPI")
    else:
        prim.AddAppliedSchema("NewtonJointAPI")
    prim.CreateAttribute(name, Sdf.ValueTypeNames.Float).Set(float(value))


def _config_index(urdf: Urdf, robot) -> dict[str, int]:
    """Joint name -> index in the robot config; checks that every driven joint exists and moves."""
    if robot is None:
        return {}
    moving = {j.name for j in urdf.joints if j.type != "fixed"}
    missing = [n for n in robot.joint_names if n not in moving]
    if missing:
        raise ConversionError(f"robot config {robot.name!r} drives joints that are not moving joints of the URDF: "
                              f"{', '.join(missing)}")
    return {n: i for i, n in enumerate(robot.joint_names)}


def write_stage(urdf: Urdf, robot=None, warn: Callable[[str], None] = _stderr) -> tuple[Usd.Stage, Counts]:
    """Build an in-memory stage for `urdf`. `robot` (a RobotConfig or None) supplies drive gains and targets:
    joints it lists get an angular DriveAPI, other joints get none."""
    cfg_index = _config_index(urdf, robot)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    scene = UsdPhysics.Scene.Define(stage, "/physicsScene")
    scene.CreateGravityDirectionAttr(Gf.Vec3f(0.0, 0.0, -1.0))
    scene.CreateGravityMagnitudeAttr(9.81)

    root_path = Sdf.Path.absoluteRootPath.AppendChild(Tf.MakeValidIdentifier(urdf.name))
    robot_prim = UsdGeom.Xform.Define(stage, root_path).GetPrim()
    stage.SetDefaultPrim(robot_prim)
    UsdPhysics.ArticulationRootAPI.Apply(robot_prim)
    counts = Counts()

    # Links. The root link is a free rigid body: no joint ties it to the world, which is how UsdPhysics
    # expresses a floating base (importers such as Newton's add a free joint for it).
    link_name = _Names(["joints"])
    link_paths: dict[str, Sdf.Path] = {}
    warned: set[Path] = set()
    poses = world_poses(urdf)
    for name, link in urdf.links.items():
        T = poses[name]
        path = root_path.AppendChild(link_name(name))
        link_paths[name] = path
        prim = UsdGeom.Xform.Define(stage, path).GetPrim()
        _set_pose(prim, T)
        UsdPhysics.RigidBodyAPI.Apply(prim)
        _write_mass(prim, link.inertial)
        counts.links += 1
        for i, c in enumerate(link.collisions):
            if c.kind == "mesh":
                # No mesh reader here (STL/DAE/OBJ would need trimesh or assimp): meshes are skipped either way,
                # and a missing file (the vendor ships URDFs without their meshes) gets one line per file.
                counts.skipped_meshes += 1
                f = _resolve_mesh(urdf, str(c.params["filename"]))
                if f not in warned:
                    warned.add(f)
                    state = "not found" if not f.exists() else "not converted (meshes are not read)"
                    warn(f"warning: {urdf.path}: link {name}: collision mesh {f} {state}; skipped")
                continue
            _write_shape(stage, path.AppendChild(f"collision_{i}"), c)
            counts.shapes += 1

    joint_scope = root_path.AppendChild("joints")
    UsdGeom.Scope.Define(stage, joint_scope)
    joint_name = _Names()
    for j in urdf.joints:
        path = joint_scope.AppendChild(joint_name(j.name))
        R0 = j.origin[:3, :3]
        if j.type == "fixed":
            joint = UsdPhysics.FixedJoint.Define(stage, path)
            Ra = np.eye(3)
        else:
            token, Ra = _axis_frame(j.axis)
            joint = (UsdPhysics.PrismaticJoint if j.type == "prismatic" else UsdPhysics.RevoluteJoint).Define(
                stage, path)
            joint.CreateAxisAttr(token)
        # Joint frame: in the parent at the URDF origin, in the child at its link origin; both turned by Ra so the
        # USD axis lies along the URDF axis (which URDF gives in the child frame). At q = 0 the two frames coincide.
        joint.CreateBody0Rel().SetTargets([link_paths[j.parent]])
        joint.CreateBody1Rel().SetTargets([link_paths[j.child]])
        joint.CreateLocalPos0Attr(Gf.Vec3f(*j.origin[:3, 3].tolist()))
        joint.CreateLocalRot0Attr(_quatf(R0 @ Ra))
        joint.CreateLocalPos1Attr(Gf.Vec3f(0.0, 0.0, 0.0))
        joint.CreateLocalRot1Attr(_quatf(Ra))
        counts.joints += 1
        if j.type == "fixed":
            continue
        angular = j.type != "prismatic"
        unit = RAD2DEG if angular else 1.0
        if j.lower is not None and j.upper is not None:  # continuous joints stay unlimited (unauthored = -inf..inf)
            joint.CreateLowerLimitAttr(j.lower * unit)
            joint.CreateUpperLimitAttr(j.upper * unit)
        prim = joint.GetPrim()
        if j.velocity is not None and j.velocity > 0:  # UsdPhysics has no velocity limit; Newton's schema: deg/s
            _newton_joint_attr(prim, "newton:velocityLimit", j.velocity * unit)
        if robot is not None and robot.armature > 0:  # the config's rotor inertia applies to every moving joint
            _newton_joint_attr(prim, "newton:armature", robot.armature)
        if j.name in cfg_index:
            k = cfg_index[j.name]
            drive = UsdPhysics.DriveAPI.Apply(prim, "angular" if angular else "linear")
            drive.CreateTypeAttr(UsdPhysics.Tokens.force)
            # UsdPhysics gains are per degree for angular drives: N m/rad * (pi/180) = N m/deg
            drive.CreateStiffnessAttr(robot.kp[k] / unit)
            drive.CreateDampingAttr(robot.kd[k] / unit)
            drive.CreateTargetPositionAttr(robot.default_q[k] * unit)
            drive.CreateMaxForceAttr(robot.effort_limit[k])
            counts.drives += 1
    return stage, counts


def convert(urdf_path: str | Path, out_path: str | Path, robot=None,
            warn: Callable[[str], None] = _stderr) -> Counts:
    """URDF file -> USD file (.usda / .usdc / .usd). Raises OSError, ET.ParseError or ConversionError."""
    urdf = parse_urdf(urdf_path)
    stage, counts = write_stage(urdf, robot, warn)
    out_path = Path(out_path)
    if out_path.suffix not in (".usda", ".usdc", ".usd"):
        raise ConversionError(f"output {out_path}: extension must be .usda, .usdc or .usd")
    if not out_path.parent.is_dir():
        raise ConversionError(f"output folder {out_path.parent} does not exist")
    stage.GetRootLayer().documentation = f"Converted from {Path(urdf_path).name} by cra_warp.usd"
    try:
        ok = stage.GetRootLayer().Export(str(out_path))
    except Tf.ErrorException as e:  # USD's error text names C++ files and lines: keep only its first message
        reason = re.search(r" : '(.*?)'(?= Error in|$)", " ".join(str(e).split()))
        raise ConversionError(f"cannot write {out_path}" + (f": {reason.group(1)}" if reason else "")) from None
    if not ok:
        raise ConversionError(f"cannot write {out_path}")
    return counts

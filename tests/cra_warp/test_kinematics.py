"""pytorch-kinematics FK: agrees with Newton's body poses, is differentiable, and stands the robot on its soles."""

import pytest
import torch

from cra_warp.kinematics import Kinematics
from cra_warp.sim import WorldConfig, make_world
from robots.adam_lite import ADAM_LITE

R = ADAM_LITE
IDENTITY_XYZW = (0.0, 0.0, 0.0, 1.0)


def random_states(n: int, gen: torch.Generator, dtype=torch.float32):
    """Random base position, uniform random base orientation (xyzw), joints uniform within limits clipped to +-2."""
    pos = torch.rand(n, 3, generator=gen, dtype=dtype) * torch.tensor([4.0, 4.0, 1.0], dtype=dtype) \
        - torch.tensor([2.0, 2.0, -0.5], dtype=dtype)
    quat = torch.randn(n, 4, generator=gen, dtype=dtype)
    quat = quat / quat.norm(dim=-1, keepdim=True)
    lo = torch.tensor(R.pos_lower, dtype=dtype).clamp(-2.0, 2.0)
    hi = torch.tensor(R.pos_upper, dtype=dtype).clamp(-2.0, 2.0)
    q = lo + (hi - lo) * torch.rand(n, R.num_joints, generator=gen, dtype=dtype)
    return pos, quat, q


def rotation_angle(qa: torch.Tensor, qb: torch.Tensor) -> torch.Tensor:
    """Angle [rad] of the rotation between quaternions qa, qb (xyzw, either sign, normalised here).

    atan2 of the relative rotation's vector and scalar parts: acos of the dot product loses precision near 0
    (a float32 round-off of 1e-7 in the dot product reads as 1e-3 rad).
    """
    qa = qa / qa.norm(dim=-1, keepdim=True)
    qb = qb / qb.norm(dim=-1, keepdim=True)
    va, wa, vb, wb = qa[..., :3], qa[..., 3:], qb[..., :3], qb[..., 3:]
    w = (wa * wb + (va * vb).sum(-1, keepdim=True)).squeeze(-1)   # scalar part of conj(qa) * qb
    v = wa * vb - wb * va - torch.cross(va, vb, dim=-1)             # vector part of conj(qa) * qb
    return 2.0 * torch.atan2(v.norm(dim=-1), w.abs())


@pytest.fixture(scope="module")
def kin():
    return Kinematics(R)


@pytest.fixture(scope="module")
def newton_and_fk(kin):
    """Newton (float32) and our FK on the same 8 random states: {body: (pos_err, rot_err)}, and the world."""
    world = make_world(R, WorldConfig(capture=False), num_envs=8)
    gen = torch.Generator().manual_seed(0)
    pos, quat, q = random_states(world.num_envs, gen)
    world.reset(joint_q=torch.cat([pos, quat, q], dim=1))  # eval_fk runs inside reset: body_q is current
    names = [n for n in world.body_index if n in kin.link_names]
    ids = [world.body_index[n] for n in names]
    # FK in float64 from the float32 state Newton holds, so the comparison measures Newton's float32 FK error.
    kin64 = Kinematics(R, dtype=torch.float64)
    p, qt = kin64.link_poses(world.root_pos.double(), world.root_quat.double(), world.joint_pos.double(), names)
    pos_err = (p - world.body_pos[:, ids].double()).norm(dim=-1)               # [N, L]
    rot_err = rotation_angle(qt, world.body_quat[:, ids].double())              # [N, L]
    return world, names, pos_err, rot_err


def test_fk_matches_newton_body_frames(newton_and_fk):
    world, names, pos_err, rot_err = newton_and_fk
    # Every Newton body has a link here (fixed-joint children merged into their parents exist only in the chain).
    assert set(names) == set(world.body_index), set(world.body_index) - set(names)
    assert len(names) == world.num_bodies == R.num_joints + 1
    worst = names[pos_err.max(0).values.argmax()], names[rot_err.max(0).values.argmax()]
    assert pos_err.max() < 1e-4, f"max position error {pos_err.max():.2e} m at {worst[0]}"
    assert rot_err.max() < 1e-4, f"max rotation error {rot_err.max():.2e} rad at {worst[1]}"


def test_newton_body_q_is_the_link_origin_not_the_com(newton_and_fk, kin):
    # If Newton's body_q were the CoM the thigh (CoM 13 cm from its origin) would be off by far more than 1e-4.
    world, names, pos_err, _ = newton_and_fk
    assert pos_err[:, names.index("thighLeft")].max() < 1e-4
    # And the foot frame is where the sole offset assumes: the toe origin is the ankle axis (anklePitch origin).
    p, _ = kin.link_frames(world.root_pos, world.root_quat, world.joint_pos, ["anklePitchLeft", "toeLeft"])
    assert torch.allclose(p[:, 0], p[:, 1], atol=1e-6)


def test_fixed_wrist_joints_are_welded(kin):
    # The wristYaw links exist in the chain (fixed joints) but have no coordinate: q has 23 columns.
    assert kin.num_joints == 23 and "wristYawLeft" in kin.link_names
    gen = torch.Generator().manual_seed(1)
    pos, quat, q = random_states(4, gen)
    p, rot = kin.link_frames(pos, quat, q, ["elbowLeft", "wristYawLeft"])
    assert torch.allclose(rot[:, 0], rot[:, 1], atol=1e-6)  # welded at 0 with an unrotated origin


def test_gradcheck_sole_corners_float64():
    kin = Kinematics(R, dtype=torch.float64)
    gen = torch.Generator().manual_seed(2)
    pos, quat, q = random_states(2, gen, torch.float64)
    inputs = tuple(t.clone().requires_grad_(True) for t in (pos, quat, q))
    assert torch.autograd.gradcheck(lambda p, o, j: kin.sole_points(p, o, j)[0], inputs, eps=1e-6, atol=1e-6)
    assert torch.autograd.gradcheck(lambda p, o, j: kin.link_poses(p, o, j, R.foot_links)[1], inputs,
                                    eps=1e-6, atol=1e-6)


def test_standing_pose_puts_the_soles_on_the_ground(kin):
    pos = torch.tensor([[0.0, 0.0, R.base_height]])
    f = kin.feet(pos, torch.tensor([IDENTITY_XYZW]), torch.tensor([R.default_q]))
    lowest = f.sole_corners[..., 2].min()
    assert lowest.abs() < 0.01, \
        f"lowest sole corner at z={lowest:.4f} m: base_height should be {R.base_height - lowest:.4f}"
    # Both soles nearly flat (within 5 mm corner to corner) and left/right mirror images.
    assert (f.sole_corners[..., 2].amax(-1) - f.sole_corners[..., 2].amin(-1)).max() < 0.005
    mirror = torch.tensor([1.0, -1.0, 1.0])
    assert torch.allclose(f.sole_centres[0, 0] * mirror, f.sole_centres[0, 1], atol=1e-5)


def test_sole_points_are_the_offset_box_in_the_foot_frame(kin):
    gen = torch.Generator().manual_seed(3)
    pos, quat, q = random_states(5, gen)
    f = kin.feet(pos, quat, q)
    hx, hy = R.sole_half_size
    c = f.sole_corners
    assert torch.allclose((c[:, :, 0] - c[:, :, 2]).norm(dim=-1), torch.full((5, 2), 2 * hx), atol=1e-5)
    assert torch.allclose((c[:, :, 0] - c[:, :, 1]).norm(dim=-1), torch.full((5, 2), 2 * hy), atol=1e-5)
    assert torch.allclose(c.mean(2), f.sole_centres, atol=1e-5)
    # sole_points and link_poses agree with feet (same FK pass).
    corners, centres = kin.sole_points(pos, quat, q)
    p, qt = kin.link_poses(pos, quat, q, R.foot_links)
    assert torch.equal(corners, c) and torch.equal(centres, f.sole_centres)
    assert torch.equal(p, f.pos) and torch.equal(qt, f.quat)


def test_joint_order_is_canonical_not_pk(kin):
    # Moving the canonical column of the left knee moves the left foot only, whatever pk's own order is.
    base = (torch.zeros(1, 3), torch.tensor([IDENTITY_XYZW]))
    q0 = torch.tensor([R.default_q])
    q1 = q0.clone()
    q1[0, R.joint_names.index("kneePitch_Left")] += 0.5
    p0, _ = kin.link_frames(*base, q0, R.foot_links)
    p1, _ = kin.link_frames(*base, q1, R.foot_links)
    assert (p1[0, 0] - p0[0, 0]).norm() > 0.05 and torch.allclose(p1[0, 1], p0[0, 1])


def test_shapes_dtype_device_and_errors():
    for dtype in (torch.float32, torch.float64):
        kin = Kinematics(R, device="cpu", dtype=dtype)
        N = 3
        pos, quat, q = (t.to(dtype) for t in random_states(N, torch.Generator().manual_seed(4)))
        p, rot = kin.link_frames(pos, quat, q)
        assert p.shape == (N, len(kin.link_names), 3) and rot.shape == (N, len(kin.link_names), 3, 3)
        p, qt = kin.link_poses(pos, quat, q, ["torso", "toeRight"])
        assert p.shape == (N, 2, 3) and qt.shape == (N, 2, 4)
        assert torch.allclose(qt.norm(dim=-1), torch.ones(N, 2, dtype=dtype)) and (qt[..., 3] >= 0).all()
        f = kin.feet(pos, quat, q)
        F = len(R.foot_links)
        assert f.pos.shape == (N, F, 3) and f.quat.shape == (N, F, 4)
        assert f.sole_corners.shape == (N, F, 4, 3) and f.sole_centres.shape == (N, F, 3)
        assert all(t.dtype == dtype and t.device == torch.device("cpu") for t in f)
    assert Kinematics(R, device=torch.device("cpu")).device == torch.device("cpu")
    with pytest.raises(ValueError, match="noSuchLink"):
        kin.link_frames(pos, quat, q, ["noSuchLink"])
    with pytest.raises(ValueError, match="22 columns"):
        kin.link_frames(pos, quat, q[:, :22])


def test_base_pose_composition(kin):
    # Translating and rotating the base moves every link rigidly: p' = R p + t.
    gen = torch.Generator().manual_seed(5)
    pos, quat, q = random_states(4, gen)
    p0, r0 = kin.link_frames(torch.zeros(4, 3), torch.tensor([IDENTITY_XYZW]).expand(4, 4), q)
    p1, r1 = kin.link_frames(pos, quat, q)
    _, rb = kin.link_frames(pos, quat, q, [R.base_link])
    Rb = rb[:, 0]
    assert torch.allclose(p1, pos[:, None] + torch.einsum("nij,nlj->nli", Rb, p0), atol=1e-5)
    assert torch.allclose(r1, Rb[:, None] @ r0, atol=1e-5)
    # Non-unit base quaternions are normalised.
    p2, _ = kin.link_frames(pos, 3.0 * quat, q)
    assert torch.allclose(p1, p2, atol=1e-5)

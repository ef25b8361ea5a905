"""cra_warp/terrain/sampling.py: bilinear heights, gradients and the height maps around a robot."""

import math

import pytest
import torch

from tests.conftest import tile_of
from cra_warp.rotations import yaw_quat
from cra_warp.terrain.sampling import HeightSampler, bench_height_maps, heading_xy


# ---------------------------------------------------------------- sampling
def slope_face_points(terrain, level, n, gen):
    """Points inside the +x face of a slope_up tile, one cell away from its edges and ridges, and its plane."""
    tile = tile_of(terrain, "slope_up", level)
    L, p, res = tile.half_inner, tile.half_platform, terrain.cfg.resolution
    u = p + res + torch.rand(n, generator=gen, dtype=torch.float64) * (L - p - 2 * res)
    v = (torch.rand(n, generator=gen, dtype=torch.float64) * 2 - 1) * (u - 2 * res)
    xy = torch.stack([tile.centre[0] + u, tile.centre[1] + v], -1)
    t = math.tan(math.radians(tile.difficulty))
    return xy, terrain.base_height + t * (L - u), t


def test_bilinear_matches_the_analytic_slope(terrain, sampler):
    gen = torch.Generator().manual_seed(0)
    for level in (2, 9):
        xy, z, _ = slope_face_points(terrain, level, 500, gen)
        assert torch.allclose(sampler.heights(xy).double(), z, atol=2e-4)


def test_gradient_of_sampled_heights_is_the_slope(terrain, sampler):
    gen = torch.Generator().manual_seed(1)
    xy, _, t = slope_face_points(terrain, 7, 200, gen)
    xy = xy.float().requires_grad_(True)
    sampler.heights(xy).sum().backward()
    g = xy.grad
    assert torch.isfinite(g).all()
    assert torch.allclose(g[:, 0], torch.full_like(g[:, 0], -t), rtol=1e-3, atol=1e-3), "falls along +x at tan(angle)"
    assert g[:, 1].abs().max() < 1e-3
    # everywhere, including outside the field: finite, and zero where the lookup clamps to the border
    pts = (torch.rand(1000, 2, generator=gen) * 140 - 20).requires_grad_(True)
    sampler.heights(pts).sum().backward()
    assert torch.isfinite(pts.grad).all()
    far = torch.tensor([[-50.0, -50.0], [500.0, 30.0]], requires_grad=True)
    h = sampler.heights(far)
    h.sum().backward()
    assert torch.allclose(h, torch.full_like(h, terrain.base_height)) and far.grad.abs().max() == 0


def test_maps_shapes_frames_and_offsets(terrain, sampler):
    tile = tile_of(terrain, "slope_up", 6)
    t = math.tan(math.radians(tile.difficulty))
    cx, cy = tile.centre
    u = 2.5                                                        # middle of the +x face
    z0 = terrain.base_height + t * (tile.half_inner - u) + 0.9
    pos = torch.tensor([[cx + u, cy, z0]] * 4)
    quat = yaw_quat(torch.tensor([0.0, math.pi / 2, math.pi, -math.pi / 2]))
    m = sampler.base_map(pos, quat)
    assert m.shape == (4, 17, 11)
    assert m[0, 8, 5] == pytest.approx(-0.9, abs=1e-3)             # centre point: ground 0.9 m below the base
    step = sampler.maps.base_spacing * t
    fwd = m[:, 1:, :].sub(m[:, :-1, :]).mean((1, 2))               # along dim 1 (the heading)
    left = m[:, :, 1:].sub(m[:, :, :-1]).mean((1, 2))              # along dim 2 (the left)
    # yaw 0 faces downhill (+x), pi/2 has downhill on its right, pi faces uphill, -pi/2 has downhill on its left
    assert fwd.tolist() == pytest.approx([-step, 0.0, step, 0.0], abs=1e-4)
    assert left.tolist() == pytest.approx([0.0, step, 0.0, -step], abs=1e-4)
    soles = pos[:, None, :].repeat(1, 2, 1) + torch.tensor([[0.0, 0.1, -0.5], [0.0, -0.1, -0.5]])
    feet = sampler.foot_maps(soles, quat[:, None].repeat(1, 2, 1))
    assert feet.shape == (4, 2, 5, 5)
    ground = sampler.heights(soles)
    assert torch.allclose(feet[:, :, 2, 2], ground - soles[..., 2], atol=1e-4)  # centre point, relative to the sole
    assert torch.allclose(feet[0, :, 1:, :] - feet[0, :, :-1, :],
                          torch.full((2, 4, 5), -sampler.maps.foot_spacing * t), atol=1e-4)


def test_maps_are_differentiable_in_the_base_pose(terrain, sampler):
    tile = tile_of(terrain, "slope_up", 6)
    t = math.tan(math.radians(tile.difficulty))
    pos = torch.tensor([[tile.centre[0] + 2.5, tile.centre[1], 4.0]], requires_grad=True)
    quat = torch.tensor([[0.0, 0.0, 0.0, 1.0]], requires_grad=True)
    sampler.base_map(pos, quat).sum().backward()
    n = 17 * 11
    assert pos.grad[0].tolist() == pytest.approx([-t * n, 0.0, -n], abs=1e-2)
    assert torch.isfinite(quat.grad).all()


def test_heading_ignores_pitch_and_roll():
    yaw, pitch = 0.7, 0.4
    q_yaw = torch.tensor([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    q_pitch = torch.tensor([0.0, math.sin(pitch / 2), 0.0, math.cos(pitch / 2)])
    x1, y1, z1, w1 = q_yaw
    x2, y2, z2, w2 = q_pitch
    q = torch.stack([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2])
    assert heading_xy(q).tolist() == pytest.approx([math.cos(yaw), math.sin(yaw)], abs=1e-6)


@pytest.mark.slow
def test_compiled_maps_match_eager(terrain, sampler):
    from cra_warp.terrain.sampling import HeightMapConfig

    fast = HeightSampler(terrain.field, maps=HeightMapConfig(compile=True))
    gen = torch.Generator().manual_seed(2)
    pos = torch.rand(32, 3, generator=gen) * torch.tensor([80.0, 50.0, 1.0]) + 2
    quat = torch.nn.functional.normalize(torch.randn(32, 4, generator=gen), dim=-1)
    assert torch.allclose(fast.base_map(pos, quat), sampler.base_map(pos, quat), atol=1e-4)


def test_bench_height_maps_runs(sampler):
    r = bench_height_maps(num_envs=64, repeats=2, sampler=sampler)
    assert r["num_envs"] == 64 and r["ms_per_step"] > 0 and r["points"] == 64 * (187 + 50)

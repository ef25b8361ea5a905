"""The terrain layer: heightfield generation, collision boxes, height sampling, curriculum, evaluation course, picture,
and (one World) Adam Lite standing on the boxes."""

import math
import subprocess
import sys

import numpy as np
import pytest
import torch

from cra_warp.terrain import TERRAIN_TYPES, TerrainConfig, column_types, generate_terrain
from cra_warp.terrain_boxes import box_surface, rectangles, terrain_boxes
from cra_warp.rotations import yaw_quat
from cra_warp.terrain_course import EVAL_KINDS, EvalCourse, EvalCourseConfig
from cra_warp.terrain_curriculum import PathMeter, TerrainCurriculum
from cra_warp.terrain_sampling import HeightSampler, bench_height_maps, heading_xy


@pytest.fixture(scope="module")
def terrain():
    return generate_terrain(TerrainConfig())


@pytest.fixture(scope="module")
def sampler(terrain):
    return HeightSampler(terrain.field)


def tile_of(terrain, kind, level):
    return terrain.tile(level, terrain.column_types.index(kind))


def centre_row(terrain, tile):
    """Heights relative to the rim along the tile's centre line in x (from its -x edge to its centre), [n/2]."""
    rows, cols = tile.cells
    mid = (cols.start + cols.stop) // 2
    return terrain.field.heights[rows.start:(rows.start + rows.stop) // 2, mid].astype(np.float64) - terrain.base_height


# ---------------------------------------------------------------- generation
@pytest.mark.parametrize("kind, sign", [("stairs_up", 1), ("stairs_down", -1)])
def test_steps_have_the_levels_nominal_height_and_tread(terrain, kind, sign):
    cfg = terrain.cfg
    res = cfg.resolution
    for level in range(cfg.num_levels):
        tile = tile_of(terrain, kind, level)
        rise = cfg.step_height[0] + (cfg.step_height[1] - cfg.step_height[0]) * level / (cfg.num_levels - 1)
        assert tile.difficulty == pytest.approx(rise)
        h = centre_row(terrain, tile)
        jumps = np.flatnonzero(np.abs(np.diff(h)) > 1e-6) + 1          # first cell of each step
        assert np.allclose(np.diff(h)[jumps - 1], sign * rise, atol=1e-5), "every riser is one nominal rise"
        # risers at the rim's inner edge, then one tread apart: exact to the resolution
        expected = cfg.tile_margin + cfg.tread * np.arange(len(jumps))
        assert np.allclose(jumps * res, expected, atol=res / 2)
        assert h[0] == 0.0 and h[-1] == pytest.approx(sign * rise * len(jumps), abs=1e-5)


@pytest.mark.parametrize("kind", ["slope_up", "slope_down"])
def test_slope_angle_measured_from_the_field(terrain, kind):
    cfg, res = terrain.cfg, terrain.cfg.resolution
    for level in range(cfg.num_levels):
        tile = tile_of(terrain, kind, level)
        h = centre_row(terrain, tile)
        m, p = int(round(cfg.tile_margin / res)), int(round((tile.half_inner - tile.half_platform) / res))
        face = h[m + 1:m + p - 1]                                      # inside the face, off its edges
        slope = np.polyfit(np.arange(len(face)) * res, face, 1)[0]
        angle = math.degrees(math.atan(abs(slope)))
        assert abs(angle - tile.difficulty) < 0.5, f"level {level}: {angle:.2f} deg, nominal {tile.difficulty}"
        assert np.sign(slope) == (1 if kind == "slope_up" else -1)


def test_same_seed_same_terrain_and_seed_matters():
    a = generate_terrain(TerrainConfig(num_levels=3, seed=7))
    b = generate_terrain(TerrainConfig(num_levels=3, seed=7))
    c = generate_terrain(TerrainConfig(num_levels=3, seed=8))
    assert np.array_equal(a.field.heights, b.field.heights)
    assert not np.array_equal(a.field.heights, c.field.heights)  # the uneven tiles differ


def test_columns_follow_proportions():
    assert column_types(TerrainConfig()) == TERRAIN_TYPES
    cols = column_types(TerrainConfig(num_cols=10, proportions=(2, 1, 1, 1, 0, 0)))
    assert cols.count("flat") == 4 and "slope_down" not in cols and len(cols) == 10


@pytest.mark.parametrize("kwargs, field", [
    (dict(num_levels=0), "num_levels"),
    (dict(tile_size=8.02), "tile_size"),
    (dict(resolution=0.0), "resolution"),
    (dict(step_height=(-0.05, 0.3)), "step_height"),
    (dict(slope_deg=(10.0, 5.0)), "slope_deg"),
    (dict(uneven_height=(0.0, -0.1)), "uneven_height"),
    (dict(proportions=(0.0,) * 6), "proportions"),
    (dict(proportions=(1.0, -1.0, 1.0, 1.0, 1.0, 1.0)), "proportions"),
])
def test_config_errors_are_one_line_naming_the_field(kwargs, field):
    with pytest.raises(ValueError) as e:
        TerrainConfig(**kwargs)
    assert f"TerrainConfig.{field}" in str(e.value) and "\n" not in str(e.value)


def test_origins_are_tile_centres_at_ground_height(terrain):
    for tile in terrain.tiles:
        o = terrain.origins[tile.level, tile.col]
        assert tuple(o[:2]) == pytest.approx(tile.centre)
        assert o[2] == pytest.approx(float(terrain.field.height_at(*tile.centre)), abs=1e-6)
    stairs = tile_of(terrain, "stairs_up", 9)
    assert terrain.origins[9, stairs.col, 2] == pytest.approx(terrain.field.heights[stairs.cells].max())  # on top
    pit = tile_of(terrain, "stairs_down", 9)
    assert terrain.origins[9, pit.col, 2] == pytest.approx(terrain.field.heights[pit.cells].min())      # at the bottom
    assert terrain.field.heights.min() == 0.0  # the deepest pit bottom sits on World's ground plane


# ---------------------------------------------------------------- collision boxes
def test_rectangles_cover_exactly_once():
    rng = np.random.default_rng(0)
    mask = rng.random((30, 20)) < 0.6
    vals = rng.integers(0, 3, (30, 20)).astype(np.float32)
    cover = np.zeros(mask.shape, int)
    for i0, i1, j0, j1 in rectangles(mask, vals):
        cover[i0:i1, j0:j1] += 1
        assert np.all(vals[i0:i1, j0:j1] == vals[i0, j0])
    assert np.array_equal(cover, mask.astype(int))


def test_box_tops_agree_with_the_array_everywhere(terrain):
    boxes = terrain_boxes(terrain)
    err = box_surface(boxes, terrain.field) - terrain.field.heights
    assert np.abs(err).max() < 1e-4, f"box surface differs by {np.abs(err).max():.2e} m"
    assert len(boxes.centers) < 1500
    assert np.allclose(np.linalg.norm(boxes.quats, axis=1), 1.0)


@pytest.mark.parametrize("kwargs", [
    dict(num_levels=3, tile_size=6.0, tile_margin=0.3, platform_size=1.0, resolution=0.1, seed=3),
    dict(num_levels=2, tile_size=5.0, tile_margin=0.25, tread=0.25, slope_deg=(30.0, 45.0), seed=4),
])
def test_box_tops_agree_for_other_configs(kwargs):
    t = generate_terrain(TerrainConfig(**kwargs))
    err = box_surface(terrain_boxes(t), t.field) - t.field.heights
    assert np.abs(err).max() < 1e-4


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
    from cra_warp.terrain_sampling import HeightMapConfig

    fast = HeightSampler(terrain.field, maps=HeightMapConfig(compile=True))
    gen = torch.Generator().manual_seed(2)
    pos = torch.rand(32, 3, generator=gen) * torch.tensor([80.0, 50.0, 1.0]) + 2
    quat = torch.nn.functional.normalize(torch.randn(32, 4, generator=gen), dim=-1)
    assert torch.allclose(fast.base_map(pos, quat), sampler.base_map(pos, quat), atol=1e-4)


def test_bench_height_maps_runs(sampler):
    r = bench_height_maps(num_envs=64, repeats=2, sampler=sampler)
    assert r["num_envs"] == 64 and r["ms_per_step"] > 0 and r["points"] == 64 * (187 + 50)


# ---------------------------------------------------------------- curriculum
def test_curriculum_promotes_demotes_and_wraps(terrain):
    n = 12
    cur = TerrainCurriculum(terrain, n, device="cpu", max_init_level=0, seed=0)
    assert cur.levels.tolist() == [0] * n and cur.cols.tolist() == [i % 6 for i in range(n)]
    cur.levels[:] = torch.tensor([3, 3, 3, 3, 0, 0, 9, 9, 9, 9, 5, 5])
    walked = torch.tensor([4.5, 1.0, 3.0, 0.5, 0.1, 5.0, 4.1, 4.1, 4.1, 4.1, 2.0, 2.0])
    commanded = torch.tensor([10., 10., 4., 0.0, 5., 5., 5., 5., 5., 5., 3.9, 4.1])
    ids = torch.arange(n)
    cur.update(ids, walked, torch.zeros(n), commanded)  # the path rule ignores the farthest point
    # >4 m (half a tile): up; < half the commanded distance: down (not below 0); otherwise stay
    assert cur.levels[[0, 1, 2, 3, 4, 5, 10, 11]].tolist() == [4, 2, 3, 3, 0, 1, 5, 4]
    assert ((cur.levels[6:10] >= 0) & (cur.levels[6:10] < 10)).all()     # past the top: a random level
    assert torch.equal(cur.origins, cur.tile_origins[cur.levels, cur.cols])
    assert cur.mean_level() == pytest.approx(cur.levels.float().mean().item())
    before = cur.levels.clone()
    cur.update(torch.tensor([1]), torch.tensor([9.0]), torch.tensor([0.0]), torch.tensor([1.0]))  # env 1 alone
    assert cur.levels[1] == before[1] + 1 and torch.equal(cur.levels[2:], before[2:])


def test_curriculum_reach_rule_judges_the_farthest_point(terrain):
    """Rule "reach": a long path circling near the origin (a pit's floor) is a demotion, not a promotion."""
    cur = TerrainCurriculum(terrain, 6, rule="reach")
    cur.levels[:] = 3
    walked = torch.tensor([9.0, 9.0, 9.0, 1.0, 9.0, 0.1])
    farthest = torch.tensor([4.5, 1.5, 2.5, 1.0, 1.9, 0.1])
    commanded = torch.tensor([10., 10., 10., 1.0, 3.0, 0.0])
    cur.update(torch.arange(6), walked, farthest, commanded)
    # out of the pit: up; stuck at its wall's foot (< 2 m): down however far it walked; halfway out: stays;
    # short commands ask for less (1 m -> 0.5 m, 3 m -> 1.5 m); no command: never down
    assert cur.levels.tolist() == [4, 2, 3, 3, 3, 3]
    with pytest.raises(ValueError, match="rule"):
        TerrainCurriculum(terrain, 2, rule="displacement")


def test_curriculum_wrap_spreads_over_levels(terrain):
    cur = TerrainCurriculum(terrain, 600, max_init_level=9, seed=1)
    cur.levels[:] = 9
    cur.update(torch.arange(600), torch.full((600,), 6.0), torch.full((600,), 6.0), torch.zeros(600))
    counts = torch.bincount(cur.levels, minlength=10)
    assert (counts > 20).all(), counts.tolist()


def test_curriculum_rejects_bad_init_level(terrain):
    with pytest.raises(ValueError, match="max_init_level"):
        TerrainCurriculum(terrain, 4, max_init_level=10)


def test_path_meter_counts_a_walked_circle_and_not_the_sway_and_the_farthest_point():
    """50 Hz for 20 s: robot 0 walks a 0.5 m/s circle of radius 1 m with a 2 cm, 2 Hz sideways sway (it ends near
    its start: legged_gym's displacement would give it nothing); robot 1 only sways on the spot."""
    dt, steps = 0.02, 1000
    meter = PathMeter(2, window=50)
    meter.reset(torch.arange(2), torch.tensor([[1.0, 0.0], [0.0, 0.0]]))
    for k in range(1, steps + 1):
        t = k * dt
        sway = 0.02 * math.sin(2 * math.pi * 2 * t)
        a = 0.5 * t  # rad: 0.5 m/s on a 1 m radius
        circle = [(1 + sway) * math.cos(a), (1 + sway) * math.sin(a)]
        xy = torch.tensor([circle, [0.0, sway]])
        meter.update(xy)
    walked = meter.walked(torch.arange(2), xy)
    assert walked[0] == pytest.approx(0.5 * steps * dt, rel=0.03)  # 10 m along the circle
    assert walked[1] < 0.1
    # the farthest from the start: across the circle (2 m, plus the sway), not where it ended (1.9 m)
    farthest = meter.farthest(torch.arange(2), xy)
    assert farthest[0] == pytest.approx(2.0, abs=0.03) and (xy[0] - torch.tensor([1.0, 0.0])).norm() < 1.95
    assert farthest[1] == pytest.approx(0.02, abs=1e-3)
    meter.reset(torch.tensor([0]), xy[:1])
    assert meter.farthest(torch.tensor([0]), xy[:1]) == 0.0
    with pytest.raises(ValueError, match="window"):
        PathMeter(2, window=0)


def test_curriculum_restore_puts_robots_on_their_levels_tiles(terrain):
    cur = TerrainCurriculum(terrain, 4, max_init_level=0, seed=0)
    cur.restore([2, 0, 9, 4])
    assert cur.levels.tolist() == [2, 0, 9, 4]
    assert torch.equal(cur.origins, cur.tile_origins[torch.tensor([2, 0, 9, 4]), cur.cols])
    with pytest.raises(ValueError, match="for \\(3,\\) envs"):
        cur.restore([1, 2, 3])
    with pytest.raises(ValueError, match="must be in \\[0, 9\\]"):
        cur.restore([0, 0, 10, 0])


# ---------------------------------------------------------------- evaluation course
def test_eval_course_layout_and_reached():
    course = EvalCourse()
    assert course.kinds == EVAL_KINDS
    k = {name: i for i, name in enumerate(course.kinds)}
    assert course.difficulty[k["stairs_ascend"]].tolist() == pytest.approx([0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35])
    assert course.difficulty[k["slope_ascend"], [0, -1]].tolist() == pytest.approx([2.0, 34.0])
    base = course.terrain.base_height
    # ascents start on the rim and end on top; descents the other way round; uneven stays on the rim height
    rise = course.targets[k["stairs_ascend"], :, 2] - course.starts[k["stairs_ascend"], :, 2]
    steps = rise / course.difficulty[k["stairs_ascend"]]
    assert np.allclose(steps, np.round(steps)) and (steps >= 5).all()
    assert np.allclose(course.starts[k["stairs_ascend"], :, 2], base)
    assert np.allclose(course.targets[k["stairs_descend"], :, 2], base)
    assert np.allclose(course.starts[k["uneven"], :, 2], base) and np.allclose(course.targets[k["uneven"], :, 2], base)
    dep = course.deploy(robots_per_level=200)
    n = len(course.kinds) * 7 * 200
    assert dep.start.shape == (n, 3) and dep.target.shape == (n, 3) and dep.kind.shape == (n,)
    assert not dep.reached(dep.start).any() and dep.reached(dep.target).all()
    pos, quat = dep.spawn_pose(base_height=0.88)
    assert torch.allclose(pos[:, 2], dep.start[:, 2] + 0.89) and quat.shape == (n, 4)
    facing = heading_xy(quat)
    to_target = torch.nn.functional.normalize(dep.target[:, :2] - dep.start[:, :2], dim=-1)
    assert torch.allclose(facing, to_target, atol=1e-5)
    ok = dep.reached(torch.where((dep.level == 3)[:, None], dep.target, dep.start))
    rate = course.success_rate(dep, ok)
    assert rate.shape == (5, 7) and rate[:, 3].tolist() == [1.0] * 5 and rate.sum() == 5


def test_eval_course_is_fixed_and_checks_kinds():
    a, b = EvalCourse(), EvalCourse()
    assert np.array_equal(a.terrain.field.heights, b.terrain.field.heights)
    with pytest.raises(ValueError, match="kinds"):
        EvalCourseConfig(kinds=("stairs", "slopes"))


# ---------------------------------------------------------------- picture
def test_terrain_png_cli(tmp_path):
    from tools.terrain_png import main

    out = tmp_path / "t.png"
    assert main(["--png", str(out), "--levels", "2", "--cols", "3", "--seed", "1"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, needle", [
    (["--levels", "2"], "--png"),
    (["--png", "x.png", "--levels", "0"], "num_levels"),
    (["--png", "/no/such/dir/x.png"], "does not exist"),
    (["--png", "x.png", "--tile-size", "8.03"], "tile_size"),
])
def test_terrain_png_bad_args_one_line_exit_2(args, needle, tmp_path):
    r = subprocess.run([sys.executable, "-m", "tools.terrain_png", *args], capture_output=True, text=True,
                       cwd=tmp_path.parent, env={"PYTHONPATH": str(__import__("pathlib").Path(__file__).parents[1]),
                                                 "PATH": ""})
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr


# ---------------------------------------------------------------- physics: Adam Lite standing on the boxes
# One World for all standing checks. A small terrain (4 levels of stairs, slopes and uneven ground: 5/10/15/20 cm,
# 5/10/15/20 deg) keeps the box count, and so the build and step time, low. Robots stand under the scripted stand
# (cra_warp.stand) at the reference pose; on slopes the ankle pitch targets are turned by the slope angle so the feet lie flat while the body stays
# upright (the flat-ground pose tips over on any slope: with stiff ankles the whole body leans with the feet).
PHYS_CFG = TerrainConfig(num_levels=4, num_cols=3, proportions=(0, 1, 0, 1, 0, 1), step_height=(0.05, 0.20),
                         slope_deg=(5.0, 20.0), seed=0)
STAND_S, SLIDE_S = 2.0, 1.0


def _ankle_ids(robot):
    return [robot.joint_names.index(f"anklePitch_{s}") for s in ("Left", "Right")]


class _Stand:
    """Spawn poses of the test robots: (name, base xy, yaw, ankle pitch offset, tolerance test)."""

    def __init__(self, terrain, kin, sampler, robot):
        self.terrain, self.kin, self.sampler, self.robot = terrain, kin, sampler, robot
        self.rows, self.names, self.targets = [], [], []
        q0 = torch.tensor(robot.default_q)[None]
        f = kin.feet(torch.zeros(1, 3), torch.tensor([[0.0, 0.0, 0.0, 1.0]]), q0)
        self.sole_ahead = f.sole_centres[0, 0, 0].item()      # sole centre ahead of the pelvis [m]
        self.sole_side = f.sole_centres[0, 0, 1].item()       # and to its left

    def add(self, name, xy, yaw, ankle=0.0, clearance=0.01):
        """Base z so that the lowest sole corner is ``clearance`` above the ground (sampled under each corner)."""
        q = torch.tensor(self.robot.default_q)[None].clone()
        q[0, _ankle_ids(self.robot)] += ankle
        quat = yaw_quat(torch.tensor([yaw], dtype=torch.float32))
        corners = self.kin.feet(torch.tensor([[xy[0], xy[1], 0.0]]), quat, q).sole_corners.reshape(-1, 3)
        z = (self.sampler.heights(corners) - corners[:, 2]).max().item() + clearance
        self.rows.append(torch.cat([torch.tensor([xy[0], xy[1], z]), quat[0], q[0]]))
        self.targets.append(q[0])
        self.names.append(name)


def _uneven_stance(terrain, level, side_offset):
    """Base xy on an uneven tile with each sole inside one grid square: the feet straddle a square boundary in y,
    the soles centred in x, on two raised squares of equal height (the PD stand itself tips over when one foot is
    1 cm higher than the other: measured on flat plates, not a terrain matter)."""
    cfg = terrain.cfg
    tile = tile_of(terrain, "uneven", level)
    hf = terrain.field
    x0, y0 = tile.centre[0] - tile.half_inner, tile.centre[1] - tile.half_inner
    g = int(round(2 * tile.half_inner / cfg.uneven_cell))
    for a in range(g):
        for b in range(1, g):
            x, y = x0 + (a + 0.5) * cfg.uneven_cell, y0 + b * cfg.uneven_cell
            if max(abs(x - tile.centre[0]), abs(y - tile.centre[1])) < cfg.spawn_pad:
                continue
            hl, hr = (float(hf.height_at(x, y + s * side_offset)) - terrain.base_height for s in (1, -1))
            if hl > 1e-4 and abs(hl - hr) < 1e-6:
                return x, y, hl
    raise AssertionError(f"no stance on two equal raised squares in uneven level {level}")


@pytest.fixture(scope="module")
def stand_run():
    from cra_warp.kinematics import Kinematics
    from cra_warp.stand import ScriptedStand
    from cra_warp.sim import WorldConfig, make_world
    from robots.adam_lite import ADAM_LITE as R

    terrain = generate_terrain(PHYS_CFG)
    sampler = HeightSampler(terrain.field)
    kin = Kinematics(R)
    s = _Stand(terrain, kin, sampler, R)
    cfg = terrain.cfg

    s.add("flat", (tile_of(terrain, "stairs_up", 0).centre[0] - cfg.tile_size / 2 - cfg.border / 2,
                   tile_of(terrain, "stairs_up", 0).centre[1]), 0.0)
    for level, ring, yaw in ((2, 2, 0.0), (3, 3, math.pi)):       # on a tread of the -x face, up / down the stairs
        t = tile_of(terrain, "stairs_up", level)
        mid = t.centre[0] - cfg.tile_size / 2 + cfg.tile_margin + (ring - 0.5) * cfg.tread
        s.add(f"stair tread {t.difficulty * 100:.0f} cm {'up' if yaw == 0 else 'down'}",
              (mid - math.cos(yaw) * s.sole_ahead, t.centre[1]), yaw)
    for level in (0, 1):
        x, y, raised = _uneven_stance(terrain, level, s.sole_side)
        s.add(f"uneven level {level} ({raised * 100:.0f} cm squares)", (x - s.sole_ahead, y), 0.0)
    for level, yaw in ((0, math.pi), (1, math.pi), (1, 0.0), (3, math.pi), (3, 0.0)):
        t = tile_of(terrain, "slope_up", level)                       # the +x face falls towards +x
        angle = math.radians(t.difficulty)
        uphill = math.cos(yaw) < 0
        s.add(f"slope {t.difficulty:.0f} deg {'uphill' if uphill else 'downhill'}",
              (t.centre[0] + (t.half_inner + t.half_platform) / 2, t.centre[1]), yaw,
              ankle=-angle if uphill else angle)                      # toe up facing uphill
    t = tile_of(terrain, "slope_up", 3)
    s.add(f"slope {t.difficulty:.0f} deg flat pose (tips, slides)",
          (t.centre[0] + (t.half_inner + t.half_platform) / 2, t.centre[1] + 0.8), math.pi)

    boxes = terrain_boxes(terrain)
    world = make_world(R, WorldConfig(num_envs=len(s.rows)), boxes)
    world.reset(joint_q=torch.stack(s.rows))
    q_ref = torch.stack(s.targets)
    stand = ScriptedStand(R)
    d = world.solver.mjw_data
    rel, pen, upright, ncon, nefc = [], [], [], 0, 0
    xy0 = world.root_pos[:, :2].clone()
    slide = None
    for _ in range(int(STAND_S / world.cfg.env_dt)):
        world.joint_target.copy_(stand.targets(world, q_ref))
        world.step()
        feet = kin.feet(world.root_pos, world.root_quat, world.joint_pos)
        ground = sampler.heights(feet.sole_centres).mean(1)
        rel.append(world.root_pos[:, 2] - ground - R.base_height)                       # [N]
        pen.append((sampler.heights(feet.sole_corners) - feet.sole_corners[..., 2]).amax((1, 2)))  # [N]
        x, y = world.root_quat[:, 0], world.root_quat[:, 1]
        upright.append(1 - 2 * (x * x + y * y))
        ncon = max(ncon, int(d.nacon.numpy()[0]))
        nefc = max(nefc, int(d.nefc.numpy().max()))
        if len(rel) == int((0.3 + SLIDE_S) / world.cfg.env_dt):
            slide = (world.root_pos[:, :2] - xy0).norm(dim=-1)
    return dict(names=s.names, rel=torch.stack(rel), pen=torch.stack(pen), upright=torch.stack(upright),
                slide=slide, ncon=ncon, nefc=nefc, naconmax=d.naconmax, njmax=d.njmax, num_envs=world.num_envs,
                boxes=len(boxes.centers), dt=world.cfg.env_dt)


@pytest.mark.slow
def test_pd_stand_holds_on_flat_stairs_uneven_and_gentle_slopes(stand_run):
    r = stand_run
    for i, name in enumerate(r["names"]):
        if "20 deg" in name:  # the steep-slope robots are only checked for sinking (next test)
            continue
        dev = r["rel"][:, i].abs().max().item()
        assert dev < 0.035, f"{name}: pelvis {dev:.3f} m off its height above the local ground"
        assert r["upright"][:, i].min() > 0.95, f"{name}: tipped over"


@pytest.mark.slow
def test_soles_stay_on_the_slope_surfaces_even_sliding(stand_run):
    """Sole corners (FK) against the sampled surface over 1 s from 0.3 s, after the landing from the 1 cm spawn
    clearance (its transient peaks at ~1 cm on flat ground too); the flat-pose robot on 20 deg slides and tips
    meanwhile. Stairs are left out: bilinear samples ramp across a riser within one cell."""
    r = stand_run
    window = slice(int(0.3 / r["dt"]), int((0.3 + SLIDE_S) / r["dt"]))
    for i, name in enumerate(r["names"]):
        if "slope" in name:
            pen = r["pen"][window, i].max().item()
            assert pen < 0.01, f"{name}: a sole corner {pen * 100:.1f} cm below the surface"
    slider = r["names"].index(next(n for n in r["names"] if "flat pose" in n))
    assert r["slide"][slider] > 0.05, "the flat-pose robot should have slid (else this test checks nothing new)"


@pytest.mark.slow
def test_terrain_contacts_fit_the_worlds_buffers(stand_run):
    r = stand_run
    assert r["ncon"] < r["naconmax"] and r["nefc"] < r["njmax"]
    assert r["ncon"] >= 8 * r["num_envs"]  # every robot stands on its feet: >= 4 contacts per sole


def test_rough_ground_takes_its_tiles_from_the_config_and_logs_levels_per_type():
    from envs.ground import Ground

    cfg = TerrainConfig(num_levels=3, num_cols=4, tile_size=4.0, platform_size=1.0,
                        proportions=(0.0, 0.0, 1.0, 0.0, 1.0, 0.0))   # pits only: the ascents
    ground = Ground("rough", 8, torch.device("cpu"), seed=2, rough=cfg)
    assert set(ground.column_types) == {"stairs_down", "slope_down"} and ground.curriculum.num_levels == 3
    ground.curriculum.restore(torch.tensor([c % 3 for c in range(8)]))
    by_type = ground.mean_level_by_type()
    cur = ground.curriculum
    for name, level in by_type.items():
        on = torch.tensor([ground.column_types[c] == name for c in cur.cols.tolist()])
        assert level == pytest.approx(float(cur.levels[on].float().mean()))
    assert len(set(by_type.values())) == 2  # the two types hold different levels here

"""The terrain generator (cra_warp/terrain/__init__.py): tiles, steps, slopes, seeds, origins; and (one World)
Adam Lite standing on the generated terrain's boxes."""

import math

import numpy as np
import pytest
import torch

from tests.conftest import centre_row, tile_of
from cra_warp.rotations import yaw_quat
from cra_warp.terrain import TERRAIN_TYPES, TerrainConfig, column_types, generate_terrain
from cra_warp.terrain.boxes import terrain_boxes
from cra_warp.terrain.sampling import HeightSampler


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
    from robots.adam_lite.loco import ADAM_LITE_LOCO

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
    world = make_world(R, WorldConfig(), boxes, num_envs=len(s.rows))
    world.reset(joint_q=torch.stack(s.rows))
    q_ref = torch.stack(s.targets)
    stand = ScriptedStand(R, ADAM_LITE_LOCO.stand)
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


def test_robot_way_is_what_the_tiles_make_a_robot_do():
    """A robot spawned on a "climbs" type stands below its tile's rim (a pit), on a "descends" type above it."""
    from cra_warp.terrain import ROBOT_WAY, TerrainConfig, generate_terrain

    t = generate_terrain(TerrainConfig(num_levels=2, num_cols=6, tile_size=8.0, resolution=0.1))
    for c, kind in enumerate(t.column_types):
        if kind in ROBOT_WAY:
            centre = t.origins[1, c, 2]
            assert (centre < t.base_height) == (ROBOT_WAY[kind] == "climbs"), kind

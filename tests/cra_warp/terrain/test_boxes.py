"""cra_warp/terrain/boxes.py: the heightfield as collision boxes, whose tops are the array's heights."""

import numpy as np
import pytest

from cra_warp.terrain import TerrainConfig, generate_terrain
from cra_warp.terrain.boxes import box_surface, rectangles, terrain_boxes


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

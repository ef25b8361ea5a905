"""envs/ground.py: rough ground takes its tiles from the config and logs the levels per terrain type."""

import pytest
import torch

from cra_warp.terrain import TerrainConfig


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
    assert len({float(v) for v in by_type.values()}) == 2  # the two types hold different levels here

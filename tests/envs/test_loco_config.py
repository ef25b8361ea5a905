"""The task config (envs/loco_config.py)."""

import pytest


def test_eval_terrain_needs_whole_levels():
    from envs.loco_config import LocoConfig

    with pytest.raises(ValueError, match="LocoConfig.num_envs must be a multiple of 35"):
        LocoConfig(num_envs=36, terrain="eval")

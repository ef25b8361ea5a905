"""The method registry (envs/methods.py): every method's row reaches the env and learner configs it names, and
build_configs applies the recipe, then the caller's overrides."""

from __future__ import annotations

import pytest

from envs.methods import METHODS, build_configs


@pytest.mark.parametrize("method", list(METHODS))
def test_each_method_builds_the_configs_its_row_names(method):
    spec = METHODS[method]
    env_cfg, learner, recipe = build_configs(method, "rough", recipe="paper", num_envs=8, sim="mujoco", seed=3)
    assert (env_cfg.variant, learner.contrast.variant, learner.actor.kind) == (
        spec.clock_mode, spec.contrast_pairing, spec.actor_kind)
    assert env_cfg.uses_clock == spec.uses_clock
    assert (env_cfg.terrain, env_cfg.num_envs, env_cfg.world.backend, env_cfg.seed) == ("rough", 8, "mujoco", 3)
    assert recipe["name"] == "paper" and learner.run_name == f"rough_{method}"


def test_overrides_come_after_the_recipe_and_reach_the_learner():
    env_cfg, learner, recipe = build_configs("ours", "flat", recipe="walk", overrides={
        "gait.alpha": 2.0, "learner.ppo.desired_kl": 0.02})
    assert recipe["overrides"]["gait.alpha"] == 5.0 and env_cfg.gait.alpha == 2.0
    assert learner.ppo.desired_kl == 0.02
    with pytest.raises(ValueError, match="--override: .*no_such"):
        build_configs("ours", "flat", overrides={"gait.no_such": 1})
    with pytest.raises(ValueError, match="--override: learner"):
        build_configs("ours", "flat", overrides={"learner.ppo.no_such": 1})

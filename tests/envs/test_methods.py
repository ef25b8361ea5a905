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


def test_the_baselines_paper_pairings_build_their_papers_clock_and_actor():
    """dreamwaq_clock_free: DreamWaQ's actor with AdaBoot and no clock, so the walk recipe's clock keys are left out
    (as clock_free's); dwl_fixed_cycle: DWL's actor on a clock of fixed period, the recipe whole. The same-clock
    versions keep our adaptive clock and plain dreamwaq keeps AdaBoot off (its stored runs trained without it)."""
    env_cfg, learner, recipe = build_configs("dreamwaq_clock_free", "flat", recipe="walk")
    assert (env_cfg.variant, env_cfg.uses_clock, learner.actor.kind) == ("clock_free", False, "dreamwaq")
    assert learner.dreamwaq.adaboot and learner.contrast.variant == "none"
    _, _, clock_free = build_configs("clock_free", "flat", recipe="walk")
    assert recipe["not_used"] == clock_free["not_used"] and "gait.swing_feedforward" in recipe["not_used"]
    assert not any(k.startswith("gait.") for k in recipe["overrides"])
    assert env_cfg.gait.swing_feedforward == 0.0 and env_cfg.gait.alpha == 0.5   # the defaults, not walk's

    env_cfg, learner, recipe = build_configs("dwl_fixed_cycle", "flat", recipe="walk")
    assert (env_cfg.variant, env_cfg.uses_clock, learner.actor.kind) == ("fixed_cycle", True, "dwl")
    assert recipe["not_used"] == {} and env_cfg.gait.swing_feedforward == 0.25
    assert not learner.dreamwaq.adaboot

    for same_clock in ("dreamwaq", "dwl"):
        env_cfg, learner, _ = build_configs(same_clock, "flat")
        assert env_cfg.variant == "adaptive" and not learner.dreamwaq.adaboot
    # the method's learner settings come before the caller's overrides: AdaBoot can be turned off, or on for dreamwaq
    _, learner, _ = build_configs("dreamwaq_clock_free", "flat", overrides={"learner.dreamwaq.adaboot": False})
    assert not learner.dreamwaq.adaboot
    _, learner, _ = build_configs("dreamwaq", "flat", overrides={"learner.dreamwaq.adaboot": True})
    assert learner.dreamwaq.adaboot

"""Recipes (envs/recipes.py): each builds a valid config for every task and method; each shipped policy's recipe
(walk, or climb for rough_walk_v1) rebuilds its config.json; paper is Table I and the paper's clock as published."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import PAPER_TABLE_I, one_line_error
from cra_warp.config_io import flatten, to_data
from envs import recipes
from envs.checkpoints import stored_env
from envs.loco_config import LocoConfig
from train import train as train_cli
from envs.methods import METHODS

POLICIES = Path(__file__).resolve().parents[2] / "robots" / "adam_lite" / "policies"
SHIPPED = sorted(p for p in POLICIES.iterdir() if (p / "config.json").is_file())

def resolved(**kw) -> LocoConfig:
    env_cfg, _, _ = train_cli.configs(train_cli.TrainArgs(**kw))
    return env_cfg


@pytest.mark.parametrize("name", list(recipes.RECIPES))
@pytest.mark.parametrize("task", ["flat", "rough"])
@pytest.mark.parametrize("variant", list(METHODS))
def test_every_recipe_builds_a_valid_config(name, task, variant):
    cfg = resolved(recipe=name, task=task, variant=variant)
    overrides, dropped = recipes.resolve(name, task, uses_clock=cfg.uses_clock)
    got = flatten(to_data(cfg))
    for path, value in overrides.items():
        assert got[path] == value, path
    # a method without a clock leaves out exactly the recipe's clock keys, and keeps the rest
    assert bool(dropped) == (not cfg.uses_clock and any(k.startswith("gait.") for k in recipes.RECIPES[name].overrides))
    assert all(k.startswith("gait.") for k in dropped)


def test_the_default_recipe_is_walk_and_a_resume_keeps_the_checkpoints(tmp_path):
    a = train_cli.TrainArgs(log_dir=tmp_path)
    train_cli.validate(a)
    assert a.recipe == recipes.DEFAULT_RECIPE == "walk"
    # --resume without --recipe: the checkpoint's recipe; one written before recipes ran on the paper's defaults
    import torch

    for stored, want in (({"recipe": {"name": "paper"}}, "paper"), ({"recipe": {"name": "walk"}}, "walk"),
                         ({}, "paper"), (None, "paper")):
        ckpt = tmp_path / f"model_{len(want)}.pt"
        torch.save({"actor_state_dict": {}, "iter": 3, "infos": {"config": stored}}, ckpt)
        a = train_cli.TrainArgs(log_dir=tmp_path, resume=ckpt)
        train_cli.validate(a)
        assert a.recipe == want, stored
    a = train_cli.TrainArgs(log_dir=tmp_path, resume=ckpt, recipe="walk")
    train_cli.validate(a)
    assert a.recipe == "walk"   # said explicitly, it wins
    _, _, record = train_cli.configs(train_cli.TrainArgs(variant="clock_free"))
    assert record["name"] == "walk" and "gait.swing_feedforward" in record["not_used"]
    assert not any(k.startswith("gait.") for k in record["overrides"])
    assert "without gait.alpha" in recipes.describe("walk", uses_clock=False) and "no clock" in recipes.describe(
        "walk", uses_clock=False)
    assert recipes.describe("walk") == "walk"


# the recipe each shipped policy's card names (walk unless listed): its run may have given the same settings as
# --override items (rough_walk_v1's and v2's campaign ran walk plus overrides from before the climb recipe existed)
RECIPE_OF = {"rough_walk_v1": "climb", "rough_walk_v2": "climb"}


@pytest.mark.parametrize("policy", SHIPPED, ids=[p.name for p in SHIPPED])
def test_its_recipe_reproduces_each_shipped_policys_env_settings(policy):
    """The shipped policy's stored env config against `cra-train --recipe R --task <its task>` (R: RECIPE_OF):
    every setting the stored file has, but what is the run's own (robots, seed, device, simulator), is the same."""
    stored = json.loads((policy / "config.json").read_text())
    recipe = RECIPE_OF.get(policy.name, "walk")
    now = flatten(to_data(resolved(recipe=recipe, task=stored["args"]["task"])))
    then = flatten(stored_env(stored))
    # the run's own, and the fall rule, fixed after they shipped (they trained with "base": envs/checkpoints.PREDATED)
    own = ("num_envs", "device", "seed", "world.", "fall_ground")
    differ = {k: (then[k], now.get(k)) for k in then if not k.startswith(own) and then[k] != now.get(k)}
    assert not differ, differ
    overrides, _ = recipes.resolve(recipe, stored["args"]["task"])
    assert all(then[k] == v for k, v in overrides.items())


def test_paper_is_table_i_and_the_papers_clock():
    cfg = resolved(recipe="paper")
    w = cfg.rewards.weights
    for term, weight in PAPER_TABLE_I.items():
        # body_height: the one Table I number we do not take as printed (a penalty on its squared error)
        assert w[term] == (-weight if term == "body_height" else weight), term
    assert set(w) - set(PAPER_TABLE_I) == set(recipes.BEYOND_TABLE_I)
    assert all(w[t] == 0.0 for t in recipes.BEYOND_TABLE_I)
    g = cfg.gait
    assert g.psi == 0.5 and g.alpha == 0.5 and g.beta_scale == 1.0 and not g.random_start_phase
    assert g.swing_feedforward == g.stride_feedforward == g.lateral_feedforward == g.turn_feedforward == 0.0
    # and the dataclass defaults are the paper's: the recipe changes nothing the CLI builds
    base = flatten(to_data(LocoConfig()))
    assert all(base[k] == v for k, v in recipes.resolve("paper", "flat")[0].items())


def test_an_unknown_recipe_is_one_line(capsys):
    one_line_error(capsys, train_cli.main(["--recipe", "magic"]), "--recipe")
    with pytest.raises(KeyError, match="paper, walk"):
        recipes.resolve("magic", "flat")


def test_no_curriculum_drops_the_recipes_curriculum_settings():
    cfg = resolved(recipe="walk", curriculum=False)
    assert not cfg.difficulty.commands and not cfg.difficulty.randomization and cfg.gait.alpha == 5.0


def test_climb_is_walk_on_flat_ground_and_each_key_it_adds_is_a_documented_departure():
    assert recipes.resolve("climb", "flat") == recipes.resolve("walk", "flat")
    walk, _ = recipes.resolve("walk", "rough")
    climb, _ = recipes.resolve("climb", "rough")
    assert all(climb[k] == v for k, v in walk.items())
    added = set(climb) - set(walk)
    assert {"terrain_curriculum", "commands.pit_fall_line", "rewards.weights.yaw_bias"} <= added
    rows = [line for line in (Path(__file__).resolve().parents[2] / "docs" / "paper.md").read_text().splitlines()
            if line.startswith("| ") and "climb:" in line]
    undocumented = [k for k in added if not any(f"`{k}`" in r for r in rows)]
    assert not undocumented, undocumented
    cfg = resolved(recipe="climb", task="rough")
    assert cfg.terrain_curriculum == "reach" and cfg.commands.pit_fall_line and cfg.rewards.weights["yaw_bias"] == -30

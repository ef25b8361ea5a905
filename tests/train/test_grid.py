"""cra-grid: the plan skips finished runs and resumes unfinished ones; a tiny grid runs end to end (train, the
paper's protocol, figures, table) and a second call redoes nothing."""

from __future__ import annotations

import json

import pytest

from tests.conftest import one_line_error
from train import grid


def test_plan_skips_done_runs_and_resumes_the_rest(tmp_path):
    a = grid.GridArgs(methods=("ours", "dwl"), seeds=(1,), out=tmp_path, iterations=3)
    fresh = grid.plan(a)
    assert all(j["cmd"] and "--resume" not in j["cmd"] for j in fresh)
    assert fresh[0]["cmd"][fresh[0]["cmd"].index("--max-iterations") + 1] == "3"
    (tmp_path / "train" / "ours-s1" / "rough_ours_x").mkdir(parents=True)
    (tmp_path / "train" / "ours-s1" / "rough_ours_x" / "model_0.pt").write_bytes(b"")
    (tmp_path / "train" / "dwl-s1" / "rough_dwl_x").mkdir(parents=True)
    (tmp_path / "train" / "dwl-s1" / "rough_dwl_x" / "model_2.pt").write_bytes(b"")
    ours, dwl = grid.plan(a)
    assert ours["cmd"][ours["cmd"].index("--max-iterations") + 1] == "2" and "--resume" in ours["cmd"]
    assert dwl["cmd"] is None and dwl["final"].name == "model_2.pt"


def test_the_grid_says_which_recipe_each_method_ran(tmp_path):
    """Every run gets the grid's recipe; a method that cannot use part of it (clock_free: no clock) is told so."""
    a = grid.GridArgs(methods=("ours", "clock_free"), seeds=(1,), out=tmp_path, recipe="paper")
    ours, free = grid.plan(a)
    for j in (ours, free):
        assert j["cmd"][j["cmd"].index("--recipe") + 1] == "paper"
    assert ours["recipe"] == "paper"
    lines = []
    grid.run(grid.GridArgs(methods=("ours", "clock_free"), seeds=(1,), out=tmp_path, dry_run=True), log=lines.append)
    said = {line.split()[0]: line for line in lines if " recipe " in line}
    assert said["ours"].split()[-1] == "walk"
    assert "walk without" in said["clock_free"] and "gait.swing_feedforward" in said["clock_free"]
    assert "no clock" in said["clock_free"]
    assert "fair pair of clock_free" in said["ours_as_clock_free"]


def test_a_method_that_cannot_use_the_recipe_gets_its_fair_pair(tmp_path):
    """clock_free under walk trains without the clock's settings; the grid also trains ours without them (its
    fair pair), labelled apart in the evaluation records; under paper the pair would be ours itself, so none."""
    import json

    a = grid.GridArgs(methods=("ours", "clock_free"), seeds=(1,), out=tmp_path, recipe="walk")
    jobs = {j["method"]: j for j in grid.plan(a)}
    assert set(jobs) == {"ours", "clock_free", "ours_as_clock_free"}
    pair = jobs["ours_as_clock_free"]["cmd"]
    assert pair[pair.index("--method") + 1] == "ours" and pair[pair.index("--recipe") + 1] == "walk"
    over = pair[pair.index("--override") + 1:]
    assert "gait.swing_feedforward=0.0" in over and "gait.alpha=0.5" in over and "gait.beta_scale=1.0" in over
    assert not any(k.startswith("rewards.") for k in over)   # the rest of the recipe is the same for both
    assert "--override" not in jobs["ours"]["cmd"]
    # the pair's overrides reach the config cra-train builds: ours with the clock's recipe keys at the defaults
    from train import train as train_cli

    cfg, _, _ = train_cli.configs(train_cli.TrainArgs(task="rough", variant="ours", recipe="walk",
                                                         override=tuple(over)))
    assert cfg.gait.stride_feedforward == 0.0 and cfg.rewards.weights["lin_vel_tracking"] == 9.0
    assert [j["method"] for j in grid.plan(grid.GridArgs(methods=("ours", "clock_free"), seeds=(1,), out=tmp_path,
                                                         recipe="paper"))] == ["ours", "clock_free"]
    assert "ours_as_clock_free" not in grid.labels(grid.GridArgs(methods=("clock_free",), fair_pairs=False))
    path = tmp_path / "e.json"
    path.write_text(json.dumps([{"method": "ours", "success_rate": 0.5}]))
    grid.relabel(path, "ours_as_clock_free")
    assert json.loads(path.read_text()) == [{"method": "ours_as_clock_free", "success_rate": 0.5}]


def test_the_clock_free_methods_share_one_fair_pair(tmp_path):
    """clock_free and dreamwaq_clock_free leave out the same recipe keys: one ours_as_clock_free stands beside both
    (not a second, identical run), and beside dreamwaq_clock_free alone; dwl_fixed_cycle has a clock and needs none."""
    a = grid.GridArgs(methods=("clock_free", "dreamwaq_clock_free", "dwl_fixed_cycle"), seeds=(1,), out=tmp_path)
    assert grid.labels(a) == {"clock_free": "clock_free", "dreamwaq_clock_free": "dreamwaq_clock_free",
                              "dwl_fixed_cycle": "dwl_fixed_cycle", "ours_as_clock_free": "ours"}
    assert "fair pair of clock_free, dreamwaq_clock_free" in grid.recipe_of(a, "ours_as_clock_free")
    alone = grid.GridArgs(methods=("dreamwaq_clock_free",), seeds=(1,), out=tmp_path)
    jobs = {j["method"]: j["cmd"] for j in grid.plan(alone)}
    assert set(jobs) == {"dreamwaq_clock_free", "ours_as_clock_free"}
    pair = jobs["ours_as_clock_free"]
    assert pair[pair.index("--method") + 1] == "ours" and "gait.swing_feedforward=0.0" in pair
    assert jobs["dreamwaq_clock_free"][jobs["dreamwaq_clock_free"].index("--method") + 1] == "dreamwaq_clock_free"


def test_grid_rejects_bad_values(capsys, tmp_path):
    one_line_error(capsys, grid.main(["--recipe", "magic", "--out", str(tmp_path)]), "--recipe")
    one_line_error(capsys, grid.main(["--scale", "tpu"]), "--scale")
    one_line_error(capsys, grid.main(["--methods", "magic"]), "--methods")
    one_line_error(capsys, grid.main(["--iterations", "0", "--out", str(tmp_path)]), "--iterations")


@pytest.mark.slow
def test_a_tiny_grid_runs_end_to_end_and_resumes(tmp_path, capsys):
    # 8 iterations: long enough for the first falls, when a run first logs its terrain level
    args = ["--methods", "ours", "dwl", "--seeds", "1", "--iterations", "8", "--num-envs", "4", "--parallel", "1",
            "--out", str(tmp_path), "--eval-args=--robots-per-level 1 --speeds 1.0 --ablation-robots 1 --sim mujoco"]
    assert grid.main(args) == 0
    started = [line.split(" (pid")[0] for line in capsys.readouterr().out.splitlines() if " (pid" in line]
    # each run is evaluated as soon as its training ends, before the next training takes the slot
    assert started == ["training ours seed 1", "evaluating ours seed 1", "training dwl seed 1",
                       "evaluating dwl seed 1"], started
    for m in ("ours", "dwl"):
        records = json.loads((tmp_path / "eval" / f"{m}-s1.json").read_text())
        assert {r["protocol"] for r in records} == {"speed_sweep", "ablation"} and {r["method"] for r in records} == {m}
    for name in grid.FIGURES:
        assert (tmp_path / "figures" / f"{name}.png").is_file()
    table = json.loads((tmp_path / "table.json").read_text())
    assert {m["method"] for m in table["seed_means"]} == {"ours", "dwl"}
    assert set(table["methods"]) == {"ours", "dwl"} and all(m["seeds"] == 1 for m in table["methods"].values())
    assert table["recipes"] == {"ours": "walk", "dwl": "walk"}
    assert (tmp_path / "table.csv").read_text().startswith("table,")
    lines = []
    grid.run(grid.GridArgs(methods=("ours", "dwl"), seeds=(1,), iterations=8, num_envs=4, parallel=1, out=tmp_path,
                           eval_args="--robots-per-level 1 --speeds 1.0 --ablation-robots 1 --sim mujoco"),
             log=lines.append)
    assert not any(line.startswith("training") for line in lines)
    assert sum("up to date" in line for line in lines) == 3, lines   # two evaluations, the figures
    assert any(line.strip().startswith("dwl ") and "falls" in line for line in lines), lines  # the table, again

"""cra-figures draws the paper's four figures from small synthetic logs and results, and from a real stairs
rollout of a freshly trained checkpoint."""

from __future__ import annotations

import json

import pytest

from tests.conftest import one_line_error
from tools import figures


def write_levels(run_dir, values):
    from torch.utils.tensorboard import SummaryWriter

    w = SummaryWriter(str(run_dir))
    for it, v in enumerate(values):
        w.add_scalar(figures.LEVEL_TAG, v, it)
    w.close()


def eval_records():
    """Two methods x two seeds: a speed sweep and the 0.15 m/s ablation on two levels of stairs and slopes."""
    recs = []
    for method, base in (("ours", 0.9), ("dwl", 0.6)):
        for seed in (1, 2):
            pol = f"{method}-s{seed}/model.pt"
            for speed in (0.15, 0.5, 1.0):
                for lv in range(2):
                    recs.append({"policy": pol, "method": method, "train_seed": seed, "protocol": "speed_sweep",
                                 "speed": speed, "kind": "uneven", "level": lv, "difficulty": 0.05 * (lv + 1),
                                 "success_rate": base - 0.2 * speed - 0.05 * seed})
            for kind, d in (("stairs_ascend", (0.05, 0.10)), ("slope_ascend", (2.0, 7.3))):
                for lv in range(2):
                    recs.append({"policy": pol, "method": method, "train_seed": seed, "protocol": "ablation",
                                 "speed": 0.15, "kind": kind, "level": lv, "difficulty": d[lv], "robots": 10,
                                 "success_rate": base - 0.1 * lv})
    return recs


def test_figures_from_synthetic_logs_and_results(tmp_path, capsys):
    runs = []
    for method, slope in (("ours", 0.02), ("dwl", 0.01)):
        dirs = []
        for seed in (1, 2):
            d = tmp_path / f"{method}-s{seed}"
            write_levels(d, [slope * it * seed for it in range(20)])
            dirs.append(str(d))
        runs.append(f"{method}={','.join(dirs)}")
    (tmp_path / "eval.json").write_text(json.dumps(eval_records()))
    out = tmp_path / "fig"
    assert figures.main(["--runs", *runs, "--eval", str(tmp_path / "eval.json"), "--out", str(out)]) == 0
    assert "skipped torque_velocity" in capsys.readouterr().out
    for name in ("terrain_level", "success_vs_speed", "success_vs_terrain"):
        assert (out / f"{name}.png").stat().st_size > 10_000 and (out / f"{name}.json").is_file()
    speed = json.loads((out / "success_vs_speed.json").read_text())
    assert list(speed) == ["ours", "dwl"]   # the registry's order (as the grid's --runs): a method keeps its colour
    # ours at 0.5 m/s: seeds 0.9 - 0.1 - 0.05 = 0.75 and 0.70 -> mean 72.5 %, population std 2.5 %
    i = speed["ours"]["x"].index(0.5)
    assert speed["ours"]["mean"][i] == pytest.approx(72.5) and speed["ours"]["std"][i] == pytest.approx(2.5)
    terrain = json.loads((out / "success_vs_terrain.json").read_text())
    assert terrain["stairs_ascend"]["dwl"]["x"] == pytest.approx([5.0, 10.0])   # cm
    assert terrain["slope_ascend"]["ours"]["mean"] == pytest.approx([90.0, 80.0])
    # each point's robots over both seeds (10 each) and the Wilson interval of their pooled successes (9 + 9 of 20)
    from envs.evaluation import wilson

    assert terrain["slope_ascend"]["ours"]["robots"] == [20, 20]
    assert terrain["slope_ascend"]["ours"]["ci95"][0] == pytest.approx([100 * v for v in wilson(18, 20)])
    assert "ci95" not in speed["ours"]   # the sweep's records here give no robot count: no interval
    levels = json.loads((out / "terrain_level.json").read_text())
    assert len(levels["dwl"]) == 2 and levels["dwl"][1][19] == pytest.approx([19, 0.38])


def test_figures_reject_bad_input(tmp_path, capsys):
    one_line_error(capsys, figures.main(["--out", str(tmp_path)]), "nothing to draw")
    (tmp_path / "bad.json").write_text("{not json")
    one_line_error(capsys, figures.main(["--eval", str(tmp_path / "bad.json"), "--out", str(tmp_path)]), "bad.json")
    write_levels(tmp_path / "flat", [])
    one_line_error(capsys, figures.main(["--runs", f"ours={tmp_path / 'flat'}", "--out", str(tmp_path)]), "ours")


def test_torque_velocity_scatter_of_a_policy_climbing_stairs(tmp_path):
    """A 1-iteration policy on the stairs: leg joints only, both sides, and the torques within the drives' limits."""
    from robots.adam_lite import ADAM_LITE as R
    from train import train as train_cli

    assert train_cli.main(["--num-envs", "4", "--max-iterations", "1", "--sim", "mujoco", "--no-export",
                           "--log-dir", str(tmp_path), "--quiet"]) == 0
    ckpt = next(tmp_path.glob("*/model_0.pt"))
    samples = figures.record_stairs(ckpt, robots=1, speed=1.0, sim="mujoco", level=0)
    assert set(samples) == {f"{j}_{s}" for j in figures.LEG_JOINTS for s in ("Left", "Right")}
    limit = dict(zip(R.joint_names, R.effort_limit))
    for name, s in samples.items():
        assert len(s["qd"]) == len(s["tau"]) > 0
        assert max(abs(t) for t in s["tau"]) <= limit[name] + 1e-3
    figures.torque_velocity(samples, tmp_path / "tv.png", "test")
    assert (tmp_path / "tv.png").stat().st_size > 10_000

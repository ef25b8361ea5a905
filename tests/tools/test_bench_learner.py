"""cra-bench-learner: --profile's printing (records with the update's FLOP floor and older records without it), the
progress line it reads."""

from __future__ import annotations

import json
from pathlib import Path

from tools.bench_learner import matmul_peak_gflops, print_profile, print_ratio_table

ROOT = Path(__file__).resolve().parents[2]


def _record(**extra) -> dict:
    seconds = {"collect_s": 1.0, "update_s": 1.5, "physics": 0.7, "returns": 0.15, "update_backward": 0.7}
    return {"terrain": "flat", "num_envs": 256, "threads": 1, "bf16": True, "seconds": seconds,
            "env_steps_per_s": 2458.0, "env_steps_per_wall_s": 2400.0, "task_alone_env_steps_per_s": 9000.0,
            "task_env_steps_per_s": 7000.0, "ratio": 0.27, **extra}


def test_profile_prints_the_floor_and_old_records(capsys):
    new = _record(update_gflop=118.0, update_gflops=95.0, matmul_peak_gflops=200.0, update_floor_s=0.59,
                  ratio_at_matmul_peak=0.41)
    print_profile(new)
    print_ratio_table([new, _record()], {"model": "test CPU", "flags": ["avx2"]})
    out = capsys.readouterr().out
    assert "118 GFLOP at 95 GFLOP/s, 48% of the 200 GFLOP/s matmul peak (floor 0.59 s)" in out
    rows = [line.split() for line in out.splitlines() if line.strip().startswith("flat")]
    assert rows[0][-2:] == ["0.27", "0.41"] and rows[1][-1] == "nan"  # the committed JSONs predate the floor


def test_matmul_peak_on_the_process_clock():
    import time

    assert matmul_peak_gflops(1, n=256, repeats=2, clock=time.process_time) > 0.0


def test_committed_profiles_carry_the_cpu():
    for path in sorted((ROOT / "tools" / "results").glob("bench_learner_profile_*.json")):
        data = json.loads(path.read_text())
        assert data["cpu"]["model"] and data["cpu"]["flags"], path.name


def test_learner_bench_reads_the_progress_line(capsys):
    """cra-bench-learner parses cra-train's progress lines: the format and the parser must agree."""
    import types

    from tools.bench_learner import PROGRESS
    from cra_warp.learning.runner import CraRunner

    fake = types.SimpleNamespace(_t0=0.0)
    CraRunner._progress(fake, {"it": 4, "env_steps_per_s": 948.2, "collect_s": 12.8, "update_s": 13.15,
                               "reward": 3.0, "episode_s": 1.0}, 0, 10)
    m = PROGRESS.search(capsys.readouterr().out)
    assert m and m.groups() == ("5", "948", "12.8", "13.2")


def test_end_to_end_table_scales_against_one_core(capsys):
    from tools.bench_learner import print_table

    row = dict(kind="end_to_end", sim="mujoco", bf16=True, num_envs_per_process=256, collect_s=0.8, update_s=1.6)
    print_table([{**row, "processes": 1, "env_steps_per_s": 2600.0},
                 {**row, "processes": 2, "env_steps_per_s": 4732.0}])
    rows = [line.split() for line in capsys.readouterr().out.splitlines() if line.strip().startswith("mujoco")]
    assert [r[2:5] for r in rows] == [["1", "2600", "1.00"], ["2", "4732", "1.82"]]


def test_end_to_end_needs_a_core_per_process(monkeypatch):
    import os

    import pytest

    from tools.bench_learner import end_to_end

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
    with pytest.raises(RuntimeError, match="2 processes need 2 cores"):
        end_to_end(256, 2, processes=2, sim="mujoco")

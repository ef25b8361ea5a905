"""cra-bench (tools/bench.py): bad input is one stderr line and exit code 2 before anything runs, and a tiny real run
writes the records it prints (N as asked, env-steps/s, the standing fraction, the Newton start time)."""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _bench(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    # a fresh process, as the command runs: cra-bench sets the process's malloc tuning (keep_freed_memory)
    return subprocess.run([sys.executable, "-m", "tools.bench", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)


@pytest.mark.parametrize("args, word", [
    (["--num-envs", "3"], "--num-envs"),
    (["--num-envs", "0", "64"], "--num-envs"),
    (["--engines", "bogus"], "--engines"),
    (["--terrain", "hills"], "--terrain"),
    (["--parallel", "0"], "--parallel"),
    (["--seconds", "nan"], "--seconds"),
    (["--seconds", "-1"], "--seconds"),
    (["--min-steps", "0"], "--min-steps"),
    (["--warmup", "-1"], "--warmup"),
    (["--json", "/nonexistent/dir/bench.json"], "no such directory"),
    (["--device", "tpu"], "--device"),
])
def test_bad_input_is_one_line_and_exit_2(args, word):
    r = _bench(*args)
    err = r.stderr.strip()
    assert r.returncode == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err and err.startswith("cra-bench: error:"), err
    assert word in err, err
    assert r.stdout == ""  # refused before measuring anything


@pytest.mark.slow  # the run always times a Newton world of 1024 robots starting (~15-40 s on a loaded CPU)
def test_a_tiny_run_writes_what_it_measured(tmp_path):
    out = tmp_path / "bench.json"
    r = _bench("--engines", "task_mujoco", "--terrain", "flat", "--num-envs", "2", "--parallel", "1",
               "--seconds", "0", "--min-steps", "2", "--warmup", "1", "--no-cold", "--no-learner", "--json", str(out),
               timeout=600)
    assert r.returncode == 0, r.stderr
    records = json.loads(out.read_text())
    (task,) = [rec for rec in records if rec["engine"] == "task_mujoco"]
    assert task["num_envs"] == 2 and task["threads"] == 1 and task["terrain"] == "flat"
    assert math.isfinite(task["env_steps_per_s"]) and task["env_steps_per_s"] > 0
    assert math.isfinite(task["peak_rss_mb"]) and task["peak_rss_mb"] > 0
    assert task["standing"] == 1.0  # the scripted stand holds both robots for the few steps measured
    assert math.isfinite(task["overhead_vs_sim"]) and task["overhead_vs_sim"] > 0
    (start,) = [rec for rec in records if rec.get("kind") == "start"]
    assert start["cold_start_s"] is None and start["warm_start_s"] > 0  # --no-cold: not measured, JSON null
    assert not any(rec["engine"] in ("learner", "height_maps") for rec in records)  # --no-learner
    assert all(rec["cpu"]["model"] and "torch_isa" in rec["cpu"] for rec in records)  # the machine, every record
    assert "task_mujoco x1 flat N=2:" in r.stdout and f"wrote {out}" in r.stdout

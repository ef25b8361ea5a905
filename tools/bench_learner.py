"""cra-bench-learner: the PPO learner's levers on this machine, and training end to end in 1 and 2 processes.

    cra-bench-learner                       # levers at N=1024, then cra-train end to end (~15 min on 2 cores)
    cra-bench-learner --num-envs 256 --no-end-to-end --json levers.json

Levers (free dummy env, so the learner alone is timed; one fresh process per row): torch threads, PPO epochs x
mini-batches, rsl-rl's torch_compile_mode, the contrast variant, the critic CNN's strides, the update's precision
(fp32, or bf16 autocast: --bf16). Each row: rollout inference (collect) and update seconds per iteration, the
update's achieved GFLOP/s and its share of this CPU's matmul peak in that precision (measured here once per thread
count and precision). End to end: cra-train on the flat task, 1 process with N envs and 2 processes (torchrun,
gloo) with N/2 each, on Newton in fp32 and on MuJoCo C with bf16, env-steps/s and collect/update seconds per
iteration from the runner's progress lines.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cra_warp.atomic_json import write_json

# (threads, epochs, mini-batches, compile mode, contrast variant, critic CNN strides, precision); the first row is
# the default
LEVERS = [
    (2, 5, 4, None, "same_step", (1, 2), "fp32"),
    (1, 5, 4, None, "same_step", (1, 2), "fp32"),
    (2, 5, 2, None, "same_step", (1, 2), "fp32"),
    (2, 5, 8, None, "same_step", (1, 2), "fp32"),
    (2, 3, 4, None, "same_step", (1, 2), "fp32"),
    (2, 5, 4, "default", "same_step", (1, 2), "fp32"),
    (2, 5, 4, None, "none", (1, 2), "fp32"),
    (2, 5, 4, None, "same_step", (2, 1), "fp32"),  # downsample first: a 3.4x smaller conv activation
    (2, 5, 4, None, "same_step", (1, 2), "bf16"),
    (1, 5, 4, None, "same_step", (1, 2), "bf16"),
    (2, 3, 4, None, "same_step", (1, 2), "bf16"),
]
PROGRESS = re.compile(r"it (\d+)/\d+ \|\s+(\d+) env-steps/s \| collect ([\d.]+)s update ([\d.]+)s")


def matmul_peak_gflops(threads: int, n: int = 2048, repeats: int = 10, precision: str = "fp32") -> float:
    """Best GFLOP/s of an n x n matmul on ``threads`` torch threads in ``precision`` (fp32 or bf16)."""
    import torch

    torch.set_num_threads(threads)
    dtype = torch.bfloat16 if precision == "bf16" else torch.float32
    a, b = torch.randn(n, n, dtype=dtype), torch.randn(n, n, dtype=dtype)
    a @ b
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        a @ b
        best = min(best, time.perf_counter() - t0)
    return 2 * n**3 / best / 1e9


def _lever_worker(spec: dict) -> dict:
    from cra_warp.host_memory import keep_freed_memory
    from cra_warp.learning.bench import learner_benchmark
    from cra_warp.learning.config import LearnerConfig

    keep_freed_memory()
    cfg = LearnerConfig(torch_compile_mode=spec["compile"])
    cfg.ppo.num_learning_epochs, cfg.ppo.num_mini_batches = spec["epochs"], spec["mini_batches"]
    cfg.critic.cnn_stride = tuple(spec["cnn_stride"])
    cfg.ppo.use_mixed_precision = spec["precision"] == "bf16"
    rec = learner_benchmark(spec["num_envs"], threads=spec["threads"], variant=spec["variant"], learner_cfg=cfg)
    rec["compile"], rec["cnn_stride"], rec["precision"] = spec["compile"], list(cfg.critic.cnn_stride), spec["precision"]
    return {"kind": "lever", **rec}


def levers(num_envs: int) -> list[dict]:
    # one peak per thread count, measured before the rows (best of 30): a peak taken per row moved with the
    # machine's neighbours (134-180 GFLOP/s seen on 2 threads) and made the shares incomparable
    peaks = {(t, pr): matmul_peak_gflops(t, repeats=30, precision=pr) for t, pr in
             sorted({(row[0], row[6]) for row in LEVERS})}
    print("  matmul peak: " + ", ".join(f"{p:.0f} GFLOP/s {pr} on {t} thread(s)" for (t, pr), p in peaks.items()))
    out = []
    for threads, epochs, mb, compile_mode, variant, cnn_stride, precision in LEVERS:
        spec = dict(num_envs=num_envs, threads=threads, epochs=epochs, mini_batches=mb, compile=compile_mode,
                    variant=variant, cnn_stride=cnn_stride, precision=precision)
        proc = subprocess.run([sys.executable, "-m", "tools.bench_learner", "--worker", json.dumps(spec)],
                              capture_output=True, text=True)
        if proc.returncode:
            raise RuntimeError(f"lever worker {spec} failed: {proc.stderr.strip().splitlines()[-1:]}")
        rec = json.loads(proc.stdout.strip().splitlines()[-1])
        rec["matmul_peak_gflops"] = peaks[(threads, precision)]
        rec["peak_share"] = rec["update_gflops"] / peaks[(threads, precision)]
        out.append(rec)
        print(f"  {_lever_name(rec)}: collect {rec['collect_s']:.2f} s, update {rec['update_s']:.2f} s, "
              f"{rec['update_gflops']:.0f} GFLOP/s ({100 * rec['peak_share']:.0f}% of peak)", flush=True)
    return out


def _lever_name(r: dict) -> str:
    return (f"{r['threads']}t {r['epochs']}x{r['mini_batches']} compile={r['compile'] or 'off'} "
            f"contrast={r['variant']} cnn={','.join(map(str, r.get('cnn_stride', (1, 2))))} "
            f"{r.get('precision', 'fp32')}")


def end_to_end(num_envs: int, iterations: int, processes: int, sim: str = "newton", bf16: bool = False) -> dict:
    """cra-train flat for ``iterations``; the first iteration (warm-up) is left out of the means."""
    with tempfile.TemporaryDirectory() as logs:
        args = ["--num-envs", str(num_envs // processes), "--max-iterations", str(iterations), "--log-dir", logs,
                "--no-export", "--save-interval", str(10**6), "--sim", sim, "--bf16" if bf16 else "--no-bf16"]
        if processes == 1:
            cmd = [sys.executable, "-m", "train.train", *args]
        else:
            cmd = [sys.executable, "-m", "torch.distributed.run", "--nproc-per-node", str(processes),
                   "-m", "train.train", *args]
        proc = subprocess.run(cmd, capture_output=True, text=True)
    rows = [tuple(float(g) for g in m.groups()) for m in PROGRESS.finditer(proc.stdout)]
    if proc.returncode or len(rows) < 2:
        raise RuntimeError(f"cra-train x{processes} failed: {proc.stderr.strip().splitlines()[-1:]}")
    rows = rows[1:]
    mean = lambda k: sum(r[k] for r in rows) / len(rows)  # noqa: E731
    return {"kind": "end_to_end", "processes": processes, "sim": sim, "bf16": bf16, "num_envs": num_envs,
            "iterations": len(rows),
            "env_steps_per_s": mean(1), "collect_s": mean(2), "update_s": mean(3)}


def print_table(records: list[dict]) -> None:
    lev = [r for r in records if r["kind"] == "lever"]
    if lev:
        base = lev[0]["update_s"]
        print(f"\nlearner levers, N={lev[0]['num_envs']}, 24 steps per env (free dummy env)")
        print(f"{'setting':59} {'collect s':>9} {'update s':>9} {'vs default':>10} {'GFLOP/s':>8} {'% peak':>7}")
        for r in lev:
            print(f"{_lever_name(r):59} {r['collect_s']:9.2f} {r['update_s']:9.2f} {r['update_s'] / base:10.2f} "
                  f"{r['update_gflops']:8.0f} {100 * r['peak_share']:7.0f}")
    e2e = [r for r in records if r["kind"] == "end_to_end"]
    if e2e:
        print(f"\ncra-train end to end, flat task, N={e2e[0]['num_envs']} in total")
        print(f"{'sim':>7} {'update':>6} {'processes':>9} {'env-steps/s':>12} {'collect s':>10} {'update s':>9}")
        for r in e2e:
            print(f"{r['sim']:>7} {'bf16' if r['bf16'] else 'fp32':>6} {r['processes']:9d} {r['env_steps_per_s']:12.0f} "
                  f"{r['collect_s']:10.2f} {r['update_s']:9.2f}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="cra-bench-learner", description=__doc__.splitlines()[0])
    p.add_argument("--num-envs", type=int, default=1024)
    p.add_argument("--iterations", type=int, default=3, help="end-to-end training iterations (first is warm-up)")
    p.add_argument("--no-levers", action="store_true")
    p.add_argument("--no-end-to-end", action="store_true")
    p.add_argument("--json", type=Path, help="write the records to this file")
    p.add_argument("--worker", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        print(json.dumps(_lever_worker(json.loads(a.worker))))
        return 0
    if a.num_envs < 2 or a.num_envs % 8:
        p.error(f"--num-envs must be a multiple of 8 (8 mini-batches, 2 processes), got {a.num_envs}")
    if a.json is not None and not a.json.parent.is_dir():
        p.error(f"--json {a.json}: no such directory {a.json.parent}")
    if a.iterations < 2:
        p.error(f"--iterations must be >= 2 (the first is a warm-up), got {a.iterations}")
    os.environ.setdefault("OMP_NUM_THREADS", "1")  # torchrun's children: cra-train sets its own thread count
    records = [] if a.no_levers else levers(a.num_envs)
    if not a.no_end_to_end:
        for sim, bf16 in (("newton", False), ("mujoco", True)):
            for procs in (1, 2):
                records.append(end_to_end(a.num_envs, a.iterations, procs, sim, bf16))
                r = records[-1]
                print(f"  cra-train --sim {sim}{' --bf16' if bf16 else ''} x{procs}: {r['env_steps_per_s']:.0f} "
                      f"env-steps/s", flush=True)
    print_table(records)
    if a.json:
        write_json(a.json, records)
        print(f"wrote {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

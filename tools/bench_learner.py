"""cra-bench-learner: the PPO learner's levers on this machine, and training end to end in 1 and 2 processes.

    cra-bench-learner                       # levers at N=1024, then cra-train end to end (~15 min on 2 cores)
    cra-bench-learner --num-envs 256 --no-end-to-end --json levers.json

Levers (free dummy env, so the learner alone is timed; one fresh process per row): torch threads, PPO epochs x
mini-batches, rsl-rl's torch_compile_mode, the contrast variant, the critic CNN's strides, the update's precision
(fp32, or bf16 autocast: --bf16). Each row: rollout inference (collect) and update seconds per iteration, the
update's achieved GFLOP/s and its share of this CPU's matmul peak in that precision (measured here once per thread
count and precision). End to end: cra-train on the flat task with N envs per process, 1 process pinned to one core
and 2 processes (torchrun, gloo) on a core each, on Newton in fp32 and on MuJoCo C with bf16, env-steps/s, the
scaling over one core and collect/update seconds per iteration from the runner's progress lines. Every record
carries the CPU's model and precision flags.

    cra-bench-learner --profile --json tools/results/bench_learner_profile_<cpu>.json

--profile (issue 34): cra-train's own iteration on the real task (MuJoCo backend, one thread, N x terrain), each
part timed in CPU seconds by wrapping the method that does it (physics, task, actor and critic inference, the
returns with the batched critic, storage copies, the update's batches, forwards, contrast heads, backward and
optimizer), and the headline: end-to-end env-steps/s over the full task's own rate at the same N (scripted-stand
actions, as cra-bench's task_mujoco), both on the same clock. CPU seconds because the machine's cores are shared:
wall time would count the neighbours' turns (it is recorded beside). Each record also counts the update's FLOPs
(matmuls and convolutions, on the warm-up iteration) and this core's matmul peak in the update's precision: the
update's floor in seconds and the ratio the same math would reach with the update at that peak.
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
from cra_warp.machine import cpu_info

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


def matmul_peak_gflops(threads: int, n: int = 2048, repeats: int = 10, precision: str = "fp32",
                       clock=time.perf_counter) -> float:
    """Best GFLOP/s of an n x n matmul on ``threads`` torch threads in ``precision`` (fp32 or bf16); ``clock``
    time.process_time gives GFLOP per CPU second (one thread on a shared core)."""
    import torch

    torch.set_num_threads(threads)
    dtype = torch.bfloat16 if precision == "bf16" else torch.float32
    a, b = torch.randn(n, n, dtype=dtype), torch.randn(n, n, dtype=dtype)
    a @ b
    best = float("inf")
    for _ in range(repeats):
        t0 = clock()
        a @ b
        best = min(best, clock() - t0)
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
    """cra-train flat for ``iterations`` with ``num_envs`` robots per process, each process on a core of its own: one
    process pinned to the first core this one may use (the one-core baseline), or torchrun's ranks (cra-train pins
    each to its own core). The first iteration (warm-up) is left out of the means."""
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) < processes:
        raise RuntimeError(f"{processes} processes need {processes} cores, this process may use {len(allowed)}")
    with tempfile.TemporaryDirectory() as logs:
        args = ["--num-envs", str(num_envs), "--max-iterations", str(iterations), "--log-dir", logs,
                "--no-export", "--save-interval", str(10**6), "--sim", sim, "--bf16" if bf16 else "--no-bf16"]
        if processes == 1:
            cmd = [sys.executable, "-m", "train.train", *args]
        else:
            cmd = [sys.executable, "-m", "torch.distributed.run", "--nproc-per-node", str(processes),
                   "-m", "train.train", *args]
        one_core = (lambda: os.sched_setaffinity(0, allowed[:1])) if processes == 1 else None
        proc = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=one_core)
    rows = [tuple(float(g) for g in m.groups()) for m in PROGRESS.finditer(proc.stdout)]
    if proc.returncode or len(rows) < 2:
        raise RuntimeError(f"cra-train x{processes} failed: {proc.stderr.strip().splitlines()[-1:]}")
    rows = rows[1:]
    mean = lambda k: sum(r[k] for r in rows) / len(rows)  # noqa: E731
    return {"kind": "end_to_end", "cpu": cpu_info(), "processes": processes, "cores": processes, "sim": sim,
            "bf16": bf16, "num_envs_per_process": num_envs, "num_envs": num_envs * processes,
            "iterations": len(rows),
            "env_steps_per_s": mean(1), "collect_s": mean(2), "update_s": mean(3)}


# (part name, object attribute path, method) timed by the profile; "actor"/"critic" forwards are split into
# collection (inference mode) and update by where they run. Time inside env.step minus physics is the task.
PARTS = ("physics", "task", "actor_inference", "critic_inference", "returns", "copies", "update_batches",
         "update_actor_forward", "update_critic_forward", "contrast_heads", "update_backward", "update_optimizer",
         "normalizers")


def _profile_worker(spec: dict) -> dict:
    """cra-train's learner on the real task (MuJoCo backend, one thread), every part of an iteration timed by
    wrapping the method that does it; the first iteration is a warm-up."""
    import torch
    import rsl_rl.storage.rollout_storage as rs
    from rsl_rl.runners import OnPolicyRunner

    from cra_warp.host_memory import keep_freed_memory
    from cra_warp.learning.config import LearnerConfig, bf16_supported, runner_cfg
    from cra_warp.sim import WorldConfig
    from envs.loco_config import DifficultyConfig, LocoConfig
    from envs.locomotion import LocoEnv

    keep_freed_memory()
    clock = time.process_time  # CPU seconds: core 1 is shared, wall time would count the neighbours' turns
    torch.set_num_threads(spec["threads"])
    torch.manual_seed(spec["seed"])
    env = LocoEnv(LocoConfig(num_envs=spec["num_envs"], terrain=spec["terrain"], seed=spec["seed"],
                             world=WorldConfig(backend="mujoco", threads=spec["threads"]),
                             difficulty=DifficultyConfig(commands=True, randomization=True)))
    learner = LearnerConfig()
    learner.ppo.num_learning_epochs, learner.ppo.num_mini_batches = 2, 4
    learner.ppo.use_mixed_precision = spec["bf16"] and bf16_supported("cpu")
    learner.privileged_slices = {k: (env.priv_layout[name].start, env.priv_layout[name].stop)
                                 for k, name in (("velocity", "base_lin_vel"), ("observation", "actor"))}
    for k, v in spec.get("learner", {}).items():  # dotted overrides of the learner config
        *path, last = k.split(".")
        target = learner
        for name in path:
            target = getattr(target, name)
        setattr(target, last, v)
    runner = OnPolicyRunner(env, runner_cfg(learner), log_dir=None, device="cpu")
    alg = runner.alg
    acc = {k: 0.0 for k in PARTS}
    stats = {"trajectories": 0, "batches": 0}

    def timed(part, fn, pick=None):
        def wrapper(*args, **kwargs):
            t = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                name = pick() if pick else part
                acc[name] += clock() - t
        return wrapper

    in_update = lambda: torch.is_grad_enabled() and not torch.is_inference_mode_enabled()  # noqa: E731
    env.world.step = timed("physics", env.world.step)
    env_step = env.step

    def task_step(actions):
        p0, t = acc["physics"], clock()
        out = env_step(actions)
        acc["task"] += clock() - t - (acc["physics"] - p0)
        return out

    env.step = task_step
    for model, name in ((alg.actor, "actor"), (alg.critic, "critic")):
        model.forward = timed(None, model.forward,
                              lambda n=name: f"update_{n}_forward" if in_update() else f"{n}_inference")
    for obj, attr, part in ((alg, "compute_returns", "returns"), (alg.storage, "add_transition", "copies"),
                            (alg, "contrastive_loss", "contrast_heads"), (alg.optimizer, "step", "update_optimizer"),
                            (alg.actor, "update_normalization", "normalizers"),
                            (alg.critic, "update_normalization", "normalizers")):
        if hasattr(obj, attr):
            setattr(obj, attr, timed(part, getattr(obj, attr)))
    backward, clip = torch.Tensor.backward, torch.nn.utils.clip_grad_norm_
    torch.Tensor.backward = timed("update_backward", backward)
    torch.nn.utils.clip_grad_norm_ = timed("update_optimizer", clip)
    split = rs.split_and_pad_trajectories

    def counting_split(tensor, dones):
        out = split(tensor, dones)
        stats["trajectories"] += out[1].shape[1]
        stats["batches"] += 1
        return out

    rs.split_and_pad_trajectories = timed("update_batches", counting_split)
    for gen in ("recurrent_mini_batch_generator", "mini_batch_generator", "whole_env_mini_batches"):
        if hasattr(alg.storage, gen):
            orig = getattr(alg.storage, gen)

            def timed_gen(*a, _orig=orig, **kw):  # time spent building each batch, not the loop body
                it = _orig(*a, **kw)
                while True:
                    t = clock()
                    try:
                        b = next(it)
                    except StopIteration:
                        return
                    finally:
                        acc["update_batches"] += clock() - t
                    yield b
            setattr(alg.storage, gen, timed_gen)

    log = runner.logger.log
    iters: list[dict] = []
    marks = {"start": clock()}
    compute_returns = alg.compute_returns

    def marked_returns(*a, **kw):  # the runner calls it right after the rollout: the end of collection
        marks["collected"] = clock()
        return compute_returns(*a, **kw)

    alg.compute_returns = marked_returns
    # the FLOPs of one update (matmuls and convolutions, forward and backward), counted on the warm-up iteration
    # (left out of the medians): with this CPU's matmul peak they give the update's floor in seconds
    from torch.utils.flop_counter import FlopCounterMode

    update = alg.update

    def counted_update(*a, **kw):
        if "update_gflop" in flops:
            return update(*a, **kw)
        with FlopCounterMode(display=False) as counter:
            out = update(*a, **kw)
        flops["update_gflop"] = counter.get_total_flops() / 1e9
        return out

    flops: dict[str, float] = {}
    alg.update = counted_update

    def record(**kw):
        now = clock()
        iters.append({"collect_s": marks["collected"] - marks["start"], "update_s": now - marks["collected"],
                      "collect_wall_s": kw["collect_time"], "update_wall_s": kw["learn_time"], **dict(acc)})
        for k in acc:
            acc[k] = 0.0
        marks["start"] = clock()
    runner.logger.log = record
    try:
        runner.learn(spec["iterations"] + 1)
    finally:
        torch.Tensor.backward, torch.nn.utils.clip_grad_norm_ = backward, clip
        rs.split_and_pad_trajectories = split
        runner.logger.log = log
    iters = iters[1:]
    import statistics

    med = {k: statistics.median(r[k] for r in iters) for k in iters[0]}
    collect_parts = ("physics", "task", "actor_inference", "critic_inference", "copies")
    med["collect_other"] = med["collect_s"] - sum(med[k] for k in collect_parts)
    update_parts = ("update_batches", "update_actor_forward", "update_critic_forward", "contrast_heads",
                    "update_backward", "update_optimizer", "normalizers")
    med["update_other"] = med["update_s"] - med["returns"] - sum(med[k] for k in update_parts)
    steps = spec["num_envs"] * learner.num_steps_per_env
    total = med["collect_s"] + med["update_s"]
    rec = {"kind": "profile", "terrain": spec["terrain"], "num_envs": spec["num_envs"], "threads": spec["threads"],
           "bf16": learner.ppo.use_mixed_precision, "iterations": len(iters), "seconds": med,
           "share": {k: v / total for k, v in med.items() if not k.endswith("_s")},
           "env_steps_per_wall_s": steps / (med["collect_wall_s"] + med["update_wall_s"]),
           "env_steps_per_s": steps / total, "physics_env_steps_per_s": steps / med["physics"],
           "task_env_steps_per_s": steps / (med["physics"] + med["task"])}
    if stats["batches"]:
        rec["padded_trajectories_per_env"] = stats["trajectories"] / stats["batches"] / spec["num_envs"]
    # the full task's own rate at this N (cra-bench's task_mujoco: scripted-stand actions, no learner), on the same
    # clock as the parts above
    with torch.inference_mode():
        for _ in range(5):
            env.step(env.stand_actions())
        t, steps = clock(), 0
        while steps < 24 or clock() - t < 3.0:
            env.step(env.stand_actions())
            steps += 1
        rec["task_alone_env_steps_per_s"] = steps * spec["num_envs"] / (clock() - t)
    rec["ratio"] = rec["env_steps_per_s"] / rec["task_alone_env_steps_per_s"]
    # what the same math could reach: the update (after the returns) at this core's matmul peak in its precision,
    # the rest of the iteration as measured
    peak = matmul_peak_gflops(spec["threads"], repeats=10, precision="bf16" if rec["bf16"] else "fp32", clock=clock)
    gflop = flops.get("update_gflop", 0.0)
    update_work = med["update_s"] - med["returns"]
    floor = gflop / peak
    rec.update(update_gflop=gflop, update_gflops=gflop / update_work, matmul_peak_gflops=peak,
               update_floor_s=floor,
               ratio_at_matmul_peak=spec["num_envs"] * learner.num_steps_per_env / (med["collect_s"] + med["returns"] + floor)
               / rec["task_alone_env_steps_per_s"])
    if spec.get("torch_profile"):
        from torch.profiler import ProfilerActivity, profile

        with profile(activities=[ProfilerActivity.CPU]) as prof:
            runner.learn(1)
        ops = sorted(prof.key_averages(), key=lambda e: -e.self_cpu_time_total)[:25]
        rec["top_ops"] = [{"op": e.key, "self_s": e.self_cpu_time_total / 1e6, "calls": e.count} for e in ops]
    return rec


def profile(terrains, sizes, iterations: int, bf16: bool, torch_profile: bool, learner: dict | None = None) -> list:
    out = []
    for terrain in terrains:
        for n in sizes:
            spec = dict(terrain=terrain, num_envs=n, iterations=iterations, bf16=bf16, threads=1, seed=1,
                        torch_profile=torch_profile, learner=learner or {})
            proc = subprocess.run([sys.executable, "-m", "tools.bench_learner", "--worker", json.dumps(spec),
                                   "--worker-kind", "profile"], capture_output=True, text=True)
            if proc.returncode:
                raise RuntimeError(f"profile worker {terrain} N={n} failed: {proc.stderr.strip().splitlines()[-3:]}")
            rec = json.loads(proc.stdout.strip().splitlines()[-1])
            out.append(rec)
            print_profile(rec)
    return out


def print_ratio_table(records: list[dict], cpu: dict) -> None:
    """The headline: end-to-end training over the full task's own rate at the same N, one core."""
    print(f"\ncra-train end to end over the task alone, one core, MuJoCo backend, CPU seconds: {cpu['model']} "
          f"({' '.join(cpu['flags'])}; torch kernels {cpu.get('torch_isa', '?')})")
    print(f"{'terrain':>7} {'N':>5} {'update':>6} {'end to end':>10} {'task alone':>10} {'ratio':>6} {'at peak':>7}")
    for r in records:
        print(f"{r['terrain']:>7} {r['num_envs']:5d} {'bf16' if r['bf16'] else 'fp32':>6} "
              f"{r['env_steps_per_s']:10.0f} {r['task_alone_env_steps_per_s']:10.0f} {r['ratio']:6.2f} "
              f"{r.get('ratio_at_matmul_peak', float('nan')):7.2f}")


def print_profile(r: dict) -> None:
    s, total = r["seconds"], r["seconds"]["collect_s"] + r["seconds"]["update_s"]
    print(f"\nprofile {r['terrain']} N={r['num_envs']} ({'bf16' if r['bf16'] else 'fp32'} update, "
          f"{r['threads']} thread, CPU time): {r['env_steps_per_s']:.0f} env-steps/s end to end "
          f"({r['env_steps_per_wall_s']:.0f} by the wall clock); the task alone {r['task_alone_env_steps_per_s']:.0f} "
          f"(ratio {r['ratio']:.2f}), physics + task in training {r['task_env_steps_per_s']:.0f}"
          + (f", {r['padded_trajectories_per_env']:.2f} padded trajectories per env"
             if "padded_trajectories_per_env" in r else ""))
    for k, v in s.items():
        if not k.endswith("_s") and v > 0.0005:
            print(f"  {k:22} {v:7.3f} s {100 * v / total:5.1f}%")
    print(f"  {'collect / update':22} {s['collect_s']:.3f} / {s['update_s']:.3f} s")
    if "update_gflop" in r:
        print(f"  update: {r['update_gflop']:.0f} GFLOP at {r['update_gflops']:.0f} GFLOP/s, "
              f"{100 * r['update_gflops'] / r['matmul_peak_gflops']:.0f}% of the {r['matmul_peak_gflops']:.0f} GFLOP/s "
              f"matmul peak (floor {r['update_floor_s']:.2f} s); ratio with the update at that peak "
              f"{r['ratio_at_matmul_peak']:.2f}")
    for op in r.get("top_ops", [])[:12]:
        print(f"    {op['op'][:48]:48} {op['self_s']:7.3f} s {op['calls']:7d} calls")


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
        print(f"\ncra-train end to end, flat task, N={e2e[0]['num_envs_per_process']} per process, one core each")
        print(f"{'sim':>7} {'update':>6} {'cores':>5} {'env-steps/s':>12} {'x one core':>10} {'collect s':>10} "
              f"{'update s':>9}")
        one = {(r["sim"], r["bf16"]): r["env_steps_per_s"] for r in e2e if r["processes"] == 1}
        for r in e2e:
            base = one.get((r["sim"], r["bf16"]))
            print(f"{r['sim']:>7} {'bf16' if r['bf16'] else 'fp32':>6} {r['processes']:5d} {r['env_steps_per_s']:12.0f} "
                  f"{r['env_steps_per_s'] / base if base else float('nan'):10.2f} {r['collect_s']:10.2f} "
                  f"{r['update_s']:9.2f}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="cra-bench-learner", description=__doc__.splitlines()[0])
    p.add_argument("--num-envs", type=int, default=1024)
    p.add_argument("--iterations", type=int, default=3, help="end-to-end training iterations (first is warm-up)")
    p.add_argument("--no-levers", action="store_true")
    p.add_argument("--no-end-to-end", action="store_true")
    p.add_argument("--sims", nargs="+", default=["newton", "mujoco"], choices=["newton", "mujoco"],
                   help="end to end: the backends (Newton in fp32, MuJoCo C with bf16 where the CPU has it)")
    p.add_argument("--json", type=Path, help="write the records to this file")
    p.add_argument("--profile", action="store_true",
                   help="profile cra-train's iteration on the real task (MuJoCo, one thread) instead: --terrain x "
                        "--sizes, the time of every part (physics, task, inference, update parts)")
    p.add_argument("--terrain", nargs="+", default=["flat", "rough"], choices=["flat", "rough"])
    p.add_argument("--sizes", type=int, nargs="+", default=[256, 1024], help="--profile: N per run")
    p.add_argument("--no-bf16", action="store_true",
                   help="--profile and MuJoCo end to end: fp32 update even where bf16 is native")
    p.add_argument("--torch-profile", action="store_true", help="--profile: add torch.profiler's top ops")
    p.add_argument("--learner", default="{}", help="--profile: learner config overrides as JSON {dotted: value}")
    p.add_argument("--worker", help=argparse.SUPPRESS)
    p.add_argument("--worker-kind", default="lever", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        worker = _profile_worker if a.worker_kind == "profile" else _lever_worker
        print(json.dumps(worker(json.loads(a.worker))))
        return 0
    if a.profile:
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        records = profile(a.terrain, a.sizes, a.iterations, not a.no_bf16, a.torch_profile, json.loads(a.learner))
        print_ratio_table(records, cpu_info())
        if a.json:
            write_json(a.json, {"cpu": cpu_info(), "profiles": records}, indent=1)
            print(f"wrote {a.json}")
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
        for sim, bf16 in (("newton", False), ("mujoco", not a.no_bf16)):
            if sim not in a.sims:
                continue
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

"""cra-bench: throughput and memory of the Adam Lite world on both backends, and of the full task on both.

One env step = cfg.substeps x cfg.sim_dt (4 x 0.005 s = 0.02 s of sim time). Every configuration runs in a fresh
worker process, so its peak RSS is its own. Engines:
  newton       the Newton world (1 or 2 processes), robots held up by the scripted stand (cra_warp.stand)
  mujoco       the MuJoCo C backend (1 or 2 threads in one process), scripted stand
  rollout      bare mujoco.rollout on the same model with constant targets, no sensors or conversions (the floor
               of the MuJoCo backend's cost); every world restarts standing every HOLD_S, before its robot, on
               the robot's soft ankles, falls (a fallen robot's contacts are not the task's)
  task         the full locomotion env (obs, rewards, maps, resets) on Newton, scripted-stand actions
  task_mujoco  the same on the MuJoCo backend, 1 or 2 threads
Each record says which fraction of robots was still up at the end (pelvis within 15 cm of its spawn height,
upright). MuJoCo C runs the very model Newton builds (SolverMuJoCo's own MJCF export).

    cra-bench                                   # the full table (several minutes)
    cra-bench --num-envs 64 256 --no-cold       # a quick look
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cra_warp.atomic_json import write_json
from cra_warp.machine import cpu_info
from cra_warp.host_memory import keep_freed_memory

HOLD_S = 0.5       # [s] the bare rollout's robots restart standing this often (a zero action falls in ~1.3 s)
STAND_DROP = 0.15  # [m] a robot counts as standing while its pelvis is within this of the spawn height
TERRAINS = ("flat", "stairs", "rough")  # rough: the training course (897 boxes, per-world windows), level-0 tiles
ENGINES = ("newton", "mujoco", "rollout", "task", "task_mujoco")
THREADED = ("mujoco", "rollout", "task_mujoco")  # one process, --parallel threads; the others: --parallel processes


def stairs():
    """A straight staircase of box steps (0.15 m rise, 0.3 m tread, 2 m wide); the robot spawns on the third tread,
    its soles centred on it (the sole centre is ~3 cm ahead of the pelvis at the standing pose).

    Returns (TerrainBoxes, spawn ground height).
    """
    import numpy as np

    from cra_warp.sim import TerrainBoxes

    rise, tread, width, n = 0.15, 0.3, 2.0, 10
    k = np.arange(1, n + 1)
    heights = rise * k
    centers = np.stack([(k - 3) * tread + 0.03, np.zeros(n), heights / 2], 1)
    half = np.stack([np.full(n, tread / 2), np.full(n, width / 2), heights / 2], 1)
    return TerrainBoxes(centers, half), float(heights[2])


def rough(num_envs: int):
    """The default training terrain's boxes and, per robot, a level-0 tile origin [N, 3] (round-robin columns)."""
    from cra_warp.terrain import generate_terrain
    from cra_warp.terrain.boxes import terrain_boxes
    from cra_warp.terrain.curriculum import TerrainCurriculum

    terrain = generate_terrain()
    return terrain_boxes(terrain), TerrainCurriculum(terrain, num_envs).origins


def _peak_rss_mb() -> float:
    """Peak RSS of this process since exec. (ru_maxrss would carry the forking parent's high-water mark.)"""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _world_worker(spec: dict) -> dict:
    import torch

    from cra_warp.sim import WorldConfig, make_world
    from cra_warp.stand import ScriptedStand
    from robots.adam_lite import ADAM_LITE
    from robots.adam_lite.loco import ADAM_LITE_LOCO

    torch.set_num_threads(1)

    n = spec["num_envs"]
    if spec["terrain"] == "rough":
        terrain, origins = rough(n)
    else:
        terrain, ground = stairs() if spec["terrain"] == "stairs" else (None, 0.0)
        origins = torch.tensor([0.0, 0.0, ground]).repeat(n, 1)
    t0 = time.perf_counter()
    # stairs: shared boxes, the very model MuJoCo C runs; rough: per-world windows of the course, as training does
    window = {} if spec["terrain"] == "rough" else {"terrain_window": None}
    world = make_world(ADAM_LITE, WorldConfig(backend=spec["backend"], threads=spec.get("threads", 0), **window),
                       terrain, num_envs=n, device=spec["device"])
    stand = ScriptedStand(ADAM_LITE, ADAM_LITE_LOCO.stand, world.joint_pos.device)
    q = world.default_joint_q.clone()
    q[:, :3] += origins.to(q.device)
    world.reset(joint_q=q)

    def step():
        world.joint_target.copy_(stand.targets(world))
        world.step()

    step()
    start_s = time.perf_counter() - t0
    spawn_z = world.root_pos[:, 2].clone()
    for _ in range(spec["warmup"]):
        step()
    steps, t0 = 0, time.perf_counter()
    while steps < spec["min_steps"] or time.perf_counter() - t0 < spec["seconds"]:
        step()
        steps += 1
    if spec["backend"] == "newton":
        wp_sync(world)
    dt = time.perf_counter() - t0
    up = (world.root_pos[:, 2] > spawn_z - STAND_DROP) & _upright(world.root_quat)
    return {"engine": spec["backend"], "num_envs": spec["num_envs"], "env_steps_per_s": steps * spec["num_envs"] / dt,
            "peak_rss_mb": _peak_rss_mb(), "standing": float(up.float().mean()), "start_s": start_s,
            "bodies": world.num_bodies}


def _task_worker(spec: dict) -> dict:
    """The locomotion task under scripted-stand actions: env-steps/s and the share of time spent outside the
    world's step."""
    import torch

    from cra_warp.sim import WorldConfig
    from envs.loco_config import LocoConfig
    from envs.locomotion import LocoEnv

    torch.set_num_threads(1)  # the learner's threads are a separate budget; one core per process here
    t0 = time.perf_counter()
    world = WorldConfig(backend=spec["backend"], threads=spec.get("threads", 0))
    env = LocoEnv(LocoConfig(num_envs=spec["num_envs"], device=spec["device"], terrain=spec["terrain"], world=world))
    start_s = time.perf_counter() - t0
    sim_step, sim_s = env.world.step, [0.0]

    def timed_sim_step():
        t = time.perf_counter()
        sim_step()
        sim_s[0] += time.perf_counter() - t

    env.world.step = timed_sim_step
    with torch.inference_mode():
        for _ in range(spec["warmup"]):
            env.step(env.stand_actions())
        sim_s[0], steps, t0 = 0.0, 0, time.perf_counter()
        while steps < spec["min_steps"] or time.perf_counter() - t0 < spec["seconds"]:
            env.step(env.stand_actions())
            steps += 1
    dt = time.perf_counter() - t0
    up = (env.root_pos[:, 2] - env.ground_under_base > env.robot.base_height - STAND_DROP) & _upright(env.world.root_quat)
    return {"engine": "task" if spec["backend"] == "newton" else "task_mujoco", "num_envs": env.num_envs,
            "env_steps_per_s": steps * env.num_envs / dt,
            "peak_rss_mb": _peak_rss_mb(), "standing": float(up.float().mean()), "start_s": start_s,
            "overhead_vs_sim": (dt - sim_s[0]) / sim_s[0]}


def _learner_worker(spec: dict) -> dict:
    from cra_warp.learning.bench import learner_benchmark

    return {"engine": "learner", **learner_benchmark(spec["num_envs"], threads=spec["threads"])}


def _maps_worker(spec: dict) -> dict:
    import torch

    from cra_warp.terrain import generate_terrain
    from cra_warp.terrain.sampling import HeightMapConfig, HeightSampler, bench_height_maps

    torch.set_num_threads(spec["threads"])
    sampler = HeightSampler(generate_terrain().field, spec["device"], HeightMapConfig(compile=spec["compile"]))
    return {"engine": "height_maps", "compile": spec["compile"],
            **bench_height_maps(spec["num_envs"], spec["device"], sampler=sampler)}


def learner_and_maps(args) -> list[dict]:
    """PPO update vs collection on a free dummy env (the learner alone), and the critic's height maps at N=4096."""
    recs = [_run_workers([{"kind": "learner", "num_envs": n, "threads": 2}])[0] for n in (256, 1024)]
    for threads, compiled in ((1, False), (1, True), (2, True)):
        recs += _run_workers([{"kind": "maps", "num_envs": 4096, "device": args.device, "threads": threads,
                               "compile": compiled}])
    return recs


def wp_sync(world):
    import warp as wp

    wp.synchronize_device(world.device)


class _OneLineParser(argparse.ArgumentParser):
    def error(self, message):  # argparse prints the usage too; a bad argument is one line here, exit code 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def _upright(quat_xyzw):
    """Projected gravity z < -0.9: the base is tilted less than ~25 deg."""
    x, y = quat_xyzw[..., 0], quat_xyzw[..., 1]
    return 1.0 - 2.0 * (x * x + y * y) > 0.9


def _rollout_worker(spec: dict) -> dict:
    import mujoco
    import numpy as np
    from mujoco import rollout

    from robots.adam_lite import ADAM_LITE

    model = mujoco.MjModel.from_xml_path(spec["mjcf"])
    model.opt.timestep = spec["sim_dt"]  # Newton passes dt per step; its MJCF export leaves the default
    n, threads, substeps = spec["num_envs"], spec["threads"], spec["substeps"]
    data = mujoco.MjData(model)
    data.qpos[:3] = [0.0, 0.0, ADAM_LITE.base_height + spec["ground"]]
    data.qpos[3:7] = [1.0, 0.0, 0.0, 0.0]  # MuJoCo quaternions are wxyz
    data.qpos[7:] = ADAM_LITE.default_q
    spec_full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstate = mujoco.mj_stateSize(model, spec_full)
    s0 = np.empty(nstate)
    mujoco.mj_getState(model, data, s0, spec_full)
    state = np.tile(s0, (n, 1))
    ctrl = np.tile(np.asarray(ADAM_LITE.default_q), (n, substeps, 1))
    datas = [mujoco.MjData(model) for _ in range(threads)]
    out = np.empty((n, substeps, nstate))
    spawn_z = s0[3]
    hold = max(1, round(HOLD_S / (substeps * spec["sim_dt"])))
    count = [0]

    def env_step():
        count[0] += 1
        if count[0] % hold == 0:
            state[:] = s0
        rollout.rollout(model, datas, state, ctrl, nstep=substeps, state=out, persistent_pool=True)
        state[:] = out[:, -1]

    start = time.perf_counter()
    env_step()
    start_s = time.perf_counter() - start
    for _ in range(spec["warmup"]):
        env_step()
    steps, t0 = 0, time.perf_counter()
    while steps < spec["min_steps"] or time.perf_counter() - t0 < spec["seconds"]:
        env_step()
        steps += 1
    dt = time.perf_counter() - t0
    rollout.shutdown_persistent_pool()
    qx, qy = state[:, 5], state[:, 6]  # state = [time, qpos (xyz, quaternion wxyz, joints), ...]
    up = (state[:, 3] > spawn_z - STAND_DROP) & (1.0 - 2.0 * (qx * qx + qy * qy) > 0.9)
    return {"engine": "rollout", "num_envs": n, "env_steps_per_s": steps * n / dt, "peak_rss_mb": _peak_rss_mb(),
            "standing": float(up.mean()), "start_s": start_s}


def export_mjcf(terrain: str, path: str) -> None:
    """Write the MJCF that SolverMuJoCo builds for a one-robot world with the benchmark's options."""
    from cra_warp.sim import mjcf
    from robots.adam_lite import ADAM_LITE

    Path(path).write_text(mjcf(ADAM_LITE, terrain=stairs()[0] if terrain == "stairs" else None))


def _run_workers(specs: list[dict], env: dict | None = None) -> list[dict]:
    """Run one worker process per spec, all at once; return their records."""
    procs = [subprocess.Popen([sys.executable, "-m", "tools.bench", "--worker", json.dumps(s)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
             for s in specs]
    records = []
    for p in procs:
        out, err = p.communicate()
        if p.returncode != 0:
            raise RuntimeError(f"benchmark worker failed: {err.strip().splitlines()[-1] if err.strip() else p.returncode}")
        records.append(json.loads(out.strip().splitlines()[-1]))
    return records


def measure(engine: str, parallel: int, terrain: str, num_envs: int, args, mjcf: dict[str, str]) -> dict:
    base = {"terrain": terrain, "seconds": args.seconds, "min_steps": args.min_steps, "warmup": args.warmup}
    if engine in ("newton", "task"):
        kind = "world" if engine == "newton" else "task"
        per = [{**base, "kind": kind, "backend": "newton", "num_envs": num_envs // parallel,
                "device": args.device}] * parallel
        recs = _run_workers(per)
    elif engine in ("mujoco", "task_mujoco"):
        kind = "world" if engine == "mujoco" else "task"
        recs = _run_workers([{**base, "kind": kind, "backend": "mujoco", "num_envs": num_envs, "threads": parallel,
                              "device": "cpu"}])
    else:
        spec = {**base, "kind": "rollout", "num_envs": num_envs, "threads": parallel, "mjcf": mjcf[terrain],
                "sim_dt": 0.005, "substeps": 4, "ground": stairs()[1] if terrain == "stairs" else 0.0}
        recs = _run_workers([spec])
    rec = {"engine": engine, ("threads" if engine in THREADED else "processes"): parallel, "terrain": terrain,
           "num_envs": num_envs, "env_steps_per_s": sum(r["env_steps_per_s"] for r in recs),
           "peak_rss_mb": sum(r["peak_rss_mb"] for r in recs), "standing": min(r["standing"] for r in recs)}
    if engine.startswith("task"):
        rec["overhead_vs_sim"] = max(r["overhead_vs_sim"] for r in recs)
    return rec


def start_times(num_envs: int, device: str, cold: bool) -> dict:
    """Build time of a world (kernels loaded, one step taken): cold = empty Warp kernel cache, warm = ours."""
    spec = {"kind": "world", "backend": "newton", "terrain": "flat", "num_envs": num_envs, "device": device,
            "seconds": 0.0,
            "min_steps": 1, "warmup": 0}
    cold_s = None  # not measured (--no-cold); JSON null
    if cold:
        with tempfile.TemporaryDirectory() as cache:
            cold_s = _run_workers([spec], env={**os.environ, "WARP_CACHE_PATH": cache})[0]["start_s"]
    warm = _run_workers([spec])[0]["start_s"]
    return {"engine": "newton", "kind": "start", "num_envs": num_envs, "cold_start_s": cold_s, "warm_start_s": warm}


def print_table(records: list[dict]) -> None:
    rows = [r for r in records if r.get("kind") != "start" and r["engine"] not in ("learner", "height_maps")]
    mj1 = {(r["terrain"], r["num_envs"]): r["env_steps_per_s"] for r in rows
           if r["engine"] == "rollout" and r.get("threads") == 1}
    print(f"{'engine':11} {'par':>3} {'terrain':7} {'N':>5} {'env-steps/s':>12} {'peak MB':>8} {'MB/env':>7} "
          f"{'standing':>8} {'/rollout-1t':>11}")
    for r in rows:
        par = r.get("processes", r.get("threads"))
        ref = mj1.get((r["terrain"], r["num_envs"]))
        ratio = f"{r['env_steps_per_s'] / ref:11.2f}" if ref else f"{'-':>11}"
        print(f"{r['engine']:11} {par:3d} {r['terrain']:7} {r['num_envs']:5d} {r['env_steps_per_s']:12.0f} "
              f"{r['peak_rss_mb']:8.0f} {r['peak_rss_mb'] / r['num_envs']:7.3f} {r['standing']:8.2f} {ratio}")
    for r in records:
        if r.get("kind") == "start":
            cold = f"{r['cold_start_s']:.1f} s" if r["cold_start_s"] is not None else "not measured"
            print(f"Newton world start, N={r['num_envs']}: cold {cold} (empty kernel cache), "
                  f"warm {r['warm_start_s']:.1f} s")
    for r in records:
        if r["engine"] == "learner":
            print(f"learner N={r['num_envs']} (24 steps, {r['epochs']}x{r['mini_batches']}, {r['threads']} threads): "
                  f"collect {r['collect_s']:.2f} s, update {r['update_s']:.2f} s per iteration, "
                  f"{r['update_gflops']:.0f} GFLOP/s in the update")
        if r["engine"] == "height_maps":
            print(f"height maps (17x11 + 2 x 5x5) N={r['num_envs']}, {'compiled' if r['compile'] else 'eager'}, "
                  f"{r['torch_threads']} thread(s): {r['ms_per_step']:.1f} ms per env step")
    for r in rows:
        if r["engine"].startswith("task"):
            par = f"x{r['processes']}" if "processes" in r else f"{r['threads']} threads"
            print(f"{r['engine']} {r['terrain']} N={r['num_envs']} {par}: env overhead (obs, rewards, sampling, "
                  f"resets) = {100 * r['overhead_vs_sim']:.0f}% of the world step time")
    down = [r for r in rows if r["standing"] < 1.0 and r["engine"] != "rollout"]
    print("all robots standing under the scripted stand while measured" if not down else
          f"NOT all standing: {[(r['engine'], r['terrain'], r['num_envs'], r['standing']) for r in down]}")


def main(argv: list[str] | None = None) -> int:
    p = _OneLineParser(prog="cra-bench", description=__doc__.splitlines()[0])
    p.add_argument("--num-envs", type=int, nargs="+", default=[64, 256, 1024, 4096])
    p.add_argument("--terrain", nargs="+", default=list(TERRAINS), choices=TERRAINS)
    p.add_argument("--engines", nargs="+", default=list(ENGINES), choices=ENGINES)
    p.add_argument("--parallel", type=int, nargs="+", default=[1, 2], help="Newton processes / MuJoCo threads")
    p.add_argument("--seconds", type=float, default=3.0, help="minimum measuring time per configuration")
    p.add_argument("--min-steps", type=int, default=5, help="minimum env steps measured per configuration")
    p.add_argument("--warmup", type=int, default=5, help="env steps before measuring")
    p.add_argument("--device", default="cpu")
    p.add_argument("--no-cold", action="store_true", help="skip the cold-start measurement (~1 min)")
    p.add_argument("--no-learner", action="store_true", help="skip the learner and height-map timings (~1 min)")
    p.add_argument("--json", type=Path, help="write the records to this file")
    p.add_argument("--worker", help=argparse.SUPPRESS)
    args = p.parse_args(argv)

    keep_freed_memory()  # as cra-train does: measure what training runs with
    if args.worker:
        spec = json.loads(args.worker)
        rec = {"world": _world_worker, "rollout": _rollout_worker, "task": _task_worker,
               "learner": _learner_worker, "maps": _maps_worker}[spec["kind"]](spec)
        print(json.dumps(rec))
        return 0
    bad = [n for n in args.num_envs if n < 2 or n % 2]
    if bad:
        p.error(f"--num-envs must be even and >= 2 (split over 2 processes), got {bad}")
    # checked before anything runs: a bad value would otherwise end a run of minutes in a traceback
    if [n for n in args.parallel if n < 1]:
        p.error(f"--parallel must be >= 1, got {args.parallel}")
    if not 0.0 <= args.seconds < float("inf") or args.min_steps < 1 or args.warmup < 0:
        p.error(f"--seconds must be finite and >= 0, --min-steps >= 1 and --warmup >= 0, got {args.seconds}, "
                f"{args.min_steps}, {args.warmup}")
    if args.json and not args.json.parent.is_dir():
        p.error(f"--json {args.json}: no such directory {args.json.parent}")
    from cra_warp.cli import UsageError, check_device

    try:
        check_device(args.device)
    except UsageError as e:
        p.error(str(e))

    records = []
    with tempfile.TemporaryDirectory() as tmp:
        mjcf = {}
        if "rollout" in args.engines:
            for t in args.terrain:
                mjcf[t] = str(Path(tmp) / f"adam_lite_{t}.xml")
                _run_export(t, mjcf[t])
        for t in args.terrain:
            for n in args.num_envs:
                for engine in args.engines:
                    if (engine.startswith("task") and t == "stairs") or (engine == "rollout" and t == "rough"):
                        continue  # the task walks flat or rough; the bare rollout is compared on flat and stairs
                    for par in args.parallel:
                        rec = measure(engine, par, t, n, args, mjcf)
                        records.append(rec)
                        print(f"  {engine} x{par} {t} N={n}: {rec['env_steps_per_s']:.0f} env-steps/s, "
                              f"{rec['peak_rss_mb']:.0f} MB, standing {rec['standing']:.2f}", flush=True)
    records.append(start_times(1024, args.device, cold=not args.no_cold))
    if not args.no_learner:
        records += learner_and_maps(args)
    print_table(records)
    if args.json:  # every record names the CPU it was measured on (they change between sessions)
        cpu = cpu_info()
        write_json(args.json, [{**r, "cpu": cpu} for r in records])
        print(f"wrote {args.json}")
    return 0


def _run_export(terrain: str, path: str) -> None:
    subprocess.run([sys.executable, "-c", f"from tools.bench import export_mjcf; export_mjcf({terrain!r}, {path!r})"],
                   check=True, capture_output=True)


if __name__ == "__main__":
    sys.exit(main())

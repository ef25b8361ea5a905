"""cra-grid --study fork | walk: two comparisons of the paper's methods that fit a CPU (issue 37).

    cra-grid --study fork --out fork/   # ours sequential no_contrast fixed_cycle x seeds 1 2 3, 300 iterations each
    cra-grid --study walk --out walk/   # every method and ours_as_clock_free x seeds 1 2, <= 30M env steps each

Both run on --scale's simulator and device (cpu: MuJoCo on the CPU, two processes at a time, one core each) with
256 robots per run (--num-envs) and one recipe for every run (--recipe, walk unless told; a method that cannot use
part of it runs without it, as in the comparison, and the walk study trains its fair pair beside it).

fork: rough fine-tuning from one walker. Every method whose actor has our architecture starts from --walker
(default robots/adam_lite/policies/flat_walk_v2/checkpoint.pt) and trains the same --iterations on rough ground:

    cra-train --task rough --method M --recipe R --init WALKER --seed S --num-envs 256 --sim mujoco
              --max-iterations 300 --save-interval 20 --log-dir <out>/train/M-sS --no-export --quiet

clock_free (no clock inputs or gait actions: its actor's observation and outputs are not the walker's) and the
baselines (dreamwaq, dwl and their papers' pairings: their actors are their papers' networks, not our GRU) cannot
fork: the plan says so and leaves them out.
Each finished run gets cra-eval --protocol paper --robots-per-level 10 --ablation-robots 50 (the 0.15 m/s stairs
and slope ascent with 50 robots per level, the speed sweep 0.15-1.0 m/s with 10; --eval-args replaces these) and
cra-probe (its defaults; --probe-args adds to them).

    <out>/train/<method>-s<seed>/           cra-train runs (--init WALKER first, --resume after an interruption)
    <out>/train/<method>-s<seed>.json       the study's settings (recipe, iterations, walker) for cra-campaign
    <out>/eval/<method>-s<seed>.json        cra-eval --protocol paper of the final checkpoint (and its .log)
    <out>/eval/<method>-s<seed>.probe.json  cra-probe of the final checkpoint: R^2 of m_a and of o_t (and .probe.log)
    <out>/figures/                          cra-figures: terrain level over training, success vs speed, vs stairs
                                            and slope, torque scatter of ours
    <out>/table.json, table.csv             per method, mean and std over seeds: the sweep's success and falls,
                                            each ablation cell (with all the seeds' robots and their 95% Wilson
                                            interval) and each probe R^2; every record

walk: time to walk from scratch on flat ground. Every run trains in chunks of --check-every iterations (100):

    cra-train --task flat --method M --recipe R --seed S --num-envs 256 --sim mujoco --max-iterations 100
              --save-interval 20 --log-dir <out>/walk/M-sS --no-export --quiet [--resume <out>/walk/M-sS]

and after each chunk its newest checkpoint gets the flat trial, cra-eval --trial flat --speeds 0.5 --robots 32
--seconds 10 (--eval-args replaces these). A run walks at the first check where every robot stays up and the v_x
error (the trial's tracking_error) is <= --walk-error (0.15 m/s); it stops training there, or at --budget env steps
(30M: the last check is at the budget; "not within budget").

    <out>/walk/<label>-s<seed>/             cra-train runs
    <out>/walk/<label>-s<seed>.json         every check (iteration, env steps, robots up, v_x error) and the first
                                            that walked
    <out>/walk/<label>-s<seed>.check.json   the newest check's cra-eval records (and .check.log)
    <out>/figures/walk_error.png            cra-figures --walk: v_x error vs env steps, per arm (and its JSON)
    <out>/table.json, table.csv             per arm and seed the env steps to walk (or not within budget); the mean

A setting tuned before a study (a baseline's value its paper does not give) is a study of its own: --methods M
--override PATH=VALUE in another --out (which keeps that --override: resumed with another, cra-grid refuses), its
table beside the study's arms of M; --override cannot set the clock (gait.*), which a fair pair must mirror:

    cra-grid --study walk --methods dreamwaq_clock_free --no-fair-pairs --override learner.dreamwaq.beta=1.0 \
        --out tune_beta/

Resumable: re-running the same command trains only what is left (an unfinished run resumes from its newest
checkpoint, a finished one is not retrained), redoes an evaluation or probe only when its JSON is older than the
final checkpoint, and repeats no check already recorded. On another machine: save the runs' newest checkpoints into
the repository, commit them, restore them there and re-run the same command:

    cra-campaign save fork_study fork/train/*/          # then git add/commit robots/adam_lite/campaigns/fork_study
    cra-campaign restore fork_study --out fork/train    # on the other machine, then: cra-grid --study fork --out fork
    cra-campaign save walk_study walk/walk/*/           # each run's check record (RUN.json beside it) goes along
    cra-campaign restore walk_study --out walk/walk

Only the newest checkpoints and the records travel (a walk run that is done: its record alone): the terrain-level
curve of a restored run starts at the restore (its TensorBoard logs stay behind), and the evaluations are redone.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from cra_warp.atomic_json import write_json, write_text
from cra_warp.cli import UsageError
from envs.methods import METHODS
from train.grid import PAIR, SCALES, GridArgs, _newest, labels, override_args, paired, recipe_of, unusable

FORK = {"iterations": 300, "num_envs": 256, "seeds": (1, 2, 3),
        "eval": ["--robots-per-level", "10", "--ablation-robots", "50"]}
WALK = {"num_envs": 256, "seeds": (1, 2), "eval": ["--speeds", "0.5", "--robots", "32", "--seconds", "10"]}
SAVE_INTERVAL = 20
FORK_FIGURES = ("terrain_level", "success_vs_speed", "success_vs_terrain", "torque_velocity")


def cannot_fork(method: str) -> str | None:
    """Why ``method``'s actor cannot start from a checkpoint of ours (None: it can). Checked with cra-train --init
    of flat_walk_v2: clock_free's actor observation differs at prev_action, dreamwaq's and dwl's actor weights do
    not fit."""
    spec = METHODS[method]
    if spec.actor_kind != METHODS["ours"].actor_kind:
        return f"its actor is its paper's network ({spec.actor_kind}), not our GRU: the walker's weights do not fit"
    if not spec.uses_clock:
        return "no clock inputs or gait actions: its actor's observation and outputs are not the walker's"
    return None


def resolved(a: GridArgs) -> GridArgs:
    """``a`` with the study's defaults where it leaves them unset."""
    d = FORK if a.study == "fork" else WALK
    return replace(a, seeds=a.seeds or d["seeds"], num_envs=a.num_envs or d["num_envs"],
                   iterations=a.iterations or d.get("iterations"),
                   parallel=a.parallel or SCALES[a.scale]["parallel"])


def checked(a: GridArgs) -> GridArgs:
    """cra-grid's checks of a study's arguments (UsageError, one line)."""
    a = resolved(a)
    if a.study == "fork":
        if not a.walker.is_file():
            raise UsageError(f"--walker {a.walker}: no such checkpoint")
        if all(cannot_fork(m) for m in a.methods):
            raise UsageError(f"--study fork: none of --methods can fork from the walker "
                             f"({'; '.join(f'{m}: {cannot_fork(m)}' for m in a.methods)})")
    else:
        if a.iterations is not None:
            raise UsageError("--iterations: the walk study's budget is --budget (env steps per run)")
        if not (math.isfinite(a.walk_error) and a.walk_error > 0):
            raise UsageError(f"--walk-error must be finite and > 0 m/s, got {a.walk_error}")
        if walk_iterations(a) < 1:
            raise UsageError(f"--budget {a.budget}: less than one iteration of {a.num_envs} robots "
                             f"({a.num_envs * steps_per_env()} env steps)")
    return a


def steps_per_env() -> int:
    from cra_warp.learning.config import LearnerConfig

    return LearnerConfig().num_steps_per_env


def fork_methods(a: GridArgs) -> tuple[list[str], dict[str, str]]:
    """(the methods of --methods that can fork, {method left out: why})."""
    out = {m: cannot_fork(m) for m in a.methods}
    return [m for m, why in out.items() if why is None], {m: why for m, why in out.items() if why}


# ---- scheduling: each run is a sequence of steps (train, evaluate, ...), each a command


@dataclass
class Step:
    what: str                                    # training | evaluating | probing | checking
    cmd: list[str]
    log: Path                                    # the command's stdout and stderr (appended)
    after: Callable[[], None] | None = None      # run when the command succeeded (records a check)
    before: Callable[[], None] | None = None     # run just before the command starts (records the study's settings)


def schedule(runs: dict[str, Callable[[], Step | None]], parallel: int, log, popen=subprocess.Popen,
             poll_s: float = 2.0) -> None:
    """Every run's steps until each run's next step is None, ``parallel`` commands at a time (each pinned to its own
    core where there are enough). A run's next step is asked of it again after each step it ran (the steps are a
    function of what is on disk, which is what makes a study resumable); evaluations, probes and checks go before
    trainings, so they share the cores with the remaining trainings instead of queueing behind them. Runs go depth
    first: a run that has started goes on before one that has not, so at most ``parallel`` runs are part-trained
    at a time (the checkpoints a session must commit to carry the study to another machine) and finished arms
    come in whole, in order."""
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    waiting, running, free = list(runs), [], list(range(parallel))
    while waiting or running:
        while free:
            steps = [(name, runs[name]()) for name in waiting]
            waiting = [name for name, step in steps if step is not None]
            steps = [(name, step) for name, step in steps if step is not None]
            if not steps:
                break
            name, step = min(steps, key=lambda ns: ns[1].what == "training")   # the first non-training, if any
            waiting.remove(name)
            step.log.parent.mkdir(parents=True, exist_ok=True)
            if step.before is not None:
                step.before()
            logf = open(step.log, "a")
            slot = free.pop(0)
            pin = {cores[slot]} if parallel > 1 and len(cores) >= parallel else None
            p = popen(step.cmd, stdout=logf, stderr=subprocess.STDOUT,
                      preexec_fn=(lambda c=pin: os.sched_setaffinity(0, c)) if pin else None)
            log(f"{step.what} {name} (pid {p.pid}{f', core {cores[slot]}' if pin else ''})")
            running.append((p, name, step, slot, logf))
        finished = [r for r in running if r[0].poll() is not None]
        if not finished:
            time.sleep(poll_s)
            continue
        for r in finished:
            p, name, step, slot, logf = r
            logf.close()
            running.remove(r)
            free.append(slot)
            if p.returncode != 0:
                for q, *_ in running:  # stop the others: the study is resumable, nothing is lost
                    q.terminate()
                raise UsageError(f"{step.what} {name} failed (exit {p.returncode}); see {step.log}")
            if step.after is not None:
                step.after()
            waiting.insert(0, name)   # depth first: this run's next step before any run that has not started


def _run_or_print(a, runs: dict, log, popen) -> bool:
    """--dry-run: print each run's next step and return False; else run them all ``a.parallel`` at a time."""
    if a.dry_run:
        for name, step in runs.items():
            s = step()
            log(f"{name}: " + (f"{s.what}: {' '.join(s.cmd)}" if s else "done"))
        return False
    schedule(runs, a.parallel, log, popen)
    return True


def _stale(out: Path, ckpt: Path) -> bool:
    return not out.is_file() or ckpt.stat().st_mtime > out.stat().st_mtime


def _train_cmd(a: GridArgs, task: str, method: str, seed: int, run_dir: Path, iterations: int) -> list[str]:
    s = SCALES[a.scale]
    return [sys.executable, "-m", "train.train", "--task", task, "--method", method, "--recipe", a.recipe,
            "--seed", str(seed), "--num-envs", str(a.num_envs), "--sim", s["sim"], "--device", s["device"],
            "--max-iterations", str(iterations), "--log-dir", str(run_dir), "--quiet",
            "--save-interval", str(SAVE_INTERVAL), "--no-export"]


def _draw(a: GridArgs, args: list[str], inputs: list[Path], drawn: list[Path], log) -> None:
    """cra-figures ``args`` (as its command: train/ and tools/ stay apart) unless ``drawn`` are newer than
    ``inputs``."""
    if all(f.is_file() for f in drawn) and max(f.stat().st_mtime for f in inputs) <= min(
            f.stat().st_mtime for f in drawn):
        log(f"figures: up to date ({a.out / 'figures'})")
        return
    done = subprocess.run([sys.executable, "-m", "tools.figures", *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise UsageError(f"cra-figures {' '.join(args)} failed: {done.stderr.strip()[-300:]}")
    log(done.stdout.strip())


def _mean_std(values: list[float]) -> dict:
    return {"per_seed": values, "mean": statistics.fmean(values), "std": statistics.pstdev(values)}


# ---- fork: rough fine-tuning from one walker


def _fork_paths(a: GridArgs, label: str, seed: int) -> tuple[Path, Path, Path]:
    """(run directory, cra-eval JSON, cra-probe JSON) of one run."""
    name = f"{label}-s{seed}"
    return a.out / "train" / name, a.out / "eval" / f"{name}.json", a.out / "eval" / f"{name}.probe.json"


def fork_record(a: GridArgs, method: str, seed: int) -> dict:
    """The study's settings beside the run's directory (<out>/train/<method>-s<seed>.json): cra-campaign save takes
    it along, so the RESUME.md of a saved fork study re-runs cra-grid with them."""
    run_dir = _fork_paths(a, method, seed)[0]
    rec = {"study": "fork", "label": method, "method": method, "seed": seed, "recipe": recipe_of(a, method),
           "num_envs": a.num_envs, "iterations": a.iterations, "walker": str(a.walker.resolve())}
    path = run_dir.with_name(f"{run_dir.name}.json")
    if not path.is_file() or json.loads(path.read_text()) != rec:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_json(path, rec, indent=2)
    return rec


def fork_step(a: GridArgs, method: str, seed: int) -> Step | None:
    """The run's next step: train (from the walker, or resume), evaluate, probe; None when all are done."""
    from envs.evaluation import judged_today

    run_dir, ev, pr = _fork_paths(a, method, seed)
    newest = _newest(run_dir)
    done = newest[0] + 1 if newest else 0
    if done < a.iterations:
        cmd = _train_cmd(a, "rough", method, seed, run_dir, a.iterations - done) + override_args(a, {})
        cmd += ["--resume", str(run_dir)] if newest else ["--init", str(a.walker)]
        return Step("training", cmd, run_dir / "train.log", before=lambda: fork_record(a, method, seed))
    ckpt = newest[1]
    if _stale(ev, ckpt) or not judged_today(ev):
        extra = shlex.split(a.eval_args) if a.eval_args else FORK["eval"]
        return Step("evaluating", [sys.executable, "-m", "train.evaluate", str(ckpt), "--protocol", "paper",
                                   "--json", str(ev), "--device", SCALES[a.scale]["device"], *extra],
                    ev.with_suffix(".log"))
    if _stale(pr, ckpt):
        return Step("probing", [sys.executable, "-m", "tools.probe", str(ckpt), "--json", str(pr),
                                *shlex.split(a.probe_args)], pr.with_suffix(".log"))
    return None


def run_fork(a: GridArgs, log, popen) -> list[dict]:
    methods, left_out = fork_methods(a)
    a = replace(a, methods=tuple(methods))
    log(f"fork study: {len(methods)} methods x {len(a.seeds)} seeds from {a.walker}, {a.iterations} iterations of "
        f"{a.num_envs} robots each on rough ground ({SCALES[a.scale]['sim']})")
    for m, why in left_out.items():
        log(f"{m:12} left out: cannot fork ({why})")
    for m in methods:
        log(f"{m:12} recipe {recipe_of(a, m)}")
    runs = {f"{m} seed {s}": (lambda m=m, s=s: fork_step(a, m, s)) for m in methods for s in a.seeds}
    jobs = [{"method": m, "seed": s, "run_dir": _fork_paths(a, m, s)[0]} for m in methods for s in a.seeds]
    if not _run_or_print(a, runs, log, popen):
        return jobs
    evals = {(m, s): json.loads(_fork_paths(a, m, s)[1].read_text()) for m in methods for s in a.seeds}
    probes = {(m, s): json.loads(_fork_paths(a, m, s)[2].read_text()) for m in methods for s in a.seeds}
    ours = next((j for j in jobs if j["method"] == "ours"), jobs[0])
    _draw(a, ["--runs", *(f"{m}={','.join(str(_fork_paths(a, m, s)[0]) for s in a.seeds)}" for m in methods),
              "--eval", *(str(_fork_paths(a, m, s)[1]) for m, s in evals), "--out", str(a.out / "figures"),
              "--torque", str(_newest(ours["run_dir"])[1]), "--sim", SCALES[a.scale]["sim"]],
          [_fork_paths(a, m, s)[1] for m, s in evals], [a.out / "figures" / f"{n}.png" for n in FORK_FIGURES], log)
    fork_table(a, [r for rs in evals.values() for r in rs], probes, left_out, log)
    return jobs


def probe_summary(probes: dict[tuple[str, int], list[dict]]) -> dict:
    """{method: {source ("latent" | "obs"): {group: mean, std and per-seed R^2}}} over each method's seeds."""
    per: dict[str, list[dict]] = {}
    for (m, _), records in probes.items():
        per.setdefault(m, []).extend(r["r2"] for r in records)
    return {m: {src: {g: _mean_std([r2[src][g] for r2 in r2s]) for g in r2s[0][src]} for src in r2s[0]}
            for m, r2s in per.items()}


def fork_table(a: GridArgs, records: list[dict], probes: dict, left_out: dict[str, str], log) -> dict:
    from envs.evaluation import method_summary, seed_means, write_csv

    means = seed_means(records)
    table = {"study": "fork", "walker": str(a.walker), "recipe": a.recipe, "override": list(a.override),
             "iterations": a.iterations,
             "num_envs": a.num_envs, "seeds": list(a.seeds), "left_out": left_out,
             "methods": method_summary(records), "ablation": [m for m in means if m["protocol"] == "ablation"],
             "probe": probe_summary(probes), "records": records, "seed_means": means}
    write_json(a.out / "table.json", table)
    write_csv(a.out / "table.csv", records)
    log(f"wrote {a.out / 'table.csv'}, {a.out / 'table.json'}; mean (std) over seeds, [95% interval of all the "
        "seeds' robots]:")
    for m, row in table["methods"].items():
        s, f = row["success_rate"], row["fall_rate"]
        log(f"  {m:12} speed sweep: success {100 * s['mean']:5.1f}% ({100 * s['std']:4.1f})  falls "
            f"{100 * f['mean']:5.1f}% ({100 * f['std']:4.1f}), {row['seeds']} seeds")
        for kind in dict.fromkeys(c["kind"] for c in table["ablation"]):
            cells = [c for c in table["ablation"] if c["method"] == m and c["kind"] == kind]
            unit, scale = ("cm", 100) if kind.startswith("stairs") else ("deg", 1)
            log(f"  {'':12} {kind} at 0.15 m/s: " + ", ".join(
                f"{c['difficulty'] * scale:.0f}{unit} {100 * c['success_mean']:.0f}% ({100 * c['success_std']:.0f})"
                + (f" [{100 * c['success_ci95'][0]:.0f}-{100 * c['success_ci95'][1]:.0f}] of {c['robots']}"
                   if c.get("success_ci95") else "") for c in cells))
        for src, groups in table["probe"].get(m, {}).items():
            log(f"  {'':12} probe R^2 from {src:6}: " + ", ".join(
                f"{g} {v['mean']:.3f} ({v['std']:.3f})" for g, v in groups.items()))
    return table


# ---- walk: time to walk from scratch


def walk_iterations(a: GridArgs) -> int:
    """Iterations of a run within the budget (env steps = iterations x robots x steps per env)."""
    return a.budget // (a.num_envs * steps_per_env())


def check_iterations(a: GridArgs) -> list[int]:
    """The iterations whose checkpoints are checked: the end of every --check-every chunk, and the budget's last."""
    total = walk_iterations(a)
    return [min(k * a.check_every, total) - 1 for k in range(1, -(-total // a.check_every) + 1)]


def walks(check: dict, walk_error: float) -> bool:
    """A check walks: every robot up, v_x error at most ``walk_error``."""
    return (check["robots_up"] == check["robots"] and check["vx_error"] is not None
            and check["vx_error"] <= walk_error)


def walk_next(checks: list[dict], newest: int | None, at: list[int], walk_error: float) -> tuple[str, int | None]:
    """What a walk run does next, from its recorded ``checks``, its newest checkpoint's iteration and the check
    iterations ``at``: ("walked", None), ("not within budget", None), ("check", iteration) or ("train", the
    iteration to train to)."""
    if any(walks(c, walk_error) for c in checks):
        return "walked", None
    if checks and at and max(c["iteration"] for c in checks) >= at[-1]:
        return "not within budget", None   # known from the record alone (a finished run travels without its files)
    it = -1 if newest is None else newest
    if it in at and it not in {c["iteration"] for c in checks}:
        return "check", it
    later = [c for c in at if c > it]
    return ("train", later[0]) if later else ("not within budget", None)


def _walk_paths(a: GridArgs, label: str, seed: int) -> tuple[Path, Path, Path]:
    """(run directory, check record, the newest check's cra-eval JSON) of one run."""
    name = f"{label}-s{seed}"
    return a.out / "walk" / name, a.out / "walk" / f"{name}.json", a.out / "walk" / f"{name}.check.json"


def read_walk(path: Path) -> dict:
    return json.loads(path.read_text()) if path.is_file() else {"checks": []}


def record_check(a: GridArgs, label: str, method: str, seed: int, iteration: int, ckpt: Path) -> dict:
    """The check's cra-eval records added to the run's record (written atomically), the first walking one named."""
    _, rec_path, check_json = _walk_paths(a, label, seed)
    r = next(r for r in json.loads(check_json.read_text()) if r.get("trial") == "flat")
    check = {"iteration": iteration, "env_steps": (iteration + 1) * a.num_envs * steps_per_env(),
             "robots": r["robots"], "robots_up": round(r["success_rate"] * r["robots"]),
             "vx_error": r["tracking_error"], "speed": r["speed"], "seconds": r.get("seconds"),
             "checkpoint": str(ckpt)}
    check["walking"] = walks(check, a.walk_error)
    rec = read_walk(rec_path)
    checks = sorted([c for c in rec["checks"] if c["iteration"] != iteration] + [check], key=lambda c: c["iteration"])
    rec = {"study": "walk", "label": label, "method": method, "seed": seed, "recipe": recipe_of(a, label),
           "num_envs": a.num_envs, "budget_env_steps": a.budget, "check_every": a.check_every,
           "walk_error": a.walk_error, "checks": checks,
           "walked": next((c for c in checks if walks(c, a.walk_error)), None),
           "budget_spent": checks[-1]["iteration"] >= check_iterations(a)[-1]}
    write_json(rec_path, rec, indent=2)
    return rec


def walk_step(a: GridArgs, label: str, method: str, seed: int) -> Step | None:
    run_dir, rec_path, check_json = _walk_paths(a, label, seed)
    newest = _newest(run_dir)
    what, it = walk_next(read_walk(rec_path)["checks"], newest[0] if newest else None, check_iterations(a),
                         a.walk_error)
    if what == "check":
        extra = shlex.split(a.eval_args) if a.eval_args else WALK["eval"]
        return Step("checking", [sys.executable, "-m", "train.evaluate", str(newest[1]), "--trial", "flat",
                                 "--json", str(check_json), "--device", SCALES[a.scale]["device"], *extra],
                    check_json.with_suffix(".log"),
                    after=lambda: record_check(a, label, method, seed, it, newest[1]))
    if what != "train":
        return None
    cmd = _train_cmd(a, "flat", method, seed, run_dir, it - (newest[0] if newest else -1))
    cmd += override_args(a, unusable(a, paired(a, label)[0]) if label.startswith(PAIR) else {})
    if newest:
        cmd += ["--resume", str(run_dir)]
    return Step("training", cmd, run_dir / "train.log")


def run_walk(a: GridArgs, log, popen) -> list[dict]:
    arms = labels(a)
    total = walk_iterations(a)
    log(f"walk study: {len(arms)} arms x {len(a.seeds)} seeds on flat ground ({SCALES[a.scale]['sim']}), "
        f"{a.num_envs} robots, at most {total} iterations ({total * a.num_envs * steps_per_env() / 1e6:.1f}M env "
        f"steps); a flat trial every {a.check_every} iterations, walking: every robot up and v_x error <= "
        f"{a.walk_error} m/s")
    for label in arms:
        log(f"{label:12} recipe {recipe_of(a, label)}")
    runs = {f"{label} seed {s}": (lambda label=label, m=m, s=s: walk_step(a, label, m, s))
            for label, m in arms.items() for s in a.seeds}
    jobs = [{"method": label, "seed": s, "run_dir": _walk_paths(a, label, s)[0]} for label in arms for s in a.seeds]
    if not _run_or_print(a, runs, log, popen):
        return jobs
    records = [_walk_paths(a, label, s)[1] for label in arms for s in a.seeds]
    _draw(a, ["--walk", *map(str, records), "--out", str(a.out / "figures")], records,
          [a.out / "figures" / "walk_error.png"], log)
    walk_table(a, log)
    return jobs


def walk_table(a: GridArgs, log) -> dict:
    """Per arm and seed: the env steps to walk, or not within budget; the mean over the seeds when all walked."""
    at, rows, arms = check_iterations(a), [], {}
    for label, method in labels(a).items():
        per = {}
        for seed in a.seeds:
            run_dir, rec_path, _ = _walk_paths(a, label, seed)
            checks = read_walk(rec_path)["checks"]
            newest = _newest(run_dir)
            status, _ = walk_next(checks, newest[0] if newest else None, at, a.walk_error)
            walked = next((c for c in checks if walks(c, a.walk_error)), None)
            per[seed] = {"status": status if status in ("walked", "not within budget") else "unfinished",
                         "env_steps": walked["env_steps"] if walked else None,
                         "iteration": walked["iteration"] if walked else None, "checks": len(checks),
                         "last": checks[-1] if checks else None}
            rows.append({"arm": label, "method": method, "seed": seed, **{k: v for k, v in per[seed].items()
                                                                           if k != "last"}})
        steps = [p["env_steps"] for p in per.values()]
        arms[label] = {"method": method, "recipe": recipe_of(a, label), "seeds": per,
                       "walked": sum(s is not None for s in steps), "of": len(steps),
                       "mean_env_steps": statistics.fmean(steps) if all(s is not None for s in steps) else None}
    table = {"study": "walk", "recipe": a.recipe, "override": list(a.override), "num_envs": a.num_envs,
             "budget_env_steps": a.budget,
             "check_every": a.check_every, "walk_error": a.walk_error, "arms": arms}
    write_json(a.out / "table.json", table, indent=2)
    cols = ["arm", "method", "seed", "status", "env_steps", "iteration", "checks"]
    write_text(a.out / "table.csv", "\n".join([",".join(cols)] + [",".join(
        "" if r[c] is None else str(r[c]) for c in cols) for r in rows]) + "\n")
    log(f"wrote {a.out / 'table.csv'}, {a.out / 'table.json'}; env steps to walk (every robot up, v_x error <= "
        f"{a.walk_error} m/s):")
    for label, arm in arms.items():
        cells = [f"s{s} " + (f"{p['env_steps'] / 1e6:.2f}M" if p["env_steps"] is not None else p["status"])
                 for s, p in arm["seeds"].items()]
        mean = f"{arm['mean_env_steps'] / 1e6:.2f}M" if arm["mean_env_steps"] is not None else "-"
        log(f"  {label:20} {'; '.join(cells)}; mean {mean}")
    return table


def run(a: GridArgs, log=print, popen=subprocess.Popen) -> list[dict]:
    """Run study ``a.study`` (fork | walk) to its end, or (--dry-run) print each run's next step."""
    a = resolved(a)
    return (run_fork if a.study == "fork" else run_walk)(a, log, popen)

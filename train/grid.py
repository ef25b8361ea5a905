"""cra-grid: the paper's whole comparison in one command: train every method and seed, evaluate them with the
paper's protocol, draw its figures and the table. Two smaller studies of the same methods (--study; train/studies.py
says what each runs, writes and how it resumes):

    cra-grid --scale cpu --out grid/                         # this 2-core CPU (see SCALES)
    cra-grid --scale gpu --methods ours dwl dreamwaq --seeds 1 2 3 --out grid/
    cra-grid --study fork --out fork/   # rough fine-tuning of every method that can fork from one flat walker
    cra-grid --study walk --out walk/   # env steps to walk from scratch on flat ground, every method

--study comparison (the default) is the grid below; fork and walk take the simulator and device from --scale
(cpu: MuJoCo on the CPU) and set their own budgets (--iterations, --num-envs, --budget). Every study resumes by
re-running the same command, on this machine or, after cra-campaign save / restore, on another.

    <out>/train/<method>-s<seed>/   cra-train runs (rough terrain); resumed where a previous call stopped
    <out>/eval/<method>-s<seed>.json  cra-eval --protocol paper of the run's final checkpoint (and its .log)
    <out>/figures/                  cra-figures: terrain level, success vs speed, vs stairs / slope, torque scatter
    <out>/table.csv, table.json     every record, each cell's mean and std over seeds, and (table.json "methods",
                                    printed) each method's success and fall rate over the speed sweep; table.json
                                    "recipes" says which recipe each method trained with

Every method trains with one recipe (--recipe, envs/recipes.py; walk unless told). A method that cannot use part
of it runs without that part, and the plan and the table say so: clock_free and dreamwaq_clock_free have no clock,
so they train without the recipe's gait.* settings (under walk: no clock feedforward). Their fair pair,
ours_as_clock_free, is ours with the same keys left out; the grid trains and evaluates it beside the methods
(--no-fair-pairs: not) wherever those keys differ from the defaults (under walk; not under paper, where ours is
that pair already).

Resumable: a run whose final checkpoint exists is not trained again, an unfinished one resumes from its newest
checkpoint, and a run's evaluation is redone only when its final checkpoint is newer than its JSON. A run is
evaluated as soon as its training ends, in the next free slot, while the other trainings go on.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

from envs.recipes import CLOCK_KEYS, DEFAULT_RECIPE, RECIPES
from cra_warp.atomic_json import write_json
from cra_warp.cli import UsageError, parse_args
from envs.methods import METHODS, Method

# The two budgets. gpu: the paper's setting (4096 robots, 10k iterations, rough, every robot of the protocol).
# cpu: what a 2-core machine runs within one sitting: 30 runs (the 9 methods and ours_as_clock_free x 3 seeds) x 60
# iterations of 128 robots on the MuJoCo backend, two at a time, each evaluated with 4 robots per level (a run of
# ours: ~5.5 s per iteration on a Zen 1 core). It shows the pipeline, not an ordering: walking took ~20M env steps on
# flat ground, a run here is 0.18M (--iterations and --num-envs give longer runs).
SCALES = {
    "gpu": {"num_envs": 4096, "iterations": 10000, "sim": "newton", "device": "cuda:0", "parallel": 1,
            "eval": []},
    "cpu": {"num_envs": 128, "iterations": 60, "sim": "mujoco", "device": "cpu", "parallel": 2,
            "eval": ["--robots-per-level", "4", "--speeds", "0.15", "0.5", "1.0", "--ablation-robots", "4"]},
}


RecipeName = Literal[tuple(RECIPES)]  # type: ignore[valid-type]  # the choices --help lists
DEFAULT_SEEDS = (1, 2, 3)
WALKER = Path(__file__).resolve().parent.parent / "robots" / "adam_lite" / "policies" / "flat_walk_v2" / "checkpoint.pt"
FIGURES = ("terrain_level", "success_vs_speed", "success_vs_terrain", "torque_velocity")
STUDIES = ("comparison", "fork", "walk")   # train/studies.py: fork and walk
StudyName = Literal[STUDIES]  # type: ignore[valid-type]  # the choices --help lists


@dataclass
class GridArgs:
    # comparison: the paper's grid of every method; fork: rough fine-tuning from one walker; walk: time to walk
    # from scratch (train/studies.py)
    study: StudyName = "comparison"
    scale: str = "cpu"                                  # cpu | gpu (see SCALES); fork, walk: their sim and device
    # registered methods (cra-train --method); fork leaves out (saying why) those whose actor cannot fork
    methods: tuple[Method, ...] = tuple(METHODS)
    recipe: RecipeName = DEFAULT_RECIPE                 # cra-train --recipe of every run (envs/recipes.py)
    seeds: tuple[int, ...] | None = None                # default 1 2 3 (walk: 1 2)
    out: Path = Path("grid")
    iterations: int | None = None                       # the scale's unless given (fork: 300 for every run)
    num_envs: int | None = None                         # the scale's unless given (fork, walk: 256)
    parallel: int | None = None                         # training processes at a time (cpu: one core each)
    # cra-eval arguments instead of the scale's (fork, walk: the study's), as one string:
    # --eval-args="--speeds 1 --robots-per-level 2"
    eval_args: str = ""
    # for a method that cannot use part of the recipe (clock_free: its gait.* keys), also train ours without that
    # part ("ours_as_clock_free"), so the method is compared with ours on the same terms
    fair_pairs: bool = True
    dry_run: bool = False                               # print what would run, run nothing
    # fork: the checkpoint every run starts from (cra-train --init)
    walker: Path = WALKER
    # fork: cra-probe arguments of each run's probe, as one string (default: cra-probe's own)
    probe_args: str = ""
    budget: int = 30_000_000                            # walk: env steps per run at most
    check_every: int = 100                              # walk: iterations between flat trials
    walk_error: float = 0.15                            # walk: v_x error [m/s] at most (and every robot up) to walk
    # PATH=VALUE given to every run's cra-train --override, after the recipe's (not gait.*): a study that tunes one
    # setting (--methods dreamwaq_clock_free --no-fair-pairs --override learner.dreamwaq.beta=1.0) in its own --out
    override: tuple[str, ...] = ()


def override_args(a: GridArgs, left_out: dict[str, object]) -> list[str]:
    """cra-train's --override for one run: the recipe keys its method cannot use (a fair pair's), then --override's."""
    items = [*(f"{k}={json.dumps(v)}" for k, v in left_out.items()), *a.override]
    return ["--override", *items] if items else []


def _newest(run_dir: Path) -> tuple[int, Path] | None:
    """(iteration, path) of the run's newest checkpoint (cra-train --resume's choice), None before the first."""
    from train.train import newest_checkpoint

    path = newest_checkpoint(run_dir) if run_dir.is_dir() else None
    return (int(path.stem.split("_")[1]), path) if path else None


PAIR = "ours_as_"   # the label of ours trained without what a method cannot use: ours_as_clock_free


def unusable(a: GridArgs, method: str) -> dict[str, object]:
    """{recipe key: the default it falls back to} for the keys of the grid's recipe that ``method`` cannot use and
    that differ from the defaults (what a fair pair of ours leaves out too); {} when it can use them all."""
    from cra_warp.config_io import to_data
    from envs.loco_config import LocoConfig
    from envs.recipes import resolve

    task = "flat" if a.study == "walk" else "rough"
    _, dropped = resolve(a.recipe, task, uses_clock=METHODS[method].uses_clock)
    full, _ = resolve(a.recipe, task)
    base = to_data(LocoConfig())
    defaults = {}
    for key in dropped:
        node = base
        for part in key.split("."):
            node = node[part]
        if node != full[key]:
            defaults[key] = node
    return defaults


def labels(a: GridArgs) -> dict[str, str]:
    """Every run label of the grid -> the method it trains: the methods, and their fair pairs: one per clock mode
    (clock_free and dreamwaq_clock_free leave out the same keys), named by it: ours_as_clock_free."""
    out = {m: m for m in a.methods}
    if a.fair_pairs:
        out |= {PAIR + METHODS[m].clock_mode: "ours" for m in a.methods if unusable(a, m)}
    return out


def paired(a: GridArgs, label: str) -> list[str]:
    """The methods of the grid a fair pair's label stands beside (those of its clock mode that need one)."""
    return [m for m in a.methods if PAIR + METHODS[m].clock_mode == label and unusable(a, m)]


def recipe_of(a: GridArgs, label: str) -> str:
    """The recipe a run label trains with, in words: the name, and what of it the method cannot use (or, for a
    fair pair, leaves out)."""
    from envs.recipes import describe

    if label.startswith(PAIR):
        methods = paired(a, label)
        return f"{a.recipe} without {', '.join(unusable(a, methods[0]))} (the fair pair of {', '.join(methods)})"
    return describe(a.recipe, uses_clock=METHODS[label].uses_clock)


def plan(a: GridArgs) -> list[dict]:
    """One entry per (run label, seed): its run directory, the command left to run (None when done), final ckpt."""
    s = SCALES[a.scale]
    total = a.iterations or s["iterations"]
    jobs = []
    for m, method in labels(a).items():
        left_out = unusable(a, paired(a, m)[0]) if m.startswith(PAIR) else {}
        for seed in a.seeds or DEFAULT_SEEDS:
            run_dir = a.out / "train" / f"{m}-s{seed}"
            newest = _newest(run_dir)
            done_it = newest[0] + 1 if newest else 0
            cmd = None
            if done_it < total:
                cmd = [sys.executable, "-m", "train.train", "--task", "rough", "--method", method,
                       "--recipe", a.recipe, "--seed", str(seed),
                       "--num-envs", str(a.num_envs or s["num_envs"]), "--sim", s["sim"], "--device", s["device"],
                       "--max-iterations", str(total - done_it), "--log-dir", str(run_dir), "--quiet",
                       "--save-interval", "20", "--no-export"]
                cmd += override_args(a, left_out)
                if newest:
                    cmd += ["--resume", str(run_dir)]
            jobs.append({"method": m, "seed": seed, "run_dir": run_dir, "cmd": cmd, "recipe": recipe_of(a, m),
                         "final": newest[1] if newest and cmd is None else None})
    return jobs


def relabel(path: Path, label: str) -> None:
    """A fair pair's evaluation records name the checkpoint's method (ours): name them by the run's label instead,
    so the table and the figures keep it apart from ours."""
    records = json.loads(path.read_text())
    if any(r.get("method") != label for r in records):
        write_json(path, [{**r, "method": label} for r in records])


def _eval_json(a: GridArgs, job: dict) -> Path:
    return a.out / "eval" / f"{job['method']}-s{job['seed']}.json"


def _eval_cmd(a: GridArgs, job: dict) -> list[str] | None:
    """cra-eval --protocol paper of the run's final checkpoint, None while its JSON is newer than that checkpoint and
    judged by today's fall rule."""
    from envs.evaluation import judged_today

    ckpt, out = _newest(job["run_dir"])[1], _eval_json(a, job)
    if out.is_file() and ckpt.stat().st_mtime <= out.stat().st_mtime and judged_today(out):
        return None
    out.parent.mkdir(parents=True, exist_ok=True)
    return [sys.executable, "-m", "train.evaluate", str(ckpt), "--protocol", "paper", "--json", str(out),
            "--device", SCALES[a.scale]["device"],
            *(shlex.split(a.eval_args) if a.eval_args else SCALES[a.scale]["eval"])]


def train_and_evaluate(a: GridArgs, jobs: list[dict], log) -> list[Path]:
    """Every pending training and evaluation, ``parallel`` processes at a time, each pinned to its own core where
    there are enough. A run is evaluated as soon as its training ends (evaluations go first), so the evaluations
    share the cores with the remaining trainings instead of queueing behind all of them."""
    parallel = a.parallel or SCALES[a.scale]["parallel"]
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    trainings = [j for j in jobs if j["cmd"]]
    evals = [j for j in jobs if not j["cmd"]]    # finished runs: evaluated unless up to date
    running: list[tuple[subprocess.Popen, dict, str, int, object]] = []
    free = list(range(parallel))
    while trainings or evals or running:
        while free and (trainings or evals):
            if evals:
                j, what = evals.pop(0), "evaluating"
                cmd = _eval_cmd(a, j)
                if cmd is None:
                    log(f"evaluation of {j['method']} seed {j['seed']}: up to date ({_eval_json(a, j)})")
                    continue
                logf = open(_eval_json(a, j).with_suffix(".log"), "a")
            else:
                j, what = trainings.pop(0), "training"
                cmd = j["cmd"]
                j["run_dir"].mkdir(parents=True, exist_ok=True)
                logf = open(j["run_dir"] / "train.log", "a")
            slot = free.pop(0)
            pin = {cores[slot]} if parallel > 1 and len(cores) >= parallel else None
            p = subprocess.Popen(cmd, stdout=logf, stderr=subprocess.STDOUT,
                                 preexec_fn=(lambda c=pin: os.sched_setaffinity(0, c)) if pin else None)
            log(f"{what} {j['method']} seed {j['seed']} (pid {p.pid}{f', core {cores[slot]}' if pin else ''})")
            running.append((p, j, what, slot, logf))
        finished = [r for r in running if r[0].poll() is not None]
        if not finished:
            time.sleep(2)
            continue
        for r in finished:
            p, j, what, slot, logf = r
            logf.close()
            running.remove(r)
            if p.returncode != 0:
                for q, *_ in running:  # stop the others: the grid is resumable, nothing is lost
                    q.terminate()
                where = j["run_dir"] / "train.log" if what == "training" else _eval_json(a, j).with_suffix(".log")
                raise UsageError(f"{what} {j['method']} seed {j['seed']} failed (exit {p.returncode}); see {where}")
            if what == "training":
                evals.append(j)
            free.append(slot)
    return [_eval_json(a, j) for j in jobs]


def run(a: GridArgs, log=print) -> list[dict]:
    from envs.evaluation import method_summary, seed_means, write_csv

    if a.study != "comparison":
        from train import studies

        return studies.run(a, log)
    jobs = plan(a)
    recipes = {m: recipe_of(a, m) for m in labels(a)}
    for m, said in recipes.items():
        log(f"{m:12} recipe {said}")
    if a.dry_run:
        for j in jobs:
            log(f"{j['method']:12} seed {j['seed']}: " + (" ".join(j["cmd"]) if j["cmd"] else f"done ({j['final']})"))
        return jobs
    evals = train_and_evaluate(a, jobs, log)
    for j in jobs:
        if j["method"].startswith(PAIR):
            relabel(_eval_json(a, j), j["method"])
    records = [r for f in evals for r in json.loads(f.read_text())]
    runs = [f"{m}={','.join(str(j['run_dir']) for j in jobs if j['method'] == m)}" for m in labels(a)]
    drawn = [a.out / "figures" / f"{n}.png" for n in FIGURES]
    if all(f.is_file() for f in drawn) and max(e.stat().st_mtime for e in evals) <= min(
            f.stat().st_mtime for f in drawn):
        log(f"figures: up to date ({a.out / 'figures'})")
    else:
        ours = next((j for j in jobs if j["method"] == "ours"), jobs[0])
        fig_args = ["--runs", *runs, "--eval", *map(str, evals), "--out", str(a.out / "figures"),
                    "--torque", str(_newest(ours["run_dir"])[1]), "--sim", SCALES[a.scale]["sim"]]
        # cra-figures as its command, like the trainings and evaluations (the command packages stay apart)
        done = subprocess.run([sys.executable, "-m", "tools.figures", *fig_args], capture_output=True, text=True)
        if done.returncode != 0:
            raise UsageError(f"cra-figures {' '.join(fig_args)} failed: {done.stderr.strip()[-300:]}")
        log(done.stdout.strip())
    # the table is cheap: always rewritten, so a grid drawn by an older version gains its newer columns
    summary = method_summary(records)
    write_csv(a.out / "table.csv", records)
    write_json(a.out / "table.json", {"methods": summary, "recipes": recipes, "override": list(a.override),
                                      "records": records, "seed_means": seed_means(records)})
    log(f"wrote {a.out / 'table.csv'}; speed sweep, mean (std) over seeds:")
    for m, row in summary.items():
        s, f = row["success_rate"], row["fall_rate"]
        log(f"  {m:12} success {100 * s['mean']:5.1f}% ({100 * s['std']:4.1f})  falls {100 * f['mean']:5.1f}% "
            f"({100 * f['std']:4.1f})  {row['seeds']} seeds, recipe {recipes.get(m, a.recipe)}")
    return jobs


def checked_override(a: GridArgs) -> None:
    """--override builds every method's config, leaves the clock alone (a method without a clock and its fair pair
    would no longer be compared on the same terms) and is the one the study in --out started with (its runs,
    finished or not, trained with that one): a UsageError naming what is wrong otherwise."""
    from train import train as train_cli

    clock = [item for item in a.override if item.partition("=")[0].startswith(CLOCK_KEYS)]
    if clock:
        raise UsageError(f"--override cannot set the clock ({', '.join(clock)}): a clock-free method and its fair "
                         "pair would differ; give it a recipe (envs/recipes.py)")
    task = "flat" if a.study == "walk" else "rough"
    for m in a.methods:
        train_cli.configs(train_cli.TrainArgs(variant=m, task=task, recipe=a.recipe, override=a.override))
    stored = a.out / "override.json"
    if stored.is_file():
        before = json.loads(stored.read_text())
        if before != list(a.override):
            raise UsageError(f"--out {a.out} was started with --override {' '.join(before) or '(none)'}, not "
                             f"{' '.join(a.override) or '(none)'}: give the same, or another --out")
    elif not a.dry_run:
        a.out.mkdir(parents=True, exist_ok=True)
        write_json(stored, list(a.override))


def main(argv: list[str] | None = None) -> int:
    try:
        a = parse_args(GridArgs, argv, __doc__)
        if a.recipe not in RECIPES:
            raise UsageError(f"--recipe must be one of {', '.join(RECIPES)}, got {a.recipe!r}")
        if a.scale not in SCALES:
            raise UsageError(f"--scale must be one of {', '.join(SCALES)}, got {a.scale!r}")
        bad = [m for m in a.methods if m not in METHODS]
        if bad or not a.methods or a.seeds == ():
            raise UsageError(f"--methods must be among {', '.join(METHODS)} and --seeds non-empty, got "
                             f"{', '.join(bad) or 'none'}")
        for flag, v in (("--iterations", a.iterations), ("--num-envs", a.num_envs), ("--parallel", a.parallel),
                        ("--budget", a.budget), ("--check-every", a.check_every)):
            if v is not None and v < 1:
                raise UsageError(f"{flag} must be >= 1, got {v}")
        if a.out.exists() and not a.out.is_dir():
            raise UsageError(f"--out {a.out}: not a directory")
        a = replace(a, methods=tuple(dict.fromkeys(a.methods)),
                    seeds=tuple(dict.fromkeys(a.seeds)) if a.seeds else None)
        checked_override(a)
        if a.study != "comparison":
            from train import studies

            a = studies.checked(a)
        run(a)
    except UsageError as e:
        print(f"cra-grid: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

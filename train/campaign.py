"""cra-campaign: long training runs that outlive the machine they started on.

    cra-campaign save climb ~/cra_runs/climb/control_s1 ~/cra_runs/climb/sigma_s1 --target 3000
    cra-campaign resume climb [--out ~/cra_runs/climb] [--cores 0]
    cra-campaign status climb [RUN ...] [--iteration K] [--json out.json]
    cra-campaign restore climb --out grid/walk          # the checkpoints back into run directories, no training

A campaign is a folder robots/<robot>/campaigns/<name>/ in the repository: for each of its runs the newest
checkpoint (actor, critic, optimizer, curriculum levels and the run's whole resolved config: a few MB), a
campaign.json and a RESUME.md with the one command that continues every run on a fresh clone. ``save`` replaces
what the folder held (never accumulates); ``resume`` restarts each run with the arguments stored in its checkpoint,
``--resume`` from the committed file (or from <out>/<run>/'s own newest checkpoint where this machine kept one
further along), logging to <out>/<run>/, all on the given cores (one core shared by every
run by default), until the campaign's target iteration. ``status`` tells where each run is (iteration, env steps,
mean terrain level per terrain type: the pits are the ascents) from its checkpoint, the committed campaign's or
each RUN directory's. The checkpoint is the source of truth: nothing else is
needed to continue, so a lost ~/cra_runs costs at most the iterations since the last save. Commit a save once
per working session, at its end: each save rewrites every run's ~13 MB file, and a submission's diffs are capped
(a session that committed four runs' saves several times was refused whole, its results lost).

A cra-grid study keeps several runs under one directory (<out>/train/<method>-s<seed>/, <out>/walk/...): ``save``
takes them all (``cra-campaign save NAME <out>/walk/*/``), each with the record the study keeps beside its directory
(RUN.json: the walk study's checks, the fork study's settings) when there is one. ``restore NAME --out DIR`` puts
every run's checkpoint back as DIR/<run>/model_<it>.pt and its record as DIR/<run>.json, trains nothing, and leaves
alone a run whose directory already holds a checkpoint as new; re-running the study's cra-grid command then
continues it.
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from tyro.conf import Positional

from cra_warp.atomic_json import write_json
from cra_warp.cli import UsageError, parse_args
from cra_warp.machine import cpu_info

REPO = Path(__file__).resolve().parent.parent
ROOT = REPO / "robots" / "adam_lite" / "campaigns"
# cra-train arguments that belong to one start of a run, not to the run: resume sets its own.
_PER_START = ("resume", "init", "log_dir", "max_iterations")


@dataclass
class CampaignArgs:
    action: Positional[Literal["save", "resume", "status", "restore"]]
    name: Positional[str]                       # the campaign's folder under robots/adam_lite/campaigns/
    runs: Positional[tuple[Path, ...]] = ()     # save, status: each run's --log-dir (its newest model_<it>.pt)
    target: int | None = None                   # save: the iteration every run trains to (default: kept, or 3000)
    # resume: where the runs continue (default ~/cra_runs/<name>); restore: where the run directories go (the same)
    out: Path | None = None
    cores: tuple[int, ...] = (0,)               # resume: the cores every run shares (taskset)
    iterations: int | None = None               # resume: at most this many more iterations per run
    only: tuple[str, ...] = ()                  # resume: these runs only (default: every run)
    root: Path = ROOT                           # where campaigns live (tests use a temporary one)
    dry_run: bool = False                       # resume: print the commands, run nothing
    iteration: int | None = None                # status: each run's model_<iteration>.pt instead of its newest
    json: Path | None = None                    # status: write the table here


def train_argv(args: dict) -> list[str]:
    """cra-train flags for a checkpoint's stored TrainArgs, without the per-start ones."""
    argv = []
    for key, value in args.items():
        if key in _PER_START or value is None:
            continue
        flag = "--" + key.replace("_", "-")
        if isinstance(value, bool):
            argv.append(flag if value else "--no-" + key.replace("_", "-"))
        elif isinstance(value, (list, tuple)):
            if value:
                argv += [flag, *map(str, value)]
        else:
            argv += [flag, str(value)]
    return argv


def _stored(path: Path) -> tuple[int, dict]:
    from cra_warp.learning.checkpoint import read_checkpoint

    saved = read_checkpoint(path)
    config = (saved.get("infos") or {}).get("config")
    if not config or "args" not in config:
        raise UsageError(f"{path}: the checkpoint holds no run config (trained before runs stored theirs)")
    return int(saved["iter"]), config


def _env_steps(it: int, config: dict) -> int:
    """Env steps of a run whose checkpoint finished iteration ``it`` (counted from its start: a fork's parent not
    included)."""
    return (it + 1) * config.get("args", {}).get("num_envs", 0) * config.get("learner", {}).get("num_steps_per_env", 24)


def save(a: CampaignArgs) -> Path:
    if not a.runs:
        raise UsageError("save needs at least one run directory")
    folder = a.root / a.name
    old = json.loads((folder / "campaign.json").read_text()) if (folder / "campaign.json").is_file() else {}
    target = a.target or old.get("target", 3000)
    if len({run.name for run in a.runs}) != len(a.runs):
        raise UsageError("the run directories must have distinct names (they name the campaign's runs)")
    staging = folder.with_name(folder.name + ".saving")
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    try:   # a save that fails leaves no half-written folder in the repository
        runs, study = _stage(a.runs, staging)
        manifest = {"name": a.name, "target": target, "saved": time.strftime("%Y-%m-%d %H:%M %Z"),
                    "cpu": cpu_info()["model"], "runs": runs}
        write_json(staging / "campaign.json", manifest, indent=2)
        (staging / "RESUME.md").write_text(resume_md(manifest, study))
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    # swap in one step: the old folder is removed only once the new one is complete
    if folder.exists():
        trash = folder.with_name(folder.name + ".old")
        shutil.rmtree(trash, ignore_errors=True)
        folder.rename(trash)
        staging.rename(folder)
        shutil.rmtree(trash)
    else:
        staging.rename(folder)
    return folder


def _stage(run_dirs: tuple[Path, ...], staging: Path) -> tuple[dict, dict | None]:
    """Each run's newest checkpoint (and the study's record beside it) copied into ``staging``: (the manifest's
    runs, one run's study record or None)."""
    from train.train import newest_checkpoint

    runs, study = {}, None
    for run in run_dirs:
        label, record = run.name, _record(run)
        kept = json.loads(record.read_text()) if record.is_file() else None  # a grid study's record of the run
        ckpt = newest_checkpoint(run) if run.is_dir() else None
        if ckpt is None:
            last = (kept or {}).get("checks") or [{}]
            if not (last[-1] and study_finished(kept, last[-1]["iteration"]) == "walk"):
                raise UsageError(f"{run}: no model_<it>.pt under it")
            # a finished walk run restored from a campaign: its record is all there is, and all the study reads
            runs[label] = {"checkpoint": None, "iteration": last[-1]["iteration"],
                           "env_steps": last[-1]["env_steps"], "args": None, "finished": True}
        else:
            it, config = _stored(ckpt)
            finished = kept is not None and study_finished(kept, it)
            runs[label] = {"checkpoint": None if finished == "walk" else f"{label}/{ckpt.name}", "iteration": it,
                           "env_steps": _env_steps(it, config), "args": config["args"], "finished": bool(finished)}
            (staging / label).mkdir()
            if finished != "walk":   # a finished fork run keeps its optimizer: a longer --iterations resumes it
                shutil.copy2(ckpt, staging / label / ckpt.name)
        if kept is not None:
            (staging / label).mkdir(exist_ok=True)
            shutil.copy2(record, staging / label / "record.json")
            runs[label]["record"] = f"{label}/record.json"
            study = study or kept
    return runs, study


def study_finished(record: dict, it: int) -> str | None:
    """"walk" or "fork" when a study's run is done training (a walk run walked or was checked at its budget's end; a
    fork run reached its iterations), else None. A finished walk run travels as its record alone (the study reads
    nothing else of it); cra-campaign resume leaves finished runs to their study."""
    if record.get("study", "walk") == "fork":
        return "fork" if it + 1 >= record["iterations"] else None
    return "walk" if record.get("walked") or record.get("budget_spent") else None


def _record(run: Path) -> Path:
    """The record a cra-grid study keeps beside a run's directory: <run>.json."""
    return run.parent / f"{run.name}.json"


def _kept(run_dir: Path) -> tuple[Path | None, int]:
    """The newest checkpoint this machine holds under a run's directory and its iteration ((None, -1): none)."""
    from train.train import newest_checkpoint

    ckpt = newest_checkpoint(run_dir) if run_dir.is_dir() else None
    return ckpt, int(ckpt.stem.split("_")[1]) if ckpt is not None else -1


def restore(a: CampaignArgs) -> list[Path]:
    """Every run's checkpoint back as <out>/<run>/model_<it>.pt (and its record as <out>/<run>.json), no training;
    a run whose directory already holds a checkpoint at least as far along is left as it is (said so)."""
    folder, manifest = _manifest(a)
    out = a.out or Path.home() / "cra_runs" / a.name
    restored = []
    for label, run in manifest["runs"].items():
        run_dir = out / label
        if run["checkpoint"] is None:   # a finished walk run: its record alone (and its directory, for save's glob)
            run_dir.mkdir(parents=True, exist_ok=True)
            shutil.copy2(folder / run["record"], _record(run_dir))
            print(f"{label}: finished at iteration {run['iteration']}: its record -> {_record(run_dir)}")
            continue
        ckpt = folder / run["checkpoint"]
        have, have_it = _kept(run_dir)
        if have is not None and have_it >= run["iteration"]:
            print(f"{label}: {have} is as far as the campaign's iteration {run['iteration']} or further: left as "
                  "it is")
            continue
        run_dir.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ckpt, run_dir / ckpt.name)
        if run.get("record"):
            shutil.copy2(folder / run["record"], _record(run_dir))
        print(f"{label}: iteration {run['iteration']} -> {run_dir / ckpt.name}")
        restored.append(run_dir / ckpt.name)
    return restored


def study_md(m: dict, record: dict) -> str:
    """RESUME.md of a cra-grid study's runs (walk, or fork: ``record["study"]``, walk when absent as in the first
    walk records): they go back into the study's layout and its command goes on with the settings ``record`` (one
    run's study record) holds (a plain resume would train them past the study's checks or iterations, and skip
    its evaluations). A study started with --override needs it again (override.json stays with the old machine's
    --out)."""
    name, study = m["name"], record.get("study", "walk")
    checkpoints = "the newest checkpoint of each part-trained run (actor, critic, optimizer, config)"
    recipe = str(record.get("recipe") or "walk").split()[0]   # "walk", or "walk without ..." for a clock-free arm
    if study == "fork":
        from train.grid import WALKER

        keys = (("num-envs", "num_envs"), ("iterations", "iterations"))
        walker = Path(record.get("walker") or WALKER)
        # the default walker needs no flag; another of the repository's is named from the clone's root, and one
        # from outside it must be brought to the same path first (the study checks it before anything runs)
        flags_walker = "" if walker == WALKER else \
            f" --walker {walker.relative_to(REPO) if walker.is_relative_to(REPO) else walker}"
        layout, what = "train", checkpoints
        if not walker.is_relative_to(REPO):
            what += f". The walker {walker} is not in the repository: bring it to that path first"
        redo = "it trains only what is left, then evaluates and probes each run"
    else:
        keys = (("num-envs", "num_envs"), ("budget", "budget_env_steps"), ("check-every", "check_every"),
                ("walk-error", "walk_error"))
        flags_walker, layout = "", "walk"
        what = f"{checkpoints} and the study's record of its checks"
        redo = "it trains only what is left and repeats no check"
    flags = " ".join(f"--{flag} {record[key]}" for flag, key in keys if key in record) + flags_walker
    return f"""# Campaign {name}: a cra-grid {study} study

Saved {m['saved']} on {m['cpu']}: {what}.
On a fresh clone, put them back in the study's layout and re-run the study ({redo}):

```bash
bash tools/setup.sh && .venv/bin/cra-campaign restore {name} --out ~/cra_runs/{name}/{layout} && \\
  nohup .venv/bin/cra-grid --study {study} --recipe {recipe} {flags} --parallel 2 --out ~/cra_runs/{name} \\
  > ~/cra_runs_{name}.log 2>&1 &
```

(the study's other flags were its defaults; a study started with --override needs the same --override). Before the
session ends, save its runs back here (this replaces the folder; every run directory, so finished runs keep their
records):

```bash
.venv/bin/cra-campaign save {name} ~/cra_runs/{name}/{layout}/*/
```

| run | iteration | env steps |
|---|---|---|
""" + "\n".join(f"| {k} | {r['iteration']}{' (finished)' if r.get('finished') else ''} | {r['env_steps'] / 1e6:.2f}M |"
              for k, r in m["runs"].items()) + "\n"


def resume_md(m: dict, record: dict | None = None) -> str:
    """RESUME.md: the one command that continues the campaign's runs (``record``: a walk study's record of one of
    them, when its runs carry the study's records)."""
    if record is not None:
        return study_md(m, record)
    rows = "\n".join(f"| {k} | {r['iteration']} | {r['env_steps'] / 1e6:.2f}M | `{' '.join(train_argv(r['args']))}` |"
                     for k, r in m["runs"].items())
    return f"""# Campaign {m['name']}

Saved {m['saved']} on {m['cpu']}: each run's newest checkpoint (actor, critic, optimizer, curriculum levels, config).
Continue every run to iteration {m['target']} on a fresh clone (one core shared by all runs; logs and checkpoints in
~/cra_runs/{m['name']}/<run>/):

```bash
bash tools/setup.sh && nohup .venv/bin/cra-campaign resume {m['name']} > ~/cra_runs_{m['name']}.log 2>&1 &
```

Then, before the session ends, save the newest checkpoints back here (this replaces the folder):

```bash
.venv/bin/cra-campaign save {m['name']} {' '.join(f'~/cra_runs/{m["name"]}/{k}' for k in m['runs'])}
```

| run | iteration | env steps | cra-train arguments (besides --resume, --log-dir, --max-iterations) |
|---|---|---|---|
{rows}
"""


def _manifest(a: CampaignArgs) -> tuple[Path, dict]:
    """The committed campaign's folder and campaign.json; a one-line error naming those that exist if none."""
    folder = a.root / a.name
    if not (folder / "campaign.json").is_file():
        have = sorted(p.parent.name for p in a.root.glob("*/campaign.json")) if a.root.is_dir() else []
        raise UsageError(f"no campaign {a.name!r} under {a.root} (have: {', '.join(have) or 'none'})")
    return folder, json.loads((folder / "campaign.json").read_text())


def resume(a: CampaignArgs) -> int:
    folder, manifest = _manifest(a)
    out = a.out or Path.home() / "cra_runs" / a.name
    procs = []
    unknown = set(a.only) - set(manifest["runs"])
    if unknown:
        raise UsageError(f"campaign {a.name!r} has no run(s) {sorted(unknown)} (has: {', '.join(manifest['runs'])})")
    for label, run in manifest["runs"].items():
        if a.only and label not in a.only:
            continue
        if run.get("finished"):
            print(f"{label}: finished in its study at iteration {run['iteration']} (RESUME.md continues the study)")
            continue
        log_dir = out / label
        ckpt = folder / run["checkpoint"]
        kept, kept_it = _kept(log_dir)
        if kept is not None and kept_it > run["iteration"]:
            ckpt = kept  # this machine kept the run, further along than the commit: lose none of it
        it, config = _stored(ckpt)
        left = manifest["target"] - it
        if a.iterations is not None:
            left = min(left, a.iterations)
        if left <= 0:
            print(f"{label}: at iteration {it}, the target {manifest['target']} is reached")
            continue
        argv = [sys.executable, "-m", "train.train", *train_argv(config["args"]), "--resume", str(ckpt),
                "--log-dir", str(log_dir), "--max-iterations", str(left)]
        print(f"{label}: from iteration {it}, {left} more: {shlex.join(argv)}")
        if a.dry_run:
            continue
        log_dir.mkdir(parents=True, exist_ok=True)
        log = open(out / f"{label}.log", "a")
        cores = set(a.cores)
        procs.append((label, subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT,
                                              env={**os.environ, "OMP_NUM_THREADS": "1"},
                                              preexec_fn=lambda: os.sched_setaffinity(0, cores))))
    failed = [label for label, p in procs if p.wait() != 0]
    if failed:
        print(f"cra-campaign: runs failed: {', '.join(failed)} (see {out}/<run>.log)", file=sys.stderr)
        return 1
    return 0


def status(a: CampaignArgs) -> list[dict]:
    """One record per run: its checkpoint, iteration, env steps, difficulty and mean terrain level per type."""
    from cra_warp.config_io import from_data
    from cra_warp.learning.checkpoint import read_checkpoint
    from cra_warp.terrain import ROBOT_WAY, TerrainConfig, column_types
    from cra_warp.terrain.curriculum import levels_by_type
    from train.train import newest_checkpoint

    if a.runs:
        found = {}
        for run in a.runs:
            if a.iteration is None:
                ckpt = newest_checkpoint(run) if run.is_dir() else None
            else:
                ckpt = max(run.rglob(f"model_{a.iteration}.pt"), key=lambda p: p.stat().st_mtime, default=None)
            if ckpt is None:
                raise UsageError(f"{run}: no model_{a.iteration if a.iteration is not None else '<it>'}.pt under it")
            # two runs of one name (s1 of two campaigns) are told apart by their parent folder
            clash = sum(r.name == run.name for r in a.runs) > 1
            found[f"{run.parent.name}/{run.name}" if clash else run.name] = ckpt
    else:
        folder, manifest = _manifest(a)
        found = {k: folder / r["checkpoint"] for k, r in manifest["runs"].items() if r["checkpoint"]}
    records = []
    for label, ckpt in found.items():
        saved = read_checkpoint(ckpt)
        infos = saved.get("infos") or {}
        config = infos.get("config") or {}
        it = int(saved["iter"])
        rec = {"run": label, "checkpoint": str(ckpt), "iteration": it, "env_steps": _env_steps(it, config),
               "difficulty": infos.get("difficulty_level")}
        if infos.get("terrain_levels") is not None:
            tiles = from_data(TerrainConfig, (config.get("env") or {}).get("rough") or {})
            rec["terrain_level"] = sum(infos["terrain_levels"]) / len(infos["terrain_levels"])
            rec["terrain_level_by_type"] = {k: float(v) for k, v in
                                            levels_by_type(infos["terrain_levels"], column_types(tiles)).items()}
        records.append(rec)
    types = list(dict.fromkeys(t for r in records for t in r.get("terrain_level_by_type", {})))
    print(f"{'run':16} {'iter':>6} {'env steps':>10} " + " ".join(f"{t:>11}" for t in types))
    print(f"{'':35}" + " ".join(f"{'(' + ROBOT_WAY[t] + ')' if t in ROBOT_WAY else '':>11}" for t in types))
    for r in records:
        by = r.get("terrain_level_by_type", {})
        print(f"{r['run']:16} {r['iteration']:6d} {r['env_steps'] / 1e6:9.2f}M "
              + " ".join(f"{by[t]:11.2f}" if t in by else f"{'-':>11}" for t in types))
    if a.json:
        write_json(a.json, {"campaign": a.name, "cpu": cpu_info()["model"], "runs": records}, indent=2)
    return records


def main(argv: list[str] | None = None) -> int:
    try:
        a = parse_args(CampaignArgs, argv, __doc__)
        if a.iterations is not None and a.iterations < 1:
            raise UsageError(f"--iterations must be >= 1, got {a.iterations}")
        if a.action == "save":
            print(f"saved {save(a)}")
            return 0
        if a.action == "status":
            status(a)
            return 0
        if a.action == "restore":
            restore(a)
            return 0
        return resume(a)
    except UsageError as e:
        print(f"cra-campaign: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

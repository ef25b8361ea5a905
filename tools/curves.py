"""cra-curves: training curves of runs, grouped into arms, in one figure (the A/B evidence for a learning claim).

    cra-curves fp32=runs/ab/fp32-s1,runs/ab/fp32-s2 bf16=runs/ab/bf16-s1,runs/ab/bf16-s2 --out ab.png --json ab.json

Each ARM=DIR[,DIR...] names one arm and its runs (one per seed; a run directory is searched for TensorBoard event
files). An entry FILE.json#NAME instead takes the runs of arm NAME from a JSON this tool wrote before, so an arm
measured once serves later A/Bs on the same seeds and budget without a rerun. Per arm the figure draws every seed thin
and the seed mean thick, one panel per tag (default: mean reward and mean episode length per iteration). The JSON
holds the curves and, per tag, each arm's mean over the last ``--last`` iterations (of those up to ``--upto``: a
longer campaign can serve as one seed of an arm) with its seed-to-seed spread (max - min of the per-seed means), and
whether the arms' means differ by less than the larger spread ("within_spread"): the test the speed work states for
"learning unchanged".
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cra_warp.atomic_json import write_json

TAGS = ("Train/mean_reward", "Train/mean_episode_length")


def read_scalars(run: Path | str, tags: tuple[str, ...],
                 upto: int | None = None) -> dict[str, list[tuple[int, float]]]:
    """{tag: [(iteration, value), ...]} from the TensorBoard event files under ``run``, iterations <= ``upto``."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    files = sorted(Path(run).rglob("events.out.tfevents.*"))
    if not files:
        raise ValueError(f"{run}: no TensorBoard event files")
    out: dict[str, dict[int, float]] = {t: {} for t in tags}
    for f in files:
        acc = EventAccumulator(str(f), size_guidance={"scalars": 0})
        acc.Reload()
        for t in tags:
            if t in acc.Tags()["scalars"]:
                out[t].update({e.step: e.value for e in acc.Scalars(t) if upto is None or e.step <= upto})
    return {t: sorted(v.items()) for t, v in out.items()}


def summarise(arms: dict[str, list[dict]], tags: tuple[str, ...], last: int) -> dict:
    summary = {}
    for t in tags:
        per_arm = {}
        for arm, runs in arms.items():
            means = []
            for r in runs:
                vals = [v for _, v in r[t]][-last:]
                means.append(sum(vals) / len(vals) if vals else float("nan"))
            per_arm[arm] = {"seed_means": means, "mean": sum(means) / len(means), "spread": max(means) - min(means)}
        arm_means = [a["mean"] for a in per_arm.values()]
        spread = max(a["spread"] for a in per_arm.values())
        summary[t] = {"arms": per_arm, "difference": max(arm_means) - min(arm_means), "max_spread": spread,
                      "within_spread": max(arm_means) - min(arm_means) <= spread}
    return summary


def plot(arms: dict[str, list[dict]], tags: tuple[str, ...], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tags), figsize=(5.5 * len(tags), 4), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, t in zip(axes[0], tags):
        for k, (arm, runs) in enumerate(arms.items()):
            c = colours[k % len(colours)]
            series = [dict(r[t]) for r in runs]
            for s in series:
                ax.plot(list(s), list(s.values()), color=c, alpha=0.3, lw=0.8)
            common = sorted(set.intersection(*(set(s) for s in series))) if series else []
            ax.plot(common, [sum(s[i] for s in series) / len(series) for i in common], color=c, lw=2,
                    label=f"{arm} ({len(runs)} seeds)")
        ax.set_xlabel("iteration")
        ax.set_ylabel(t.split("/")[-1].replace("_", " "))
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle(title)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def read_stored_arm(source: str, tags: tuple[str, ...], upto: int | None = None) -> list[dict]:
    """The runs of one arm from a JSON cra-curves wrote: ``FILE.json#ARM``."""
    import json

    file, arm = source.rsplit("#", 1)
    runs = json.loads(Path(file).read_text()).get("arms", {}).get(arm)
    if not runs:
        raise ValueError(f"{source}: no arm {arm!r} in {file}")
    missing = [t for t in tags if t not in runs[0]]
    if missing:
        raise ValueError(f"{source}: no values for {', '.join(missing)}")
    return [{t: [(i, v) for i, v in r[t] if upto is None or i <= upto] for t in tags} for r in runs]


def parse_arm(text: str) -> tuple[str, list[str]]:
    if "=" not in text:
        raise ValueError(f"arm {text!r}: expected NAME=DIR[,DIR...]")
    name, dirs = text.split("=", 1)
    sources = [d for d in dirs.split(",") if d]
    missing = [d for d in sources if not (Path(d.rsplit("#", 1)[0]).is_file() if "#" in d else Path(d).is_dir())]
    if not name or not sources or missing:
        raise ValueError(f"arm {text!r}: {'no such directory or file ' + ', '.join(missing) if missing else 'empty'}")
    return name, sources


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="cra-curves", description=__doc__.split("\n\n")[0])
    p.add_argument("arms", nargs="+",
                   help="NAME=DIR[,DIR...] (one run directory per seed, or FILE.json#ARM: a stored arm)")
    p.add_argument("--tags", nargs="+", default=list(TAGS), help="TensorBoard scalar tags, one panel each")
    p.add_argument("--last", type=int, default=10, help="iterations averaged for the summary")
    p.add_argument("--upto", type=int, help="only iterations up to this one (a longer run as one seed of an arm)")
    p.add_argument("--title", default="")
    p.add_argument("--out", type=Path, required=True, help="PNG to write")
    p.add_argument("--json", type=Path, help="write curves and summary here")
    a = p.parse_args(argv)
    try:
        if a.last < 1:
            raise ValueError(f"--last must be >= 1, got {a.last}")
        tags = tuple(a.tags)
        arms = {}
        for text in a.arms:
            name, sources = parse_arm(text)
            arms[name] = []
            for d in sources:
                if "#" in d:
                    arms[name] += read_stored_arm(d, tags, a.upto)
                    continue
                r = read_scalars(Path(d), tags, a.upto)
                empty = [t for t in tags if not r[t]]
                if empty:
                    raise ValueError(f"{d}: no values for {', '.join(empty)}")
                arms[name].append(r)
        summary = summarise(arms, tags, a.last)
        plot(arms, tags, a.out, a.title)
    except ValueError as e:
        print(f"cra-curves: {e}", file=sys.stderr)
        return 2
    for t, s in summary.items():
        arms_txt = ", ".join(f"{n} {v['mean']:.2f} (spread {v['spread']:.2f})" for n, v in s["arms"].items())
        print(f"{t} (last {a.last}): {arms_txt}; difference {s['difference']:.2f} "
              f"{'within' if s['within_spread'] else 'OUTSIDE'} the seed spread")
    if a.json is not None:
        write_json(a.json, {"arms": {n: [{t: r[t] for t in tags} for r in runs] for n, runs in arms.items()},
                            "summary": summary, "last": a.last})
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""cra-figures: the paper's four figures (IV-B) of training logs, cra-eval results and a stairs rollout.

    cra-figures --runs ours=g/ours-s1,g/ours-s2 dwl=g/dwl-s1,g/dwl-s2 --eval g/eval.json \\
                --torque g/ours-s1/model_1500.pt --out figures/

    terrain_level.png       terrain level vs iteration per method (TensorBoard "/terrain_level"; seeds thin,
                            their mean thick)
    success_vs_speed.png    success rate vs commanded speed per method: cra-eval's speed sweep, each policy's rate
                            over every kind and level, mean +- std over the method's seeds; shaded (and in the
                            JSON: robots, ci95) the 95% Wilson interval of all its robots at that speed
    success_vs_terrain.png  success rate vs stair height and vs slope at 0.15 m/s (cra-eval's ablation; the
                            speed sweep's 0.15 m/s records when there is no ablation), error bars over seeds
    torque_velocity.png     joint velocity vs torque of the leg joints of one policy climbing stairs (a rollout of
                            --torque on the course's stairs ascent, robots still up)

And one of cra-grid --study walk:

    cra-figures --walk walk/walk/*-s*.json --out walk/figures/

    walk_error.png          the flat trial's v_x error vs env steps of every check of every run (an arm's seeds in
                            one colour; a hollow marker: not every robot up), the walking threshold dashed

Each PNG has a JSON of what it draws beside it. A figure whose inputs were not given is skipped (said so).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

from cra_warp.atomic_json import write_json
from tools.curves import parse_arm, read_scalars
from envs.methods import METHODS

LEVEL_TAG = "/terrain_level"
LEG_JOINTS = ("hipPitch", "hipRoll", "kneePitch", "anklePitch")  # the paper's scatter: the major leg joints


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    _plt().close(fig)
    write_json(path.with_suffix(".json"), data)


def terrain_levels(runs: dict[str, list[Path]], path: Path) -> dict:
    plt = _plt()
    data = {m: [read_scalars(d, (LEVEL_TAG,))[LEVEL_TAG] for d in dirs] for m, dirs in runs.items()}
    empty = [m for m, series in data.items() if not all(series)]
    if empty:  # a run logs the level when its first episodes end; a flat run never does
        raise ValueError(f"no {LEVEL_TAG} values in some runs of {', '.join(empty)} (flat ground, or too short?)")
    fig, ax = plt.subplots(figsize=(6, 4))
    for k, (m, series) in enumerate(data.items()):
        c = f"C{k}"
        dicts = [dict(s) for s in series]
        for s in dicts:
            ax.plot(list(s), list(s.values()), color=c, alpha=0.3, lw=0.8)
        common = sorted(set.intersection(*(set(s) for s in dicts)))
        ax.plot(common, [statistics.mean(s[i] for s in dicts) for i in common], color=c, lw=2,
                label=f"{m} ({len(dicts)} seeds)")
    ax.set(xlabel="iteration", ylabel="mean terrain level", title="Terrain level over training")
    ax.grid(alpha=0.3)
    ax.legend()
    _save(fig, path, {m: [list(map(list, s)) for s in series] for m, series in data.items()})
    return data


def _per_policy(records: list[dict], key) -> dict:
    """{method: {x: [per-policy success rate over its records at x]}} (a policy's rate: its records' mean)."""
    cells: dict[tuple, list[float]] = {}
    for r in records:
        x = key(r)
        if x is not None:
            cells.setdefault((r.get("method", r["policy"]), x, r["policy"]), []).append(r["success_rate"])
    # methods in the registry's order, as the grid passes --runs: a method keeps its colour across the figures
    rank = {m: k for k, m in enumerate(METHODS)}
    out: dict[str, dict] = {}
    for (m, x, _), rates in sorted(cells.items(), key=lambda kv: (rank.get(kv[0][0], len(rank)), kv[0])):
        out.setdefault(m, {}).setdefault(x, []).append(statistics.mean(rates))
    return out


def _pooled(records: list[dict], key) -> dict:
    """{method: {x: (successes, robots)}} over every record at x of every seed; robots None when a record does
    not say how many robots it had (then no interval is drawn)."""
    from envs.evaluation import with_interval

    out: dict[str, dict] = {}
    for r in map(with_interval, records):
        x = key(r)
        if x is None:
            continue
        m = r.get("method", r["policy"])
        k, n = out.setdefault(m, {}).get(x, (0, 0))
        out[m][x] = (None, None) if n is None or "successes" not in r else (k + r["successes"], n + r["robots"])
    return out


def _errorbars(ax, per: dict, scale: float = 1.0, pooled: dict | None = None) -> dict:
    """Mean +- std over seeds per x; where the records give robot counts, the 95% Wilson interval of every seed's
    robots together is shaded behind (how far the robot count alone lets the mean be trusted)."""
    from envs.evaluation import wilson

    drawn = {}
    for k, (m, xs) in enumerate(per.items()):
        x = sorted(xs)
        mean = [100 * statistics.mean(xs[v]) for v in x]
        std = [100 * statistics.pstdev(xs[v]) for v in x]
        ax.errorbar([v * scale for v in x], mean, yerr=std, color=f"C{k}", marker="o", capsize=3,
                    label=f"{m} ({max(len(v) for v in xs.values())} seeds)")
        drawn[m] = {"x": [v * scale for v in x], "mean": mean, "std": std, "seeds": [len(xs[v]) for v in x]}
        counts = [(pooled or {}).get(m, {}).get(v, (None, None)) for v in x]
        if all(n for _, n in counts):
            ci = [wilson(s, n) for s, n in counts]
            drawn[m] |= {"robots": [n for _, n in counts], "ci95": [[100 * lo, 100 * hi] for lo, hi in ci]}
            ax.fill_between([v * scale for v in x], [100 * lo for lo, _ in ci], [100 * hi for _, hi in ci],
                            color=f"C{k}", alpha=0.12, lw=0)
    ax.set_ylim(-5, 105)
    ax.grid(alpha=0.3)
    ax.legend()
    return drawn


def success_vs_speed(records: list[dict], path: Path) -> dict:
    sweep = [r for r in records if r.get("protocol", "speed_sweep") == "speed_sweep" and "kind" in r]
    if not sweep:
        raise ValueError("no course records of a speed sweep in --eval (run cra-eval --protocol paper)")
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    data = _errorbars(ax, _per_policy(sweep, lambda r: r["speed"]), pooled=_pooled(sweep, lambda r: r["speed"]))
    ax.set(xlabel="command velocity [m/s]", ylabel="success rate [%]", title="Success vs command velocity")
    _save(fig, path, data)
    return data


def success_vs_terrain(records: list[dict], path: Path, speed: float = 0.15) -> dict:
    course = [r for r in records if "kind" in r and abs(r["speed"] - speed) < 1e-6]
    ablation = [r for r in course if r.get("protocol") == "ablation"]
    course = ablation or course
    panels = (("stairs_ascend", "stair height [cm]", 100.0), ("slope_ascend", "slope [deg]", 1.0))
    if not any(r["kind"] == kind for r in course for kind, _, _ in panels):
        raise ValueError(f"no stairs or slope ascent records at {speed} m/s in --eval")
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    data = {}
    for ax, (kind, label, scale) in zip(axes, panels):
        rs = [r for r in course if r["kind"] == kind]
        data[kind] = _errorbars(ax, _per_policy(rs, lambda r: r["difficulty"]), scale,
                                pooled=_pooled(rs, lambda r: r["difficulty"]))
        ax.set(xlabel=label, ylabel="success rate [%]", title=f"{kind.split('_')[0]} at {speed} m/s")
    _save(fig, path, data)
    return data


def walk_error(records: list[dict], path: Path) -> dict:
    """v_x error vs env steps of each run's checks (cra-grid --study walk records), one colour per arm."""
    plt = _plt()
    arms: dict[str, list[dict]] = {}
    for r in records:
        arms.setdefault(r["label"], []).append(r)
    if not any(r["checks"] for r in records):
        raise ValueError("no checks in the --walk records")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    data = {}
    for k, (arm, runs) in enumerate(arms.items()):
        c = f"C{k % 10}"
        data[arm] = {}
        for n, r in enumerate(sorted(runs, key=lambda r: r["seed"])):
            pts = [(ch["env_steps"] / 1e6, ch["vx_error"], ch["robots_up"] == ch["robots"]) for ch in r["checks"]
                   if ch["vx_error"] is not None]
            data[arm][f"s{r['seed']}"] = {"env_steps": [ch["env_steps"] for ch in r["checks"]],
                                          "vx_error": [ch["vx_error"] for ch in r["checks"]],
                                          "robots_up": [ch["robots_up"] for ch in r["checks"]],
                                          "robots": [ch["robots"] for ch in r["checks"]],
                                          "walked": r.get("walked")}
            if not pts:
                continue
            ax.plot([p[0] for p in pts], [p[1] for p in pts], color=c, lw=1, alpha=0.8,
                    label=f"{arm} ({len(runs)} seeds)" if n == 0 else None)
            for filled in (True, False):
                sel = [p for p in pts if p[2] == filled]
                ax.scatter([p[0] for p in sel], [p[1] for p in sel], s=14, edgecolors=c,
                           facecolors=c if filled else "none")
    threshold = records[0].get("walk_error")
    if threshold is not None:
        ax.axhline(threshold, color="k", ls="--", lw=0.8, label=f"walking: v_x error <= {threshold} m/s")
    ax.set(xlabel="env steps [M]", ylabel="v_x error [m/s] (robots still up)",
           title="Flat trial during training (hollow: some robots fell)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    _save(fig, path, data)
    return data


def record_stairs(checkpoint: Path, robots: int = 5, speed: float = 0.15, sim: str | None = None,
                  level: int = 2) -> dict:
    """Leg joints' velocity and torque, every step of ``robots`` robots climbing the course's stairs at ``level``
    (0: 5 cm), robots still up only: {joint: {"qd": [...], "tau": [...]}}."""
    import torch

    from cra_warp.terrain.course import EvalCourseConfig
    from cra_warp.cli import quiet_stdout
    from envs.checkpoints import runner_for_checkpoint
    from envs.evaluation import evaluate, judged

    course = EvalCourseConfig(kinds=("stairs_ascend",))
    with quiet_stdout():  # rsl-rl's model dumps
        runner, env = runner_for_checkpoint(checkpoint, num_envs=course.num_levels * robots, sim=sim,
                                            **judged(terrain="eval", course=course))
    policy = runner.get_inference_policy("cpu")
    names = env.robot.joint_names
    legs = [i for i, n in enumerate(names) if n.split("_")[0] in LEG_JOINTS]
    on_level = env.ground.deployment.level == level
    up = torch.ones(env.num_envs, dtype=torch.bool)
    qd, tau = [], []

    def act(obs, dones):
        if qd:  # from the second step on, dones are falls (no time-outs here): a fall ends a robot's record
            up.logical_and_(~dones)
        keep = on_level & up
        qd.append(env.world.joint_vel[keep][:, legs].clone())
        tau.append(env.world.joint_torque[keep][:, legs].clone())
        policy.reset(dones)
        return policy(obs)

    evaluate(env, act, speed)
    qd, tau = torch.cat(qd), torch.cat(tau)
    return {names[j]: {"qd": qd[:, k].tolist(), "tau": tau[:, k].tolist()} for k, j in enumerate(legs)}


def torque_velocity(samples: dict, path: Path, title: str) -> dict:
    plt = _plt()
    kinds = list(dict.fromkeys(n.split("_")[0] for n in samples))
    fig, axes = plt.subplots(1, len(kinds), figsize=(4 * len(kinds), 3.8), squeeze=False)
    for ax, kind in zip(axes[0], kinds):
        for c, side in (("C0", "Left"), ("C3", "Right")):
            s = samples.get(f"{kind}_{side}")
            if s:
                ax.scatter(s["qd"], s["tau"], s=2, alpha=0.3, color=c, label=side)
        ax.set(xlabel="joint velocity [rad/s]", ylabel="torque [N m]", title=kind)
        ax.grid(alpha=0.3)
        ax.legend(markerscale=4)
    fig.suptitle(title)
    _save(fig, path, samples)
    return samples


def main(argv: list[str] | None = None) -> int:
    import json

    from cra_warp.sim.config import BACKENDS

    p = argparse.ArgumentParser(prog="cra-figures", description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", nargs="+", default=[], help="METHOD=DIR[,DIR...] training runs (one per seed)")
    p.add_argument("--eval", nargs="+", type=Path, default=[], help="cra-eval --json files")
    p.add_argument("--torque", type=Path, help="a checkpoint to record climbing stairs for the scatter")
    p.add_argument("--torque-level", type=int, default=2, help="stairs level of the scatter (0: 5 cm, 2: 15 cm)")
    p.add_argument("--sim", choices=BACKENDS, help="simulator of the stairs rollout")
    p.add_argument("--walk", nargs="+", type=Path, default=[],
                   help="cra-grid --study walk check records (<out>/walk/<arm>-s<seed>.json): v_x error vs env steps")
    p.add_argument("--out", type=Path, required=True, help="directory for the PNGs and their JSON")
    a = p.parse_args(argv)
    try:
        if not (a.runs or a.eval or a.torque or a.walk):
            raise ValueError("nothing to draw: give --runs, --eval, --torque and/or --walk")
        runs = dict(parse_arm(t) for t in a.runs)
        records = []
        for f in a.eval:
            try:
                records += json.loads(f.read_text())
            except (OSError, ValueError) as e:
                raise ValueError(f"--eval {f}: not a cra-eval JSON ({e})") from None
        walked = []
        for f in a.walk:
            try:
                walked.append(json.loads(f.read_text()))
                walked[-1]["checks"]
            except (OSError, ValueError, KeyError, TypeError) as e:
                raise ValueError(f"--walk {f}: not a cra-grid --study walk record ({e})") from None
        if a.torque is not None and not a.torque.is_file():
            raise ValueError(f"--torque {a.torque}: no such checkpoint")
        a.out.mkdir(parents=True, exist_ok=True)
        wrote = []
        if runs:
            terrain_levels(runs, a.out / "terrain_level.png")
            wrote.append("terrain_level.png")
        if records:
            success_vs_speed(records, a.out / "success_vs_speed.png")
            success_vs_terrain(records, a.out / "success_vs_terrain.png")
            wrote += ["success_vs_speed.png", "success_vs_terrain.png"]
        if a.torque is not None:
            samples = record_stairs(a.torque, sim=a.sim, level=a.torque_level)
            # the path's last three parts name the run and its iteration without the machine's directories
            torque_velocity(samples, a.out / "torque_velocity.png", f"{Path(*a.torque.parts[-3:])} climbing stairs")
            wrote.append("torque_velocity.png")
        if walked:
            walk_error(walked, a.out / "walk_error.png")
            wrote.append("walk_error.png")
    except ValueError as e:
        print(f"cra-figures: {e}", file=sys.stderr)
        return 2
    skipped = [n for n, given in (("terrain_level (--runs)", runs), ("success (--eval)", records),
                                  ("torque_velocity (--torque)", a.torque)) if not given and not walked]
    print(f"wrote {', '.join(str(a.out / w) for w in wrote)}" + (f"; skipped {', '.join(skipped)}" if skipped else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())

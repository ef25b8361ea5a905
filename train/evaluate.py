"""cra-eval: success rates of policies on the evaluation course (paper IV-B: reach the target without falling),
or the flat-ground walking trial.

    cra-eval runs/<run>/model_120.pt                          # one policy, 10 robots per difficulty level
    cra-eval a/model_120.pt b/model_120.pt --agent-stand --speeds 0.3 0.6 --json eval.json
    cra-eval runs/<run>/model_900.pt --trial flat --robots 200 --seconds 20   # walking on flat ground
    cra-eval runs/<run>/model_900.pt --kinds stairs_descend --video-level 1 --video down.gif  # and one robot's GIF

Every (kind, level) of cra_warp.terrain.course gets --robots-per-level robots at its start, facing its target
(the paper deploys 200 per level; 10 keeps a CPU run at a few minutes). Each robot is commanded forward at the
speed with its heading steered at the target (through its yaw-rate command, also for a policy trained without
heading mode). A robot succeeds when its base comes within the target radius before it ever falls; a fallen robot
is respawned by the env but stays failed. A trial lasts twice the start-target distance over the speed, plus 2 s.
Physical randomisation, pushes and shoves are off (the nominal robot); the actor's observation noise stays on.
--agent-stand adds a floor: the scripted stand (cra_warp.stand), which holds the reference pose and walks nowhere
(the robot's soft ankles make a zero action fall).
The flat trial (--trial flat): --robots robots on flat ground, each commanded (speed, 0) with its heading held at 0
(a policy trained without heading mode: a yaw rate of 0; its drift is part of what the trial measures), for
--seconds; success = no fall; tracking error = mean |v_x - speed| (base frame) over the robots still up, after
the first 2 s (the start from rest). --lateral adds trials commanded (0, v_y), --yaw-rates trials turning at a yaw
rate while walking forward at --turn-speed (heading mode commands no turn to a robot told to stand still); each
record gives the mean tracking error of v_x, v_y and the yaw rate, per step and of each robot's average over the
trial (its gait's sway within a step averages out).

The paper's protocol (IV-B), one option: --protocol paper runs (1) the speed sweep, 200 robots per level of every
kind at each of --speeds (default 0.15 ... 1.0 m/s), and (2) the terrain ablation, 25 robots per level of the
stairs and slope ascents at 0.15 m/s (--robots-per-level and --ablation-robots scale both down for a CPU). Records
name the method (the run info's "variant" key) and its training seed; with several seeds of a method, the table and
--csv also give each cell's mean and std over the seeds.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import torch
from tyro.conf import Positional

from cra_warp.atomic_json import write_json
from cra_warp.cli import Sim, UsageError, check_device, check_sim, parse_args, quiet_stdout
from envs.evaluation import (FALL_GROUND, STAND, course_records, evaluate, flat_trial, judged, method_of,
                             seed_means, with_interval, write_csv)

@dataclass
class EvalArgs:
    checkpoints: Positional[tuple[Path, ...]] = ()   # cra-train checkpoints to compare (model_<it>.pt)
    agent_stand: bool = False                        # also evaluate the scripted stand (a floor)
    speeds: tuple[float, ...] | None = None          # forward commands [m/s]; default 0.5 (paper protocol: its sweep)
    robots_per_level: int | None = None              # default 10 (paper protocol: 200 in the sweep)
    kinds: tuple[str, ...] = ()                      # a subset of the course kinds; default all
    device: str = "cpu"
    sim: Sim | None = None                           # default: each checkpoint's (newton for the stand)
    seed: int = 0
    json: Path | None = None                         # write the records (one per policy, speed, kind, level)
    trial: Literal["course", "flat"] = "course"      # the evaluation course, or the flat walking trial
    robots: int = 200                                # flat trial: robots per policy and speed
    seconds: float = 20.0                            # flat trial: its length [s]
    lateral: tuple[float, ...] = ()                  # flat trial: also lateral commands [m/s], forward 0
    yaw_rates: tuple[float, ...] = ()                # flat trial: also yaw-rate commands [rad/s] ...
    turn_speed: float = 0.3                          # ... while walking forward at this speed [m/s]
    protocol: Literal["none", "paper"] = "none"      # paper: the speed sweep and the 0.15 m/s terrain ablation
    ablation_robots: int = 25                        # paper protocol: robots per level of the ablation
    csv: Path | None = None                          # write the records (and the seed means) as CSV
    # course: a GIF of the first robot on --video-level of the first kind (first policy and speed), to its target
    # or its fall (MuJoCo's offscreen renderer, 16.7 frames/s, a camera beside its path)
    video: Path | None = None
    video_level: int = 0                             # the course level of --video (0: the easiest)


# The paper's protocol (IV-B): its velocity range is not given in numbers; ours spans the training commands.
PAPER_SPEEDS = (0.15, 0.3, 0.5, 0.75, 1.0)
PAPER_SWEEP_ROBOTS = 200                             # robots per (kind, level), every kind
PAPER_ABLATION = {"speed": 0.15, "kinds": ("stairs_ascend", "slope_ascend")}
DEFAULT_SPEEDS, DEFAULT_ROBOTS = (0.5,), 10          # without the protocol


def _policies(a: EvalArgs):
    """(name, factory) pairs; factory(num_envs, overrides) -> (env, act)."""
    from cra_warp.sim import WorldConfig
    from envs.loco_config import LocoConfig
    from envs.locomotion import LocoEnv

    def stand(num_envs, overrides):
        with quiet_stdout():
            env = LocoEnv(LocoConfig(num_envs=num_envs, device=a.device, seed=a.seed,
                                     world=WorldConfig(**({"backend": a.sim} if a.sim else {})), **overrides))
        return env, lambda obs, dones: env.stand_actions()

    def checkpoint(path):
        def make(num_envs, overrides):
            from envs.checkpoints import runner_for_checkpoint

            with quiet_stdout():  # rsl-rl's model dumps and the backends' set-up notes, once per policy and speed
                runner, env = runner_for_checkpoint(path, num_envs=num_envs, device=a.device, sim=a.sim,
                                                    seed=a.seed, **overrides)
            policy = runner.get_inference_policy(a.device)

            def act(obs, dones):
                policy.reset(dones)  # a respawned robot starts with a fresh recurrent state
                return policy(obs)   # deterministic (mean) actions
            return env, act
        return make

    out = [(str(p), checkpoint(p)) for p in a.checkpoints]
    return out + [(STAND, stand)] if a.agent_stand else out


def run_protocol(a: EvalArgs) -> list[dict]:
    """The paper's protocol: the speed sweep over every kind and level, then the 0.15 m/s terrain ablation."""
    import dataclasses

    sweep = dataclasses.replace(a, protocol="none", speeds=a.speeds or PAPER_SPEEDS,
                                robots_per_level=a.robots_per_level or PAPER_SWEEP_ROBOTS)
    ab = PAPER_ABLATION
    ablation = dataclasses.replace(a, protocol="none", speeds=(ab["speed"],), robots_per_level=a.ablation_robots,
                                   kinds=tuple(k for k in ab["kinds"] if not a.kinds or k in a.kinds) or ab["kinds"])
    return ([{**r, "protocol": "speed_sweep"} for r in run(sweep)]
            + [{**r, "protocol": "ablation"} for r in run(ablation)])


def run(a: EvalArgs) -> list[dict]:
    import dataclasses

    if a.protocol == "paper":
        return run_protocol(a)
    a = dataclasses.replace(a, speeds=a.speeds or DEFAULT_SPEEDS, robots_per_level=a.robots_per_level or DEFAULT_ROBOTS)
    methods = {name: method_of(name) for name, _ in _policies(a)}
    return [{**methods[r["policy"]], **r, "fall_ground": FALL_GROUND} for r in _run(a)]


def _run(a: EvalArgs) -> list[dict]:
    from cra_warp.host_memory import keep_freed_memory
    from cra_warp.terrain.course import EVAL_KINDS, EvalCourseConfig

    keep_freed_memory()
    if a.trial == "flat":
        records = []
        commands = ([(v, 0.0, 0.0) for v in a.speeds] + [(0.0, v, 0.0) for v in a.lateral]
                    + [(a.turn_speed, 0.0, w) for w in a.yaw_rates])
        for name, make in _policies(a):
            for vx, vy, wz in commands:
                torch.manual_seed(a.seed)
                env, act = make(a.robots, judged(terrain="flat"))
                top = env.cfg.commands.ang_vel_yaw[1]
                if abs(wz) > top:
                    raise UsageError(f"--yaw-rates must be within the training range +-{top} rad/s, got {wz}")
                records.append(with_interval({"policy": name, "speed": vx, "trial": "flat", "robots": a.robots,
                                              "seconds": a.seconds, **flat_trial(env, act, vx, a.seconds, vy, wz)}))
        return records
    course = EvalCourseConfig(kinds=a.kinds or EVAL_KINDS)
    num_envs = len(course.kinds) * course.num_levels * a.robots_per_level
    records = []
    for name, make in _policies(a):
        for speed in a.speeds:
            torch.manual_seed(a.seed)
            env, act = make(num_envs, judged(terrain="eval", course=course))
            video = _CourseVideo(env, speed, a) if a.video is not None and not records else None
            records += course_records(env, evaluate(env, act, speed, video), name, speed, a.robots_per_level)
            if video is not None:
                video.close()
    return records


class _CourseVideo:
    """evaluate()'s on_step that draws the first robot on ``a.video_level`` of the first kind at video.FPS,
    until it reaches its target (and half a second beyond) or falls (the env respawns a fallen robot at once: the
    frame after a fall would show it back at the start)."""

    def __init__(self, env, speed: float, a: EvalArgs):
        from cra_warp.video import FPS, RolloutVideo, frame_every

        dep, course = env.ground.deployment, env.ground.course
        self.i = int(((dep.kind == 0) & (dep.level == a.video_level)).nonzero()[0])
        self.every, self.tail = frame_every(env.dt), round(0.5 * FPS)
        self.gif = RolloutVideo(env.world, env.ground.boxes, a.video, fps=1 / (self.every * env.dt), robot=self.i,
                                heading=float(dep.yaw[self.i]))
        kind, difficulty = course.kinds[0], float(course.difficulty[0, a.video_level])
        unit, scale = ("deg", 1) if kind.startswith("slope") else ("cm", 100)
        self.title = f"{kind} {difficulty * scale:.0f} {unit}"
        self.speed, self.dt, self.done = speed, env.dt, False

    def __call__(self, k: int, tally) -> None:
        if self.done:
            return
        fell, reached = bool(tally.fell[self.i]), bool(tally.succeeded[self.i])
        if fell:
            self.done = True
            self.gif.frames.extend(self.gif.frames[-1:] * self.tail)  # hold the last frame before the respawn
            return
        if k % self.every == 0:
            state = ("reached the target", (120, 255, 120)) if reached else ("on its way", (255, 255, 255))
            self.gif.frame([(f"{self.title}   cmd {self.speed:.2f} m/s   t {(k + 1) * self.dt:5.2f} s",
                             (255, 255, 255)), state])
        if reached:
            self.tail -= 1
            self.done = self.tail <= 0

    def close(self) -> None:
        self.gif.close()


def short_names(policies: list[str]) -> dict[str, str]:
    """Each policy path's shortest tail of path components that no other policy shares (seed runs of one setup
    differ only far up their paths, so a fixed-width tail would print them alike)."""
    parts = {p: p.split("/") for p in dict.fromkeys(policies)}
    for k in range(1, max(map(len, parts.values()), default=0) + 1):
        names = {p: "/".join(v[-k:]) for p, v in parts.items()}
        if len(set(names.values())) == len(names):
            return names
    return {}   # no policies (for any others the whole paths, k = the longest, already differ)


def print_table(records: list[dict]) -> None:
    """One block per (policy, speed): a row per kind, success % per level, the level's difficulty on top (the flat
    trial: one row per policy and command)."""
    means = [m for m in seed_means(records) if m["seeds"] > 1]
    if means:
        print(f"\nmean (std) success % over seeds: {', '.join(dict.fromkeys(m['method'] for m in means))}")
        for m in means:
            where = (m["kind"] and f"{m['kind']} level {m['level']}"
                     or f"{m['trial']} v_y {m['lateral'] or 0:+.2f} yaw {m['yaw_rate'] or 0:+.2f}")
            ci = f" [{_pct(m['success_ci95'])}] of {m['robots']} robots" if m.get("success_ci95") else ""
            print(f"  {m['method']:12} {m['protocol'] or '':12} {m['speed']:5.2f} m/s {where:24} "
                  f"{100 * m['success_mean']:5.1f} ({100 * m['success_std']:4.1f}) over {m['seeds']}{ci}")
    if records and records[0].get("trial") == "flat":
        names = short_names([r["policy"] for r in records])
        w = max(len("policy"), *map(len, names.values()))
        cols = (("v_x err", "tracking_error", 3), ("v_y err", "tracking_error_y", 3),
                ("yaw err", "tracking_error_yaw", 3), ("mean v_x", "mean_error", 3), ("mean v_y", "mean_error_y", 3),
                ("mean yaw", "mean_error_yaw", 3),
                ("steps/s", "touchdowns_per_s", 2), ("one foot", "single_support", 2))
        print(f"{'policy':{w}} {'v_x':>5} {'v_y':>5} {'yaw':>5} {'robots':>6} {'success':>8} {'95% CI':>9} "
              + " ".join(f"{c:>{max(len(c), 7)}}" for c, _, _ in cols))
        for r in map(with_interval, records):
            vals = ("-" if r.get(k) is None else f"{r[k]:.{p}f}" for _, k, p in cols)
            print(f"{names[r['policy']]:{w}} {r['speed']:5.2f} {r.get('lateral', 0.0):5.2f} "
                  f"{r.get('yaw_rate', 0.0):5.2f} {r['robots']:6d} {100 * r['success_rate']:7.1f}% "
                  f"{_pct(r.get('success_ci95')):>9} "
                  + " ".join(f"{v:>{max(len(c), 7)}}" for v, (c, _, _) in zip(vals, cols)))
        return
    units = {"stairs": ("cm", 100), "slope": ("deg", 1), "uneven": ("cm", 100)}
    blocks = {}
    for r in records:
        blocks.setdefault((r["policy"], r["speed"], r.get("protocol")), []).append(r)
    for (policy, speed, protocol), rs in blocks.items():
        print(f"\n{policy} @ {speed:.2f} m/s{f' ({protocol})' if protocol else ''}: success % (falls %) and the "
              f"success's 95% interval, {rs[0]['robots']} robots per level")
        for kind in dict.fromkeys(r["kind"] for r in rs):
            row = [with_interval(r) for r in rs if r["kind"] == kind]
            unit, scale = units[kind.split("_")[0]]
            print(f"  {kind:15} " + " ".join(f"{r['difficulty'] * scale:>6.0f}{unit:<3}" for r in row))
            print(f"  {'':15} " + " ".join(f"{100 * r['success_rate']:>4.0f} ({100 * r['fall_rate']:>2.0f})"
                                           for r in row))
            print(f"  {'':15} " + " ".join(f"{_pct(r.get('success_ci95')):>9}" for r in row))
            if all(r.get("forward_speed") is not None for r in row):  # on the way: clock rate x, v_x m/s
                print(f"  {'rate, v_x':15} " + " ".join(
                    f"{'-' if r.get('gait_rate') is None else format(r['gait_rate'], '.2f'):>4} "
                    f"{r['forward_speed']:+.2f}".rjust(9) for r in row))


def _pct(ci) -> str:
    """A 95% interval as "lo-hi" in whole percent ("-" without one)."""
    return f"{100 * ci[0]:.0f}-{100 * ci[1]:.0f}" if ci else "-"


def main(argv: list[str] | None = None) -> int:
    from cra_warp.learning.checkpoint import CheckpointError
    from cra_warp.terrain.course import EVAL_KINDS

    try:
        a = parse_args(EvalArgs, argv, __doc__)
        if not a.checkpoints and not a.agent_stand:
            raise UsageError("nothing to evaluate: give checkpoints and/or --agent-stand")
        missing = [str(p) for p in a.checkpoints if not p.is_file()]
        if missing:
            raise UsageError(f"checkpoint not found: {', '.join(missing)}")
        bad = [k for k in a.kinds if k not in EVAL_KINDS]
        if bad:
            raise UsageError(f"--kinds must be among {', '.join(EVAL_KINDS)}, got {', '.join(bad)}")
        if a.robots < 1 or not (math.isfinite(a.seconds) and a.seconds > 2.0):
            raise UsageError(f"--robots must be >= 1 and --seconds > 2, got {a.robots} and {a.seconds}")
        if (a.robots_per_level is not None and a.robots_per_level < 1) or a.ablation_robots < 1:
            raise UsageError(f"--robots-per-level and --ablation-robots must be >= 1, got {a.robots_per_level} "
                             f"and {a.ablation_robots}")
        if a.speeds is not None and not (a.speeds and all(math.isfinite(v) and v > 0 for v in a.speeds)):
            raise UsageError(f"--speeds must be finite and > 0 m/s, got {a.speeds}")
        if (a.lateral or a.yaw_rates) and a.trial != "flat":
            raise UsageError("--lateral and --yaw-rates are commands of the flat trial (--trial flat)")
        if not all(math.isfinite(v) and v != 0 for v in (*a.lateral, *a.yaw_rates)):
            raise UsageError(f"--lateral and --yaw-rates must be finite and non-zero, got {a.lateral} {a.yaw_rates}")
        if a.yaw_rates and not (math.isfinite(a.turn_speed) and a.turn_speed > 0):
            raise UsageError(f"--turn-speed must be finite and > 0 m/s (turning is commanded while walking), "
                             f"got {a.turn_speed}")
        for flag, path in (("--json", a.json), ("--csv", a.csv)):
            if path is not None and not path.parent.is_dir():
                raise UsageError(f"{flag} {path}: no such directory {path.parent}")
        if a.protocol == "paper" and a.trial != "course":
            raise UsageError("--protocol paper runs the course (not --trial flat)")
        if a.video is not None:
            from cra_warp.terrain.course import EvalCourseConfig
            from cra_warp.video import check_gif_path

            if a.trial != "course" or a.protocol != "none":
                raise UsageError("--video records a course run (not --trial flat or --protocol paper)")
            if why := check_gif_path(a.video):
                raise UsageError(why)
            if not 0 <= a.video_level < EvalCourseConfig().num_levels:
                raise UsageError(f"--video-level must be 0 ... {EvalCourseConfig().num_levels - 1}, "
                                 f"got {a.video_level}")
        check_sim(a.sim, a.device)
        check_device(a.device)
        records = run(a)
    except (UsageError, CheckpointError) as e:
        print(f"cra-eval: {e}", file=sys.stderr)
        return 2
    print_table(records)
    if a.json is not None:
        write_json(a.json, records)
        print(f"wrote {a.json}")
    if a.csv is not None:
        write_csv(a.csv, records)
        print(f"wrote {a.csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The evaluation library (paper IV-B): the course deployment and the flat walking trial, each robot's tally, and
the statistics of their records (Wilson intervals, seed means, the per-method summary, CSV). cra-eval, cra-grid and
cra-figures are its command lines.

A course deployment (``evaluate``) runs the env on the "eval" terrain: every robot commanded forward at one speed,
its heading steered at its target; it succeeds when its base comes within the target radius before it ever falls,
and a fallen robot is respawned by the env but stays failed. A trial lasts twice the start-target distance over the
speed, plus 2 s. The flat trial (``flat_trial``) holds one command on flat ground and measures falls, tracking
and the gait.
"""

from __future__ import annotations

import math
from pathlib import Path

import torch

STAND = "stand"  # the name of the scripted-stand floor in reports
# Every policy is judged by one fall rule, whatever it trained with (LocoConfig.fall_ground): cra-eval's records say
# which. Records without "fall_ground" were judged by "base", which ended robots at stair risers: crouched ones from
# 15 cm, upright ones from 25-30 cm (docs/experiments.md).
FALL_GROUND = "lowest"


def judged(**overrides) -> dict:
    """LocoConfig overrides of an env that judges a policy (``overrides`` added): the nominal robot (no physical
    randomisation, pushes or shoves), no time-outs (the trial clock is the evaluator's) and FALL_GROUND."""
    from envs.loco_config import DomainRandConfig

    return dict(randomization=DomainRandConfig(enabled=False), episode_length_s=1e6, fall_ground=FALL_GROUND,
                **overrides)


def judged_today(path: Path) -> bool:
    """Whether cra-eval records at ``path`` were judged by today's fall rule (FALL_GROUND): a study re-evaluates
    records that were not."""
    import json

    records = json.loads(Path(path).read_text())
    return bool(records) and all(r.get("fall_ground") == FALL_GROUND for r in records)


def wilson(successes: float, n: int, z: float = 1.96) -> tuple[float, float] | None:
    """The 95% Wilson score interval of a success rate of ``successes`` out of ``n`` robots (None for n = 0).
    Unlike rate +- 1.96 sqrt(p(1-p)/n) it stays within [0, 1] and is not empty at 0 or n: 3 of 10 reads
    0.11-0.60, so two course cells of 10 robots reading 30% and 10% do not differ by more than chance."""
    if not n:
        return None
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def with_interval(record: dict) -> dict:
    """``record`` with its success count and 95% Wilson interval (from success_rate and robots; records written
    before the interval was recorded get it here too)."""
    n = record.get("robots")
    if not n or record.get("success_rate") is None:
        return record
    k = round(record["success_rate"] * n)
    return {**record, "successes": k, "success_ci95": list(wilson(k, n))}


class Tally:
    """Per-robot outcome of one deployment: a robot succeeds at the first step its base is within the target
    radius, provided it has not fallen before; falls after success do not undo it. While a robot is on its way
    (trial running, neither succeeded nor fallen) it also sums how it walks: GAIT's quantities, per step."""

    GAIT = ("gait_rate", "forward_speed", "swing_height", "pitch_deg")

    def __init__(self, num: int, device):
        self.fell = torch.zeros(num, dtype=torch.bool, device=device)
        self.succeeded = torch.zeros(num, dtype=torch.bool, device=device)
        self.fell_at = torch.full((num,), math.nan, device=device)   # [m] how far along its way a robot fell
        self.gait_sums = torch.zeros(num, len(self.GAIT), device=device)
        self.gait_steps = torch.zeros(num, device=device)

    def update(self, reached: torch.Tensor, fell: torch.Tensor, active: torch.Tensor, way: torch.Tensor | None = None):
        """reached / fell [n] bool this step; only ``active`` robots (trial still running) count. ``way`` [n]: how
        far along its way [m] each robot was before this step, kept for those that fall now."""
        self.succeeded |= reached & ~self.fell & active
        falls = fell & active & ~self.succeeded & ~self.fell
        self.fell |= falls
        if way is not None:
            self.fell_at = torch.where(falls, way, self.fell_at)

    def walk(self, env, active: torch.Tensor):
        """Sum this step's gait of the ``active`` robots still on their way: the clock's rate (x the nominal
        1 / T_cycle: what the policy chose, 1 for a fixed cycle), forward speed [m/s, base frame], mean sole height
        of the feet in the air [m] and pelvis pitch [deg, > 0 leaning forward]."""
        on = active & ~self.succeeded & ~self.fell
        g = env.projected_gravity
        swing = ~env.contact
        rate = ((1.0 + env.cfg.gait.alpha * env.clock.deltas[:, 0]).clamp(min=0.0) if env.cfg.variant == "adaptive"
                else torch.ones_like(g[:, 0]))
        now = torch.stack([rate, env.base_lin_vel[:, 0],
                           (env.sole_height * swing).sum(-1) / swing.sum(-1).clamp(min=1),
                           torch.rad2deg(torch.atan2(g[:, 0], -g[:, 2]))], -1)
        self.gait_sums += now * on.unsqueeze(-1)
        self.gait_steps += on

    def gait(self, select: torch.Tensor, uses_clock: bool = True) -> dict[str, float | None]:
        """Means over the ``select``ed robots [n] bool of each robot's mean gait (robots never on their way left
        out); the rate is None without a clock."""
        seen = select & (self.gait_steps > 0)
        if not seen.any():
            return dict.fromkeys(self.GAIT)
        means = (self.gait_sums[seen] / self.gait_steps[seen].unsqueeze(-1)).mean(0).tolist()
        out = dict(zip(self.GAIT, means))
        if not uses_clock:
            out["gait_rate"] = None
        return out


def trial_steps(dep, speed: float, dt: float) -> torch.Tensor:
    """[n] steps each robot's trial lasts: twice its start-target distance at ``speed``, plus 2 s."""
    dist = (dep.target[:, :2] - dep.start[:, :2]).norm(dim=-1)
    return ((2 * dist / speed + 2.0) / dt).ceil().long()


def evaluate(env, act, speed: float, on_step=None) -> Tally:
    """Run one deployment (env on the "eval" terrain) until every robot succeeded, fell or ended its trial.
    ``act(obs, dones)`` returns actions and resets whatever recurrent state it keeps for the robots in ``dones``;
    ``on_step(k, tally)``, if given, is called after each step's tally (a video records there)."""
    dep = env.ground.deployment
    steps = trial_steps(dep, speed, env.dt)
    tally = Tally(env.num_envs, env.device)
    forward = torch.tensor([speed, 0.0], device=env.device).expand(env.num_envs, 2)
    env.reset_idx(torch.arange(env.num_envs, device=env.device))   # every robot at its start, at rest
    dones = torch.ones(env.num_envs, dtype=torch.bool, device=env.device)  # fresh recurrent state for all
    with torch.inference_mode():
        for k in range(int(steps.max())):
            # observed once at the start; later the step's own observation shows the steered command
            env.hold_commands(forward, dep.heading_to_target(env.root_pos), refresh=k == 0, steer=True)
            way = dep.progress(env.root_pos)  # before the step: a robot that falls in it is respawned inside
            _, _, d, extras = env.step(act(env.get_observations(), dones))
            dones = d.bool()
            fell = dones & ~extras["time_outs"]
            # a fallen robot was respawned inside step(): its position no longer tells where it got to
            tally.walk(env, (k < steps) & ~dones)  # before the update: the step that ends a trial counts
            tally.update(dep.reached(env.root_pos) & ~fell, fell, k < steps, way)
            if on_step is not None:
                on_step(k, tally)
            # a success or a fall is final: once every robot has one or is past its trial, the rest changes nothing
            if k % 25 == 0 and not ((k < steps) & ~tally.succeeded & ~tally.fell).any():
                break
    return tally


def flat_trial(env, act, speed: float, seconds: float, lateral: float = 0.0, yaw_rate: float = 0.0) -> dict:
    """Every robot commanded (speed, lateral) on flat ground for ``seconds``, its heading held at 0, or with
    ``yaw_rate`` turning at that rate (the training's heading controller, steered to a heading ahead of the robot's
    own). Fall rate, and after the first 2 s over the robots still up: the mean tracking error of each commanded
    quantity (v_x, v_y in the base frame, yaw rate against the command in force), the same for each robot's average
    over the trial, then averaged over robots (the gait's sway within a step averages out of it), that average
    with its sign (offset: actual - command, e.g. < 0 for a robot slower than told), and the
    gait: touchdowns per second (both feet together) and the share of steps on one foot (a robot that stands still
    has neither)."""
    n, dev = env.num_envs, env.device
    fell = torch.zeros(n, dtype=torch.bool, device=dev)
    err, count = torch.zeros(3, device=dev), torch.zeros((), device=dev)
    signed, up_steps = torch.zeros(n, 3, device=dev), torch.zeros(n, device=dev)
    touchdowns, single = torch.zeros((), device=dev), torch.zeros((), device=dev)
    lin = torch.tensor([speed, lateral], device=dev).expand(n, 2)
    heading = torch.zeros(n, device=dev)
    env.reset_idx(torch.arange(n, device=dev))
    dones = torch.ones(n, dtype=torch.bool, device=dev)
    turn_by_heading = bool(yaw_rate) and env.cfg.commands.heading_mode  # else the yaw rate is commanded as it is
    with torch.inference_mode():
        for k in range(round(seconds / env.dt)):
            if turn_by_heading:  # a heading ahead of the robot's own, seen in this step's observation
                heading = _turning_heading(env, yaw_rate)
            env.hold_commands(lin, heading, refresh=k == 0 or turn_by_heading, yaw_rate=yaw_rate)
            commanded = env.commands[:, :3].clone()   # what this step's action was chosen for
            _, _, d, extras = env.step(act(env.get_observations(), dones))
            dones = d.bool()
            fell |= dones & ~extras["time_outs"]
            if (k + 1) * env.dt > 2.0:
                up = ~fell & ~dones  # a robot reset in this step shows its new episode's first contact
                actual = torch.stack([env.base_lin_vel[:, 0], env.base_lin_vel[:, 1], env.base_ang_vel[:, 2]], -1)
                err += ((actual - commanded).abs() * up[:, None]).sum(0)
                signed += (actual - commanded) * up[:, None]
                up_steps += up
                touchdowns += (env.first_contact.sum(-1) * up).sum()
                single += ((env.contact.sum(-1) == 1) & up).sum()
                count += up.sum()
    up_s, ok = count * env.dt, count > 0
    counted = up_steps > 0
    per_robot = signed[counted] / up_steps[counted, None]
    mean_err = per_robot.abs().mean(0).tolist() if counted.any() else [None] * 3
    offset = per_robot.mean(0).tolist() if counted.any() else [None] * 3   # signed: which way the robots miss
    return {"lateral": lateral, "yaw_rate": yaw_rate,
            "fall_rate": float(fell.float().mean()), "success_rate": float(1.0 - fell.float().mean()),
            "tracking_error": float(err[0] / count) if ok else None,
            "tracking_error_y": float(err[1] / count) if ok else None,
            "tracking_error_yaw": float(err[2] / count) if ok else None,
            "mean_error": mean_err[0], "mean_error_y": mean_err[1], "mean_error_yaw": mean_err[2],
            "offset": offset[0], "offset_y": offset[1], "offset_yaw": offset[2],
            "touchdowns_per_s": float(touchdowns / up_s) if ok else None,
            "single_support": float(single / count) if ok else None}


def _turning_heading(env, yaw_rate: float) -> torch.Tensor:
    """A heading the training's P-controller (rate = gain x heading error, clamped) turns towards at ``yaw_rate``."""
    from cra_warp.rotations import yaw

    return yaw(env.world.root_quat) + yaw_rate / env.cfg.commands.heading_gain


def _median(x: torch.Tensor) -> float | None:
    return float(x.median()) if len(x) else None


def course_records(env, tally: Tally, policy: str, speed: float, robots_per_level: int) -> list[dict]:
    """One record per (kind, level) of a course deployment's ``tally``: success and fall rate with the success's
    interval, the level's difficulty, how far along their way the robots that fell did so (the median, m from the
    start towards the target: on stairs, which riser) and how the robots walked on their way."""
    c, dep = env.ground.course, env.ground.deployment
    success = c.success_rate(dep, tally.succeeded)
    falls = c.success_rate(dep, tally.fell)
    records = []
    for k, kind in enumerate(c.kinds):
        for lv in range(c.cfg.num_levels):
            cell = (dep.kind == k) & (dep.level == lv)
            records.append(with_interval({
                "policy": policy, "speed": speed, "kind": kind, "level": lv,
                "difficulty": float(c.difficulty[k, lv]), "robots": robots_per_level,
                "success_rate": float(success[k, lv]), "fall_rate": float(falls[k, lv]),
                "fell_at_m": _median(tally.fell_at[cell & tally.fell]),
                **tally.gait(cell, env.cfg.uses_clock)}))
    return records


def method_of(name: str) -> dict:
    """{"method", "train_seed"} of a policy in the records: the checkpoint's method (its run info's "variant" key)
    and seed (the stand: itself)."""
    if name == STAND:
        return {"method": STAND, "train_seed": None}
    from cra_warp.learning.checkpoint import read_checkpoint

    info = read_checkpoint(name).get("infos") or {}
    return {"method": info.get("variant", "ours"), "train_seed": info.get("seed")}


def seed_means(records: list[dict]) -> list[dict]:
    """Per method and cell (protocol, trial, speed, kind, level): mean and std of the success rate over the
    method's checkpoints (its seeds; std 0 for one)."""
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        key = (r.get("method"), r.get("protocol"), r.get("trial", "course"), r["speed"], r.get("lateral"),
               r.get("yaw_rate"), r.get("kind"), r.get("level"))
        groups.setdefault(key, []).append(r)
    out = []
    for (method, protocol, trial, speed, lateral, yaw_rate, kind, level), rs in groups.items():
        v = torch.tensor([r["success_rate"] for r in rs], dtype=torch.float64)
        pooled = [with_interval(r) for r in rs]
        robots = sum(r.get("robots") or 0 for r in pooled) if all(r.get("robots") for r in pooled) else None
        ci = wilson(sum(r["successes"] for r in pooled), robots) if robots else None
        out.append({"method": method, "protocol": protocol, "trial": trial, "speed": speed, "lateral": lateral,
                    "yaw_rate": yaw_rate, "kind": kind,
                    "level": level, "difficulty": rs[0].get("difficulty"), "seeds": len(rs),
                    "success_mean": float(v.mean()), "success_std": float(v.std(unbiased=False)),
                    # every seed's robots together: how sure the mean is from the robot count alone
                    "robots": robots, "success_ci95": list(ci) if ci else None})
    return out


def method_summary(records: list[dict]) -> dict[str, dict]:
    """Per method, over its speed-sweep records (every speed, kind and level): each checkpoint's (seed's) mean
    success and fall rate, and their mean and std over the seeds - the one-line-per-method table of a grid."""
    per: dict[str, dict[str, list[dict]]] = {}
    for r in records:
        if r.get("protocol", "speed_sweep") == "speed_sweep" and "kind" in r:
            per.setdefault(r.get("method") or r["policy"], {}).setdefault(r["policy"], []).append(r)
    out = {}
    for method, policies in per.items():
        row = {"seeds": len(policies)}
        for rate in ("success_rate", "fall_rate"):
            v = torch.tensor([sum(r[rate] for r in rs) / len(rs) for rs in policies.values()], dtype=torch.float64)
            row[rate] = {"per_seed": v.tolist(), "mean": float(v.mean()), "std": float(v.std(unbiased=False))}
        out[method] = row
    return out


def write_csv(path: Path, records: list[dict]) -> None:
    """The records, then the seed means, as one CSV (a "table" column tells them apart); written atomically."""
    import csv
    import io

    from cra_warp.atomic_json import write_text

    rows = [{"table": "record", **r} for r in records] + [{"table": "seed_mean", **m} for m in seed_means(records)]
    cols = list(dict.fromkeys(k for r in rows for k in r))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols)
    w.writeheader()
    w.writerows(rows)
    write_text(path, buf.getvalue())

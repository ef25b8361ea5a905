"""cra-probe: how much terrain a policy's actor latent m_a holds, by a linear probe (the paper's claim, III-C).

    cra-probe runs/a/model_3000.pt runs/b/model_3000.pt --json tools/results/probe.json

Each checkpoint's policy runs on the evaluation course (every kind and level; robots commanded forward at --speed
with their heading at the target, respawned when they fall) for --steps control steps; every step records the frozen
actor latent m_a and the terrain around the robot: the critic's 17x11 height map (ground under and ahead of the
base) and the two 5x5 maps around the soles, each minus its mean (the ground's shape, not how high the robot holds
itself above it, which proprioception knows), and two summaries of the map ahead: its slope (a plane fit, two
gradients) and its largest step (the largest height change between neighbouring cells along the heading). Ridge
regression (standardised inputs, --ridge) from m_a to each target group is fitted on half of the robots and scored
on the other half (R^2 = 1 - residual / total variance, over the group's outputs). The same probe from the actor's
own observation o_t (proprioception, no terrain) is the reference: what m_a adds over it is terrain it inferred.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import torch
from tyro.conf import Positional

from cra_warp.atomic_json import write_json
from cra_warp.cli import Sim, UsageError, parse_args

GROUPS = ("height_map", "foot_maps", "slope", "step")


@dataclass
class ProbeArgs:
    checkpoints: Positional[tuple[Path, ...]] = ()
    steps: int = 400                 # control steps recorded per checkpoint (after --warmup)
    warmup: int = 50                 # steps run before recording (the recurrent state settles)
    robots_per_level: int = 2        # robots on each (kind, level) of the course: 70 with the default course
    speed: float = 0.5
    ridge: float = 10.0              # L2 penalty on the standardised inputs
    sim: Sim | None = None           # default: the checkpoint's
    seed: int = 0
    json: Path | None = None


def terrain_targets(env, obs) -> dict[str, torch.Tensor]:
    """The probe's targets [N, k] per group from the env's privileged observations (noise-free)."""
    hmap = obs["height_map"][:, 0]                                          # [N, 17 (x, ahead), 11 (y)]
    n, nx, ny = hmap.shape
    x = torch.linspace(-1.0, 1.0, nx).view(1, nx, 1).expand(n, nx, ny)
    y = torch.linspace(-1.0, 1.0, ny).view(1, 1, ny).expand(n, nx, ny)
    design = torch.stack([x, y, torch.ones_like(x)], -1).reshape(n, -1, 3)  # plane fit h = a x + b y + c
    coef = torch.linalg.lstsq(design, hmap.reshape(n, -1, 1)).solution[:, :2, 0]
    step = (hmap[:, 1:] - hmap[:, :-1]).abs().amax(dim=(1, 2)).unsqueeze(-1)
    # shapes only: each map minus its own mean, so the base's and the soles' heights above the ground (which
    # proprioception knows) are not part of the target
    feet = obs["privileged"][:, env.priv_layout["foot_height_maps"]].reshape(n, 2, -1)
    return {"height_map": (hmap - hmap.mean(dim=(1, 2), keepdim=True)).reshape(n, -1),
            "foot_maps": (feet - feet.mean(-1, keepdim=True)).reshape(n, -1), "slope": coef, "step": step}


def record(runner, env, a: ProbeArgs) -> dict[str, torch.Tensor]:
    """[T, N, ...] latents, actor observations and targets of one checkpoint's rollout."""
    policy = runner.get_inference_policy("cpu")
    dep = env.ground.deployment
    forward = torch.tensor([a.speed, 0.0]).expand(env.num_envs, 2)
    env.reset_idx(torch.arange(env.num_envs))
    dones = torch.ones(env.num_envs, dtype=torch.bool)
    out: dict[str, list] = {"latent": [], "obs": [], **{g: [] for g in GROUPS}}
    with torch.inference_mode():
        for k in range(a.warmup + a.steps):
            env.hold_commands(forward, dep.heading_to_target(env.root_pos), refresh=k == 0, steer=True)
            obs = env.get_observations()
            policy.reset(dones)
            actions = policy(obs)
            if k >= a.warmup:
                out["latent"].append(policy.latent.reshape(env.num_envs, -1).clone())
                out["obs"].append(obs["policy"].clone())
                for g, t in terrain_targets(env, obs).items():
                    out[g].append(t.clone())
            _, _, d, _ = env.step(actions)
            dones = d.bool()
    return {k: torch.stack(v) for k, v in out.items()}


def ridge_r2(x: torch.Tensor, y: torch.Tensor, train: torch.Tensor, lam: float) -> float:
    """R^2 on the held-out rows of a ridge fit on the ``train`` rows; x [M, D], y [M, K] (float64)."""
    x, y = x.double(), y.double()
    xt, yt, xv, yv = x[train], y[train], x[~train], y[~train]
    mu, sd = xt.mean(0), xt.std(0).clamp(min=1e-6)
    xt, xv = (xt - mu) / sd, (xv - mu) / sd
    xt, xv = torch.cat([xt, torch.ones(len(xt), 1, dtype=x.dtype)], 1), torch.cat([xv, torch.ones(len(xv), 1,
                                                                                                   dtype=x.dtype)], 1)
    reg = lam * torch.eye(xt.shape[1], dtype=x.dtype)
    reg[-1, -1] = 0.0  # the intercept is not penalised
    w = torch.linalg.solve(xt.T @ xt + reg, xt.T @ yt)
    resid = ((yv - xv @ w) ** 2).sum()
    total = ((yv - yt.mean(0)) ** 2).sum()
    return float(1.0 - resid / total) if total > 0 else float("nan")


def probe(data: dict[str, torch.Tensor], lam: float, seed: int) -> dict[str, dict[str, float]]:
    """{source ("latent" | "obs") -> {group -> held-out R^2}}; robots split in halves (no shared trajectories)."""
    t, n = data["latent"].shape[:2]
    gen = torch.Generator().manual_seed(seed)
    robots = torch.randperm(n, generator=gen) < n // 2
    train = robots.unsqueeze(0).expand(t, n).reshape(-1)
    flat = {k: v.reshape(t * n, -1) for k, v in data.items()}
    return {src: {g: ridge_r2(flat[src], flat[g], train, lam) for g in GROUPS} for src in ("latent", "obs")}


def run(a: ProbeArgs) -> list[dict]:
    from cra_warp.terrain.course import EVAL_KINDS, EvalCourseConfig
    from envs.checkpoints import runner_for_checkpoint
    from envs.evaluation import judged

    course = EvalCourseConfig(kinds=EVAL_KINDS)
    num_envs = len(course.kinds) * course.num_levels * a.robots_per_level
    records = []
    for path in a.checkpoints:
        torch.manual_seed(a.seed)
        runner, env = runner_for_checkpoint(path, num_envs=num_envs, sim=a.sim, seed=a.seed,
                                            **judged(terrain="eval", course=course))
        if not hasattr(runner.alg.get_policy(), "latent"):
            raise UsageError(f"{path}: its actor keeps no latent m_a to probe")
        r2 = probe(record(runner, env, a), a.ridge, a.seed)
        records.append({"policy": str(path), "samples": a.steps * num_envs, "ridge": a.ridge, "r2": r2})
    return records


def print_table(records: list[dict]) -> None:
    print(f"{'policy':48} {'input':7} " + " ".join(f"{g:>11}" for g in GROUPS))
    for r in records:
        for src, row in r["r2"].items():
            print(f"{r['policy'][-48:]:48} {src:7} " + " ".join(f"{row[g]:11.3f}" for g in GROUPS))


def main(argv: list[str] | None = None) -> int:
    from cra_warp.learning.checkpoint import CheckpointError

    try:
        a = parse_args(ProbeArgs, argv, __doc__)
        if not a.checkpoints:
            raise UsageError("nothing to probe: give checkpoints")
        missing = [str(p) for p in a.checkpoints if not p.is_file()]
        if missing:
            raise UsageError(f"checkpoint not found: {', '.join(missing)}")
        if a.steps < 2 or a.warmup < 0 or a.robots_per_level < 2 or not a.ridge >= 0:
            raise UsageError(f"--steps must be >= 2, --warmup >= 0, --robots-per-level >= 2 and --ridge >= 0, got "
                             f"{a.steps}, {a.warmup}, {a.robots_per_level}, {a.ridge}")
        if a.json is not None and not a.json.parent.is_dir():
            raise UsageError(f"--json {a.json}: no such directory {a.json.parent}")
        records = run(a)
    except (UsageError, CheckpointError) as e:
        print(f"cra-probe: {e}", file=sys.stderr)
        return 2
    print_table(records)
    if a.json is not None:
        write_json(a.json, records, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())

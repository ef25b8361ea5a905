"""cra-train: train the CRA-Loco policy on any Warp device.

    cra-train                                   # the default: a ~10 min CPU run on flat ground (128 envs)
    cra-train --num-envs 4096 --device cuda:0 --task rough --max-iterations 10000
    cra-train --resume runs/<run>/model_40.pt --max-iterations 40   # continues at iteration 41
    cra-train --resume runs/ --log-dir runs/ ...                     # the newest checkpoint under runs/ (campaigns)
    cra-train --task rough --init runs/<flat run>/model_2800.pt      # a new run from a flat walker's networks
    torchrun --nproc-per-node 2 -m train.train --num-envs 128        # data parallel: gloo on CPU, NCCL on CUDA

Variants (paper IV-A): ours (same-step contrast, adaptive clock), sequential (contrast with the next step),
no_contrast, fixed_cycle, clock_free. Writes TensorBoard logs, checkpoints and, at the end, the exported policy
(TorchScript, ONNX, deploy JSON) to the run directory.
"""

from __future__ import annotations

import dataclasses
import math
import os
import random
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from cra_warp.atomic_json import write_json
from train.cli import (TASKS, VARIANTS, Sim, Task, UsageError, Variant, check_device, check_sim, parse_args,
                       world_config)


@dataclass
class TrainArgs:
    task: Task = "flat"                # rough: the terrain curriculum
    variant: Variant = "ours"
    num_envs: int = 128                # parallel robots (per process with torchrun)
    device: str = "cpu"                # cpu | cuda:N
    sim: Sim = "newton"                # newton (CPU or CUDA) | mujoco (MuJoCo C, CPU: the fast CPU path)
    max_iterations: int = 120          # learning iterations (24 env steps per env each): ~10 min on 2 CPU cores
    seed: int = 1
    # checkpoint to continue from (iteration count and optimizer state); a directory: its newest model_<it>.pt
    # (highest iteration, then newest run), so a campaign restarts with the same command
    resume: Path | None = None
    # checkpoint whose actor and critic (with their normalisers; a shipped policy has the actor only) this run
    # starts from, at iteration 0 with a fresh optimizer and contrastive heads: a fork into another task or variant
    # (the rough task from a flat walker, an ablation from the same start); its curriculum levels carry over. It
    # starts at learner.fork_learning_rate, and a fresh critic learns alone for learner.fork_critic_warmup updates
    init: Path | None = None
    log_dir: Path = Path("runs")       # runs go to <log_dir>/<task>_<variant>_<time>
    save_interval: int = 20            # iterations between checkpoints
    epochs: int = 2                    # PPO epochs per iteration (tools/results/ab_epochs*.json)
    mini_batches: int = 4              # PPO mini-batches per epoch; must divide num_envs (recurrent: whole rollouts)
    bf16: bool = True                  # bf16 autocast in the PPO update where the device has native bf16; --no-bf16
    # env settings by dotted path, VALUE as JSON: --override rewards.weights.contact_momentum=-4.4e-5 obs.noise=false;
    # learner settings under "learner.": --override learner.ppo.desired_kl=0.02 learner.actor.init_std=0.5
    override: tuple[str, ...] = ()
    contrast_weight: float = 0.1       # weight of the InfoNCE term in the loss
    contrast_tau: float = 0.1          # InfoNCE temperature
    export: bool = True                # write TorchScript + ONNX + deploy JSON at the end
    # the difficulty curriculum (envs/difficulty.py): standing commands and the nominal robot first, both widened as
    # the episodes lengthen (2-seed A/B: 116 vs 93 steps at 100 iterations, tools/results/ab_curriculum.json);
    # --no-curriculum trains on the whole task from the start. play, eval and export always run the whole task.
    curriculum: bool = True
    quiet: bool = False                # no progress lines


def validate(a: TrainArgs) -> None:
    if a.task not in TASKS:
        raise UsageError(f"--task must be one of {', '.join(TASKS)}, got {a.task!r}")
    if a.variant not in VARIANTS:
        raise UsageError(f"--variant must be one of {', '.join(VARIANTS)}, got {a.variant!r}")
    if a.num_envs < 1:
        raise UsageError(f"--num-envs must be >= 1, got {a.num_envs}")
    if a.max_iterations < 1:
        raise UsageError(f"--max-iterations must be >= 1, got {a.max_iterations}")
    if a.save_interval < 1:
        raise UsageError(f"--save-interval must be >= 1, got {a.save_interval}")
    if a.epochs < 1:
        raise UsageError(f"--epochs must be >= 1, got {a.epochs}")
    if a.mini_batches < 1 or a.num_envs % a.mini_batches:
        raise UsageError(f"--mini-batches must divide --num-envs ({a.num_envs}): each holds whole rollouts, "
                         f"got {a.mini_batches}")
    finite = math.isfinite(a.contrast_weight) and math.isfinite(a.contrast_tau)
    if not finite or a.contrast_weight < 0 or a.contrast_tau <= 0:
        raise UsageError(f"--contrast-weight must be >= 0 and --contrast-tau > 0, got {a.contrast_weight}, "
                         f"{a.contrast_tau}")
    parse_overrides(a.override)
    if a.resume is not None and a.resume.is_dir():
        a.resume = newest_checkpoint(a.resume)
    if a.resume is not None and not a.resume.is_file():
        raise UsageError(f"--resume {a.resume}: no such file")
    if a.init is not None and a.resume is not None:
        raise UsageError("--init and --resume exclude each other (--init starts a new run from a checkpoint's "
                         "networks, --resume continues one)")
    if a.init is not None and not a.init.is_file():
        raise UsageError(f"--init {a.init}: no such file")
    check_sim(a.sim, a.device)
    check_device(a.device)


def parse_overrides(items: tuple[str, ...]) -> dict[str, object]:
    """--override PATH=VALUE items -> {path: value}; VALUE is JSON (a bare word is a string)."""
    import json

    out = {}
    for item in items:
        path, sep, text = item.partition("=")
        if not sep or not path:
            raise UsageError(f"--override expects PATH=VALUE, got {item!r}")
        try:
            out[path] = json.loads(text)
        except json.JSONDecodeError:
            out[path] = text
    return out


def run_config(a: TrainArgs, env, env_cfg, learner) -> dict:
    """Everything that defines a run, resolved: CLI arguments, env (world, robot-facing task settings) and learner
    configs, the robot, and the observation layouts the networks were built for."""
    from cra_warp.config_io import to_data

    return {"args": to_data(a), "env": to_data(env_cfg), "learner": to_data(learner), "robot": to_data(env.robot),
            "layout": {"actor": to_data(env.layout), "privileged": to_data(env.priv_layout)}}


def newest_checkpoint(folder: Path) -> Path | None:
    """The checkpoint under ``folder`` with the highest iteration (ties: the newest file); None if there is none,
    so a campaign's first start and its restarts are the same command."""
    found = [(int(p.stem.split("_")[1]), p.stat().st_mtime, p) for p in folder.rglob("model_*.pt")
             if p.stem.split("_")[1].isdigit()]
    return max(found)[2] if found else None


def check_resume(path: Path, env, learner, rank: int, fork: bool = False) -> None:
    """A checkpoint resumed into today's run: refused (one line) if the robot or the observation layouts changed
    since, or (unless ``fork``: --init, fresh heads) if its contrastive heads were built for another target; a PPO
    setting that differs from the checkpoint's is said on stderr when resuming (the CLI's value is used)."""
    from cra_warp.config_io import to_data
    from cra_warp.learning.checkpoint import read_checkpoint
    from cra_warp.learning.config import stored_target_actor_obs
    from train.runner import _check_against_today

    stored = (read_checkpoint(path).get("infos") or {}).get("config")
    if stored is None:
        return
    _check_against_today(path, stored, env)
    target = stored_target_actor_obs(stored.get("learner", {}))
    if not fork and learner.contrast.variant != "none" and target != learner.contrast.target_actor_obs:
        raise UsageError(f"{path} was trained with the contrast target {'with' if target else 'without'} the actor "
                         f"observation: add --override learner.contrast.target_actor_obs={str(target).lower()}")
    then, now = stored.get("learner", {}).get("ppo", {}), to_data(learner.ppo)
    changed = {k: f"{then.get(k)} -> {v}" for k, v in now.items() if then.get(k) != v}
    if changed and rank == 0 and not fork:  # a fork is a new run with its own settings
        print(f"cra-train: resuming {path} with PPO settings changed from its own: {changed}", file=sys.stderr)


def seed_everything(seed: int) -> None:
    import numpy as np
    import torch

    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)


def unused_dir(path: Path) -> Path:
    """path, or path-2, path-3, ...: two runs started in the same second into one log dir must not share a run."""
    n = 1
    while (candidate := path if n == 1 else path.with_name(f"{path.name}-{n}")).exists():
        n += 1
    return candidate


def run(a: TrainArgs):
    """Train as the arguments say; returns (run directory, runner)."""
    import torch

    from cra_warp.config_io import with_overrides
    from cra_warp.host_memory import keep_freed_memory
    from cra_warp.learning.checkpoint import load_checkpoint, read_checkpoint
    from cra_warp.learning.config import LearnerConfig, bf16_supported, runner_cfg
    from envs.loco_config import DifficultyConfig, LocoConfig
    from envs.locomotion import LocoEnv
    from train.export import export_run
    from train.runner import CraRunner

    keep_freed_memory()  # batched CPU tensors page-fault on every allocation otherwise (see host_memory)
    rank = int(os.getenv("RANK", "0"))
    if a.device.startswith("cuda") and int(os.getenv("WORLD_SIZE", "1")) > 1:  # torchrun: one GPU per rank
        a = dataclasses.replace(a, device=f"cuda:{os.getenv('LOCAL_RANK', '0')}")
    seed_everything(a.seed + rank)  # before the env is built: its generator, DR and networks all follow
    # the cores this process may run on (taskset / cgroup cpusets), shared among the data-parallel processes:
    # the learner's torch threads and the MuJoCo backend's batch threads
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    threads = max(1, cores // int(os.getenv("WORLD_SIZE", "1")))
    env_variant, contrast, actor_kind = VARIANTS[a.variant]
    env_cfg = LocoConfig(num_envs=a.num_envs, device=a.device, variant=env_variant, terrain=a.task,
                         seed=a.seed + rank, world=world_config(a.sim, threads=threads),
                         difficulty=DifficultyConfig(commands=a.curriculum, randomization=a.curriculum))
    overrides = parse_overrides(a.override)
    env_over = {k: v for k, v in overrides.items() if not k.startswith("learner.")}
    learner_over = {k[len("learner."):]: v for k, v in overrides.items() if k.startswith("learner.")}
    if env_over:
        try:
            env_cfg = with_overrides(env_cfg, env_over)
        except (ValueError, TypeError) as e:
            raise UsageError(f"--override: {e}") from e
    env = LocoEnv(env_cfg)
    learner = LearnerConfig(save_interval=a.save_interval, run_name=f"{a.task}_{a.variant}")
    learner.contrast = dataclasses.replace(learner.contrast, variant=contrast, weight=a.contrast_weight,
                                           tau=a.contrast_tau)
    learner.ppo = dataclasses.replace(learner.ppo, num_learning_epochs=a.epochs, num_mini_batches=a.mini_batches,
                                      use_mixed_precision=a.bf16 and bf16_supported(a.device))
    learner.actor = dataclasses.replace(learner.actor, kind=actor_kind)
    learner.privileged_slices = {k: (env.priv_layout[name].start, env.priv_layout[name].stop)
                                 for k, name in (("velocity", "base_lin_vel"), ("observation", "actor"))}
    if learner_over:
        try:
            learner = with_overrides(learner, learner_over)
        except (ValueError, TypeError) as e:
            raise UsageError(f"--override: learner.{e}") from e
    lr, warmup = learner.fork_learning_rate, learner.fork_critic_warmup
    if not (math.isfinite(lr) and lr > 0) or min(warmup, learner.critic_warmup) < 0:
        raise UsageError(f"--override: learner.fork_learning_rate must be > 0 and the warm-ups >= 0, got {lr}, "
                         f"{warmup}, {learner.critic_warmup}")
    has_critic = False
    if a.init is not None:  # a fork starts slowly (LearnerConfig.fork_learning_rate says why)
        has_critic = "critic_state_dict" in read_checkpoint(a.init)
        learner.ppo = dataclasses.replace(learner.ppo, learning_rate=learner.fork_learning_rate)
        learner.critic_warmup = 0 if has_critic else learner.fork_critic_warmup
    run_dir = unused_dir(a.log_dir / f"{a.task}_{a.variant}_{time.strftime('%Y%m%d-%H%M%S')}")
    config = run_config(a, env, env_cfg, learner)
    runner = CraRunner(env, runner_cfg(learner), log_dir=str(run_dir) if rank == 0 else None, device=a.device,
                       quiet=a.quiet, run_info={"task": a.task, "variant": a.variant, "seed": a.seed,
                                                "sim": a.sim, "bf16": a.bf16, "config": config})
    if rank == 0:  # the whole resolved configuration, beside the logs (every checkpoint carries it too)
        run_dir.mkdir(parents=True, exist_ok=True)
        write_json(run_dir / "config.json", config, indent=2)
    infos = None
    if a.resume is not None:
        check_resume(a.resume, env, learner, rank)
        infos = load_checkpoint(a.resume, runner)
        runner.current_learning_iteration += 1  # the checkpoint's iteration is done: continue after it
    elif a.init is not None:
        check_resume(a.init, env, learner, rank, fork=True)
        if not has_critic and rank == 0:  # a shipped policy keeps its actor only
            print(f"cra-train: {a.init} has no critic: the critic starts fresh and learns alone for "
                  f"{learner.critic_warmup} iterations", file=sys.stderr)
        infos = load_checkpoint(a.init, runner, load_cfg={"actor": True, "critic": has_critic})
    if "difficulty_level" in (infos or {}):
        env.difficulty.level.fill_(infos["difficulty_level"])
    if "terrain_levels" in (infos or {}) and env.ground.curriculum is not None:
        saved = infos["terrain_levels"]
        if len(saved) == a.num_envs:
            env.ground.curriculum.restore(saved)
        elif rank == 0:
            print(f"cra-train: {len(saved)} terrain levels saved for {a.num_envs} robots: the terrain curriculum "
                  "starts again", file=sys.stderr)
    torch.set_num_threads(threads)
    runner.learn(a.max_iterations)
    if rank == 0 and a.export:
        export_run(runner, env, run_dir / "exported")
    if torch.distributed.is_initialized():  # leave together: a rank exiting mid-collective aborts the others
        torch.distributed.barrier()
        torch.distributed.destroy_process_group()
    return run_dir, runner


def main(argv: list[str] | None = None) -> int:
    from cra_warp.learning.checkpoint import CheckpointError

    try:
        args = parse_args(TrainArgs, argv, __doc__)
        validate(args)
        run_dir, _ = run(args)
    except (UsageError, CheckpointError) as e:
        print(f"cra-train: {e}", file=sys.stderr)
        return 2
    if int(os.getenv("RANK", "0")) == 0:
        print(f"run directory: {run_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""cra-train: train the CRA-Loco policy on any Warp device.

    cra-train                                   # the default: a ~10 min CPU run on flat ground (128 envs)
    cra-train --sim mujoco --num-envs 256 --max-iterations 3200   # the walk recipe at the shipped walkers' budget
    cra-train --recipe paper                    # Table I and the paper's clock as published (envs/recipes.py)
    cra-train --num-envs 4096 --device cuda:0 --task rough --max-iterations 10000
    cra-train --resume runs/<run>/model_40.pt --max-iterations 40   # continues at iteration 41
    cra-train --resume runs/ --log-dir runs/ ...                     # the newest checkpoint under runs/ (campaigns)
    cra-train --task rough --init runs/<flat run>/model_2800.pt      # a new run from a flat walker's networks
    torchrun --nproc-per-node 2 -m train.train --num-envs 128        # data parallel: gloo on CPU, NCCL on CUDA

Methods (paper IV-A; envs/methods.py): ours (same-step contrast, adaptive clock), sequential (contrast with the next
step), no_contrast, fixed_cycle, clock_free, and the baselines dreamwaq and dwl on our clock, and as their papers
pair them: dreamwaq_clock_free (with AdaBoot) and dwl_fixed_cycle. Recipes (envs/recipes.py): walk (the default:
what the shipped walkers trained with), climb (walk plus the climbing campaign's rough-ground settings) and paper; a
recipe's overrides come before --override's. Writes TensorBoard logs, checkpoints and, at the end, the exported
policy (TorchScript, ONNX, deploy JSON) to the run directory.
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

from typing import Annotated, Literal

import tyro

from cra_warp.atomic_json import write_json
from envs.recipes import DEFAULT_RECIPE, RECIPES
from cra_warp.cli import Sim, UsageError, check_device, check_sim, parse_args, quiet_stdout
from envs.methods import METHODS, TASKS, Method, Task

RecipeName = Literal[tuple(RECIPES)]  # type: ignore[valid-type]  # the choices --help lists


@dataclass
class TrainArgs:
    task: Task = "flat"                # rough: the terrain curriculum
    # the method (envs/methods.py: clock mode, contrast pairing, actor); --method and --variant (stored runs' name)
    # alike
    variant: Annotated[Method, tyro.conf.arg(aliases=("--method",))] = "ours"
    # named overrides (envs/recipes.py), applied before --override: walk = what the shipped walkers trained with,
    # climb = walk plus the climbing campaign's rough-ground settings, paper = Table I and the paper's clock as
    # published. Unset: walk for a new run (and --init), the checkpoint's own with --resume (paper for one written
    # before recipes: it ran on the dataclass defaults, which are paper's)
    recipe: RecipeName | None = None
    num_envs: int = 128                # parallel robots (per process with torchrun)
    device: str = "cpu"                # cpu | cuda:N
    sim: Sim = "newton"                # newton (CPU or CUDA) | mujoco (MuJoCo C, CPU: the fast CPU path)
    max_iterations: int = 120          # learning iterations (24 env steps per env each): ~10 min on 2 CPU cores
    seed: int = 1
    # checkpoint to continue from (iteration count and optimizer state); a directory: its newest model_<it>.pt
    # (highest iteration, then newest run), so a campaign restarts with the same command
    resume: Path | None = None
    # checkpoint whose networks (actor, critic and contrastive heads where it has them, with their normalisers;
    # rough_walk_v0 and flat_walk_v2 have the actor only) this run starts from, at iteration 0 with a fresh
    # optimizer: a fork into another task or variant (the rough task from a flat walker, an ablation from the same
    # start); its curriculum levels carry over. It starts at learner.fork_learning_rate, and a missing critic
    # learns alone for learner.fork_critic_warmup updates (by default the run's rate and none)
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
    if a.variant not in METHODS:
        raise UsageError(f"--method must be one of {', '.join(METHODS)}, got {a.variant!r}")
    if a.recipe is not None and a.recipe not in RECIPES:
        raise UsageError(f"--recipe must be one of {', '.join(RECIPES)}, got {a.recipe!r}")
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
    if a.recipe is None:
        a.recipe = stored_recipe(a.resume) if a.resume is not None else DEFAULT_RECIPE
    check_sim(a.sim, a.device)
    check_device(a.device)
    if int(os.getenv("RANK", "0")) == 0:  # before minutes of set-up: an unwritable place is one line, not a traceback
        check_writable(a.log_dir, "--log-dir")


def stored_recipe(path: Path) -> str:
    """The recipe a checkpoint's run trained with: its stored name, or "paper" for a run written before recipes
    (it trained on the dataclass defaults plus its overrides, and the defaults are the paper recipe)."""
    from cra_warp.learning.checkpoint import read_checkpoint

    config = (read_checkpoint(path).get("infos") or {}).get("config") or {}
    name = (config.get("recipe") or {}).get("name") or "paper"
    if name not in RECIPES:
        raise UsageError(f"--resume {path}: trained with the recipe {name!r}, which this code does not have "
                         f"(give --recipe {'|'.join(RECIPES)})")
    return name


def check_writable(path: Path, flag: str) -> None:
    """UsageError unless a directory can be made at ``path``: tried in its nearest existing ancestor, which is left
    as it was (a run that fails later leaves no empty log directory behind)."""
    import tempfile

    base = path.absolute()
    while not base.exists() and base != base.parent:
        base = base.parent
    if not base.is_dir():
        raise UsageError(f"{flag} {path}: {base} is not a directory")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".cra-train-", dir=base))
    except OSError as e:
        raise UsageError(f"{flag} {path}: cannot write in {base} ({e.strerror or e})") from None


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


def run_config(a: TrainArgs, env, env_cfg, learner, recipe: dict | None = None) -> dict:
    """Everything that defines a run, resolved: CLI arguments, the recipe (its name, the overrides it applied and
    those the method could not use), env (world, robot-facing task settings) and learner configs, the robot (as
    driven), what the task read of it (joint groups, stand gains; its numbers are in env), and the observation
    layouts the networks were built for."""
    from cra_warp.config_io import to_data

    return {"args": to_data(a), "recipe": to_data(recipe or {}), "env": to_data(env_cfg),
            "learner": to_data(learner), "robot": to_data(env.robot),
            "loco_robot": {k: v for k, v in to_data(env.loco_robot).items() if k != "robot"},
            "layout": {"actor": to_data(env.layout), "privileged": to_data(env.priv_layout)}}


def configs(a: TrainArgs, threads: int = 1, rank: int = 0):
    """The run's (LocoConfig, LearnerConfig, recipe record): envs.methods.build_configs of the CLI's choices, the
    recipe's overrides (minus what the method cannot use), then --override's."""
    from cra_warp.learning.config import bf16_supported
    from envs.methods import build_configs

    try:
        return build_configs(a.variant, a.task, recipe=a.recipe, overrides=parse_overrides(a.override),
                             num_envs=a.num_envs, device=a.device, sim=a.sim, seed=a.seed + rank, threads=threads,
                             curriculum=a.curriculum, contrast_weight=a.contrast_weight, contrast_tau=a.contrast_tau,
                             epochs=a.epochs, mini_batches=a.mini_batches, save_interval=a.save_interval,
                             mixed_precision=a.bf16 and bf16_supported(a.device))
    except ValueError as e:
        raise UsageError(str(e)) from e


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
    from cra_warp.config_io import flatten, to_data
    from cra_warp.learning.checkpoint import read_checkpoint
    from cra_warp.learning.config import stored_target_actor_obs
    from envs.checkpoints import check_against_today, stored_env

    stored = (read_checkpoint(path).get("infos") or {}).get("config")
    if stored is None:
        return
    check_against_today(path, stored, env)
    target = stored_target_actor_obs(stored.get("learner", {}))
    if not fork and learner.contrast.variant != "none" and target != learner.contrast.target_actor_obs:
        raise UsageError(f"{path} was trained with the contrast target {'with' if target else 'without'} the actor "
                         f"observation: add --override learner.contrast.target_actor_obs={str(target).lower()}")
    then, now = stored.get("learner", {}).get("ppo", {}), to_data(learner.ppo)
    changed = {k: f"{then.get(k)} -> {v}" for k, v in now.items() if then.get(k) != v}
    if changed and rank == 0 and not fork:  # a fork is a new run with its own settings
        print(f"cra-train: resuming {path} with PPO settings changed from its own: {changed}", file=sys.stderr)
    # the task as it was: a run resumed under another recipe (or one written before recipes, on the paper's
    # defaults) would silently train on changed rewards or clock; said in one line, the CLI's value is used
    then_env, now_env = flatten(stored_env(stored) if "env" in stored else {}), flatten(to_data(env.cfg))
    moved = {k: f"{then_env[k]} -> {v}" for k, v in now_env.items()
             if k in then_env and then_env[k] != v and not k.startswith(_RUN_FIELDS)}
    if moved and rank == 0 and not fork:
        print(f"cra-train: resuming {path} with env settings changed from its own: {moved}", file=sys.stderr)


_RUN_FIELDS = ("num_envs", "device", "seed", "world.")   # what may differ between a run and its resume


def _tiles(rough: dict | None) -> dict:
    """A stored rough-terrain config without its seed (the run's seed replaces it); None: the default tiles."""
    from cra_warp.config_io import to_data
    from cra_warp.terrain import TerrainConfig

    return {k: v for k, v in (rough or to_data(TerrainConfig())).items() if k != "seed"}


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

    from cra_warp.config_io import to_data
    from cra_warp.host_memory import keep_freed_memory
    from cra_warp.learning.checkpoint import load_checkpoint, read_checkpoint
    from cra_warp.learning.config import runner_cfg
    from envs.locomotion import LocoEnv
    from envs.methods import bind_learner
    from train.export import export_run, third_party_quiet
    from envs.checkpoints import make_runner

    keep_freed_memory()  # batched CPU tensors page-fault on every allocation otherwise (see host_memory)
    if a.recipe is None:  # run() called without validate(): the same choice
        a = dataclasses.replace(a, recipe=stored_recipe(a.resume) if a.resume is not None else DEFAULT_RECIPE)
    if a.resume is not None:  # it goes on with the task it trained on, fields added since included
        from envs.checkpoints import predated_overrides

        a = dataclasses.replace(a, override=(*a.override, *predated_overrides(a.resume, a.override)))
    rank = int(os.getenv("RANK", "0"))
    if a.device.startswith("cuda") and int(os.getenv("WORLD_SIZE", "1")) > 1:  # torchrun: one GPU per rank
        a = dataclasses.replace(a, device=f"cuda:{os.getenv('LOCAL_RANK', '0')}")
    seed_everything(a.seed + rank)  # before the env is built: its generator, DR and networks all follow
    # the cores this process may run on (taskset / cgroup cpusets), shared among the data-parallel processes:
    # the learner's torch threads and the MuJoCo backend's batch threads
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    threads = max(1, cores // int(os.getenv("WORLD_SIZE", "1")))
    if int(os.getenv("WORLD_SIZE", "1")) > 1 and hasattr(os, "sched_setaffinity"):
        # each data-parallel process on its own slice of the cores: no migrations between them (a few % faster
        # on 2 cores than leaving it to the scheduler, tools/results/bench_two_cores_*.json)
        local, allowed = int(os.getenv("LOCAL_RANK", "0")), sorted(os.sched_getaffinity(0))
        if len(allowed) >= threads * (local + 1):
            os.sched_setaffinity(0, allowed[local * threads:(local + 1) * threads])
    env_cfg, learner, recipe = configs(a, threads=threads, rank=rank)
    with quiet_stdout():  # the backends' set-up notes
        env = LocoEnv(env_cfg)
    bind_learner(learner, env)
    lr, warmup = learner.fork_learning_rate, learner.fork_critic_warmup
    if not (math.isfinite(lr) and lr > 0) or min(warmup, learner.critic_warmup) < 0:
        raise UsageError(f"--override: learner.fork_learning_rate must be > 0 and the warm-ups >= 0, got {lr}, "
                         f"{warmup}, {learner.critic_warmup}")
    has_critic = has_heads = False
    if a.init is not None:  # LearnerConfig.fork_learning_rate says why a fork starts at full rate by default
        saved = read_checkpoint(a.init)
        has_critic, has_heads = "critic_state_dict" in saved, "contrast_state_dict" in saved
        learner.ppo = dataclasses.replace(learner.ppo, learning_rate=learner.fork_learning_rate)
        learner.critic_warmup = 0 if has_critic else learner.fork_critic_warmup
    run_dir = unused_dir(a.log_dir / f"{a.task}_{a.variant}_{time.strftime('%Y%m%d-%H%M%S')}")
    config = run_config(a, env, env_cfg, learner, recipe)
    with quiet_stdout():  # rsl-rl prints both networks whole; the config holds them
        runner = make_runner(env, runner_cfg(learner), log_dir=str(run_dir) if rank == 0 else None, device=a.device,
                           quiet=a.quiet, run_info={"task": a.task, "variant": a.variant, "seed": a.seed,
                                                    "sim": a.sim, "bf16": a.bf16, "recipe": a.recipe,
                                                    "config": config})
    if rank == 0:  # the whole resolved configuration, beside the logs (every checkpoint carries it too)
        run_dir.mkdir(parents=True, exist_ok=True)
        write_json(run_dir / "config.json", config, indent=2)
    infos = None
    if a.resume is not None:
        check_resume(a.resume, env, learner, rank)
        with quiet_stdout():
            infos = load_checkpoint(a.resume, runner)
        runner.current_learning_iteration += 1  # the checkpoint's iteration is done: continue after it
    elif a.init is not None:
        check_resume(a.init, env, learner, rank, fork=True)
        if not has_critic and rank == 0:  # the shipped walkers keep their actor only
            print(f"cra-train: {a.init} has no critic: the critic starts fresh"
                  + (f" and learns alone for {learner.critic_warmup} iterations" if learner.critic_warmup else ""),
                  file=sys.stderr)
        with quiet_stdout():
            # the heads too where both have them, so a fork goes on from the run it came from
            heads = has_heads and getattr(runner.alg, "heads", None) is not None
            infos = load_checkpoint(a.init, runner, load_cfg={"actor": True, "critic": has_critic, "contrast": heads})
    if "difficulty_level" in (infos or {}):
        env.difficulty.level.fill_(infos["difficulty_level"])
    if "terrain_levels" in (infos or {}) and env.ground.curriculum is not None:
        saved = infos["terrain_levels"]
        # a level means a tile of one layout: levels saved on other tiles (rough.*) would put robots on wrong ones
        saved_tiles = ((infos.get("config") or {}).get("env") or {}).get("rough")
        same_tiles = _tiles(saved_tiles) == _tiles(to_data(env_cfg.rough))
        if len(saved) == a.num_envs and same_tiles:
            env.restore_terrain_levels(saved)
        elif rank == 0:
            why = "on other tiles (rough.*)" if not same_tiles else f"for {len(saved)} robots, not {a.num_envs}"
            print(f"cra-train: the checkpoint's terrain levels were saved {why}: the terrain curriculum starts "
                  "again", file=sys.stderr)
    torch.set_num_threads(threads)
    runner.learn(a.max_iterations)
    runner.exported = {}
    if rank == 0 and a.export:
        with third_party_quiet() as silenced:  # the ONNX exporter's notes and UserWarnings
            runner.exported = export_run(runner, env, run_dir / "exported")
        runner.silenced_warnings = silenced
    if torch.distributed.is_initialized():  # leave together: a rank exiting mid-collective aborts the others
        torch.distributed.barrier()
        torch.distributed.destroy_process_group()
    return run_dir, runner


def main(argv: list[str] | None = None) -> int:
    from cra_warp.learning.checkpoint import CheckpointError

    try:
        args = parse_args(TrainArgs, argv, __doc__)
        validate(args)
        run_dir, runner = run(args)
    except (UsageError, CheckpointError) as e:
        print(f"cra-train: {e}", file=sys.stderr)
        return 2
    if int(os.getenv("RANK", "0")) == 0:
        silenced = getattr(runner, "silenced_warnings", [])
        if silenced:
            print(f"cra-train: {len(silenced)} third-party warnings during the export silenced ({silenced[0]}, ...)",
                  file=sys.stderr)
        print(f"run directory: {run_dir}")
        for kind, path in getattr(runner, "exported", {}).items():
            print(f"{kind:>12}: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

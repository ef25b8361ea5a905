"""rsl-rl's OnPolicyRunner with three changes a user of this stack needs:

- checkpoints are written atomically (temp file + rename): a run stopped mid-save never leaves a torn file;
- data-parallel training on the CPU: rsl-rl hard-codes NCCL and cuda:<local_rank>; on "cpu" we use gloo so that
  torchrun's processes each drive one core (CUDA keeps rsl-rl's own NCCL path);
- one compact progress line per iteration (iteration, env-steps/s, reward, episode length, InfoNCE accuracy, ETA)
  instead of rsl-rl's 40-line block; everything still goes to TensorBoard through rsl-rl's logger.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import io
import os
import statistics
import time

import torch
from rsl_rl.runners import OnPolicyRunner


class CraRunner(OnPolicyRunner):
    def __init__(self, env, train_cfg: dict, log_dir: str | None = None, device: str = "cpu", quiet: bool = False,
                 run_info: dict | None = None):
        self._quiet = quiet
        self.run_info = run_info or {}  # stored in every checkpoint: what play/export need to rebuild the env
        self.history: list[dict] = []   # one record per iteration: what the progress line shows
        self._t0 = time.time()
        alg = train_cfg.get("algorithm", {})
        if alg.get("symmetry_weight"):  # the task's mirror maps (envs.observations), which the library cannot know
            from envs.observations import action_mirror, actor_mirror

            train_cfg = {**train_cfg, "algorithm": {**alg, "mirror": {
                "obs": actor_mirror(env.layout, env.robot, env.cfg.uses_clock),
                "actions": action_mirror(env.robot, env.cfg.uses_clock)}}}
        super().__init__(env, train_cfg, log_dir=log_dir, device=device)
        log = self.logger.log

        def compact_log(**kw):
            with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl's console block; TensorBoard still written
                log(**kw)
            self._record(**kw)
            if not self._quiet and self.gpu_global_rank == 0:
                self._progress(self.history[-1], kw["start_it"], kw["total_it"])

        self.logger.log = compact_log

    def _record(self, it, collect_time, learn_time, loss_dict, **_):
        lg = self.logger
        steps = self.cfg["num_steps_per_env"] * self.env.num_envs * self.gpu_world_size
        rec = {"it": it, "env_steps_per_s": steps / (collect_time + learn_time), "collect_s": collect_time,
               "update_s": learn_time}
        if len(lg.rewbuffer):
            rec.update(reward=statistics.mean(lg.rewbuffer), episode_s=statistics.mean(lg.lenbuffer) * self.env.dt)
        rec.update({k: loss_dict[k] for k in ("infonce_acc", "infonce_chance") if k in loss_dict})
        rec["losses"] = {k: float(v) for k, v in loss_dict.items()}
        self.history.append(rec)

    def _progress(self, r: dict, start_it: int, total_it: int):
        done = r["it"] + 1 - start_it
        eta = (time.time() - self._t0) / done * (total_it - start_it - done)
        parts = [f"it {r['it'] + 1}/{total_it}", f"{r['env_steps_per_s']:6.0f} env-steps/s",
                 f"collect {r['collect_s']:.1f}s update {r['update_s']:.1f}s"]
        if "reward" in r:
            parts += [f"reward {r['reward']:7.2f}", f"ep len {r['episode_s']:5.1f}s"]
        if "infonce_acc" in r:
            parts.append(f"InfoNCE top-1 {r['infonce_acc']:.2f} (chance {r['infonce_chance']:.4f})")
        parts.append(f"ETA {datetime.timedelta(seconds=int(eta))}")
        print(" | ".join(parts), flush=True)

    def save(self, path: str, infos: dict | None = None) -> None:
        tmp = f"{path}.tmp"
        state = {}
        if hasattr(self.env, "difficulty"):  # the curriculum's level: a resumed run continues where it was
            state["difficulty_level"] = float(self.env.difficulty.level)
        curriculum = getattr(getattr(self.env, "ground", None), "curriculum", None)
        if curriculum is not None:  # and each robot's terrain level
            state["terrain_levels"] = curriculum.levels.tolist()
        super().save(tmp, {**self.run_info, **state, **(infos or {})})
        os.replace(tmp, path)

    def _configure_multi_gpu(self) -> None:
        world_size = int(os.getenv("WORLD_SIZE", "1"))
        if world_size <= 1 or str(self.device).startswith("cuda"):
            return super()._configure_multi_gpu()
        # CPU data parallel: rsl-rl's bookkeeping with gloo instead of NCCL and no CUDA device binding.
        self.gpu_world_size, self.is_distributed = world_size, True
        self.gpu_local_rank = int(os.getenv("LOCAL_RANK", "0"))
        self.gpu_global_rank = int(os.getenv("RANK", "0"))
        self.cfg["multi_gpu"] = {"global_rank": self.gpu_global_rank, "local_rank": self.gpu_local_rank,
                                 "world_size": world_size}
        if not torch.distributed.is_initialized():
            torch.distributed.init_process_group(backend="gloo", rank=self.gpu_global_rank, world_size=world_size)


def runner_for_checkpoint(path, num_envs: int = 1, device: str = "cpu", sim: str | None = None,
                          whole_course: bool = False, **env_overrides):
    """Rebuild the env and runner a checkpoint was trained with and load it. Returns (runner, env).

    The checkpoint's stored configuration (env, world, learner) is rebuilt as it was, never from today's defaults;
    the caller changes only what an evaluation needs: ``num_envs``, ``device``, the simulator (``sim``), every
    terrain box in every world (``whole_course``, for recording) and LocoConfig fields in ``env_overrides``
    (terrain, seed, course, randomization, episode_length_s). A checkpoint whose observation layout no longer
    matches today's code is refused. Raises CheckpointError (one line) for a missing, foreign or mismatched file.
    """
    from cra_warp.config_io import from_data
    from cra_warp.learning.checkpoint import CheckpointError, load_checkpoint, read_checkpoint
    from cra_warp.learning.config import LearnerConfig, runner_cfg, stored_target_actor_obs
    from envs.loco_config import DifficultyConfig, LocoConfig
    from envs.locomotion import LocoEnv
    from train.cli import VARIANTS

    info = read_checkpoint(path).get("infos") or {}
    stored = info.get("config")
    try:
        if stored is not None:
            env_cfg = from_data(LocoConfig, stored["env"])
            learner = from_data(LearnerConfig, stored["learner"])
            learner.contrast = dataclasses.replace(learner.contrast,
                                                   target_actor_obs=stored_target_actor_obs(stored["learner"]))
        else:  # written before runs stored their configuration: variant and task only, today's defaults
            variant = info.get("variant", "ours")
            if variant not in VARIANTS:
                raise CheckpointError(f"{path}: unknown variant {variant!r} in the checkpoint")
            env_variant, contrast, kind = VARIANTS[variant]
            env_cfg = LocoConfig(variant=env_variant, terrain=info.get("task", "flat"))
            learner = LearnerConfig()
            learner.contrast = dataclasses.replace(learner.contrast, variant=contrast,
                                                   target_actor_obs=stored_target_actor_obs({}))
            learner.actor = dataclasses.replace(learner.actor, kind=kind)
            sim = sim or info.get("sim", "newton")
        world = dataclasses.replace(env_cfg.world, threads=0)  # MuJoCo batch threads: this machine's, not the run's
        if sim is not None:
            world = dataclasses.replace(world, backend=sim)
        if whole_course:
            world = dataclasses.replace(world, terrain_window=None)
        # evaluation runs the whole task: a training curriculum's level (a rebuilt env would restart it) is off
        env_cfg = dataclasses.replace(env_cfg, num_envs=num_envs, device=device,
                                      difficulty=DifficultyConfig(commands=False, randomization=False),
                                      world=dataclasses.replace(world, device=device), **env_overrides)
    except (KeyError, TypeError, ValueError) as e:
        if isinstance(e, CheckpointError):
            raise
        raise CheckpointError(f"{path}: its stored configuration cannot be rebuilt ({e})") from e
    env = LocoEnv(env_cfg)
    if stored is not None:
        _check_against_today(path, stored, env)
    runner = CraRunner(env, runner_cfg(learner), log_dir=None, device=device, quiet=True, run_info=info)
    load_checkpoint(path, runner, load_cfg={"actor": True})  # inference: a shipped, actor-only file is enough
    return runner, env


# What a policy was trained against that today's code also defines: the robot's actuation and pose, and the
# observation layouts. A difference means the policy would run on another robot or read shifted inputs.
ROBOT_FIELDS = ("joint_names", "default_q", "kp", "kd", "effort_limit", "velocity_limit", "pos_lower", "pos_upper",
                "action_scale", "armature")


def _check_against_today(path, stored: dict, env) -> None:
    from cra_warp.config_io import to_data
    from cra_warp.learning.checkpoint import CheckpointError

    try:
        robot, layouts = stored["robot"], stored["layout"]
        layouts = {g: layouts[g] for g in ("actor", "privileged")}
    except (KeyError, TypeError) as e:
        raise CheckpointError(f"{path}: its stored configuration lacks {e}") from e
    today = to_data(env.robot)
    for k in ROBOT_FIELDS:
        if robot.get(k) != today[k]:
            raise CheckpointError(f"{path}: the robot's {k} differs from today's config ({robot.get(k)} in the "
                                  f"checkpoint, {today[k]} now)")
    for group, now in (("actor", env.layout), ("privileged", env.priv_layout)):
        then, now = layouts[group], to_data(now)
        if then != now:
            diff = next(k for k in list(then) + list(now) if then.get(k) != now.get(k))
            raise CheckpointError(f"{path}: the {group} observation layout differs from today's code at "
                                  f"{diff!r} ({then.get(diff)} in the checkpoint, {now.get(diff)} now)")

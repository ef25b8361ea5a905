"""rsl-rl's OnPolicyRunner with three changes a user of this stack needs:

- checkpoints are written atomically (temp file + rename): a run stopped mid-save never leaves a torn file;
- data-parallel training on the CPU: rsl-rl hard-codes NCCL and cuda:<local_rank>; on "cpu" we use gloo so that
  torchrun's processes each drive one core (CUDA keeps rsl-rl's own NCCL path);
- one compact progress line per iteration (iteration, env-steps/s, reward, episode length, InfoNCE accuracy, ETA)
  instead of rsl-rl's 40-line block; everything still goes to TensorBoard through rsl-rl's logger.
The symmetry loss's mirror maps and the action bound loss's bounds come from the task (envs.checkpoints.make_runner
hands them over as ``task_args``).
"""

from __future__ import annotations

import contextlib
import datetime
import io
import os
import statistics
import time

import torch
from rsl_rl.runners import OnPolicyRunner


class CraRunner(OnPolicyRunner):
    def __init__(self, env, train_cfg: dict, log_dir: str | None = None, device: str = "cpu", quiet: bool = False,
                 run_info: dict | None = None, task_args: dict | None = None):
        self._quiet = quiet
        self.run_info = run_info or {}  # stored in every checkpoint: what play/export need to rebuild the env
        self.history: list[dict] = []   # one record per iteration: what the progress line shows
        self._t0 = time.time()
        if task_args:  # what the task hands the algorithm (envs.checkpoints.make_runner): mirror maps, action bounds
            train_cfg = {**train_cfg, "algorithm": {**train_cfg.get("algorithm", {}), **task_args}}
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

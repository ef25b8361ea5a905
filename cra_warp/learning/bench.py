"""A dummy rsl-rl VecEnv with the task's observation shapes, a rollout helper and the learner benchmark.

The dummy env costs ~nothing, so timing an iteration on it measures the learner alone (rollout inference +
PPO update with the contrastive term).
"""

from __future__ import annotations

import time

import torch
from tensordict import TensorDict

try:
    from rsl_rl.env import VecEnv
except ImportError:  # pragma: no cover
    VecEnv = object


class DummyEnv(VecEnv):
    """Random observations with the task's groups: policy [N, 84], privileged [N, 179], height_map [N, 1, 17, 11].

    Episodes end at random (probability ``done_prob`` per step, some flagged as time-outs) so recurrent mini-batches
    contain several trajectories per env, as in training.
    """

    def __init__(self, num_envs: int = 8, num_obs: int = 84, num_privileged: int = 179, num_actions: int = 26,
                 map_shape: tuple[int, int] = (17, 11), done_prob: float = 0.05, seed: int = 0,
                 device: str = "cpu") -> None:
        self.num_envs, self.num_actions, self.device = num_envs, num_actions, torch.device(device)
        self.max_episode_length = 1000
        self.episode_length_buf = torch.zeros(num_envs, dtype=torch.long, device=self.device)
        self.cfg = {"dummy": True}
        self.dims = (num_obs, num_privileged, map_shape)
        self.done_prob = done_prob
        self.gen = torch.Generator(device=self.device).manual_seed(seed)
        self.obs = self._sample()
        # where the task's layout keeps the base velocity and the noise-free actor observation in "privileged"
        self.privileged_slices = {"velocity": (0, 3), "observation": (num_privileged - num_obs, num_privileged)}

    def _sample(self) -> TensorDict:
        n, (d_o, d_p, (h, w)) = self.num_envs, self.dims
        r = lambda *s: torch.randn(*s, generator=self.gen, device=self.device)  # noqa: E731
        return TensorDict({"policy": r(n, d_o), "privileged": r(n, d_p), "height_map": r(n, 1, h, w)},
                          batch_size=[n], device=self.device)

    def get_observations(self) -> TensorDict:
        return self.obs

    def step(self, actions: torch.Tensor):
        u = torch.rand(self.num_envs, generator=self.gen, device=self.device)
        dones = u < self.done_prob
        time_outs = u < self.done_prob / 4
        self.episode_length_buf = torch.where(dones, 0, self.episode_length_buf + 1)
        self.obs = self._sample()
        rew = -actions.pow(2).mean(-1) + 0.1 * torch.randn(self.num_envs, generator=self.gen, device=self.device)
        return self.obs, rew, dones.long(), {"time_outs": time_outs, "log": {}}


def collect(alg, env, steps: int) -> TensorDict:
    """One rollout of ``steps`` env steps into the algorithm's storage (as OnPolicyRunner.learn does), then
    returns/advantages; returns the last observation."""
    obs = env.get_observations()
    with torch.inference_mode():
        for _ in range(steps):
            actions = alg.act(obs)
            obs, rew, dones, extras = env.step(actions)
            alg.process_env_step(obs, rew, dones, extras)
        alg.compute_returns(obs)
    return obs


def learner_benchmark(num_envs: int, steps: int = 24, iterations: int = 2, variant: str = "same_step",
                      threads: int | None = None, learner_cfg=None, seed: int = 0, done_prob: float = 0.02) -> dict:
    """Time rollout + PPO update per iteration on the dummy env; FLOPs counted on the first (warm-up) update.

    ``done_prob``: per-step episode end probability of the dummy env (0.02: ~1 s episodes, early-training falls);
    more dones = more padded trajectories in the recurrent mini-batches = more RNN work (counted in the FLOPs).
    Returns {num_envs, steps, epochs, mini_batches, variant, threads, collect_s, update_s (means over the timed
    iterations), update_gflop (one update), update_gflops (achieved GFLOP/s in the update)}.
    """
    from torch.utils.flop_counter import FlopCounterMode

    from rsl_rl.runners import OnPolicyRunner

    from cra_warp.learning.config import LearnerConfig, runner_cfg

    if threads:
        torch.set_num_threads(threads)
    torch.manual_seed(seed)
    cfg = learner_cfg or LearnerConfig()
    cfg.num_steps_per_env = steps
    cfg.contrast.variant = variant
    env = DummyEnv(num_envs, seed=seed, done_prob=done_prob)
    cfg.privileged_slices = cfg.privileged_slices or env.privileged_slices
    runner = OnPolicyRunner(env, runner_cfg(cfg), log_dir=None, device="cpu")
    alg = runner.alg
    alg.train_mode()
    collect(alg, env, steps)
    with FlopCounterMode(display=False) as counter:  # warm-up iteration, also counts the update's FLOPs
        alg.update()
    gflop = counter.get_total_flops() / 1e9
    t_collect = t_update = 0.0
    for _ in range(iterations):
        t0 = time.perf_counter()
        collect(alg, env, steps)
        t1 = time.perf_counter()
        alg.update()
        t2 = time.perf_counter()
        t_collect += t1 - t0
        t_update += t2 - t1
    t_collect, t_update = t_collect / iterations, t_update / iterations
    return {"num_envs": num_envs, "steps": steps, "epochs": cfg.ppo.num_learning_epochs,
            "mini_batches": cfg.ppo.num_mini_batches, "variant": variant, "threads": torch.get_num_threads(),
            "collect_s": t_collect, "update_s": t_update, "update_gflop": gflop, "update_gflops": gflop / t_update}

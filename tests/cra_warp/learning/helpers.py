"""What the learner tests share: a small runner on a dummy env, fake deploy metadata, a deterministic rollout."""

from __future__ import annotations

import torch
from tensordict import TensorDict

from rsl_rl.runners import OnPolicyRunner

from cra_warp.learning import ContrastConfig, LearnerConfig, PPOConfig, runner_cfg
from cra_warp.learning.bench import DummyEnv


STEPS = 8


def make_runner(variant="same_step", num_envs=8, seed=0, mini_batches=2, env=None,
                max_samples=2048, contrast=None, privileged_slices=None, critic_warmup=0, batched_values=True,
                critic_warmup_learning_rate=None, **env_kw):
    torch.manual_seed(seed)
    env = env or DummyEnv(num_envs, seed=seed, **env_kw)
    slices = env.privileged_slices if privileged_slices is None else privileged_slices
    cfg = LearnerConfig(num_steps_per_env=STEPS, privileged_slices=slices,
                        contrast=ContrastConfig(variant=variant, max_samples=max_samples, **(contrast or {})),
                        ppo=PPOConfig(num_learning_epochs=2, num_mini_batches=mini_batches),
                        critic_warmup=critic_warmup, critic_warmup_learning_rate=critic_warmup_learning_rate,
                        batched_values=batched_values)  # False: rsl-rl's per-step critic
    train_cfg = runner_cfg(cfg)
    return OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu"), env


def fake_metadata(num_joints=23, obs_dim=84, clock=True):
    layout, i = {}, 0
    for k, n in [("head", obs_dim - 2 * num_joints), ("joint_pos", num_joints), ("joint_vel", num_joints)]:
        layout[k] = slice(i, i + n)
        i += n
    return {"obs_layout": layout, "joint_names": [f"j{k}" for k in range(num_joints)], "action_scale": 0.5,
            "default_q": torch.linspace(-0.3, 0.3, num_joints), "kp": [100.0] * num_joints, "kd": [2.0] * num_joints,
            "gait": {"cycle_time": 0.8, "alpha": 0.5, "psi": 0.5, "gamma": -0.1, "beta_scale": 1.0} if clock else None,
            "control_dt": 0.02, "obs_scales": {"ang_vel": 0.25, "joint_vel": 0.05},
            "action_clip": {"joints": 10.0, "gait": 1.0}, "effort_limit": [50.0] * num_joints,
            "pd": {"law": "tau = clip(kp (q_target - q) - kd qd, +-effort_limit)"}}


def rollout_actions(actor, obs_seq):
    """Deterministic actions of a fresh hidden state over [T, 1, D] observations."""
    actor.eval()
    actor.reset()
    with torch.no_grad():
        return torch.stack([actor(TensorDict({"policy": o}, batch_size=[1])) for o in obs_seq])

"""A policy exported from a fresh runner on the task (MuJoCo backend), what the deploy and sim-to-sim tests run."""

import torch

from cra_warp.deploy import DeployPolicy
from cra_warp.learning import ContrastConfig, LearnerConfig, PPOConfig, export_policy, runner_cfg
from envs.loco_config import LocoConfig
from envs.locomotion import LocoEnv
from rsl_rl.runners import OnPolicyRunner
from train.export import deploy_metadata


def _exported(variant: str, tmp_path, **gait):
    cfg = LocoConfig(num_envs=2, variant=variant, seed=3)
    for k, v in gait.items():
        setattr(cfg.gait, k, v)
    cfg.commands.heading_mode = False
    cfg.world.backend = "mujoco"
    cfg.obs.noise = False
    env = LocoEnv(cfg)
    torch.manual_seed(0)
    learner = LearnerConfig(num_steps_per_env=4, contrast=ContrastConfig(variant="none"),
                            ppo=PPOConfig(num_mini_batches=1))
    runner = OnPolicyRunner(env, runner_cfg(learner), log_dir=None, device="cpu")
    export_policy(runner, tmp_path, deploy_metadata(env))
    return env, runner.alg.get_policy(), DeployPolicy(tmp_path)

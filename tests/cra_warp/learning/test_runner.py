"""The runner: rsl-rl's own learn() loop logs the contrast and saves the heads."""

from __future__ import annotations

import torch

from rsl_rl.runners import OnPolicyRunner

from cra_warp.learning import LearnerConfig, PPOConfig, runner_cfg
from cra_warp.learning.bench import DummyEnv
from tests.cra_warp.learning.helpers import STEPS


def test_runner_learn_logs_infonce(tmp_path):
    """rsl-rl's own loop: one learn() iteration logs Loss/infonce* and saves a checkpoint with the heads."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    torch.manual_seed(0)
    env = DummyEnv(4)
    cfg = LearnerConfig(num_steps_per_env=STEPS, ppo=PPOConfig(num_learning_epochs=1, num_mini_batches=2),
                        privileged_slices=env.privileged_slices)
    runner = OnPolicyRunner(env, runner_cfg(cfg), log_dir=str(tmp_path), device="cpu")
    runner.learn(1)
    events = EventAccumulator(str(tmp_path))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    assert {"Loss/infonce", "Loss/infonce_acc", "Loss/infonce_chance"} <= tags and "Loss/symmetry" not in tags
    assert "contrast_state_dict" in torch.load(tmp_path / "model_0.pt", weights_only=False)

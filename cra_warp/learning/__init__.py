"""The learner: rsl-rl 5.5.1 (used as a library) with the paper's recurrent asymmetric actor-critic and contrast.

config.py        typed hyper-parameters and ``runner_cfg()`` -> rsl-rl OnPolicyRunner train_cfg
models.py        CRAActor (GRU + MLP), CRACritic (GRU + CNN -> 288 -> V), both rsl-rl RNNModels
contrastive.py   encoder heads, InfoNCE, same-step / sequential pairing
ppo.py           CRAPPO: rsl-rl PPO + weight * InfoNCE on the same mini-batches
checkpoint.py    load_checkpoint(): runner.load with one-line errors
export.py        TorchScript + ONNX actor and a JSON with everything a deploy program needs
bench.py         DummyEnv and learner_benchmark()
"""

from cra_warp.learning.checkpoint import CheckpointError, load_checkpoint
from cra_warp.learning.config import (ActorConfig, ContrastConfig, CriticConfig, LearnerConfig, PPOConfig,
                                      runner_cfg)
from cra_warp.learning.export import export_policy
from cra_warp.learning.models import CRAActor, CRACritic
from cra_warp.learning.ppo import CRAPPO

__all__ = ["ActorConfig", "CriticConfig", "ContrastConfig", "PPOConfig", "LearnerConfig", "runner_cfg",
           "CRAActor", "CRACritic", "CRAPPO", "load_checkpoint", "CheckpointError", "export_policy"]

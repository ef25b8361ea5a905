"""Typed learner configuration and its translation into rsl-rl 5.5.1's runner cfg dict.

Defaults follow the paper where it says something (III-A..III-C, IV-A: GRU/RNN 256 for actor and critic, CNN
feature u_t of 32, InfoNCE with a temperature) and the legged_gym/rsl-rl PPO defaults where it does not (clip 0.2,
gamma 0.99, lambda 0.95, adaptive KL schedule with desired KL 0.01, lr 1e-3, 4 mini-batches, 24 env steps per
iteration; 2 epochs, not 5: see the field). Every choice the paper leaves open is commented at its field.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Literal

ContrastVariant = Literal["same_step", "sequential", "none"]
CONTRAST_VARIANTS: tuple[str, ...] = ("same_step", "sequential", "none")
ActorKind = Literal["gru", "dreamwaq", "dwl"]

# Where rsl-rl's resolve_callable finds our classes ("module:Class" keeps the cfg dict serialisable).
ACTOR_CLASSES = {"gru": "cra_warp.learning.models:CRAActor",
                 "dreamwaq": "cra_warp.learning.baselines:DreamWaQActor",
                 "dwl": "cra_warp.learning.baselines:DWLActor"}
CRITIC_CLASS = "cra_warp.learning.models:CRACritic"
ALGORITHM_CLASS = "cra_warp.learning.ppo:CRAPPO"


@dataclass
class ActorConfig:
    """RNN_a over o_t, then a small MLP to the Gaussian mean (paper III-A.1)."""

    # GRU, not LSTM: the paper's Eq. (1) has one 256-dim recurrent state h_t and a 256-dim output m_a; a GRU's output
    # IS its hidden state, so m_a = h_t exactly. It also carries one state tensor instead of two (one h_in/h_out pair
    # in the ONNX graph for the deploy program) and has 3 gates instead of 4: ~25% less compute in the update, which
    # dominates our CPU iteration time.
    rnn_type: str = "gru"
    rnn_hidden_dim: int = 256
    rnn_num_layers: int = 1
    hidden_dims: tuple[int, ...] = (128, 64)     # "a small MLP" (paper); 256 -> 128 -> 64 -> A
    activation: str = "elu"
    obs_normalization: bool = True               # running mean/std; copied into the exported graph
    init_std: float = 0.3                        # Gaussian std at start, in action units (see below)
    std_type: str = "scalar"                     # "scalar" or "log" parameterisation of the state-free std
    # the actor's representation: "gru" (RNN_a, every CRA-Loco variant) or a baseline's estimator (issue 13):
    # "dreamwaq" (LearnerConfig.dreamwaq) or "dwl" (LearnerConfig.dwl). The critic is ours for all of them.
    kind: ActorKind = "gru"


@dataclass
class DreamWaQConfig:
    """DreamWaQ's context-aided estimator (Nahrendra et al. 2023, sec. III; baselines.DreamWaQActor). Sizes as
    the paper's Fig. 2 is read by public re-implementations (its text gives none); every other choice is ours."""

    history: int = 5                             # H observations in the estimator's window (paper: H = 5)
    latent_dim: int = 16                         # z
    encoder_dims: tuple[int, ...] = (128, 64)    # window -> 128 -> 64 -> [v_hat 3, mu 16, log var 16]
    decoder_dims: tuple[int, ...] = (64, 128)    # [v_hat, z] -> 64 -> 128 -> o_{t+1}
    hidden_dims: tuple[int, ...] = (512, 256, 128)  # the policy MLP on [o_t, v_hat, mu]
    # beta of the beta-VAE (paper: not given), with the KL and both MSEs averaged over their dimensions; a public
    # re-implementation found z collapsed with beta 1 on a summed KL and alive with 0.35 on averaged terms.
    beta: float = 0.35
    # The estimator's loss enters PPO's loss with this weight (the paper trains CENet beside the policy, lr 1e-3,
    # and does not say how: one optimizer, the KL-adapted lr and rsl-rl's gradient clip, is our choice). Its outputs
    # enter the policy detached.
    weight: float = 1.0
    # AdaBoot (the paper's adaptive bootstrapping; cra_warp/learning/adaboot.py): each learning iteration the policy
    # is fed the estimator's velocity with probability p_boot = 1 - tanh(CV(R)), CV the coefficient of variation of
    # the robots' episodic returns, and the true (privileged) velocity otherwise: ground truth while the returns
    # still spread widely, the estimates once they agree. On for dreamwaq_clock_free; off for dreamwaq, whose stored
    # runs trained without it (an override turns it on). Export and deploy always feed the estimates.
    adaboot: bool = False


@dataclass
class DWLConfig:
    """DWL's denoising world model (Gu et al. 2024, Table VI; baselines.DWLActor): GRU 256 -> 256 -> z (24) ->
    policy 48 -> A; decoder z -> 64 -> s_t. Loss ||s_hat - s||^2 (mean) + 0.002 ||z||_1, joint with PPO."""

    encoder_dims: tuple[int, ...] = (256,)
    latent_dim: int = 24
    decoder_dims: tuple[int, ...] = (64,)
    hidden_dims: tuple[int, ...] = (48,)
    latent_l1: float = 0.002
    # DWL weighs its PPO losses 5x the denoising loss (lambda_pi = lambda_v = 5): 1/5 relative to our PPO loss
    weight: float = 0.2


@dataclass
class CriticConfig:
    """RNN_c over s_t (m_c, 256) and a CNN over the 17x11 height map (u_t, 32); z_t = [m_c, u_t] (288) -> V."""

    rnn_type: str = "gru"                        # same reasoning as the actor
    rnn_hidden_dim: int = 256
    rnn_num_layers: int = 1
    # The paper says "a fully connected layer" on z_t; rsl-rl's MLP needs >= 1 hidden layer and a value head on 288
    # features benefits from one: 288 -> 256 -> 128 -> 1.
    hidden_dims: tuple[int, ...] = (256, 128)
    activation: str = "elu"
    obs_normalization: bool = True
    # rsl-rl CNN over [1, 17, 11]: conv3x3 s1 -> [16, 15, 9], conv3x3 s2 -> [32, 7, 4], flatten 896, then a linear
    # layer + ELU to u_t (32). No global pooling: where an edge is in the map matters for the value.
    cnn_channels: tuple[int, ...] = (16, 32)
    cnn_kernel_size: int = 3
    # (2, 1) downsamples first: ~20% less PPO update time on the CPU, but a 10-20% higher value loss on rough
    # terrain in two seeds (cra-bench-learner's CNN row; the README), so full resolution first stays the default.
    cnn_stride: tuple[int, ...] = (1, 2)
    cnn_latent_dim: int = 32                     # u_t


@dataclass
class ContrastConfig:
    """Contrastive module (paper III-C): MLP_S(m_a) vs MLP_T([stop_grad(u_t), s_t]) with InfoNCE."""

    variant: ContrastVariant = "same_step"       # ours | "sequential" (target = next step) | "none" (ablation)
    weight: float = 0.1                          # loss = PPO loss + weight * InfoNCE (paper: not given; untuned)
    tau: float = 0.1                             # temperature (paper: not given; the usual value for cosine logits)
    # L2-normalise I_S and I_T (cosine logits in [-1/tau, 1/tau]). The paper's Eq. uses a plain dot product; with
    # unnormalised embeddings the loss can also be lowered by inflating their norms, which feeds ever larger
    # gradients into the actor's RNN (that the policy shares). Normalised logits are bounded and make tau mean what
    # it says. False reproduces the paper's literal dot product.
    normalize: bool = True
    embed_dim: int = 256                         # I_S, I_T in R^256 (paper)
    hidden_dims: tuple[int, ...] = (256,)        # one hidden layer in each encoder head
    activation: str = "elu"
    # Cap on the samples one InfoNCE term uses: a random subset of the mini-batch's (env, step) samples when it has
    # more (0 = all, the paper's literal form). The logits are K x K, so the term costs O(K^2 D): at N=1024 a whole
    # mini-batch (K = 24 x 256 = 6144) took ~1.2 TFLOP per update, more than the rest of the update together
    # (~0.8 TFLOP); K = 2048 costs ~0.13 TFLOP and still gives 2047 negatives per positive. Below N=342 (with
    # 24 steps, 4 mini-batches) the whole mini-batch is used anyway.
    max_samples: int = 2048
    # MLP_T's s_t with the noise-free actor observation that the privileged group carries (our first reading of
    # the paper's s_t) or without it. With it InfoNCE pairs I_S and I_T on proprioception alone (top-1 1.00 within
    # ~10 iterations); without it only the privileged state and the terrain (u_t, the foot maps) are left to
    # match. Without it, a linear probe finds more terrain in m_a than with it or with no contrast (issue 11 part
    # 5: 2 seeds each, rough fine-tunes of 500 iterations; tools/results/probe_contrast_seed*.json, recorded
    # before cra-probe steered these yaw-rate policies at their targets: they walked their start headings).
    target_actor_obs: bool = False

    def __post_init__(self):
        if self.variant not in CONTRAST_VARIANTS:
            raise ValueError(f"ContrastConfig.variant must be one of {CONTRAST_VARIANTS}, got {self.variant!r}")
        if self.tau <= 0:
            raise ValueError(f"ContrastConfig.tau must be > 0, got {self.tau}")
        if self.weight < 0:
            raise ValueError(f"ContrastConfig.weight must be >= 0, got {self.weight}")
        if self.max_samples < 0 or self.max_samples == 1:
            raise ValueError(f"ContrastConfig.max_samples must be 0 (all) or >= 2, got {self.max_samples}")


@dataclass
class PPOConfig:
    """rsl-rl PPO hyper-parameters (arguments of rsl_rl.algorithms.PPO)."""

    clip_param: float = 0.2                      # paper: epsilon e.g. 0.2
    gamma: float = 0.99
    lam: float = 0.95
    value_loss_coef: float = 1.0
    # Entropy of the 26-dim Gaussian is summed over dims, so the bonus scales with the action count; 0.005 keeps
    # exploration pressure near legged_gym's 0.01 for 12-dof robots' per-dim level.
    entropy_coef: float = 0.005
    learning_rate: float = 1e-3
    # 2, not rsl-rl's 5. 5 -> 3: 40% less update time, and in a 2-seed A/B (100 flat iterations, bf16) the reward
    # ended higher (141 vs 126), the episode length the same (tools/results/ab_epochs.json). 3 -> 2: ~30% less
    # update time (fp32, N=256), episode length 120 vs 116 and reward 462 vs 446, within the seed spread
    # (tools/results/ab_epochs2.json)
    num_learning_epochs: int = 2
    num_mini_batches: int = 4                    # recurrent: splits the envs, each mini-batch = N/4 whole rollouts
    schedule: str = "adaptive"                   # lr adapted to keep KL(old || new) near desired_kl
    desired_kl: float = 0.01
    max_grad_norm: float = 1.0
    use_clipped_value_loss: bool = True
    normalize_advantage_per_mini_batch: bool = False
    # bf16 autocast of the update's forward passes and losses (rsl-rl's own switch); parameters, optimizer state,
    # returns and advantages stay fp32, and InfoNCE's softmax runs in fp32. With AVX512-BF16 the update at N=1024,
    # one thread, took 16.7 s in fp32 and 10.5 s in bf16 (tools/results/learner_cpu_2core.json); a 2-seed A/B of
    # 100 flat iterations learned the same (tools/results/ab_bf16.json). cra-train turns it off where the device
    # has no native bf16 (bf16_supported), as emulated bf16 is slower than fp32.
    use_mixed_precision: bool = True


@dataclass
class LearnerConfig:
    actor: ActorConfig = field(default_factory=ActorConfig)
    critic: CriticConfig = field(default_factory=CriticConfig)
    contrast: ContrastConfig = field(default_factory=ContrastConfig)
    ppo: PPOConfig = field(default_factory=PPOConfig)
    dreamwaq: DreamWaQConfig = field(default_factory=DreamWaQConfig)
    dwl: DWLConfig = field(default_factory=DWLConfig)
    # where the baselines' targets sit in the privileged group (cra-train fills them from the env's layout):
    # "velocity" (base linear velocity) and "observation" (the noise-free actor observation), [start, stop)
    privileged_slices: dict[str, tuple[int, int]] = field(default_factory=dict)
    num_steps_per_env: int = 24                  # rollout length per env and iteration (= recurrent BPTT window)
    save_interval: int = 100                     # iterations between checkpoints (only when a log_dir is given)
    # first updates of a run that train the critic (and the contrastive heads) only, the actor held and the
    # learning rate fixed: for a fork from a shipped, actor-only policy, whose fresh critic would otherwise steer
    # the actor with untrained advantages (CRAPPO.update)
    critic_warmup: int = 0
    # cra-train --init: the fork's starting learning rate (the adaptive schedule takes over from there) and its
    # critic warm-up where the checkpoint has no critic. A slow start (5e-5 and 10 warm-up updates) kept a
    # rough_walk_v0 fork's terrain level over 100 iterations where ppo.learning_rate's first steps lost it
    # (ab_fork_lr), but the slow-start forks then lost their flat walking by iteration ~300 (v_x error 0.29-1.7 at
    # 0.5 m/s, median 0.70, 9 runs, also on the code of that A/B) where full-rate forks mostly kept it (0.10-0.34,
    # median 0.18, 5 runs): docs/experiments.md, the fork regression. So a fork starts at the run's rate, unwarmed.
    fork_learning_rate: float = 1e-3
    fork_critic_warmup: int = 0
    # The warm-up's own rate, its value loss then unclipped (CRAPPO.update); None = the run's rate with PPO's clip.
    # Off: 50 warm-up iterations at 1e-3 fitted a rough_walk_v0 fork's critic (value loss 4400 -> ~1000) but the
    # fork unlearnt walking sooner, not later
    critic_warmup_learning_rate: float | None = None
    # Weight of the actor's left-right mirror loss (cra_warp/learning/symmetry.py; beyond the paper), 0 = off. The
    # maps come from the task (the runner reads them off the env).
    symmetry_weight: float = 0.0
    # Weight of a loss on the actor's action mean beyond the env's clip (sum over actions of relu(|mu| - bound)^2;
    # beyond the paper), 0 = off. The env clips the gait actions to +-1, so a mean that drifted past the clip sends
    # every sample to the same clock rate and PPO gets no signal to slow it down again: in the climbing runs the rate
    # sat at its 1.5x ceiling on every terrain (docs/experiments.md). Inside the bounds it is zero, so
    # it changes no optimum, only where the search can go. The bounds come from the task (LocoEnv.action_bounds).
    action_bound_weight: float = 0.0
    # How the update reads the rollout (CRAPPO): the critic's values in one pass over the whole rollout after
    # collection (equal to rsl-rl's per-step values, tests/cra_warp/learning/test_ppo_whole_envs.py; False: rsl-rl's per step), and
    # mini-batches of whole environments without padding (equal to rsl-rl's padded ones; slower on our CPUs)
    batched_values: bool = True
    whole_env_update: bool = False
    # The privileged group already holds the noise-free actor observation, so the critic needs no "policy".
    obs_groups: dict[str, list[str]] = field(default_factory=lambda: {
        "actor": ["policy"], "critic": ["privileged", "height_map"]})
    logger: str = "tensorboard"
    experiment_name: str = "cra_loco"
    run_name: str = ""
    check_for_nan: bool = True
    # rsl-rl compiles actor and critic with torch.compile in this mode (None: eager). Measured on this CPU
    # (tools/bench_learner.py): no gain for the GRU models, so eager is the default.
    torch_compile_mode: str | None = None


def stored_target_actor_obs(stored_learner: dict) -> bool:
    """ContrastConfig.target_actor_obs of a run's stored learner config; runs stored before the field had the actor
    observation in the target."""
    return bool(stored_learner.get("contrast", {}).get("target_actor_obs", True))


def bf16_supported(device: str) -> bool:
    """Native bf16 matrix work on ``device``: AVX512-BF16 or AMX on a CPU, compute capability 8+ on CUDA."""
    import torch

    if str(device).startswith("cuda"):
        return torch.cuda.is_bf16_supported(including_emulation=False)
    return bool(torch.cpu._is_avx512_bf16_supported() or torch.cpu._is_amx_tile_supported())


def runner_cfg(cfg: LearnerConfig | None = None) -> dict:
    """rsl-rl 5.5.1 OnPolicyRunner train_cfg for ``cfg``, serialisable: classes as "module:Class" strings, which
    rsl-rl resolves (so this module imports neither the models nor the algorithm)."""
    cfg = cfg or LearnerConfig()
    a, c, p = cfg.actor, cfg.critic, cfg.ppo
    if a.kind not in ACTOR_CLASSES:
        raise ValueError(f"ActorConfig.kind must be one of {tuple(ACTOR_CLASSES)}, got {a.kind!r}")
    actor = {"class_name": ACTOR_CLASSES[a.kind], "hidden_dims": list(a.hidden_dims), "activation": a.activation,
             "obs_normalization": a.obs_normalization,
             "distribution_cfg": {"class_name": "rsl_rl.modules:GaussianDistribution", "init_std": a.init_std,
                                  "std_type": a.std_type}}
    representation_weight = 0.0
    if a.kind == "gru":
        actor.update(rnn_type=a.rnn_type, rnn_hidden_dim=a.rnn_hidden_dim, rnn_num_layers=a.rnn_num_layers)
    elif a.kind == "dreamwaq":
        d = cfg.dreamwaq
        actor.update(hidden_dims=list(d.hidden_dims), history=d.history, latent_dim=d.latent_dim,
                     encoder_dims=list(d.encoder_dims), decoder_dims=list(d.decoder_dims), beta=d.beta,
                     targets={k: list(v) for k, v in cfg.privileged_slices.items()}, adaboot=d.adaboot)
        representation_weight = d.weight
    else:
        d = cfg.dwl
        actor.update(hidden_dims=list(d.hidden_dims), rnn_type=a.rnn_type, rnn_hidden_dim=a.rnn_hidden_dim,
                     rnn_num_layers=a.rnn_num_layers, encoder_dims=list(d.encoder_dims), latent_dim=d.latent_dim,
                     decoder_dims=list(d.decoder_dims), latent_l1=d.latent_l1)
        representation_weight = d.weight
    return {
        "num_steps_per_env": cfg.num_steps_per_env,
        "save_interval": cfg.save_interval,
        "obs_groups": {k: list(v) for k, v in cfg.obs_groups.items()},
        "logger": cfg.logger,
        "experiment_name": cfg.experiment_name,
        "run_name": cfg.run_name,
        "check_for_nan": cfg.check_for_nan,
        "torch_compile_mode": cfg.torch_compile_mode,
        "actor": actor,
        "critic": {
            "class_name": CRITIC_CLASS,
            "hidden_dims": list(c.hidden_dims), "activation": c.activation, "obs_normalization": c.obs_normalization,
            "rnn_type": c.rnn_type, "rnn_hidden_dim": c.rnn_hidden_dim, "rnn_num_layers": c.rnn_num_layers,
            "cnn_cfg": {"output_channels": list(c.cnn_channels), "kernel_size": c.cnn_kernel_size,
                        "stride": list(c.cnn_stride), "activation": c.activation},
            "cnn_latent_dim": c.cnn_latent_dim,
        },
        "algorithm": {"class_name": ALGORITHM_CLASS, **asdict(p), "optimizer": "adam", "rnd_cfg": None,
                      "symmetry_cfg": None, "contrast_cfg": asdict(cfg.contrast),
                      "actor_obs_slice": list(cfg.privileged_slices["observation"])
                      if "observation" in cfg.privileged_slices else None,
                      "representation_weight": representation_weight, "critic_warmup": cfg.critic_warmup,
                      "critic_warmup_learning_rate": cfg.critic_warmup_learning_rate,
                      "symmetry_weight": cfg.symmetry_weight, "action_bound_weight": cfg.action_bound_weight,
                      "batched_values": cfg.batched_values, "whole_env_update": cfg.whole_env_update},
    }

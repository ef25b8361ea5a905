"""PPO with auxiliary representation losses: rsl-rl 5.5.1's PPO, plus weight * InfoNCE (ours) or a baseline actor's
own loss (DreamWaQ's estimator, DWL's world model: cra_warp/learning/baselines.py) on the same mini-batches.

How a term gets into rsl-rl's loss (the smallest override that works in 5.5.1): ``PPO.update()`` is one method
with no auxiliary-loss hook except the symmetry extension's slot, which runs inside the mini-batch loop right after
the actor and critic forwards, under the same autocast, and adds ``mirror_loss_coeff * compute_loss(...)`` to the
loss before the single ``backward()``. rsl-rl refuses a symmetry config for recurrent models, so that slot is free
here: we put a small adapter there (:class:`_AuxLossHook`) instead of copying the ~150-line update loop. The
PPO loss, clipping, KL-adaptive learning rate, gradient-norm clipping and optimizer step stay rsl-rl's own code.
The adapter counts its calls and ``update()`` checks the count, so an rsl-rl release that changes the loop fails
loudly instead of silently training without the term.
Differences from plain PPO: the two contrastive encoder heads are an extra optimizer param group (same lr, adapted
by the same KL schedule); their gradients are not norm-clipped (rsl-rl clips actor and critic only; Adam is
insensitive to the gradient scale), and they are saved/loaded as ``contrast_state_dict`` in the checkpoint. A
baseline's estimator or decoder is part of its actor: optimised, clipped and saved with it. DreamWaQ's AdaBoot
(adaboot.py) adds its coins to the observations before each act, so the storage, built with that group, replays them.

Where the time goes on a CPU (issue 34): with ``batched_values`` (the default) the critic does not run inside the
rollout loop. ``act`` steps the actor only; ``compute_returns`` runs the critic once over the whole [T, N] rollout
(one GRU pass with the state zeroed after each done, the CNN and the value head batched), saves its states where
rsl-rl's storage keeps them, then applies rsl-rl's time-out bootstrap and GAE to those values: the same numbers
(tests/cra_warp/learning/test_ppo_whole_envs.py).
``whole_env_update`` (off by default) replaces rsl-rl's padded recurrent mini-batches by whole environments over
the fixed window, the GRUs restarting at dones inside the sequence (models.gru_sequence); the same losses, KL
schedule, clipping and step, tested equal to rsl-rl's update. Off because it measured slower on the CPU: the
written-out GRU's backward took ~2x nn.GRU's, and rsl-rl's padding adds only ~7% trajectories in training
(tools/results/bench_learner_profile_*.json).
"""

from __future__ import annotations

from itertools import chain

import torch

from rsl_rl.algorithms import PPO
from rsl_rl.utils import reduce_gradients_in_buckets

from cra_warp.learning.adaboot import BOOTSTRAP_GROUP, AdaBoot, with_bootstrap
from cra_warp.learning.config import ContrastConfig
from cra_warp.learning.contrastive import ContrastiveHeads, contrast_pairs, episode_ids, info_nce, subsample
from cra_warp.learning.models import CRAActor, CRACritic
from cra_warp.learning.symmetry import Mirror, mirror_loss


class _AuxLossHook:
    """Stands in rsl-rl's ``PPO.symmetry`` slot: no augmentation, its "mirror loss" is the sum of our auxiliary
    terms, each already weighted (``mirror_loss_coeff`` is 1)."""

    use_data_augmentation = False
    use_mirror_loss = True
    mirror_loss_coeff = 1.0

    def __init__(self, terms) -> None:
        self.terms = terms  # [(weight, fn(batch) -> (loss, {name: value}))]
        self.reset()

    def reset(self) -> None:
        self.calls, self.sums = 0, {}

    def augment_batch(self, batch, original_batch_size: int) -> None:
        pass

    def compute_loss(self, actor, batch, original_batch_size: int) -> torch.Tensor:
        total = 0.0
        for weight, term in self.terms:
            loss, logs = term(batch)
            total = total + weight * loss
            for k, v in logs.items():
                self.sums[k] = self.sums.get(k, 0.0) + v
        self.calls += 1
        return total

    def means(self) -> dict[str, float]:
        return {k: v / max(self.calls, 1) for k, v in self.sums.items()}


class _WholeEnvBatch:
    """What our loss terms read of a whole-env mini-batch: observations [T, B] and episode ids [T, B] (no masks)."""

    masks = None

    def __init__(self, observations, episodes) -> None:
        self.observations, self.episodes = observations, episodes


class CRAPPO(PPO):
    """rsl-rl PPO + ``contrast_cfg.weight`` * InfoNCE(MLP_S(m_a), MLP_T([sg(u_t), s_t])) + ``representation_weight``
    * the actor's ``representation_loss(batch)`` where the actor has one (the baselines).

    ``update()`` returns rsl-rl's keys plus, unless the contrast variant is "none": ``infonce`` (mean loss),
    ``infonce_acc`` (top-1 accuracy of the positive) and ``infonce_chance`` (1 / samples per term), and the
    baseline's own terms -> the runner logs them as Loss/<key>.
    """

    def __init__(self, actor, critic, storage, contrast_cfg: dict | ContrastConfig | None = None,
                 representation_weight: float = 1.0, actor_obs_slice: tuple[int, int] | None = None,
                 critic_warmup: int = 0, critic_warmup_learning_rate: float | None = None,
                 batched_values: bool = True, whole_env_update: bool = False,
                 symmetry_weight: float = 0.0, mirror: dict | None = None,
                 action_bound_weight: float = 0.0, action_bounds: list[float] | None = None, **kwargs) -> None:
        super().__init__(actor, critic, storage, **kwargs)
        # batched values need our CRACritic with a GRU; the whole-env update also a GRU CRAActor
        self.batched_values = (batched_values and isinstance(critic, CRACritic) and self.rnd is None
                               and isinstance(critic.rnn.rnn, torch.nn.GRU))
        self.whole_env_update = (whole_env_update and self.batched_values and isinstance(actor, CRAActor)
                                 and isinstance(actor.rnn.rnn, torch.nn.GRU) and isinstance(critic.rnn.rnn, torch.nn.GRU))
        if self.batched_values:
            T, N = storage.num_transitions_per_env, storage.num_envs
            rnn = critic.rnn.rnn
            self._time_outs = torch.zeros(T, N, 1, device=self.device)
            self._no_values = torch.zeros(N, 1, device=self.device)  # the rollout's placeholder, filled after it
            # the critic's state before each step, as rsl-rl's storage keeps it (its padded update reads it)
            storage.saved_hidden_state_c = [torch.zeros(T, rnn.num_layers, N, rnn.hidden_size, device=self.device)]
        if critic_warmup < 0:
            raise ValueError(f"critic_warmup must be >= 0 updates, got {critic_warmup}")
        self.critic_warmup_left = critic_warmup  # updates that still hold the actor (saved: a resume continues)
        # the warm-up's own rate (None: the run's rate); the critic alone takes it, so the actor's rate need not
        if critic_warmup_learning_rate is not None and not critic_warmup_learning_rate > 0:
            raise ValueError(f"critic_warmup_learning_rate must be > 0, got {critic_warmup_learning_rate}")
        self.critic_warmup_learning_rate = critic_warmup_learning_rate
        cfg = contrast_cfg if isinstance(contrast_cfg, ContrastConfig) else ContrastConfig(**(contrast_cfg or {}))
        self.contrast_cfg = cfg
        self.heads: ContrastiveHeads | None = None
        self.target_columns: torch.Tensor | None = None  # columns of s_t that MLP_T sees (None: all)
        terms = []
        if cfg.variant != "none":
            if not isinstance(actor, CRAActor) or not isinstance(critic, CRACritic):
                raise TypeError(f"the contrastive variant {cfg.variant!r} needs CRAActor and CRACritic models, "
                                f"got {type(actor).__name__} and {type(critic).__name__}")
            target_dim = critic.obs_dim
            if not cfg.target_actor_obs:
                if actor_obs_slice is None or not 0 <= actor_obs_slice[0] < actor_obs_slice[1] <= critic.obs_dim:
                    raise ValueError(f"contrast target_actor_obs=False needs the actor observation's [start, stop) "
                                     f"in the critic's s_t (width {critic.obs_dim}), got {actor_obs_slice}")
                keep = torch.ones(critic.obs_dim, dtype=torch.bool)
                keep[actor_obs_slice[0]:actor_obs_slice[1]] = False
                self.target_columns = keep.nonzero().squeeze(-1).to(self.device)
                target_dim = len(self.target_columns)
            self.heads = ContrastiveHeads(actor.latent_dim, critic.cnn_latent_dim, target_dim, cfg.embed_dim,
                                          cfg.hidden_dims, cfg.activation).to(self.device)
            self.optimizer.add_param_group({"params": list(self.heads.parameters()), "lr": self.learning_rate})
            terms.append((cfg.weight, self._contrast_term))
        if hasattr(actor, "representation_loss"):
            terms.append((representation_weight, lambda batch: self._raw_actor.representation_loss(batch)))
        if action_bound_weight:
            if action_bounds is None or len(action_bounds) != storage.actions.shape[-1]:
                raise ValueError(f"the action bound loss needs one bound per action ({storage.actions.shape[-1]}), "
                                 f"got {None if action_bounds is None else len(action_bounds)}")
            self.action_bounds = torch.as_tensor(action_bounds, dtype=torch.float, device=self.device)
            terms.append((action_bound_weight, self._bound_term))
        if symmetry_weight:
            if not isinstance(actor, CRAActor) or not mirror:
                raise ValueError("the mirror loss needs a CRAActor and the task's mirror maps (mirror={'obs': "
                                 "(index, sign), 'actions': (index, sign)})")
            self.mirrors = Mirror(*mirror["obs"], self.device), Mirror(*mirror["actions"], self.device)
            terms.append((symmetry_weight, self._mirror_term))  # last: it leaves the actor at the mirrored pass
        if terms:
            if self.symmetry is not None:
                raise ValueError("the auxiliary losses use rsl-rl's symmetry slot; symmetry_cfg must be None")
            self.symmetry = _AuxLossHook(terms)
        self.adaboot = AdaBoot(storage.num_envs, self.device) if getattr(actor, "adaboot", False) else None
        if self.adaboot is not None and BOOTSTRAP_GROUP not in storage.observations.keys():
            raise ValueError("AdaBoot needs the storage built with its observation group (CRAPPO.construct_algorithm)")

    @staticmethod
    def construct_algorithm(obs, env, cfg: dict, device: str) -> "CRAPPO":
        """rsl-rl's construction; with AdaBoot its storage also keeps the coins (adaboot.py) beside each step."""
        if cfg["actor"].get("adaboot"):
            obs = with_bootstrap(obs, torch.zeros(obs.batch_size[0], 1, device=obs.device))
        return PPO.construct_algorithm(obs, env, cfg, device)

    def _bound_term(self, batch) -> tuple[torch.Tensor, dict[str, float]]:
        """sum over actions of relu(|mu| - bound)^2 on the last actor forward's means, averaged over the samples."""
        excess = torch.relu(self._raw_actor.output_mean.float().abs() - self.action_bounds)
        loss = excess.square().sum(-1).mean()
        return loss, {"action_bound": loss.item()}

    def _mirror_term(self, batch) -> tuple[torch.Tensor, dict[str, float]]:
        starts = None
        if getattr(batch, "episodes", None) is not None:  # whole environments: restart where the episode changes
            starts = torch.zeros_like(batch.episodes, dtype=torch.bool)
            starts[1:] = batch.episodes[1:] != batch.episodes[:-1]
        loss = mirror_loss(self._raw_actor, batch.observations, starts, *self.mirrors, masks=batch.masks)
        return loss, {"mirror": loss.item()}

    def _contrast_term(self, batch) -> tuple[torch.Tensor, dict[str, float]]:
        loss, acc, k = self.contrastive_loss(batch.masks, getattr(batch, "episodes", None))
        return loss, {"infonce": loss.item(), "infonce_acc": acc.item(), "infonce_chance": 1.0 / k}

    def contrastive_loss(self, masks: torch.Tensor | None, episodes: torch.Tensor | None = None
                         ) -> tuple[torch.Tensor, torch.Tensor, int]:
        """InfoNCE on the features of the last actor and critic forward; (loss, top-1 accuracy, samples K).
        ``episodes`` [T, B] labels each step's episode (whole-env batches); else they come from rsl-rl's masks."""
        m_a, u, s = self._raw_actor.latent, self._raw_critic.u_t, self._raw_critic.s_t  # [T, B, ..] in update
        if self.target_columns is not None:
            s = s.index_select(-1, self.target_columns)
        if episodes is None and masks is not None:
            episodes = episode_ids(masks)                                               # [T, B]
        m_a, u, s = contrast_pairs(self.contrast_cfg.variant, m_a, u, s, episodes)     # [K, ..]
        m_a, u, s = subsample(self.contrast_cfg.max_samples, m_a, u, s)
        if m_a.shape[0] < 2:
            raise ValueError(f"the contrast needs at least 2 samples per mini-batch, got {m_a.shape[0]}")
        i_s, i_t = self.heads(m_a, u, s)                                                # [K, 256] each
        loss, acc = info_nce(i_s, i_t, self.contrast_cfg.tau, self.contrast_cfg.normalize)
        return loss, acc, m_a.shape[0]

    # ---------------------------------------------------------------- collection: the actor only, values after
    def act(self, obs):
        if self.adaboot is not None:  # the policy and the storage see this rollout's coins
            obs = self.adaboot.tag(obs)
        if not self.batched_values:
            return super().act(obs)
        t = self.transition
        t.hidden_states = (self.actor.get_hidden_state(), None)  # the critic's are saved by compute_returns
        t.actions = self.actor(obs, stochastic_output=True).detach()
        t.values = self._no_values
        t.actions_log_prob = self.actor.get_output_log_prob(t.actions).detach()
        t.distribution_params = tuple(p.detach() for p in self.actor.output_distribution_params)
        t.observations = obs
        return t.actions

    def process_env_step(self, obs, rewards, dones, extras) -> None:
        if self.adaboot is not None:
            self.adaboot.record(rewards, dones)
        if not self.batched_values:
            return super().process_env_step(obs, rewards, dones, extras)
        t = self.transition
        t.rewards, t.dones = rewards.clone(), dones  # the time-out bootstrap is added once the values exist
        time_outs = extras.get("time_outs")
        self._time_outs[self.storage.step] = 0.0 if time_outs is None else time_outs.to(self.device).unsqueeze(-1)
        self.storage.add_transition(t)
        t.clear()
        self.actor.reset(dones)  # the critic keeps the state it had at the rollout's start until compute_returns

    def compute_returns(self, obs) -> None:
        if not self.batched_values:
            return super().compute_returns(obs)
        st, critic = self.storage, self._raw_critic
        rnn = critic.rnn.rnn
        h0 = critic.get_hidden_state()
        if h0 is None:
            h0 = torch.zeros(rnn.num_layers, st.num_envs, rnn.hidden_size, device=self.device)
        starts = torch.zeros_like(st.dones[..., 0], dtype=torch.bool)
        starts[1:] = st.dones[:-1, :, 0].bool()
        values, h_last = critic.sequence(st.observations, h0, starts, st.saved_hidden_state_c[0])
        st.values.copy_(values)
        st.rewards += self.gamma * values * self._time_outs  # rsl-rl's bootstrap on time-outs, V of that step
        # the state the next rollout starts from: after the last step, zeroed where it ended an episode
        critic.reset(hidden_state=h_last * (1.0 - st.dones[-1, :, 0].float()).unsqueeze(-1))
        super().compute_returns(obs)  # last values from that state (restored after), then GAE

    def update(self) -> dict[str, float]:
        loss_dict = self._update() if self.critic_warmup_left <= 0 else self._warmup_update()
        if self.adaboot is not None:  # the next rollout's coins, from the returns so far
            loss_dict.update(self.adaboot.next_rollout())
        return loss_dict

    def _warmup_update(self) -> dict[str, float]:
        # Critic warm-up: the actor's parameters take no gradient (Adam skips them, rsl-rl's clipping and gradient
        # reduction ignore missing gradients) and its observation normaliser no update (rsl-rl's flag gates the
        # update only), so the policy that collects the data is the one being evaluated. The adaptive schedule
        # would multiply the learning rate by 1.5 every mini-batch (the KL of a held actor is rounding noise above
        # 0) and hand the actor a rate far too high when the warm-up ends: it stays put.
        # With critic_warmup_learning_rate the critic is fitted at that rate without PPO's value clip (0.2 per sample
        # and update, against returns in the hundreds); without it, at the run's rate with the clip.
        actor = self._raw_actor
        actor_params = [p for p in actor.parameters() if p.requires_grad]
        schedule, self.schedule = self.schedule, "fixed"
        own_rate = self.critic_warmup_learning_rate is not None
        clipped = self.use_clipped_value_loss
        self.use_clipped_value_loss = clipped and not own_rate
        normalization, actor.obs_normalization = actor.obs_normalization, False
        self._set_learning_rate(self.critic_warmup_learning_rate if own_rate else self.learning_rate)
        for p in actor_params:
            p.requires_grad_(False)
        try:
            loss_dict = self._update()
        finally:
            self.schedule, self.use_clipped_value_loss, actor.obs_normalization = schedule, clipped, normalization
            self._set_learning_rate(self.learning_rate)
            for p in actor_params:
                p.requires_grad_(True)
        self.critic_warmup_left -= 1
        return loss_dict

    def _set_learning_rate(self, rate: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] = rate

    def _update(self) -> dict[str, float]:
        if self.whole_env_update:
            return self._update_whole_envs()
        hook = self.symmetry
        if not isinstance(hook, _AuxLossHook):
            return super().update()
        hook.reset()
        loss_dict = super().update()
        loss_dict.pop("symmetry", None)  # the slot's own log entry is the sum; its terms are logged by name
        n = self.num_learning_epochs * self.num_mini_batches
        if hook.calls != n:
            raise RuntimeError(f"rsl-rl's PPO.update() called the auxiliary losses {hook.calls} times for {n} "
                               "mini-batches: CRAPPO relies on rsl-rl 5.5.1's update loop "
                               "(see cra_warp/learning/ppo.py)")
        loss_dict.update(hook.means())
        return loss_dict

    def _update_whole_envs(self) -> dict[str, float]:
        """rsl-rl 5.5.1's PPO.update over whole-environment mini-batches (env slices in rsl-rl's order, the same
        every epoch): the same losses, KL-adaptive rate, clipping and step, with our auxiliary terms called
        directly. Returns rsl-rl's keys and the terms' means."""
        st = self.storage
        T, N = st.num_transitions_per_env, st.num_envs
        size = N // self.num_mini_batches
        starts = torch.zeros(T, N, dtype=torch.bool, device=self.device)
        starts[1:] = st.dones[:-1, :, 0].bool()
        episodes = starts.cumsum(0)                                 # [T, N]: episode index within each env
        h0_actor, h0_critic = st.saved_hidden_state_a[0][0], st.saved_hidden_state_c[0][0]  # [L, N, H] at t = 0
        terms = self.symmetry.terms if isinstance(self.symmetry, _AuxLossHook) else []
        sums: dict[str, float] = {"value": 0.0, "surrogate": 0.0, "entropy": 0.0}
        device_type = torch.device(self.device).type
        for _ in range(self.num_learning_epochs):
            for i in range(self.num_mini_batches):
                sl = slice(i * size, (i + 1) * size)
                obs, advantages = st.observations[:, sl], st.advantages[:, sl]
                if self.normalize_advantage_per_mini_batch:
                    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
                with torch.autocast(device_type=device_type, enabled=self.use_mixed_precision, dtype=torch.bfloat16):
                    # clone: the saved states are inference tensors, which autograd may not keep
                    self._raw_actor.sequence(obs, h0_actor[:, sl].clone(), starts[:, sl])
                    log_prob = self.actor.get_output_log_prob(st.actions[:, sl])              # [T, B]
                    values, _ = self._raw_critic.sequence(obs, h0_critic[:, sl].clone(), starts[:, sl])
                    params = self.actor.output_distribution_params
                    entropy = self.actor.output_entropy
                    if self.desired_kl is not None and self.schedule == "adaptive":
                        old = tuple(p[:, sl] for p in st.distribution_params)
                        self._adapt_learning_rate(old, params)
                    old_log_prob = st.actions_log_prob[:, sl, 0]
                    ratio = torch.exp(log_prob - old_log_prob)
                    adv = advantages[..., 0]
                    surrogate = -adv * ratio
                    surrogate_clipped = -adv * torch.clamp(ratio, 1.0 - self.clip_param, 1.0 + self.clip_param)
                    surrogate_loss = torch.max(surrogate, surrogate_clipped).mean()
                    old_values, returns = st.values[:, sl], st.returns[:, sl]
                    if self.use_clipped_value_loss:
                        value_clipped = old_values + (values - old_values).clamp(-self.clip_param, self.clip_param)
                        value_loss = torch.max((values - returns).pow(2), (value_clipped - returns).pow(2)).mean()
                    else:
                        value_loss = (returns - values).pow(2).mean()
                    loss = surrogate_loss + self.value_loss_coef * value_loss - self.entropy_coef * entropy.mean()
                    batch = _WholeEnvBatch(obs, episodes[:, sl])
                    for weight, term in terms:
                        term_loss, logs = term(batch)
                        loss = loss + weight * term_loss
                        for k, v in logs.items():
                            sums[k] = sums.get(k, 0.0) + v
                self.optimizer.zero_grad()
                loss.backward()
                if self.is_multi_gpu:
                    self.reduce_parameters()
                torch.nn.utils.clip_grad_norm_(self.actor.parameters(), self.max_grad_norm)
                torch.nn.utils.clip_grad_norm_(self.critic.parameters(), self.max_grad_norm)
                self.optimizer.step()
                sums["value"] += value_loss.item()
                sums["surrogate"] += surrogate_loss.item()
                sums["entropy"] += entropy.mean().item()
        flat = st.observations.flatten(0, 1)
        self.actor.update_normalization(flat)
        self.critic.update_normalization(flat)
        st.clear()
        n = self.num_learning_epochs * self.num_mini_batches
        return {k: v / n for k, v in sums.items()}

    def _adapt_learning_rate(self, old_params, new_params) -> None:
        """rsl-rl's adaptive schedule, step for step: KL(old || new) of the mini-batch in fp32 moves the rate by
        1.5x when it leaves [desired / 2, 2 desired]; rank 0 decides, the others follow."""
        with torch.inference_mode():
            new_params = tuple(p.float() for p in new_params)
            kl_mean = torch.mean(self.actor.get_kl_divergence(old_params, new_params))
            if self.is_multi_gpu:
                torch.distributed.all_reduce(kl_mean, op=torch.distributed.ReduceOp.SUM)
                kl_mean /= self.gpu_world_size
            if self.gpu_global_rank == 0:
                if kl_mean > self.desired_kl * 2.0:
                    self.learning_rate = max(1e-5, self.learning_rate / 1.5)
                elif self.desired_kl / 2.0 > kl_mean > 0.0:
                    self.learning_rate = min(1e-2, self.learning_rate * 1.5)
            if self.is_multi_gpu:
                lr_tensor = torch.tensor(self.learning_rate, device=self.device)
                torch.distributed.broadcast(lr_tensor, src=0)
                self.learning_rate = lr_tensor.item()
            for group in self.optimizer.param_groups:
                group["lr"] = self.learning_rate

    # ---------------------------------------------------------------- the heads follow the models everywhere
    def train_mode(self) -> None:
        super().train_mode()
        if self.heads is not None:
            self.heads.train()

    def eval_mode(self) -> None:
        super().eval_mode()
        if self.heads is not None:
            self.heads.eval()

    def save(self) -> dict:
        saved = super().save()
        if self.heads is not None:
            saved["contrast_state_dict"] = self.heads.state_dict()
        if self.critic_warmup_left > 0:
            saved["critic_warmup_left"] = self.critic_warmup_left
        if self.adaboot is not None:
            saved["adaboot_state"] = self.adaboot.state_dict()
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        load_iteration = super().load(loaded_dict, load_cfg, strict)
        if load_cfg is None or load_cfg.get("optimizer"):  # a resume (not a fork) continues a warm-up it stopped in
            self.critic_warmup_left = loaded_dict.get("critic_warmup_left", 0)
            if self.adaboot is not None and "adaboot_state" in loaded_dict:  # and AdaBoot at its probability
                self.adaboot.load_state_dict(loaded_dict["adaboot_state"])
        if self.heads is not None and (load_cfg is None or load_cfg.get("contrast", load_cfg.get("optimizer"))):
            if "contrast_state_dict" in loaded_dict:
                self.heads.load_state_dict(loaded_dict["contrast_state_dict"], strict=strict)
            elif strict:
                raise KeyError("the checkpoint has no contrastive heads (trained with contrast variant 'none'?)")
        return load_iteration

    def broadcast_parameters(self) -> None:
        super().broadcast_parameters()
        if self.heads is not None:
            for tensor in self.heads.state_dict().values():
                torch.distributed.broadcast(tensor, src=0)

    def reduce_parameters(self) -> None:
        if self.heads is None:
            return super().reduce_parameters()
        params = chain(self.actor.parameters(), self.critic.parameters(), self.heads.parameters())
        if self.rnd:
            params = chain(params, self.rnd.parameters())
        reduce_gradients_in_buckets(params, self.gpu_world_size, self.grad_reduce_bucket_mb)

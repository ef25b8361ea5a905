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
baseline's estimator or decoder is part of its actor: optimised, clipped and saved with it.
"""

from __future__ import annotations

from itertools import chain

import torch

from rsl_rl.algorithms import PPO
from rsl_rl.utils import reduce_gradients_in_buckets

from cra_warp.learning.config import ContrastConfig
from cra_warp.learning.contrastive import ContrastiveHeads, contrast_pairs, episode_ids, info_nce, subsample
from cra_warp.learning.models import CRAActor, CRACritic


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


class CRAPPO(PPO):
    """rsl-rl PPO + ``contrast_cfg.weight`` * InfoNCE(MLP_S(m_a), MLP_T([sg(u_t), s_t])) + ``representation_weight``
    * the actor's ``representation_loss(batch)`` where the actor has one (the baselines).

    ``update()`` returns rsl-rl's keys plus, unless the contrast variant is "none": ``infonce`` (mean loss),
    ``infonce_acc`` (top-1 accuracy of the positive) and ``infonce_chance`` (1 / samples per term), and the
    baseline's own terms -> the runner logs them as Loss/<key>.
    """

    def __init__(self, actor, critic, storage, contrast_cfg: dict | ContrastConfig | None = None,
                 representation_weight: float = 1.0, actor_obs_slice: tuple[int, int] | None = None,
                 critic_warmup: int = 0, **kwargs) -> None:
        super().__init__(actor, critic, storage, **kwargs)
        if critic_warmup < 0:
            raise ValueError(f"critic_warmup must be >= 0 updates, got {critic_warmup}")
        self.critic_warmup_left = critic_warmup  # updates that still hold the actor (saved: a resume continues)
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
        if terms:
            if self.symmetry is not None:
                raise ValueError("the auxiliary losses use rsl-rl's symmetry slot; symmetry_cfg must be None")
            self.symmetry = _AuxLossHook(terms)

    def _contrast_term(self, batch) -> tuple[torch.Tensor, dict[str, float]]:
        loss, acc, k = self.contrastive_loss(batch.masks)
        return loss, {"infonce": loss.item(), "infonce_acc": acc.item(), "infonce_chance": 1.0 / k}

    def contrastive_loss(self, masks: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor, int]:
        """InfoNCE on the features of the last actor and critic forward; (loss, top-1 accuracy, samples K)."""
        m_a, u, s = self._raw_actor.latent, self._raw_critic.u_t, self._raw_critic.s_t  # [T, B, ..] in update
        if self.target_columns is not None:
            s = s.index_select(-1, self.target_columns)
        episodes = episode_ids(masks) if masks is not None else None                    # [T, B]
        m_a, u, s = contrast_pairs(self.contrast_cfg.variant, m_a, u, s, episodes)     # [K, ..]
        m_a, u, s = subsample(self.contrast_cfg.max_samples, m_a, u, s)
        if m_a.shape[0] < 2:
            raise ValueError(f"the contrast needs at least 2 samples per mini-batch, got {m_a.shape[0]}")
        i_s, i_t = self.heads(m_a, u, s)                                                # [K, 256] each
        loss, acc = info_nce(i_s, i_t, self.contrast_cfg.tau, self.contrast_cfg.normalize)
        return loss, acc, m_a.shape[0]

    def update(self) -> dict[str, float]:
        if self.critic_warmup_left <= 0:
            return self._update()
        # Critic warm-up: the actor's parameters take no gradient (Adam skips them, rsl-rl's clipping and gradient
        # reduction ignore missing gradients) and its observation normaliser no update (rsl-rl's flag gates the
        # update only), so the policy that collects the data is the one being evaluated. The adaptive schedule
        # would multiply the learning rate by 1.5 every mini-batch (the KL of a held actor is rounding noise above
        # 0) and hand the actor a rate far too high when the warm-up ends: it stays put.
        actor = self._raw_actor
        actor_params = [p for p in actor.parameters() if p.requires_grad]
        schedule, self.schedule = self.schedule, "fixed"
        normalization, actor.obs_normalization = actor.obs_normalization, False
        for p in actor_params:
            p.requires_grad_(False)
        try:
            loss_dict = self._update()
        finally:
            self.schedule, actor.obs_normalization = schedule, normalization
            for p in actor_params:
                p.requires_grad_(True)
        self.critic_warmup_left -= 1
        return loss_dict

    def _update(self) -> dict[str, float]:
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
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        load_iteration = super().load(loaded_dict, load_cfg, strict)
        if load_cfg is None or load_cfg.get("optimizer"):  # a resume (not a fork) continues a warm-up it stopped in
            self.critic_warmup_left = loaded_dict.get("critic_warmup_left", 0)
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

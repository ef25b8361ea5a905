"""Contrastive representation module (paper III-C): source / target encoders and the InfoNCE loss.

    I_S = MLP_S(m_a)                          [K, 256]   from the actor's RNN output (gradient flows into RNN_a)
    I_T = MLP_T([stop_grad(u_t), s_t])        [K, 256]   u_t: critic CNN feature (32), s_t: privileged obs (179)
    L   = -1/K sum_k log softmax_j(I_S[k] . I_T[j] / tau)[k]

Samples are (env, step) pairs of one PPO mini-batch. Positive of source row k = target row k (the diagonal):
the same env at the same step ("same_step", ours) or the same env at the next step of the same episode
("sequential" ablation). Negatives = every other (env, step) target of the mini-batch (all K-1 off-diagonal
entries of the row), after padded steps of the recurrent mini-batch are dropped (the models unpad with rsl-rl's
masks) and, when more than ``ContrastConfig.max_samples`` remain (default 2048), among a random subset of that
size drawn for the term (the same subset on both sides, so every kept positive stays on the diagonal).
The contrast never sends gradient into the critic: u_t is detached, s_t is an input and m_c is not used.
"""

from __future__ import annotations

import torch
import torch.nn as nn
import torch.nn.functional as F

from rsl_rl.modules import MLP
from rsl_rl.utils import unpad_trajectories


class ContrastiveHeads(nn.Module):
    """MLP_S: m_a [.., 256] -> I_S [.., 256]; MLP_T: [u_t (32), s_t (179)] -> I_T [.., 256]."""

    def __init__(self, source_dim: int, cnn_dim: int, priv_dim: int, embed_dim: int = 256,
                 hidden_dims=(256,), activation: str = "elu") -> None:
        super().__init__()
        self.source = MLP(source_dim, embed_dim, list(hidden_dims), activation)
        self.target = MLP(cnn_dim + priv_dim, embed_dim, list(hidden_dims), activation)

    def forward(self, m_a: torch.Tensor, u: torch.Tensor, s: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.source(m_a), self.target(torch.cat([u.detach(), s.detach()], dim=-1))


def info_nce(i_s: torch.Tensor, i_t: torch.Tensor, tau: float, normalize: bool = True
             ) -> tuple[torch.Tensor, torch.Tensor]:
    """InfoNCE of K source / target embeddings [K, D] whose positives are the diagonal.

    Returns (loss, top-1 accuracy): accuracy = share of rows whose positive has the largest logit (chance 1/K).
    ``normalize`` L2-normalises both sides first (cosine logits); False is the paper's plain dot product.
    """
    if normalize:
        i_s, i_t = F.normalize(i_s, dim=-1), F.normalize(i_t, dim=-1)
    logits = i_s @ i_t.T                                         # [K, K]; bf16 under the update's autocast
    # softmax, loss and argmax in fp32: on the CPU their bf16 kernels ran ~10x slower than fp32 here
    with torch.autocast(logits.device.type, enabled=False):
        logits = logits.float() / tau
        labels = torch.arange(logits.shape[0], device=logits.device)
        loss = F.cross_entropy(logits, labels)
    with torch.no_grad():
        acc = (logits.argmax(dim=-1) == labels).float().mean()
    return loss, acc


def episode_ids(masks: torch.Tensor) -> torch.Tensor:
    """Trajectory index of every (step, env) of a recurrent mini-batch: masks [T, B'] -> ids [T, B].

    rsl-rl splits each env's rollout at dones into trajectories (columns of the padded batch); unpadding their
    column index with the same masks labels each (t, env) with the episode piece it belongs to.
    """
    ids = torch.arange(masks.shape[1], device=masks.device).expand(masks.shape[0], -1)
    return unpad_trajectories(ids, masks)


def contrast_pairs(variant: str, m_a: torch.Tensor, u: torch.Tensor, s: torch.Tensor,
                   episodes: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Flatten [T, B, ..] features into K aligned rows (source m_a, target u, target s) for the variant.

    same_step:  row = (t, b) for every step, target features of (t, b).
    sequential: row = (t, b) with target features of (t + 1, b), only where t + 1 is in the same episode
                (``episodes`` [T, B] from :func:`episode_ids`; None = no dones in the batch): the last step
                and pairs across a done/reset are dropped.
    Flat [K, ..] inputs (no time axis) are accepted for "same_step" only.
    """
    if variant == "same_step":
        return m_a.reshape(-1, m_a.shape[-1]), u.reshape(-1, u.shape[-1]), s.reshape(-1, s.shape[-1])
    if variant == "sequential":
        if m_a.dim() != 3:
            raise ValueError("the sequential contrast needs [T, B, ..] features (a time axis)")
        if episodes is None:
            keep = torch.ones(m_a.shape[0] - 1, m_a.shape[1], dtype=torch.bool, device=m_a.device)
        else:
            keep = episodes[:-1] == episodes[1:]                    # [T-1, B]: t and t+1 in one episode
        return m_a[:-1][keep], u[1:][keep], s[1:][keep]
    raise ValueError(f"unknown contrast variant {variant!r} (expected 'same_step' or 'sequential')")


def subsample(max_samples: int, *rows: torch.Tensor) -> tuple[torch.Tensor, ...]:
    """The same random subset of ``max_samples`` rows of every tensor (all rows when 0 or fewer rows)."""
    k = rows[0].shape[0]
    if max_samples <= 0 or k <= max_samples:
        return rows
    idx = torch.randperm(k, device=rows[0].device)[:max_samples]
    return tuple(r[idx] for r in rows)

"""Left-right symmetry for a recurrent actor: a mirror loss over whole rollout windows.

rsl-rl 5.5.1's symmetry extension refuses recurrent models (a GRU's state has no mirror image to augment with), and
CRAPPO uses its slot for the contrast. So the term is ours: run the actor over the window's observations and over
their mirror images, both from the zero state and restarting where episodes start, and ask the mirrored sequence's
mean actions to be the mirror of the original's:

    L_mirror = mean_t || mu(M_o o_{1..t}) - M_a mu(o_{1..t}) ||^2      (the original's side detached)

An actor that is equivariant (mu(M_o o) = M_a mu(o) for every history) pays nothing; both passes start from zero
because a stored hidden state of the original has no mirrored counterpart. The maps M_o, M_a (index and sign per
entry) come from the task (envs.observations.actor_mirror / action_mirror): the library knows no robot.
"""

from __future__ import annotations

import torch


class Mirror:
    """A signed permutation of the last dimension: ``x[..., index] * sign`` (an involution for a mirror)."""

    def __init__(self, index, sign, device: str | torch.device = "cpu"):
        self.index = torch.as_tensor(index, dtype=torch.long, device=device)
        self.sign = torch.as_tensor(sign, dtype=torch.float32, device=device)
        if self.index.shape != self.sign.shape or self.index.ndim != 1:
            raise ValueError(f"a mirror needs one index and one sign per entry, got {tuple(self.index.shape)} and "
                             f"{tuple(self.sign.shape)}")
        x = torch.arange(len(self.index), dtype=torch.float32, device=device) + 1.0
        if not torch.equal(self(self(x)), x):
            raise ValueError("the mirror map must be its own inverse (index[index] = identity, sign[index] = sign)")

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        return x.index_select(-1, self.index) * self.sign.to(x.dtype)

    def to(self, device) -> Mirror:
        return Mirror(self.index.to(device), self.sign.to(device), device)


def mirror_loss(actor, obs, starts: torch.Tensor | None, obs_mirror: Mirror, action_mirror: Mirror,
                group: str = "policy") -> torch.Tensor:
    """L_mirror of ``actor`` (a CRAActor: ``sequence`` over whole environments) on obs [T, B] (a TensorDict whose
    ``group`` holds the actor observation), episodes restarting where ``starts`` [T, B] is set."""
    rnn = actor.rnn.rnn
    T, B = obs[group].shape[:2]
    h0 = torch.zeros(rnn.num_layers, B, rnn.hidden_size, device=obs[group].device, dtype=obs[group].dtype)
    latent = actor.latent  # the PPO pass's m_a (the contrast reads it after this term): kept
    with torch.no_grad():
        actor.sequence(obs, h0, starts)
        target = action_mirror(actor.distribution.mean)
    mirrored = obs.clone()
    mirrored[group] = obs_mirror(obs[group])
    actor.sequence(mirrored, h0, starts)
    loss = (actor.distribution.mean - target).pow(2).sum(-1).mean()
    actor.latent = latent
    return loss

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
                masks: torch.Tensor | None = None) -> torch.Tensor:
    """L_mirror of ``actor`` (a CRAActor: ``sequence`` over whole environments, one observation group) on obs
    [T, B] (a TensorDict), episodes restarting where ``starts`` [T, B] is set; only steps where ``masks`` [T, B]
    is set count (rsl-rl's padded trajectories). Call it after the PPO quantities of the mini-batch are taken:
    it leaves the actor's distribution at the mirrored pass (its ``latent`` is restored)."""
    if len(actor.obs_groups) != 1:
        raise ValueError(f"the mirror loss needs one actor observation group, got {actor.obs_groups}")
    group = actor.obs_groups[0]
    x = obs[group]
    T, B = x.shape[:2]
    rnn = actor.rnn.rnn
    h0 = torch.zeros(rnn.num_layers, B, rnn.hidden_size, device=x.device, dtype=x.dtype)
    latent = actor.latent  # the PPO pass's m_a (the contrast may read it after this term): kept
    with torch.no_grad():
        actor.sequence({group: x}, h0, starts)
        target = action_mirror(actor.distribution.mean)
    actor.sequence({group: obs_mirror(x)}, h0, starts)
    err = (actor.distribution.mean - target).pow(2).sum(-1)                 # [T, B]
    actor.latent = latent
    if masks is None:
        return err.mean()
    m = masks.to(err.dtype)
    return (err * m).sum() / m.sum().clamp(min=1.0)

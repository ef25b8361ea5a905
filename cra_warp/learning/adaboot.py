"""AdaBoot, DreamWaQ's adaptive bootstrapping (Nahrendra et al. 2023, sec. III; docs/paper.md).

The rule: p_boot = 1 - tanh(CV(R)), CV(R) = std(R) / mean(R) over R, the episodic returns of the domain-randomised
robots. p_boot is the probability of bootstrapping, i.e. of feeding the policy the estimator's body velocity; with
1 - p_boot it is fed the true (privileged) velocity. Returns that spread widely (CV large: the robots have not learnt
yet) give p_boot near 0, the truth; returns that agree (CV near 0) give p_boot near 1, the estimates the robot will
have. The estimator's context z has no true value: the policy always reads the estimator's.

Where the paper is silent (our choices): R holds each robot's latest finished episode; p_boot is recomputed after
every update and kept while fewer than 2 robots have finished an episode (0 before the first: the truth); a mean
return <= 0 counts as not learnt (p_boot 0); each robot draws its own coin once per rollout and keeps it through it.

The coins travel with the observations as the group "bootstrap" ([N, 1]: 1 the estimates, 0 the truth), so rsl-rl's
storage keeps them per step and the update replays to the policy what it was fed in collection. An observation
without the group (evaluation, play) gets the estimates; the exported graphs have no other input.
"""

from __future__ import annotations

import math

import torch
from tensordict import TensorDict

BOOTSTRAP_GROUP = "bootstrap"


def bootstrap_probability(returns: torch.Tensor) -> float | None:
    """p_boot = 1 - tanh(std / mean) of the finite entries of ``returns``; None with fewer than 2, 0 for a mean
    return <= 0 (no coefficient of variation: not learnt)."""
    r = returns[torch.isfinite(returns)].double()
    if r.numel() < 2:
        return None
    mean = r.mean()
    if mean <= 0:
        return 0.0
    return float(1.0 - torch.tanh(r.std(unbiased=False) / mean))


def with_bootstrap(obs: TensorDict, flags: torch.Tensor) -> TensorDict:
    """``obs`` (not modified) with the coins [N, 1] as its "bootstrap" group."""
    out = obs.copy()
    out[BOOTSTRAP_GROUP] = flags.to(obs.device)
    return out


class AdaBoot:
    """The coins of ``num_envs`` robots: the returns they come from (``record`` every env step), the probability
    (``next_rollout`` after every update) and the observation group (``tag`` before every act)."""

    def __init__(self, num_envs: int, device) -> None:
        self.probability = 0.0                                   # the truth until returns say otherwise
        self.running = torch.zeros(num_envs, device=device)      # each robot's return so far this episode
        self.returns = torch.full((num_envs,), math.nan, device=device)  # its latest finished episode's
        self.flags = torch.zeros(num_envs, 1, device=device)

    def record(self, rewards: torch.Tensor, dones: torch.Tensor) -> None:
        # out of place: called under inference mode in the rollout, read outside it
        done = dones.view(-1).bool()
        running = self.running + rewards.view(-1).float()
        self.returns = torch.where(done, running, self.returns)
        self.running = torch.where(done, 0.0, running)

    def next_rollout(self) -> dict[str, float]:
        """New probability from the returns so far, new coins for the next rollout; the logged values."""
        p = bootstrap_probability(self.returns)
        if p is not None:
            self.probability = p
        self._draw()
        return {"adaboot_probability": self.probability, "adaboot_estimates": float(self.flags.mean())}

    def tag(self, obs: TensorDict) -> TensorDict:
        return with_bootstrap(obs, self.flags)

    def state_dict(self) -> dict:
        return {"probability": self.probability}

    def load_state_dict(self, state: dict) -> None:
        self.probability = float(state["probability"])
        self._draw()

    def _draw(self) -> None:
        self.flags = (torch.rand_like(self.flags) < self.probability).float()

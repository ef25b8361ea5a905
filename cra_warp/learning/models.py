"""Actor and critic of the asymmetric actor-critic (paper III-A), as rsl-rl 5.5.1 models.

Both subclass ``rsl_rl.models.RNNModel`` so rsl-rl's PPO (act / evaluate / KL), RolloutStorage (saved hidden
states, padded recurrent mini-batches), OnPolicyRunner (save / load) and export (``as_jit`` / ``as_onnx``) treat them
exactly as rsl-rl's own recurrent models. What we add is the two features the contrastive module needs, kept from
the last forward pass:

    actor.latent   m_a                  [N, 256] in a rollout step, [T, B, 256] in a recurrent mini-batch
    critic.u_t     CNN feature u_t      [N, 32] / [T, B, 32]
    critic.s_t     privileged obs s_t   [N, 179] / [T, B, 179] (as RNN_c sees it: normalised, detached)

In a mini-batch rsl-rl feeds observations padded per trajectory ([T, B', ...], B' >= B trajectories, with masks);
its RNN returns the output already unpadded back to [T, B, ...] (time x env). u_t and s_t are unpadded with the same
masks, so row (t, b) of all three is the same env at the same step and padded steps never appear.

CRAPPO's own path (ppo.py) runs both models over whole environments instead: ``sequence(obs [T, B], h0, starts)``
steps the GRU through the fixed window with the state zeroed where an episode starts (:func:`gru_sequence`), which
is what rsl-rl's split-and-pad gives (a trajectory after a done starts from the zero state it saved) without the
padding, the split copies and the unpad gathers. The features above are then [T, B, ..] for every step.
"""

from __future__ import annotations

import torch
import torch.nn as nn
import torch.nn.functional as F
from tensordict import TensorDict

from rsl_rl.models import CNNModel, RNNModel
from rsl_rl.modules import CNN, HiddenState
from rsl_rl.utils import unpad_trajectories

CNN_CHUNK = 1536  # height maps per CNN call in a sequence pass: the conv activations of a larger batch leave the
#                   cache (6144 maps in one call took ~1.4x the time of four calls of 1536 here)


def gru_sequence(gru: nn.GRU, x: torch.Tensor, h0: torch.Tensor, starts: torch.Tensor | None = None,
                 states: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """``gru`` over x [T, B, D] from h0 [L, B, H], every layer's state zeroed before step t where starts[t] [T, B].

    The same recurrence as nn.GRU (gates r, z, n), written out so that the state can restart mid-sequence: the
    input projections of all T steps are one matmul per layer, only h @ W_hh is per step. ``states`` [T, L, B, H]
    (optional) receives the state each step starts from, after its restart (what rsl-rl's rollout storage saves).
    Returns (output of the last layer [T, B, H], state after the last step [L, B, H], before any restart).
    """
    T, H = x.shape[0], gru.hidden_size
    keep = None
    if starts is not None:
        restart = starts.any(dim=1).tolist()           # one host sync; most steps restart no env
        keep = (~starts).unsqueeze(-1)                 # [T, B, 1]
    finals = []
    inp = x
    for layer in range(gru.num_layers):
        w_ih, w_hh = getattr(gru, f"weight_ih_l{layer}"), getattr(gru, f"weight_hh_l{layer}")
        b_ih, b_hh = getattr(gru, f"bias_ih_l{layer}"), getattr(gru, f"bias_hh_l{layer}")
        gi = F.linear(inp, w_ih, b_ih)                 # [T, B, 3H]
        h = h0[layer]
        outs = []
        for t in range(T):
            if keep is not None and restart[t]:
                h = h * keep[t]
            if states is not None:
                states[t, layer].copy_(h)
            gh = F.linear(h, w_hh, b_hh)               # [B, 3H]
            r, z = torch.sigmoid(gi[t, :, :2 * H] + gh[:, :2 * H]).chunk(2, dim=-1)
            n = torch.tanh(gi[t, :, 2 * H:] + r * gh[:, 2 * H:])
            h = n + z * (h - n)                        # (1 - z) n + z h
            outs.append(h)
        inp = torch.stack(outs)
        finals.append(h)
    return inp, torch.stack(finals)


class CRAActor(RNNModel):
    """o_t [.., 84] -> GRU (256) -> m_a -> MLP (128, 64) -> Gaussian mean [.., 26] (rsl-rl's RNNModel unchanged).

    GRU rather than LSTM (see ActorConfig.rnn_type): its output is its state, m_a = h_t as in the paper's Eq. (1),
    one state tensor to carry at deployment, and 3 gates instead of 4 (cheaper updates on our CPU).
    """

    def __init__(self, obs: TensorDict, obs_groups: dict[str, list[str]], obs_set: str, output_dim: int,
                 hidden_dims=(128, 64), activation: str = "elu", obs_normalization: bool = True,
                 distribution_cfg: dict | None = None, rnn_type: str = "gru", rnn_hidden_dim: int = 256,
                 rnn_num_layers: int = 1) -> None:
        super().__init__(obs, obs_groups, obs_set, output_dim, hidden_dims, activation, obs_normalization,
                         distribution_cfg, rnn_type, rnn_hidden_dim, rnn_num_layers)
        self.latent: torch.Tensor | None = None  # m_a of the last forward (keeps its graph in training)

    def get_latent(self, obs: TensorDict, masks: torch.Tensor | None = None,
                   hidden_state: HiddenState = None) -> torch.Tensor:
        self.latent = super().get_latent(obs, masks, hidden_state)
        return self.latent

    def sequence(self, obs: TensorDict, h0: torch.Tensor, starts: torch.Tensor | None) -> None:
        """Forward over whole environments, obs [T, B]: sets the action distribution and ``latent`` [T, B, 256]
        (as ``forward(..., stochastic_output=True)`` does in a rollout step, minus the sample)."""
        x = self.obs_normalizer(torch.cat([obs[g] for g in self.obs_groups], dim=-1))
        self.latent, _ = gru_sequence(self.rnn.rnn, x, h0, starts)
        self.distribution.update(self.mlp(self.latent))


class CRACritic(RNNModel):
    """s_t -> GRU (256) = m_c; height map [1, 17, 11] -> CNN -> u_t (32); z_t = [m_c, u_t] (288) -> MLP -> V.

    Built on RNNModel (the recurrent part, hidden-state handling) with rsl-rl's CNN encoder; the observation-group
    split into 1D (RNN) and 2D (CNN) groups is CNNModel's own. Exactly one 2D group (the height map) is expected.
    """

    # 1D groups -> self.obs_groups / self.obs_dim (fed to the RNN); 2D groups -> self.obs_groups_2d etc.
    _get_obs_dim = CNNModel._get_obs_dim

    def __init__(self, obs: TensorDict, obs_groups: dict[str, list[str]], obs_set: str, output_dim: int,
                 hidden_dims=(256, 128), activation: str = "elu", obs_normalization: bool = True,
                 distribution_cfg: dict | None = None, rnn_type: str = "gru", rnn_hidden_dim: int = 256,
                 rnn_num_layers: int = 1, cnn_cfg: dict | None = None, cnn_latent_dim: int = 32) -> None:
        self._get_obs_dim(obs, obs_groups, obs_set)  # sets the 2D group attributes before the MLP is sized
        if len(self.obs_groups_2d) != 1:
            raise ValueError(f"CRACritic expects exactly one 2D observation group (the height map), "
                             f"got {self.obs_groups_2d}")
        cnn_cfg = dict(cnn_cfg or {"output_channels": (16, 32), "kernel_size": 3, "stride": (1, 2)})
        cnn_cfg.setdefault("activation", activation)
        cnn = CNN(input_dim=tuple(self.obs_dims_2d[0]), input_channels=int(self.obs_channels_2d[0]), **cnn_cfg)
        if cnn.output_channels is not None:
            raise ValueError("the critic's CNN must flatten its output (cnn_cfg flatten=True)")
        self.cnn_latent_dim = cnn_latent_dim
        super().__init__(obs, obs_groups, obs_set, output_dim, hidden_dims, activation, obs_normalization,
                         distribution_cfg, rnn_type, rnn_hidden_dim, rnn_num_layers)
        # conv stack -> flatten -> linear + ELU to the 32-dim u_t (the paper's size; the conv output is 896)
        self.cnn = nn.Sequential(cnn, nn.Linear(int(cnn.output_dim), cnn_latent_dim), nn.ELU())
        self.u_t: torch.Tensor | None = None
        self.s_t: torch.Tensor | None = None

    def get_latent(self, obs: TensorDict, masks: torch.Tensor | None = None,
                   hidden_state: HiddenState = None) -> torch.Tensor:
        s = self.obs_normalizer(torch.cat([obs[g] for g in self.obs_groups], dim=-1))  # [N, 179] | [T, B', 179]
        m_c = self.rnn(s, masks, hidden_state)                    # [1, N, 256] | [T, B, 256] (unpadded by rsl-rl)
        hmap = obs[self.obs_groups_2d[0]]                         # [N, 1, 17, 11] | [T, B', 1, 17, 11]
        if masks is None:
            m_c = m_c.squeeze(0)
        else:  # back to [T, B, ...] before the CNN: no convolutions on padding
            s, hmap = unpad_trajectories(s, masks), unpad_trajectories(hmap, masks)
        u = self.cnn(hmap.flatten(0, -4)).unflatten(0, hmap.shape[:-3])  # [N, 32] | [T, B, 32]
        self.u_t, self.s_t = u, s.detach()
        return torch.cat([m_c, u], dim=-1)                        # z_t [.., 288]

    def sequence(self, obs: TensorDict, h0: torch.Tensor, starts: torch.Tensor | None,
                 states: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """Values over whole environments, obs [T, B]; sets ``u_t`` and ``s_t`` [T, B, ..]. Returns (values
        [T, B, 1], the GRU state after the last step [L, B, H]); ``states``: see :func:`gru_sequence`."""
        s = self.obs_normalizer(torch.cat([obs[g] for g in self.obs_groups], dim=-1))   # [T, B, 179]
        m_c, h_last = gru_sequence(self.rnn.rnn, s, h0, starts, states)                 # [T, B, 256]
        hmap = obs[self.obs_groups_2d[0]]                                               # [T, B, 1, 17, 11]
        u = torch.cat([self.cnn(part) for part in hmap.flatten(0, 1).split(CNN_CHUNK)])
        self.u_t, self.s_t = u.unflatten(0, hmap.shape[:2]), s.detach()
        return self.mlp(torch.cat([m_c, self.u_t], dim=-1)), h_last

    def _get_latent_dim(self) -> int:
        return self.latent_dim + self.cnn_latent_dim

    def as_jit(self) -> nn.Module:
        raise NotImplementedError("only the actor is exported (the critic is a training-time model)")

    def as_onnx(self, verbose: bool = False) -> nn.Module:
        raise NotImplementedError("only the actor is exported (the critic is a training-time model)")

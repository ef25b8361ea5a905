"""The baselines' actors (paper IV-A; issue 13): DreamWaQ's context-aided estimator and DWL's denoising world model,
as rsl-rl 5.5.1 models beside our CRAActor. Critic, rewards, clock and PPO are ours, so a comparison differs in the
actor's representation only.

    DreamWaQ (Nahrendra et al., ICRA 2023)  window of the last H observations -> encoder -> v_hat (3), z ~ N(mu, s);
        decoder([v_hat, z]) -> o_{t+1}; policy MLP on [o_t, v_hat, mu]. Loss: MSE(v_hat, v) + MSE(o_hat, o_{t+1})
        + beta KL(N(mu, s) || N(0, 1)); the estimates enter the policy detached (PPO does not train the estimator).
        With AdaBoot (adaboot.py) the policy reads the true v instead of v_hat where the robot's coin says so.
    DWL (Gu et al., RSS 2024)  the noisy observation -> GRU encoder (our RNN_a) -> latent -> policy MLP; a decoder
        reconstructs the noise-free privileged state s_t from the latent. Loss: MSE(decoder(m_a), s_t); PPO and the
        reconstruction both train the encoder.

Each actor exposes ``representation_loss(batch) -> (loss, logs)`` on the features of its last forward over the
mini-batch; CRAPPO adds ``weight * loss`` to rsl-rl's PPO loss (see ppo.py). Targets come from the batch's
"privileged" group (noise-free, see envs/observations.py) at the slices in ``targets``.
"""

from __future__ import annotations

import copy

import torch
import torch.nn as nn
from tensordict import TensorDict

from rsl_rl.models import MLPModel, RNNModel
from rsl_rl.modules import MLP, EmpiricalNormalization, HiddenState
from rsl_rl.utils import unpad_trajectories

from cra_warp.learning.adaboot import BOOTSTRAP_GROUP
from cra_warp.learning.contrastive import episode_ids


class HistoryMemory(nn.Module):
    """The last ``length`` inputs as a recurrent state behind rsl-rl's RNN interface (forward / reset /
    detach_hidden_state / hidden_state), so rsl-rl's storage saves it every step and replays it at the start of
    each trajectory of a recurrent mini-batch exactly like a GRU state. No such module in rsl-rl 5.5.1.

    State [1, N, (length - 1) * D]: the previous inputs, oldest first; zeros at episode start (as rsl-rl resets a
    GRU state), which for normalised inputs is the mean observation. Output: the window [.., length * D].
    """

    def __init__(self, input_size: int, length: int) -> None:
        super().__init__()
        if length < 2:
            raise ValueError(f"a history needs at least 2 steps, got {length}")
        self.input_size, self.length = input_size, length
        self.state_dim = (length - 1) * input_size
        self.hidden_state: torch.Tensor | None = None

    def forward(self, x: torch.Tensor, masks: torch.Tensor | None = None,
                hidden_state: HiddenState = None) -> torch.Tensor:
        if masks is not None:  # x [T, B', D] padded trajectories, hidden_state [1, B', (H-1) D] at their starts
            if hidden_state is None:
                raise ValueError("HistoryMemory: no saved state passed in the policy update")
            T, B, D = x.shape
            past = hidden_state.reshape(B, self.length - 1, D).transpose(0, 1)    # [H-1, B', D]
            windows = torch.cat([past, x], 0).unfold(0, self.length, 1)           # [T, B', D, H]
            windows = windows.transpose(-1, -2).reshape(T, B, self.length * D)  # oldest first
            return unpad_trajectories(windows, masks)                           # [T, B, H D]
        if self.hidden_state is None:
            self.hidden_state = x.new_zeros(1, x.shape[0], self.state_dim)
        window = torch.cat([self.hidden_state[0], x], -1)                      # [N, H D]
        self.hidden_state = window[:, self.input_size:].unsqueeze(0)
        return window.unsqueeze(0)

    def reset(self, dones: torch.Tensor | None = None, hidden_state: HiddenState = None) -> None:
        if dones is None:
            self.hidden_state = hidden_state
        elif self.hidden_state is not None:
            if hidden_state is not None:
                raise NotImplementedError("resetting done environments to a given state is not supported")
            self.hidden_state[..., dones == 1, :] = 0.0

    def detach_hidden_state(self, dones: torch.Tensor | None = None) -> None:
        if self.hidden_state is not None:  # holds observations only, never a graph; detached for symmetry
            self.hidden_state = self.hidden_state.detach()


def _mse(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a.float() - b.float()).pow(2).mean()


def _unpadded(batch, group: str, where: tuple[int, int]) -> torch.Tensor:
    """``batch.observations[group][..., a:b]`` of a recurrent mini-batch, unpadded to [T, B, b - a]."""
    if batch.masks is None:
        raise ValueError("the baselines' losses need recurrent mini-batches (a time axis)")
    a, b = where
    return unpad_trajectories(batch.observations[group][..., a:b], batch.masks)


class DreamWaQActor(MLPModel):
    """o_{t-H+1..t} (normalised) -> encoder MLP -> [v_hat (3), mu (L), log var (L)]; policy MLP on
    [o_t, v_hat, mu] (estimates detached) -> Gaussian mean; decoder MLP [v_hat, z] -> o_{t+1} for the loss.

    The window is this model's recurrent state (HistoryMemory), so rollouts, recurrent mini-batches, checkpoints and
    the exported graphs (h_in / h_out) treat it as they treat our GRU actor.
    ``targets``: slices of the privileged group: "velocity" (the base velocity, as scaled there) and "observation"
    (the noise-free actor observation). ``adaboot``: where the observation has the "bootstrap" group (training),
    its 0 rows feed the policy that true velocity instead of v_hat; without the group, v_hat (evaluation, export).
    """

    is_recurrent: bool = True

    def __init__(self, obs: TensorDict, obs_groups: dict[str, list[str]], obs_set: str, output_dim: int,
                 hidden_dims=(512, 256, 128), activation: str = "elu", obs_normalization: bool = True,
                 distribution_cfg: dict | None = None, history: int = 5, latent_dim: int = 16,
                 encoder_dims=(128, 64), decoder_dims=(64, 128), beta: float = 1.0,
                 targets: dict | None = None, adaboot: bool = False) -> None:
        self.z_dim = latent_dim
        self._obs_width = sum(obs[g].shape[-1] for g in obs_groups[obs_set])
        super().__init__(obs, obs_groups, obs_set, output_dim, hidden_dims, activation, obs_normalization,
                         distribution_cfg)
        self.memory = HistoryMemory(self.obs_dim, history)
        self.encoder = MLP(history * self.obs_dim, 3 + 2 * latent_dim, list(encoder_dims), activation)
        self.decoder = MLP(3 + latent_dim, self.obs_dim, list(decoder_dims), activation)
        self.beta = beta
        self.targets = {k: tuple(v) for k, v in (targets or {}).items()}
        if adaboot and "velocity" not in self.targets:
            raise ValueError("DreamWaQActor with AdaBoot needs targets['velocity'] (the true velocity it may feed)")
        self.adaboot = adaboot
        self.estimate: tuple[torch.Tensor, torch.Tensor, torch.Tensor] | None = None  # v_hat, mu, log var

    def _get_latent_dim(self) -> int:
        return self._obs_width + 3 + self.z_dim

    def get_latent(self, obs: TensorDict, masks: torch.Tensor | None = None,
                   hidden_state: HiddenState = None) -> torch.Tensor:
        x = self.obs_normalizer(torch.cat([obs[g] for g in self.obs_groups], dim=-1))
        window = self.memory(x, masks, hidden_state)
        if masks is None:
            window = window.squeeze(0)
        v, mu, logvar = self.encoder(window).split([3, self.z_dim, self.z_dim], dim=-1)
        self.estimate = (v, mu, logvar)
        v_fed = v.detach()
        if self.adaboot and BOOTSTRAP_GROUP in obs.keys():
            a, b = self.targets["velocity"]
            truth, coin = obs["privileged"][..., a:b], obs[BOOTSTRAP_GROUP]
            if masks is not None:  # the update's padded trajectories, as the window above
                truth, coin = unpad_trajectories(truth, masks), unpad_trajectories(coin, masks)
            v_fed = torch.where(coin > 0.5, v_fed, truth.to(v_fed.dtype))
        return torch.cat([window[..., -self.obs_dim:], v_fed, mu.detach()], dim=-1)

    def representation_loss(self, batch) -> tuple[torch.Tensor, dict[str, float]]:
        for k in ("velocity", "observation"):
            if k not in self.targets:
                raise ValueError(f"DreamWaQActor needs targets[{k!r}] (a slice of the privileged group)")
        v, mu, logvar = self.estimate                                    # [T, B, ..] of the last forward
        v_true = _unpadded(batch, "privileged", self.targets["velocity"])
        with torch.no_grad():  # o_{t+1}, noise-free, in the policy's normalised units
            nxt = self.obs_normalizer(_unpadded(batch, "privileged", self.targets["observation"]))[1:]
        z = mu + torch.randn_like(mu) * torch.exp(0.5 * logvar)
        recon = self.decoder(torch.cat([v, z], dim=-1))[:-1]
        episodes = episode_ids(batch.masks)
        same = episodes[:-1] == episodes[1:]                             # t and t + 1 in one episode
        vel = _mse(v, v_true)
        rec = _mse(recon[same], nxt[same])
        kl = (-0.5 * (1 + logvar.float() - mu.float().pow(2) - logvar.float().exp())).mean()  # per latent dim
        loss = vel + rec + self.beta * kl
        return loss, {"estimator_velocity": vel.item(), "estimator_reconstruction": rec.item(),
                      "estimator_kl": kl.item()}

    def get_hidden_state(self) -> HiddenState:
        return self.memory.hidden_state

    def reset(self, dones: torch.Tensor | None = None, hidden_state: HiddenState = None) -> None:
        self.memory.reset(dones, hidden_state)

    def detach_hidden_state(self, dones: torch.Tensor | None = None) -> None:
        self.memory.detach_hidden_state(dones)

    @property
    def state_shape(self) -> list[int]:
        """The exported graphs' state (h_in / h_out): the previous H - 1 normalised observations."""
        return [1, 1, self.memory.state_dim]

    def as_jit(self) -> nn.Module:
        return _DreamWaQJit(self)

    def as_onnx(self, verbose: bool = False) -> nn.Module:
        return _DreamWaQOnnx(self)


class _DreamWaQStep(nn.Module):
    """One deterministic control step of a DreamWaQActor: (obs [1, D], state) -> (actions [1, A], new state)."""

    def __init__(self, model: DreamWaQActor) -> None:
        super().__init__()
        self.obs_normalizer = copy.deepcopy(model.obs_normalizer).cpu()
        self.encoder = copy.deepcopy(model.encoder).cpu()
        self.mlp = copy.deepcopy(model.mlp).cpu()
        self.deterministic_output = model.distribution.as_deterministic_output_module()
        self.obs_dim, self.z_dim, self.state_dim = model.obs_dim, model.z_dim, model.memory.state_dim

    def step(self, obs: torch.Tensor, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = self.obs_normalizer(obs)
        window = torch.cat([state[0], x], dim=-1)
        e = self.encoder(window)
        latent = torch.cat([x, e[:, :3 + self.z_dim]], dim=-1)          # o_t, v_hat, mu
        return self.deterministic_output(self.mlp(latent)), window[:, self.obs_dim:].unsqueeze(0)


class _DreamWaQJit(_DreamWaQStep):
    def __init__(self, model: DreamWaQActor) -> None:
        super().__init__(model)
        self.register_buffer("hidden_state", torch.zeros(1, 1, self.state_dim))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out, h = self.step(x, self.hidden_state)
        self.hidden_state[:] = h
        return out

    @torch.jit.export
    def reset(self) -> None:
        self.hidden_state[:] = 0.0


class _DreamWaQOnnx(_DreamWaQStep):
    is_recurrent: bool = True
    input_names = ["obs", "h_in"]
    output_names = ["actions", "h_out"]

    def forward(self, obs: torch.Tensor, h_in: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.step(obs, h_in)

    def get_dummy_inputs(self) -> tuple[torch.Tensor, torch.Tensor]:
        return torch.zeros(1, self.obs_dim), torch.zeros(1, 1, self.state_dim)


class DWLActor(RNNModel):
    """o_t (noisy) -> GRU (256) -> Linear 256 -> ELU -> Linear -> z (24) -> policy MLP (48) -> Gaussian mean (DWL's
    Table VI sizes); decoder z -> 64 -> the noise-free privileged state and the height map (DWL's s_t holds its
    height scan), normalised by their own running statistics so every part weighs alike in the MSE.

    The z projection is the front of ``self.mlp``, so rsl-rl's exported GRU graphs carry it unchanged.
    """

    def __init__(self, obs: TensorDict, obs_groups: dict[str, list[str]], obs_set: str, output_dim: int,
                 hidden_dims=(48,), activation: str = "elu", obs_normalization: bool = True,
                 distribution_cfg: dict | None = None, rnn_type: str = "gru", rnn_hidden_dim: int = 256,
                 rnn_num_layers: int = 1, encoder_dims=(256,), latent_dim: int = 24, decoder_dims=(64,),
                 latent_l1: float = 0.002, targets: tuple[str, ...] = ("privileged", "height_map")) -> None:
        self.z_dim = latent_dim
        super().__init__(obs, obs_groups, obs_set, output_dim, hidden_dims, activation, obs_normalization,
                         distribution_cfg, rnn_type, rnn_hidden_dim, rnn_num_layers)
        head = MLP(rnn_hidden_dim, latent_dim, list(encoder_dims), activation)  # GRU output -> z, linear last
        self.z_layers = len(head)
        self.mlp = nn.Sequential(*head, *self.mlp)
        self.targets = tuple(targets)
        width = sum(obs[g][0].numel() for g in self.targets)
        self.decoder = MLP(latent_dim, width, list(decoder_dims), activation)
        self.target_normalizer = EmpiricalNormalization(width)
        self.latent_l1 = latent_l1
        self.latent: torch.Tensor | None = None  # GRU output of the last forward

    def _get_latent_dim(self) -> int:  # the policy MLP built by rsl-rl reads z, not the GRU output
        return self.z_dim

    def get_latent(self, obs: TensorDict, masks: torch.Tensor | None = None,
                   hidden_state: HiddenState = None) -> torch.Tensor:
        self.latent = super().get_latent(obs, masks, hidden_state)
        return self.latent

    def _target(self, obs: TensorDict) -> torch.Tensor:
        return torch.cat([obs[g].flatten(obs.batch_dims) for g in self.targets], dim=-1)

    def representation_loss(self, batch) -> tuple[torch.Tensor, dict[str, float]]:
        if batch.masks is None:
            raise ValueError("the baselines' losses need recurrent mini-batches (a time axis)")
        with torch.no_grad():
            target = self.target_normalizer(unpad_trajectories(self._target(batch.observations), batch.masks))
        z = self.mlp[:self.z_layers](self.latent)
        rec = _mse(self.decoder(z), target)
        l1 = z.float().abs().sum(-1).mean()                             # ||z||_1 per sample
        return rec + self.latent_l1 * l1, {"world_model_reconstruction": rec.item(), "world_model_latent_l1": l1.item()}

    def update_normalization(self, obs: TensorDict) -> None:
        super().update_normalization(obs)
        self.target_normalizer.update(self._target(obs))

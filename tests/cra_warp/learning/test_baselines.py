"""The baselines' actors (DreamWaQ, DWL): the history window replays in the update as it ran in the rollout, each
estimator learns what it is for, PPO does not train DreamWaQ's estimator, and the exported graphs act as the model."""

from __future__ import annotations

import json

import pytest
import torch
from rsl_rl.runners import OnPolicyRunner
from tensordict import TensorDict

from cra_warp.learning import export_policy
from cra_warp.learning.bench import DummyEnv, collect
from cra_warp.learning.config import (ActorConfig, ContrastConfig, DWLConfig, LearnerConfig, PPOConfig,
                                      runner_cfg)
from tests.cra_warp.learning.helpers import fake_metadata, rollout_actions

STEPS = 8
SLICES = {"velocity": (0, 3), "observation": (95, 179)}  # DummyEnv's privileged group has 179 entries


class EchoEnv(DummyEnv):
    """Privileged state that observations explain: its first 3 entries (the "velocity" target) are the first 3 actor
    inputs of the step before (0 on an episode's first step), so only a model that remembers the previous
    observation predicts them; the rest is a fixed function of 8 directions of the current observation (DWL's
    24-dim latent can carry them); the height map is flat."""

    def _sample(self) -> TensorDict:
        prev = getattr(self, "obs", None)
        obs = super()._sample()
        if not hasattr(self, "mix"):
            d_o, d_p = obs["policy"].shape[-1], obs["privileged"].shape[-1]
            self.mix = torch.randn(d_o, 8, generator=self.gen) @ torch.randn(8, d_p - 3, generator=self.gen)
        obs["privileged"][:, 3:] = torch.tanh(obs["policy"] @ self.mix / 25.0)
        obs["privileged"][:, :3] = 0.0
        if prev is not None:
            fresh = self.episode_length_buf == 0
            obs["privileged"][~fresh, :3] = prev["policy"][~fresh, :3]
        obs["height_map"].zero_()
        return obs


def make(kind: str, num_envs=8, mini_batches=2, env=None, seed=0, ppo=None, dwl=None, **env_kw):
    torch.manual_seed(seed)
    cfg = LearnerConfig(num_steps_per_env=STEPS, contrast=ContrastConfig(variant="none"),
                        ppo=PPOConfig(num_learning_epochs=2, num_mini_batches=mini_batches, **(ppo or {})),
                        actor=ActorConfig(kind=kind), privileged_slices=SLICES, dwl=DWLConfig(**(dwl or {})))
    env = env or DummyEnv(num_envs, seed=seed, **env_kw)
    return OnPolicyRunner(env, runner_cfg(cfg), log_dir=None, device="cpu"), env


def test_history_window_replays_in_the_update():
    """DreamWaQ's estimates of the padded mini-batch forward are the rollout's, row for row, and the window holds
    the episode's previous observations (zeros before its start)."""
    runner, env = make("dreamwaq", num_envs=6, mini_batches=1, done_prob=0.25)
    alg = runner.alg
    rec, windows, act = [], [], alg.act

    def recording_act(obs):
        state = alg.actor.get_hidden_state()
        windows.append(None if state is None else state.clone())
        a = act(obs)
        rec.append(torch.cat(alg.actor.estimate, -1).clone())
        return a

    alg.act = recording_act
    collect(alg, env, STEPS)
    assert alg.storage.dones.sum() >= 2
    batch = next(alg.storage.recurrent_mini_batch_generator(1, 1))
    assert batch.masks.shape[1] > env.num_envs                       # padded: several trajectories per env
    with torch.no_grad():
        alg.actor(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[0])
    torch.testing.assert_close(torch.cat(alg.actor.estimate, -1), torch.stack(rec), atol=1e-5, rtol=0)

    D, dones = 84, alg.storage.dones.squeeze(-1).bool()              # [T, N]
    norm = alg.actor.obs_normalizer
    for t in range(1, STEPS):                                        # newest slot of the state = o_{t-1}
        newest = windows[t][0, :, -D:]
        expected = torch.where(dones[t - 1].unsqueeze(-1), 0.0, norm(alg.storage.observations["policy"][t - 1]))
        torch.testing.assert_close(newest, expected, atol=1e-6, rtol=0)


@pytest.mark.slow
def test_dreamwaq_estimator_uses_the_history():
    """Trained on EchoEnv, the velocity estimate learns a target that only the previous step's observation
    explains; PPO's own loss sends no gradient into the estimator (its outputs enter the policy detached)."""
    runner, env = make("dreamwaq", num_envs=16, env=EchoEnv(16, seed=1, done_prob=0.02),
                       ppo={"schedule": "fixed", "learning_rate": 2e-3})  # no KL to adapt to on random data
    alg = runner.alg
    losses = []
    for _ in range(30):
        collect(alg, env, STEPS)
        losses.append(alg.update()["estimator_velocity"])
    # a model without the previous observation cannot do better than the target's variance
    floor = alg.storage.observations["privileged"][..., :3].var().item()
    assert floor > 0.8 and sum(losses[-5:]) / 5 < 0.5 * floor, (floor, losses[::5])

    batch = next(alg.storage.recurrent_mini_batch_generator(2, 1))
    alg.actor(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[0], stochastic_output=True)
    alg.actor.zero_grad()
    alg.actor.get_output_log_prob(batch.actions).mean().backward(retain_graph=True)
    assert all(p.grad is None or not p.grad.any() for p in alg.actor.encoder.parameters())
    assert any(p.grad is not None and p.grad.any() for p in alg.actor.mlp.parameters())
    alg.actor.representation_loss(batch)[0].backward()
    assert all(p.grad is not None and p.grad.any() for p in alg.actor.encoder.parameters())


@pytest.mark.slow
def test_dwl_world_model_trains_the_shared_encoder():
    """DWL's reconstruction loss reaches the GRU encoder and the decoder, not the critic; an update lowers it."""
    # on random rewards PPO's gradient is noise that shares the actor's norm clip: a larger weight than DWL's 0.2
    runner, env = make("dwl", env=EchoEnv(8, seed=2, done_prob=0.05), ppo={"schedule": "fixed", "learning_rate": 2e-3},
                       dwl={"weight": 5.0})
    alg = runner.alg
    collect(alg, env, STEPS)
    batch = next(alg.storage.recurrent_mini_batch_generator(2, 1))
    alg.actor(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[0])
    alg.critic(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[1])
    alg.optimizer.zero_grad()
    loss, logs = alg.actor.representation_loss(batch)
    loss.backward()
    assert set(logs) == {"world_model_reconstruction", "world_model_latent_l1"}
    assert alg.actor.rnn.rnn.weight_ih_l0.grad.any() and all(p.grad.any() for p in alg.actor.decoder.parameters())
    assert all(p.grad is None or not p.grad.any() for p in alg.critic.parameters())
    losses = [alg.update()["world_model_reconstruction"]]
    for _ in range(30):
        collect(alg, env, STEPS)
        losses.append(alg.update()["world_model_reconstruction"])
    # losses[0] is before the target normaliser has statistics (it updates after the first update)
    assert sum(losses[-3:]) / 3 < 0.5 * losses[1], losses[::3]


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["dreamwaq", "dwl"])
def test_baseline_export_parity(tmp_path, kind):
    """TorchScript and ONNX (obs, h_in) -> (actions, h_out) give the model's rollout actions; the JSON names the
    state's shape (and DreamWaQ's history length)."""
    ort = pytest.importorskip("onnxruntime")
    runner, env = make(kind)
    collect(runner.alg, env, STEPS)
    runner.alg.update()
    actor = runner.alg.get_policy()
    paths = export_policy(runner, tmp_path, fake_metadata())
    obs_seq = torch.randn(10, 1, 84, generator=torch.Generator().manual_seed(3)) * 2
    ref = rollout_actions(actor, obs_seq)

    jit = torch.jit.load(str(paths["torchscript"]))
    jit.reset()
    with torch.no_grad():
        torch.testing.assert_close(torch.stack([jit(o) for o in obs_seq]), ref, atol=1e-5, rtol=0)
    doc = json.loads(paths["json"].read_text())
    shape = doc["network"]["hidden_state_shape"]
    assert shape == ([1, 1, 4 * 84] if kind == "dreamwaq" else [1, 1, 256])
    if kind == "dreamwaq":
        assert doc["network"]["history"] == 5
    sess = ort.InferenceSession(str(paths["onnx"]))
    h, out = torch.zeros(shape).numpy(), []
    for o in obs_seq:
        a, h = sess.run(["actions", "h_out"], {"obs": o.numpy(), "h_in": h})
        out.append(torch.from_numpy(a))
    torch.testing.assert_close(torch.stack(out), ref, atol=1e-5, rtol=0)


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["dreamwaq", "dwl", "dreamwaq_clock_free", "dwl_fixed_cycle"])
def test_baseline_trains_exports_and_runs_from_its_export(tmp_path, variant, capsys):
    """cra-train --variant <baseline>: 2 iterations on the task (the papers' pairings on their clocks, DreamWaQ's
    with AdaBoot), its export driven by the numpy deploy module from the JSON's inputs alone, and cra-play
    rebuilding the run from its checkpoint."""
    import numpy as np

    from cra_warp.deploy import DeployPolicy
    from envs.methods import METHODS
    from train import play as play_cli
    from train import train as train_cli

    args = ["--variant", variant, "--num-envs", "4", "--max-iterations", "2", "--save-interval", "1",
            "--sim", "mujoco", "--log-dir", str(tmp_path), "--quiet"]
    assert train_cli.main(args) == 0
    run = next(tmp_path.iterdir())
    saved = torch.load(run / "model_1.pt", weights_only=False)
    method = METHODS[variant]
    assert saved["infos"]["config"]["learner"]["actor"]["kind"] == method.actor_kind
    assert ("adaboot_state" in saved) == (variant == "dreamwaq_clock_free")
    policy = DeployPolicy(run / "exported")
    spec = policy.spec
    assert spec["variant"] == method.clock_mode and spec["network"]["recurrent"]
    J = policy.num_joints
    jit = torch.jit.load(str(run / "exported" / "policy.pt"))
    jit.reset()
    for k in range(5):
        obs = policy.observe([0.5, 0.0, 0.0], [0.0, 0.0, -1.0], policy.default_q + 0.01 * k, np.zeros(J),
                             [0.0, 0.0, 0.1])
        actions = policy.act(obs)
        with torch.no_grad():
            ref = policy.clip(jit(torch.from_numpy(obs).unsqueeze(0)).numpy().reshape(-1).astype(np.float64))
        np.testing.assert_allclose(actions, ref, atol=1e-5)
        targets = policy.apply(actions)
        assert targets.shape == (J,) and np.isfinite(targets).all()
    assert play_cli.main([str(run / "model_1.pt"), "--num-envs", "2", "--steps", "10"]) == 0
    assert "vel_tracking_rmse" in capsys.readouterr().out

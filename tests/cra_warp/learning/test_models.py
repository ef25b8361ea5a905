"""The actor and critic (cra_warp/learning/models.py): shapes, the padded mini-batch forward against the rollout, and
gru_sequence against the GRU stepped with restarts."""

from __future__ import annotations

import pytest
import torch

from cra_warp.learning.bench import collect
from cra_warp.learning.models import gru_sequence
from tests.cra_warp.learning.helpers import STEPS, make_runner


@pytest.mark.parametrize("num_obs,num_actions", [(84, 26), (79, 23)])  # ours / clock-free
def test_model_shapes(num_obs, num_actions):
    runner, env = make_runner(num_envs=4, num_obs=num_obs, num_actions=num_actions)
    actor, critic = runner.alg.actor, runner.alg.critic
    obs = env.get_observations()
    assert actor(obs).shape == (4, num_actions)
    assert actor.latent.shape == (4, 256) and isinstance(actor.rnn.rnn, torch.nn.GRU)
    assert critic(obs).shape == (4, 1)
    assert critic.get_latent(obs).shape == (4, 288)           # z_t = [m_c (256), u_t (32)]
    assert critic.mlp[0].in_features == 288
    assert critic.u_t.shape == (4, 32) and critic.s_t.shape == (4, 179)
    assert critic.obs_groups == ["privileged"] and critic.obs_groups_2d == ["height_map"]


def test_batched_features_match_rollout():
    """m_a, u_t, s_t of the padded mini-batch forward are the rollout's, row for row ([T, B] = step x env)."""
    runner, env = make_runner(num_envs=6, mini_batches=1, done_prob=0.25, batched_values=False)
    alg = runner.alg
    rec = {"m": [], "u": [], "s": []}
    act = alg.act

    def recording_act(obs):
        a = act(obs)
        rec["m"].append(alg.actor.latent.clone())
        rec["u"].append(alg.critic.u_t.clone())
        rec["s"].append(alg.critic.s_t.clone())
        return a

    alg.act = recording_act
    collect(alg, env, STEPS)
    assert alg.storage.dones.sum() >= 2  # several trajectories per env
    batch = next(alg.storage.recurrent_mini_batch_generator(1, 1))
    assert batch.masks.shape[1] > env.num_envs                      # padded: more trajectories than envs
    with torch.no_grad():
        alg.actor(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[0])
        alg.critic(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[1])
    torch.testing.assert_close(alg.actor.latent, torch.stack(rec["m"]), atol=1e-5, rtol=0)
    torch.testing.assert_close(alg.critic.u_t, torch.stack(rec["u"]), atol=1e-5, rtol=0)
    torch.testing.assert_close(alg.critic.s_t, torch.stack(rec["s"]), atol=1e-6, rtol=0)


@pytest.mark.parametrize("layers", [1, 2])
def test_gru_sequence_is_the_gru_stepped_with_restarts(layers):
    torch.manual_seed(0)
    T, B, D, H = 9, 5, 7, 16
    gru = torch.nn.GRU(D, H, layers)
    x, h0 = torch.randn(T, B, D), torch.randn(layers, B, H)
    starts = torch.rand(T, B) < 0.3
    starts[0] = False
    ref, h = [], h0
    with torch.no_grad():
        for t in range(T):
            h = h * (~starts[t]).float().unsqueeze(-1)
            out, h = gru(x[t:t + 1], h)
            ref.append(out[0])
        states = torch.zeros(T, layers, B, H)
        out, h_last = gru_sequence(gru, x, h0, starts, states)
    torch.testing.assert_close(out, torch.stack(ref), atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(h_last, h, atol=1e-5, rtol=1e-5)
    assert torch.all(states[starts.nonzero(as_tuple=True)[0], :, starts.nonzero(as_tuple=True)[1]] == 0)
    with torch.no_grad():  # no restarts: exactly nn.GRU over the sequence
        torch.testing.assert_close(gru_sequence(gru, x, h0)[0], gru(x, h0)[0], atol=1e-5, rtol=1e-5)

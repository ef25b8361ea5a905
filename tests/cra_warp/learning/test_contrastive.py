"""The contrastive module (cra_warp/learning/contrastive.py): InfoNCE by hand, the pairs it draws, the stop-gradient
into the critic and the target without the actor observation."""

from __future__ import annotations

import math

import pytest
import torch

from rsl_rl.utils import split_and_pad_trajectories

from cra_warp.learning.bench import collect
from cra_warp.learning.contrastive import contrast_pairs, episode_ids, info_nce
from tests.cra_warp.learning.helpers import STEPS, make_runner


def test_stop_gradient():
    """InfoNCE gives exactly zero gradient to the critic (CNN, RNN, head), non-zero to actor RNN and both heads."""
    runner, env = make_runner(mini_batches=2, done_prob=0.1)
    alg = runner.alg
    collect(alg, env, STEPS)
    batch = next(alg.storage.recurrent_mini_batch_generator(2, 1))
    alg.actor(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[0], stochastic_output=True)
    alg.critic(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[1])
    alg.optimizer.zero_grad()
    loss, acc, k = alg.contrastive_loss(batch.masks)
    assert k == STEPS * env.num_envs // 2
    loss.backward()
    for name, p in alg.critic.named_parameters():
        assert p.grad is None or torch.count_nonzero(p.grad) == 0, name
    assert any(True for n, _ in alg.critic.named_parameters() if n.startswith("cnn."))
    for name in ("weight_ih_l0", "weight_hh_l0"):
        assert torch.count_nonzero(getattr(alg.actor.rnn.rnn, name).grad) > 0
    for head in (alg.heads.source, alg.heads.target):
        assert all(torch.count_nonzero(p.grad) > 0 for p in head.parameters())


def test_contrast_target_without_the_actor_observation():
    """target_actor_obs=False: MLP_T sees s_t without the actor observation's columns, so the InfoNCE loss does
    not move when only those change, and moves when any other privileged column does."""
    actor_cols = (95, 179)  # where cra-train's layout puts the noise-free actor observation (last)
    runner, env = make_runner(privileged_slices={"observation": actor_cols})  # the default target
    alg = runner.alg
    assert alg.heads.target[0].in_features == 32 + 179 - 84  # u_t + s_t without the 84 actor columns
    collect(alg, env, STEPS)
    batch = next(alg.storage.recurrent_mini_batch_generator(2, 1))
    alg.actor(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[0])
    alg.critic(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[1])
    base = alg.contrastive_loss(batch.masks)[0].item()
    s = alg.critic.s_t
    alg.critic.s_t = s.clone()
    alg.critic.s_t[..., actor_cols[0]:] = torch.randn_like(s[..., actor_cols[0]:])
    assert alg.contrastive_loss(batch.masks)[0].item() == pytest.approx(base, abs=1e-6)
    alg.critic.s_t[..., :3] += 1.0  # base velocity: still part of the target
    assert abs(alg.contrastive_loss(batch.masks)[0].item() - base) > 1e-4
    with pytest.raises(ValueError, match="target_actor_obs=False needs"):
        make_runner(privileged_slices={})


@pytest.mark.parametrize("normalize", [False, True])
def test_info_nce_by_hand(normalize):
    i_s = torch.tensor([[1.0, 0.0], [0.5, 0.5], [-1.0, 2.0]])
    i_t = torch.tensor([[0.8, 0.1], [0.2, 0.9], [-0.5, 1.0]])
    tau = 0.5
    s, t = i_s.tolist(), i_t.tolist()
    if normalize:
        s = [[x / math.hypot(*r) for x in r] for r in s]
        t = [[x / math.hypot(*r) for x in r] for r in t]
    dot = [[sum(a * b for a, b in zip(s[i], t[j])) / tau for j in range(3)] for i in range(3)]
    expected = -sum(dot[i][i] - math.log(sum(math.exp(d) for d in dot[i])) for i in range(3)) / 3
    expected_acc = sum(max(range(3), key=lambda j: dot[i][j]) == i for i in range(3)) / 3
    loss, acc = info_nce(i_s, i_t, tau, normalize=normalize)
    assert loss.item() == pytest.approx(expected, rel=1e-6)
    assert acc.item() == pytest.approx(expected_acc)


def test_sequential_pairs_stay_within_episodes():
    T, B = 5, 3
    dones = torch.zeros(T, B, 1, dtype=torch.uint8)
    dones[1, 0] = 1  # env 0: episode ends at t=1 -> (1, 2) is not a pair
    dones[3, 2] = 1  # env 2: ends at t=3 -> (3, 4) is not a pair
    tb = torch.stack(torch.meshgrid(torch.arange(T), torch.arange(B), indexing="ij"), -1).float()  # [T, B, 2]
    padded, masks = split_and_pad_trajectories(tb, dones)        # as rsl-rl builds recurrent mini-batches
    ep = episode_ids(masks)
    assert ep.shape == (T, B)
    src, u, s = contrast_pairs("sequential", tb, tb, tb + 100, ep)
    pairs = {(int(a[0]), int(a[1]), int(b[0]), int(b[1])) for a, b in zip(src, u)}
    expected = {(t, b, t + 1, b) for t in range(T - 1) for b in range(B)} - {(1, 0, 2, 0), (3, 2, 4, 2)}
    assert pairs == expected and len(src) == (T - 1) * B - 2
    torch.testing.assert_close(s, u + 100)                        # s and u from the same (t + 1, env)
    same, _, _ = contrast_pairs("same_step", tb, tb, tb, ep)
    assert same.shape == (T * B, 2)

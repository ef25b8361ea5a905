"""CRAPPO's CPU path (issue 34) against rsl-rl's: the critic run once over the rollout gives the values the
per-step critic gave, and the whole-environment update gives the padded update's losses and parameters."""

from __future__ import annotations

import copy

import pytest
import torch
from rsl_rl.runners import OnPolicyRunner

from cra_warp.learning import ContrastConfig, LearnerConfig, PPOConfig, runner_cfg
from cra_warp.learning.bench import DummyEnv, collect

STEPS = 12


def make(batched_values: bool, variant="same_step", num_envs=8, seed=0, done_prob=0.2, bf16=False, mini_batches=2):
    torch.manual_seed(seed)
    env = DummyEnv(num_envs, seed=seed, done_prob=done_prob)
    cfg = LearnerConfig(num_steps_per_env=STEPS, privileged_slices=env.privileged_slices,
                        contrast=ContrastConfig(variant=variant),
                        ppo=PPOConfig(num_learning_epochs=2, num_mini_batches=mini_batches, use_mixed_precision=bf16),
                        batched_values=batched_values)
    train_cfg = runner_cfg(cfg)
    return OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu").alg, env


def test_batched_values_are_the_stepped_critics():
    """Two rollouts (the critic's state carries over) on the same env: values, time-out bootstraps, returns,
    advantages and the saved critic states match rsl-rl's per-step critic."""
    stepped, env_a = make(batched_values=False, done_prob=0.25)
    batched, env_b = make(batched_values=True, done_prob=0.25)
    assert batched.batched_values and not stepped.batched_values
    for i in range(2):
        for alg, env in ((stepped, env_a), (batched, env_b)):
            torch.manual_seed(100 + i)  # the same action samples
            collect(alg, env, STEPS)
        a, b = stepped.storage, batched.storage
        assert a.dones.sum() >= 4 and torch.equal(a.actions, b.actions)
        torch.testing.assert_close(b.values, a.values, atol=1e-5, rtol=1e-5)
        torch.testing.assert_close(b.rewards, a.rewards, atol=1e-5, rtol=1e-5)
        torch.testing.assert_close(b.returns, a.returns, atol=1e-4, rtol=1e-5)
        torch.testing.assert_close(b.advantages, a.advantages, atol=1e-4, rtol=1e-5)
        torch.testing.assert_close(b.saved_hidden_state_c[0], a.saved_hidden_state_c[0], atol=1e-5, rtol=1e-5)
        torch.testing.assert_close(batched.critic.get_hidden_state(), stepped.critic.get_hidden_state(),
                                   atol=1e-5, rtol=1e-5)
        a.clear()
        b.clear()


@pytest.mark.parametrize("variant", ["same_step", "sequential", "none"])
def test_whole_env_update_is_the_padded_update(variant):
    """From the same rollout and parameters, one update over whole-env mini-batches ends where rsl-rl's padded
    update ends: the same losses, learning rate and parameters (fp32). Adam divides each gradient by its own
    running size, so an element whose gradient is float noise steps by up to the learning rate either way (seen on
    AVX2 CPUs, whose reductions round differently): at most 0.1% of the elements may differ, each by no more than
    the update moved any element. A wrong update (another rollout) moves ~80% of them."""
    padded, env_a = make(batched_values=False, variant=variant)
    whole, env_b = make(batched_values=False, variant=variant)
    whole.whole_env_update = True
    for alg, env in ((padded, env_a), (whole, env_b)):
        torch.manual_seed(100)
        collect(alg, env, STEPS)
    assert padded.storage.dones[:-1].sum() >= 2  # trajectories split inside the window
    models = [(padded.actor, whole.actor), (padded.critic, whole.critic)]
    if variant != "none":
        models.append((padded.heads, whole.heads))
    start = [copy.deepcopy(ma.state_dict()) for ma, _ in models]
    out_a, out_b = padded.update(), whole.update()
    assert out_a.keys() == out_b.keys()
    for k in out_a:
        assert out_b[k] == pytest.approx(out_a[k], rel=1e-4, abs=1e-5), k
    assert whole.learning_rate == pytest.approx(padded.learning_rate)
    step = max((pa - p0).abs().max().item() for (ma, _), s0 in zip(models, start)
               for pa, p0 in zip(ma.state_dict().values(), s0.values()) if pa.is_floating_point())
    off = total = 0
    for ma, mb in models:
        for (name, pa), pb in zip(ma.state_dict().items(), mb.state_dict().values()):
            diff = (pb - pa).abs()
            off += int((diff > 2e-5 + 1e-4 * pa.abs()).sum())
            total += diff.numel()
            assert diff.max().item() <= 2 * step + 2e-5, name
    assert off <= 1e-3 * total, f"{off} of {total} parameters differ"


def test_whole_env_update_runs_in_bf16_and_moves_every_part():
    alg, env = make(batched_values=True, bf16=True)
    alg.whole_env_update = True
    collect(alg, env, STEPS)
    before = [{k: v.clone() for k, v in m.state_dict().items()} for m in (alg.actor, alg.critic, alg.heads)]
    out = alg.update()
    assert all(torch.isfinite(torch.tensor(v)) for v in out.values())
    for b, m in zip(before, (alg.actor, alg.critic, alg.heads)):
        assert any(not torch.equal(v, m.state_dict()[k]) for k, v in b.items() if v.is_floating_point())

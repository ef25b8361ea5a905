"""DreamWaQ's AdaBoot (cra_warp/learning/adaboot.py): p_boot = 1 - tanh(CV) of the robots' episodic returns is the
probability of feeding the policy the estimates (equal returns: the estimates; spread returns: the truth), each
robot's coin is replayed in the update as it was in collection, and the exported policy reads the estimates only."""

from __future__ import annotations

import math

import pytest
import torch
from rsl_rl.runners import OnPolicyRunner
from tensordict import TensorDict

from cra_warp.learning import export_policy
from cra_warp.learning.adaboot import BOOTSTRAP_GROUP, AdaBoot, bootstrap_probability
from cra_warp.learning.bench import DummyEnv, collect
from cra_warp.learning.config import (ActorConfig, ContrastConfig, DreamWaQConfig, LearnerConfig, PPOConfig,
                                      runner_cfg)
from tests.cra_warp.learning.helpers import fake_metadata, rollout_actions

STEPS = 8
D = 84  # DummyEnv's actor observation: the policy MLP reads [o_t (84), v (3), mu]


def make(num_envs=6, adaboot=True, seed=0, **env_kw):
    torch.manual_seed(seed)
    env = DummyEnv(num_envs, seed=seed, **env_kw)
    cfg = LearnerConfig(num_steps_per_env=STEPS, contrast=ContrastConfig(variant="none"),
                        ppo=PPOConfig(num_learning_epochs=1, num_mini_batches=1), actor=ActorConfig(kind="dreamwaq"),
                        privileged_slices=env.privileged_slices, dreamwaq=DreamWaQConfig(adaboot=adaboot))
    return OnPolicyRunner(env, runner_cfg(cfg), log_dir=None, device="cpu"), env


def test_the_probability_follows_the_rule_in_both_directions():
    equal = torch.full((64,), 120.0)
    assert bootstrap_probability(equal) == pytest.approx(1.0)            # CV 0: always the estimates
    spread = torch.tensor([1.0, 1.0, 1.0, 300.0] * 16)                   # CV ~1.7: mostly the truth
    cv = spread.std(unbiased=False) / spread.mean()
    assert bootstrap_probability(spread) == pytest.approx(1 - math.tanh(cv), rel=1e-6)
    assert bootstrap_probability(spread) < 0.1
    assert bootstrap_probability(torch.tensor([100.0, 110.0, 90.0])) > 0.9  # close returns: mostly estimates
    # no evidence yet (None: keep the probability), not learnt (a mean <= 0: the truth), unfinished robots ignored
    assert bootstrap_probability(torch.tensor([5.0, math.nan, math.nan])) is None
    assert bootstrap_probability(torch.tensor([-3.0, 1.0])) == 0.0
    assert bootstrap_probability(torch.tensor([4.0, 4.0, math.nan])) == pytest.approx(1.0)


def test_the_coins_come_from_the_finished_episodes_returns():
    boot = AdaBoot(4000, "cpu")
    assert boot.probability == 0.0 and not boot.flags.any()              # the truth until returns come in
    done = torch.zeros(4000, dtype=torch.long)
    boot.record(torch.full((4000,), 2.0), done)
    boot.next_rollout()
    assert boot.probability == 0.0                                       # no episode finished: kept
    boot.record(torch.full((4000,), 3.0), torch.ones(4000, dtype=torch.long))
    assert torch.equal(boot.returns, torch.full((4000,), 5.0)) and not boot.running.any()
    logs = boot.next_rollout()
    assert boot.probability == pytest.approx(1.0) and boot.flags.all()   # equal returns: every robot the estimates
    assert logs == {"adaboot_probability": boot.probability, "adaboot_estimates": 1.0}
    # widely spread returns: few robots get the estimates, in proportion p_boot
    spread = torch.where(torch.arange(4000) % 4 == 0, 60.0, 1.0)
    boot.record(spread, torch.ones(4000, dtype=torch.long))
    boot.next_rollout()
    p = 1 - math.tanh(spread.std(unbiased=False) / spread.mean())
    assert boot.probability == pytest.approx(p, rel=1e-6) and p < 0.25
    assert abs(boot.flags.mean().item() - p) < 0.03
    boot.load_state_dict({"probability": 0.0})
    assert boot.probability == 0.0 and not boot.flags.any()


def _recording(alg):
    """Record each act's coins and the velocity the policy read (the 3 entries after o_t in its MLP's input)."""
    actor, coins, fed, act, latent = alg.actor, [], [], alg.act, alg.actor.get_latent

    def recording_latent(obs, masks=None, hidden_state=None):
        out = latent(obs, masks, hidden_state)
        fed.append(out[..., D:D + 3].clone())
        return out

    def recording_act(obs):
        coins.append(alg.adaboot.flags.clone())
        return act(obs)

    actor.get_latent, alg.act = recording_latent, recording_act
    return coins, fed


def test_the_update_replays_each_robots_coin_as_collected():
    runner, env = make(done_prob=0.25)
    alg = runner.alg
    assert BOOTSTRAP_GROUP in alg.storage.observations.keys()
    alg.adaboot.flags = torch.tensor([[1.0], [0.0], [1.0], [0.0], [0.0], [1.0]])   # both kinds in one rollout
    coins, fed = _recording(alg)
    collect(alg, env, STEPS)
    assert alg.storage.dones.sum() >= 2                                  # trajectories split inside the rollout
    st = alg.storage
    torch.testing.assert_close(st.observations[BOOTSTRAP_GROUP], torch.stack(coins))
    fed_rollout = torch.stack(fed)                                       # [T, N, 3]
    truth = st.observations["privileged"][..., 0:3]
    rows = torch.stack(coins)[..., 0] > 0.5                              # [T, N]
    torch.testing.assert_close(fed_rollout[~rows], truth[~rows])        # coin 0: the policy read the truth
    assert not torch.allclose(fed_rollout[rows], truth[rows])            # coin 1: its estimates

    batch = next(st.recurrent_mini_batch_generator(1, 1))
    assert batch.masks.shape[1] > env.num_envs                           # padded: several trajectories per env
    fed.clear()
    with torch.no_grad():
        alg.actor(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[0])
    torch.testing.assert_close(fed[0], fed_rollout, atol=1e-5, rtol=0)   # the update reads what collection read
    estimates = alg.actor.estimate[0]
    torch.testing.assert_close(fed[0][rows], estimates[rows], atol=1e-5, rtol=0)
    assert "adaboot_probability" in alg.update()


def test_the_exported_policy_reads_the_estimates(tmp_path):
    runner, env = make()
    alg = runner.alg
    collect(alg, env, STEPS)                                             # p_boot 0: every robot fed the truth
    alg.update()
    actor = alg.get_policy()
    paths = export_policy(runner, tmp_path, fake_metadata(), onnx=False)
    g = torch.Generator().manual_seed(3)
    obs_seq = torch.randn(10, 1, D, generator=g) * 2
    estimates = rollout_actions(actor, obs_seq)                          # no coin group: the estimates
    jit = torch.jit.load(str(paths["torchscript"]))
    jit.reset()
    with torch.no_grad():
        torch.testing.assert_close(torch.stack([jit(o) for o in obs_seq]), estimates, atol=1e-5, rtol=0)

    def with_coin(coin: float) -> torch.Tensor:                          # the same observations, a coin fed to it
        privileged = torch.randn(1, 179, generator=torch.Generator().manual_seed(4)) * 5
        actor.reset()
        with torch.no_grad():
            return torch.stack([actor(TensorDict({"policy": o, "privileged": privileged,
                                                  BOOTSTRAP_GROUP: torch.full((1, 1), coin)}, batch_size=[1]))
                                for o in obs_seq])

    torch.testing.assert_close(with_coin(1.0), estimates)
    assert not torch.allclose(with_coin(0.0), estimates, atol=1e-3)


def test_a_resume_keeps_the_probability_and_plain_dreamwaq_has_no_coins():
    runner, _ = make()
    runner.alg.adaboot.probability = 0.7
    saved = runner.alg.save()
    assert saved["adaboot_state"] == {"probability": 0.7}
    again, _ = make(seed=1)
    again.alg.load(saved, None, strict=True)
    assert again.alg.adaboot.probability == 0.7
    plain, env = make(adaboot=False)
    assert plain.alg.adaboot is None and BOOTSTRAP_GROUP not in plain.alg.storage.observations.keys()
    collect(plain.alg, env, STEPS)
    assert not any(k.startswith("adaboot") for k in plain.alg.update())
    assert "adaboot_state" not in plain.alg.save()

"""The PPO subclass (cra_warp/learning/ppo.py): the update with each contrast variant, the critic warm-up, the
contrast's sample cap, the mirror term. Small sizes on a dummy env (the learner does not care where observations come
from)."""

from __future__ import annotations

import copy
import math

import pytest
import torch

from cra_warp.learning import load_checkpoint
from cra_warp.learning.bench import collect
from tests.cra_warp.learning.helpers import STEPS, make_runner


@pytest.mark.parametrize("variant", ["same_step", "sequential", "none"])
def test_ppo_update_variants(variant):
    runner, env = make_runner(variant)
    alg = runner.alg
    collect(alg, env, STEPS)
    heads0 = copy.deepcopy(alg.heads.state_dict()) if alg.heads is not None else None
    out = alg.update()
    assert {"value", "surrogate", "entropy"} <= out.keys() and "symmetry" not in out
    keys = {"infonce", "infonce_acc", "infonce_chance"}
    if variant == "none":
        assert alg.heads is None and not keys & out.keys() and len(alg.optimizer.param_groups) == 1
        return
    assert keys <= out.keys() and all(math.isfinite(out[k]) for k in keys)
    assert 0.0 <= out["infonce_acc"] <= 1.0
    k = STEPS * env.num_envs // 2 if variant == "same_step" else None
    if k:
        assert out["infonce_chance"] == pytest.approx(1 / k)
    assert len(alg.optimizer.param_groups) == 2
    assert all(g["lr"] == alg.learning_rate for g in alg.optimizer.param_groups)  # heads follow the KL schedule
    assert any(not torch.equal(v, alg.heads.state_dict()[n]) for n, v in heads0.items())


def test_critic_warmup_holds_the_actor(tmp_path):
    """The first updates train critic and heads only, at a fixed learning rate; the next one moves the actor. A
    resume continues the warm-up, a fork (actor and critic loaded, no optimizer) starts its own. The warm-up fits
    the critic at its own rate without PPO's value clip."""
    runner, env = make_runner(critic_warmup=2, critic_warmup_learning_rate=5e-3)
    alg = runner.alg
    lr0 = alg.learning_rate

    def snapshot():
        return [copy.deepcopy(m.state_dict()) for m in (alg.actor, alg.critic, alg.heads)]

    def moved(before):
        return [any(not torch.equal(v, m.state_dict()[n]) for n, v in b.items())
                for b, m in zip(before, (alg.actor, alg.critic, alg.heads))]

    seen = []  # (rate, value clip) each mini-batch step of the warm-up sees
    step = alg.optimizer.step
    alg.optimizer.step = lambda *a, **k: (seen.append((alg.optimizer.param_groups[0]["lr"],
                                                        alg.use_clipped_value_loss)), step(*a, **k))[1]
    for left in (1, 0):
        collect(alg, env, STEPS)
        before = snapshot()
        alg.update()
        assert moved(before) == [False, True, True] and alg.critic_warmup_left == left
        assert set(seen) == {(5e-3, False)} and alg.use_clipped_value_loss  # its own rate, unclipped, restored
        assert alg.learning_rate == lr0 and all(g["lr"] == lr0 for g in alg.optimizer.param_groups)
        assert all(p.requires_grad for p in alg.actor.parameters())
    collect(alg, env, STEPS)
    before = snapshot()
    alg.update()
    assert moved(before) == [True, True, True]

    mid, env2 = make_runner(critic_warmup=3)
    collect(mid.alg, env2, STEPS)
    mid.alg.update()
    mid.save(str(tmp_path / "mid.pt"))
    resumed, _ = make_runner(critic_warmup=3)
    load_checkpoint(tmp_path / "mid.pt", resumed)
    forked, _ = make_runner(critic_warmup=3)
    load_checkpoint(tmp_path / "mid.pt", forked, load_cfg={"actor": True, "critic": True})
    assert (resumed.alg.critic_warmup_left, forked.alg.critic_warmup_left) == (2, 3)
    with pytest.raises(ValueError, match="critic_warmup must be >= 0"):
        make_runner(critic_warmup=-1)
    plain, env3 = make_runner(critic_warmup=1)  # no rate of its own: the run's rate, the value clip kept
    seen.clear()
    step3 = plain.alg.optimizer.step
    plain.alg.optimizer.step = lambda *a, **k: (seen.append((plain.alg.optimizer.param_groups[0]["lr"],
                                                              plain.alg.use_clipped_value_loss)), step3(*a, **k))[1]
    collect(plain.alg, env3, STEPS)
    plain.alg.update()
    assert set(seen) == {(plain.alg.learning_rate, True)}
    with pytest.raises(ValueError, match="critic_warmup_learning_rate must be > 0"):
        make_runner(critic_warmup=1, critic_warmup_learning_rate=0.0)


def test_contrast_sample_cap():
    """Above max_samples the InfoNCE term uses a random subset: chance level 1 / max_samples."""
    runner, env = make_runner(max_samples=10)
    collect(runner.alg, env, STEPS)
    out = runner.alg.update()
    assert out["infonce_chance"] == pytest.approx(1 / 10)


@pytest.mark.parametrize("whole_envs", [False, True])
def test_ppo_logs_and_trains_the_mirror_term(whole_envs):
    from rsl_rl.runners import OnPolicyRunner

    from cra_warp.learning import ContrastConfig, LearnerConfig, PPOConfig, runner_cfg
    from cra_warp.learning.bench import DummyEnv, collect

    torch.manual_seed(0)
    env = DummyEnv(8, seed=0)
    swap = list(range(84))
    swap[3], swap[4] = 4, 3
    acts = list(range(26))
    acts[0], acts[1] = 1, 0
    cfg = LearnerConfig(num_steps_per_env=8, privileged_slices=env.privileged_slices, symmetry_weight=0.5,
                        contrast=ContrastConfig(variant="same_step"), ppo=PPOConfig(num_mini_batches=2))
    train_cfg = runner_cfg(cfg)
    train_cfg["algorithm"] |= {"mirror": {"obs": (swap, [1.0] * 84), "actions": (acts, [1.0] * 26)},
                               "whole_env_update": whole_envs}
    alg = OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu").alg
    collect(alg, env, 8)
    out = alg.update()
    assert out["mirror"] > 0 and "infonce" in out   # logged beside the contrast, which still reads m_a
    train_cfg["algorithm"].pop("mirror")
    with pytest.raises(ValueError, match="mirror maps"):
        OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu")


def test_action_bound_loss_pulls_a_drifted_mean_back_inside_the_clip():
    """A gait action mean past the env's clip of +-1 gets a loss that brings it back; without the weight nothing
    pulls it (the clipped action is all the env sees); a missing bound per action is refused."""
    from rsl_rl.runners import OnPolicyRunner

    from cra_warp.learning import ContrastConfig, LearnerConfig, PPOConfig, runner_cfg
    from cra_warp.learning.bench import DummyEnv, collect

    def gait_mean_after(weight: float, updates: int = 8) -> tuple[float, float, dict]:
        torch.manual_seed(0)
        env = DummyEnv(8, seed=0)
        cfg = LearnerConfig(num_steps_per_env=8, privileged_slices=env.privileged_slices, action_bound_weight=weight,
                            contrast=ContrastConfig(variant="none"), ppo=PPOConfig(num_mini_batches=2))
        train_cfg = runner_cfg(cfg)
        train_cfg["algorithm"]["action_bounds"] = [10.0] * 23 + [1.0] * 3
        alg = OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu").alg
        with torch.no_grad():
            alg.actor.mlp[-1].bias[-3:] = 3.0               # the rate and offsets' means far past the clip
        obs = env.get_observations()
        before = alg.actor(obs)[:, -3:].mean().item()       # the deterministic output: the mean
        out = {}
        for _ in range(updates):
            collect(alg, env, 8)
            out = alg.update()
        alg.actor.reset()
        return before, alg.actor(obs)[:, -3:].mean().item(), out

    before, bounded, out = gait_mean_after(1.0)
    _, free, out_free = gait_mean_after(0.0)
    assert before > 2.5 and out["action_bound"] > 0 and "action_bound" not in out_free
    assert bounded < before - 0.2 and bounded < free - 0.2

    env = DummyEnv(8, seed=0)
    train_cfg = runner_cfg(LearnerConfig(num_steps_per_env=8, privileged_slices=env.privileged_slices,
                                         action_bound_weight=1.0))
    with pytest.raises(ValueError, match="one bound per action"):
        OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu")

"""Learner tests: models, contrastive module, PPO update, checkpoints, export. Small sizes on a dummy env
(the learner does not care where observations come from); one slow test runs the real task env."""

from __future__ import annotations

import copy
import json
import math

import pytest
import torch
from tensordict import TensorDict

from rsl_rl.runners import OnPolicyRunner
from rsl_rl.utils import split_and_pad_trajectories

from cra_warp.learning import (CheckpointError, ContrastConfig, LearnerConfig, PPOConfig, export_policy,
                               load_checkpoint, runner_cfg)
from cra_warp.learning.bench import DummyEnv, collect
from cra_warp.learning.contrastive import contrast_pairs, episode_ids, info_nce

STEPS = 8


def make_runner(variant="same_step", num_envs=8, seed=0, mini_batches=2, env=None,
                max_samples=2048, contrast=None, privileged_slices=None, critic_warmup=0, batched_values=True,
                critic_warmup_learning_rate=None, **env_kw):
    torch.manual_seed(seed)
    env = env or DummyEnv(num_envs, seed=seed, **env_kw)
    slices = env.privileged_slices if privileged_slices is None else privileged_slices
    cfg = LearnerConfig(num_steps_per_env=STEPS, privileged_slices=slices,
                        contrast=ContrastConfig(variant=variant, max_samples=max_samples, **(contrast or {})),
                        ppo=PPOConfig(num_learning_epochs=2, num_mini_batches=mini_batches),
                        critic_warmup=critic_warmup, critic_warmup_learning_rate=critic_warmup_learning_rate,
                        batched_values=batched_values)  # False: rsl-rl's per-step critic
    train_cfg = runner_cfg(cfg)
    return OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu"), env


def fake_metadata(num_joints=23, obs_dim=84, clock=True):
    layout, i = {}, 0
    for k, n in [("head", obs_dim - 2 * num_joints), ("joint_pos", num_joints), ("joint_vel", num_joints)]:
        layout[k] = slice(i, i + n)
        i += n
    return {"obs_layout": layout, "joint_names": [f"j{k}" for k in range(num_joints)], "action_scale": 0.5,
            "default_q": torch.linspace(-0.3, 0.3, num_joints), "kp": [100.0] * num_joints, "kd": [2.0] * num_joints,
            "gait": {"cycle_time": 0.8, "alpha": 0.5, "psi": 0.5, "gamma": -0.1, "beta_scale": 1.0} if clock else None,
            "control_dt": 0.02, "obs_scales": {"ang_vel": 0.25, "joint_vel": 0.05},
            "action_clip": {"joints": 10.0, "gait": 1.0}, "effort_limit": [50.0] * num_joints,
            "pd": {"law": "tau = clip(kp (q_target - q) - kd qd, +-effort_limit)"}}


def rollout_actions(actor, obs_seq):
    """Deterministic actions of a fresh hidden state over [T, 1, D] observations."""
    actor.eval()
    actor.reset()
    with torch.no_grad():
        return torch.stack([actor(TensorDict({"policy": o}, batch_size=[1])) for o in obs_seq])


# ---------------------------------------------------------------- models
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


# ---------------------------------------------------------------- contrastive module
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


# ---------------------------------------------------------------- PPO
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
    with pytest.raises(ValueError, match="critic_warmup_learning_rate must be > 0"):
        make_runner(critic_warmup=1, critic_warmup_learning_rate=0.0)


def test_contrast_sample_cap():
    """Above max_samples the InfoNCE term uses a random subset: chance level 1 / max_samples."""
    runner, env = make_runner(max_samples=10)
    collect(runner.alg, env, STEPS)
    out = runner.alg.update()
    assert out["infonce_chance"] == pytest.approx(1 / 10)


def test_runner_learn_logs_infonce(tmp_path):
    """rsl-rl's own loop: one learn() iteration logs Loss/infonce* and saves a checkpoint with the heads."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    torch.manual_seed(0)
    env = DummyEnv(4)
    cfg = LearnerConfig(num_steps_per_env=STEPS, ppo=PPOConfig(num_learning_epochs=1, num_mini_batches=2),
                        privileged_slices=env.privileged_slices)
    runner = OnPolicyRunner(env, runner_cfg(cfg), log_dir=str(tmp_path), device="cpu")
    runner.learn(1)
    events = EventAccumulator(str(tmp_path))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    assert {"Loss/infonce", "Loss/infonce_acc", "Loss/infonce_chance"} <= tags and "Loss/symmetry" not in tags
    assert "contrast_state_dict" in torch.load(tmp_path / "model_0.pt", weights_only=False)


# ---------------------------------------------------------------- checkpoints
def test_checkpoint_round_trip(tmp_path):
    a, env = make_runner(seed=1)
    collect(a.alg, env, STEPS)
    a.alg.update()
    a.current_learning_iteration = 7
    path = tmp_path / "model_7.pt"
    a.save(str(path))
    b, _ = make_runner(seed=2)
    obs_seq = torch.randn(6, 1, 84)
    assert not torch.allclose(rollout_actions(a.alg.actor, obs_seq), rollout_actions(b.alg.actor, obs_seq))
    load_checkpoint(path, b)
    assert b.current_learning_iteration == 7
    torch.testing.assert_close(rollout_actions(b.alg.actor, obs_seq), rollout_actions(a.alg.actor, obs_seq),
                               atol=0, rtol=0)
    for n, v in a.alg.heads.state_dict().items():
        assert torch.equal(v, b.alg.heads.state_dict()[n])
    c, _ = make_runner(seed=3)
    c.load(str(path))  # rsl-rl's own load works on the same file
    torch.testing.assert_close(rollout_actions(c.alg.actor, obs_seq), rollout_actions(a.alg.actor, obs_seq))


def test_checkpoint_errors(tmp_path):
    runner, _ = make_runner()

    def error(path):
        with pytest.raises(CheckpointError) as e:
            load_checkpoint(path, runner)
        msg = str(e.value)
        assert msg.startswith(str(path)) and "\n" not in msg
        return msg

    assert "no such checkpoint" in error(tmp_path / "missing.pt")
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"\x00not a checkpoint" * 10)
    assert "not a readable torch checkpoint" in error(junk)
    good = tmp_path / "good.pt"
    runner.save(str(good))
    cut = tmp_path / "cut.pt"
    cut.write_bytes(good.read_bytes()[:2000])
    assert "not a readable torch checkpoint" in error(cut)
    other = tmp_path / "other.pt"
    torch.save({"weights": 1}, other)
    assert "not an rsl-rl checkpoint" in error(other)
    clock_free, _ = make_runner(num_obs=79, num_actions=23)
    small = tmp_path / "clock_free.pt"
    clock_free.save(str(small))
    assert "actor observation dim is 79 in the checkpoint but 84 in this model" in error(small)
    none_runner, _ = make_runner("none")
    none_ckpt = tmp_path / "none.pt"
    none_runner.save(str(none_ckpt))
    assert "has no contrastive heads but this runner's contrast variant is 'same_step'" in error(none_ckpt)
    load_checkpoint(none_ckpt, runner, load_cfg={"actor": True})  # the actor alone loads fine


# ---------------------------------------------------------------- export
def test_export_parity(tmp_path):
    ort = pytest.importorskip("onnxruntime")
    runner, env = make_runner()
    collect(runner.alg, env, STEPS)
    runner.alg.update()  # non-trivial observation normaliser statistics
    actor = runner.alg.get_policy()
    assert actor.obs_normalizer._std.sub(1).abs().max() > 1e-3
    paths = export_policy(runner, tmp_path, fake_metadata())
    obs_seq = torch.randn(10, 1, 84, generator=torch.Generator().manual_seed(3)) * 2
    ref = rollout_actions(actor, obs_seq)                                # [10, 1, 26]

    jit = torch.jit.load(str(paths["torchscript"]))
    jit.reset()
    with torch.no_grad():
        out_jit = torch.stack([jit(o) for o in obs_seq])
    torch.testing.assert_close(out_jit, ref, atol=1e-5, rtol=0)

    sess = ort.InferenceSession(str(paths["onnx"]))
    assert [i.name for i in sess.get_inputs()] == ["obs", "h_in"]
    h = torch.zeros(1, 1, 256).numpy()
    out_onnx = []
    for o in obs_seq:
        a, h = sess.run(["actions", "h_out"], {"obs": o.numpy(), "h_in": h})
        out_onnx.append(torch.from_numpy(a))
    torch.testing.assert_close(torch.stack(out_onnx), ref, atol=1e-5, rtol=0)

    doc = json.loads(paths["json"].read_text())
    assert doc["obs_layout"]["joint_vel"] == [61, 84] and len(doc["default_q"]) == 23
    assert doc["network"]["hidden_state_shape"] == [1, 1, 256] and doc["network"]["action_dim"] == 26
    assert doc["actions"]["gait"] == [23, 26] and doc["gait"]["cycle_time"] == 0.8
    assert doc["onnx"]["inputs"]["h_in"] == [1, 1, 256] and doc["files"]["onnx"] == "policy.onnx"

    bare = export_policy(actor, tmp_path / "bare", fake_metadata(), onnx=False)  # from a model, no runner
    jit2 = torch.jit.load(str(bare["torchscript"]))
    with torch.no_grad():
        torch.testing.assert_close(torch.stack([jit2(o) for o in obs_seq]), ref, atol=1e-5, rtol=0)


def test_export_checks_metadata(tmp_path):
    runner, _ = make_runner()
    meta = fake_metadata()
    del meta["kp"]
    with pytest.raises(ValueError, match="lacks \\['kp'\\]"):
        export_policy(runner, tmp_path, meta)
    with pytest.raises(ValueError, match="covers 80 entries but the policy takes 84"):
        export_policy(runner, tmp_path, fake_metadata(obs_dim=80))
    with pytest.raises(ValueError, match="gait lacks"):
        export_policy(runner, tmp_path, fake_metadata(clock=False))


# ---------------------------------------------------------------- the real task env
@pytest.mark.slow
def test_real_env_update_and_export(tmp_path):
    from envs.locomotion import LocoEnv
    from envs.loco_config import LocoConfig

    env = LocoEnv(LocoConfig(num_envs=4))
    actor = env.priv_layout["actor"]
    runner, _ = make_runner(env=env, mini_batches=2, privileged_slices={"observation": (actor.start, actor.stop)})
    obs = env.get_observations()
    assert obs["policy"].shape == (4, 84) and obs["privileged"].shape == (4, 179 + 2 * 23)  # + PD gain scales
    assert obs["height_map"].shape == (4, 1, 17, 11)
    collect(runner.alg, env, STEPS)
    out = runner.alg.update()
    assert math.isfinite(out["infonce"])
    from train.export import deploy_metadata

    robot = env.robot
    paths = export_policy(runner, tmp_path, deploy_metadata(env))
    doc = json.loads(paths["json"].read_text())
    assert doc["obs_layout"]["gait_phase"] == [82, 84] and doc["joint_names"] == list(robot.joint_names)

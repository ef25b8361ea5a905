"""Export (cra_warp/learning/export.py): TorchScript and ONNX act as the actor, the metadata is checked; one slow test
updates and exports on the real task env."""

from __future__ import annotations

import json
import math

import pytest
import torch

from cra_warp.learning import export_policy
from cra_warp.learning.bench import collect
from tests.cra_warp.learning.helpers import STEPS, fake_metadata, make_runner, rollout_actions


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

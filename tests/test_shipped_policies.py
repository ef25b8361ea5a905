"""Every policy we ship (robots/adam_lite/policies/<name>/, written by cra-export --ship) still runs on today's code
and walks, and its exported graph acts as its checkpoint does.

"Walks" here is a short, cheap version of cra-eval's flat trial: 8 nominal robots told to walk forward at 0.5 m/s
for 6 s on flat ground in MuJoCo; none may fall and their average forward speeds must be within 0.25 m/s of it. The
full figures of each policy (200 robots, 20 s, lateral and turning commands) are in its eval.json.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

POLICIES = sorted((Path(__file__).resolve().parents[1] / "robots" / "adam_lite" / "policies").glob("*/checkpoint.pt"))


@pytest.mark.parametrize("checkpoint", POLICIES, ids=lambda p: p.parent.name)
def test_shipped_policy_walks_and_its_export_acts_as_its_checkpoint(checkpoint):
    from envs.loco_config import DomainRandConfig
    from envs.evaluation import flat_trial
    from envs.checkpoints import runner_for_checkpoint

    for name in ("policy.pt", "policy.onnx", "policy.json", "config.json", "eval.json", "curves.png"):
        assert (checkpoint.parent / name).is_file(), f"{checkpoint.parent.name} ships no {name}"
    runner, env = runner_for_checkpoint(checkpoint, num_envs=8, sim="mujoco", seed=0, terrain="flat",
                                        randomization=DomainRandConfig(enabled=False), episode_length_s=1e6)
    policy = runner.get_inference_policy()
    seen = []

    def act(obs, dones):
        policy.reset(dones)
        if len(seen) < 50:
            seen.append(obs["policy"][:1].clone())
        return policy(obs)

    r = flat_trial(env, act, 0.5, 6.0)
    assert r["fall_rate"] == 0.0, f"{r['fall_rate']:.0%} of the robots fell"
    assert r["mean_error"] < 0.25, f"the robots' average forward speed is {r['mean_error']:.2f} m/s off 0.5"

    jit = torch.jit.load(str(checkpoint.parent / "policy.pt"))
    jit.reset()
    with torch.inference_mode():
        policy.reset(torch.ones(env.num_envs, dtype=torch.bool))
        for obs in seen:  # robot 0's first observations, fed to both in order (the GRU carries state)
            want = policy({"policy": obs.expand(env.num_envs, -1)})[:1]
            torch.testing.assert_close(jit(obs), want, atol=1e-5, rtol=0)


@pytest.mark.parametrize("folder", [p.parent for p in POLICIES], ids=lambda p: p.name)
def test_shipped_onnx_with_its_data_file_acts_as_the_torchscript(folder, tmp_path):
    """Every sim-to-sim figure runs the ONNX graph (cra_warp.deploy, cra-sim2sim), so the shipped .onnx with its
    .onnx.data (the weights) must load in onnxruntime and give the TorchScript's actions to 1e-5, step by step with
    the GRU state fed back; without the data file it must not load at all."""
    import json
    import shutil

    import numpy as np
    import onnxruntime as ort

    net = json.loads((folder / "policy.json").read_text())["network"]
    assert (folder / "policy.onnx.data").is_file(), f"{folder.name} ships no policy.onnx.data"
    session = ort.InferenceSession(str(folder / "policy.onnx"), providers=["CPUExecutionProvider"])
    assert [i.name for i in session.get_inputs()] == ["obs", "h_in"]
    jit = torch.jit.load(str(folder / "policy.pt"))
    jit.reset()
    g = torch.Generator().manual_seed(0)
    h = np.zeros(net["hidden_state_shape"], dtype=np.float32)
    worst = 0.0
    for _ in range(40):
        obs = torch.randn(1, net["obs_dim"], generator=g)
        with torch.inference_mode():
            want = jit(obs).numpy()
        got, h = session.run(["actions", "h_out"], {"obs": obs.numpy(), "h_in": h})
        assert got.shape == (1, net["action_dim"])
        worst = max(worst, float(np.abs(got - want).max()))
    assert worst < 1e-5, f"ONNX and TorchScript differ by {worst:.2e}"
    assert np.abs(h).max() > 0  # the state moved: the recurrence was exercised
    shutil.copy(folder / "policy.onnx", tmp_path / "policy.onnx")  # the graph alone, its weights left behind
    with pytest.raises(Exception):
        ort.InferenceSession(str(tmp_path / "policy.onnx"), providers=["CPUExecutionProvider"])

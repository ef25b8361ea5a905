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


def _stored_world(folder: Path) -> dict:
    import json

    return json.loads((folder / "config.json").read_text())["env"]["world"]


# the policies saved while env.world still held num_envs and device (rough_walk_v1 and later do not)
OLD_WORLD = [p.parent for p in POLICIES if {"num_envs", "device"} <= set(_stored_world(p.parent))]


def test_some_shipped_policy_has_the_old_world_fields():
    assert OLD_WORLD, "no shipped config.json holds env.world.num_envs and .device: the test below checks nothing"


@pytest.mark.parametrize("folder", OLD_WORLD, ids=lambda p: p.name)
def test_a_stored_config_with_the_worlds_old_size_and_device_still_loads(folder):
    """Stored runs carry env.world.num_envs and .device (the world's size and device were WorldConfig fields before
    they became make_world's): loading skips them, the task's own values stand, and other unknown keys still fail."""
    import json

    from cra_warp.config_io import from_data, to_data
    from envs.loco_config import LocoConfig

    env = json.loads((folder / "config.json").read_text())["env"]
    assert {"num_envs", "device"} <= set(env["world"])
    cfg = from_data(LocoConfig, env)
    assert (cfg.num_envs, cfg.device, cfg.world.backend) == (env["num_envs"], env["device"], env["world"]["backend"])
    assert "num_envs" not in to_data(cfg)["world"]
    env["world"]["substep"] = 4
    with pytest.raises(ValueError, match=r"world has no field\(s\) \['substep'\]"):
        from_data(LocoConfig, env)


def test_a_checkpoint_rebuilt_for_mujoco_on_cuda_is_refused_in_one_line():
    from cra_warp.learning.checkpoint import CheckpointError
    from envs.checkpoints import runner_for_checkpoint

    with pytest.raises(CheckpointError, match="cannot be rebuilt .mujoco runs on the CPU only, got device 'cuda:0'"):
        runner_for_checkpoint(POLICIES[0], device="cuda:0", sim="mujoco")

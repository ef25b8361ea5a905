"""cra-export (train/export.py): the export command, and the shipped actor-only checkpoint it writes."""

import json

import torch

from tests.conftest import one_line_error
from train import export as export_cli


def test_export_cli(trained, tmp_path, capsys):
    first, _ = trained
    assert export_cli.main([str(first / "model_1.pt"), "--out", str(tmp_path / "dep")]) == 0
    assert (tmp_path / "dep" / "policy.onnx").is_file()
    out = capsys.readouterr()
    assert "onnx_data" in out.out and "Actor Model" not in out.out
    assert len(out.err.strip().splitlines()) <= 1, out.err  # the exporter's warnings: one summary line at most
    bad = tmp_path / "model_9.pt"
    bad.write_bytes(b"not a checkpoint")
    one_line_error(capsys, export_cli.main([str(bad)]), str(bad))


def test_shipped_checkpoint_is_the_actor_and_plays_like_the_full_one(trained, tmp_path):
    """--ship: checkpoint.pt keeps the networks a fork needs (actor, critic, contrastive heads), iteration and run
    info, but no optimizer state, and config.json the run's configuration; a policy rebuilt from it acts exactly as
    one from the full checkpoint."""
    from envs.checkpoints import runner_for_checkpoint

    first, _ = trained
    out = tmp_path / "ship"
    assert export_cli.main([str(first / "model_1.pt"), "--out", str(out), "--ship"]) == 0
    slim = torch.load(out / "checkpoint.pt", weights_only=False)
    full = torch.load(first / "model_1.pt", weights_only=False)
    assert set(slim) == {"actor_state_dict", "critic_state_dict", "contrast_state_dict", "iter", "infos"}
    for key in ("actor_state_dict", "critic_state_dict", "contrast_state_dict"):
        assert all(torch.equal(v, full[key][n]) for n, v in slim[key].items()), key
    assert json.loads((out / "config.json").read_text()) == slim["infos"]["config"]
    actions = []
    for path in (first / "model_1.pt", out / "checkpoint.pt"):
        runner, env = runner_for_checkpoint(path, num_envs=2, sim="mujoco")
        obs = env.get_observations()
        actions.append(runner.get_inference_policy()(obs))
    assert torch.equal(actions[0], actions[1])
    assert (out / "checkpoint.pt").stat().st_size < (first / "model_1.pt").stat().st_size / 2  # Adam's two moments

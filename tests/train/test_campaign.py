"""cra-campaign: a campaign folder holds one checkpoint per run, replaced on every save, and continues from it."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cra_warp.config_io import to_data
from train.campaign import ROOT, CampaignArgs, resume, save, status, train_argv
from cra_warp.cli import parse_args
from train.train import TrainArgs


def test_stored_arguments_rebuild_the_run():
    a = TrainArgs(task="rough", sim="mujoco", num_envs=64, seed=3, bf16=False, curriculum=False,
                  override=("gait.alpha=5", 'terrain_curriculum="reach"'), init=Path("x.pt"), max_iterations=7)
    back = parse_args(TrainArgs, train_argv(to_data(a)), None)
    for field in ("task", "sim", "num_envs", "seed", "bf16", "curriculum", "override", "recipe", "epochs"):
        assert getattr(back, field) == getattr(a, field), field
    assert back.init is None and back.max_iterations == TrainArgs.max_iterations  # per-start: left out


def _train(log_dir: Path, iterations: int) -> None:
    cmd = [sys.executable, "-m", "train.train", "--sim", "mujoco", "--num-envs", "8", "--mini-batches", "2",
           "--max-iterations", str(iterations), "--save-interval", "1", "--log-dir", str(log_dir), "--no-export",
           "--quiet"]
    subprocess.run(cmd, check=True, capture_output=True)


@pytest.mark.slow
def test_save_replaces_and_resume_continues(tmp_path):
    run = tmp_path / "runs" / "arm_s1"
    _train(run, 2)
    folder = save(CampaignArgs("save", "c", (run,), target=5, root=tmp_path / "campaigns"))
    first = sorted(p.name for p in folder.glob("*/*.pt"))
    assert first == ["model_1.pt"]
    assert "cra-campaign resume c" in (folder / "RESUME.md").read_text()
    out = tmp_path / "out"
    assert resume(CampaignArgs("resume", "c", root=tmp_path / "campaigns", out=out, iterations=1, cores=(0, 1))) == 0
    continued = sorted(p.name for p in (out / "arm_s1").rglob("model_*.pt"))
    assert continued == ["model_2.pt"]
    # again, before any save: from this machine's model_2, not the committed model_1
    assert resume(CampaignArgs("resume", "c", root=tmp_path / "campaigns", out=out, iterations=1, cores=(0, 1))) == 0
    assert sorted(p.name for p in (out / "arm_s1").rglob("model_*.pt")) == ["model_2.pt", "model_3.pt"]
    (next((out / "arm_s1").rglob("model_3.pt"))).unlink()
    folder = save(CampaignArgs("save", "c", (out / "arm_s1",), root=tmp_path / "campaigns"))
    assert sorted(p.name for p in folder.glob("*/*.pt")) == ["model_2.pt"]  # replaced, not accumulated
    manifest = json.loads((folder / "campaign.json").read_text())
    assert manifest["target"] == 5 and manifest["runs"]["arm_s1"]["iteration"] == 2
    records = status(CampaignArgs("status", "c", root=tmp_path / "campaigns", json=tmp_path / "s.json"))
    assert [(r["run"], r["iteration"], r["env_steps"]) for r in records] == [("arm_s1", 2, 3 * 8 * 24)]
    first_run = status(CampaignArgs("status", "c", (run,), iteration=0))
    assert first_run[0]["iteration"] == 0 and json.loads((tmp_path / "s.json").read_text())["runs"] == records
    both = status(CampaignArgs("status", "c", (run, out / "arm_s1")))  # one name in two folders: both kept
    assert [(r["run"], r["iteration"]) for r in both] == [("runs/arm_s1", 1), ("out/arm_s1", 2)]


@pytest.mark.slow
def test_committed_campaigns_resume_for_one_iteration(tmp_path):
    campaigns = sorted(p.parent.name for p in ROOT.glob("*/campaign.json"))
    if not campaigns:
        pytest.skip("no live campaign is committed under robots/adam_lite/campaigns/")
    for name in campaigns:
        manifest = json.loads((ROOT / name / "campaign.json").read_text())
        label = next((k for k, r in manifest["runs"].items() if not r.get("finished")), None)
        if label is None:   # every run finished in its study: nothing to resume
            continue
        it = manifest["runs"][label]["iteration"]
        # one run of each campaign, one iteration further, from the committed file
        out = tmp_path / name
        assert resume(CampaignArgs("resume", name, out=out, iterations=1, only=(label,), cores=(0, 1))) == 0
        assert sorted(p.name for p in (out / label).rglob("model_*.pt")) == [f"model_{it + 1}.pt"]

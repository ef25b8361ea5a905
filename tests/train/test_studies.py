"""cra-grid --study fork | walk: the fork study starts every arm from the walker with the same budget and leaves out
the methods that cannot fork; the walk study stops a run at its first walking check and, resumed, repeats no
check; cra-campaign carries a study's runs (and their check records) to another machine. A tiny study of each
runs end to end (slow)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from cra_warp.cli import UsageError
from envs.evaluation import FALL_GROUND
from tests.conftest import one_line_error
from train import grid, studies


def _flag(cmd: list[str], flag: str) -> str:
    return cmd[cmd.index(flag) + 1]


def _ckpt(run_dir: Path, it: int) -> Path:
    """A stand-in checkpoint file (the plans look at names only)."""
    (run_dir / "rough_x").mkdir(parents=True, exist_ok=True)
    path = run_dir / "rough_x" / f"model_{it}.pt"
    path.write_bytes(b"")
    return path


def test_fork_plan_starts_every_arm_from_the_walker_with_one_budget(tmp_path):
    lines = []
    a = grid.GridArgs(study="fork", seeds=(1, 2), out=tmp_path, iterations=7, dry_run=True)
    grid.run(a, log=lines.append)
    left = {line.split()[0]: line for line in lines if "left out: cannot fork" in line}
    assert set(left) == {"clock_free", "dreamwaq", "dwl", "dreamwaq_clock_free", "dwl_fixed_cycle"}, lines
    cmds = {line.split(":")[0]: line.split("training: ")[1].split() for line in lines if "training: " in line}
    assert set(cmds) == {f"{m} seed {s}" for m in ("ours", "sequential", "no_contrast", "fixed_cycle")
                         for s in (1, 2)}
    for name, cmd in cmds.items():
        assert cmd[cmd.index("-m") + 1] == "train.train" and _flag(cmd, "--task") == "rough"
        assert _flag(cmd, "--init") == str(grid.GridArgs.walker) and "--resume" not in cmd
        assert _flag(cmd, "--max-iterations") == "7" and _flag(cmd, "--num-envs") == "256"
        assert _flag(cmd, "--method") == name.split()[0] and _flag(cmd, "--seed") == name.split()[-1]
        assert (_flag(cmd, "--save-interval"), _flag(cmd, "--sim"), _flag(cmd, "--recipe")) == ("20", "mujoco", "walk")
    # an interrupted run resumes (no --init) for what is left; a finished one is evaluated, then probed
    a = studies.resolved(grid.GridArgs(study="fork", seeds=(1,), out=tmp_path, iterations=7))
    _ckpt(tmp_path / "train" / "ours-s1", 3)
    step = studies.fork_step(a, "ours", 1)
    assert step.what == "training" and "--init" not in step.cmd and _flag(step.cmd, "--max-iterations") == "3"
    assert _flag(step.cmd, "--resume") == str(tmp_path / "train" / "ours-s1")
    final = _ckpt(tmp_path / "train" / "dwl-s1", 6)   # any method's paths: the plan reads the disk only
    step = studies.fork_step(a, "dwl", 1)
    assert step.what == "evaluating" and step.cmd[3] == str(final) and _flag(step.cmd, "--protocol") == "paper"
    assert _flag(step.cmd, "--ablation-robots") == "50"
    (tmp_path / "eval").mkdir()
    (tmp_path / "eval" / "dwl-s1.json").write_text(json.dumps([{"success_rate": 0.5}]))  # judged by the old rule
    assert studies.fork_step(a, "dwl", 1).what == "evaluating"
    (tmp_path / "eval" / "dwl-s1.json").write_text(json.dumps([{"success_rate": 0.5, "fall_ground": FALL_GROUND}]))
    step = studies.fork_step(a, "dwl", 1)
    assert step.what == "probing" and step.cmd[2] == "tools.probe" and step.cmd[3] == str(final)
    (tmp_path / "eval" / "dwl-s1.probe.json").write_text("[]")
    assert studies.fork_step(a, "dwl", 1) is None


def test_the_methods_that_cannot_fork_are_the_ones_whose_actor_differs():
    assert [m for m in grid.METHODS if studies.cannot_fork(m) is None] == ["ours", "sequential", "no_contrast",
                                                                          "fixed_cycle"]


def test_walk_plan_trains_every_arm_in_chunks_within_the_budget(tmp_path):
    lines = []
    grid.run(grid.GridArgs(study="walk", out=tmp_path, dry_run=True), log=lines.append)
    cmds = {line.split(":")[0]: line.split("training: ")[1].split() for line in lines if "training: " in line}
    arms = {name.rsplit(" seed ", 1)[0] for name in cmds}
    assert arms == set(grid.METHODS) | {"ours_as_clock_free"} and len(cmds) == 2 * len(arms)   # seeds 1 2
    for name, cmd in cmds.items():
        assert _flag(cmd, "--task") == "flat" and _flag(cmd, "--max-iterations") == "100"
        assert "--init" not in cmd and "--resume" not in cmd
    pair = cmds["ours_as_clock_free seed 1"]
    assert _flag(pair, "--method") == "ours" and "gait.swing_feedforward=0.0" in pair
    a = studies.resolved(grid.GridArgs(study="walk", out=tmp_path))
    at = studies.check_iterations(a)
    assert at[:2] == [99, 199] and at[-1] == 30_000_000 // (256 * 24) - 1 and len(at) == 49


def test_override_reaches_every_run_of_every_study_after_a_fair_pairs_keys(tmp_path):
    """A tuning arm: cra-grid --override PATH=VALUE goes into each run's cra-train --override, after the keys a fair
    pair leaves out, in the comparison, the fork and the walk study alike."""
    for study in ("comparison", "fork", "walk"):
        lines = []
        grid.run(grid.GridArgs(study=study, out=tmp_path / study, seeds=(1,), dry_run=True,
                               methods=("ours", "clock_free"), override=("learner.dreamwaq.beta=1.0",)),
                 log=lines.append)
        # "<label> seed 1: [training: ]<command>" (the comparison's plan leaves out "training: ")
        cmds = {" ".join(line.split(":")[0].split()): line.split(": ", 1)[1].removeprefix("training: ").split()
                for line in lines if " train.train " in line}
        assert set(cmds) == {f"{m} seed 1" for m in ("ours", "clock_free", "ours_as_clock_free")
                             if study != "fork" or m == "ours"}, (study, lines)
        for name, cmd in cmds.items():
            given = cmd[cmd.index("--override") + 1:]
            assert cmd.count("--override") == 1 and "learner.dreamwaq.beta=1.0" in given, (study, name)
            if name.startswith("ours_as_clock_free"):   # the pair's own keys stay, before the tuned one
                assert given.index("gait.swing_feedforward=0.0") < given.index("learner.dreamwaq.beta=1.0")


def test_walk_next_stops_at_the_first_walking_check_and_repeats_none():
    at = [1, 3, 5, 6]
    ok = {"robots": 4, "robots_up": 4, "vx_error": 0.1}
    fell = {"robots": 4, "robots_up": 3, "vx_error": 0.1}
    slow = {"robots": 4, "robots_up": 4, "vx_error": 0.2}
    assert studies.walk_next([], None, at, 0.15) == ("train", 1)
    assert studies.walk_next([], 1, at, 0.15) == ("check", 1)
    assert studies.walk_next([{"iteration": 1, **fell}], 1, at, 0.15) == ("train", 3)
    assert studies.walk_next([{"iteration": 1, **fell}], 2, at, 0.15) == ("train", 3)   # interrupted mid-chunk
    assert studies.walk_next([{"iteration": 1, **slow}, {"iteration": 3, **ok}], 3, at, 0.15) == ("walked", None)
    assert studies.walk_next([{"iteration": 1, **slow}], 1, at, 0.25) == ("walked", None)
    assert studies.walk_next([{"iteration": 6, **fell}], 6, at, 0.15) == ("not within budget", None)
    assert studies.walk_next([{"iteration": 6, **fell}], None, at, 0.15) == ("not within budget", None)  # record only
    from train.campaign import study_finished

    assert study_finished({"budget_spent": True, "walked": None}, 9) == "walk"
    assert study_finished({"budget_spent": False, "walked": None}, 8) is None
    assert study_finished({"walked": {"iteration": 3}}, 3) == "walk"
    assert study_finished({"study": "fork", "iterations": 9}, 8) == "fork"
    assert study_finished({"study": "fork", "iterations": 9}, 7) is None


class _Done:
    """A finished process."""
    pid, returncode = 0, 0

    def __init__(self, returncode: int = 0):
        self.returncode = returncode

    def poll(self):
        return self.returncode

    def terminate(self):
        pass


def _fake_commands(walks_at: dict[str, int], launched: list, fail_check: set | None = None):
    """A stand-in for subprocess.Popen: training writes the checkpoint the command would end at, the flat trial
    writes a record whose robots all stay up with v_x error 0.1 from the iteration ``walks_at[method]`` on (before:
    0.3), and a check of an iteration in ``fail_check`` fails once."""
    fail_check = set(fail_check or ())

    def popen(cmd, **_):
        module = cmd[cmd.index("-m") + 1]
        if module == "train.train":
            run_dir = Path(_flag(cmd, "--log-dir"))
            now = max(int(p.stem.split("_")[1]) for p in run_dir.rglob("model_*.pt")) if "--resume" in cmd else -1
            it = now + int(_flag(cmd, "--max-iterations"))
            launched.append(("train", run_dir.name, it))
            _ckpt(run_dir, it)
            return _Done()
        ckpt = Path(cmd[3])
        it, name = int(ckpt.stem.split("_")[1]), ckpt.parent.parent.name
        if it in fail_check:
            fail_check.discard(it)
            return _Done(1)
        launched.append(("check", name, it))
        err = 0.1 if it >= walks_at[name.split("-s")[0]] else 0.3
        Path(_flag(cmd, "--json")).write_text(json.dumps([{"trial": "flat", "speed": 0.5, "robots": 4,
                                                           "seconds": 3.0, "success_rate": 1.0,
                                                           "tracking_error": err}]))
        return _Done()
    return popen


def test_a_walk_study_stops_at_the_first_walking_check_and_resumes_without_repeating_checks(tmp_path):
    # 8 robots x 24 steps = 192 env steps per iteration; the budget: 10 iterations; a check every 2
    a = grid.GridArgs(study="walk", methods=("ours", "dwl"), seeds=(1,), out=tmp_path, num_envs=8,
                      budget=10 * 192, check_every=2, parallel=1, fair_pairs=False)
    launched, lines = [], []
    popen = _fake_commands({"ours": 5, "dwl": 99}, launched, fail_check={7})
    with pytest.raises(grid.UsageError, match="checking dwl seed 1 failed"):
        studies.run(a, log=lines.append, popen=popen)   # dwl's check at iteration 7 fails: the study stops there
    ours = json.loads((tmp_path / "walk" / "ours-s1.json").read_text())
    assert [c["iteration"] for c in ours["checks"]] == [1, 3, 5] and ours["walked"]["iteration"] == 5
    assert ours["walked"]["env_steps"] == 6 * 192 and not ours["checks"][0]["walking"]
    first = list(launched)
    launched.clear()
    studies.run(a, log=lines.append, popen=popen)       # resumed: dwl goes on from its check at 7; ours is done
    assert launched == [("check", "dwl-s1", 7), ("train", "dwl-s1", 9), ("check", "dwl-s1", 9)], launched
    checks = [e for e in first + launched if e[0] == "check"]
    assert len(checks) == len(set(checks))             # no check twice
    dwl = json.loads((tmp_path / "walk" / "dwl-s1.json").read_text())
    assert [c["iteration"] for c in dwl["checks"]] == [1, 3, 5, 7, 9] and dwl["walked"] is None
    assert dwl["budget_spent"] and not ours["budget_spent"]   # what cra-campaign save reads as finished
    table = json.loads((tmp_path / "table.json").read_text())
    assert table["arms"]["ours"]["seeds"]["1"]["env_steps"] == 6 * 192
    assert table["arms"]["ours"]["mean_env_steps"] == 6 * 192
    assert table["arms"]["dwl"]["seeds"]["1"]["status"] == "not within budget"
    assert table["arms"]["dwl"]["mean_env_steps"] is None
    assert "ours,ours,1,walked,1152,5,3" in (tmp_path / "table.csv").read_text()
    assert (tmp_path / "figures" / "walk_error.png").is_file()
    drawn = json.loads((tmp_path / "figures" / "walk_error.json").read_text())
    assert drawn["dwl"]["s1"]["env_steps"] == [2 * 192, 4 * 192, 6 * 192, 8 * 192, 10 * 192]
    launched.clear()
    lines.clear()
    studies.run(a, log=lines.append, popen=popen)       # everything done: nothing runs, the figure is up to date
    assert launched == [] and any("figures: up to date" in line for line in lines), lines


def test_a_study_goes_depth_first_so_few_runs_are_part_trained(tmp_path):
    """One command at a time: each run trains and checks to its end before the next run starts; two at a time: only
    two runs are ever part-trained (the rest not started or finished)."""
    for parallel in (1, 2):
        out = tmp_path / str(parallel)
        a = grid.GridArgs(study="walk", methods=("ours", "dwl", "sequential"), seeds=(1,), out=out, num_envs=8,
                          budget=6 * 192, check_every=2, parallel=parallel, fair_pairs=False)
        launched = []
        studies.run(a, log=lambda _: None, popen=_fake_commands({"ours": 3, "dwl": 99, "sequential": 99}, launched))
        order = [name for _, name, _ in launched]
        if parallel == 1:
            assert order == ["ours-s1"] * 4 + ["dwl-s1"] * 6 + ["sequential-s1"] * 6, order
        started = [order.index(n) for n in ("ours-s1", "dwl-s1", "sequential-s1")]
        ended = [len(order) - 1 - order[::-1].index(n) for n in ("ours-s1", "dwl-s1", "sequential-s1")]
        live = max(sum(s <= i <= e for s, e in zip(started, ended)) for i in range(len(order)))
        assert live <= parallel, (parallel, order)


def test_studies_reject_bad_values(capsys, tmp_path):
    one_line_error(capsys, grid.main(["--study", "fork", "--methods", "dwl", "clock_free", "--out", str(tmp_path)]),
                   "none of --methods can fork")
    one_line_error(capsys, grid.main(["--study", "fork", "--walker", str(tmp_path / "x.pt"), "--out",
                                      str(tmp_path)]), "--walker")
    one_line_error(capsys, grid.main(["--study", "walk", "--budget", "100", "--out", str(tmp_path)]), "--budget")
    one_line_error(capsys, grid.main(["--study", "walk", "--iterations", "5", "--out", str(tmp_path)]),
                   "--iterations")
    one_line_error(capsys, grid.main(["--study", "walk", "--walk-error", "0", "--out", str(tmp_path)]),
                   "--walk-error")
    one_line_error(capsys, grid.main(["--study", "walk", "--check-every", "0", "--out", str(tmp_path)]),
                   "--check-every")
    one_line_error(capsys, grid.main(["--study", "sideways"]), "--study")
    # --override: a path no config has, the clock (a fair pair would differ), another than the --out started with
    one_line_error(capsys, grid.main(["--study", "walk", "--override", "learner.dreamwaq.betaa=1", "--out",
                                      str(tmp_path)]), "betaa")
    one_line_error(capsys, grid.main(["--study", "walk", "--override", "gait.alpha=2", "--out", str(tmp_path)]),
                   "cannot set the clock")
    (tmp_path / "override.json").write_text(json.dumps(["learner.dreamwaq.beta=1.0"]))
    one_line_error(capsys, grid.main(["--study", "walk", "--override", "learner.dreamwaq.beta=0.5", "--out",
                                      str(tmp_path)]), "was started with --override learner.dreamwaq.beta=1.0")
    one_line_error(capsys, grid.main(["--study", "walk", "--out", str(tmp_path)]), "not (none)")


def test_a_campaign_carries_a_studys_runs_and_their_records(tmp_path):
    """save takes several run directories of one study (and the record beside each), restore puts them back in
    the study's layout without training, and leaves a run that is further along alone."""
    import torch

    from train.campaign import CampaignArgs, restore, save

    walk = tmp_path / "walk" / "walk"
    for name, it in (("ours-s1", 5), ("dwl-s1", 3)):
        run_dir = walk / name / "flat_x"
        run_dir.mkdir(parents=True)
        torch.save({"actor_state_dict": {}, "iter": it, "infos": {"config": {"args": {"num_envs": 8},
                                                                             "learner": {}}}},
                   run_dir / f"model_{it}.pt")
    record = {"checks": [{"iteration": 5, "robots": 4, "robots_up": 3, "vx_error": 0.1}],
              "recipe": "climb without gait.alpha (no clock)", "num_envs": 8, "budget_env_steps": 1920}
    (walk / "ours-s1.json").write_text(json.dumps(record))
    root = tmp_path / "campaigns"
    folder = save(CampaignArgs("save", "w", (walk / "ours-s1", walk / "dwl-s1"), root=root))
    manifest = json.loads((folder / "campaign.json").read_text())
    assert manifest["runs"]["ours-s1"]["record"] == "ours-s1/record.json" and "record" not in manifest["runs"]["dwl-s1"]
    # its RESUME.md restores into the study's layout and re-runs the study (a plain resume would skip its checks)
    resume = (folder / "RESUME.md").read_text()
    command = " ".join(resume.split("```bash\n")[1].split("```")[0].replace("\\\n", " ").split())
    assert "cra-campaign restore w --out ~/cra_runs/w/walk && nohup .venv/bin/cra-grid --study walk" in command
    assert "--recipe climb --num-envs 8 --budget 1920 --parallel" in resume and "cra-campaign resume" not in resume
    assert "save w ~/cra_runs/w/walk/*/" in resume
    elsewhere = tmp_path / "other" / "walk"
    _ckpt(elsewhere / "dwl-s1", 4)    # this machine's dwl is further along than the campaign's
    restored = restore(CampaignArgs("restore", "w", root=root, out=elsewhere))
    assert restored == [elsewhere / "ours-s1" / "model_5.pt"]
    assert json.loads((elsewhere / "ours-s1.json").read_text()) == record
    a = studies.resolved(grid.GridArgs(study="walk", methods=("ours",), seeds=(1,), out=elsewhere.parent,
                                       num_envs=8, budget=10 * 192, check_every=2))
    step = studies.walk_step(a, "ours", "ours", 1)    # the restored run continues after its recorded check
    assert step.what == "training" and _flag(step.cmd, "--max-iterations") == "2"
    assert _flag(step.cmd, "--resume") == str(elsewhere / "ours-s1")

    # a finished run travels as its record alone, and is not trained again where it is restored
    walked = {**record, "checks": [{"iteration": 5, "env_steps": 48, "robots": 4, "robots_up": 4, "vx_error": 0.1}]}
    walked["walked"] = walked["checks"][0]
    (walk / "ours-s1.json").write_text(json.dumps(walked))
    folder = save(CampaignArgs("save", "w", (walk / "ours-s1", walk / "dwl-s1"), root=root))
    manifest = json.loads((folder / "campaign.json").read_text())
    assert manifest["runs"]["ours-s1"]["checkpoint"] is None and manifest["runs"]["ours-s1"]["finished"]
    assert not list((folder / "ours-s1").glob("*.pt")) and "| ours-s1 | 5 (finished) |" in (
        folder / "RESUME.md").read_text()
    fresh = tmp_path / "fresh" / "walk"
    restore(CampaignArgs("restore", "w", root=root, out=fresh))
    assert json.loads((fresh / "ours-s1.json").read_text()) == walked and not list(fresh.rglob("ours-s1/*.pt"))
    assert studies.walk_step(replace(a, out=fresh.parent), "ours", "ours", 1) is None
    # and saved again from there (its directory empty), it keeps its record
    folder = save(CampaignArgs("save", "w", (fresh / "ours-s1", fresh / "dwl-s1"), root=root))
    assert json.loads((folder / "ours-s1" / "record.json").read_text()) == walked


def test_a_campaign_carries_a_fork_study_back_to_cra_grid(tmp_path):
    """A fork run keeps the study's settings beside its directory once it trains, so a saved fork study's RESUME.md
    restores into <out>/train and re-runs cra-grid --study fork with its recipe, iterations and walker (a plain
    resume would train past its iterations and skip its evaluation); restored, the run resumes for what is left."""
    import torch

    from train.campaign import REPO, CampaignArgs, restore, save

    walker = REPO / "robots" / "adam_lite" / "policies" / "rough_walk_v0" / "checkpoint.pt"
    a = studies.resolved(grid.GridArgs(study="fork", recipe="climb", methods=("ours",), seeds=(2,),
                                       out=tmp_path / "fork", iterations=9, num_envs=8, walker=walker))
    run_dir = tmp_path / "fork" / "train" / "ours-s2"
    step = studies.fork_step(a, "ours", 2)
    assert step.what == "training" and not (run_dir.parent / "ours-s2.json").exists()   # a dry run writes nothing
    step.before()   # as the study starts its training
    record = json.loads((run_dir.parent / "ours-s2.json").read_text())
    assert (record["study"], record["recipe"], record["iterations"], record["num_envs"]) == ("fork", "climb", 9, 8)
    (run_dir / "rough_x").mkdir(parents=True)
    torch.save({"actor_state_dict": {}, "iter": 4, "infos": {"config": {"args": {"num_envs": 8}, "learner": {}}}},
               run_dir / "rough_x" / "model_4.pt")
    folder = save(CampaignArgs("save", "f", (run_dir,), root=tmp_path / "campaigns"))
    resume = (folder / "RESUME.md").read_text()
    command = " ".join(resume.split("```bash\n")[1].split("```")[0].replace("\\\n", " ").split())
    assert "cra-campaign restore f --out ~/cra_runs/f/train && nohup .venv/bin/cra-grid --study fork" in command
    assert "--recipe climb --num-envs 8 --iterations 9 " in command, command
    assert "--walker robots/adam_lite/policies/rough_walk_v0/checkpoint.pt" in command
    assert "save f ~/cra_runs/f/train/*/" in resume and "cra-campaign resume" not in resume
    elsewhere = tmp_path / "other" / "train"
    assert restore(CampaignArgs("restore", "f", root=tmp_path / "campaigns", out=elsewhere)) == [
        elsewhere / "ours-s2" / "model_4.pt"]
    step = studies.fork_step(studies.resolved(replace(a, out=elsewhere.parent)), "ours", 2)
    assert step.what == "training" and _flag(step.cmd, "--max-iterations") == "4"
    assert _flag(step.cmd, "--resume") == str(elsewhere / "ours-s2")
    # a finished fork run keeps its optimizer (a longer --iterations resumes it) and is left to its study
    torch.save({"actor_state_dict": {}, "optimizer_state_dict": {"state": 1}, "iter": 8,
                "infos": {"config": {"args": {"num_envs": 8}, "learner": {}}}}, run_dir / "rough_x" / "model_8.pt")
    folder = save(CampaignArgs("save", "f", (run_dir,), root=tmp_path / "campaigns"))
    kept = torch.load(folder / "ours-s2" / "model_8.pt", weights_only=False)
    assert kept["iter"] == 8 and "optimizer_state_dict" in kept
    assert json.loads((folder / "campaign.json").read_text())["runs"]["ours-s2"]["finished"]
    # a save that fails (a run without a checkpoint) leaves the committed folder as it was and no staging folder
    empty = tmp_path / "fork" / "train" / "ours-s3"
    empty.mkdir()
    with pytest.raises(UsageError, match="no model_"):
        save(CampaignArgs("save", "f", (run_dir, empty), root=tmp_path / "campaigns"))
    assert sorted(p.name for p in (tmp_path / "campaigns").iterdir()) == ["f"]
    assert (folder / "ours-s2" / "model_8.pt").is_file()


@pytest.mark.slow
def test_tiny_studies_run_end_to_end(tmp_path, capsys):
    """A walk study of one arm (8 robots, two chunks of 2 iterations, each checked), then a fork study of one method
    and seed from the walk run's checkpoint (its robots fall at once, so the terrain level is logged within two
    iterations; the shipped walker does not fall that soon), for real: training, checks, evaluation, probe,
    figures, tables; a second call runs nothing."""
    walk = tmp_path / "walk"
    args = ["--study", "walk", "--methods", "ours", "--seeds", "1", "--num-envs", "8", "--budget", str(4 * 192),
            "--check-every", "2", "--parallel", "1", "--out", str(walk),
            "--eval-args=--speeds 0.5 --robots 2 --seconds 3"]
    assert grid.main(args) == 0
    started = [line.split(" (pid")[0] for line in capsys.readouterr().out.splitlines() if " (pid" in line]
    assert started == ["training ours seed 1", "checking ours seed 1"] * 2, started
    record = json.loads((walk / "walk" / "ours-s1.json").read_text())
    assert [c["iteration"] for c in record["checks"]] == [1, 3] and all(c["robots"] == 2 for c in record["checks"])
    assert [c["env_steps"] for c in record["checks"]] == [2 * 192, 4 * 192]
    assert json.loads((walk / "table.json").read_text())["arms"]["ours"]["seeds"]["1"]["status"] in (
        "walked", "not within budget")
    assert (walk / "figures" / "walk_error.png").is_file()
    assert grid.main(args) == 0
    assert " (pid" not in capsys.readouterr().out     # nothing left to run

    walker = max((walk / "walk" / "ours-s1").rglob("model_*.pt"), key=lambda p: int(p.stem.split("_")[1]))
    fork = tmp_path / "fork"
    args = ["--study", "fork", "--methods", "ours", "dwl", "--seeds", "1", "--iterations", "2", "--num-envs", "8",
            "--parallel", "1", "--out", str(fork), "--walker", str(walker),
            "--eval-args=--robots-per-level 1 --speeds 1.0 --ablation-robots 1 --kinds slope_ascend",
            "--probe-args=--steps 2 --warmup 0 --robots-per-level 2"]
    assert grid.main(args) == 0
    out = capsys.readouterr().out
    assert "dwl          left out: cannot fork" in out
    started = [line.split(" (pid")[0] for line in out.splitlines() if " (pid" in line]
    assert started == ["training ours seed 1", "evaluating ours seed 1", "probing ours seed 1"], started
    config = json.loads(next((fork / "train" / "ours-s1").rglob("config.json")).read_text())
    assert config["args"]["init"] == str(walker) and config["args"]["task"] == "rough"
    # the study's settings beside the run, for cra-campaign save
    assert json.loads((fork / "train" / "ours-s1.json").read_text())["walker"] == str(walker)
    records = json.loads((fork / "eval" / "ours-s1.json").read_text())
    assert {r["protocol"] for r in records} == {"speed_sweep", "ablation"}
    table = json.loads((fork / "table.json").read_text())
    assert set(table["probe"]["ours"]) == {"latent", "obs"} and set(table["left_out"]) == {"dwl"}
    assert {c["kind"] for c in table["ablation"]} == {"slope_ascend"}
    assert all(c["robots"] == 1 and c["success_ci95"] for c in table["ablation"])
    for name in studies.FORK_FIGURES:
        assert (fork / "figures" / f"{name}.png").is_file()
    assert grid.main(args) == 0
    assert " (pid" not in capsys.readouterr().out

"""cra-eval (train/evaluate.py): bad input, the flat trial and the paper protocol from the command line, tables,
run names, the course video, a trained policy against the PD stand."""

import json

import pytest
import torch

from envs import evaluation
from tests.conftest import one_line_error
from train import evaluate as eval_cli


def test_short_names_tell_seed_runs_apart():
    runs = ["a/ff_s1/flat_ours_1/model_859.pt", "a/none_s1/flat_ours_1/model_859.pt", "b/model_9.pt"]
    names = eval_cli.short_names(runs)
    assert names == {runs[0]: "ff_s1/flat_ours_1/model_859.pt", runs[1]: "none_s1/flat_ours_1/model_859.pt",
                     runs[2]: "b/model_9.pt"}
    assert eval_cli.short_names(["x/m.pt", "x/m.pt"]) == {"x/m.pt": "m.pt"}


@pytest.mark.parametrize("args, word", [
    ([], "nothing to evaluate"),
    (["/nonexistent/model_1.pt"], "checkpoint not found"),
    (["--agent-stand", "--kinds", "ladder"], "--kinds"),
    (["--agent-stand", "--robots-per-level", "0"], "--robots-per-level"),
    (["--agent-stand", "--speeds", "-1"], "--speeds"),
    (["--agent-stand", "--speeds", "nan"], "--speeds"),
    (["--agent-stand", "--json", "/nonexistent/dir/eval.json"], "no such directory"),
    (["--agent-stand", "--device", "tpu"], "--device"),
    (["--agent-stand", "--trial", "hills"], "--trial"),
    (["--agent-stand", "--trial", "flat", "--seconds", "1"], "--seconds"),
    (["--agent-stand", "--lateral", "0.2"], "flat trial"),
    (["--agent-stand", "--trial", "flat", "--yaw-rates", "0"], "--yaw-rates"),
    (["--agent-stand", "--trial", "flat", "--yaw-rates", "0.3", "--turn-speed", "0"], "--turn-speed"),
    (["--agent-stand", "--trial", "flat", "--robots", "2", "--seconds", "2.1", "--yaw-rates", "3"],
     "training range"),
    (["--agent-stand", "--video", "walk.mp4"], ".gif"),
    (["--agent-stand", "--trial", "flat", "--video", "walk.gif"], "course run"),
    (["--agent-stand", "--video", "walk.gif", "--video-level", "7"], "--video-level"),
])
def test_eval_rejects_bad_values(capsys, args, word):
    one_line_error(capsys, eval_cli.main(args), word)


@pytest.mark.slow
def test_flat_trial_scores_a_stand_as_upright_and_not_tracking(tmp_path):
    """The scripted stand on flat ground: every robot stays up for the trial, its forward-velocity tracking error
    is the commanded speed and it never lifts a foot (it does not walk); a robot that falls counts as failed."""
    import json

    out = tmp_path / "flat.json"
    assert eval_cli.main(["--agent-stand", "--trial", "flat", "--robots", "4", "--seconds", "3", "--speeds", "0.4",
                          "--sim", "mujoco", "--json", str(out)]) == 0
    (r,) = json.loads(out.read_text())
    assert r["trial"] == "flat" and r["robots"] == 4 and r["success_rate"] == 1.0
    assert r["successes"] == 4 and r["success_ci95"] == pytest.approx([0.5101, 1.0], abs=1e-4)  # 4 of 4
    assert r["tracking_error"] == pytest.approx(0.4, abs=0.05)
    assert r["touchdowns_per_s"] == 0.0 and r["single_support"] == 0.0   # it stands on both feet: no steps

    from envs.loco_config import DomainRandConfig, LocoConfig
    from envs.locomotion import LocoEnv

    env = LocoEnv(LocoConfig(num_envs=4, randomization=DomainRandConfig(enabled=False), episode_length_s=1e6))
    zero = evaluation.flat_trial(env, lambda obs, dones: torch.zeros(env.num_envs, env.num_actions), 0.4, 10.0)
    assert zero["fall_rate"] == 1.0   # a zero action is no stand: it falls after ~3.4 s (nominal robot)


def test_flat_trial_commands_lateral_and_turning_and_a_stand_tracks_neither(tmp_path):
    """A lateral command is scored on v_y, a turn on the yaw rate against the command in force: the scripted
    stand, which moves nowhere, misses each by the command (and a turn is commanded at the asked rate)."""
    import json

    out = tmp_path / "flat.json"
    assert eval_cli.main(["--agent-stand", "--trial", "flat", "--robots", "2", "--seconds", "3", "--speeds", "0.4",
                          "--lateral", "0.2", "--yaw-rates", "-0.3", "--sim", "mujoco", "--json", str(out)]) == 0
    fwd, side, turn = json.loads(out.read_text())
    assert (side["speed"], side["lateral"], turn["speed"], turn["yaw_rate"]) == (0.0, 0.2, 0.3, -0.3)
    assert side["tracking_error_y"] == pytest.approx(0.2, abs=0.05) and side["tracking_error"] < 0.05
    assert turn["tracking_error_yaw"] == pytest.approx(0.3, abs=0.05)
    assert fwd["tracking_error_y"] < 0.05
    assert fwd["mean_error"] == pytest.approx(0.4, abs=0.05) and turn["mean_error_yaw"] == pytest.approx(0.3, abs=0.05)
    # signed: the stand is slower than told forward and sideways, and turns less clockwise than told
    assert fwd["offset"] == pytest.approx(-0.4, abs=0.05) and side["offset_y"] == pytest.approx(-0.2, abs=0.05)
    assert turn["offset_yaw"] == pytest.approx(0.3, abs=0.05)


def test_paper_protocol_runs_the_sweep_and_the_ablation(monkeypatch):
    """--protocol paper: 200 robots per level of every kind at each paper speed, then 25 per level of the stairs and
    slope ascents at 0.15 m/s; every record says which part it belongs to."""
    seen = []

    def fake_run(a):
        seen.append(a)
        return [{"policy": "stand", "speed": v, "kind": k, "level": 0, "success_rate": 1.0}
                for v in a.speeds for k in (a.kinds or ("all",))]

    monkeypatch.setattr(eval_cli, "_run", fake_run)
    records = eval_cli.run(eval_cli.EvalArgs(agent_stand=True, protocol="paper"))
    sweep, ablation = seen
    assert sweep.speeds == eval_cli.PAPER_SPEEDS and sweep.robots_per_level == 200 and sweep.kinds == ()
    assert ablation.speeds == (0.15,) and ablation.robots_per_level == 25
    assert ablation.kinds == ("stairs_ascend", "slope_ascend")
    assert {r["protocol"] for r in records} == {"speed_sweep", "ablation"}
    assert all(r["method"] == "stand" for r in records)


def test_tables_print_each_rate_with_its_interval(capsys):
    recs = [{"policy": "a/model.pt", "speed": 0.5, "kind": "stairs_ascend", "level": lv, "difficulty": 0.05 * (lv + 1),
             "robots": 10, "success_rate": rate, "fall_rate": 1 - rate} for lv, rate in enumerate((0.3, 0.1))]
    eval_cli.print_table(recs)
    out = capsys.readouterr().out
    assert "95% interval, 10 robots per level" in out and "11-60" in out and "2-40" in out
    flat = [{"policy": "a/model.pt", "speed": 0.5, "trial": "flat", "robots": 200, "success_rate": 0.995}]
    eval_cli.print_table(flat)
    assert "97-100" in capsys.readouterr().out


@pytest.mark.slow
def test_eval_draws_one_course_robot_on_its_terrain(tmp_path):
    """--video: the first robot on --video-level of the first kind, on the course's terrain boxes (drawn in their
    own checker, sand-coloured), at the GIF size; the other levels' robots are evaluated as without it."""
    import numpy as np
    from PIL import Image

    from cra_warp import video

    gif, out = tmp_path / "down.gif", tmp_path / "eval.json"
    assert eval_cli.main(["--agent-stand", "--kinds", "stairs_descend", "--robots-per-level", "1", "--speeds", "8",
                          "--sim", "mujoco", "--video-level", "2", "--video", str(gif), "--json", str(out)]) == 0
    assert len(json.loads(out.read_text())) == 7
    im = Image.open(gif)
    assert im.size == video.SIZE[::-1] and im.n_frames >= 10
    im.seek(im.n_frames // 2)
    rgb = np.asarray(im.convert("RGB")).astype(int)
    sand = (rgb[..., 0] - rgb[..., 2] > 25) & (rgb[..., 0] > 100) & (rgb[..., 0] - rgb[..., 2] < 110)
    assert sand[180:].mean() > 0.2, "the stairs' platform and steps around the robot"


@pytest.mark.slow
def test_eval_a_trained_policy_against_the_pd_stand(trained, tmp_path, capsys):
    first, _ = trained
    out = tmp_path / "eval.json"
    assert eval_cli.main([str(first / "model_1.pt"), "--agent-stand", "--kinds", "stairs_ascend",
                          "--robots-per-level", "1", "--speeds", "8", "--json", str(out)]) == 0
    records = json.loads(out.read_text())
    assert len(records) == 2 * 7                     # two policies x seven step heights
    assert {r["policy"] for r in records} == {str(first / "model_1.pt"), "stand"}
    assert [r["difficulty"] for r in records[:7]] == pytest.approx([0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35])
    assert all(0.0 <= r["success_rate"] <= 1.0 and 0.0 <= r["fall_rate"] <= 1.0 for r in records)
    assert all(r["robots"] == 1 and r["success_ci95"] == pytest.approx(list(evaluation.wilson(r["successes"], 1)))
               for r in records)
    printed = capsys.readouterr().out
    assert "stairs_ascend" in printed and "95% interval" in printed
    assert "Actor Model" not in printed and "GRU(" not in printed   # the table, not the networks

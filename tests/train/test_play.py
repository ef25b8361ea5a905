"""cra-play (train/play.py): a trained policy, held commands, the GIF of robot 0, bad input."""

import pytest

from tests.conftest import one_line_error
from train import play as play_cli


def test_play_a_trained_policy(trained, capsys):
    first, _ = trained
    assert play_cli.main([str(first / "model_1.pt"), "--num-envs", "2", "--steps", "10"]) == 0
    out = capsys.readouterr().out
    assert "vel_tracking_rmse" in out and "falls_per_robot_minute" in out


def test_play_draws_robot_0_into_a_gif(tmp_path):
    import numpy as np
    from PIL import Image

    from cra_warp import video

    gif = tmp_path / "stand.gif"
    assert play_cli.main(["--agent", "stand", "--num-envs", "2", "--steps", "20", "--sim", "mujoco",
                          "--video", str(gif)]) == 0
    im = Image.open(gif)
    assert im.n_frames == 7 and im.size == (640, 360) == video.SIZE[::-1]  # every third 50 Hz step: 16.7 frames/s
    assert im.info["duration"] == 60
    assert gif.stat().st_size < 40_000 * im.n_frames, "one shared palette, no dither: a README-sized file"
    im.seek(im.n_frames - 1)
    rgb = np.asarray(im.convert("RGB")).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    limb = ((b - r > 60) & (b > 120)) | ((r - b > 120) & (r > 150))  # the skeleton's blue left and orange right
    limb[:50] = False                                                 # not the caption
    cols = limb.any(0).nonzero()[0]
    assert limb.sum() > 1500, "no robot drawn"
    assert 220 < cols.mean() < 420, "the camera keeps the robot near the image centre"
    floor = rgb[250:][~limb[250:]].mean(-1)  # the lower third, robot excluded: the floor under the camera
    lo, hi = np.percentile(floor, [5, 95])
    assert hi - lo > 40, f"a checker floor of light and dark checks, not one flat colour ({lo:.0f}..{hi:.0f})"
    assert len(np.unique(rgb[250:].reshape(-1, 3), axis=0)) >= 8, "a lit floor with its checks and the robot's shadow"


def test_play_rejects_a_video_it_cannot_write(capsys, tmp_path):
    one_line_error(capsys, play_cli.main(["--agent", "zero", "--video", str(tmp_path / "a.mp4")]), ".gif")


def test_play_holds_a_given_command(capsys):
    """--command: every robot is told the same (v_x, v_y) for the whole rollout; the stand walks nowhere, so its
    tracking error is about that speed."""
    assert play_cli.main(["--agent", "stand", "--num-envs", "2", "--steps", "100", "--sim", "mujoco",
                          "--command", "0.4", "0"]) == 0
    rmse = float(next(line for line in capsys.readouterr().out.splitlines() if "vel_tracking_rmse" in line).split()[-1])
    assert rmse == pytest.approx(0.4, abs=0.1)   # plus what the stand sways while it settles


def test_play_nominal_turns_the_randomisation_off(monkeypatch):
    """--nominal: the robots play without randomised physics, pushes or shoves; without it, the training's."""
    import envs.locomotion as loco

    seen, build = [], loco.LocoEnv.__init__

    def spy(self, cfg):
        seen.append(cfg.randomization.enabled)
        build(self, cfg)

    monkeypatch.setattr(loco.LocoEnv, "__init__", spy)
    common = ["--agent", "stand", "--num-envs", "2", "--steps", "3", "--sim", "mujoco"]
    assert play_cli.main([*common, "--nominal"]) == 0 and play_cli.main(common) == 0
    assert seen == [False, True]


def test_play_rejects_a_non_finite_command(capsys):
    one_line_error(capsys, play_cli.main(["--agent", "stand", "--command", "nan", "0"]), "--command")


def test_play_rejects_missing_checkpoint(capsys):
    one_line_error(capsys, play_cli.main(["--agent", "policy"]), "checkpoint")


def test_play_rejects_unknown_task(capsys):
    one_line_error(capsys, play_cli.main(["--agent", "zero", "--task", "moon"]), "--task")

"""cra-train (train/train.py): bad input, checkpoints, resume, export at the end, forks, the stored configuration.
cra-export, cra-play and cra-eval are in test_export.py, test_play.py and test_evaluate.py beside this file."""

import json

import pytest
import torch

from envs.loco_config import LocoConfig
from tests.conftest import one_line_error
from train import export as export_cli
from train import train as train_cli


@pytest.mark.parametrize("args, word", [
    (["--num-envs", "-3"], "--num-envs"),
    (["--device", "tpu"], "--device"),
    (["--device", "cuda:0"], "no such CUDA device"),
    (["--variant", "magic"], "--variant"),
    (["--method", "magic"], "--method"),
    (["--task", "moon"], "--task"),
    (["--resume", "/nonexistent/model_3.pt"], "no such file"),
    (["--init", "/nonexistent/model_3.pt"], "--init /nonexistent/model_3.pt: no such file"),
    (["--epochs", "0"], "--epochs"),
    (["--mini-batches", "200"], "--mini-batches"),
    (["--num-envs", "6", "--mini-batches", "4"], "--mini-batches"),
    (["--contrast-weight", "nan"], "--contrast-weight"),
    (["--contrast-tau", "0"], "--contrast-tau"),
    (["--sim", "bullet"], "--sim"),
    (["--override", "rewards.weights"], "PATH=VALUE"),
    (["--override", "rewards.no_such_field=1", "--max-iterations", "1"], "no_such_field"),
    (["--override", "obs.noise=False", "--max-iterations", "1"], "obs.noise must be a bool"),
    (["--override", "world.contacts=bogus", "--max-iterations", "1"], "world.contacts must be one of"),
    (["--override", "randomization.mass_scale=[0.9,1.1,1.3]", "--max-iterations", "1"], "must have 2 entries"),
    (["--override", "obs.noise=null", "--max-iterations", "1"], "must not be null"),
    (["--override", "rewards.weights.contact_momentum=abc", "--max-iterations", "1"], "must be a finite float"),
    (["--override", "learner.fork_learning_rate=-1", "--max-iterations", "1"], "fork_learning_rate must be > 0"),
    (["--override", "learner.critic_warmup=-2", "--max-iterations", "1"], "the warm-ups >= 0"),
    (["--sim", "mujoco", "--device", "cuda:0"], "--sim mujoco runs on the CPU only"),
    (["--num-envs", "many"], "--num-envs"),                # tyro's own parse errors, as one line too
    (["--no-such-flag"], "Unrecognized options: --no-such-flag"),
    (["--recipe", "magic"], "--recipe"),
    (["--log-dir", "/proc/x"], "--log-dir /proc/x"),         # unwritable: one line before any set-up
])
def test_train_rejects_bad_values(capsys, args, word):
    one_line_error(capsys, train_cli.main(args), word)


def test_checkpoints_are_complete_and_atomic(trained):
    first, _ = trained
    names = sorted(p.name for p in first.glob("model_*.pt"))
    assert names == ["model_0.pt", "model_1.pt"]
    assert not list(first.rglob("*.tmp"))
    saved = torch.load(first / "model_1.pt", weights_only=False)
    assert saved["iter"] == 1 and saved["infos"]["variant"] == "ours" and saved["infos"]["task"] == "flat"


def test_resume_continues_iterations_and_optimizer(trained):
    first, second = trained
    assert [p.name for p in second.glob("model_*.pt")] == ["model_2.pt"]
    before = torch.load(first / "model_1.pt", weights_only=False)
    after = torch.load(second / "model_2.pt", weights_only=False)
    assert after["iter"] == 2
    assert before["infos"]["sim"] == "newton" and after["infos"]["sim"] == "mujoco"  # the run records its sim

    def adam_steps(ckpt):
        return max(float(s["step"]) for s in ckpt["optimizer_state_dict"]["state"].values())

    assert adam_steps(after) > adam_steps(before)  # Adam's moments came along, not a fresh optimizer


def test_export_at_the_end_of_training(trained):
    first, _ = trained
    meta = json.loads((first / "exported" / "policy.json").read_text())
    assert (first / "exported" / "policy.pt").is_file() and (first / "exported" / "policy.onnx").is_file()
    assert len(meta["joint_names"]) == 23 and meta["control_dt"] == pytest.approx(0.02)
    assert meta["gait"]["psi"] == 0.5 and len(meta["action_scale"]) == 23
    assert meta["action_scale"][5] == pytest.approx(0.5 * 12 / 70)  # ankle roll: 0.5 effort / kp


def test_deploy_json_is_complete_for_a_program_that_reads_nothing_else(trained):
    """Clips, the PD law with its gains, limits and rate, held joints, every observation term's frame and rule,
    and every file the exported graphs need (ONNX keeps its weights beside the graph when they are external)."""
    from robots.adam_lite import ADAM_LITE as R

    first, _ = trained
    out = first / "exported"
    meta = json.loads((out / "policy.json").read_text())
    assert meta["action_clip"] == {"joints": 10.0, "gait": 1.0}
    assert meta["kp"] == list(R.kp) and meta["kd"] == list(R.kd) and meta["effort_limit"] == list(R.effort_limit)
    pd = meta["pd"]
    assert "kp (q_target - q) - kd qd" in pd["law"] and pd["rate_hz"] == pytest.approx(200.0)
    assert pd["held_joints"] == {"wristYaw_Left": 0.0, "wristYaw_Right": 0.0} and pd["armature"] == R.armature
    assert set(meta["observation"]) == set(meta["obs_layout"]) | {"clip", "order"}
    assert "base (pelvis) frame" in meta["observation"]["ang_vel"] and "tau 0.2 s" in meta["observation"]["avg_ang_speed"]
    assert "sin, cos" in meta["observation"]["gait_phase"]
    for f in meta["files"].values():
        assert (out / f).is_file(), f
    onnx_data = out / "policy.onnx.data"
    assert not onnx_data.exists() or meta["files"]["onnx_data"] == onnx_data.name


@pytest.mark.slow
def test_data_parallel_on_cpu_with_torchrun(tmp_path):
    """Two processes, gloo: rsl-rl's gradient all-reduce runs on the CPU and only rank 0 writes the run."""
    import subprocess
    import sys
    from pathlib import Path

    torchrun = Path(sys.executable).with_name("torchrun")
    out = subprocess.run([str(torchrun), "--nproc-per-node", "2", "-m", "train.train", "--num-envs", "4",
                          "--max-iterations", "1", "--no-export", "--quiet", "--log-dir", str(tmp_path)],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.count("run directory:") == 1
    run_dir = next(tmp_path.iterdir())
    assert (run_dir / "model_0.pt").is_file()


def test_the_run_stores_its_whole_configuration_and_is_rebuilt_from_it(trained, tmp_path, capsys):
    """config.json and every checkpoint hold the resolved configuration; play/eval/export rebuild from it, not from
    today's defaults; a checkpoint whose observation layout differs from today's code is refused in one line."""
    from envs.checkpoints import predated_overrides, runner_for_checkpoint

    first, _ = trained
    stored = json.loads((first / "config.json").read_text())
    ckpt = torch.load(first / "model_1.pt", weights_only=False)
    assert ckpt["infos"]["config"] == stored
    assert stored["args"]["recipe"] == stored["recipe"]["name"] == "walk" and ckpt["infos"]["recipe"] == "walk"
    assert stored["recipe"]["overrides"]["gait.stride_feedforward"] == stored["env"]["gait"]["stride_feedforward"]
    assert stored["env"]["world"]["backend"] == "newton"
    # the robot by name with its numbers in env, and what the task read of it (joint groups, stand) beside it
    assert stored["env"]["robot"] == "adam_lite" and stored["env"]["fall_height"] == 0.45
    assert stored["loco_robot"]["swing_joints"][0][0] == "hipPitch_Left" and "stand_kp" not in stored["robot"]
    assert stored["learner"]["ppo"]["num_learning_epochs"] == train_cli.TrainArgs().epochs == 2
    # a stored setting that differs from today's defaults is what the rebuilt env gets
    ckpt["infos"]["config"]["env"]["obs"]["yaw_rate_filter_tau"] = 0.35
    ckpt["infos"]["config"]["learner"]["ppo"]["gamma"] = 0.98
    ckpt["infos"]["config"]["env"]["fall_height"] = 0.4          # not the robot's number: the stored one stands
    del ckpt["infos"]["config"]["env"]["robot"]                  # as runs stored before the field: Adam Lite
    del ckpt["infos"]["config"]["env"]["fall_ground"]            # ... and before this one: the old fall rule
    odd = tmp_path / "model_odd.pt"
    torch.save(ckpt, odd)
    runner, env = runner_for_checkpoint(odd, num_envs=2)
    assert env.cfg.obs.yaw_rate_filter_tau == 0.35 and runner.alg.gamma == 0.98 and env.num_envs == 2
    assert env.cfg.fall_height == 0.4 and env.cfg.robot == "adam_lite" and env.cfg.fall_ground == "base"
    # resumed, it goes on with that rule unless --override names it
    assert predated_overrides(odd, ()) == ('fall_ground="base"',)
    assert predated_overrides(odd, ('fall_ground="lowest"',)) == () == predated_overrides(first / "model_1.pt", ())
    # an actor layout of another version of the code
    ckpt["infos"]["config"]["layout"]["actor"]["gait_phase"] = [80, 82]
    torch.save(ckpt, odd)
    one_line_error(capsys, export_cli.main([str(odd)]), "actor observation layout differs", "gait_phase")
    # a robot retuned since (gains): the policy would run on another actuator
    ckpt["infos"]["config"] = json.loads(json.dumps(stored))
    ckpt["infos"]["config"]["robot"]["kp"][4] = 500.0
    torch.save(ckpt, odd)
    one_line_error(capsys, export_cli.main([str(odd)]), "robot's kp differs")
    one_line_error(capsys, train_cli.main(["--num-envs", "4", "--resume", str(odd), "--max-iterations", "1",
                                           "--no-export", "--quiet", "--log-dir", str(tmp_path / "r")]),
                   "robot's kp differs")


@pytest.mark.slow
def test_the_same_seed_gives_identical_first_iterations(tmp_path):
    """Two CPU runs with one seed: the same rewards, episode lengths and losses for their first 3 iterations."""
    histories = []
    for k in range(2):
        _, runner = train_cli.run(train_cli.TrainArgs(num_envs=4, max_iterations=3, seed=7, export=False, quiet=True,
                                                      log_dir=tmp_path / str(k), sim="mujoco"))
        histories.append(runner.history)
    keys = ("reward", "episode_s", "infonce_acc", "losses")
    assert [{k: h.get(k) for k in keys} for h in histories[0]] == [{k: h.get(k) for k in keys} for h in histories[1]]
    assert len(histories[0]) == 3 and {"value", "surrogate"} <= set(histories[0][-1]["losses"])


def test_overrides_reach_the_env_and_the_stored_config(tmp_path):
    run_dir, runner = train_cli.run(train_cli.TrainArgs(
        num_envs=4, max_iterations=1, export=False, quiet=True, log_dir=tmp_path, sim="mujoco",
        override=("rewards.weights.contact_momentum=-4.4e-5", "obs.yaw_rate_filter_tau=0.3")))
    assert runner.env.cfg.rewards.weights["contact_momentum"] == -4.4e-5
    assert runner.env.cfg.obs.yaw_rate_filter_tau == 0.3
    assert json.loads((run_dir / "config.json").read_text())["env"]["obs"]["yaw_rate_filter_tau"] == 0.3


@pytest.mark.slow
def test_kill_9_mid_training_loses_at_most_one_save_interval(tmp_path):
    """cra-train killed with SIGKILL while it trains and checkpoints every iteration: every checkpoint left is whole
    (written to a temp file, then renamed), and --resume continues after the newest."""
    import os
    import signal
    import subprocess
    import sys
    import time

    logs = tmp_path / "runs"
    cmd = [sys.executable, "-m", "train.train", "--num-envs", "4", "--sim", "mujoco", "--save-interval", "1",
           "--max-iterations", "200", "--no-export", "--quiet", "--log-dir", str(logs)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 300
    while time.time() < deadline and proc.poll() is None and len(list(logs.rglob("model_*.pt"))) < 4:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    saved = sorted(logs.rglob("model_*.pt"), key=lambda p: int(p.stem.split("_")[1]))
    assert len(saved) >= 4, "the run never got to its fourth checkpoint"
    for p in saved:
        assert torch.load(p, weights_only=False)["iter"] == int(p.stem.split("_")[1])  # none torn
    newest = saved[-1]
    assert train_cli.main(["--num-envs", "4", "--sim", "mujoco", "--resume", str(newest), "--max-iterations", "1",
                           "--no-export", "--quiet", "--log-dir", str(tmp_path / "resumed")]) == 0
    resumed = next((tmp_path / "resumed").rglob("model_*.pt"))
    assert torch.load(resumed, weights_only=False)["iter"] == int(newest.stem.split("_")[1]) + 1


def test_resume_from_a_directory_takes_its_newest_checkpoint(tmp_path):
    """--resume DIR: the highest iteration under DIR (any run inside it); none yet means a fresh start."""
    assert train_cli.newest_checkpoint(tmp_path) is None
    for run, its in (("a", (20, 100)), ("b", (40,))):
        (tmp_path / run).mkdir()
        for it in its:
            (tmp_path / run / f"model_{it}.pt").write_bytes(b"x")
    (tmp_path / "b" / "model_final.pt").write_bytes(b"x")
    assert train_cli.newest_checkpoint(tmp_path) == tmp_path / "a" / "model_100.pt"


def test_runs_started_in_the_same_second_get_their_own_directories(tmp_path):
    base = tmp_path / "flat_ours_20261203-090334"
    assert train_cli.unused_dir(base) == base
    base.mkdir()
    assert train_cli.unused_dir(base) == tmp_path / "flat_ours_20261203-090334-2"
    (tmp_path / "flat_ours_20261203-090334-2").mkdir()
    assert train_cli.unused_dir(base) == tmp_path / "flat_ours_20261203-090334-3"


def test_resume_keeps_the_difficulty_level(tmp_path):
    """A run with the difficulty curriculum stores its level in every checkpoint; --resume continues from it (the
    resumed iteration may move it by one step), not from the configured start."""
    common = ["--num-envs", "4", "--max-iterations", "1", "--save-interval", "1", "--log-dir", str(tmp_path),
              "--quiet", "--no-export", "--sim", "mujoco"]
    assert train_cli.main([*common, "--override", "difficulty.commands=true", "difficulty.start=0.35"]) == 0
    first = next(tmp_path.iterdir())
    assert torch.load(first / "model_0.pt", weights_only=False)["infos"]["difficulty_level"] == pytest.approx(0.35)
    assert train_cli.main([*common, "--resume", str(first / "model_0.pt"), "--override", "difficulty.commands=true",
                           "difficulty.start=0.0"]) == 0
    second = next(d for d in tmp_path.iterdir() if d != first)
    level = torch.load(second / "model_1.pt", weights_only=False)["infos"]["difficulty_level"]
    assert level == pytest.approx(0.35) or level == pytest.approx(0.30)
    from envs.checkpoints import runner_for_checkpoint  # play / eval / export: the whole task, no curriculum
    _, env = runner_for_checkpoint(second / "model_1.pt", num_envs=2, sim="mujoco")
    assert float(env.difficulty.level) == 1.0 and not env.difficulty.active


def test_training_uses_the_curriculum_unless_told_not_to(trained, tmp_path):
    first, _ = trained
    stored = json.loads((first / "config.json").read_text())["env"]["difficulty"]
    # the walk recipe (the default) keeps the randomisation curriculum and gives commands at full range at once
    assert not stored["commands"] and stored["randomization"] and stored["start"] == 0.0 and stored["step"] == 0.02
    _, runner = train_cli.run(train_cli.TrainArgs(num_envs=4, max_iterations=1, export=False, quiet=True,
                                                  log_dir=tmp_path, sim="mujoco", recipe="paper"))
    assert runner.env.cfg.difficulty.commands and runner.env.cfg.difficulty.randomization
    run_dir, runner = train_cli.run(train_cli.TrainArgs(num_envs=4, max_iterations=1, export=False, quiet=True,
                                                        log_dir=tmp_path, sim="mujoco", curriculum=False))
    assert not runner.env.difficulty.active and float(runner.env.difficulty.level) == 1.0


def test_init_forks_a_checkpoints_networks_into_a_new_run(trained, tmp_path, capsys):
    """--init: another variant starts from the checkpoint's actor and critic at iteration 0 with a fresh optimizer
    (no contrastive heads to carry over); --init with --resume is refused."""
    first, _ = trained
    src = torch.load(first / "model_1.pt", weights_only=False)
    run_dir, runner = train_cli.run(train_cli.TrainArgs(num_envs=4, max_iterations=1, export=False, quiet=True,
                                                        log_dir=tmp_path, sim="mujoco", variant="no_contrast",
                                                        init=first / "model_1.pt", save_interval=1))
    assert runner.alg.heads is None
    forked = torch.load(run_dir / "model_0.pt", weights_only=False)
    assert forked["iter"] == 0 and "contrast_state_dict" not in forked
    # the observation normalisers went on counting from the checkpoint's: one iteration of 4 robots x 24 steps
    for model in ("actor_state_dict", "critic_state_dict"):
        assert int(forked[model]["obs_normalizer.count"]) == int(src[model]["obs_normalizer.count"]) + 4 * 24
    stored = json.loads((run_dir / "config.json").read_text())["learner"]
    assert stored["ppo"]["learning_rate"] == stored["fork_learning_rate"] and stored["critic_warmup"] == 0
    one_line_error(capsys, train_cli.main(["--num-envs", "4", "--log-dir", str(tmp_path), "--init",
                                           str(first / "model_1.pt"), "--resume", str(first / "model_1.pt")]),
                   "exclude each other")


def test_init_carries_the_contrastive_heads_over(trained, tmp_path):
    """A fork of the same contrast (ours from ours) starts from the checkpoint's heads, not fresh ones."""
    first, _ = trained
    src = torch.load(first / "model_1.pt", weights_only=False)
    run_dir, runner = train_cli.run(train_cli.TrainArgs(num_envs=4, max_iterations=1, export=False, quiet=True,
                                                        log_dir=tmp_path, sim="mujoco", init=first / "model_1.pt",
                                                        seed=7))  # fresh heads would start elsewhere than its
    heads = runner.alg.heads.state_dict()
    # one iteration at the fork's rate (5e-5, 8 Adam steps) moves a weight by ~4e-4; fresh heads differ by ~0.1
    drift = max(float((heads[n].cpu() - v).abs().max()) for n, v in src["contrast_state_dict"].items())
    assert set(heads) == set(src["contrast_state_dict"]) and drift < 1e-2


def test_init_from_an_actor_only_policy_warms_its_critic_up(trained, tmp_path):
    """A policy without a critic, forked with a critic warm-up (learner.fork_critic_warmup, 0 by default): the first
    updates leave its actor (normaliser included) exactly as shipped and train the fresh critic."""
    first, _ = trained
    src = torch.load(first / "model_1.pt", weights_only=False)
    shipped = tmp_path / "actor_only.pt"
    torch.save({k: v for k, v in src.items() if k not in ("critic_state_dict", "optimizer_state_dict")}, shipped)
    run_dir, runner = train_cli.run(train_cli.TrainArgs(num_envs=4, max_iterations=2, export=False, quiet=True,
                                                        log_dir=tmp_path / "runs", sim="mujoco", init=shipped,
                                                        save_interval=1, override=("learner.fork_critic_warmup=3",)))
    warmup = json.loads((run_dir / "config.json").read_text())["learner"]["fork_critic_warmup"]
    assert warmup == 3 and runner.alg.critic_warmup_left == warmup - 2
    forked = torch.load(run_dir / "model_1.pt", weights_only=False)
    for name, value in src["actor_state_dict"].items():
        assert torch.equal(forked["actor_state_dict"][name], value), name
    assert forked["critic_warmup_left"] == warmup - 2


@pytest.mark.slow
def test_resume_keeps_each_robots_terrain_level(tmp_path):
    """Rough runs store every robot's terrain level; --resume puts them back instead of starting the terrain
    curriculum again."""
    args = dict(num_envs=4, max_iterations=1, export=False, quiet=True, log_dir=tmp_path, sim="mujoco",
                task="rough", save_interval=1)
    run_dir, runner = train_cli.run(train_cli.TrainArgs(**args))
    levels = torch.tensor([3, 0, 5, 1])
    runner.env.ground.curriculum.restore(levels)
    runner.save(str(run_dir / "model_7.pt"))
    assert torch.load(run_dir / "model_7.pt", weights_only=False)["infos"]["terrain_levels"] == [3, 0, 5, 1]
    _, resumed = train_cli.run(train_cli.TrainArgs(**{**args, "max_iterations": 1},
                                                   resume=run_dir / "model_7.pt"))
    # an episode that ends in the resumed iteration moves its robot one level at most; a fresh curriculum would
    # have every robot on level 0
    assert (resumed.env.ground.curriculum.levels.cpu() - levels).abs().max() <= 1


def test_resume_refuses_contrastive_heads_built_for_another_target(trained, capsys):
    """The default target leaves the actor observation out; a run trained that way resumed with it in would need
    heads of another shape: one line naming the override that matches the checkpoint."""
    first, _ = trained
    one_line_error(capsys, train_cli.main(["--num-envs", "4", "--max-iterations", "1", "--no-export", "--quiet",
                                           "--log-dir", str(first.parent), "--resume", str(first / "model_1.pt"),
                                           "--override", "learner.contrast.target_actor_obs=true"]),
                   "learner.contrast.target_actor_obs=false")


@pytest.mark.slow
def test_what_a_user_reads(tmp_path):
    """A run ends with its directory and the exported files, third-party warnings summarised in one line; neither
    a run nor its --resume prints the networks."""
    import subprocess
    import sys

    common = [sys.executable, "-m", "train.train", "--num-envs", "4", "--sim", "mujoco", "--max-iterations", "1",
              "--save-interval", "1", "--log-dir", str(tmp_path)]
    out = subprocess.run(common, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.strip().splitlines()
    ends = [line.split(":")[0].strip() for line in lines[-5:]]
    assert ends == ["run directory", "torchscript", "json", "onnx", "onnx_data"], lines[-5:]
    assert all(tmp_path in __import__("pathlib").Path(line.split(": ", 1)[1]).parents for line in lines[-5:])
    noise = [line for line in out.stderr.splitlines() if "Warning" in line and "cra-train:" not in line
             and "Warp CUDA warning" not in line]
    assert not noise and out.stderr.count("third-party warnings") <= 1, out.stderr
    assert "Actor Model" not in out.stdout and "GRU(" not in out.stdout
    resumed = subprocess.run([*common, "--resume", str(tmp_path), "--no-export"], capture_output=True, text=True,
                             timeout=600)
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert "Actor Model" not in resumed.stdout and "GRU(" not in resumed.stdout, resumed.stdout
    assert resumed.stdout.strip().splitlines()[-1].startswith("run directory:")


def test_terrain_levels_carry_over_only_onto_the_same_tiles():
    """A checkpoint's terrain levels index its own tile layout: --init/--resume restores them only when rough.*
    (but for the seed, which the run sets) is the same. rough_walk_v0 was saved on today's default tiles."""
    from cra_warp.config_io import to_data
    from cra_warp.learning.checkpoint import read_checkpoint
    from cra_warp.terrain import TerrainConfig
    from train.train import _tiles

    stored = read_checkpoint("robots/adam_lite/policies/rough_walk_v0/checkpoint.pt")["infos"]["config"]["env"]
    assert _tiles(stored.get("rough")) == _tiles(to_data(TerrainConfig(seed=7)))
    assert _tiles(None) == _tiles(to_data(TerrainConfig()))
    assert _tiles(stored.get("rough")) != _tiles(to_data(TerrainConfig(num_cols=8)))
    assert _tiles(None) != _tiles(to_data(TerrainConfig(step_height=(0.02, 0.35))))


@pytest.mark.slow
def test_cra_train_reads_the_mirror_maps_and_the_action_bounds_off_the_task(tmp_path):
    import glob
    import subprocess
    import sys

    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    subprocess.run([sys.executable, "-m", "train.train", "--sim", "mujoco", "--num-envs", "8", "--mini-batches", "2",
                    "--max-iterations", "2", "--log-dir", str(tmp_path), "--no-export", "--quiet",
                    "--override", "learner.symmetry_weight=0.5", "learner.action_bound_weight=0.1"],
                   check=True, capture_output=True)
    ea = EventAccumulator(glob.glob(str(tmp_path / "*"))[0])
    ea.Reload()
    values = [e.value for e in ea.Scalars("Loss/mirror")]
    assert len(values) == 2 and all(v > 0 for v in values)
    assert len(ea.Scalars("Loss/action_bound")) == 2  # a fresh policy's means sit inside the clip: the loss is 0


def test_an_unknown_robot_is_one_line_naming_it_and_the_known_ones(capsys, tmp_path):
    with pytest.raises(ValueError, match=r"^LocoConfig.robot: unknown robot 'g1' \(known: adam_lite\)$"):
        LocoConfig(robot="g1")
    from train import train as train_cli

    one_line_error(capsys, train_cli.main(["--override", "robot=g1", "--log-dir", str(tmp_path)]), "unknown robot 'g1'",
                   "adam_lite")

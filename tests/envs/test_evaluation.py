"""The evaluation library (envs/evaluation.py): success bookkeeping, a deployment on the evaluation course, the
statistics (its command line, cra-eval: tests/train/test_evaluate.py)."""

import pytest
import torch

from envs import evaluation


def test_tally_success_needs_reaching_before_any_fall():
    t = evaluation.Tally(4, "cpu")
    on = torch.ones(4, dtype=torch.bool)
    # robot 0 falls then reaches; 1 reaches then falls; 2 reaches after its trial ended; 3 never reaches
    t.update(torch.tensor([0, 1, 0, 0]).bool(), torch.tensor([1, 0, 0, 0]).bool(), on)
    t.update(torch.tensor([1, 0, 0, 0]).bool(), torch.tensor([0, 1, 0, 0]).bool(), on)
    t.update(torch.tensor([0, 0, 1, 0]).bool(), torch.zeros(4, dtype=torch.bool), torch.tensor([1, 1, 0, 1]).bool())
    assert t.succeeded.tolist() == [False, True, False, False]
    assert t.fell.tolist() == [True, False, False, False]


def test_tally_keeps_how_far_along_its_way_a_robot_first_fell():
    t = evaluation.Tally(3, "cpu")
    on = torch.ones(3, dtype=torch.bool)
    t.update(torch.zeros(3, dtype=torch.bool), torch.tensor([1, 0, 0]).bool(), on, torch.tensor([0.3, 0.5, 0.7]))
    t.update(torch.tensor([0, 1, 0]).bool(), torch.tensor([1, 0, 1]).bool(), on, torch.tensor([0.0, 0.9, 1.1]))
    t.update(torch.zeros(3, dtype=torch.bool), torch.tensor([0, 1, 0]).bool(), on, torch.tensor([0.0, 2.0, 0.0]))
    # robot 0 where it first fell, robot 2 where it fell, robot 1 reached first: its later fall is not kept
    assert t.fell_at[[0, 2]].tolist() == pytest.approx([0.3, 1.1]) and t.fell_at[1].isnan()


@pytest.fixture(scope="module")
def course_env():
    """One robot per level on the stair ascent and the slope descent of the evaluation course."""
    from cra_warp.terrain.course import EvalCourseConfig
    from envs.loco_config import DomainRandConfig, LocoConfig
    from envs.locomotion import LocoEnv

    return LocoEnv(LocoConfig(num_envs=14, terrain="eval", course=EvalCourseConfig(kinds=("stairs_ascend",
                              "slope_descend")), randomization=DomainRandConfig(enabled=False), episode_length_s=1e6))


def test_robots_spawn_at_their_starts_facing_their_targets(course_env):
    from cra_warp.rotations import yaw

    env, dep = course_env, course_env.ground.deployment
    assert torch.allclose(env.root_pos[:, :2], dep.start[:, :2], atol=1e-3)
    height = env.root_pos[:, 2] - dep.start[:, 2]
    assert torch.allclose(height, torch.full_like(height, env.robot.base_height + 0.01), atol=0.02)
    to_target = dep.target[:, :2] - dep.start[:, :2]
    assert torch.allclose(yaw(env.world.root_quat), torch.atan2(to_target[:, 1], to_target[:, 0]), atol=1e-3)
    # progress: none at the start, the whole way at the target, half of it halfway
    assert dep.progress(dep.start).abs().max() < 1e-5
    assert torch.allclose(dep.progress(dep.target), to_target.norm(dim=-1))
    assert torch.allclose(dep.progress((dep.start + dep.target) / 2), to_target.norm(dim=-1) / 2)


def test_a_standing_robot_reaches_only_a_target_it_stands_on(course_env):
    """The scripted stand never walks 3.75 m, and never falls on the course's flat start rims and top platforms;
    with a target radius wider than the start-target distance every one of them succeeds."""
    env = course_env

    def stand(obs, dones):
        return env.stand_actions()

    far = evaluation.evaluate(env, stand, speed=8.0)   # short trials: 2 x 3.75 m / 8 m/s + 2 s
    assert not far.succeeded.any() and not far.fell.any()
    dep = env.ground.deployment
    env.ground.deployment = dep._replace(radius=4.0)
    try:
        near = evaluation.evaluate(env, stand, speed=8.0)
    finally:
        env.ground.deployment = dep
    assert near.succeeded.all() and not near.fell.any()


def test_a_deployment_ends_once_every_robot_is_decided(course_env, monkeypatch):
    """Robots that all reached their targets cannot change their outcome: the deployment stops there instead of
    running to the end of its longest trial."""
    env, dep = course_env, course_env.ground.deployment
    calls, step = [], env.step
    monkeypatch.setattr(env, "step", lambda actions: calls.append(1) or step(actions))
    env.ground.deployment = dep._replace(radius=4.0)
    try:
        near = evaluation.evaluate(env, lambda obs, dones: env.stand_actions(), speed=8.0)
    finally:
        env.ground.deployment = dep
    assert near.succeeded.all()
    assert len(calls) == 1 < int(evaluation.trial_steps(dep, 8.0, env.dt).max())


def test_commands_point_at_the_target(course_env):
    env, dep = course_env, course_env.ground.deployment
    to_target = dep.target[:, :2] - env.root_pos[:, :2]
    env.hold_commands(torch.tensor([0.4, 0.0]).expand(env.num_envs, 2), torch.atan2(to_target[:, 1], to_target[:, 0]))
    assert torch.equal(env.commands[:, 0], torch.full((env.num_envs,), 0.4))
    assert env.commands[:, 2].abs().max() < 0.1     # already facing the target: (almost) no turn commanded
    assert torch.isinf(env.command_timer).all()     # no resampling while held
    layout = env.layout["command"]
    assert torch.allclose(env.obs["policy"][:, layout][:, 0], 0.4 * env.cfg.obs.command_scale[0] * torch.ones(14))


class _AlternatingFeet:
    """A stand-in env for flat_trial's arithmetic: 2 robots walking in place at 0.3 m/s, each foot in swing for
    5 of every 20 steps (left first, right 10 steps later): 2 touchdowns per 0.4 s cycle, one foot down 50%."""

    num_envs, device, dt, num_actions = 2, "cpu", 0.02, 1

    def __init__(self):
        self.k = 0
        self.base_lin_vel = torch.tensor([[0.3, 0.0, 0.0]]).repeat(2, 1)
        self.contact = torch.ones(2, 2, dtype=torch.bool)
        self.first_contact = torch.zeros(2, 2, dtype=torch.bool)
        self.base_ang_vel, self.commands = torch.zeros(2, 3), torch.zeros(2, 3)

    def reset_idx(self, ids):
        self.k = 0

    def hold_commands(self, lin_vel_xy, heading, refresh, yaw_rate=0.0):
        self.commands[:, :2] = lin_vel_xy

    def get_observations(self):
        return None

    def step(self, actions):
        self.k += 1
        last = self.contact.clone()
        phase = self.k % 20
        self.contact = torch.tensor([[not (0 <= phase < 5), not (10 <= phase < 15)]]).repeat(2, 1)
        self.first_contact = self.contact & ~last
        return None, None, torch.zeros(2, dtype=torch.long), {"time_outs": torch.zeros(2, dtype=torch.bool)}


def test_flat_trial_counts_touchdowns_and_single_support():
    r = evaluation.flat_trial(_AlternatingFeet(), lambda obs, dones: None, 0.5, 10.0)
    assert r["success_rate"] == 1.0 and r["tracking_error"] == pytest.approx(0.2)
    assert r["mean_error"] == pytest.approx(0.2, abs=1e-5) and r["tracking_error_y"] == 0.0
    assert r["offset"] == pytest.approx(-0.2, abs=1e-5)
    assert r["touchdowns_per_s"] == pytest.approx(5.0, rel=0.02)     # 2 per 20 steps of 0.02 s
    assert r["single_support"] == pytest.approx(0.5, abs=0.01)


def test_seed_means_and_csv(tmp_path):
    """Two seeds of one method: each cell's mean and (population) std over them, in the CSV beside the records."""
    import csv

    recs = [{"policy": f"s{s}/model.pt", "method": "ours", "train_seed": s, "speed": 0.5, "kind": "uneven",
             "level": lv, "difficulty": 0.1 * lv, "robots": 4, "success_rate": rate, "fall_rate": 1 - rate}
            for s, rates in ((1, (1.0, 0.5)), (2, (0.5, 0.25))) for lv, rate in enumerate(rates)]
    means = evaluation.seed_means(recs)
    assert [(m["level"], m["seeds"]) for m in means] == [(0, 2), (1, 2)]
    # level 0: 4 + 2 of 8 robots over both seeds
    assert means[0]["robots"] == 8 and means[0]["success_ci95"] == pytest.approx(evaluation.wilson(6, 8))
    assert means[0]["success_mean"] == pytest.approx(0.75) and means[0]["success_std"] == pytest.approx(0.25)
    assert means[1]["success_mean"] == pytest.approx(0.375) and means[1]["success_std"] == pytest.approx(0.125)
    evaluation.write_csv(tmp_path / "eval.csv", recs)
    rows = list(csv.DictReader((tmp_path / "eval.csv").open()))
    assert [r["table"] for r in rows] == ["record"] * 4 + ["seed_mean"] * 2
    assert float(rows[4]["success_mean"]) == pytest.approx(0.75) and rows[0]["train_seed"] == "1"


def test_method_summary_averages_each_seed_then_over_seeds():
    """Seed 1: success 0.75 over its two cells, seed 2: 0.375; the ablation record does not count."""
    recs = [{"policy": f"s{s}/model.pt", "method": "ours", "speed": 0.5, "kind": "uneven", "level": lv,
             "success_rate": rate, "fall_rate": 1 - rate, "protocol": "speed_sweep"}
            for s, rates in ((1, (1.0, 0.5)), (2, (0.5, 0.25))) for lv, rate in enumerate(rates)]
    recs.append({**recs[0], "protocol": "ablation", "success_rate": 0.0, "fall_rate": 1.0})
    row = evaluation.method_summary(recs)["ours"]
    assert row["seeds"] == 2 and row["success_rate"]["per_seed"] == pytest.approx([0.75, 0.375])
    assert row["success_rate"]["mean"] == pytest.approx(0.5625) and row["success_rate"]["std"] == pytest.approx(0.1875)
    assert row["fall_rate"]["mean"] == pytest.approx(0.4375)


def test_the_course_steers_a_policy_trained_on_yaw_rate_commands(course_env):
    """Without heading mode the yaw-rate command is the policy's own input: the evaluator still turns every robot
    towards its target through it (here a target to each robot's left: a positive, anticlockwise command)."""
    from cra_warp.rotations import yaw

    env, dep = course_env, course_env.ground.deployment
    left = yaw(env.world.root_quat) + torch.pi / 2
    aside = dep.start[:, :2] + 3.0 * torch.stack([torch.cos(left), torch.sin(left)], -1)
    seen = []

    def stand(obs, dones):
        seen.append(env.commands[:, 2].clone())
        return env.stand_actions()

    heading_mode, env.cfg.commands.heading_mode = env.cfg.commands.heading_mode, False
    env.ground.deployment = dep._replace(target=torch.cat([aside, dep.target[:, 2:]], -1))
    try:
        evaluation.evaluate(env, stand, speed=8.0)
    finally:
        env.cfg.commands.heading_mode = heading_mode
        env.ground.deployment = dep
    assert len(seen) > 10 and all((c > 0.2).all() for c in seen)


def test_wilson_intervals_match_the_published_values_and_tell_small_cells_apart():
    """The 95% Wilson score interval (Newcombe 1998, table I: 0/10 -> 0-0.2775, 1/29 -> 0.0061-0.1718,
    81/263 -> 0.2553-0.3662), and what it means for a 10-robot course cell: 30% and 10% overlap."""
    assert evaluation.wilson(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert evaluation.wilson(1, 29) == pytest.approx((0.0061, 0.1718), abs=1e-4)
    assert evaluation.wilson(81, 263) == pytest.approx((0.2553, 0.3662), abs=1e-4)
    assert evaluation.wilson(3, 0) is None
    lo30, _ = evaluation.wilson(3, 10)
    _, hi10 = evaluation.wilson(1, 10)
    assert lo30 < hi10
    rec = evaluation.with_interval({"success_rate": 0.3, "robots": 10})
    assert rec["successes"] == 3 and rec["success_ci95"] == pytest.approx(list(evaluation.wilson(3, 10)))
    assert "success_ci95" not in evaluation.with_interval({"success_rate": 0.3})   # no robot count, no interval


def test_the_course_records_how_a_robot_walks_on_its_way(course_env):
    """The scripted stand on the course: no forward speed, both feet down (no swing height), the clock at its
    nominal rate (zero gait actions) and an upright pelvis, as measured while the robots are on their way."""
    env = course_env
    tally = evaluation.evaluate(env, lambda obs, dones: env.stand_actions(), speed=8.0)
    every = torch.ones(env.num_envs, dtype=torch.bool)
    gait = tally.gait(every)
    assert set(gait) == set(evaluation.Tally.GAIT) and (tally.gait_steps > 0).all()
    assert gait["gait_rate"] == pytest.approx(1.0)
    assert abs(gait["forward_speed"]) < 0.05 and gait["swing_height"] == pytest.approx(0.0, abs=1e-3)
    assert abs(gait["pitch_deg"]) < 10.0
    assert tally.gait(every, uses_clock=False)["gait_rate"] is None
    assert all(v is None for v in tally.gait(torch.zeros_like(every)).values())
    records = evaluation.course_records(env, tally, "stand", 8.0, 1)
    assert all(r["fell_at_m"] is None for r in records if r["fall_rate"] == 0)

"""The locomotion task on the real batched world: layout, randomisation, pushes, terminations, the VecEnv contract."""

import math

import pytest
import torch

from tests.conftest import DEVICE
from envs.loco_config import DomainRandConfig, LocoConfig, ObsConfig
from envs.locomotion import LocoEnv
from robots.adam_lite import ADAM_LITE

J = ADAM_LITE.num_joints


@pytest.fixture(scope="module")
def env():
    # pushes and external forces off: these tests poke the state themselves
    rd = DomainRandConfig(push_interval=1e9, force_max=0.0)
    return LocoEnv(LocoConfig(num_envs=8, device=DEVICE, obs=ObsConfig(noise=False), randomization=rd))


def test_actor_observation_layout(env):
    env.reset_idx(torch.arange(env.num_envs, device=env.device))
    env.commands[:] = torch.tensor([0.5, -0.2, 0.3], device=env.device)
    obs, *_ = env.step(torch.zeros(env.num_envs, env.num_actions, device=env.device))
    o, L = obs["policy"], env.layout
    assert o.shape == (env.num_envs, 84) and env.num_actions == 26
    assert list(L) == ["command", "gravity", "joint_pos", "joint_vel", "prev_action", "ang_vel", "avg_ang_speed",
                       "gait_phase"]
    assert torch.allclose(o[:, L["gravity"]], torch.tensor([0.0, 0.0, -1.0], device=env.device), atol=0.05)  # upright
    assert torch.allclose(o[:, L["command"]], env.commands * torch.tensor([2.0, 2.0, 0.25], device=env.device))
    assert o[:, L["joint_pos"]].abs().max() < 0.2                      # near the reference pose
    assert torch.equal(o[:, L["gait_phase"]], env.clock.phase_obs)
    a = torch.zeros(env.num_envs, env.num_actions, device=env.device)
    a[:, 3], a[:, 24] = 0.2, -0.5
    obs, *_ = env.step(a)
    assert torch.equal(obs["policy"][:, L["prev_action"]], a)
    assert obs["privileged"].shape == (env.num_envs, 179 + 2 * J)  # + the PD gain scales
    assert torch.allclose(obs["privileged"][:, env.priv_layout["actor"]], obs["policy"])  # noise-free copy
    p, P = obs["privileged"], env.priv_layout                  # each privileged slice holds what it names
    assert torch.allclose(p[:, P["base_lin_vel"]], env.base_lin_vel * env.cfg.obs.lin_vel_scale)
    assert torch.equal(p[:, P["foot_contact"]], env.contact.float())
    assert torch.allclose(p[:, P["foot_forces"]], (env.foot_forces / env.robot_weight).flatten(1))
    for name in ("motor_strength", "kp_scale", "kd_scale", "com_offset"):
        assert torch.allclose(p[:, P[name]], getattr(env, name)), name
    assert torch.allclose(p[:, P["friction"]], env.friction.unsqueeze(-1))
    assert obs["height_map"].shape == (env.num_envs, 1, 17, 11)
    assert torch.allclose(obs["height_map"], -env.root_pos[:, 2].view(-1, 1, 1, 1).expand(-1, 1, 17, 11))


def test_clock_free_variant_has_79_inputs_and_23_actions():
    e = LocoEnv(LocoConfig(num_envs=2, device=DEVICE, variant="clock_free"))
    obs = e.get_observations()
    assert e.num_actions == J and obs["policy"].shape == (2, 79) and "gait_phase" not in e.layout
    _, rew, *_ = e.step(torch.zeros(2, J, device=e.device))
    assert torch.isfinite(rew).all()


def test_randomised_rotor_inertia_reaches_the_solver():
    rd = DomainRandConfig(armature_scale=(0.5, 2.0), push_interval=1e9, force_max=0.0)
    e = LocoEnv(LocoConfig(num_envs=4, device=DEVICE, randomization=rd))
    scale = e.world.joint_armature / ADAM_LITE.armature
    assert scale.min() >= 0.5 - 1e-5 and scale.max() <= 2.0 + 1e-5 and scale.std() > 0.2
    solver = e.world.solver.mjw_model.dof_armature.numpy()  # [N, base dofs + joints]
    assert torch.allclose(torch.as_tensor(solver[:, 6:]), e.world.joint_armature.cpu(), rtol=1e-6)
    with pytest.raises(ValueError, match="randomization.armature_scale must be a range"):
        DomainRandConfig(armature_scale=(2.0, 1.0))


def test_randomised_parameters_in_range_and_in_the_sim(env):
    rd = env.cfg.randomization
    assert (env.motor_strength >= rd.motor_strength[0]).all() and (env.motor_strength <= rd.motor_strength[1]).all()
    assert (env.mass_offset.abs() <= 0.05).all() and env.mass_offset.std() > 0
    assert (env.com_offset.abs() <= rd.base_com_offset).all()
    assert (env.friction >= rd.friction[0]).all() and (env.friction <= rd.friction[1]).all()
    kp, kd = torch.tensor(ADAM_LITE.kp, device=env.device), torch.tensor(ADAM_LITE.kd, device=env.device)
    assert torch.allclose(env.world.joint_kp, env.motor_strength * env.kp_scale * kp)  # MuJoCo Warp's actuators
    assert torch.allclose(env.world.joint_kd, env.motor_strength * env.kd_scale * kd)
    assert env.kp_scale.min() >= rd.kp_scale[0] and env.kp_scale.max() <= rd.kp_scale[1] and env.kp_scale.std() > 0
    P = env.priv_layout
    priv = env.obs["privileged"]
    assert torch.equal(priv[:, P["kp_scale"]], env.kp_scale) and torch.equal(priv[:, P["kd_scale"]], env.kd_scale)
    heavier = env.mass_offset.argmax()
    assert env.world.body_mass[heavier].sum() > env.world.body_mass[env.mass_offset.argmin()].sum()
    mj_mass = env.world.solver.mjw_model.body_mass.numpy()  # [N, bodies + world body]
    assert mj_mass[int(heavier)].sum() == pytest.approx(float(env.world.body_mass[heavier].sum()), rel=1e-5)


def test_push_changes_base_velocity_by_the_sampled_amount():
    rd = DomainRandConfig(push_interval=1e9, push_max_vel=0.8, force_max=0.0)
    e = LocoEnv(LocoConfig(num_envs=4, device=DEVICE, randomization=rd))
    v0 = e.world.root_lin_vel.clone()
    e.push_timer[1] = 0.0  # robot 1 is due
    e._perturb()
    dv = e.world.root_lin_vel - v0
    assert dv[[0, 2, 3]].abs().max() == 0
    assert 0 < dv[1, :2].norm() <= 0.8 and dv[1, 2] == 0
    assert e.push_timer[1] == pytest.approx(rd.push_interval)


def test_time_outs_and_falls(env):
    env.reset_idx(torch.arange(env.num_envs, device=env.device))
    env.episode_length_buf[1] = env.max_episode_length - 1
    q = env.world.joint_q[2].clone()
    q[2] = 0.3  # pelvis 30 cm above the ground: fallen
    env.world.reset(torch.tensor([2], device=env.device), joint_q=q.unsqueeze(0))
    _, _, dones, extras = env.step(torch.zeros(env.num_envs, env.num_actions, device=env.device))
    assert dones.tolist() == [0, 1, 1, 0, 0, 0, 0, 0]
    assert extras["time_outs"].tolist() == [False, True, False, False, False, False, False, False]
    assert env.episode_length_buf[1] == 0 and env.root_pos[2, 2] > 0.8  # both reset to a stand


def test_a_robot_whose_pelvis_is_past_a_35_cm_riser_has_not_fallen_but_a_low_or_seated_one_has():
    """On the course's 35 cm flight: soles on the rim, legs swung back so the pelvis (0.78 m above the rim) is
    over the first step. Measured from the ground under the pelvis (the old rule) it is 0.43 m up, under the
    fall height: "lowest" measures from the rim under the soles and keeps it. Lowered to 0.35 m above the rim it
    has fallen; at 0.50 m (0.15 m above the step under it: seated, feet a step below) too."""
    from cra_warp.sim.config import FREE_Q
    from cra_warp.terrain.course import EvalCourseConfig

    env = LocoEnv(LocoConfig(num_envs=7, device=DEVICE, terrain="eval", obs=ObsConfig(noise=False),
                             course=EvalCourseConfig(kinds=("stairs_ascend",)),
                             randomization=DomainRandConfig(enabled=False)))
    env.reset_idx(torch.arange(7, device=env.device))
    top, rim = 6, float(env.ground.deployment.start[6, 2])
    q = env.world.joint_q[top].clone()
    for side in ("Left", "Right"):
        q[FREE_Q + env.robot.joint_names.index(f"hipPitch_{side}")] = 0.35   # legs back
    q[0] += 0.30

    def fallen(pelvis_above_rim: float, rule: str) -> bool:
        q[2] = rim + pelvis_above_rim
        env.world.reset(torch.tensor([top], device=env.device), joint_q=q.unsqueeze(0))
        env.cfg.fall_ground = rule
        env._refresh()
        return bool(env._terminations()[0][top])

    fallen(0.78, "lowest")  # puts the robot in the pose
    # the pose is what the docstring says: the pelvis over the 35 cm step, both soles behind its riser
    assert float(env.ground_under_base[top]) == pytest.approx(rim + 0.35, abs=1e-3)
    assert (env.sole_height - (env.sole_centres[..., 2] - rim)).abs()[top].max() < 1e-3
    assert not fallen(0.78, "lowest") and fallen(0.78, "base")
    assert fallen(0.35, "lowest") and fallen(0.35, "base")
    assert fallen(0.50, "lowest")


def test_nan_in_one_world_resets_that_world_only(env):
    env.reset_idx(torch.arange(env.num_envs, device=env.device))
    for _ in range(3):
        env.step(torch.zeros(env.num_envs, env.num_actions, device=env.device))
    before = env.nonfinite_resets
    lengths = env.episode_length_buf.clone()
    env.world.joint_qd[3, 10] = float("nan")
    obs, rew, dones, extras = env.step(torch.zeros(env.num_envs, env.num_actions, device=env.device))
    assert dones[3] == 1 and dones.sum() == 1
    assert env.nonfinite_resets == before + 1 and extras["log"]["/nonfinite_resets"] == before + 1
    assert rew[3] == 0 and torch.isfinite(rew).all()
    assert all(torch.isfinite(v).all() for v in obs.values())
    assert torch.equal(env.episode_length_buf[[0, 1, 2, 4]], lengths[[0, 1, 2, 4]] + 1)
    # a non-finite action never reaches the sim
    a = torch.zeros(env.num_envs, env.num_actions, device=env.device)
    a[5, 0] = float("inf")
    env.step(a)
    assert torch.isfinite(env.world.joint_target).all() and env.actions[5].abs().max() == 0


@pytest.mark.slow
def test_scripted_stand_keeps_robots_up_where_zero_actions_fall():
    # Nominal physics. The robot's ankle PD (pitch kp 130) cannot hold the reference pose: a zero action falls
    # after ~3.4 s; the scripted stand (cra_warp.stand) holds it through the same PD law.
    env = LocoEnv(LocoConfig(num_envs=4, device=DEVICE, randomization=DomainRandConfig(enabled=False)))

    def falls(agent):
        env.reset_idx(torch.arange(env.num_envs, device=env.device))
        fell = torch.zeros(env.num_envs, dtype=torch.bool, device=env.device)
        for _ in range(400):
            _, _, dones, extras = env.step(agent())
            fell |= dones.bool() & ~extras["time_outs"]
        return fell

    assert falls(lambda: torch.zeros(env.num_envs, env.num_actions, device=env.device)).all()
    assert not falls(env.stand_actions).any()


def test_rsl_rl_runner_contract(env, tmp_path):
    """One learning iteration of rsl-rl's own OnPolicyRunner on this env, with plain MLPs."""
    from rsl_rl.runners import OnPolicyRunner

    mlp = {"class_name": "MLPModel", "hidden_dims": [32], "activation": "elu"}
    cfg = {"num_steps_per_env": 4, "save_interval": 100, "obs_groups": {"actor": ["policy"],
                                                                        "critic": ["policy", "privileged"]},
           "actor": {**mlp, "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0}},
           "critic": mlp, "algorithm": {"class_name": "PPO", "num_learning_epochs": 1, "num_mini_batches": 2},
           "run_name": "contract", "logger": "tensorboard"}
    runner = OnPolicyRunner(env, cfg, log_dir=None, device=str(env.device))
    runner.learn(1)
    assert runner.current_learning_iteration == 0
    assert isinstance(env.max_episode_length, int) and env.episode_length_buf.shape == (env.num_envs,)
    env.reset_idx(torch.tensor([0], device=env.device))  # buffers stay writable outside inference mode



def test_privileged_com_is_the_mass_weighted_link_coms(env):
    """Moving world 0's base CoM 5 cm forward (base frame) moves the whole-body CoM by m_base / M x 5 cm."""
    ids = torch.tensor([0, 1], device=env.device)
    env.reset_idx(ids)  # draws random physics: the offsets are set below
    env.world.set_base_com_offset(ids, torch.zeros(2, 3, device=env.device))
    env.world.commit_physics()
    com0 = env._observations()["privileged"][:, env.priv_layout["com_pos"]]
    env.world.set_base_com_offset(torch.tensor([0], device=env.device),
                                  torch.tensor([[0.05, 0.0, 0.0]], device=env.device))
    env.world.commit_physics()
    com1 = env._observations()["privileged"][:, env.priv_layout["com_pos"]]
    m = env.world.body_mass[0]
    assert com1[0, 0] - com0[0, 0] == pytest.approx(0.05 * float(m[0] / m.sum()), rel=1e-3)
    assert torch.allclose(com1[1], com0[1])
    assert -0.05 < com1[0, 2] < 0.25  # above the pelvis origin: the torso and arms outweigh the legs' drop


def test_heading_mode_observed_yaw_command_is_the_rewarded_one():
    env = LocoEnv(LocoConfig(num_envs=8, device=DEVICE, obs=ObsConfig(noise=False)))
    scale = env.cfg.obs.command_scale[2]
    rewarded = []
    rewards = env._rewards

    def spy():
        rewarded.append(env.commands[:, 2].clone())
        return rewards()

    env._rewards = spy
    env.command_timer[:] = 0.0  # every robot draws new commands at the end of the next step
    observed = []
    for _ in range(3):
        obs, *_ = env.step(torch.zeros(env.num_envs, env.num_actions, device=env.device))
        observed.append(obs["policy"][:, env.layout["command"]][:, 2] / scale)
    for seen, paid in zip(observed[:-1], rewarded[1:]):
        assert torch.allclose(seen, paid, atol=1e-6)
    # the freshly drawn yaw rate was replaced by the heading controller's before anyone saw it
    from cra_warp.rotations import wrap_angle, yaw
    c = env.cfg.commands
    moving = env.commands[:, :2].norm(dim=-1) > 0
    want = (c.heading_gain * wrap_angle(env.heading - yaw(env.world.root_quat))).clamp(*c.ang_vel_yaw)
    assert torch.allclose(observed[-1], torch.where(moving, want, 0.0), atol=1e-6)


@pytest.mark.parametrize("rule", ["path", "reach", "reach_upright"])
def test_an_early_fall_is_demoted_by_the_whole_episode_distance(rule):
    """Walking 0.6 m in 1 s under a 1 m/s command is more than half of what that second asked, but far less than
    half of what the 20 s episode asked: legged_gym's rule demotes it, under either promotion rule."""
    env = LocoEnv(LocoConfig(num_envs=2, device=DEVICE, terrain="rough", terrain_curriculum=rule))
    cur = env.ground.curriculum
    assert cur.rule == rule
    cur.levels[:] = 2
    env.episode_length_buf[:] = int(1.0 / env.dt)
    env.commanded_dist[:] = 1.0
    env.path.reset(torch.arange(2), env.root_pos[:, :2] - torch.tensor([0.6, 0.0], device=env.device))
    env.reset_idx(torch.tensor([0], device=env.device))
    assert cur.levels.tolist() == [1, 2]
    with pytest.raises(ValueError, match="terrain_curriculum must be one of"):
        LocoConfig(terrain_curriculum="displacement")


def test_a_fall_demotes_under_the_reach_upright_rule_and_a_time_out_does_not():
    """Two robots 2.5 m out of their tiles' centres (under "reach" both would hold their level): the one that
    falls is demoted, the one whose time runs out stays."""
    env = LocoEnv(LocoConfig(num_envs=2, device=DEVICE, terrain="rough", terrain_curriculum="reach_upright"))
    cur = env.ground.curriculum
    env.restore_terrain_levels(torch.tensor([3, 3], device=env.device))
    env.episode_length_buf[:] = env.max_episode_length - 1
    env.commanded_dist[:] = 10.0
    env.path.reach[:] = 2.5
    q = env.world.joint_q[0].clone()
    q[2] = env.ground_under_base[0] + 0.3  # pelvis 30 cm above the ground: fallen
    env.world.reset(torch.tensor([0], device=env.device), joint_q=q.unsqueeze(0))
    _, _, dones, extras = env.step(torch.zeros(env.num_envs, env.num_actions, device=env.device))
    assert dones.tolist() == [1, 1] and extras["time_outs"].tolist() == [False, True]
    assert cur.levels.tolist() == [2, 3]


def test_restored_terrain_levels_respawn_every_robot_on_its_levels_tile_unjudged():
    """A resumed run's robots start again on their saved levels' tiles at once, and the episodes cut short on the
    tiles the env was built on (level 0, easy to leave) promote nobody."""
    env = LocoEnv(LocoConfig(num_envs=6, device=DEVICE, terrain="rough", terrain_curriculum="reach"))
    cur = env.ground.curriculum
    # every robot has left its level-0 tile: judged at a reset, each would be promoted
    env.episode_length_buf[:] = 100
    env.path.reach[:] = 10.0
    saved = torch.tensor([3, 5, 1, 7, 2, 4], device=env.device)
    env.restore_terrain_levels(saved)
    assert cur.levels.tolist() == saved.tolist()
    xy = env.root_pos[:, :2]
    assert torch.allclose(xy, cur.tile_origins[saved, cur.cols][:, :2], atol=1e-3)
    assert (env.episode_length_buf == 0).all() and (env.path.reach == 0).all()
    assert torch.isfinite(env.obs["policy"]).all()


def test_robots_on_pits_are_told_to_walk_up_a_fall_line():
    """With commands.pit_fall_line, robots on the tiles they climb out of get forward-only commands in
    pit_lin_vel_x and a heading along a tile axis, pointing away from the tile centre once they are off it; the
    others keep their random commands."""
    from cra_warp.sim import WorldConfig
    from envs.loco_config import CommandConfig

    cmds = CommandConfig(pit_fall_line=True, pit_lin_vel_x=(0.2, 0.4), standing_fraction=0.0)
    env = LocoEnv(LocoConfig(num_envs=12, device=DEVICE, terrain="rough", commands=cmds,
                             world=WorldConfig(backend="mujoco" if DEVICE == "cpu" else "newton")))
    pit = env.ground.climbing_envs()
    assert pit.any() and (~pit).any()
    for _ in range(3):
        env._resample_commands(torch.arange(env.num_envs, device=env.device))
        quarter = env.heading[pit] / (math.pi / 2)
        assert torch.allclose(quarter, quarter.round(), atol=1e-5)
        assert (env.commands[pit, 0] >= 0.2).all() and (env.commands[pit, 0] <= 0.4).all()
        assert (env.commands[pit, 1] == 0).all()
        assert not torch.allclose(env.heading[~pit] / (math.pi / 2), (env.heading[~pit] / (math.pi / 2)).round())
    # off the centre, the axis points from the tile centre towards the robot: up the face it stands on
    xy = env.ground.curriculum.origins[:, :2] + torch.tensor([-1.5, 0.4], device=env.device)
    up = env.ground.fall_line_heading(xy, torch.zeros(env.num_envs, dtype=torch.long, device=env.device))
    assert torch.allclose(up, torch.full_like(up, math.pi))
    off = LocoEnv(LocoConfig(num_envs=2, device=DEVICE))   # flat ground: no pits, nothing changes
    assert off.ground.climbing_envs() is None


def test_the_task_on_the_mujoco_backend_has_the_same_layout_and_stays_finite():
    from cra_warp.sim import WorldConfig

    cfgs = {b: LocoConfig(num_envs=4, world=WorldConfig(backend=b), obs=ObsConfig(noise=False)) for b in
            ("newton", "mujoco")}  # on the CPU, where both backends run
    envs = {b: LocoEnv(c) for b, c in cfgs.items()}
    obs = {b: e.get_observations() for b, e in envs.items()}
    for k in ("policy", "privileged", "height_map"):
        assert obs["newton"][k].shape == obs["mujoco"][k].shape
    # the same state at reset: the same observation up to float32 rounding (commands and DR draws are seeded alike)
    assert torch.allclose(obs["newton"]["policy"], obs["mujoco"]["policy"], atol=1e-4)
    e = envs["mujoco"]
    gen = torch.Generator().manual_seed(0)
    for _ in range(50):
        o, rew, dones, extras = e.step(torch.randn(4, e.num_actions, generator=gen))
        assert torch.isfinite(rew).all() and all(torch.isfinite(v).all() for v in o.values())


def test_reward_sum_clips_at_zero_skips_zero_weights_and_needs_the_clock_for_the_pattern(env):
    """The step reward is the weighted sum of the terms with a non-zero weight, clipped at 0 from below when
    only_positive_rewards is on (the default), times dt with scale_by_dt; a term with weight 0 is not computed; the
    clock-free variant has no contact-pattern term."""
    rw = env.cfg.rewards
    saved = dict(rw.weights), rw.only_positive_rewards, rw.scale_by_dt
    try:
        gen = torch.Generator().manual_seed(0)
        env.step(0.3 * torch.randn(env.num_envs, env.num_actions, generator=gen).to(env.device))
        rw.weights["feet_parallel"] = 0.0
        rw.weights["orientation"] = -1e4          # a large penalty: some totals go negative
        env.world.root_quat[:4] = torch.tensor([0.2, 0.0, 0.0, 0.98], device=env.device)  # tilted robots pay it
        env._refresh()
        rw.only_positive_rewards = False
        raw, terms = env._rewards()
        assert "feet_parallel" not in terms and "contact_pattern" in terms
        assert torch.allclose(raw, sum(terms.values()), atol=1e-4)
        assert (raw < 0).any()
        rw.only_positive_rewards = True
        clipped, _ = env._rewards()
        assert torch.allclose(clipped, raw.clamp(min=0.0), atol=1e-4)
        rw.scale_by_dt = True                     # every term a rate per second: x dt per step
        scaled, scaled_terms = env._rewards()
        assert torch.allclose(scaled, env.dt * clipped, atol=1e-5)
        assert all(torch.allclose(scaled_terms[k], env.dt * terms[k], atol=1e-5) for k in terms)
    finally:
        rw.scale_by_dt = saved[2]
        rw.weights.clear()
        rw.weights.update(saved[0])
        rw.only_positive_rewards = saved[1]
        env.reset_idx(torch.arange(env.num_envs, device=env.device))
    free = LocoEnv(LocoConfig(num_envs=2, device=DEVICE, variant="clock_free", obs=ObsConfig(noise=False)))
    free.step(torch.zeros(2, free.num_actions, device=free.device))
    assert "contact_pattern" not in free._rewards()[1]


def test_fixed_cycle_ignores_the_gait_actions():
    """fixed_cycle keeps the 26-dim action but its clock runs at 1 / T_cycle whatever the gait actions say."""
    e = LocoEnv(LocoConfig(num_envs=2, device=DEVICE, variant="fixed_cycle", obs=ObsConfig(noise=False)))
    assert e.num_actions == J + 3
    a = torch.zeros(2, e.num_actions, device=e.device)
    a[:, J:] = torch.tensor([[1.0, 0.5, -0.5], [-1.0, -0.3, 0.7]], device=e.device)
    for k in range(5):
        e.step(a)
        assert torch.allclose(e.clock.phase, torch.full((2,), (k + 1) * e.dt, device=e.device), atol=1e-6)
        assert (e.clock.deltas == 0).all()
    adaptive = LocoEnv(LocoConfig(num_envs=2, device=DEVICE, obs=ObsConfig(noise=False)))
    adaptive.step(a)
    assert not torch.allclose(adaptive.clock.phase[0], adaptive.clock.phase[1])  # the same actions do steer it


def test_actions_are_clipped_to_the_bounds_the_learner_is_told():
    """step() clips the joints to +-clip_joint_actions and the gait actions to +-1, the bounds LocoEnv.action_bounds
    hands the learner's action bound loss: a rate action of +-50 runs the clock at 1 +- alpha x beta_scale."""
    cfg = LocoConfig(num_envs=2, device=DEVICE, obs=ObsConfig(noise=False))
    cfg.gait.alpha, cfg.gait.beta_scale = 5.0, 0.1
    e = LocoEnv(cfg)
    assert e.action_bounds.tolist() == [cfg.clip_joint_actions] * J + [1.0] * 3
    a = torch.full((2, e.num_actions), 50.0, device=e.device)
    a[1] = -50.0
    e.step(a)
    assert torch.equal(e.actions[:, :J].abs(), torch.full((2, J), cfg.clip_joint_actions, device=e.device))
    assert torch.equal(e.actions[:, J:], torch.tensor([[1.0] * 3, [-1.0] * 3], device=e.device))
    assert torch.allclose(e.clock.phase, torch.tensor([1.5, 0.5], device=e.device) * e.dt, atol=1e-6)
    free = LocoEnv(LocoConfig(num_envs=1, device=DEVICE, variant="clock_free", obs=ObsConfig(noise=False)))
    assert free.action_bounds.tolist() == [cfg.clip_joint_actions] * J


def test_command_sampling_ranges_standing_share_and_minimum_speed(env):
    c = env.cfg.commands
    cmds = []
    for _ in range(200):
        env._resample_commands(torch.arange(env.num_envs, device=env.device))
        cmds.append(env.commands.clone())
    cmds = torch.cat(cmds)
    xy = cmds[:, :2].norm(dim=-1)
    standing = (cmds == 0).all(-1).float().mean()
    assert abs(standing - c.standing_fraction) < 0.04           # 1600 draws
    assert ((xy == 0) | (xy >= c.min_speed)).all() and (xy > 0).any()
    for k, (lo, hi) in enumerate((c.lin_vel_x, c.lin_vel_y, c.ang_vel_yaw)):
        assert (cmds[:, k] >= lo).all() and (cmds[:, k] <= hi).all()
    # heading mode: a robot commanded to move turns towards its heading (the sign of the yaw-rate command)
    from cra_warp.rotations import yaw

    env.hold_commands(torch.tensor([0.5, 0.0], device=env.device).expand(env.num_envs, 2),
                      yaw(env.world.root_quat) + torch.linspace(-1.0, 1.0, env.num_envs, device=env.device))
    sign = torch.sign(torch.linspace(-1.0, 1.0, env.num_envs, device=env.device))
    assert (torch.sign(env.commands[:, 2]) == sign).all()
    env.reset_idx(torch.arange(env.num_envs, device=env.device))


def test_effort_scaled_actions_ask_each_joint_for_the_same_share_of_its_torque():
    """action_scale_effort: a unit action moves each stiff joint's target by factor x effort / kp (capped), so the
    PD torque it asks for is the same share of every joint's limit; ankle roll (kp 0) keeps the robot's scale."""
    e = LocoEnv(LocoConfig(num_envs=2, device=DEVICE, obs=ObsConfig(noise=False), action_scale_effort=0.5,
                           action_scale_max=1.0,
                           randomization=DomainRandConfig(enabled=False)))
    r = ADAM_LITE
    kp, effort = torch.tensor(r.kp, device=e.device), torch.tensor(r.effort_limit, device=e.device)
    e.step(torch.ones(2, e.num_actions, device=e.device))
    step = e.world.joint_target[0] - torch.tensor(r.default_q, device=e.device)
    stiff = (kp > 0) & (0.5 * effort / kp.clamp(min=1e-6) < 1.0)
    assert torch.allclose((kp * step)[stiff], 0.5 * effort[stiff], rtol=1e-5)
    assert torch.allclose(step[(kp > 0) & ~stiff], torch.ones(int(((kp > 0) & ~stiff).sum()), device=e.device))
    assert torch.allclose(step[kp == 0], torch.full((int((kp == 0).sum()),), r.action_scale, device=e.device))


def test_difficulty_curriculum_scales_commands_and_randomisation_with_its_level():
    from envs.loco_config import DifficultyConfig

    n = 16
    e = LocoEnv(LocoConfig(num_envs=n, device=DEVICE, difficulty=DifficultyConfig(
        commands=True, randomization=True, interval=1, step=0.5)))
    d, rd, dev = e.difficulty, e.cfg.randomization, e.device
    everyone = torch.ones(n, dtype=torch.bool, device=dev)
    assert float(d.level) == 0.0  # level 0: the nominal robot, asked to stand
    for name in ("motor_strength", "kp_scale", "kd_scale"):
        assert (getattr(e, name) == 1.0).all(), name
    assert (e.friction == e.cfg.world.friction).all()
    assert (e.com_offset == 0).all() and (e.commands == 0).all()
    d.record(torch.full((n,), e.max_episode_length, device=dev), everyone)   # whole episodes: one step up
    assert float(d.level) == 0.5
    e.reset_idx(torch.arange(n, device=dev))
    lo, hi = 1.0 + 0.5 * (rd.motor_strength[0] - 1.0), 1.0 + 0.5 * (rd.motor_strength[1] - 1.0)
    assert e.motor_strength.min() >= lo - 1e-6 and e.motor_strength.max() <= hi + 1e-6
    assert (e.motor_strength - 1.0).abs().max() > 0.05                      # but no longer nominal
    assert e.com_offset.abs().max() <= 0.5 * rd.base_com_offset + 1e-6 and e.com_offset.abs().max() > 0
    c = e.cfg.commands
    assert e.commands[:, 0].abs().max() <= 0.5 * max(map(abs, c.lin_vel_x)) + 1e-6
    d.record(torch.full((n,), 10, device=dev), ~everyone)                    # nothing ended: the level stays
    assert float(d.level) == 0.5
    d.record(torch.full((n,), 10, device=dev), everyone)                     # early falls: one step down
    assert float(d.level) == 0.0
    assert float(LocoEnv(LocoConfig(num_envs=2, device=DEVICE)).difficulty.level) == 1.0  # off: the whole task


def test_swing_feedforward_lifts_each_foot_while_the_clock_has_it_in_swing():
    # The scripted stand's targets plus the clock's swing feedforward: within two cycles each sole rises
    # 2 cm or more while its leg is in swing and that foot leaves the ground; without the feedforward neither does.
    def lift(feedforward):
        cfg = LocoConfig(num_envs=2, device=DEVICE, randomization=DomainRandConfig(enabled=False))
        cfg.gait.swing_feedforward = feedforward
        env = LocoEnv(cfg)
        env.reset_idx(torch.arange(2, device=env.device))
        height, airborne = torch.zeros(2), torch.zeros(2, dtype=torch.bool)
        for _ in range(round(2 * cfg.gait.cycle_time / env.dt)):
            env.step(env.stand_actions())
            swing = env.clock.swing_depth[0] > 0.5
            height = torch.maximum(height, torch.where(swing, env.sole_height[0], 0.0).cpu())
            airborne |= (swing & ~env.contact[0]).cpu()
        return height, airborne

    height, airborne = lift(0.3)
    assert (height > 0.02).all() and airborne.all(), (height, airborne)
    height, airborne = lift(0.0)
    assert (height < 0.01).all() and not airborne.any(), (height, airborne)


def test_a_march_of_the_feedforward_turns_the_way_its_start_phase_says():
    # Why gait.random_start_phase exists: the scripted stand plus the swing and stride feedforward under a 0.3 m/s
    # command turns the robot clockwise when its clock starts at phase 0 (left foot first) and anticlockwise from
    # half a cycle, each by more than 0.3 rad/s on average over its first second. A policy trained from phase-0
    # starts only inherits one of the two turns.
    def mean_yaw_rate(start):
        cfg = LocoConfig(num_envs=2, device=DEVICE, randomization=DomainRandConfig(enabled=False))
        cfg.gait.swing_feedforward, cfg.gait.stride_feedforward = 0.25, 0.5
        cfg.commands.heading_mode = False
        env = LocoEnv(cfg)
        ids = torch.arange(2, device=env.device)
        env.reset_idx(ids)
        env.clock.reset(ids, torch.full((2,), start, device=env.device))
        rate = torch.zeros(2)
        for _ in range(50):
            env.hold_commands(torch.tensor([[0.3, 0.0]] * 2, device=env.device), torch.zeros(2, device=env.device))
            env.step(env.stand_actions())
            rate += env.base_ang_vel[:, 2].cpu() / 50
        return rate

    assert (mean_yaw_rate(0.0) < -0.3).all() and (mean_yaw_rate(0.4) > 0.3).all()


def test_held_yaw_rate_is_commanded_and_observed_without_heading_mode():
    cfg = LocoConfig(num_envs=2, device=DEVICE)
    cfg.commands.heading_mode = False
    env = LocoEnv(cfg)
    env.hold_commands(torch.tensor([[0.3, 0.0]] * 2, device=env.device), torch.zeros(2, device=env.device),
                      yaw_rate=-0.3)
    assert torch.allclose(env.commands[:, 2], torch.full((2,), -0.3, device=env.device))
    seen = env.obs["policy"][:, env.layout["command"]][:, 2]
    assert torch.allclose(seen, torch.full((2,), -0.3 * cfg.obs.command_scale[2], device=env.device))


def test_steer_turns_a_yaw_rate_policy_towards_the_heading_each_step():
    # The evaluation course steers every robot at its target, also one trained without heading mode: the yaw-rate
    # command must follow the heading error (left of the robot: turn left), and step() must keep re-aiming it.
    from cra_warp.rotations import yaw

    cfg = LocoConfig(num_envs=2, device=DEVICE, randomization=DomainRandConfig(enabled=False))
    cfg.commands.heading_mode = False
    env = LocoEnv(cfg)
    env.reset_idx(torch.arange(2, device=env.device))
    heading = yaw(env.world.root_quat) + torch.tensor([0.6, -0.6], device=env.device)  # spawns face random ways
    env.hold_commands(torch.tensor([[0.3, 0.0]] * 2, device=env.device), heading, steer=True)
    first = env.commands[:, 2].clone()
    assert first[0] > 0.1 and first[1] < -0.1
    env.heading -= torch.tensor([1.2, -1.2], device=env.device)  # the target moved to the other side
    env.step(env.stand_actions())
    assert env.commands[0, 2] < -0.1 and env.commands[1, 2] > 0.1
    env.hold_commands(torch.tensor([[0.3, 0.0]] * 2, device=env.device), heading)  # no steer: the yaw rate as held
    assert (env.commands[:, 2] == 0).all()
    env.step(env.stand_actions())
    assert (env.commands[:, 2] == 0).all()  # and step() no longer re-aims it


def test_random_start_phase_spreads_the_clock_over_the_cycle():
    cfg = LocoConfig(num_envs=64, device=DEVICE)
    assert (LocoEnv(cfg).clock.phase == 0).all()
    cfg.gait.random_start_phase = True
    phase = LocoEnv(cfg).clock.phase
    assert phase.min() >= 0 and phase.max() < cfg.gait.cycle_time
    assert phase.std() > 0.15 and (phase < cfg.gait.cycle_time / 2).float().mean().item() == pytest.approx(0.5, abs=0.2)


def _sweep_at_touchdown(feedforward: str, command: tuple[float, float, float]) -> list[float]:
    """Per leg, how far a zero action's PD targets put the sole, in the pelvis frame through forward kinematics,
    where the clock puts the foot down (its leg signal rising through 0) from where it lifts it (falling through 0),
    under a held command (vx, vy, yaw rate) with gait.<feedforward> = 0.25: along x for the stride, y for the
    lateral feedforward and the sole's yaw [rad] for the turn."""
    from cra_warp.kinematics import Kinematics

    cfg = LocoConfig(num_envs=1, device=DEVICE, randomization=DomainRandConfig(enabled=False))
    cfg.commands.heading_mode = False
    setattr(cfg.gait, feedforward, 0.25)
    env = LocoEnv(cfg)
    env.reset_idx(torch.arange(1, device=env.device))
    env.hold_commands(torch.tensor([command[:2]], device=env.device), torch.zeros(1, device=env.device),
                      yaw_rate=command[2])
    kin, targets, signals = Kinematics(ADAM_LITE), [], []
    for _ in range(round(cfg.gait.cycle_time / env.dt) + 1):
        env.step(torch.zeros(1, env.num_actions, device=env.device))
        targets.append(env.world.joint_target[0].cpu().clone())
        signals.append(env.clock.signals[0].cpu().clone())
    sig = torch.stack(signals)
    q = torch.stack(targets)
    upright = torch.tensor([[0.0, 0.0, 0.0, 1.0]]).repeat(len(q), 1)
    feet = kin.feet(torch.zeros(len(q), 3), upright, q)
    toes = feet.sole_corners[:, :, 0] - feet.sole_corners[:, :, 2]        # back-left -> front-left corner
    measure = {"stride_feedforward": feet.sole_centres[..., 0], "lateral_feedforward": feet.sole_centres[..., 1],
               "turn_feedforward": torch.atan2(toes[..., 1], toes[..., 0])}[feedforward]
    out = []
    for leg in range(2):
        s = sig[:, leg]
        down = int(torch.argmin(torch.where(s[1:] > s[:-1], s[1:].abs(), 9.0))) + 1   # rising through 0
        up = int(torch.argmin(torch.where(s[1:] < s[:-1], s[1:].abs(), 9.0))) + 1     # falling through 0
        out.append((measure[down, leg] - measure[up, leg]).item())
    return out


def test_stride_feedforward_puts_each_foot_down_ahead_and_lifts_it_behind():
    # About a step (2 x 0.25 x 0.5 rad on a ~0.8 m leg) ahead under a 0.5 m/s forward command; backwards for a
    # backward command; no stride without a command.
    forward, backward = (_sweep_at_touchdown("stride_feedforward", (v, 0.0, 0.0)) for v in (0.5, -0.5))
    still = _sweep_at_touchdown("stride_feedforward", (0.0, 0.3, 0.5))
    assert all(0.1 < d < 0.35 for d in forward), forward
    assert all(-0.35 < d < -0.1 for d in backward), backward
    assert all(abs(d) < 0.01 for d in still), still


@pytest.mark.slow
def test_lateral_and_turn_feedforward_put_each_foot_down_towards_the_command():
    # Under a 0.3 m/s leftward command each sole lands ~2 x 0.25 x 0.3 rad x leg length further left than it lifts
    # (the robot's lateral joint signs are right), rightward for a rightward one; under a 0.5 rad/s turn each sole
    # lands turned ~2 x 0.25 x 0.5 rad anticlockwise from where it lifts; neither moves for a forward command.
    left, right = (_sweep_at_touchdown("lateral_feedforward", (0.0, v, 0.0)) for v in (0.3, -0.3))
    assert all(0.05 < d < 0.25 for d in left), left
    assert all(-0.25 < d < -0.05 for d in right), right
    anticlockwise, clockwise = (_sweep_at_touchdown("turn_feedforward", (0.0, 0.0, w)) for w in (0.5, -0.5))
    assert all(0.15 < d < 0.35 for d in anticlockwise), anticlockwise
    assert all(-0.35 < d < -0.15 for d in clockwise), clockwise
    for ff in ("lateral_feedforward", "turn_feedforward"):
        assert all(abs(d) < 0.01 for d in _sweep_at_touchdown(ff, (0.5, 0.0, 0.0))), ff


def test_yaw_bias_keeps_a_steady_turn_and_averages_out_the_gait_sway():
    """yaw_bias low-passes (commanded - measured) yaw rate: a 2 Hz sway of 0.4 rad/s around the command averages out,
    a steady 0.1 rad/s beside it stays; a reset clears it."""
    from envs.rewards import yaw_bias

    env = LocoEnv(LocoConfig(num_envs=2, device=DEVICE))
    env.commands[:, 2] = 0.3
    for k in range(int(5.0 / env.dt)):
        sway = 0.4 * math.sin(2 * math.pi * 2.0 * k * env.dt)
        env.base_ang_vel[:, 2] = torch.tensor([0.3 + sway, 0.2 + sway], device=env.device)
        env._advance_history()
    err = env.slow_yaw_error.cpu()
    assert abs(err[0]) < 0.04 and err[1] == pytest.approx(0.1, abs=0.04)
    assert torch.allclose(yaw_bias(env), env.slow_yaw_error ** 2)
    env.reset_idx(torch.tensor([1], device=env.device))
    assert env.slow_yaw_error[1] == 0.0 and env.slow_yaw_error[0] == err[0].to(env.device)

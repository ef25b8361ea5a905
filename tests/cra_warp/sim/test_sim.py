"""The batched world, on both backends (Newton, MuJoCo C): physical facts of a standing Adam Lite, the tensor
interface, and the two engines agreeing on a trajectory."""

import pytest
import torch
import warp as wp

from tests.conftest import device_for, stand_steps
from cra_warp.sim import FREE_Q, World, WorldConfig, make_world, mjcf
from robots.adam_lite import ADAM_LITE

G = 9.81


@pytest.fixture(scope="module", params=["newton", "mujoco"])
def backend(request):
    return request.param


@pytest.fixture(scope="module")
def world(backend):
    return make_world(ADAM_LITE, WorldConfig(backend=backend), num_envs=4, device=device_for(backend))


def sensor_lag(w: World) -> float:
    """How long before the state the body quantities were evaluated: MuJoCo's sensors run at the start of the last
    physics step, Newton's bodies come from the state itself (cra_warp.sim.mujoco)."""
    return w.cfg.sim_dt if w.cfg.backend == "mujoco" else 0.0


def total_mass(w: World) -> torch.Tensor:
    return w.body_mass.sum(1)  # [N]


def com_velocity(w: World) -> torch.Tensor:
    m = w.body_mass.unsqueeze(-1)
    return (m * w.body_lin_vel).sum(1) / m.sum(1)  # [N, 3]


def test_one_mjcf_is_the_model_the_mujoco_backend_runs(world):
    """cra_warp.sim.mjcf is the one MJCF builder: one world whatever the config's backend or threads, and its
    bodies are the worlds' bodies in their order."""
    import re

    xml = mjcf(ADAM_LITE, WorldConfig(backend="mujoco", threads=3))
    assert xml == mjcf(ADAM_LITE)
    names = [b[len(ADAM_LITE.name) + 1:] for b in re.findall(r'<body name="([^"]+)"', xml)]
    assert {n: i for i, n in enumerate(names)} == world.body_index


def test_zero_targets_fall_and_the_scripted_stand_holds_5s_with_feet_carrying_the_weight(world):
    """The robot's ankles (explicit PD, pitch kp 130) cannot hold the reference pose passively (it falls after
    ~3.4 s); the scripted stand holds it through the same PD, and then the feet carry the weight."""
    world.reset()
    for _ in range(int(6.0 / world.cfg.env_dt)):
        world.step()
    assert (world.root_pos[:, 2] < 0.5).all(), "a zero-action robot should fall (else the stand tests nothing)"
    world.reset()
    h0 = world.root_pos[:, 2].clone()
    heights, fz = [], []

    def record(k):
        heights.append(world.root_pos[:, 2].clone())
        if k >= 150:  # at rest after 3 s
            fz.append(world.foot_forces[..., 2].sum(1))

    stand_steps(world, int(5.0 / world.cfg.env_dt), each=record)
    heights = torch.stack(heights)
    assert (heights - h0).abs().max() < 0.02, "pelvis height moved more than 2 cm"
    weight = total_mass(world) * G
    support = torch.stack(fz).mean(0)
    assert torch.allclose(support, weight, rtol=0.05), f"feet carry {support.tolist()} N, weight {weight.tolist()} N"


def test_views_follow_the_sim(world):
    if world.cfg.backend == "newton":  # zero-copy: the views are Warp's memory
        assert world.joint_pos.data_ptr() == wp.to_torch(world.state_0.joint_q).data_ptr() + FREE_Q * 4
    world.reset()
    body_pos = world.body_pos  # taken once: must follow the sim without being fetched again
    before = body_pos[0, world.body_index["elbowLeft"]].clone()
    world.joint_target[0, ADAM_LITE.joint_names.index("shoulderPitch_Left")] -= 1.0  # raise the left arm
    for _ in range(50):
        world.step()
    q = world.joint_pos[0, ADAM_LITE.joint_names.index("shoulderPitch_Left")]
    assert q < ADAM_LITE.default_q[ADAM_LITE.joint_names.index("shoulderPitch_Left")] - 0.5
    assert (body_pos[0, world.body_index["elbowLeft"]] - before).norm() > 0.1
    # the other robots did not move their arms
    others = world.joint_pos[1:, ADAM_LITE.joint_names.index("shoulderPitch_Left")]
    assert (others - ADAM_LITE.default_q[ADAM_LITE.joint_names.index("shoulderPitch_Left")]).abs().max() < 0.1


def _airborne_state(w: World, ids: torch.Tensor) -> torch.Tensor:
    q = w.joint_q[ids].clone()
    q[:, 2] = 3.0  # far above the ground: free fall, no contacts
    return q


def test_external_force_changes_momentum_by_impulse(world):
    ids = torch.arange(world.num_envs, device=world.joint_pos.device)
    world.reset(ids, joint_q=_airborne_state(world, ids))
    force = 100.0
    world.base_force[1, 0] = force  # +x on robot 1 only
    v0 = com_velocity(world).clone()
    steps = 10
    for _ in range(steps):
        world.step()
    dv = com_velocity(world) - v0
    t = steps * world.cfg.env_dt - sensor_lag(world)
    expected = force * t / total_mass(world)[1]
    assert dv[1, 0] == pytest.approx(expected.item(), rel=0.02)
    # armature (rotor inertia, not reacted on the parent link) lets internal PD motion leak ~1e-3 m/s
    assert dv[0, 0].abs() < 2e-3 and dv[2:, 0].abs().max() < 2e-3
    assert dv[:, 2].tolist() == pytest.approx([-G * t] * world.num_envs, rel=0.01)  # and gravity acts on all
    world.base_force.zero_()


def test_impulse_shifts_com_velocity(world):
    d = world.joint_pos.device
    ids = torch.arange(world.num_envs, device=d)
    world.reset(ids, joint_q=_airborne_state(world, ids))
    world.step()
    v0 = com_velocity(world).clone()
    dv = torch.tensor([[0.5, -0.3, 0.0]], device=d)
    world.apply_impulse(torch.tensor([2], device=d), dv)
    world.step()
    change = com_velocity(world) - v0
    change[:, 2] += G * world.cfg.env_dt
    assert torch.allclose(change[2], dv[0], atol=2e-3)
    assert change[[0, 1, 3]].abs().max() < 2e-3


def _rollout(w: World, reset_ids=None) -> torch.Tensor:
    """30 steps with distinct pushes per robot, an optional reset of some, 20 more; returns the full state."""
    d = w.joint_pos.device
    w.reset()
    w.apply_impulse(torch.arange(w.num_envs, device=d),
                    torch.linspace(-0.4, 0.4, w.num_envs, device=d).unsqueeze(1).repeat(1, 3))
    for _ in range(30):
        w.step()
    if reset_ids is not None:
        w.reset(reset_ids)
    for _ in range(20):
        w.step()
    return torch.cat([w.joint_q, w.joint_qd, w.body_pos.flatten(1)], 1).clone()


def test_reset_of_a_subset_leaves_others_bitwise_untouched(world):
    plain = _rollout(world)
    d = world.joint_pos.device
    other = make_world(ADAM_LITE, WorldConfig(backend=world.cfg.backend), num_envs=4,
                       device=device_for(world.cfg.backend))
    with_reset = _rollout(other, reset_ids=torch.tensor([1, 3], device=d))
    assert torch.equal(plain[[0, 2]], with_reset[[0, 2]])
    assert not torch.equal(plain[[1, 3]], with_reset[[1, 3]])
    # a reset world is back at the standing pose, at rest
    other.reset(torch.tensor([1], device=d))
    assert torch.equal(other.joint_q[1], other.default_joint_q[1])
    assert other.joint_qd[1].abs().max() == 0


def test_randomised_parameters_reach_the_solver(world):
    """A heavier robot presses harder on the ground; a weaker motor sags; changes stay in their own world."""
    d = world.joint_pos.device
    world.reset()
    ids = torch.tensor([1], device=d)
    scale = torch.full((1, world.num_bodies), 1.1, device=d)
    world.set_mass_scale(ids, scale)
    world.set_actuators(torch.tensor([2], device=d), torch.full((1, ADAM_LITE.num_joints), 0.8, device=d))
    world.commit_physics()
    assert total_mass(world)[1] == pytest.approx(1.1 * total_mass(world)[0].item(), rel=1e-6)
    fz = []
    stand_steps(world, 150, each=lambda k: k >= 100 and fz.append(world.foot_forces[..., 2].sum(1)))
    support = torch.stack(fz).mean(0)
    assert support[1] / support[0] == pytest.approx(1.1, abs=0.03)
    knee = ADAM_LITE.joint_names.index("kneePitch_Left")
    assert world.joint_kp[2, knee] == pytest.approx(0.8 * ADAM_LITE.kp[knee])
    assert world.root_pos[2, 2] < world.root_pos[0, 2] - 0.001  # weaker motors sag further under the same load
    world.set_mass_scale(ids, torch.ones(1, world.num_bodies, device=d))
    world.set_actuators(torch.tensor([2], device=d), torch.ones(1, ADAM_LITE.num_joints, device=d))
    world.commit_physics()


def test_friction_per_world(world):
    """On ice a pushed robot slides further than on rubber."""
    d = world.joint_pos.device
    world.reset()
    world.set_friction(torch.tensor([0], device=d), torch.tensor([0.05], device=d))
    world.set_friction(torch.tensor([1, 2, 3], device=d), torch.tensor([1.0, 1.0, 1.0], device=d))
    world.commit_physics()
    world.base_force[:, 0] = 60.0  # a steady horizontal shove, more than ice friction (0.05 x 575 N) holds
    start = world.body_pos[:, world.body_index["toeLeft"], 0].clone()
    stand_steps(world, 50)
    slide = (world.body_pos[:, world.body_index["toeLeft"], 0] - start).abs()  # the feet slip out backwards
    world.base_force.zero_()
    world.set_friction(torch.tensor([0], device=d), torch.tensor([1.0], device=d))
    world.commit_physics()
    assert slide[0] > 0.05 and slide[0] > 5 * slide[1:].max()


def test_rotor_inertia_per_world_slows_the_joints_alike_on_both_engines():
    """5x the armature in world 1: in the air, under the same PD step, its ankles (light links, where the rotor
    inertia dominates) move less than half as far in one control step; world 2 (nominal) moves exactly as world 0;
    and both engines agree on how much each joint is slowed."""
    ratios = {}
    for backend in ("newton", "mujoco"):
        w = make_world(ADAM_LITE, WorldConfig(backend=backend), num_envs=3, device=device_for(backend))
        d, J = w.joint_pos.device, ADAM_LITE.num_joints
        w.set_armature(torch.tensor([1], device=d), torch.full((1, J), 5.0, device=d))
        w.commit_physics()
        assert torch.allclose(w.joint_armature[1], 5 * torch.tensor(ADAM_LITE.armature, device=d).expand(J))
        q = w.default_joint_q.clone()
        q[:, 2] = 3.0  # in the air: no contacts
        w.reset(torch.arange(3, device=d), joint_q=q)
        w.joint_target.copy_(w.joint_pos + 0.3)
        q0 = w.joint_pos.clone()
        w.step()
        moved = (w.joint_pos - q0).abs()
        assert torch.equal(moved[2], moved[0])
        ratios[backend] = (moved[1] / moved[0]).cpu()
        for ankle in ("ankleRoll_Left", "ankleRoll_Right"):
            assert ratios[backend][ADAM_LITE.joint_names.index(ankle)] < 0.5
    assert torch.allclose(ratios["newton"], ratios["mujoco"], atol=1e-3)


def test_all_bodies_colliding_with_the_ground_still_stand(backend):
    """contacts="all": every robot shape meets the terrain (falls then touch down on knees and hands)."""
    w = make_world(ADAM_LITE, WorldConfig(contacts="all", backend=backend), num_envs=2, device=device_for(backend))
    h0 = w.root_pos[:, 2].clone()
    stand_steps(w, 150)
    assert (w.root_pos[:, 2] - h0).abs().max() < 0.02
    ids = torch.arange(2, device=w.joint_pos.device)
    q = _airborne_state(w, ids)
    q[:, 2] = 0.3  # pelvis 30 cm up: the legs and pelvis must rest on the ground, not pass through it
    w.reset(ids, joint_q=q)
    for _ in range(100):
        w.step()
    assert w.body_pos[..., 2].min() > -0.05  # with contacts="feet" the same fall sinks the body ~1.1 m


def test_applied_torque_is_the_explicit_pd_law_with_its_clamp(backend):
    """On random states, targets and per-world gains, the torque the rewards read (joint_torque, canonical order)
    is kp (q* - q) - kd qd clamped at the effort limit, evaluated at the state the physics step starts from. A
    near-zero time step keeps the state where it was set, so the law can be evaluated at the state after step()."""
    gen = torch.Generator().manual_seed(0)
    w = make_world(ADAM_LITE, WorldConfig(sim_dt=1e-7, capture=False, backend=backend), num_envs=4,
                   device=device_for(backend))
    n, J, d = w.num_envs, ADAM_LITE.num_joints, w.joint_pos.device
    rand = lambda *shape: torch.rand(*shape, generator=gen).to(d)  # noqa: E731  (drawn on the CPU: same draws)
    randn = lambda *shape: torch.randn(*shape, generator=gen).to(d)  # noqa: E731
    ids = torch.arange(n, device=d)
    w.set_actuators(ids, 0.8 + 0.4 * rand(n, J), 0.8 + 0.4 * rand(n, J), 0.8 + 0.4 * rand(n, J))
    w.commit_physics()
    q = w.default_joint_q.clone()
    q[:, 2] = 3.0                                     # in the air: no contacts
    q[:, FREE_Q:] += 0.2 * randn(n, J)
    qd = torch.zeros(n, 6 + J, device=d)
    qd[:, 6:] = 2.0 * randn(n, J)
    w.reset(ids, joint_q=q, joint_qd=qd)
    w.joint_target.copy_(w.joint_pos + 0.5 * randn(n, J))  # some torques saturate
    w.step()
    law = w.joint_kp * (w.joint_target - w.joint_pos) - w.joint_kd * w.joint_vel
    clamped = torch.maximum(torch.minimum(law, w.joint_effort_limit), -w.joint_effort_limit)
    assert (law.abs() > w.joint_effort_limit).any() and (law.abs() < w.joint_effort_limit).any()
    assert torch.allclose(w.joint_torque, clamped, rtol=1e-3, atol=1e-2)


def test_newton_and_mujoco_agree_on_a_trajectory():
    """The same initial state, the same push and the same stand controller for 1 s: joint angles within 0.01 rad
    and base positions within 1 cm (measured: ~1e-3 rad; the engines differ in the solver's warm start and float
    precision, and the closed loop feeds differences back)."""
    traj = {}
    for backend in ("newton", "mujoco"):
        w = make_world(ADAM_LITE, WorldConfig(backend=backend), num_envs=2, device=device_for(backend))
        d = w.joint_pos.device
        w.reset()
        w.apply_impulse(torch.tensor([1], device=d), torch.tensor([[0.3, 0.1, 0.0]], device=d))
        steps = []
        stand_steps(w, int(1.0 / w.cfg.env_dt), each=lambda k: steps.append(w.joint_q.to("cpu", copy=True)))
        traj[backend] = torch.stack(steps)
    diff = (traj["newton"] - traj["mujoco"]).abs()
    assert diff[..., FREE_Q:].max() < 0.01 and diff[..., :3].max() < 0.01
    assert (traj["newton"][-1, 1, :2] - traj["newton"][0, 1, :2]).norm() > 0.02  # the pushed robot did move

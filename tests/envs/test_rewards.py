"""Table I terms on hand-built states: sign, zero where they should be zero, the paper's weight."""

from types import SimpleNamespace

import pytest
import torch

from cra_warp.gait import swing_depth
from envs import rewards as R
from envs.loco_config import DEFAULT_WEIGHTS, TABLE_I_TERMS, LocoConfig
from tests.conftest import PAPER_TABLE_I
from robots.adam_lite import ADAM_LITE
from robots.adam_lite.loco import ADAM_LITE_LOCO

J = ADAM_LITE.num_joints


def state(n=2, **over):
    """An env-like namespace of a robot standing still at the reference pose, feet flat, both in contact."""
    q0 = torch.tensor(ADAM_LITE.default_q).repeat(n, 1)
    corners = torch.tensor([[0.12, 0.05, 0.0], [0.12, -0.05, 0.0], [-0.12, 0.05, 0.0], [-0.12, -0.05, 0.0]])
    sole = torch.stack([corners + torch.tensor([0.0, 0.11, 0.0]), corners + torch.tensor([0.0, -0.11, 0.0])])
    e = SimpleNamespace(
        cfg=LocoConfig(), commands=torch.zeros(n, 3), base_lin_vel=torch.zeros(n, 3), base_ang_vel=torch.zeros(n, 3),
        projected_gravity=torch.tensor([0.0, 0.0, -1.0]).repeat(n, 1),
        torso_gravity=torch.tensor([0.0, 0.0, -1.0]).repeat(n, 1),
        joint_acc=torch.zeros(n, J), torques=torch.zeros(n, J), joint_vel=torch.zeros(n, J), joint_pos=q0.clone(),
        joint_target=q0.clone(), default_q=q0[0].clone(), kp=torch.tensor(ADAM_LITE.kp).repeat(n, 1),
        root_pos=torch.tensor([0.0, 0.0, 0.88]).repeat(n, 1),
        sole_centres=sole.mean(1).repeat(n, 1, 1), sole_corners=sole.repeat(n, 1, 1, 1),
        sole_height=torch.zeros(n, 2), sole_corner_height=torch.zeros(n, 2, 4),
        feet_lin_vel=torch.zeros(n, 2, 3), feet_pos_yaw=sole.mean(1).repeat(n, 1, 1),
        foot_forces=torch.tensor([0.0, 0.0, 287.0]).repeat(n, 2, 1),
        contact=torch.ones(n, 2, dtype=torch.bool), first_contact=torch.zeros(n, 2, dtype=torch.bool),
        actions=torch.zeros(n, 26), last_actions=torch.zeros(n, 26), last_last_actions=torch.zeros(n, 26),
        soft_pos_lower=torch.tensor(ADAM_LITE.pos_lower) * 0.9, soft_pos_upper=torch.tensor(ADAM_LITE.pos_upper) * 0.9,
        soft_vel_limit=torch.tensor(ADAM_LITE.velocity_limit) * 0.9,
        soft_torque_limit=torch.tensor(ADAM_LITE.effort_limit) * 0.9,
        arm_joints=torch.arange(15, 23), hip_joints=torch.tensor([1, 2, 7, 8]), waist_joints=torch.tensor([12, 13, 14]),
        clock=SimpleNamespace(stance_mask=torch.ones(n, 2, dtype=torch.bool)),
    )
    for k, v in over.items():
        setattr(e, k, v)
    return e


def test_all_30_terms_with_the_papers_weights_and_the_shaping_terms_beyond_them_off():
    assert list(TABLE_I_TERMS) == list(PAPER_TABLE_I) == list(R.TERMS)[:30]
    assert list(R.TERMS) == list(DEFAULT_WEIGHTS)
    assert all(DEFAULT_WEIGHTS[k] == 0.0 for k in list(R.TERMS)[30:])
    for k, w in PAPER_TABLE_I.items():
        expected = -w if k == "body_height" else w
        assert DEFAULT_WEIGHTS[k] == expected, k


# Terms that are exactly zero for a robot standing still, at its reference pose, on flat ground, both feet down.
ZERO_AT_REST = ["lin_vel_z", "ang_vel_xy", "orientation", "joint_acc", "joint_power", "feet_clearance",
                "action_rate", "smoothness", "feet_stumble", "torques", "joint_velocity", "joint_tracking_error",
                "arm_joint_deviation", "hip_joint_deviation", "waist_joint_deviation", "joint_pos_limits",
                "joint_vel_limits", "torque_limits", "no_fly", "feet_lateral_distance", "feet_slip",
                "feet_ground_parallel", "feet_contact_force", "feet_parallel", "contact_momentum"]


@pytest.mark.parametrize("name", ZERO_AT_REST)
def test_zero_at_rest(name):
    assert torch.allclose(R.TERMS[name](state()), torch.zeros(2), atol=1e-6)


def test_tracking_is_one_when_tracking_and_decays():
    e = state(commands=torch.tensor([[0.5, 0.0, 0.3], [0.5, 0.0, 0.3]]))
    e.base_lin_vel[0, 0], e.base_ang_vel[0, 2] = 0.5, 0.3
    for f in (R.lin_vel_tracking, R.ang_vel_tracking):
        r = f(e)
        assert r[0] == pytest.approx(1.0) and 0 < r[1] < r[0]
    assert R.lin_vel_tracking(e)[1] == pytest.approx(torch.exp(torch.tensor(-0.25 / 0.25)).item())


def test_stall_counts_going_less_than_half_as_fast_as_told():
    # told 0.5 m/s forward: standing, 0.2 m/s and 0.3 m/s forward, 0.3 m/s sideways; then told 0.1 m/s, standing
    e = state(n=5, commands=torch.tensor([[0.5, 0.0, 0.0]] * 4 + [[0.1, 0.0, 0.0]]))
    e.base_lin_vel[1, 0], e.base_lin_vel[2, 0], e.base_lin_vel[3, 1] = 0.2, 0.3, 0.3
    assert R.stall(e).tolist() == [1.0, 1.0, 0.0, 1.0, 0.0]
    e.commands[:, :2] = torch.tensor([0.0, -0.4])           # told sideways: the robot going 0.3 m/s that way is not
    e.base_lin_vel[:, :2] = torch.tensor([0.0, -0.3])
    assert not R.stall(e).any()


def test_penalties_grow_with_the_error():
    e = state()
    e.base_lin_vel[1, 2] = 0.4
    e.projected_gravity[1] = torch.tensor([0.3, 0.0, -0.95])
    e.joint_pos[1, 16] += 0.5                               # an arm joint off its default
    e.joint_pos[1, 1] = ADAM_LITE.pos_upper[1]              # hip roll at its hard limit, beyond the soft one
    e.actions[1, 0] = 1.0
    for name in ("lin_vel_z", "orientation", "arm_joint_deviation", "joint_pos_limits", "action_rate",
                 "smoothness", "joint_tracking_error"):
        r = R.TERMS[name](e)
        assert r[0] == pytest.approx(0.0, abs=1e-9) and r[1] > 0, name
    assert R.lin_vel_z(e)[1] == pytest.approx(0.16)
    assert R.smoothness(e)[1] == pytest.approx(1.0)


def test_contact_terms():
    e = state()
    e.contact[1, 1] = False
    assert R.no_fly(e).tolist() == [0.0, 1.0]                   # single support
    assert R.contact_pattern(e)[0] == pytest.approx(1.0)        # mask == contacts
    assert R.contact_pattern(e)[1] == pytest.approx(torch.exp(torch.tensor(-1.0)).item())
    e.foot_forces[1, 0] = torch.tensor([900.0, 0.0, 200.0])     # toe against a riser: |F_xy| > 3 F_z
    assert R.feet_stumble(e).tolist() == [0.0, 1.0]
    e.foot_forces[0, 0, 2] = 800.0
    assert R.feet_contact_force(e)[0] == pytest.approx(100.0)
    e.first_contact[1, 0] = True
    e.feet_lin_vel[1, 0] = torch.tensor([0.3, 0.0, -0.4])
    assert R.feet_slip(e)[1] == pytest.approx(0.5)
    assert R.contact_momentum(e)[1] == pytest.approx(0.4 * 200.0)


def test_feet_geometry_terms():
    e = state()
    e.feet_pos_yaw[1, :, 1] = torch.tensor([0.05, -0.05])       # feet 10 cm apart, d_min 20 cm
    assert R.feet_lateral_distance(e)[1] == pytest.approx(-0.1)
    e.feet_pos_yaw[0, :, 1] = torch.tensor([0.3, -0.3])         # wide: no reward for ever wider feet
    assert R.feet_lateral_distance(e)[0] == 0.0
    e.sole_corner_height[1, 0] = torch.tensor([0.02, 0.02, 0.0, 0.0])  # toe up
    assert R.feet_ground_parallel(e)[1] == pytest.approx(1e-4)
    e.sole_corners[1, 0, :2, 0] += 0.05                         # left foot yawed: corner distances differ
    assert R.feet_parallel(e)[1] > 0
    e.sole_height[1] = torch.tensor([0.0, 0.08])
    e.feet_lin_vel[1, 0, 0] = 1.0                               # a foot moving fast at ground level
    assert R.feet_clearance(e)[1] == pytest.approx(0.08 ** 2)


def test_body_height_and_power():
    e = state()
    e.root_pos[1, 2] = 0.78
    assert R.body_height(e)[0] == pytest.approx(0.0, abs=1e-6)
    assert R.body_height(e)[1] == pytest.approx(0.01, rel=1e-4)
    e.torques[1, 3], e.joint_vel[1, 3] = 100.0, 2.0
    e.base_lin_vel[1, 0] = 1.0
    assert R.joint_power(e)[1] == pytest.approx(200.0)
    e.base_lin_vel[1, 0] = 0.0                                  # standing still: the floor bounds it
    assert R.joint_power(e)[1] == pytest.approx(200.0 / e.cfg.rewards.power_floor)


def _swing_state(signals, lift):
    """Robot at default_q plus ``lift`` x the swing profile on the left leg; clock signals (s, c) given."""
    e = state(n=1)
    legs = [ADAM_LITE.joint_ids(leg) for leg in ADAM_LITE_LOCO.swing_joints]
    e.swing_joints, e.swing_profile = torch.tensor(legs), torch.tensor(ADAM_LITE_LOCO.swing_profile)
    e.joint_pos[0, legs[0]] += lift * e.swing_profile
    gamma = LocoConfig().gait.gamma
    e.clock = SimpleNamespace(swing_depth=swing_depth(torch.tensor([signals]), gamma))
    return e


def test_swing_reference_rewards_lifting_the_leg_the_clock_has_in_swing():
    a = LocoConfig().rewards.swing_amplitude
    # both legs in stance (signals above gamma): the default pose is the reference
    assert R.swing_reference(_swing_state((0.5, 0.5), 0.0)).item() == pytest.approx(1.0)
    assert R.swing_reference(_swing_state((0.5, 0.5), a)).item() < 0.6
    # left leg mid-swing (s = -1): lifting it by the amplitude is the reference, standing is not
    assert R.swing_reference(_swing_state((-1.0, 1.0), a)).item() == pytest.approx(1.0)
    assert R.swing_reference(_swing_state((-1.0, 1.0), 0.0)).item() < 0.6
    # half-way into the swing, half the lift scores best
    half = R.swing_reference(_swing_state((-0.55, 1.0), a / 2)).item()
    assert half == pytest.approx(1.0, abs=1e-5)
    assert R.swing_reference(_swing_state((-0.55, 1.0), a)).item() < 0.8


def test_the_swing_profile_lifts_the_foot_and_keeps_the_sole_level():
    from cra_warp.kinematics import Kinematics

    kin, a = Kinematics(ADAM_LITE), LocoConfig().rewards.swing_amplitude
    q = torch.tensor(ADAM_LITE.default_q).repeat(2, 1)
    q[1, ADAM_LITE.joint_ids(ADAM_LITE_LOCO.swing_joints[0])] += a * torch.tensor(ADAM_LITE_LOCO.swing_profile)
    f = kin.feet(torch.zeros(2, 3), torch.tensor([[0.0, 0.0, 0.0, 1.0]]).repeat(2, 1), q)
    lift = f.sole_centres[1, 0, 2] - f.sole_centres[0, 0, 2]
    assert 0.06 < lift.item() < 0.12                                          # about the clearance target, 8 cm
    assert torch.allclose(f.sole_centres[1, 1], f.sole_centres[0, 1])         # the other foot does not move
    tilt = (f.sole_corners[1, 0, :, 2].max() - f.sole_corners[1, 0, :, 2].min()).item()
    assert tilt < 0.03                                                        # over a ~25 cm sole: < 7 deg

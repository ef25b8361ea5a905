"""The adaptive gait clock against the equations of paper III-E."""

import math

import pytest
import torch

from cra_warp.gait import GaitClock, GaitClockConfig

DT = 0.02


def run(clock: GaitClock, actions: torch.Tensor, steps: int) -> torch.Tensor:
    out = []
    for _ in range(steps):
        out.append(clock.advance(actions, DT).clone())  # advance returns the clock's own buffer
    return torch.stack(out)  # [T, N, 2]


def zero_crossings_period(signal: torch.Tensor) -> float:
    """Mean time between upward zero crossings of a sampled signal [T]."""
    up = ((signal[:-1] < 0) & (signal[1:] >= 0)).nonzero().flatten().float()
    return float((up[1:] - up[:-1]).mean()) * DT


def test_period_follows_d0():
    cfg = GaitClockConfig(cycle_time=0.8, alpha=0.5)
    clock = GaitClock(3, cfg)
    d0 = torch.tensor([-1.0, 0.0, 1.0])
    sig = run(clock, torch.stack([d0, torch.zeros(3), torch.zeros(3)], 1), 400)
    for i, d in enumerate(d0.tolist()):
        assert zero_crossings_period(sig[:, i, 0]) == pytest.approx(0.8 / (1 + 0.5 * d), rel=0.03)


def test_phase_update_is_the_equation():
    clock = GaitClock(2, GaitClockConfig(cycle_time=1.0, alpha=0.3))
    clock.advance(torch.tensor([[0.4, 0.0, 0.0], [-0.2, 0.0, 0.0]]), DT)
    assert torch.allclose(clock.phase, torch.tensor([(1 + 0.3 * 0.4) * DT, (1 + 0.3 * -0.2) * DT]))


def test_offsets_shift_s_and_c():
    cfg = GaitClockConfig(cycle_time=1.0, psi=0.5)
    base = GaitClock(1, cfg)
    shifted = GaitClock(1, cfg)
    s0 = base.advance(torch.zeros(1, 3), 0.1).clone()
    s1 = shifted.advance(torch.tensor([[0.0, 0.25, -0.1]]), 0.1)
    phi = 0.1
    assert s0[0, 0] == pytest.approx(math.sin(2 * math.pi * phi), abs=1e-6)
    assert s0[0, 1] == pytest.approx(math.sin(2 * math.pi * (phi + 0.5)), abs=1e-6)  # opposite leg
    assert s1[0, 0] == pytest.approx(math.sin(2 * math.pi * (phi + 0.25)), abs=1e-6)
    assert s1[0, 1] == pytest.approx(math.sin(2 * math.pi * (phi - 0.1 + 0.5)), abs=1e-6)


def test_stance_mask_and_dead_zone():
    clock = GaitClock(1, GaitClockConfig(cycle_time=1.0, gamma=-0.1))
    sig = run(clock, torch.zeros(1, 3), 50)[:, 0]  # one cycle
    masks = sig >= -0.1
    both = masks.all(1)
    assert both.any(), "gamma < 0 must give double support near the crossings"
    assert (masks.sum(1) >= 1).all(), "with gamma < 0 one foot is always in stance"
    assert (sig[both].abs() <= 0.1 + 1e-6).all()
    # gamma > 0 makes a flight band instead
    flight = GaitClock(1, GaitClockConfig(cycle_time=1.0, gamma=0.1))
    fsig = run(flight, torch.zeros(1, 3), 50)[:, 0]
    assert (~(fsig >= 0.1)).all(1).any()


def test_reset_restarts_only_the_given_envs():
    clock = GaitClock(3)
    run(clock, torch.full((3, 3), 0.3), 7)
    before = clock.phase.clone()
    clock.reset(torch.tensor([1]))
    assert clock.phase[1] == 0 and torch.equal(clock.phase[[0, 2]], before[[0, 2]])
    assert (clock.deltas[1] == 0).all()


def test_negative_rate_clamps_to_standstill():
    clock = GaitClock(1, GaitClockConfig(alpha=2.0))
    clock.advance(torch.tensor([[-1.0, 0.0, 0.0]]), DT)
    assert clock.phase[0] == 0


def test_config_errors_name_the_field():
    with pytest.raises(ValueError, match="cycle_time"):
        GaitClockConfig(cycle_time=0)
    with pytest.raises(ValueError, match="gamma"):
        GaitClockConfig(gamma=1.5)
    with pytest.raises(ValueError, match="swing_feedforward"):
        GaitClockConfig(swing_feedforward=-0.1)
    for f in ("stride_feedforward", "lateral_feedforward", "turn_feedforward"):
        with pytest.raises(ValueError, match=f):
            GaitClockConfig(**{f: -0.1})


def test_swing_depth_is_zero_in_stance_and_one_mid_swing():
    clock = GaitClock(1, GaitClockConfig(cycle_time=1.0, gamma=-0.1))
    depths, masks = [], []
    for _ in range(50):
        clock.advance(torch.zeros(1, 3), 0.02)
        depths.append(clock.swing_depth[0].clone())
        masks.append(clock.stance_mask[0].clone())
    depth, stance = torch.stack(depths), torch.stack(masks)
    assert (depth[stance] == 0).all() and (depth[~stance] > 0).all()
    assert depth.max() == pytest.approx(1.0, abs=0.01)         # the signal reaches -1 once per cycle
    assert ((depth[:, 0] > 0) & (depth[:, 1] > 0)).sum() == 0  # psi 0.5, gamma < 0: never both legs in swing


def test_phase_observation_tells_phases_apart_that_the_leg_signals_do_not():
    """With equal offsets (fixed_cycle: always) c = -s, so (s, c) at phi and at T/2 - phi are the same; the
    policy observes (sin, cos) of the global phase instead, which differ."""
    clock = GaitClock(2, GaitClockConfig(cycle_time=1.0))
    clock.reset(torch.tensor([0, 1]), torch.tensor([0.1, 0.4]))
    s = clock.signals
    assert torch.allclose(s[0], s[1], atol=1e-6)
    obs = clock.phase_obs
    assert (obs[0] - obs[1]).abs().max() > 0.5
    assert torch.allclose(obs.norm(dim=-1), torch.ones(2))

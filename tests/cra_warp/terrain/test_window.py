"""Per-world terrain windows: which boxes a window holds, and robots standing on what their windows hold."""

import math

import numpy as np
import pytest
import torch

from cra_warp.terrain.window import PARK_DEPTH, TerrainWindows, WindowConfig

IDENTITY = [0.0, 0.0, 0.0, 1.0]


def windows(centers, halves, quats=None, slots=3, half_width=1.0):
    quats = quats if quats is not None else [IDENTITY] * len(centers)
    return TerrainWindows(np.array(centers, float), np.array(halves, float), np.array(quats, float), 2,
                          WindowConfig(slots=slots, half_width=half_width, recentre=0.5), "cpu")


def test_a_window_holds_the_boxes_that_meet_it_nearest_first():
    w = windows([[0.5, 0, 0.1], [5.0, 0, 0.1], [1.8, 0, 0.1], [29.0, 0, 0.1]],
                [[0.1, 0.1, 0.1], [0.1, 0.1, 0.1], [0.5, 0.5, 0.1], [29.0, 1.0, 0.1]])
    c, h, q = w.select(torch.tensor([0]), torch.tensor([[0.0, 0.0]]))
    # box 0 (0.4 m away), box 3 (a long slab from x = 0 on: 0 m away), box 2 (its edge at
    # 1.3 m: 0.3 m beyond the window, so out), box 1 far: slots = [3, 0, parked]
    assert torch.allclose(c[0, :2], torch.tensor([[29.0, 0, 0.1], [0.5, 0, 0.1]]))
    assert c[0, 2, 2] == PARK_DEPTH and torch.equal(q[0, 2], torch.tensor(IDENTITY))
    assert torch.allclose(h[0, 0], torch.tensor([29.0, 1.0, 0.1]))
    assert w.overflows == 0


def test_a_rotated_box_meets_a_window_with_its_footprint():
    # a 4 m x 0.2 m slab centred 2.5 m away along y: along x it misses the window, turned 90 deg it reaches in
    quarter = [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]
    straight = windows([[0, 2.5, 0]], [[2.0, 0.1, 0.1]])
    turned = windows([[0, 2.5, 0]], [[2.0, 0.1, 0.1]], [quarter])
    at_origin = (torch.tensor([0]), torch.tensor([[0.0, 0.0]]))
    assert straight.select(*at_origin)[0][0, 0, 2] == PARK_DEPTH
    assert turned.select(*at_origin)[0][0, 0, 2] == 0.0


def test_overflow_keeps_the_nearest_and_is_counted():
    w = windows([[0.1 * k, 0, 0] for k in range(5)], [[0.05, 0.05, 0.05]] * 5, slots=2)
    c, _, _ = w.select(torch.tensor([1]), torch.tensor([[0.0, 0.0]]))
    assert torch.allclose(c[0, :, 0], torch.tensor([0.0, 0.1]))
    assert w.overflows == 1


def test_stale_worlds_are_the_ones_that_left_their_window_centre():
    w = windows([[0, 0, 0]], [[0.1, 0.1, 0.1]])
    assert w.stale(torch.zeros(2, 2)).tolist() == [0, 1]            # never filled
    w.select(torch.tensor([0, 1]), torch.zeros(2, 2))
    assert w.stale(torch.tensor([[0.4, 0.0], [0.0, -0.6]])).tolist() == [1]
    # a world gone non-finite keeps its window until it is reset; the others are unaffected
    assert w.stale(torch.tensor([[float("nan"), 0.0], [float("inf"), 9.0]])).tolist() == []


def test_config_errors_name_the_field():
    with pytest.raises(ValueError, match="WindowConfig.slots"):
        WindowConfig(slots=0)
    with pytest.raises(ValueError, match="WindowConfig.recentre"):
        WindowConfig(half_width=1.0, recentre=1.5)


@pytest.fixture(scope="module")
def platforms():
    """Two platforms 10 m apart (tops 0.3 m and 0.5 m); windows of 4 slots, 1.5 m half-width."""
    from cra_warp.sim import TerrainBoxes

    return TerrainBoxes(np.array([[0.0, 0.0, 0.15], [10.0, 0.0, 0.25]]), np.array([[1.0, 1.0, 0.15],
                                                                                    [1.0, 1.0, 0.25]]))


def _stand_then_move(platforms, window):
    """World 0 stands on the low platform throughout; world 1 starts there and is reset onto the high one."""
    from tests.conftest import stand_steps
    from cra_warp.sim import WorldConfig, make_world
    from robots.adam_lite import ADAM_LITE as R

    w = make_world(R, WorldConfig(terrain_window=window), platforms, num_envs=2)
    q = w.default_joint_q.clone()
    q[:, 2] += 0.3 + 0.01
    w.reset(joint_q=q)
    stand_steps(w, 25)
    low = w.root_pos[:, 2].clone()
    q1 = w.default_joint_q[1:].clone()
    q1[:, 0], q1[:, 2] = 10.0, q1[:, 2] + 0.5 + 0.01
    w.reset(torch.tensor([1]), joint_q=q1)
    stand_steps(w, 50)
    return low, w.root_pos[:, 2].clone()


def test_a_moved_robot_stands_on_the_terrain_of_its_new_place(platforms):
    from robots.adam_lite import ADAM_LITE as R

    low, after = _stand_then_move(platforms, WindowConfig(slots=4, half_width=1.5, recentre=1.0))
    assert torch.allclose(low, torch.full((2,), 0.3 + R.base_height), atol=0.02)
    assert abs(after[0] - low[0]) < 1e-3                              # world 0 never noticed
    assert abs(after[1] - (0.5 + R.base_height)) < 0.02, f"world 1 pelvis at {after[1]:.3f} m, not on the platform"
    shared_low, shared_after = _stand_then_move(platforms, None)      # every world holds both platforms
    assert torch.allclose(after, shared_after, atol=2e-3) and torch.allclose(low, shared_low, atol=2e-3)

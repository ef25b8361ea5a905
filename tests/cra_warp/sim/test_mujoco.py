"""The MuJoCo C backend (cra_warp/sim/mujoco.py)."""

import torch

from cra_warp.sim import WorldConfig, make_world
from robots.adam_lite import ADAM_LITE


def test_mujoco_backend_pending_writes_survive_other_resets_and_blow_ups_show():
    """A push written into one world reaches the sim even when another world is reset before the step; a world
    MuJoCo would silently reset (a state past its limits) comes back non-finite, for the task to reset and count."""
    w = make_world(ADAM_LITE, WorldConfig(backend="mujoco"), num_envs=3)
    w.reset()
    w.apply_impulse(torch.tensor([0]), torch.tensor([[1.0, 0.0, 0.0]]))
    w.reset(torch.tensor([2]))
    w.step()
    assert w.root_lin_vel[0, 0] > 0.8 and w.root_lin_vel[1, 0].abs() < 0.05
    w.joint_qd[1, 10] = 1e11  # finite, but beyond MuJoCo's limit: it resets the world to its model pose
    w.step()
    assert not torch.isfinite(w.joint_qd[1]).all()
    assert torch.isfinite(w.joint_qd[[0, 2]]).all()

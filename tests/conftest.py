"""Shared fixtures. Worlds are small (the physics is the same at N=4 as at N=4096) and built once per module."""

import os
from pathlib import Path

import numpy as np
import pytest

from robots.adam_lite.config import ADAM_LITE

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
REFERENCE = SHARED / "reference" / "adam_lite"
# The device of the tests that build Newton worlds and the task on them (cra_warp/sim/test_sim.py,
# envs/test_locomotion.py): the CPU unless CRA_TEST_DEVICE names another (tools/gpu_check.sh runs them on cuda:0).
# The MuJoCo C backend is CPU-only.
DEVICE = os.environ.get("CRA_TEST_DEVICE", "cpu")


def device_for(backend: str) -> str:
    return "cpu" if backend == "mujoco" else DEVICE


def need_shared(path: Path) -> Path:
    """Skip (saying why) when ../shared is not beside the repo; tests read reference data from there."""
    if not path.exists():
        pytest.skip(f"{path} not found: the reference data in ../shared is not beside this checkout")
    return path


def one_line_error(capsys, code: int, *words: str):
    """A CLI refused bad input: exit code 2 and one stderr line, no traceback, naming ``words``."""
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err


def stand_steps(world, steps: int, q_ref=None, each=None):
    """Step ``world`` under the scripted stand (the robot's ankles are too soft for a zero-action stand);
    ``each(k)`` runs after step k."""
    from cra_warp.stand import ScriptedStand
    from robots import robot_by_name

    stand = ScriptedStand(world.robot, robot_by_name(world.robot.name).stand, world.joint_pos.device)
    for k in range(steps):
        world.joint_target.copy_(stand.targets(world, q_ref))
        world.step()
        if each is not None:
            each(k)


# The default terrain and its sampler, built once per module (the terrain tests share them).
@pytest.fixture(scope="module")
def terrain():
    from cra_warp.terrain import TerrainConfig, generate_terrain

    return generate_terrain(TerrainConfig())


@pytest.fixture(scope="module")
def sampler(terrain):
    from cra_warp.terrain.sampling import HeightSampler

    return HeightSampler(terrain.field)


def tile_of(terrain, kind, level):
    return terrain.tile(level, terrain.column_types.index(kind))


def centre_row(terrain, tile):
    """Heights relative to the rim along the tile's centre line in x (from its -x edge to its centre), [n/2]."""
    rows, cols = tile.cells
    mid = (cols.start + cols.stop) // 2
    return terrain.field.heights[rows.start:(rows.start + rows.stop) // 2, mid].astype(np.float64) - terrain.base_height


# Table I as printed in the paper (its weights w_i, in its order), typed here again so that a change of the recipes,
# the defaults or the reward terms shows up against the paper itself (body_height's sign is corrected in the code)
PAPER_TABLE_I = {
    "lin_vel_tracking": 3.0, "ang_vel_tracking": 3.0, "lin_vel_z": -0.5, "ang_vel_xy": -0.025, "orientation": -1.25,
    "torso_orientation": 2.0, "joint_acc": -2.5e-7, "joint_power": -2.5e-5, "body_height": 0.1,
    "feet_clearance": -0.25, "action_rate": -0.01, "smoothness": -0.01, "feet_stumble": -0.5, "torques": -2.5e-6,
    "joint_velocity": -1e-4, "joint_tracking_error": -0.25, "arm_joint_deviation": -0.1,
    "hip_joint_deviation": -0.5, "waist_joint_deviation": -1.5, "joint_pos_limits": -2.0, "joint_vel_limits": -0.1,
    "torque_limits": -0.1, "no_fly": 0.25, "feet_lateral_distance": 1.0, "feet_slip": -0.05,
    "feet_ground_parallel": -2.0, "feet_contact_force": -1e-2, "feet_parallel": -2.5, "contact_momentum": -2.5e-2,
    "contact_pattern": 1.0,
}


# The Adam Lite URDF the converter tests (cra_warp/test_usd.py, tools/test_urdf2usd.py) start from
OUR_URDF = ADAM_LITE.urdf_path

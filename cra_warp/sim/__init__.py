"""Batched simulators behind one interface (cra_warp.sim.config.World): Newton (CPU, CUDA) and MuJoCo C (CPU)."""

from __future__ import annotations

from cra_warp.sim.config import FREE_Q, FREE_QD, TerrainBoxes, World, WorldConfig, check_backend_device
from robots.robot_config import RobotConfig

__all__ = ["FREE_Q", "FREE_QD", "TerrainBoxes", "World", "WorldConfig", "check_backend_device", "make_world", "mjcf"]


def make_world(robot: RobotConfig, cfg: WorldConfig | None = None, terrain: TerrainBoxes | None = None, *,
               num_envs: int, device: str = "cpu") -> World:
    """``num_envs`` robots on ``terrain`` in the backend ``cfg.backend`` names (imported only when chosen), on
    ``device``. The one place the world's size and device are checked."""
    cfg = cfg or WorldConfig()
    if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
        raise ValueError(f"make_world: num_envs must be an integer >= 1, got {num_envs!r}")
    check_backend_device(cfg.backend, device)
    if cfg.backend == "mujoco":
        from cra_warp.sim.mujoco import MujocoWorld

        return MujocoWorld(robot, cfg, terrain, num_envs)
    from cra_warp.sim.newton import NewtonWorld

    return NewtonWorld(robot, cfg, terrain, num_envs, device)


def mjcf(robot: RobotConfig, cfg: WorldConfig | None = None, terrain: TerrainBoxes | None = None) -> str:
    """The MJCF text of one world of ``cfg`` on ``terrain`` (every terrain box, no windows): the MjModel the MuJoCo C
    backend runs, videos draw and cra-sim2sim defaults to. Bodies and joints are named "<robot>_<link or joint>".
    Newton's importer and SolverMuJoCo's export build it, so it is the model Newton steps too."""
    from cra_warp.sim.newton import build_mjcf

    return build_mjcf(robot, cfg or WorldConfig(), terrain)

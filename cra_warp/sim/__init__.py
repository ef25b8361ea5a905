"""Batched simulators behind one interface (cra_warp.sim.config.World): Newton (CPU, CUDA) and MuJoCo C (CPU)."""

from __future__ import annotations

from cra_warp.sim.config import FREE_Q, FREE_QD, TerrainBoxes, World, WorldConfig
from robots.robot_config import RobotConfig

__all__ = ["FREE_Q", "FREE_QD", "TerrainBoxes", "World", "WorldConfig", "make_world"]


def make_world(robot: RobotConfig, cfg: WorldConfig | None = None, terrain: TerrainBoxes | None = None) -> World:
    """The backend ``cfg.backend`` names, built for ``robot`` on ``terrain`` (imported only when chosen)."""
    cfg = cfg or WorldConfig()
    if cfg.backend == "mujoco":
        from cra_warp.sim.mujoco import MujocoWorld

        return MujocoWorld(robot, cfg, terrain)
    from cra_warp.sim.newton import NewtonWorld

    return NewtonWorld(robot, cfg, terrain)

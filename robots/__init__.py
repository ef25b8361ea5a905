"""Robot data: descriptions and configs (no simulation code), and the registry the task's config names a robot by."""

from __future__ import annotations

from robots.adam_lite.loco import ADAM_LITE_LOCO
from robots.loco_robot import LocoRobotConfig

# LocoConfig.robot -> the robot as the locomotion task sees it (its RobotConfig is .robot). A new robot is a package
# beside adam_lite/ with its RobotConfig and LocoRobotConfig, and one line here.
ROBOTS: dict[str, LocoRobotConfig] = {r.name: r for r in (ADAM_LITE_LOCO,)}


def robot_by_name(name: str) -> LocoRobotConfig:
    """The registered robot ``name``; ValueError (one line, naming the known ones) for any other."""
    if name not in ROBOTS:
        raise ValueError(f"unknown robot {name!r} (known: {', '.join(sorted(ROBOTS))})")
    return ROBOTS[name]

"""The evaluation course (paper, Sec. IV): steps 5..35 cm, slopes 2..34 deg and uneven ground, one difficulty level
per row, a fixed seed. Each (kind, level) has a start pose and a target point; an evaluator deploys robots per
level and counts those that reach the target without falling.

Built with the training generator: one column per tile type the kinds need, one row per difficulty. Kinds:
- "stairs_ascend" / "slope_ascend": start on the rim of a pyramid tile, facing its centre; target: the top platform;
- "stairs_descend" / "slope_descend": start on the top platform; target: the rim beyond the foot of the +y face
  (ascents go along +x, so the two paths on one tile do not share a face);
- "uneven": start on the rim, cross the tile through its centre pad; target: the opposite rim.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import torch

from cra_warp.rotations import yaw_quat
from cra_warp.terrain import TERRAIN_TYPES, Terrain, TerrainConfig, generate_terrain

EVAL_KINDS = ("stairs_ascend", "stairs_descend", "slope_ascend", "slope_descend", "uneven")
_TILE_TYPE = {"stairs_ascend": "stairs_up", "stairs_descend": "stairs_up", "slope_ascend": "slope_up",
              "slope_descend": "slope_up", "uneven": "uneven"}


@dataclass
class EvalCourseConfig:
    """Seven levels: steps 5, 10, ..., 35 cm; slopes 2, 7.3, ..., 34 deg; uneven ground from the training range."""

    kinds: tuple[str, ...] = EVAL_KINDS
    num_levels: int = 7
    step_height: tuple[float, float] = (0.05, 0.35)
    slope_deg: tuple[float, float] = (2.0, 34.0)
    target_radius: float = 0.5   # [m] a robot has reached its target when its base is this close (xy)
    seed: int = 1234

    def __post_init__(self):
        bad = [k for k in self.kinds if k not in EVAL_KINDS]
        if bad or not self.kinds:
            raise ValueError(f"EvalCourseConfig.kinds must be a non-empty subset of {EVAL_KINDS}, got {self.kinds}")
        if self.target_radius <= 0:
            raise ValueError(f"EvalCourseConfig.target_radius must be > 0, got {self.target_radius}")


class Deployment(NamedTuple):
    """Robots deployed on the course, n = kinds x levels x robots per level."""

    kind: torch.Tensor        # [n] index into EvalCourse.kinds
    level: torch.Tensor       # [n]
    start: torch.Tensor       # [n, 3] ground point under the start (z = ground height)
    yaw: torch.Tensor         # [n] start heading [rad], facing the target
    target: torch.Tensor      # [n, 3] ground point of the target
    radius: float

    def reached(self, pos: torch.Tensor) -> torch.Tensor:
        """[n] bool: base position pos [n, 3] within ``radius`` (xy) of its target."""
        return (pos[:, :2] - self.target[:, :2]).norm(dim=-1) < self.radius

    def progress(self, pos: torch.Tensor) -> torch.Tensor:
        """[n] how far [m] base positions pos [n, 3] have come towards their targets: the start's distance to the
        target (xy) less theirs."""
        return ((self.target[:, :2] - self.start[:, :2]).norm(dim=-1) - (self.target[:, :2] - pos[:, :2]).norm(dim=-1))

    def heading_to_target(self, pos: torch.Tensor) -> torch.Tensor:
        """[n] world heading [rad] from base position pos [n, 3] to its target (what a robot is steered at)."""
        to_target = self.target[:, :2] - pos[:, :2]
        return torch.atan2(to_target[:, 1], to_target[:, 0])

    def spawn_pose(self, base_height: float, clearance: float = 0.01) -> tuple[torch.Tensor, torch.Tensor]:
        """Base position [n, 3] (ground + base_height + clearance) and quaternion [n, 4] xyzw (yaw only)."""
        pos = self.start.clone()
        pos[:, 2] += base_height + clearance
        return pos, yaw_quat(self.yaw)


class EvalCourse:
    """Terrain, starts [K, L, 3], yaws [K, L] and targets [K, L, 3] of the evaluation course (K kinds, L levels)."""

    def __init__(self, cfg: EvalCourseConfig | None = None):
        self.cfg = cfg = cfg or EvalCourseConfig()
        self.kinds = cfg.kinds
        types = sorted({_TILE_TYPE[k] for k in cfg.kinds}, key=TERRAIN_TYPES.index)
        proportions = tuple(1.0 if t in types else 0.0 for t in TERRAIN_TYPES)
        self.terrain: Terrain = generate_terrain(TerrainConfig(
            num_levels=cfg.num_levels, num_cols=len(types), proportions=proportions, step_height=cfg.step_height,
            slope_deg=cfg.slope_deg, seed=cfg.seed))
        t = self.terrain
        rim = t.tile(0, 0).half_inner + t.cfg.tile_margin / 2   # middle of the rim, from the tile centre
        K, L = len(self.kinds), cfg.num_levels
        self.starts, self.targets = np.zeros((K, L, 3)), np.zeros((K, L, 3))
        self.yaws = np.zeros((K, L))
        self.difficulty = np.zeros((K, L))
        for k, kind in enumerate(self.kinds):
            col = t.column_types.index(_TILE_TYPE[kind])
            for lv in range(L):
                tile = t.tile(lv, col)
                cx, cy = tile.centre
                start, target = {"stairs_ascend": ((cx - rim, cy), (cx, cy)), "slope_ascend": ((cx - rim, cy), (cx, cy)),
                                 "stairs_descend": ((cx, cy), (cx, cy + rim)), "slope_descend": ((cx, cy), (cx, cy + rim)),
                                 "uneven": ((cx - rim, cy), (cx + rim, cy))}[kind]
                self.starts[k, lv] = (*start, float(t.field.height_at(*start)))
                self.targets[k, lv] = (*target, float(t.field.height_at(*target)))
                self.yaws[k, lv] = math.atan2(target[1] - start[1], target[0] - start[0])
                self.difficulty[k, lv] = tile.difficulty

    def deploy(self, robots_per_level: int = 200, device: str | torch.device = "cpu") -> Deployment:
        """All robots of one (kind, level) share its start pose: worlds do not collide with each other."""
        K, L = self.starts.shape[:2]
        kind = torch.arange(K, device=device).repeat_interleave(L * robots_per_level)
        level = torch.arange(L, device=device).repeat_interleave(robots_per_level).repeat(K)

        def per_robot(a):
            return torch.as_tensor(a, dtype=torch.float32, device=device)[kind, level]

        return Deployment(kind, level, per_robot(self.starts), per_robot(self.yaws), per_robot(self.targets),
                          self.cfg.target_radius)

    def success_rate(self, dep: Deployment, succeeded: torch.Tensor) -> torch.Tensor:
        """[K, L] fraction of robots per (kind, level) with ``succeeded`` [n] (reached and never fell)."""
        K, L = self.starts.shape[:2]
        flat = dep.kind * L + dep.level
        total = torch.bincount(flat, minlength=K * L).clamp_min(1)
        ok = torch.bincount(flat, weights=succeeded.float(), minlength=K * L)
        return (ok / total).view(K, L)

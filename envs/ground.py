"""The ground the task walks on: collision boxes for the world, heights and height maps for observations, spawn
points and the terrain curriculum.

"flat": the ground plane; robots spawn on a 2 m grid (worlds never collide with each other: the spacing only keeps
a recorded rollout readable). "rough": cra_warp.terrain's curriculum course (stairs, slopes, uneven ground), its
collision boxes and its level curriculum. "eval": the evaluation course (cra_warp.terrain.course); every robot
spawns at its deployment's start pose, facing its target, and no curriculum runs. All sample heights through the
same HeightSampler.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import torch

from cra_warp.terrain import ROBOT_WAY, HeightField, TerrainConfig, generate_terrain
from cra_warp.terrain.boxes import terrain_boxes
from cra_warp.terrain.course import Deployment, EvalCourse, EvalCourseConfig
from cra_warp.terrain.curriculum import TerrainCurriculum, levels_by_type
from cra_warp.terrain.sampling import HeightSampler
from cra_warp.sim import TerrainBoxes

GROUND_KINDS = ("flat", "rough", "eval")


class Ground:
    def __init__(self, kind: str, num_envs: int, device: torch.device, seed: int = 0,
                 course: EvalCourseConfig | None = None, curriculum_rule: str = "path",
                 rough: TerrainConfig | None = None):
        if kind not in GROUND_KINDS:
            raise ValueError(f"LocoConfig.terrain must be one of {GROUND_KINDS}, got {kind!r}")
        self.kind = kind
        self.boxes: TerrainBoxes | None = None
        self.curriculum: TerrainCurriculum | None = None
        self.course: EvalCourse | None = None
        self.deployment: Deployment | None = None
        self._climbing: torch.Tensor | None = None
        if kind == "eval":
            self.course = EvalCourse(course)
            per_level = num_envs // self.course.starts[..., 0].size   # LocoConfig checked divisibility
            self.deployment = self.course.deploy(per_level, device)
            self.boxes = terrain_boxes(self.course.terrain)
            field = self.course.terrain.field
        elif kind == "rough":
            # the run's seed draws the tiles, whatever rough.seed says
            terrain = generate_terrain(dataclasses.replace(rough or TerrainConfig(), seed=seed))
            self.column_types = terrain.column_types
            self.boxes = terrain_boxes(terrain)
            self.curriculum = TerrainCurriculum(terrain, num_envs, device, seed=seed, rule=curriculum_rule)
            field = terrain.field
        else:
            # A zero field the size of one cell: lookups clamp to its border, i.e. height 0 everywhere.
            field = HeightField(np.zeros((2, 2), np.float32), 1.0, (0.0, 0.0))
            side = math.ceil(math.sqrt(num_envs))
            ij = torch.stack(torch.meshgrid(torch.arange(side), torch.arange(side), indexing="ij"), -1).reshape(-1, 2)
            self._origins = torch.cat([2.0 * ij[:num_envs].float(), torch.zeros(num_envs, 1)], -1).to(device)
        self.sampler = HeightSampler(field, device)
        self.foot_map_cells = math.prod(self.sampler.maps.foot_shape)

    # Inputs pass through nan_to_num: a world that went non-finite is sampled once before it is reset, and a NaN
    # coordinate would index outside the height array.
    def heights(self, xy: torch.Tensor) -> torch.Tensor:
        """Ground height [...] at points xy [..., 2]."""
        return self.sampler.heights(torch.nan_to_num(xy))

    def height_map(self, base_pos: torch.Tensor, base_quat: torch.Tensor) -> torch.Tensor:
        """[N, 17, 11] ground heights minus base height on a yaw-aligned grid around the base."""
        return self.sampler.base_map(torch.nan_to_num(base_pos), torch.nan_to_num(base_quat))

    def foot_height_maps(self, sole_centres: torch.Tensor, feet_quat: torch.Tensor) -> torch.Tensor:
        """[N, F, 5, 5] ground heights minus sole height on a grid around each sole centre."""
        return self.sampler.foot_maps(torch.nan_to_num(sole_centres), torch.nan_to_num(feet_quat))

    def spawn_origins(self, ids: torch.Tensor) -> torch.Tensor:
        """[n, 3] ground points where the envs ``ids`` start their next episode."""
        if self.deployment is not None:
            return self.deployment.start[ids]
        return self.curriculum.origins[ids] if self.curriculum is not None else self._origins[ids]

    def spawn_yaw(self, ids: torch.Tensor) -> torch.Tensor | None:
        """[n] start headings of the envs ``ids`` on the evaluation course (facing the target); None: any heading."""
        return self.deployment.yaw[ids] if self.deployment is not None else None

    def update_curriculum(self, ids: torch.Tensor, walked: torch.Tensor, farthest: torch.Tensor,
                          commanded: torch.Tensor, fell: torch.Tensor | None = None):
        if self.curriculum is not None:
            self.curriculum.update(ids, walked, farthest, commanded, fell)

    def climbing_envs(self) -> torch.Tensor | None:
        """[N] bool: envs living on tiles they must climb out of (pits); None off the rough curriculum."""
        if self.curriculum is None:
            return None
        if self._climbing is None:  # env i lives on column i mod C for the whole run
            climbs = torch.tensor([ROBOT_WAY.get(t) == "climbs" for t in self.column_types],
                                  device=self.curriculum.device)
            self._climbing = climbs[self.curriculum.cols]
        return self._climbing

    def fall_line_heading(self, xy: torch.Tensor, random_axis: torch.Tensor) -> torch.Tensor:
        """[N] world heading along the tile axis from each env's tile centre towards its robot at ``xy`` [N, 2]
        (up a pit's face: the axis the robot is farthest along); within 0.5 m of the centre the axis
        ``random_axis`` [N] (0..3). Rough ground only."""
        rel = xy - self.curriculum.origins[:, :2]
        along_x = rel[:, 0].abs() >= rel[:, 1].abs()
        axis = torch.where(along_x, torch.where(rel[:, 0] >= 0, 0, 2), torch.where(rel[:, 1] >= 0, 1, 3))
        axis = torch.where(rel.norm(dim=-1) < 0.5, random_axis, axis)
        return axis.float() * (math.pi / 2)

    def mean_level(self) -> float:
        return float(self.curriculum.mean_level()) if self.curriculum is not None else 0.0

    def mean_level_by_type(self) -> dict[str, torch.Tensor]:
        """Mean level of the robots on each terrain type's columns, for the logs (pits are the ascents)."""
        if self.curriculum is None:
            return {}
        return levels_by_type(self.curriculum.levels, self.column_types)

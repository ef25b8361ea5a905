"""The ground the task walks on: collision boxes for the world, heights and height maps for observations,
spawn points and the terrain curriculum. "flat" is the plane; "rough" is the curriculum course of cra_warp.terrain.
"""

from __future__ import annotations

import math

import torch

from cra_warp.rotations import quat_rotate, yaw
from cra_warp.world import TerrainBoxes

GLOBAL_MAP = (17, 11)      # rows along the heading, columns across it
GLOBAL_SPACING = 0.1       # [m]
FOOT_MAP = (5, 5)
FOOT_SPACING = 0.05        # [m]


def grid(shape: tuple[int, int], spacing: float, device) -> torch.Tensor:
    """Points [R*C, 3] of a centred grid in the xy plane (x forward along rows)."""
    r, c = shape
    x = (torch.arange(r, device=device) - (r - 1) / 2) * spacing
    y = (torch.arange(c, device=device) - (c - 1) / 2) * spacing
    gx, gy = torch.meshgrid(x, y, indexing="ij")
    return torch.stack([gx.flatten(), gy.flatten(), torch.zeros(r * c, device=device)], -1)


class Ground:
    foot_map_cells = FOOT_MAP[0] * FOOT_MAP[1]

    def __init__(self, kind: str, num_envs: int, device: torch.device, seed: int = 0):
        if kind != "flat":
            raise ValueError(f"LocoConfig.terrain must be 'flat' (rough terrain comes with the terrain layer), got {kind!r}")
        self.kind, self.num_envs, self.device = kind, num_envs, device
        self.boxes: TerrainBoxes | None = None
        self._global = grid(GLOBAL_MAP, GLOBAL_SPACING, device)
        self._foot = grid(FOOT_MAP, FOOT_SPACING, device)
        side = math.ceil(math.sqrt(num_envs))
        ij = torch.stack(torch.meshgrid(torch.arange(side), torch.arange(side), indexing="ij"), -1).reshape(-1, 2)
        # Worlds never collide with each other; spacing them only keeps a recorded rollout readable.
        self._origins = torch.cat([2.0 * ij[:num_envs].float(), torch.zeros(num_envs, 1)], -1).to(device)

    def heights(self, xy: torch.Tensor) -> torch.Tensor:
        """Ground height [...] at points xy [..., 2]."""
        return torch.zeros(xy.shape[:-1], device=xy.device)

    def _map(self, centre: torch.Tensor, quat: torch.Tensor, pts: torch.Tensor, shape) -> torch.Tensor:
        h = yaw(quat)
        heading = torch.stack([torch.zeros_like(h), torch.zeros_like(h), torch.sin(h / 2), torch.cos(h / 2)], -1)
        world = quat_rotate(heading.unsqueeze(-2), pts) + centre.unsqueeze(-2)  # [..., P, 3]
        return (self.heights(world[..., :2]) - centre[..., 2:3]).reshape(*centre.shape[:-1], *shape)

    def height_map(self, base_pos: torch.Tensor, base_quat: torch.Tensor) -> torch.Tensor:
        """[N, 17, 11] ground heights minus base height on a yaw-aligned grid around the base."""
        return self._map(base_pos, base_quat, self._global, GLOBAL_MAP)

    def foot_height_maps(self, sole_centres: torch.Tensor, feet_quat: torch.Tensor) -> torch.Tensor:
        """[N, F, 5, 5] ground heights minus sole height on a grid around each sole centre."""
        return self._map(sole_centres, feet_quat, self._foot, FOOT_MAP)

    def spawn_origins(self, ids: torch.Tensor) -> torch.Tensor:
        return self._origins[ids]

    def update_curriculum(self, ids: torch.Tensor, walked: torch.Tensor, commanded: torch.Tensor):
        pass  # one level on flat ground

    def mean_level(self) -> float:
        return 0.0

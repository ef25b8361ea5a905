"""Per-world terrain windows: each world holds only the terrain boxes near its robot.

Why: MuJoCo Warp tests every (robot geom, terrain geom) pair of a world in its broad phase at every substep, so a
course shared by all worlds costs in proportion to its box count. Measured at N=256 (sole contacts only): the
897-box training course slowed the Newton step by 16% with every robot standing on plain ground far from any box.
With windows each world has ``slots`` static boxes, refilled from the course whenever its robot moves more than
``recentre`` from the window's centre (along x or y); unused slots are parked deep below the ground.

A window is the square of half-width ``half_width`` around its centre; it holds every box whose footprint (the xy
bounding box of the possibly rotated box) meets the square. On the default course a 2 m half-width window meets at
most 32 boxes (42 at 2.5 m). More than ``slots`` boxes keep the nearest and count an overflow.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from cra_warp.rotations import quat_rotate

PARK_DEPTH = -100.0   # [m] z of unused slots: far below anything a robot reaches
PARK_HALF = 0.05      # [m] half extent of an unused slot's box


@dataclass
class WindowConfig:
    slots: int = 48            # boxes per world
    half_width: float = 2.0    # [m] the window square around its centre
    recentre: float = 1.0      # [m] refill when the robot's base is this far (along x or y) from the window centre

    def __post_init__(self):
        if self.slots < 1:
            raise ValueError(f"WindowConfig.slots must be >= 1, got {self.slots}")
        if not 0 < self.recentre < self.half_width:
            raise ValueError(f"WindowConfig.recentre must be in (0, half_width={self.half_width}), got {self.recentre}")


class TerrainWindows:
    """Selects, per world, the boxes of a course that meet a square window; the world writes them into its slots.

    centers [B, 3], half_extents [B, 3], quats [B, 4] xyzw: the whole course, on ``device``.
    """

    def __init__(self, centers, half_extents, quats, num_envs: int, cfg: WindowConfig, device):
        f = dict(dtype=torch.float32, device=device)
        self.cfg = cfg
        self.centers = torch.as_tensor(centers, **f)
        self.half_extents = torch.as_tensor(half_extents, **f)
        self.quats = torch.as_tensor(quats, **f)
        # xy half-size of each box's axis-aligned footprint: |R| @ half extents
        axes = torch.stack([quat_rotate(self.quats, e.expand_as(self.centers)) for e in torch.eye(3, **f)], -1)
        self.footprint = (axes.abs() @ self.half_extents.unsqueeze(-1)).squeeze(-1)[:, :2]
        self.window_centre = torch.full((num_envs, 2), float("inf"), **f)  # inf: empty, refilled at first follow
        self.overflows = 0   # refills that met more boxes than slots

    def stale(self, base_xy: torch.Tensor) -> torch.Tensor:
        """Indices of the worlds whose robot (base xy [N, 2]) is more than ``recentre`` from its window's centre
        along x or y. A non-finite position is never stale: that world is reset (and refilled) by its owner."""
        far = (base_xy - self.window_centre).abs().amax(-1) > self.cfg.recentre
        return (far & torch.isfinite(base_xy).all(-1)).nonzero().flatten()

    def select(self, ids: torch.Tensor, centre_xy: torch.Tensor):
        """Boxes for the windows of worlds ``ids`` centred at ``centre_xy`` [n, 2]: centers [n, K, 3],
        half_extents [n, K, 3], quats [n, K, 4], nearest first; slots without a box hold a parked box."""
        K = self.cfg.slots
        gap = ((centre_xy[:, None] - self.centers[None, :, :2]).abs() - self.footprint).clamp_min(0.0)  # [n, B, 2]
        meets = gap.amax(-1) <= self.cfg.half_width
        self.overflows += int((meets.sum(1) > K).sum())
        key = torch.where(meets, gap.norm(dim=-1), float("inf"))
        k = min(K, key.shape[1])
        dist, idx = torch.topk(key, k, dim=1, largest=False)
        used = torch.isfinite(dist).unsqueeze(-1)
        n, dev = len(ids), centre_xy.device
        centers = torch.zeros(n, K, 3, device=dev)
        half = torch.full((n, K, 3), PARK_HALF, device=dev)
        quats = torch.zeros(n, K, 4, device=dev)
        quats[..., 3] = 1.0
        centers[..., 2] = PARK_DEPTH
        centers[:, :k] = torch.where(used, self.centers[idx], centers[:, :k])
        half[:, :k] = torch.where(used, self.half_extents[idx], half[:, :k])
        quats[:, :k] = torch.where(used, self.quats[idx], quats[:, :k])
        self.window_centre[ids] = centre_xy
        return centers, half, quats

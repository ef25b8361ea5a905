"""Batched, differentiable height sampling of a heightfield in torch: the critic's terrain maps.

All functions take plain tensors (no World): base pos [N, 3], base quat [N, 4] xyzw, sole centres [N, 2, 3],
foot quats [N, 2, 4] xyzw, and run on the heightfield's device. Heights are bilinear between samples and
differentiable in the query points; points outside the field clamp to its border.

Cost is about twenty passes over the N x (187 + 2 x 25) points: the map grid is one small matmul per axis, and each
point gathers its four corners from the one height array with int32 indices. The gathers are bound by cache
misses: measured on this CPU at ~1M points, an int32-indexed float32 gather ~1 ms, int64 indices ~3x slower; four
gathers from four precomputed coefficient arrays (4x the memory) ~2x slower, one packed 16-byte gather ~7x slower;
grid_sample (~20 ms) and a Warp CPU kernel (~16 ns per point) were slower too. All maps of one env step at N=4096
(970k points), quiet machine, freed memory kept (cra_warp.host_memory; with glibc's defaults every temporary
page-faults and eager takes ~45 ms): eager 18-19 ms on one torch thread, 14 ms on two;
HeightMapConfig(compile=True) 9-14 ms on one thread, 4.3-7 ms on two (run to run). Against ~3 s of Newton step at that N, the maps are < 1% of an env step.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import torch

from cra_warp.terrain import HeightField


@dataclass
class HeightMapConfig:
    """Map layouts (the paper's critic: a 17 x 11 map around the base, a 5 x 5 map under each foot)."""

    base_shape: tuple[int, int] = (17, 11)   # points along the base's heading (x, forward) and its left (y)
    base_spacing: float = 0.1                # [m]
    foot_shape: tuple[int, int] = (5, 5)     # points along the foot's x and y
    foot_spacing: float = 0.05               # [m]
    compile: bool = False                    # torch.compile the map kernel: ~1.6x faster on this CPU (one fused
                                             # loop), ~3 s at the first call (~15 s with an empty inductor cache)


def grid_offsets(shape: tuple[int, int], spacing: float, device=None) -> torch.Tensor:
    """[a * b, 2] xy offsets of a centred grid, x-major (row k = point (k // b, k % b))."""
    a, b = shape
    x = (torch.arange(a, dtype=torch.float32, device=device) - (a - 1) / 2) * spacing
    y = (torch.arange(b, dtype=torch.float32, device=device) - (b - 1) / 2) * spacing
    return torch.stack(torch.meshgrid(x, y, indexing="ij"), -1).reshape(-1, 2)


def heading_xy(quat_xyzw: torch.Tensor) -> torch.Tensor:
    """Unit heading [..., 2] (cos yaw, sin yaw): the body x axis projected on the ground. Quaternions xyzw."""
    x, y, z, w = quat_xyzw.unbind(-1)
    h = torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z)], -1)
    return h / h.norm(dim=-1, keepdim=True).clamp_min(1e-6)


class HeightSampler:
    """A heightfield on ``device`` with bilinear, differentiable lookups and the critic's yaw-aligned maps."""

    def __init__(self, field: HeightField, device: str | torch.device = "cpu", maps: HeightMapConfig | None = None):
        self.device = torch.device(device)
        self.maps = maps or HeightMapConfig()
        self.shape = field.shape                               # (nx, ny)
        self.resolution = field.resolution
        self.origin = field.origin
        self._flat = torch.as_tensor(field.heights, dtype=torch.float32).reshape(-1).contiguous().to(self.device)
        self._inv_res = 1.0 / field.resolution
        self.base_offsets = grid_offsets(self.maps.base_shape, self.maps.base_spacing, self.device)  # [Pb, 2]
        self.foot_offsets = grid_offsets(self.maps.foot_shape, self.maps.foot_spacing, self.device)  # [Pf, 2]
        if self.maps.compile:
            self._local_map = torch.compile(self._local_map, dynamic=False)

    def _bilinear(self, fx: torch.Tensor, fy: torch.Tensor) -> torch.Tensor:
        """Heights at continuous sample indices fx (along x), fy (along y), any equal shapes; clamped to the field."""
        nx, ny = self.shape
        fx = fx.clamp(0.0, nx - 1.0)
        fy = fy.clamp(0.0, ny - 1.0)
        i = fx.detach().to(torch.int32).clamp_(max=nx - 2)   # truncation = floor (fx >= 0); int32: 3x faster gather
        j = fy.detach().to(torch.int32).clamp_(max=ny - 2)
        wx, wy = fx - i, fy - j                                # the only path gradients take
        cell = i.mul_(ny).add_(j).view(-1)                   # flat index of corner (i, j)
        right, up = cell + ny, cell + 1
        h00, h10, h01, h11 = (self._flat.index_select(0, k).view(fx.shape) for k in (cell, right, up, right + 1))
        # h00 + wx (h10 - h00), etc.; torch.lerp is ~4x slower than sub + addcmul on this CPU
        a = torch.addcmul(h00, wx, h10 - h00)
        b = torch.addcmul(h01, wx, h11 - h01)
        return torch.addcmul(a, wy, b - a)

    def heights(self, xy: torch.Tensor) -> torch.Tensor:
        """Ground heights [...] at world points xy [..., 2] (a trailing z, [..., 3], is ignored)."""
        xy = xy.to(torch.float32)
        return self._bilinear((xy[..., 0] - self.origin[0]) * self._inv_res, (xy[..., 1] - self.origin[1]) * self._inv_res)

    def _local_map(self, centre: torch.Tensor, heading: torch.Tensor, offsets: torch.Tensor) -> torch.Tensor:
        """Heights at centre.xy + R(yaw) offsets, minus centre.z. centre [M, 3], heading [M, 2], offsets [P, 2]
        -> [M, P]. The rotation and the index scaling are one small matmul per axis."""
        centre = centre.to(torch.float32)
        c, s = heading[:, 0:1] * self._inv_res, heading[:, 1:2] * self._inv_res
        bx = (centre[:, 0:1] - self.origin[0]) * self._inv_res
        by = (centre[:, 1:2] - self.origin[1]) * self._inv_res
        fx = torch.addmm(bx, torch.cat([c, -s], 1), offsets.T)   # [M, P]: x index of c.x + cos*ox - sin*oy
        fy = torch.addmm(by, torch.cat([s, c], 1), offsets.T)
        return self._bilinear(fx, fy) - centre[:, 2:3]

    def base_map(self, base_pos: torch.Tensor, base_quat: torch.Tensor) -> torch.Tensor:
        """[N, 17, 11] terrain height minus base height on a grid around the base, aligned with its heading
        (dim 1 forward, dim 2 left; negative = terrain below the base). base_pos [N, 3], base_quat [N, 4] xyzw."""
        m = self._local_map(base_pos, heading_xy(base_quat), self.base_offsets)
        return m.view(len(base_pos), *self.maps.base_shape)

    def foot_maps(self, sole_centres: torch.Tensor, foot_quats: torch.Tensor) -> torch.Tensor:
        """[N, F, 5, 5] terrain height minus sole height around each sole centre, aligned with the foot's heading.
        sole_centres [N, F, 3], foot_quats [N, F, 4] xyzw."""
        N, nf = sole_centres.shape[:2]
        m = self._local_map(sole_centres.reshape(-1, 3), heading_xy(foot_quats.reshape(-1, 4)), self.foot_offsets)
        return m.view(N, nf, *self.maps.foot_shape)


def bench_height_maps(num_envs: int = 4096, device: str = "cpu", repeats: int = 20,
                      sampler: HeightSampler | None = None) -> dict:
    """Time of one env step's maps (base map + both foot maps) for ``num_envs`` robots; no assertions.

    ``sampler`` defaults to the default training terrain on ``device``. Robots are scattered over the field with
    random orientations. Returns {"num_envs", "ms_per_step" (median), "points", "torch_threads"}.
    """
    if sampler is None:
        from cra_warp.terrain import generate_terrain

        sampler = HeightSampler(generate_terrain().field, device)
    gen = torch.Generator(device="cpu").manual_seed(0)
    span = torch.tensor([(n - 1) * sampler.resolution for n in sampler.shape])
    pos = torch.rand(num_envs, 3, generator=gen)
    pos[:, :2] = torch.tensor(sampler.origin) + pos[:, :2] * span
    pos[:, 2] = 3.0
    pos = pos.to(sampler.device)
    quat = torch.nn.functional.normalize(torch.randn(num_envs, 4, generator=gen), dim=-1).to(sampler.device)
    soles = pos[:, None, :] + torch.tensor([[0.03, 0.1, -0.88], [0.03, -0.1, -0.88]], device=sampler.device)
    feet_q = quat[:, None].expand(-1, 2, -1).contiguous()
    times = []
    for _ in range(repeats + 2):
        if sampler.device.type == "cuda":
            torch.cuda.synchronize(sampler.device)
        t0 = time.perf_counter()
        with torch.no_grad():  # observations: no graph
            sampler.base_map(pos, quat)
            sampler.foot_maps(soles, feet_q)
        if sampler.device.type == "cuda":
            torch.cuda.synchronize(sampler.device)
        times.append(time.perf_counter() - t0)
    times = sorted(times[2:])
    points = num_envs * (sampler.base_offsets.shape[0] + 2 * sampler.foot_offsets.shape[0])
    return {"num_envs": num_envs, "ms_per_step": 1e3 * times[len(times) // 2], "points": points,
            "torch_threads": torch.get_num_threads()}

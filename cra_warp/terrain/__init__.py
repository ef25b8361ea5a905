"""Terrain generation: one heightfield holding a grid of tiles, rows = difficulty levels, columns = terrain types.

The heightfield array is the single source of truth: collision boxes (``boxes``), height sampling (``sampling``),
spawn origins and the evaluation course (``course``) are all derived from it; ``curriculum`` moves robots between
levels, ``window`` gives each world the boxes near its robot.

Layout (world frame, z up): tile (level l, column c) is the square [x0 + l T, x0 + (l + 1) T] x [y0 + c T, ...],
T = ``tile_size``; a flat border surrounds the grid. Sample [i, j] of the array is the ground height at the centre
of cell [i, j]: x = origin_x + i * resolution, y = origin_y + j * resolution. Every tile keeps a flat rim
(``tile_margin``) at ``base_height``, so neighbouring tiles meet without cliffs.

Heights are shifted so that the lowest point of the field (the bottom of the deepest pit) is z = 0, the height of
World's ground plane: the plane lies under the whole field and pits stay open. The field starts ``field_offset``
metres from the world origin, so the origin (where World places its robots while it builds) is on the bare plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

# Column types, in the order of TerrainConfig.proportions. "up" tiles rise towards their centre (spawn on top),
# "down" tiles are pits (spawn at the bottom).
TERRAIN_TYPES = ("flat", "stairs_up", "stairs_down", "slope_up", "slope_down", "uneven")
# what a robot spawned on each type does to leave its tile (the names say the ground, not the robot's way)
ROBOT_WAY = {"stairs_up": "descends", "slope_up": "descends", "stairs_down": "climbs", "slope_down": "climbs"}


@dataclass
class TerrainConfig:
    """The training terrain. Defaults are sized for the 2-core CPU (10 x 6 tiles of 8 m, 5 cm cells)."""

    num_levels: int = 10                     # rows: difficulty levels 0..L-1
    num_cols: int = 6                        # columns, shared among the types by ``proportions``
    tile_size: float = 8.0                   # [m], a multiple of resolution
    resolution: float = 0.05                 # [m] cell size of the heightfield
    border: float = 3.0                      # [m] flat ground around the tile grid
    field_offset: float = 1.0                # [m] gap between the world origin and the field's outer corner
    tile_margin: float = 0.5                 # [m] flat rim of every tile at the base height
    platform_size: float = 3.0               # [m] edge of the centre platform of pyramid tiles
    proportions: tuple[float, float, float, float, float, float] = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)  # TERRAIN_TYPES
    step_height: tuple[float, float] = (0.05, 0.35)    # [m] stair rise at level 0 .. top level
    tread: float = 0.3                       # [m] stair depth
    slope_deg: tuple[float, float] = (2.0, 34.0)       # pyramid slope angle at level 0 .. top level
    uneven_cell: float = 0.5                 # [m] cell of the random-height grid (one collision box per cell)
    uneven_height: tuple[float, float] = (0.02, 0.08)  # [m] max random cell height at level 0 .. top level
    uneven_density: float = 0.2              # fraction of grid squares raised (each raised square costs a box)
    uneven_quantum: float = 0.01             # [m] random heights are multiples of this (equal cells merge into boxes)
    obstacles: int = 4                       # discrete obstacles per uneven tile
    obstacle_height: tuple[float, float] = (0.04, 0.20)  # [m] obstacle height at level 0 .. top level
    obstacle_size: tuple[float, float] = (0.5, 1.0)    # [m] obstacle edge range
    spawn_pad: float = 1.0                   # [m] flat pad at the centre of uneven tiles (the spawn origin)
    seed: int = 0

    def __post_init__(self):
        def fail(name, why):
            raise ValueError(f"TerrainConfig.{name} {why}")

        if self.num_levels < 1:
            fail("num_levels", f"must be >= 1, got {self.num_levels}")
        if self.num_cols < 1:
            fail("num_cols", f"must be >= 1, got {self.num_cols}")
        if self.resolution <= 0:
            fail("resolution", f"must be > 0, got {self.resolution}")
        if self.tile_size <= 0 or not _is_multiple(self.tile_size, self.resolution):
            fail("tile_size", f"must be a positive multiple of resolution {self.resolution}, got {self.tile_size}")
        if self.border < 0 or not _is_multiple(self.border, self.resolution):
            fail("border", f"must be a multiple of resolution {self.resolution} (>= 0), got {self.border}")
        for name in ("tile_margin", "platform_size", "tread", "uneven_cell", "spawn_pad", "field_offset",
                     "uneven_quantum"):
            v = getattr(self, name)
            if v < 0 or (name in ("tread", "uneven_cell", "uneven_quantum") and v == 0):
                fail(name, f"must be {'>' if name in ('tread', 'uneven_cell', 'uneven_quantum') else '>='} 0, got {v}")
        if 2 * self.tile_margin + self.platform_size > self.tile_size:
            fail("platform_size", f"{self.platform_size} plus two margins {self.tile_margin} exceeds the tile "
                                  f"{self.tile_size}")
        for name in ("step_height", "slope_deg", "uneven_height", "obstacle_height", "obstacle_size"):
            lo, hi = getattr(self, name)
            if lo < 0 or hi < lo:
                fail(name, f"must be a range 0 <= min <= max, got ({lo}, {hi})")
        if self.slope_deg[1] >= 60:
            fail("slope_deg", f"max must be < 60 deg, got {self.slope_deg[1]}")
        if not 0 <= self.uneven_density <= 1:
            fail("uneven_density", f"must be in [0, 1], got {self.uneven_density}")
        if self.obstacles < 0:
            fail("obstacles", f"must be >= 0, got {self.obstacles}")
        if len(self.proportions) != len(TERRAIN_TYPES) or min(self.proportions) < 0 or sum(self.proportions) <= 0:
            fail("proportions", f"must be {len(TERRAIN_TYPES)} weights >= 0 {TERRAIN_TYPES} with a positive sum, "
                                f"got {tuple(self.proportions)}")

    def level_fraction(self, level: int) -> float:
        """0 at level 0, 1 at the top level."""
        return level / (self.num_levels - 1) if self.num_levels > 1 else 0.0


def _is_multiple(value: float, step: float) -> bool:
    k = round(value / step)
    return abs(k * step - value) < 1e-6 * max(1.0, abs(value))


def _lerp(rng: tuple[float, float], f: float) -> float:
    return rng[0] + (rng[1] - rng[0]) * f


@dataclass
class HeightField:
    """Ground heights on a regular grid: heights[i, j] at world (origin[0] + i res, origin[1] + j res)."""

    heights: np.ndarray              # [nx, ny] float32, m
    resolution: float                # m
    origin: tuple[float, float]      # world xy of sample [0, 0] (a cell centre)

    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape

    def cell_xy(self, i, j):
        """World xy of sample (i, j) (arrays or scalars)."""
        return self.origin[0] + np.asarray(i) * self.resolution, self.origin[1] + np.asarray(j) * self.resolution

    def height_at(self, x, y) -> np.ndarray:
        """Bilinear height at world points (numpy, float64), clamped to the field: the reference for tests."""
        fx = np.clip((np.asarray(x, float) - self.origin[0]) / self.resolution, 0, self.shape[0] - 1)
        fy = np.clip((np.asarray(y, float) - self.origin[1]) / self.resolution, 0, self.shape[1] - 1)
        i0 = np.minimum(np.floor(fx).astype(int), self.shape[0] - 2)
        j0 = np.minimum(np.floor(fy).astype(int), self.shape[1] - 2)
        wx, wy = fx - i0, fy - j0
        h = self.heights.astype(np.float64)
        return ((1 - wx) * (1 - wy) * h[i0, j0] + wx * (1 - wy) * h[i0 + 1, j0]
                + (1 - wx) * wy * h[i0, j0 + 1] + wx * wy * h[i0 + 1, j0 + 1])


@dataclass
class Tile:
    """One tile of the grid and the numbers its geometry was made from (the box builder needs the slopes')."""

    level: int
    col: int
    kind: str                        # one of TERRAIN_TYPES
    difficulty: float                # stair rise [m], slope [deg], uneven max height [m]; 0 for flat
    centre: tuple[float, float]      # world xy
    cells: tuple[slice, slice]       # the tile's cells in HeightField.heights
    half_inner: float                # [m] half edge of the part inside the margin (L)
    half_platform: float             # [m] half edge of the centre platform (p); pyramids only


@dataclass
class Terrain:
    """A generated terrain: the heightfield, its tiles and spawn origins."""

    cfg: TerrainConfig
    field: HeightField
    base_height: float                       # [m] height of the border and every tile's rim
    column_types: tuple[str, ...]            # [C]
    tiles: list[Tile] = field(default_factory=list)   # level-major: tiles[l * C + c]
    origins: np.ndarray = None               # [L, C, 3] spawn points: tile centre at ground height
    difficulty: np.ndarray = None            # [L, C] nominal difficulty (see Tile.difficulty)

    @property
    def num_levels(self) -> int:
        return self.cfg.num_levels

    @property
    def num_cols(self) -> int:
        return len(self.column_types)

    def tile(self, level: int, col: int) -> Tile:
        return self.tiles[level * self.num_cols + col]


def column_types(cfg: TerrainConfig) -> tuple[str, ...]:
    """Types of the ``num_cols`` columns by ``proportions`` (largest remainder), grouped in TERRAIN_TYPES order."""
    w = np.asarray(cfg.proportions, float)
    share = w / w.sum() * cfg.num_cols
    count = np.floor(share).astype(int)
    for k in np.argsort(-(share - count), kind="stable")[: cfg.num_cols - count.sum()]:
        count[k] += 1
    return tuple(t for t, n in zip(TERRAIN_TYPES, count) for _ in range(n))


# ---------------------------------------------------------------- tile shapes (heights relative to the rim)
def _edge_distance_cells(n: int) -> np.ndarray:
    """[n, n] Chebyshev distance of each cell from the tile edge, in cells (0 = an edge cell)."""
    e = np.minimum(np.arange(n), np.arange(n)[::-1])
    return np.minimum(e[:, None], e[None, :])


def _stairs(n: int, margin_c: int, tread_c: int, steps: int, rise: float) -> np.ndarray:
    """Pyramid of ``steps`` rises: rings of ``tread_c`` cells inside the rim, the last one the platform."""
    e = _edge_distance_cells(n)
    k = np.where(e < margin_c, 0, np.minimum(1 + (e - margin_c) // tread_c, steps))
    return (k * rise).astype(np.float64)


def _slope(u: np.ndarray, half_inner: float, half_platform: float, angle_deg: float) -> np.ndarray:
    """Pyramid with four planar faces rising at ``angle_deg`` from the rim to a flat platform."""
    d = np.maximum(np.abs(u)[:, None], np.abs(u)[None, :])
    return math.tan(math.radians(angle_deg)) * np.clip(half_inner - d, 0.0, half_inner - half_platform)


def _uneven(n: int, margin_c: int, cell_c: int, pad_c: int, amp: float, quantum: float, density: float,
            obstacles: int, obstacle_h: float, obstacle_size_c: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """A grid of ``cell_c``-cell squares, a ``density`` fraction of them raised by up to ``amp``, plus obstacles.

    Every raised square is a collision box, and each box costs world step time (~0.3 us per env step, measured), so
    only a fraction of the squares is raised. Heights are multiples of ``quantum`` so equal neighbours merge; the
    centre pad (the spawn point) stays flat. Obstacles snap to the grid so each one is one box.
    """
    inner = n - 2 * margin_c
    g = -(-inner // cell_c)                                   # grid squares per side (last may be partial)
    levels = max(1, int(round(amp / quantum)))
    raised = rng.random((g, g)) < density
    grid = np.where(raised, rng.integers(1, levels + 1, size=(g, g)) * quantum, 0.0)
    for _ in range(obstacles):
        a, b = (int(rng.integers(obstacle_size_c[0], obstacle_size_c[1] + 1)) for _ in range(2))
        a, b = max(1, -(-a // cell_c)), max(1, -(-b // cell_c))
        i, j = int(rng.integers(0, max(1, g - a + 1))), int(rng.integers(0, max(1, g - b + 1)))
        grid[i:i + a, j:j + b] = round(obstacle_h * rng.uniform(0.5, 1.0) / quantum) * quantum
    h = np.zeros((n, n))
    h[margin_c:n - margin_c, margin_c:n - margin_c] = np.repeat(np.repeat(grid, cell_c, 0), cell_c, 1)[:inner, :inner]
    c0, c1 = n // 2 - pad_c, n - n // 2 + pad_c               # flat spawn pad around the centre
    h[c0:c1, c0:c1] = 0.0
    return h


def generate_terrain(cfg: TerrainConfig | None = None) -> Terrain:
    """Build the heightfield of ``cfg``. Same config (and seed) -> the same array, bit for bit."""
    cfg = cfg or TerrainConfig()
    res = cfg.resolution
    n = int(round(cfg.tile_size / res))                       # cells per tile side
    nb = int(round(cfg.border / res))
    margin_c = min(int(round(cfg.tile_margin / res)), n // 2)
    tread_c = max(1, int(round(cfg.tread / res)))
    half_inner_c = n // 2 - margin_c
    platform_c = min(int(round(cfg.platform_size / 2 / res)), half_inner_c)
    steps = 1 + (half_inner_c - platform_c) // tread_c       # rises, counting the platform's
    u = (np.arange(n) + 0.5) * res - n * res / 2              # [n] cell centres, tile-centred
    cols = column_types(cfg)
    L, C = cfg.num_levels, len(cols)

    rel = np.zeros((L * n, C * n))                            # heights relative to the rim
    specs = []
    for l in range(L):
        f = cfg.level_fraction(l)
        for c, kind in enumerate(cols):
            rng = np.random.default_rng([cfg.seed, l, c])    # per tile: independent of the tile order
            if kind in ("stairs_up", "stairs_down"):
                diff = _lerp(cfg.step_height, f)
                h = _stairs(n, margin_c, tread_c, steps, diff) * (1 if kind == "stairs_up" else -1)
            elif kind in ("slope_up", "slope_down"):
                diff = _lerp(cfg.slope_deg, f)
                h = _slope(u, half_inner_c * res, platform_c * res, diff) * (1 if kind == "slope_up" else -1)
            elif kind == "uneven":
                diff = _lerp(cfg.uneven_height, f)
                size_c = tuple(int(round(s / res)) for s in cfg.obstacle_size)
                h = _uneven(n, margin_c, max(1, int(round(cfg.uneven_cell / res))),
                            int(round(cfg.spawn_pad / 2 / res)), diff, cfg.uneven_quantum, cfg.uneven_density,
                            cfg.obstacles,
                            _lerp(cfg.obstacle_height, f), size_c, rng)
            else:
                diff, h = 0.0, np.zeros((n, n))
            rel[l * n:(l + 1) * n, c * n:(c + 1) * n] = h
            specs.append((l, c, kind, diff))

    rel = rel.astype(np.float32)
    base = np.float32(max(0.0, -float(rel.min())))            # lift so the deepest pit bottom is at z = 0 exactly
    heights = np.full((L * n + 2 * nb, C * n + 2 * nb), base, dtype=np.float32)
    heights[nb:nb + L * n, nb:nb + C * n] = rel + base
    origin = (cfg.field_offset + 0.5 * res, cfg.field_offset + 0.5 * res)
    hf = HeightField(heights, res, origin)

    grid_x0 = cfg.field_offset + nb * res                      # world xy of the tile grid's corner
    grid_y0 = grid_x0
    tiles, origins, difficulty = [], np.zeros((L, C, 3)), np.zeros((L, C))
    for l, c, kind, diff in specs:
        centre = (grid_x0 + (l + 0.5) * n * res, grid_y0 + (c + 0.5) * n * res)
        cells = (slice(nb + l * n, nb + (l + 1) * n), slice(nb + c * n, nb + (c + 1) * n))
        half_platform = (half_inner_c - (steps - 1) * tread_c if kind.startswith("stairs") else platform_c) * res
        tiles.append(Tile(l, c, kind, diff, centre, cells, half_inner_c * res, half_platform))
        origins[l, c] = (*centre, float(hf.height_at(*centre)))
        difficulty[l, c] = diff
    return Terrain(cfg, hf, float(base), cols, tiles, origins, difficulty)

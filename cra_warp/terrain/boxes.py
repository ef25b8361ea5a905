"""Collision boxes from the heightfield: static BOX shapes are the terrain form that holds Adam Lite (FACTS.md).

Every box stands on z = 0 (World's ground plane) or on another box; the union of the boxes' top faces reproduces
the heightfield at every sample point (``box_surface`` measures it, the tests check it):

- the base: every cell at or above ``terrain.base_height`` (border, tile rims, flat tiles, under the hills) is
  covered by boxes [0, base], merged into few big rectangles;
- piecewise-constant tiles (stairs, uneven ground): rectangles of equal cells, either as columns (one box per
  equal-height rectangle) or as layers (one box per height level and rectangle of the region above it: a stair
  pyramid is one slab per step); each tile takes whichever needs fewer boxes;
- slope tiles: rotated boxes whose top faces lie in the face planes. A pit (slope_down) is exact with one slab per
  face spanning the whole tile: the surface is the max of the face planes, and a union of solids is a max. A hill
  (slope_up) is the min of its planes, so each face is covered by rectangles lying inside its own trapezoid: a
  central rectangle and, for the two triangles along the diagonal ridges, rectangles with one edge on the ridge
  (their sides then dip under the neighbouring face). Such a rectangle overhangs the face's foot near the tile
  corner, where its plane is below the rim height; triangles are halved until the overhang fits inside this tile's
  rim and the neighbour's (every tile has one; the border is at rim height too).
"""

from __future__ import annotations

import math

import numpy as np

from cra_warp.terrain import HeightField, Terrain, Tile
from cra_warp.sim import TerrainBoxes

SLOPE_BOX_THICKNESS = 0.3  # [m] rotated slabs: far more than a foot can sink, thin enough to stay under the rim
MAX_RIDGE_SPLITS = 5


# ---------------------------------------------------------------- rectangles of equal cells
def _runs_merged(mask: np.ndarray, values: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Runs of equal value along axis 1, merged along axis 0 while identical. Rectangles (i0, i1, j0, j1)."""
    a, b = mask.shape
    open_rects: dict[tuple, int] = {}
    out = []
    for i in range(a):
        m, v = mask[i], values[i]
        change = np.flatnonzero((m[1:] != m[:-1]) | (m[1:] & (v[1:] != v[:-1]))) + 1
        starts, ends = np.r_[0, change], np.r_[change, b]
        keep = m[starts]
        runs = set(zip(starts[keep].tolist(), ends[keep].tolist(), v[starts[keep]].tolist()))
        for key in [k for k in open_rects if k not in runs]:
            out.append((open_rects.pop(key), i, key[0], key[1]))
        for key in runs:
            open_rects.setdefault(key, i)
    out += [(i0, a, k[0], k[1]) for k, i0 in open_rects.items()]
    return out


def rectangles(mask: np.ndarray, values: np.ndarray | None = None) -> list[tuple[int, int, int, int]]:
    """Disjoint rectangles (i0, i1, j0, j1), ends exclusive, covering the True cells of ``mask``, each of one value.

    Greedy in both orientations; the one with fewer rectangles is returned.
    """
    values = np.zeros(mask.shape, np.float32) if values is None else values
    along_j = _runs_merged(mask, values)
    along_i = [(i0, i1, j0, j1) for j0, j1, i0, i1 in _runs_merged(mask.T, values.T)]
    return along_j if len(along_j) <= len(along_i) else along_i


def _column_boxes(mask, h, floor):
    """One box [floor, h] per rectangle of equal height."""
    return [(r, floor, float(h[r[0], r[2]])) for r in rectangles(mask, h)]


def _layer_boxes(mask, h, floor):
    """Per height level z_k (ascending): boxes [z_{k-1}, z_k] over the region at or above z_k."""
    out, below = [], floor
    for z in np.unique(h[mask]):
        out += [(r, below, float(z)) for r in rectangles(mask & (h >= z))]
        below = float(z)
    return out


def _fewest(mask, h, floor):
    if not mask.any():
        return []
    a, b = _column_boxes(mask, h, floor), _layer_boxes(mask, h, floor)
    return a if len(a) <= len(b) else b


# ---------------------------------------------------------------- boxes
class _BoxList:
    def __init__(self):
        self.centers, self.half, self.rot = [], [], []

    def cells(self, hf: HeightField, rect, offset, z0: float, z1: float):
        """An axis-aligned box over cells rect (of the sub-array starting at ``offset``) from z0 to z1."""
        if z1 - z0 < 1e-6:
            return
        i0, i1, j0, j1 = rect
        res = hf.resolution
        x0 = hf.origin[0] + (offset[0] + i0 - 0.5) * res
        x1 = hf.origin[0] + (offset[0] + i1 - 0.5) * res
        y0 = hf.origin[1] + (offset[1] + j0 - 0.5) * res
        y1 = hf.origin[1] + (offset[1] + j1 - 0.5) * res
        self.centers.append(((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2))
        self.half.append(((x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2))
        self.rot.append(np.eye(3))

    def cells_world(self, centre, half):
        """An axis-aligned box given by its world centre and half extents."""
        self.centers.append(tuple(centre))
        self.half.append(tuple(half))
        self.rot.append(np.eye(3))

    def top_rect(self, o, e1, e2, thickness: float):
        """A box whose top face is the rectangle o + [0,1] e1 + [0,1] e2 (3-D, e1 perpendicular to e2)."""
        n = np.cross(e1, e2)
        if n[2] < 0:
            e1, e2, n = e2, e1, -n
        axes = np.stack([e1 / np.linalg.norm(e1), e2 / np.linalg.norm(e2), n / np.linalg.norm(n)], 1)  # columns
        self.centers.append(tuple(o + e1 / 2 + e2 / 2 - axes[:, 2] * thickness / 2))
        self.half.append((np.linalg.norm(e1) / 2, np.linalg.norm(e2) / 2, thickness / 2))
        self.rot.append(axes)

    def done(self) -> TerrainBoxes:
        rot = np.asarray(self.rot).reshape(-1, 3, 3)
        return TerrainBoxes(np.asarray(self.centers, float).reshape(-1, 3), np.asarray(self.half, float).reshape(-1, 3),
                            matrix_to_quat_xyzw(rot))


def _face_rects(tile: Tile, t: float, hill: bool, margin: float):
    """Top rectangles (o, e1, e2) of one face in face coordinates (u outward, v lateral, z relative to the rim)."""
    L, p = tile.half_inner, tile.half_platform
    z = (lambda u: t * (L - u)) if hill else (lambda u: -t * (L - u))

    def pt(u, v):
        return np.array([u, v, z(u)])

    if not hill:  # pit: one slab over the whole width; the max of the faces is what the union gives
        return [(pt(p, -L), pt(L, -L) - pt(p, -L), pt(p, L) - pt(p, -L))]

    rects = [(pt(p, -p), pt(L, -p) - pt(p, -p), pt(p, p) - pt(p, -p))]

    def ridge_rect(a, b, c):
        # edge a-b on the ridge, far edge through c: contains triangle abc, overhangs past its two legs
        A, B, C = pt(*a), pt(*b), pt(*c)
        e1 = B - A
        w = C - A
        return A, e1, w - (w @ e1) / (e1 @ e1) * e1

    for splits in range(MAX_RIDGE_SPLITS + 1):
        tri = []
        P, Q, R = np.array([p, p]), np.array([L, L]), np.array([L, p])
        for _ in range(splits):  # halve: near-platform triangle + rectangle + near-foot triangle (recursed)
            M = (P + Q) / 2
            tri.append(ridge_rect(P, M, (M[0], P[1])))
            tri.append((pt(M[0], P[1]), pt(L, P[1]) - pt(M[0], P[1]), pt(M[0], M[1]) - pt(M[0], P[1])))
            P, R = M, np.array([L, M[1]])
        tri.append(ridge_rect(P, Q, R))
        o, e1, e2 = tri[-1]
        overhang = max((o + e2)[0], (o + e1 + e2)[0]) - L   # past the face's foot, below the rim's height
        if overhang <= 2 * margin:  # every tile has a rim at the base height: ours and the neighbour's hide it
            break
    mirror = np.array([1.0, -1.0, 1.0])
    rects += tri + [(o * mirror, e1 * mirror, e2 * mirror) for o, e1, e2 in tri]
    return rects


def _slope_boxes(out: _BoxList, tile: Tile, base: float, margin: float):
    t = math.tan(math.radians(tile.difficulty))
    hill = tile.kind == "slope_up"
    L, p = tile.half_inner, tile.half_platform
    cx, cy = tile.centre
    drop = t * (L - p)
    if drop < 1e-6:
        return  # flat: the base covers it
    if hill:  # platform on top of the base
        out.cells_world((cx, cy, base + drop / 2), (p, p, drop / 2))
    elif base - drop > 1e-6:  # floor of the pit under the four slabs (the deepest pit's floor is the plane)
        out.cells_world((cx, cy, (base - drop) / 2), (L, L, (base - drop) / 2))
    for k in range(4):
        c, s = math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        for o, e1, e2 in _face_rects(tile, t, hill, margin):
            out.top_rect(rot @ o + (cx, cy, base), rot @ e1, rot @ e2, SLOPE_BOX_THICKNESS)


def terrain_boxes(terrain: Terrain) -> TerrainBoxes:
    """Static boxes reproducing ``terrain``'s heightfield (see the module docstring). Quaternions xyzw."""
    hf, base = terrain.field, terrain.base_height
    h = hf.heights
    base32 = np.float32(base)  # the rims' exact value in the array
    out = _BoxList()
    if base > 0:
        for r in rectangles(h >= base32):
            out.cells(hf, r, (0, 0), 0.0, base)
    for tile in terrain.tiles:
        if tile.kind in ("slope_up", "slope_down"):
            _slope_boxes(out, tile, base, terrain.cfg.tile_margin)
            continue
        sub = h[tile.cells]
        offset = (tile.cells[0].start, tile.cells[1].start)
        for r, z0, z1 in _fewest(sub > base32, sub, base) + _fewest(sub < base32, sub, 0.0):
            out.cells(hf, r, offset, z0, z1)
    return out.done()


# ---------------------------------------------------------------- checking
def matrix_to_quat_xyzw(rot: np.ndarray) -> np.ndarray:
    """Rotation matrices [B, 3, 3] -> unit quaternions [B, 4] xyzw (w >= 0)."""
    B = rot.shape[0]
    q = np.zeros((B, 4))
    tr = np.trace(rot, axis1=1, axis2=2)
    for b in range(B):
        m = rot[b]
        if tr[b] > 0:
            s = 2.0 * math.sqrt(1.0 + tr[b])
            q[b] = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
        else:
            k = int(np.argmax(np.diag(m)))
            i, j = (k + 1) % 3, (k + 2) % 3
            s = 2.0 * math.sqrt(1.0 + m[k, k] - m[i, i] - m[j, j])
            v = np.zeros(3)
            v[k] = s / 4
            v[i] = (m[i, k] + m[k, i]) / s
            v[j] = (m[j, k] + m[k, j]) / s
            q[b] = [*v, (m[j, i] - m[i, j]) / s]
    q *= np.where(q[:, 3:] < 0, -1.0, 1.0)
    return q


def quat_xyzw_to_matrix(q: np.ndarray) -> np.ndarray:
    """[B, 4] xyzw -> [B, 3, 3]."""
    x, y, z, w = (q / np.linalg.norm(q, axis=-1, keepdims=True)).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def box_surface(boxes: TerrainBoxes, hf: HeightField, grow: float = 1e-5) -> np.ndarray:
    """Height of the highest solid point (boxes, or the ground plane at 0) above every sample of ``hf``, [nx, ny].

    A vertical line through each sample is clipped against every box it can meet. ``grow`` enlarges the boxes by
    that much so samples lying exactly on a seam between two boxes count as covered.
    """
    top = np.zeros(hf.shape)
    rot = quat_xyzw_to_matrix(boxes.quats)
    res = hf.resolution
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    for c, half, R in zip(boxes.centers, boxes.half_extents, rot):
        half = half + grow
        xy = (corners * half) @ R.T + c
        i0 = max(0, int(math.ceil((xy[:, 0].min() - hf.origin[0]) / res)))
        i1 = min(hf.shape[0], int(math.floor((xy[:, 0].max() - hf.origin[0]) / res)) + 1)
        j0 = max(0, int(math.ceil((xy[:, 1].min() - hf.origin[1]) / res)))
        j1 = min(hf.shape[1], int(math.floor((xy[:, 1].max() - hf.origin[1]) / res)) + 1)
        if i0 >= i1 or j0 >= j1:
            continue
        x, y = np.meshgrid(*hf.cell_xy(np.arange(i0, i1), np.arange(j0, j1)), indexing="ij")
        # Box frame: p(z) = R^T ((x, y, z) - c) = a + (z - c_z) b, with b = R^T e_z (the third row of R).
        a = np.stack([R[0, k] * (x - c[0]) + R[1, k] * (y - c[1]) for k in range(3)], -1)
        b = R[2]
        lo = np.full(x.shape, -np.inf)
        hi = np.full(x.shape, np.inf)
        ok = np.ones(x.shape, bool)
        for k in range(3):
            if abs(b[k]) < 1e-12:
                ok &= np.abs(a[..., k]) <= half[k]
                continue
            t1, t2 = (-half[k] - a[..., k]) / b[k], (half[k] - a[..., k]) / b[k]
            lo, hi = np.maximum(lo, np.minimum(t1, t2)), np.minimum(hi, np.maximum(t1, t2))
        ok &= lo <= hi
        sub = top[i0:i1, j0:j1]
        np.maximum(sub, np.where(ok, c[2] + hi, -np.inf), out=sub)
    return top

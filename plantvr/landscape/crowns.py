"""Competition for crown space on layered voxels: boundary propagation (spec 004_treesketch §3.5, §3.7; V21, V22).

Every tree starts as a discretised circle under its base (radius = its trunk radius) that grows at a rate
proportional to its projected crown area; a cell is claimed by the first front that reaches it and fronts stop
at cells claimed by another tree, so regions stay connected and boundaries are curved (a crystal-growth,
multiplicatively weighted Voronoi diagram). The layered 3D version runs the same 2D competition per layer of a
voxel grid among the trees whose representative shape reaches the layer, so tall trees own the upper layers
alone and overhang shorter neighbours.

Implementation [INFERRED]: the front is simulated event by event instead of with polygon fronts and fixed time
steps. Tree i reaches a cell centre c (distance d in cells from its base) at t_i(c) = max(d - r0_i, 0) / rate_i
(its growing disc); a cell can only be claimed from a 4-neighbour the tree already owns, at
max(t_i(c), time the neighbour was claimed). A priority queue ordered by (time, tree, cell) processes the
claims, so each layer is one O(cells log cells) pass; the layers run in parallel (``numba.prange``). A pure
Python twin (:func:`propagate_layer_python`, ``heapq``) gives identical owners.

Layers follow the terrain: layer k spans heights [k dz, (k + 1) dz) above each tree's own base, and tree i
takes part in layer k iff h_max_i > k dz (spec §3.5 [INFERRED]). Hero trees claim the voxels their segments
pass through afterwards (:func:`claim_segments`, an exact 3D DDA by plane crossings).
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from .._threading import parallel_region
from .._validation import MAX_COORD, check_array, check_choice, check_int, check_point, check_range
from ..growth.sketch import SketchEngine
from .terrain import pair

#: Bounds of the crown-space grids: cells of one layer (each layer's event heap holds up to 4 entries per cell),
#: voxels in all, trees, and the spread of crown areas (rates a / max a must stay >= 1e-12: no zero rate).
MAX_LAYER_CELLS = 1 << 22
MAX_VOXELS = 1 << 27
MAX_TREES = 1_000_000
MIN_AREA_RATIO = 1e-12
#: Smallest plot side (m): base positions / cell sizes stay far inside int64 in the kernel.
MIN_SIZE = 1e-6

__all__ = ["CrownVoxels", "VoxelSketchEngine", "claim_segments", "crown_voxels", "propagate_layer",
           "propagate_layer_python", "region_geometry", "tree_region"]


# -- the 2D competition: event-driven boundary propagation ------------------------------------------------------
@numba.njit(cache=True, nogil=True)
def _less(ta, ia, ca, tb, ib, cb):
    if ta != tb:
        return ta < tb
    if ia != ib:
        return ia < ib
    return ca < cb


@numba.njit(cache=True, nogil=True)
def _less_at(ht, hi, hc, a, b):
    """Heap entry ``a`` comes before entry ``b``."""
    return _less(ht[a], hi[a], hc[a], ht[b], hi[b], hc[b])


@numba.njit(cache=True, nogil=True)
def _swap(ht, hi, hc, a, b):
    ht[a], ht[b] = ht[b], ht[a]
    hi[a], hi[b] = hi[b], hi[a]
    hc[a], hc[b] = hc[b], hc[a]


@numba.njit(cache=True, nogil=True)
def _push(ht, hi, hc, n, t, i, c):
    k = n
    ht[k], hi[k], hc[k] = t, i, c
    while k > 0:
        p = (k - 1) >> 1
        if _less_at(ht, hi, hc, k, p):
            _swap(ht, hi, hc, k, p)
            k = p
        else:
            break
    return n + 1


@numba.njit(cache=True, nogil=True)
def _pop(ht, hi, hc, n):
    t, i, c = ht[0], hi[0], hc[0]
    n -= 1
    ht[0], hi[0], hc[0] = ht[n], hi[n], hc[n]
    k = 0
    while True:
        a = 2 * k + 1
        if a >= n:
            break
        b = a + 1
        m = a
        if b < n and _less_at(ht, hi, hc, b, a):
            m = b
        if _less_at(ht, hi, hc, m, k):
            _swap(ht, hi, hc, k, m)
            k = m
        else:
            break
    return t, i, c, n


@numba.njit(cache=True, nogil=True)
def _arrival(bx, bz, r0, rate, i, row, col):
    dx = col + 0.5 - bx[i]
    dz = row + 0.5 - bz[i]
    return max(math.sqrt(dx * dx + dz * dz) - r0[i], 0.0) / rate[i]


@numba.njit(cache=True, nogil=True)
def _propagate(owner, bx, bz, r0, rate, active):
    """Fill ``owner`` (ny, nx) int32, all -1 on entry, with the claiming tree of every cell (kernel)."""
    ny, nx = owner.shape
    cap = 4 * ny * nx + len(bx) + 1
    ht = np.empty(cap, np.float64)
    hi = np.empty(cap, np.int64)
    hc = np.empty(cap, np.int64)
    n = 0
    for i in range(len(bx)):
        if not active[i]:
            continue
        col = min(max(math.floor(bx[i]), 0), nx - 1)
        row = min(max(math.floor(bz[i]), 0), ny - 1)
        n = _push(ht, hi, hc, n, _arrival(bx, bz, r0, rate, i, row, col), i, row * nx + col)
    while n > 0:
        t, i, c, n = _pop(ht, hi, hc, n)
        row, col = c // nx, c % nx
        if owner[row, col] >= 0:
            continue
        owner[row, col] = i
        for k in range(4):
            r2, c2 = row, col
            if k == 0:
                r2 -= 1
            elif k == 1:
                r2 += 1
            elif k == 2:
                c2 -= 1
            else:
                c2 += 1
            if r2 < 0 or r2 >= ny or c2 < 0 or c2 >= nx or owner[r2, c2] >= 0:
                continue
            t2 = _arrival(bx, bz, r0, rate, i, r2, c2)
            n = _push(ht, hi, hc, n, max(t2, t), i, r2 * nx + c2)


@numba.njit(cache=True, nogil=True, parallel=True)
def _propagate_layers(owner, bx, bz, r0, rate, active):
    for k in numba.prange(owner.shape[0]):
        _propagate(owner[k], bx, bz, r0, rate, active[k])


def propagate_layer_python(shape: tuple[int, int], bx, bz, r0, rate, active) -> np.ndarray:
    """Readable twin of the kernel: one layer's owners (ny, nx) int32 (-1: no participating tree).

    ``bx, bz`` base positions in cell units (column, row; cell (r, c) has its centre at (c + 0.5, r + 0.5)),
    ``r0`` trunk radii in cells, ``rate`` growth rates (cells per unit time), ``active`` participating trees.
    """
    ny, nx = shape
    owner = np.full((ny, nx), -1, np.int32)

    def arrival(i, row, col):
        dx, dz = col + 0.5 - bx[i], row + 0.5 - bz[i]
        return max(math.sqrt(dx * dx + dz * dz) - r0[i], 0.0) / rate[i]

    heap = []
    for i in range(len(bx)):
        if active[i]:
            col = min(max(math.floor(bx[i]), 0), nx - 1)
            row = min(max(math.floor(bz[i]), 0), ny - 1)
            heapq.heappush(heap, (arrival(i, row, col), i, row * nx + col))
    while heap:
        t, i, c = heapq.heappop(heap)
        row, col = divmod(c, nx)
        if owner[row, col] >= 0:
            continue
        owner[row, col] = i
        for r2, c2 in ((row - 1, col), (row + 1, col), (row, col - 1), (row, col + 1)):
            if 0 <= r2 < ny and 0 <= c2 < nx and owner[r2, c2] < 0:
                heapq.heappush(heap, (max(arrival(i, r2, c2), t), i, r2 * nx + c2))
    return owner


def _check_trees(bases, areas, trunk_radius, n_name="bases"):
    b = check_array(n_name, bases, shape=(None, 2), min_rows=1, max_abs=MAX_COORD)
    n = len(b)
    if n > MAX_TREES:
        raise ValueError(f"{n_name} must hold at most {MAX_TREES} trees, got {n}")
    a = check_array("areas", areas, shape=(n,), max_abs=1e300)
    if not np.all(a > 0):
        raise ValueError(f"areas must be positive (projected crown areas), got min {a.min()!r}")
    if a.min() < MIN_AREA_RATIO * a.max():
        raise ValueError(f"areas must lie within a factor {1 / MIN_AREA_RATIO:g} of each other (front rates), got "
                         f"{a.min():.3g} .. {a.max():.3g}")
    if np.ndim(trunk_radius) == 0:
        r0 = np.full(n, check_range("trunk_radius", trunk_radius, 0.0, MAX_COORD))
    else:
        r0 = check_array("trunk_radius", trunk_radius, shape=(n,), max_abs=MAX_COORD)
        if not np.all(r0 >= 0):
            raise ValueError(f"trunk_radius must be finite and >= 0, got min {r0.min()!r}")
    return b, a, r0


def _check_plot(size, ny, nx, layers=1):
    if ny * nx > MAX_LAYER_CELLS or layers * ny * nx > MAX_VOXELS:
        raise ValueError(f"shape must have at most {MAX_LAYER_CELLS} cells per layer and {MAX_VOXELS} voxels, "
                         f"got {layers} x {ny} x {nx}")
    W, D = pair("size", size)
    if min(W, D) < MIN_SIZE:
        raise ValueError(f"size must be at least {MIN_SIZE:g} m on each side, got {size!r}")
    return W, D


def _check_voxels(voxels) -> CrownVoxels:
    """Raise ``ValueError`` unless ``voxels`` is a consistent :class:`CrownVoxels` (owners index its trees)."""
    if not isinstance(voxels, CrownVoxels):
        raise ValueError(f"voxels must be a CrownVoxels, got {type(voxels).__name__}")
    o = voxels.owner
    if not isinstance(o, np.ndarray) or o.ndim != 3 or o.dtype.kind not in "iu" or o.size > MAX_VOXELS:
        raise ValueError("voxels owner must be a (layers, ny, nx) int array of at most "
                         f"{MAX_VOXELS} voxels")
    h = check_array("voxels h_max", voxels.h_max, shape=(None,), max_abs=MAX_COORD)
    if o.size and (o.min() < -1 or o.max() >= len(h)):
        raise ValueError(f"voxels owner must hold tree indices in [-1, {len(h) - 1}], got {o.min()} .. {o.max()}")
    pair("voxels size", voxels.size)
    check_range("voxels layer_height", voxels.layer_height, 0.0, MAX_COORD, low_open=True)
    return voxels


def propagate_layer(shape: tuple[int, int], bases: np.ndarray, areas: np.ndarray, *, size: tuple[float, float],
                    trunk_radius=0.0, active: np.ndarray | None = None, engine: str = "numba") -> np.ndarray:
    """2D boundary propagation on a grid: the claiming tree of every cell (spec §3.5, Figs. 6.14–6.16).

    Parameters
    ----------
    shape : (int, int)
        Grid (ny, nx); row j covers z in [j, j + 1) * size[1] / ny, column i x in [i, i + 1) * size[0] / nx.
    bases : (N, 2) float64 array
        Tree positions (x, z), metres.
    areas : (N,) float64 array
        Projected crown areas (> 0): the growth rate of each front is proportional to its area.
    size : (float, float)
        Plot (width, depth), metres.
    trunk_radius : float or (N,) array
        Radius (m) of each starting circle (T_w / 2 scaled).
    active : (N,) bool array, optional
        Trees taking part (default all).
    engine : {"numba", "python"}
        The kernel or its readable twin (identical owners).

    Returns
    -------
    (ny, nx) int32 array
        Claiming tree per cell; every cell is claimed when at least one tree is active, else -1.

    References
    ----------
    .. [1] Longay thesis §6.5.1, Figs. 6.13–6.16; spec 004 §3.5 (event-driven fronts [INFERRED]).
    """
    ny, nx = pair("shape", shape, kind="int", low=1, high=8192)
    W, D = _check_plot(size, ny, nx)
    b, a, r0 = _check_trees(bases, areas, trunk_radius)
    act = np.ones(len(b), bool) if active is None else check_array("active", active, shape=(len(b),), dtype=bool)
    engine = check_choice("engine", engine, ("numba", "python"))
    cx, cz = W / nx, D / ny
    bx, bz = b[:, 0] / cx, b[:, 1] / cz
    r0c = r0 / min(cx, cz)
    rate = a / a.max()
    if engine == "python":
        return propagate_layer_python((ny, nx), bx, bz, r0c, rate, act)
    owner = np.full((1, ny, nx), -1, np.int32)
    with parallel_region():
        _propagate_layers(owner, bx, bz, r0c, rate, act[None])
    return owner[0]


# -- layered voxels ---------------------------------------------------------------------------------------------
@dataclass
class CrownVoxels:
    """Claimed crown space: ``owner`` (layers, ny, nx) int32 (-1 unclaimed) over a plot of ``size`` (x, z metres),
    layer k spanning heights [k, k + 1) * ``layer_height`` above each tree's base; ``h_max`` (N,) per tree."""

    owner: np.ndarray
    size: tuple[float, float]
    layer_height: float
    h_max: np.ndarray

    @property
    def cell(self) -> tuple[float, float]:
        """Cell (width along x, depth along z), metres."""
        _, ny, nx = self.owner.shape
        return self.size[0] / nx, self.size[1] / ny

    def counts(self) -> np.ndarray:
        """(N,) voxels claimed by each tree."""
        o = self.owner[self.owner >= 0]
        return np.bincount(o, minlength=len(self.h_max))


def crown_voxels(bases: np.ndarray, areas: np.ndarray, h_max: np.ndarray, *, size: tuple[float, float],
                 shape: tuple[int, int, int] = (20, 128, 128), trunk_radius=0.0, height: float | None = None,
                 engine: str = "numba") -> CrownVoxels:
    """Layered competition for crown space (spec §3.5 3D extension, Fig. 6.17; V22).

    Parameters
    ----------
    bases : (N, 2) float64 array
        Tree positions (x, z), metres.
    areas : (N,) float64 array
        Projected crown areas A_i = pi (S_i C_w / 2)^2 (ERRATUM E3; only ratios matter).
    h_max : (N,) float64 array
        Heights of the representative shapes, S_i (T_h + C_h), metres (> 0).
    size : (float, float)
        Plot (width, depth), metres.
    shape : (int, int, int)
        (layers, ny, nx); the thesis timing used 128 x 128 x 20.
    trunk_radius : float or (N,) array
        Starting circle radius S_i T_w / 2, metres.
    height : float, optional
        Height covered by the layers (default max h_max).
    engine : {"numba", "python"}
        Parallel kernel over layers, or the readable twin layer by layer.

    Returns
    -------
    CrownVoxels
        A tree whose base cell another tree claimed first (two bases in one cell; the lower index wins ties)
        owns no voxels in that layer.

    References
    ----------
    .. [1] Longay thesis §6.5.1, Figs. 6.14–6.17, §6.9.1 ("128 x 128 x 20"); spec 004 §3.5.
    """
    b, a, r0 = _check_trees(bases, areas, trunk_radius)
    n = len(b)
    h = check_array("h_max", h_max, shape=(n,), max_abs=MAX_COORD)
    if not np.all(h > 0):
        raise ValueError(f"h_max must be positive, got min {h.min()!r}")
    if isinstance(shape, (str, bytes)) or not hasattr(shape, "__len__") or len(shape) != 3:
        raise ValueError(f"shape must be (layers, ny, nx), got {shape!r}")
    L = check_int("shape[0]", shape[0], 1, 4096)
    ny = check_int("shape[1]", shape[1], 1, 8192)
    nx = check_int("shape[2]", shape[2], 1, 8192)
    W, D = _check_plot(size, ny, nx, L)
    top = float(h.max()) if height is None else check_range("height", height, 0.0, MAX_COORD, low_open=True)
    engine = check_choice("engine", engine, ("numba", "python"))
    dz = top / L
    active = h[None, :] > (np.arange(L) * dz)[:, None]            # tree i reaches above the bottom of layer k
    cx, cz = W / nx, D / ny
    bx, bz, r0c, rate = b[:, 0] / cx, b[:, 1] / cz, r0 / min(cx, cz), a / a.max()
    owner = np.full((L, ny, nx), -1, np.int32)
    # layers with the same participants have the same owners: solve each distinct set once
    _, first, inv = np.unique(np.packbits(active, axis=1), axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    if engine == "python":
        sol = np.stack([propagate_layer_python((ny, nx), bx, bz, r0c, rate, active[k]) for k in first])
    else:
        sol = np.full((len(first), ny, nx), -1, np.int32)
        with parallel_region():
            _propagate_layers(sol, bx, bz, r0c, rate, np.ascontiguousarray(active[first]))
    owner[:] = sol[inv]
    return CrownVoxels(owner, (W, D), dz, h.copy())


def _traversed(s: np.ndarray, e: np.ndarray, edges: tuple[float, float, float], base_y: float) -> np.ndarray:
    """Points (P, 3), one inside every voxel each segment passes through: the midpoints between consecutive
    crossings of the grid planes (an exact 3D DDA), plus the end points."""
    out = [s, e]
    for a, b in zip(s, e):
        d = b - a
        ts = [np.array([0.0, 1.0])]
        for axis, h, o in ((0, edges[0], 0.0), (2, edges[1], 0.0), (1, edges[2], base_y)):
            if d[axis] != 0.0:
                lo, hi = sorted((a[axis] - o, b[axis] - o))
                k = np.arange(np.ceil(lo / h), np.floor(hi / h) + 1) * h
                ts.append((k + o - a[axis]) / d[axis])
        t = np.unique(np.clip(np.concatenate(ts), 0.0, 1.0))
        out.append(a + d * (0.5 * (t[:-1] + t[1:]))[:, None])
    return np.concatenate(out)


def claim_segments(voxels: CrownVoxels, tree: int, starts: np.ndarray, ends: np.ndarray, *, base_y: float = 0.0
                   ) -> CrownVoxels:
    """Hero tree claims (spec §3.5): every voxel a segment of the tree passes through now belongs to ``tree``.

    ``starts``, ``ends`` (M, 3) world points (x, y, z), y measured with the layers above ``base_y`` (the hero's
    base height). The voxels are found exactly (every crossing of a grid plane, a 3D DDA). Returns a new
    :class:`CrownVoxels` (the input is not changed).
    """
    L, ny, nx = _check_voxels(voxels).owner.shape
    tree = check_int("tree", tree, 0, len(voxels.h_max) - 1)
    s = check_array("starts", starts, shape=(None, 3), max_abs=MAX_COORD)
    e = check_array("ends", ends, shape=(len(s), 3), max_abs=MAX_COORD)
    base_y = check_range("base_y", base_y, -MAX_COORD, MAX_COORD)
    cx, cz = voxels.cell
    crossings = float(np.sum(np.abs(e - s) / np.array([cx, voxels.layer_height, cz]))) + 3 * len(s)
    if crossings > 1e7:
        raise ValueError(f"starts and ends cross about {crossings:.3g} voxel planes, more than 1e7 (segments far "
                         "longer than the voxels)")
    owner = voxels.owner.copy()
    p = _traversed(s, e, (cx, cz, voxels.layer_height), base_y)
    col = np.floor(p[:, 0] / cx).astype(np.int64)
    row = np.floor(p[:, 2] / cz).astype(np.int64)
    lay = np.floor((p[:, 1] - base_y) / voxels.layer_height).astype(np.int64)
    ok = (col >= 0) & (col < nx) & (row >= 0) & (row < ny) & (lay >= 0) & (lay < L)
    owner[lay[ok], row[ok], col[ok]] = tree
    return CrownVoxels(owner, voxels.size, voxels.layer_height, voxels.h_max.copy())


def tree_region(voxels: CrownVoxels, tree: int) -> dict[str, Any]:
    """The voxels of one tree, cropped: ``{"origin": (x0, z0) metres, "cell": (cx, cz), "layer_height": dz,
    "mask": (L, h, w) bool}`` (empty mask when the tree owns nothing)."""
    tree = check_int("tree", tree, 0, len(_check_voxels(voxels).h_max) - 1)
    m = voxels.owner == tree
    cx, cz = voxels.cell
    if not m.any():
        return {"origin": (0.0, 0.0), "cell": (cx, cz), "layer_height": voxels.layer_height,
                "mask": np.zeros((voxels.owner.shape[0], 0, 0), bool)}
    rows = np.flatnonzero(m.any(axis=(0, 2)))
    cols = np.flatnonzero(m.any(axis=(0, 1)))
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    return {"origin": (c0 * cx, r0 * cz), "cell": (cx, cz), "layer_height": voxels.layer_height,
            "mask": np.ascontiguousarray(m[:, r0:r1, c0:c1])}


def in_tree_region(region: dict[str, Any], points: np.ndarray, base: np.ndarray) -> np.ndarray:
    """(P,) bool: tree-local ``points`` (P, 3) (base at the origin, y up) inside the tree's voxels; heights below
    the base count as layer 0."""
    pts = np.asarray(points, float).reshape(-1, 3)
    mask = region["mask"]
    L, h, w = mask.shape
    cx, cz = region["cell"]
    col = np.floor((pts[:, 0] + base[0] - region["origin"][0]) / cx).astype(np.int64)
    row = np.floor((pts[:, 2] + base[2] - region["origin"][1]) / cz).astype(np.int64)
    lay = np.maximum(np.floor(pts[:, 1] / region["layer_height"]).astype(np.int64), 0)
    ok = (col >= 0) & (col < w) & (row >= 0) & (row < h) & (lay < L)
    out = np.zeros(len(pts), bool)
    out[ok] = mask[lay[ok], row[ok], col[ok]]
    return out


def region_geometry(voxels: CrownVoxels) -> tuple[np.ndarray, np.ndarray]:
    """Centroid C_i (N, 2) of each tree's voxels (x, z) and the bounding-circle radius B_i about it (Eq. 6.4
    inputs; pooling all layers weights each layer by its voxel count, spec §3.6 [INFERRED])."""
    L, ny, nx = _check_voxels(voxels).owner.shape
    n = len(voxels.h_max)
    cx, cz = voxels.cell
    o = voxels.owner.reshape(L, -1)
    cnt = np.zeros(n)
    sx, sz = np.zeros(n), np.zeros(n)
    xs = np.tile((np.arange(nx) + 0.5) * cx, ny)
    zs = np.repeat((np.arange(ny) + 0.5) * cz, nx)
    for k in range(L):
        m = o[k] >= 0
        cnt += np.bincount(o[k][m], minlength=n)
        sx += np.bincount(o[k][m], xs[m], minlength=n)
        sz += np.bincount(o[k][m], zs[m], minlength=n)
    C = np.column_stack([sx, sz]) / np.maximum(cnt, 1)[:, None]
    B = np.zeros(n)
    for k in range(L):
        m = o[k] >= 0
        j = o[k][m]
        np.maximum.at(B, j, np.hypot(xs[m] - C[j, 0], zs[m] - C[j, 1]))
    return C, B


# -- growth inside the voxels (spec §3.7) ---------------------------------------------------------------------
class VoxelSketchEngine(SketchEngine):
    """:class:`~plantvr.growth.sketch.SketchEngine` whose crown space is its voxels of a :class:`CrownVoxels`
    (spec §3.7: "Attraction points are scattered around bud locations, but removed if they land outside of the
    voxel constraints"); the SketchEngine ``region`` still supplies h_max (growth halts there).

    ``voxel_region`` is :func:`tree_region`'s dict plus ``"base"``: the tree's world base (x, y, z).
    """

    def __init__(self, params: dict[str, Any], *, voxel_region: dict[str, Any], **opts: Any):
        self.voxel_region = self._check_voxels(voxel_region)
        super().__init__(params, **opts)

    @staticmethod
    def _check_voxels(reg) -> dict[str, Any]:
        if not isinstance(reg, dict) or set(reg) != {"origin", "cell", "layer_height", "mask", "base"}:
            raise ValueError("voxel_region must be a dict with keys origin, cell, layer_height, mask, base, "
                             f"got {reg!r}")
        mask = np.asarray(reg["mask"])
        if mask.dtype != bool or mask.ndim != 3 or mask.size > MAX_VOXELS:
            raise ValueError(f"voxel_region mask must be a 3-D bool array of at most {MAX_VOXELS} voxels, got "
                             f"{mask.dtype} {mask.shape}")
        origin = check_array("voxel_region origin", reg["origin"], shape=(2,), max_abs=MAX_COORD)
        cell = pair("voxel_region cell", reg["cell"], low=MIN_SIZE / 8192, high=MAX_COORD)
        return {"origin": tuple(float(v) for v in origin), "cell": cell,
                "layer_height": check_range("layer_height", reg["layer_height"], 0.0, MAX_COORD, low_open=True),
                "mask": mask, "base": check_point("voxel_region base", reg["base"])}

    def in_region(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: below h_max and inside the tree's voxels."""
        ok = super().in_region(points)
        reg = self.__dict__.get("voxel_region")
        if reg is not None:
            ok &= in_tree_region(reg, points, reg["base"])
        return ok

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        state["voxel_region"] = self.voxel_region
        return state

    def __setstate__(self, state: dict) -> None:
        self.voxel_region = state["voxel_region"]
        super().__setstate__(state)

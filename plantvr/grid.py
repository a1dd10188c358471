"""The one uniform grid of the package (issue 21; spec 000_treewand §2.3, 003_implicit_sca §1.3, 000_vine §2.4.3,
002 §3.6.1): growth, colonization, the ViNE brush index and collision hashing all bin items on it.

One cell lattice of size ``h``, two layouts:

- **dense** (a bounded domain: ``origin``, ``dims``): cell ``(i, j, k)`` has id ``(i * dims[1] + j) * dims[2] + k``
  (:func:`dense_cell_ids`, ``floor((x - origin) / h)`` clamped into the grid); items are sorted stably by cell
  with a counting sort and cell ``c`` holds ``order[start[c]:start[c + 1]]`` (:func:`sort_by_cell`). A query
  visits the cells of an axis range (:func:`axis_range`, :func:`ball_cells` with their box distances) or the
  grid rows a ball's box spans (:func:`row_spans`, :func:`ball_query`); boxes are entered in every cell they
  touch (:func:`dense_box_ranges`, :func:`dense_box_entries`);
- **hashed** (an unbounded or sparse domain): cell coordinates ``floor(x / h)`` clipped to a bound
  (:func:`cell_coord`) are hashed into a power-of-two bucket table with the primes of Teschner et al. (2003)
  (:func:`hash_cell`). Points are stored sorted by bucket (:func:`sort_by_bucket`, rebuilt whole in O(M), queried
  by :func:`mark_within`); boxes are stored in a time-stamped linked-list table that clears in O(1) and takes
  inserts between queries (:class:`SpatialHash`); Python loops that add one point at a time keep item lists per
  cell in a dict (:class:`CellLists`). Collisions only add candidates: every hit is tested exactly.

Base module: numpy and numba only. Kernels have numpy twins (``*_numpy``; brute-force queries for the ball queries), checked in tests/test_grid.py.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from plantvr._sorting import counting_sort

__all__ = ["HASH_LIMIT", "HASH_PRIMES", "KEY_LIMIT", "CellLists", "SpatialHash", "axis_range", "ball_candidates",
           "ball_cells", "ball_query", "bounds", "box_cell_range", "box_gap2", "cell_buffers", "cell_coord",
           "cell_coords", "cell_coords_numpy", "cell_key", "chain_within", "dense_box_entries", "dense_box_ranges",
           "dense_cell", "dense_cell_ids", "dense_cell_ids_numpy", "hash_cell", "hash_coords", "mark_within",
           "row_spans", "sort_by_bucket", "sort_by_bucket_numpy", "sort_by_cell"]

_P1, _P2, _P3 = 73856093, 19349663, 83492791
#: Multipliers of the spatial hash (Teschner et al. 2003): cell (ix, iy, iz) -> (ix p1) XOR (iy p2) XOR (iz p3).
HASH_PRIMES = (_P1, _P2, _P3)

#: Largest |cell coordinate| of a hashed point grid (floats are exact integers up to 2**53).
HASH_LIMIT = float(2 ** 52)
#: Cell coordinates of a :class:`SpatialHash` lie in [-KEY_LIMIT, KEY_LIMIT): 21 bits each in a 63-bit cell key.
KEY_LIMIT = 1 << 20


# ----------------------------------------------------------------------------------------------------------------
# the lattice
# ----------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True)
def bounds(points):  # pragma: no cover - numba kernel, twin: points.min(0), points.max(0)
    """(lo, hi) float64 corners of the bounding box of (M, 3) points in one pass (numpy's axis-0 min/max over an
    (M, 3) array is ~10x slower); float32 points are widened exactly."""
    lo = np.empty(3, np.float64)
    hi = np.empty(3, np.float64)
    for a in range(3):
        lo[a] = np.inf
        hi[a] = -np.inf
    for v in range(points.shape[0]):
        for a in range(3):
            x = np.float64(points[v, a])
            lo[a] = min(lo[a], x)
            hi[a] = max(hi[a], x)
    return lo, hi


@numba.njit(cache=True, nogil=True, inline="always")
def cell_coord(x, inv, lo, hi):
    """``floor(x * inv)`` clipped to [lo, hi] as int64 (hashed layout, ``inv = 1 / h``); NaN gives ``lo``."""
    f = np.floor(x * inv)
    if f > hi:
        f = hi
    elif not f >= lo:
        f = lo
    return np.int64(f)


@numba.njit(cache=True, nogil=True)
def cell_coords(points, cell, limit, out):  # pragma: no cover - numba kernel, twin: cell_coords_numpy
    """Write ``floor(points / cell)`` ((M, 3) float64 points, (3,) cell sizes, one per axis) clipped to ±``limit``
    into (M, 3) int64 ``out``; NaN gives 0 (hashed layout of anisotropic cells: the shadow grid)."""
    for n in range(points.shape[0]):
        for a in range(3):
            f = np.floor(points[n, a] / cell[a])  # a float: math.floor would give an int64 and overflow
            if f > limit:
                f = limit
            elif not f >= -limit:
                f = -limit if f < 0.0 else 0.0  # below the range, or NaN
            out[n, a] = np.int64(f)


def cell_coords_numpy(points: np.ndarray, cell: np.ndarray, limit: float) -> np.ndarray:
    """numpy twin of :func:`cell_coords`: ``floor(points / cell)`` clipped to ±limit, NaN → 0, as int64."""
    f = np.clip(np.floor(np.asarray(points, np.float64) / cell), -limit, limit)
    return np.where(np.isnan(f), 0.0, f).astype(np.int64)


@numba.njit(cache=True, nogil=True, inline="always")
def hash_cell(ix, iy, iz, mask):
    """Bucket of cell (ix, iy, iz) in a table of ``mask + 1`` (a power of two) buckets."""
    return ((ix * _P1) ^ (iy * _P2) ^ (iz * _P3)) & mask


def hash_coords(cells: np.ndarray) -> np.ndarray:
    """numpy :func:`hash_cell` without the mask: (N,) int64 ``(ix p1) XOR (iy p2) XOR (iz p3)`` of (N, 3) int64
    cell coordinates (int64 products wrap, as in the kernel)."""
    with np.errstate(over="ignore"):
        i = np.asarray(cells, np.int64) * np.asarray(HASH_PRIMES, np.int64)
    return i[:, 0] ^ i[:, 1] ^ i[:, 2]


@numba.njit(cache=True, nogil=True, inline="always")
def cell_key(ix, iy, iz):
    """Unique int64 key of a cell with coordinates in [-KEY_LIMIT, KEY_LIMIT)."""
    return (ix + KEY_LIMIT) | ((iy + KEY_LIMIT) << 21) | ((iz + KEY_LIMIT) << 42)


# ----------------------------------------------------------------------------------------------------------------
# dense layout
# ----------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, inline="always")
def dense_cell(x, o, h, n):
    """Cell index ``floor((x - o) / h)`` along one axis, clamped into [0, n - 1] (before the int conversion)."""
    f = np.floor((x - o) / h)
    if f > n - 1:
        f = n - 1
    elif not f >= 0.0:
        f = 0.0
    return int(f)


@numba.njit(cache=True, nogil=True)
def dense_cell_ids(points, origin, h, dims):  # pragma: no cover - numba kernel, twin: dense_cell_ids_numpy
    """(M,) int64 dense cell ids of (M, 3) points; points outside the grid fall in its border cells."""
    m = points.shape[0]
    cell = np.empty(m, np.int64)
    for i in range(m):
        c = 0
        for a in range(3):
            c = c * dims[a] + dense_cell(np.float64(points[i, a]), origin[a], h, dims[a])
        cell[i] = c
    return cell


def dense_cell_ids_numpy(points: np.ndarray, origin: np.ndarray, h: float, dims: np.ndarray) -> np.ndarray:
    """numpy twin of :func:`dense_cell_ids`."""
    ijk = np.clip(np.floor((np.asarray(points, np.float64) - origin) / h), 0, np.asarray(dims) - 1).astype(np.int64)
    return (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]


@numba.njit(cache=True, nogil=True)
def sort_by_cell(points, origin, h, dims, index_dtype):  # pragma: no cover - twin: np.argsort(cells, "stable")
    """``(order, start)`` of the dense layout: ``order == np.argsort(dense_cell_ids(...), kind="stable")`` and
    cell ``c`` holds ``order[start[c]:start[c + 1]]`` (``index_dtype``: int32 where memory matters)."""
    return counting_sort(dense_cell_ids(points, origin, h, dims), dims[0] * dims[1] * dims[2], index_dtype)


@numba.njit(cache=True, nogil=True)
def axis_range(x, origin, h, dims, reach, axis):  # pragma: no cover - numba kernel
    """Inclusive range of cells along ``axis`` within ``reach`` cells of coordinate ``x`` (empty: lo > hi)."""
    f = (x - origin[axis]) / h
    n = dims[axis]
    if not f >= -reach - 1.0:  # also NaN: no cell, and no float -> int conversion of it
        return 1, 0
    if f > n + reach + 1.0:
        return 1, 0
    c = math.floor(f)
    return max(c - reach, 0), min(c + reach, n - 1)


@numba.njit(cache=True, nogil=True)
def box_gap2(x, y, z, origin, h, i, j, k):  # pragma: no cover - numba kernel
    """Squared distance from (x, y, z) to the box of cell (i, j, k)."""
    g = 0.0
    lo = origin[0] + i * h
    if x < lo:
        g += (lo - x) * (lo - x)
    elif x > lo + h:
        g += (x - lo - h) * (x - lo - h)
    lo = origin[1] + j * h
    if y < lo:
        g += (lo - y) * (lo - y)
    elif y > lo + h:
        g += (y - lo - h) * (y - lo - h)
    lo = origin[2] + k * h
    if z < lo:
        g += (lo - z) * (lo - z)
    elif z > lo + h:
        g += (z - lo - h) * (z - lo - h)
    return g


@numba.njit(cache=True, nogil=True)
def ball_cells(x, y, z, r2, origin, h, dims, reach, cells, gaps):  # pragma: no cover - numba kernel
    """Cells within ``reach`` of (x, y, z) whose box is within ``sqrt(r2)`` of it, in (i, j, k) order.

    Writes their ids to ``cells`` and squared box distances to ``gaps`` (both of length ≥ (2·reach + 1)³, see
    :func:`cell_buffers`) and returns how many.
    """
    ilo, ihi = axis_range(x, origin, h, dims, reach, 0)
    jlo, jhi = axis_range(y, origin, h, dims, reach, 1)
    klo, khi = axis_range(z, origin, h, dims, reach, 2)
    n = 0
    for ci in range(ilo, ihi + 1):
        for cj in range(jlo, jhi + 1):
            for ck in range(klo, khi + 1):
                g = box_gap2(x, y, z, origin, h, ci, cj, ck)
                if g <= r2:
                    cells[n] = (ci * dims[1] + cj) * dims[2] + ck
                    gaps[n] = g
                    n += 1
    return n


@numba.njit(cache=True, nogil=True)
def cell_buffers(reach):  # pragma: no cover - numba kernel
    """Scratch arrays for :func:`ball_cells`."""
    k = (2 * reach + 1) ** 3
    return np.empty(k, np.int64), np.empty(k, np.float64)


@numba.njit(cache=True, nogil=True)
def row_spans(start, origin, h, dims, c, r):  # pragma: no cover - numba kernel
    """The cells a ball query visits, as (rows, 2) [start, end) spans of the sorted order: one per (i, j) grid
    row, whose cells k in [lo, hi] are contiguous in the order. No rows if the ball's box misses the grid."""
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    for a in range(3):
        lo[a] = max(int(np.floor((c[a] - r - origin[a]) / h)), 0)
        hi[a] = min(int(np.floor((c[a] + r - origin[a]) / h)), dims[a] - 1)
    if hi[0] < lo[0] or hi[1] < lo[1] or hi[2] < lo[2]:
        return np.empty((0, 2), np.int64)
    spans = np.empty(((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1), 2), np.int64)
    q = 0
    for i in range(lo[0], hi[0] + 1):
        for j in range(lo[1], hi[1] + 1):
            base = (i * dims[1] + j) * dims[2]
            spans[q, 0] = start[base + lo[2]]
            spans[q, 1] = start[base + hi[2] + 1]
            q += 1
    return spans


@numba.njit(cache=True, nogil=True)
def ball_candidates(start, origin, h, dims, c, r):  # pragma: no cover - numba kernel
    """Upper bound on the hits of :func:`ball_query`: the number of items in the cells it visits."""
    spans = row_spans(start, origin, h, dims, c, r)
    return (spans[:, 1] - spans[:, 0]).sum()


@numba.njit(cache=True, nogil=True)
def ball_query(points, order, start, origin, h, dims, c, r, out):  # pragma: no cover - twin: brute force
    """Write the ids of points with ``(c - p)·(c - p) <= r²`` (float64 on the stored positions) into ``out`` in
    visiting order; return the count (may exceed ``len(out)``: size ``out`` by :func:`ball_candidates`)."""
    spans = row_spans(start, origin, h, dims, c, r)
    r2 = r * r
    cnt = 0
    for q in range(spans.shape[0]):
        for v in order[spans[q, 0]:spans[q, 1]]:
            dx = np.float64(points[v, 0]) - c[0]
            dy = np.float64(points[v, 1]) - c[1]
            dz = np.float64(points[v, 2]) - c[2]
            if dx * dx + dy * dy + dz * dz <= r2:
                if cnt < out.shape[0]:
                    out[cnt] = v
                cnt += 1
    return cnt


@numba.njit(cache=True, nogil=True)
def dense_box_ranges(lo, hi, origin, inv, dims):  # pragma: no cover - numba kernel
    """Inclusive cell ranges ``(c0, c1)`` (N, 3) int64 of the (N, 3) boxes ``lo``, ``hi`` in the dense layout
    (``floor((x - origin) * inv)``, ``inv = 1 / h``, clamped into the grid) and the number of (box, cell) entries."""
    n = lo.shape[0]
    c0 = np.empty((n, 3), np.int64)
    c1 = np.empty((n, 3), np.int64)
    total = 0
    for f in range(n):
        m = 1
        for a in range(3):
            x = min(max(np.int64(np.floor((lo[f, a] - origin[a]) * inv)), 0), dims[a] - 1)
            y = min(max(np.int64(np.floor((hi[f, a] - origin[a]) * inv)), 0), dims[a] - 1)
            c0[f, a] = x
            c1[f, a] = y
            m *= y - x + 1
        total += m
    return c0, c1, total


@numba.njit(cache=True, nogil=True)
def dense_box_entries(c0, c1, dims, total):  # pragma: no cover - numba kernel
    """(total,) int64 dense cell ids and box ids: one entry per box and cell of :func:`dense_box_ranges`, box by box,
    cells in (i, j, k) order."""
    keys = np.empty(total, np.int64)
    ids = np.empty(total, np.int64)
    at = 0
    for f in range(c0.shape[0]):
        for x in range(c0[f, 0], c1[f, 0] + 1):
            for y in range(c0[f, 1], c1[f, 1] + 1):
                for z in range(c0[f, 2], c1[f, 2] + 1):
                    keys[at] = (x * dims[1] + y) * dims[2] + z
                    ids[at] = f
                    at += 1
    return keys, ids


# ----------------------------------------------------------------------------------------------------------------
# hashed layout: points sorted by bucket
# ----------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True)
def _bucket_ids(points, inv, mask):  # pragma: no cover - numba kernel, twin: sort_by_bucket_numpy
    bucket = np.empty(points.shape[0], np.int64)
    for i in range(points.shape[0]):
        bucket[i] = hash_cell(cell_coord(points[i, 0], inv, -HASH_LIMIT, HASH_LIMIT),
                              cell_coord(points[i, 1], inv, -HASH_LIMIT, HASH_LIMIT),
                              cell_coord(points[i, 2], inv, -HASH_LIMIT, HASH_LIMIT), mask)
    return bucket


def sort_by_bucket(points: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, int]:
    """``(order, start, mask)`` of (M, 3) float64 points hashed on cells of size ``h``: about two buckets per point
    (at least 16), bucket ``b`` holds ``order[start[b]:start[b + 1]]``."""
    nb = 1 << max(4, int(2 * max(len(points), 1) - 1).bit_length())
    order, start = counting_sort(_bucket_ids(points, 1.0 / h, nb - 1), nb, np.int64)
    return order, start, nb - 1


def sort_by_bucket_numpy(points: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, int]:
    """numpy twin of :func:`sort_by_bucket` (object-free int64 arithmetic, wrapping like the kernel)."""
    nb = 1 << max(4, int(2 * max(len(points), 1) - 1).bit_length())
    f = np.floor(np.asarray(points, np.float64) * (1.0 / h))
    c = np.where(f > HASH_LIMIT, HASH_LIMIT, np.where(f >= -HASH_LIMIT, f, -HASH_LIMIT)).astype(np.int64)
    b = hash_coords(c) & (nb - 1)
    order = np.argsort(b, kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(b, minlength=nb))])
    return order, start, nb - 1


@numba.njit(cache=True, nogil=True, inline="always")
def _mark_near(points, i, queries, q, r2, out):  # pragma: no cover - numba kernel (inlined)
    """Set ``out[i]`` if point ``i`` lies within squared distance ``r2`` of query ``q``."""
    if not out[i]:
        dx = points[i, 0] - queries[q, 0]
        dy = points[i, 1] - queries[q, 1]
        dz = points[i, 2] - queries[q, 2]
        if dx * dx + dy * dy + dz * dz <= r2:
            out[i] = True


@numba.njit(cache=True, nogil=True)
def mark_within(points, order, start, mask, h, queries, r, out):  # pragma: no cover - twin: growth.spatial.within_any_numpy
    """Set ``out[i]`` for every point ``i`` with squared distance ``<= r²`` to a query point (hashed layout of
    :func:`sort_by_bucket`). A ball spanning more cells than there are points scans the points directly (the
    same exact test, the same result)."""
    r2 = r * r
    inv = 1.0 / h
    reach = np.int64(min(np.ceil(r / h), HASH_LIMIT))
    brute = (2 * reach + 1) ** 3 > points.shape[0] if reach < 2 ** 20 else True
    for q in range(queries.shape[0]):
        if brute:
            for i in range(points.shape[0]):
                _mark_near(points, i, queries, q, r2, out)
            continue
        cx = cell_coord(queries[q, 0], inv, -HASH_LIMIT, HASH_LIMIT)
        cy = cell_coord(queries[q, 1], inv, -HASH_LIMIT, HASH_LIMIT)
        cz = cell_coord(queries[q, 2], inv, -HASH_LIMIT, HASH_LIMIT)
        for ix in range(cx - reach, cx + reach + 1):
            for iy in range(cy - reach, cy + reach + 1):
                for iz in range(cz - reach, cz + reach + 1):
                    b = hash_cell(ix, iy, iz, mask)
                    for k in range(start[b], start[b + 1]):
                        _mark_near(points, order[k], queries, q, r2, out)


@numba.njit(cache=True, nogil=True, inline="always")
def chain_within(j, nxt, points, x, y, z, r2):  # pragma: no cover - numba helper
    """True when an item of the linked list that starts at ``j`` (next item ``nxt[j]``, ``-1`` ends it) has a
    point ``points[j]`` at squared distance < ``r2`` from ``(x, y, z)``; stops at the first such item."""
    while j >= 0:
        ex = points[j, 0] - x
        ey = points[j, 1] - y
        ez = points[j, 2] - z
        if ex * ex + ey * ey + ez * ez < r2:
            return True
        j = nxt[j]
    return False


# ----------------------------------------------------------------------------------------------------------------
# hashed layout: boxes in a time-stamped spatial hash (Teschner et al. 2003)
#
# A bucket whose stamp differs from the hash's current stamp is empty, so clearing the grid for a new step is O(1)
# (the thesis's voxel time stamps). Entries are singly linked lists in flat arrays, so elements whose boxes changed
# are simply inserted again (stale entries are harmless: every candidate is tested exactly by the caller).
# ----------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, inline="always")
def box_cell_range(lo, hi, e, inv):
    """Cells ``(x0, x1, y0, y1, z0, z1)`` (inclusive) covered by box ``e`` of ``lo``/``hi``."""
    return (cell_coord(lo[e, 0], inv, -KEY_LIMIT, KEY_LIMIT - 1), cell_coord(hi[e, 0], inv, -KEY_LIMIT, KEY_LIMIT - 1),
            cell_coord(lo[e, 1], inv, -KEY_LIMIT, KEY_LIMIT - 1), cell_coord(hi[e, 1], inv, -KEY_LIMIT, KEY_LIMIT - 1),
            cell_coord(lo[e, 2], inv, -KEY_LIMIT, KEY_LIMIT - 1), cell_coord(hi[e, 2], inv, -KEY_LIMIT, KEY_LIMIT - 1))


@numba.njit(cache=True, nogil=True)
def _count_cells(lo, hi, ids, inv):  # pragma: no cover - numba kernel
    tot = 0.0
    for k in range(ids.size):
        e = ids[k]
        n = 1.0
        for a in range(3):
            if not (np.isfinite(lo[e, a]) and np.isfinite(hi[e, a])):
                return np.inf
            n *= (cell_coord(hi[e, a], inv, -KEY_LIMIT, KEY_LIMIT - 1)
                  - cell_coord(lo[e, a], inv, -KEY_LIMIT, KEY_LIMIT - 1) + 1)
        tot += n
    return tot


@numba.njit(cache=True, nogil=True)
def _hash_insert(lo, hi, ids, inv, head, stamp, cur, nxt, elem, key, n):  # pragma: no cover - numba kernel
    mask = head.size - 1
    for k in range(ids.size):
        e = ids[k]
        x0, x1, y0, y1, z0, z1 = box_cell_range(lo, hi, e, inv)
        for iz in range(z0, z1 + 1):
            for iy in range(y0, y1 + 1):
                for ix in range(x0, x1 + 1):
                    b = hash_cell(ix, iy, iz, mask)
                    if stamp[b] != cur:
                        stamp[b] = cur
                        head[b] = -1
                    elem[n] = e
                    key[n] = cell_key(ix, iy, iz)
                    nxt[n] = head[b]
                    head[b] = n
                    n += 1
    return n


class SpatialHash:
    """Uniform grid of one element set (boxes) in a time-stamped spatial hash, reused across passes and steps.

    Cell ``(ix, iy, iz)`` lives in bucket :func:`hash_cell`; the entries of bucket ``b`` are ``j = head[b]``,
    ``nxt[j]``, ... (``-1`` ends), each with its element ``elem[j]`` and cell key ``key[j]``, valid while
    ``stamp[b] == cur``. ``seen`` and ``token`` let a query report each element once.

    Parameters
    ----------
    n_elements : int
        Number of elements that can be stored (element ids are in ``[0, n_elements)``).
    """

    def __init__(self, n_elements: int):
        self.seen = np.zeros(max(int(n_elements), 1), np.int64)
        self.token = 0
        self.head = np.full(1 << 10, -1, np.int64)
        self.stamp = np.zeros(1 << 10, np.int64)
        self.cur = 0
        self.nxt = np.empty(0, np.int64)
        self.elem = np.empty(0, np.int64)
        self.key = np.empty(0, np.int64)
        self.n = 0
        self.inv = 1.0

    def clear(self, cell: float, expected: int) -> None:
        """Empty the grid (O(1) through the stamp) and set the cell size."""
        self.cur += 1
        self.n = 0
        self.inv = 1.0 / cell
        size = 1 << max(10, int(np.ceil(np.log2(max(2 * expected, 1)))))
        if size > self.head.size:
            self.head = np.full(size, -1, np.int64)
            self.stamp = np.zeros(size, np.int64)

    def insert(self, lo: np.ndarray, hi: np.ndarray, ids: np.ndarray) -> None:
        """Insert elements ``ids`` into every cell their boxes ``lo[ids], hi[ids]`` overlap."""
        cnt = _count_cells(lo, hi, ids, self.inv)
        if not cnt < 2e8:
            raise ValueError(f"swept boxes cover {cnt} grid cells (non-finite or exploded positions?); "
                             f"use a larger cell size or smaller steps")
        need = self.n + int(cnt)
        if need > self.elem.size:
            cap = max(need, int(1.5 * self.elem.size))
            for name in ("nxt", "elem", "key"):
                a = np.empty(cap, np.int64)
                a[:self.n] = getattr(self, name)[:self.n]
                setattr(self, name, a)
        self.n = _hash_insert(lo, hi, ids, self.inv, self.head, self.stamp, self.cur, self.nxt, self.elem,
                              self.key, self.n)

    def cells_numpy(self) -> dict[int, list[int]]:
        """numpy/Python twin view: ``{cell key: [elements, in insertion order]}`` of the live entries."""
        out: dict[int, list[int]] = {}
        for b in np.flatnonzero(self.stamp == self.cur):
            j = int(self.head[b])
            while j >= 0:
                out.setdefault(int(self.key[j]), []).append(int(self.elem[j]))
                j = int(self.nxt[j])
        return {k: v[::-1] for k, v in out.items()}


# ----------------------------------------------------------------------------------------------------------------
# hashed layout for Python loops: item lists per cell in a dict
# ----------------------------------------------------------------------------------------------------------------
class CellLists:
    """Item ids per cell ``floor(x / h)`` (exact Python integers: any finite coordinate) in a dict, for Python
    loops that add points one at a time and query between adds (particle walks).

    Parameters
    ----------
    h : float
        Cell size, > 0; a query sees every item within ``h`` of its point (and some farther ones).
    """

    def __init__(self, h: float):
        self.h = h
        self.cells: dict[tuple[int, int, int], list[int]] = {}

    def cell(self, p) -> tuple[int, int, int]:
        """Cell coordinates of point ``p`` (3,)."""
        h = self.h
        return int(np.floor(p[0] / h)), int(np.floor(p[1] / h)), int(np.floor(p[2] / h))

    def add(self, i: int, p) -> None:
        """Add item ``i`` at point ``p`` (3,)."""
        self.cells.setdefault(self.cell(p), []).append(i)

    def near(self, p) -> list[int]:
        """Items of the 3 × 3 × 3 cells around ``p``'s cell: cells in (dx, dy, dz) order, items in insertion order."""
        kx, ky, kz = self.cell(p)
        get = self.cells.get
        out: list[int] = []
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    out.extend(get((kx + dx, ky + dy, kz + dz), ()))
        return out

"""Hashed uniform grid over points for fixed-radius queries (spec 000_treewand §2.3, §12.2 future work 4).

Built in O(M) by a counting sort over hash buckets, so it can be rebuilt every growth step; a query
visits only the cells its ball overlaps. Hash collisions only add candidates: every hit is distance-checked.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._sorting import counting_sort

__all__ = ["PointGrid", "build_grid", "within_any"]

_P1, _P2, _P3 = 73856093, 19349663, 83492791


@numba.njit(cache=True, nogil=True, inline="always")
def _bucket(ix, iy, iz, mask):
    return ((ix * _P1) ^ (iy * _P2) ^ (iz * _P3)) & mask


@numba.njit(cache=True, nogil=True)
def _buckets(points, h, mask):
    bucket = np.empty(points.shape[0], np.int64)
    for i in range(points.shape[0]):
        bucket[i] = _bucket(np.int64(np.floor(points[i, 0] / h)), np.int64(np.floor(points[i, 1] / h)),
                            np.int64(np.floor(points[i, 2] / h)), mask)
    return bucket


class PointGrid:
    """A uniform grid of cell size ``h`` over ``points`` (M, 3), rebuilt whole in O(M)."""

    __slots__ = ("points", "h", "order", "start", "mask")

    def __init__(self, points: np.ndarray, h: float):
        self.points = points
        self.h = float(h)
        nb = 1 << max(4, int(2 * max(len(points), 1) - 1).bit_length())
        self.order, self.start = counting_sort(_buckets(points, self.h, nb - 1), nb, np.int64)
        self.mask = nb - 1


def build_grid(points: np.ndarray, h: float) -> PointGrid:
    """Return a :class:`PointGrid` of cell size ``h`` over ``points``."""
    return PointGrid(np.ascontiguousarray(points, dtype=np.float64), h)


@numba.njit(cache=True, nogil=True)
def _within_any(points, order, start, mask, h, queries, r, out):
    r2 = r * r
    reach = np.int64(np.ceil(r / h))
    for q in range(queries.shape[0]):
        cx = np.int64(np.floor(queries[q, 0] / h))
        cy = np.int64(np.floor(queries[q, 1] / h))
        cz = np.int64(np.floor(queries[q, 2] / h))
        for ix in range(cx - reach, cx + reach + 1):
            for iy in range(cy - reach, cy + reach + 1):
                for iz in range(cz - reach, cz + reach + 1):
                    b = _bucket(ix, iy, iz, mask)
                    for k in range(start[b], start[b + 1]):
                        i = order[k]
                        if out[i]:
                            continue
                        dx = points[i, 0] - queries[q, 0]
                        dy = points[i, 1] - queries[q, 1]
                        dz = points[i, 2] - queries[q, 2]
                        if dx * dx + dy * dy + dz * dz <= r2:
                            out[i] = True


def within_any(grid: PointGrid, queries: np.ndarray, r: float) -> np.ndarray:
    """Return a (M,) bool mask of the grid's points within distance ``r`` of any query point."""
    out = np.zeros(len(grid.points), np.bool_)
    if len(queries) and len(grid.points):
        _within_any(grid.points, grid.order, grid.start, grid.mask, grid.h,
                    np.ascontiguousarray(queries, dtype=np.float64), float(r), out)
    return out

"""Hashed uniform grid over points for fixed-radius queries (spec 000_treewand §2.3, §12.2 future work 4).

Built in O(M) by a counting sort over hash buckets, so it can be rebuilt every growth step; a query
visits only the cells its ball overlaps. Hash collisions only add candidates: every hit is distance-checked.
Cell indices are clipped to ±:data:`CELL_LIMIT` before the float → int conversion (issue 20: a tiny cell
or a far point overflowed int64); clipping is a contraction, so no neighbour within reach is lost, and NaN
coordinates fall in the border cell and match nothing. A query whose ball spans more cells than the grid
has points scans the points directly (same exact test, same result).
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._sorting import counting_sort
from plantvr._validation import MAX_COORD, check_points, check_range

__all__ = ["PointGrid", "build_grid", "within_any", "within_any_numpy", "REACH", "CELL_LIMIT"]

_P1, _P2, _P3 = 73856093, 19349663, 83492791

#: Coordinate bound of the growth cores' point inputs (markers, nodes): twice MAX_COORD, since markers are
#: painted up to a brush radius beyond a centre inside MAX_COORD and nodes overshoot a marker by one internode.
REACH = 2.0 * MAX_COORD
#: Largest |cell index| of a point grid (floats are exact integers up to 2**53).
CELL_LIMIT = float(2 ** 52)


@numba.njit(cache=True, nogil=True, inline="always")
def _bucket(ix, iy, iz, mask):
    return ((ix * _P1) ^ (iy * _P2) ^ (iz * _P3)) & mask


@numba.njit(cache=True, nogil=True, inline="always")
def _cell(x, h):
    """floor(x / h) clipped to ±CELL_LIMIT as int64; NaN gives -CELL_LIMIT."""
    f = np.floor(x / h)
    if f > CELL_LIMIT:
        f = CELL_LIMIT
    elif not f >= -CELL_LIMIT:
        f = -CELL_LIMIT
    return np.int64(f)


@numba.njit(cache=True, nogil=True)
def _buckets(points, h, mask):
    bucket = np.empty(points.shape[0], np.int64)
    for i in range(points.shape[0]):
        bucket[i] = _bucket(_cell(points[i, 0], h), _cell(points[i, 1], h), _cell(points[i, 2], h), mask)
    return bucket


class PointGrid:
    """A uniform grid of cell size ``h`` over ``points`` (M, 3), rebuilt whole in O(M).

    Parameters
    ----------
    points : (M, 3) float64 array_like
        Finite points within ±:data:`REACH`.
    h : float
        Cell size, in (0, inf).
    """

    __slots__ = ("points", "h", "order", "start", "mask")

    def __init__(self, points: np.ndarray, h: float):
        self._build(check_points("points", points, max_abs=REACH),
                    check_range("h", h, 0.0, np.inf, low_open=True, high_open=True))

    @classmethod
    def _trusted(cls, points: np.ndarray, h: float) -> "PointGrid":
        """Build without the door checks (the engine's path: its own validated markers)."""
        g = cls.__new__(cls)
        g._build(np.ascontiguousarray(points, dtype=np.float64), float(h))
        return g

    def _build(self, points, h):
        self.points = points
        self.h = float(h)
        nb = 1 << max(4, int(2 * max(len(points), 1) - 1).bit_length())
        self.order, self.start = counting_sort(_buckets(points, self.h, nb - 1), nb, np.int64)
        self.mask = nb - 1


def build_grid(points: np.ndarray, h: float) -> PointGrid:
    """Return a :class:`PointGrid` of cell size ``h`` over ``points`` (M, 3) float64 within ±:data:`REACH`."""
    return PointGrid(points, h)


@numba.njit(cache=True, nogil=True)
def _within_any(points, order, start, mask, h, queries, r, out):
    r2 = r * r
    reach = np.int64(min(np.ceil(r / h), CELL_LIMIT))
    brute = (2 * reach + 1) ** 3 > points.shape[0] if reach < 2 ** 20 else True
    for q in range(queries.shape[0]):
        if brute:  # the ball spans more cells than there are points: test them all (same exact test)
            for i in range(points.shape[0]):
                if out[i]:
                    continue
                dx = points[i, 0] - queries[q, 0]
                dy = points[i, 1] - queries[q, 1]
                dz = points[i, 2] - queries[q, 2]
                if dx * dx + dy * dy + dz * dz <= r2:
                    out[i] = True
            continue
        cx = _cell(queries[q, 0], h)
        cy = _cell(queries[q, 1], h)
        cz = _cell(queries[q, 2], h)
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
    """Return a (M,) bool mask of the grid's points within distance ``r`` of any query point.

    ``queries`` (Q, 3) float64 within ±:data:`REACH`; ``r`` in [0, inf).
    """
    if not isinstance(grid, PointGrid):
        raise ValueError(f"grid must be a PointGrid (see build_grid), got {type(grid).__name__}")
    return _within_any_trusted(grid, check_points("queries", queries, max_abs=REACH),
                               check_range("r", r, 0.0, np.inf, high_open=True))


def _within_any_trusted(grid: PointGrid, queries: np.ndarray, r: float) -> np.ndarray:
    """:func:`within_any` without the door checks (the engine's path)."""
    out = np.zeros(len(grid.points), np.bool_)
    if len(queries) and len(grid.points):
        _within_any(grid.points, grid.order, grid.start, grid.mask, grid.h,
                    np.ascontiguousarray(queries, dtype=np.float64), float(r), out)
    return out


def within_any_numpy(points: np.ndarray, queries: np.ndarray, r: float) -> np.ndarray:
    """numpy twin of :func:`within_any` (brute force, the same squared-distance test)."""
    out = np.zeros(len(points), bool)
    for q in np.asarray(queries, np.float64):
        d = points - q
        out |= d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2] <= r * r
    return out

"""Hashed uniform grid over points for fixed-radius queries (spec 000_treewand §2.3, §12.2 future work 4).

Built in O(M) by a counting sort over hash buckets, so it can be rebuilt every growth step; a query
visits only the cells its ball overlaps. Hash collisions only add candidates: every hit is distance-checked.
The grid is the hashed layout of :mod:`plantvr.grid` (:func:`~plantvr.grid.sort_by_bucket`,
:func:`~plantvr.grid.mark_within`). Cell indices are clipped to ±:data:`~plantvr.grid.HASH_LIMIT` before the float → int conversion (issue 20: a tiny cell
or a far point overflowed int64); clipping is a contraction, so no neighbour within reach is lost, and NaN
coordinates fall in the border cell and match nothing. A query whose ball spans more cells than the grid
has points scans the points directly (same exact test, same result).
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import MAX_COORD, check_points, check_range
from plantvr.grid import mark_within, sort_by_bucket

__all__ = ["PointGrid", "build_grid", "within_any", "within_any_numpy", "REACH"]

#: Coordinate bound of the growth cores' point inputs (markers, nodes): twice MAX_COORD, since markers are
#: painted up to a brush radius beyond a centre inside MAX_COORD and nodes overshoot a marker by one internode.
REACH = 2.0 * MAX_COORD


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
        self.order, self.start, self.mask = sort_by_bucket(points, self.h)


def build_grid(points: np.ndarray, h: float) -> PointGrid:
    """Return a :class:`PointGrid` of cell size ``h`` over ``points`` (M, 3) float64 within ±:data:`REACH`."""
    return PointGrid(points, h)


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
        mark_within(grid.points, grid.order, grid.start, grid.mask, grid.h,
                    np.ascontiguousarray(queries, dtype=np.float64), float(r), out)
    return out


def within_any_numpy(points: np.ndarray, queries: np.ndarray, r: float) -> np.ndarray:
    """numpy twin of :func:`within_any` and :func:`plantvr.grid.mark_within` (brute force, the same
    squared-distance test)."""
    out = np.zeros(len(points), bool)
    for q in np.asarray(queries, np.float64):
        d = points - q
        out |= d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2] <= r * r
    return out

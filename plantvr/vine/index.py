"""Spatial indices for the ViNE sphere brush (spec 000_vine §2.4.3–2.4.4, checklist items 14–15).

``GridIndex`` is the dense uniform grid of :mod:`plantvr.grid`, built once by a counting sort (numba, O(V)); a
ball query visits only the
cells that overlap the sphere's bounding box, so its cost grows with the brush, not the mesh. Its memory is
one int32 vertex order (4 B/vertex) plus one int32 start per cell (about 1 B/vertex by default).
``KDTreeIndex`` (scipy ``cKDTree``) and :func:`ball_query_brute` are the oracles; the benchmark
``benchmarks/vine_brush.py`` measures all three. The brush test is Eq. 5.16, ``(C-V)·(C-V) <= R²``,
evaluated in float64 on float32 positions in both the kernel and its numpy twin.
"""
from __future__ import annotations

import numba
import numpy as np
from scipy.spatial import cKDTree

from plantvr._validation import MAX_COORD, check_array, check_point, check_range
from plantvr.grid import ball_candidates, ball_query, bounds, row_spans, sort_by_cell

__all__ = ["GridIndex", "KDTreeIndex", "ball_query_brute"]


def ball_query_brute(points: np.ndarray, center, radius: float) -> np.ndarray:
    """All vertex ids with ``(C-V)·(C-V) <= R²`` by a brute-force numpy pass (the oracle).

    Parameters
    ----------
    points : (V, 3) float32 ndarray
    center : (3,) float
    radius : float

    Returns
    -------
    (K,) int64 ndarray, sorted

    References
    ----------
    .. [1] Thesis Eqs. 5.15–5.16 (spec 000_vine §2.4.3).
    """
    points = check_array("points", points, shape=(None, 3), dtype=np.float64, max_abs=MAX_COORD)
    c = check_point("center", center)
    radius = check_range("radius", radius, 0.0, 1e13)
    d0 = points[:, 0].astype(np.float64) - c[0]
    d1 = points[:, 1].astype(np.float64) - c[1]
    d2 = points[:, 2].astype(np.float64) - c[2]
    return np.nonzero(d0 * d0 + d1 * d1 + d2 * d2 <= float(radius) * float(radius))[0]


@numba.njit(cache=True, nogil=True)
def _grid_paint(points, order, starts, origin, h, dims, c, r, labels, paintable, label,
                out_idx, out_old):  # pragma: no cover - numba kernel, twin: _paint_numpy
    """Fused brush stamp: query, skip hidden and same-label vertices, record old values, write."""
    spans = row_spans(starts, origin, h, dims, c, r)
    r2 = r * r
    cnt = 0
    for q in range(spans.shape[0]):
        for v in order[spans[q, 0]:spans[q, 1]]:
            old = labels[v]
            if old == label or not paintable[old]:
                continue
            dx = np.float64(points[v, 0]) - c[0]
            dy = np.float64(points[v, 1]) - c[1]
            dz = np.float64(points[v, 2]) - c[2]
            if dx * dx + dy * dy + dz * dz <= r2:  # Eq. 5.16 in float64 on float32 positions
                out_idx[cnt] = v
                out_old[cnt] = old
                labels[v] = label
                cnt += 1
    return cnt


def _paint_numpy(points, center, radius, labels, paintable, label):
    """Numpy twin of ``_grid_paint``: returns (sorted changed ids, their old labels) and writes labels."""
    hits = ball_query_brute(points, center, radius)
    old = labels[hits]
    keep = (old != label) & paintable[old]
    idx, old = hits[keep], old[keep]
    labels[idx] = label
    return idx, old


class GridIndex:
    """Uniform-grid ball query over fixed vertex positions, built once in O(V).

    Parameters
    ----------
    points : (V, 3) float32 ndarray
        Vertex positions (kept by reference; do not move them afterwards). V < 2**31.
    cell_size : float, optional
        Grid spacing; default makes about ``cells_per_vertex * V`` cells over the bounding box.
    cells_per_vertex : float
        Used when ``cell_size`` is None, in (0, 8].

    Notes
    -----
    A query visits every cell overlapping the sphere's bounding box, i.e. O(brush); a tiny brush visits one
    to eight cells. Results are unsorted ids (the caller sorts once per operation, spec §2.5).
    """

    def __init__(self, points: np.ndarray, *, cell_size: float | None = None, cells_per_vertex: float = 0.25):
        pts = check_array("points", points, shape=(None, 3), dtype=np.float32, min_rows=1)
        if pts.shape[0] >= 2 ** 31 - 1:
            raise ValueError(f"points must have fewer than 2**31 rows, got {pts.shape[0]}")
        cells_per_vertex = check_range("cells_per_vertex", cells_per_vertex, 0.0, 8.0, low_open=True)
        lo, hi = bounds(pts)
        ext = np.maximum(hi - lo, 1e-9)
        if cell_size is None:
            target = max(cells_per_vertex * len(pts), 1.0)
            cell_size = float(np.prod(ext) / target) ** (1.0 / 3.0)
            cell_size = max(cell_size, float(ext.max()) / 2048.0, 1e-9)
        cell_size = check_range("cell_size", cell_size, 0.0, np.inf, low_open=True, high_open=True)
        dims = np.maximum(np.floor(ext / cell_size).astype(np.int64) + 1, 1)
        if int(np.prod(dims)) > 2 ** 31 - 2:
            raise ValueError(f"cell_size {cell_size!r} makes too many cells ({int(np.prod(dims))}); use a larger one")
        self.points = pts
        self.origin = lo
        self.cell_size = float(cell_size)
        self.dims = dims
        self.order, self.starts = sort_by_cell(pts, lo, self.cell_size, dims, np.int32)
        self._buf = np.empty(1024, np.int64)

    @property
    def nbytes(self) -> int:
        """Index memory in bytes (vertex order + cell starts), excluding the positions it references."""
        return int(self.order.nbytes + self.starts.nbytes)

    def query(self, center, radius: float) -> np.ndarray:
        """Ids of vertices with ``(C-V)·(C-V) <= R²`` (unsorted, (K,) int64)."""
        c = check_point("center", center)
        r = check_range("radius", radius, 0.0, np.inf, high_open=True)
        n = ball_candidates(self.starts, self.origin, self.cell_size, self.dims, c, r)
        if n > len(self._buf):
            self._buf = np.empty(max(n, 2 * len(self._buf)), np.int64)
        k = ball_query(self.points, self.order, self.starts, self.origin, self.cell_size, self.dims, c, r, self._buf)
        return self._buf[:k].copy()

    def paint(self, center: np.ndarray, radius: float, labels: np.ndarray, paintable: np.ndarray,
              label: int) -> tuple[np.ndarray, np.ndarray]:
        """Fused brush stamp (inputs already validated): write ``label``, return (ids, old labels)."""
        n = ball_candidates(self.starts, self.origin, self.cell_size, self.dims, center, radius)
        idx = np.empty(n, np.int64)
        old = np.empty(n, labels.dtype)
        k = _grid_paint(self.points, self.order, self.starts, self.origin, self.cell_size, self.dims,
                        center, float(radius), labels, paintable, labels.dtype.type(label), idx, old)
        return idx[:k], old[:k]


class KDTreeIndex:
    """scipy ``cKDTree`` ball query with the same interface as :class:`GridIndex` (oracle and baseline)."""

    def __init__(self, points: np.ndarray, *, leafsize: int = 32):
        self.points = check_array("points", points, shape=(None, 3), dtype=np.float32, min_rows=1)
        self.tree = cKDTree(self.points, leafsize=leafsize, balanced_tree=False, compact_nodes=False)

    @property
    def nbytes(self) -> int:
        """Approximate memory: the float64 data copy plus the index array."""
        return int(self.tree.data.nbytes + self.tree.indices.nbytes)

    def query(self, center, radius: float) -> np.ndarray:
        """Ids of vertices within ``radius`` of ``center`` ((K,) int64, unsorted)."""
        c = check_point("center", center)
        r = check_range("radius", radius, 0.0, np.inf, high_open=True)
        return np.asarray(self.tree.query_ball_point(c, r, return_sorted=False), np.int64)

    def paint(self, center, radius, labels, paintable, label):
        """Brush stamp through the k-d tree (same contract as :meth:`GridIndex.paint`)."""
        hits = self.query(center, radius)
        old = labels[hits]
        keep = (old != label) & paintable[old]
        idx, old = hits[keep], old[keep]
        labels[idx] = label
        return idx, old

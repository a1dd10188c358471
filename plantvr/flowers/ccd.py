"""Continuous collision detection and collision constraints (spec 002 §3.3.4–3.3.5, §3.6; C11–C13).

Broad phase: the time-stamped spatial hash of :mod:`plantvr.grid` over padded swept AABBs, queried with a stamp
array per query (the analogue of the thesis's time stamps). Narrow phase: Provot's coplanarity cubic
(Eqs. 4.2–4.5, B.2 vector form per ERRATUM A.6), coefficient culling, hybrid Newton/bisection root
finding on brackets from the critical points, barycentric (B.7) and segment-distance (B.8–B.11)
verification, parity rule (ERRATUM A.15). Constraints: unilateral vertex-triangle (Eq. 4.6) and
edge-edge (Eq. 4.7) with thickness h, side from the start-of-step state.

This module holds the checked wrappers, :class:`CollisionDetector` and the numpy twins; the numba kernels are
in :mod:`plantvr.flowers._ccd_kernels`.
"""
from __future__ import annotations

import time

import numpy as np

from plantvr._barycentric import barycentric_numpy
from plantvr._validation import MAX_COORD, MAX_COUNT, check_array, check_index, check_int, check_range
from plantvr.flowers._ccd_kernels import (
    _cubic_s,
    _hash_query,
    _narrow_kernel,
    _project_collision,
    _roots01,
    _seg_tri_count,
    _swept_boxes_kernel,
)
from plantvr.grid import SpatialHash

__all__ = [
    "CollisionDetector",
    "broad_phase",
    "count_static_intersections",
    "cubic_coefficients",
    "cubic_roots01",
    "detect_collisions",
    "detect_collisions_numpy",
    "mesh_edges_of",
    "solve_collisions",
]

# ---------------------------------------------------------------------------------------------------------
# Broad phase: padded swept boxes in the time-stamped spatial hash of plantvr.grid (Teschner et al. 2003,
# thesis [43]); a query reports each (query, target) pair once and tests the swept boxes exactly.


def _query(grid: SpatialHash, qids, qlo, qhi, qverts, tlo, thi, tverts, tmode, out, m, *, swap=False):
    """Append candidate pairs of queries ``qids`` against the elements stored in ``grid`` to ``out[:m]``."""
    out, m, grid.token = _hash_query(qids, qlo, qhi, qverts, tlo, thi, tverts, tmode, grid.inv, grid.head,
                                     grid.stamp, grid.cur, grid.nxt, grid.elem, grid.key, grid.seen,
                                     grid.token, out, m, swap)
    return out, m


def broad_phase(x0: np.ndarray, x1: np.ndarray, query: np.ndarray, target: np.ndarray, *,
                pad: float, cell: float | None = None, same_set: bool = False) -> np.ndarray:
    """Candidate pairs (query element, target element) whose padded swept AABBs overlap (spec 002 §3.6.1).

    Parameters
    ----------
    x0, x1 : (V, 3) float64 ndarray
        Start and end positions of the step.
    query : (Q, kq) int64 ndarray
        Query elements as vertex lists (vertices (Q, 1), edges (Q, 2)).
    target : (T, kt) int64 ndarray
        Elements stored in the grid (triangles (T, 3), edges (T, 2)).
    pad : float
        Box padding (numerical epsilon plus h, spec 002 §3.6.1).
    cell : float, optional
        Cell size; default the mean largest extent of the target boxes.
    same_set : bool
        Query and target are the same elements: keep each unordered pair once (q < t).

    Returns
    -------
    (K, 2) int64 ndarray
        Candidate pairs; pairs sharing a vertex are excluded.
    """
    query = np.ascontiguousarray(query, dtype=np.int64)
    target = np.ascontiguousarray(target, dtype=np.int64)
    if query.shape[0] == 0 or target.shape[0] == 0:
        return np.zeros((0, 2), np.int64)
    x0 = np.ascontiguousarray(x0, dtype=np.float64)
    x1 = np.ascontiguousarray(x1, dtype=np.float64)
    tid = np.arange(target.shape[0], dtype=np.int64)
    qid = np.arange(query.shape[0], dtype=np.int64)
    tlo, thi = np.empty((len(tid), 3)), np.empty((len(tid), 3))
    qlo, qhi = np.empty((len(qid), 3)), np.empty((len(qid), 3))
    _swept_boxes_kernel(x0, x1, target, tid, pad, tlo, thi)
    _swept_boxes_kernel(x0, x1, query, qid, pad, qlo, qhi)
    if cell is None:
        cell = float(np.mean((thi - tlo).max(axis=1))) + 1e-12
    grid = SpatialHash(target.shape[0])
    grid.clear(cell, 2 * target.shape[0])
    grid.insert(tlo, thi, tid)
    tmode = np.full(target.shape[0], 1 if same_set else 0, np.int8)
    out, m = _query(grid, qid, qlo, qhi, query, tlo, thi, target, tmode, np.empty((1024, 2), np.int64), 0)
    return out[:m].copy()


# ---------------------------------------------------------------------------------------------------------
# Narrow phase (its scalar kernels, no per-pair allocation, are in plantvr.flowers._ccd_kernels)


def _narrow(x0, x1, pairs, qel, tel, kind, bary_tol, dist_tol):
    """Narrow phase over candidate pairs: constraints (K, 4), sides (K,), first contact times (K,)."""
    m = pairs.shape[0]
    cons = np.empty((m, 4), np.int64)
    sides = np.empty(m)
    tfirst = np.empty(m)
    k = _narrow_kernel(np.ascontiguousarray(x0, dtype=np.float64), np.ascontiguousarray(x1, dtype=np.float64),
                       np.ascontiguousarray(pairs, dtype=np.int64), m, np.ascontiguousarray(qel, dtype=np.int64),
                       np.ascontiguousarray(tel, dtype=np.int64), kind, bary_tol, dist_tol, cons, sides, tfirst)
    return cons[:k], sides[:k], tfirst[:k]


# ---------------------------------------------------------------------------------------------------------
# Public wrappers


def cubic_coefficients(x, u, y, v, z, w) -> tuple[float, float, float, float]:
    """Coefficients (A, B, C, D) of f(t) = [(y + t v) x (z + t w)] . (x + t u) (Eqs. 4.2–4.5, B.2)."""
    args = [float(c) for a in (x, u, y, v, z, w) for c in np.asarray(a, dtype=np.float64).reshape(3)]
    return tuple(float(c) for c in _cubic_s(*args))


def cubic_roots01(a: float, b: float, c: float, d: float) -> np.ndarray:
    """All real roots of a t^3 + b t^2 + c t + d in [0, 1], ascending (spec 002 §3.6.3)."""
    out = np.empty(4)
    m = _roots01(float(a), float(b), float(c), float(d), out, np.empty(4))
    return out[:m].copy()


def mesh_edges_of(faces: np.ndarray) -> np.ndarray:
    """Unique undirected edges (E, 2) int64 of a triangle mesh."""
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0)


def _check_step(x0, x1, faces):
    x0 = check_array("x0", x0, shape=(None, 3), max_abs=MAX_COORD)
    x1 = check_array("x1", x1, shape=x0.shape, max_abs=MAX_COORD)
    faces = check_index("faces", faces, shape=(None, 3), low=0, high=x0.shape[0] - 1, table="vertices")
    return x0, x1, faces


def _incidence(elems: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR vertex -> element incidence (offsets (V+1,), element ids)."""
    v = elems.ravel()
    order = np.argsort(v, kind="stable")
    off = np.zeros(n_vertices + 1, np.int64)
    np.add.at(off, v + 1, 1)
    return np.cumsum(off), (order // elems.shape[1]).astype(np.int64)


def _gather(off: np.ndarray, ids: np.ndarray, verts: np.ndarray) -> np.ndarray:
    """Unique elements incident to ``verts`` (vectorised CSR gather)."""
    if verts.size == 0:
        return np.zeros(0, np.int64)
    starts = off[verts]
    cnt = off[verts + 1] - starts
    idx = np.repeat(starts - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    return np.unique(ids[idx])


class CollisionDetector:
    """Continuous collision detection for one mesh, with grids reused across passes and steps (§3.6).

    :meth:`detect` runs the full broad and narrow phases for a step ``x0 -> x1``. After collision
    constraints moved some vertices, :meth:`redetect` re-runs both phases only for the elements touching
    the moved vertices (their swept boxes are refreshed and re-inserted into the time-stamped grids) and
    keeps the earlier result for every pair whose vertices did not move, which equals a full pass.

    Parameters
    ----------
    faces : (F, 3) int64 ndarray
    n_vertices : int
    h : float
        Collision thickness ``spacing``; also pads the swept boxes.
    edges : (E, 2) int64 ndarray, optional
    cell : float, optional
        Grid cell size; default the mean largest extent of the triangles' swept boxes.
    """

    def __init__(self, faces: np.ndarray, n_vertices: int, *, h: float = 0.005, edges: np.ndarray | None = None,
                 cell: float | None = None):
        self.h = check_range("h", h, 0.0, 1e6)
        self.nv = check_int("n_vertices", n_vertices, 0, MAX_COUNT)
        self.faces = check_index("faces", faces, shape=(None, 3), low=0, high=self.nv - 1, table="vertices")
        self.edges = mesh_edges_of(self.faces) if edges is None else check_index(
            "edges", edges, shape=(None, 2), low=0, high=self.nv - 1, table="vertices")
        self.cell = None if cell is None else check_range("cell", cell, 0.0, 1e12, low_open=True)
        self.verts = np.arange(self.nv, dtype=np.int64)[:, None]
        self.vt_off, self.vt_ids = _incidence(self.faces, self.nv)
        self.ve_off, self.ve_ids = _incidence(self.edges, self.nv)
        nf, ne = len(self.faces), len(self.edges)
        self.tri_hash, self.edge_hash, self.vert_hash = SpatialHash(nf), SpatialHash(ne), SpatialHash(self.nv)
        self.tlo, self.thi = np.empty((nf, 3)), np.empty((nf, 3))
        self.elo, self.ehi = np.empty((ne, 3)), np.empty((ne, 3))
        self.vlo, self.vhi = np.empty((self.nv, 3)), np.empty((self.nv, 3))
        self.mode0_t = np.zeros(nf, np.int8)
        self.mode1_e = np.ones(ne, np.int8)
        self._buf = np.empty((4096, 2), np.int64)
        self._vhash_ok = False
        self.x0 = self.x1 = None
        self._last = None

    def _narrow_all(self, vt, ee, timings):
        t1 = time.perf_counter()
        c1, s1, _ = _narrow(self.x0, self.x1, vt, self.verts, self.faces, 0, 1e-6, 0.0)
        c2, s2, _ = _narrow(self.x0, self.x1, ee, self.edges, self.edges, 1, 1e-6, 1e-6 * self.scale)
        if timings is not None:
            timings["narrow"] = timings.get("narrow", 0.0) + time.perf_counter() - t1
            timings["candidates"] = timings.get("candidates", 0) + len(vt) + len(ee)
        kind = np.concatenate([np.zeros(len(c1), np.int8), np.ones(len(c2), np.int8)])
        return np.concatenate([c1, c2]), np.concatenate([s1, s2]), kind

    def detect(self, x0: np.ndarray, x1: np.ndarray, *, timings: dict | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Full CCD pass over one step (see :func:`detect_collisions` for the returned arrays)."""
        x0 = check_array("x0", x0, shape=(self.nv, 3), max_abs=MAX_COORD)
        x1 = check_array("x1", x1, shape=(self.nv, 3), max_abs=MAX_COORD)
        self.x0 = np.ascontiguousarray(x0)
        self.x1 = np.ascontiguousarray(x1).copy()
        t0 = time.perf_counter()
        self.pad = self.h + 1e-9 * (1.0 + float(np.abs(x0).max(initial=0.0)))
        e = self.edges
        self.scale = float(np.mean(np.linalg.norm(x0[e[:, 0]] - x0[e[:, 1]], axis=1))) if e.size else 1.0
        allf = np.arange(len(self.faces), dtype=np.int64)
        alle = np.arange(len(self.edges), dtype=np.int64)
        allv = np.arange(self.nv, dtype=np.int64)
        _swept_boxes_kernel(self.x0, self.x1, self.faces, allf, self.pad, self.tlo, self.thi)
        _swept_boxes_kernel(self.x0, self.x1, self.edges, alle, self.pad, self.elo, self.ehi)
        _swept_boxes_kernel(self.x0, self.x1, self.verts, allv, self.pad, self.vlo, self.vhi)
        cell = self.cell
        if cell is None:
            cell = float(np.mean((self.thi - self.tlo).max(axis=1))) + 1e-12 if len(allf) else 1.0
        self._cell = cell
        self.tri_hash.clear(cell, 4 * len(allf))
        self.tri_hash.insert(self.tlo, self.thi, allf)
        self.edge_hash.clear(cell, 4 * len(alle))
        self.edge_hash.insert(self.elo, self.ehi, alle)
        self._vhash_ok = False
        buf, m = _query(self.tri_hash, allv, self.vlo, self.vhi, self.verts, self.tlo, self.thi, self.faces,
                        self.mode0_t, self._buf, 0)
        vt = buf[:m].copy()
        buf, m = _query(self.edge_hash, alle, self.elo, self.ehi, self.edges, self.elo, self.ehi, self.edges,
                        self.mode1_e, buf, 0)
        ee = buf[:m].copy()
        self._buf = buf
        if timings is not None:
            timings["broad"] = timings.get("broad", 0.0) + time.perf_counter() - t0
        self._last = self._narrow_all(vt, ee, timings)
        return self._last

    def redetect(self, x1: np.ndarray, *, timings: dict | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CCD for the same step after the end positions changed; only moved vertices' elements are re-tested."""
        if self._last is None:
            raise ValueError("redetect needs a previous detect() for this step")
        x1 = check_array("x1", x1, shape=(self.nv, 3))
        t0 = time.perf_counter()
        moved_mask = np.any(x1 != self.x1, axis=1)
        moved = np.flatnonzero(moved_mask).astype(np.int64)
        if moved.size == 0:
            return self._last
        self.x1[moved] = x1[moved]
        cons, sides, kind = self._last
        keep = ~moved_mask[cons].any(axis=1) if len(cons) else np.zeros(0, bool)
        tris = _gather(self.vt_off, self.vt_ids, moved)
        eds = _gather(self.ve_off, self.ve_ids, moved)
        _swept_boxes_kernel(self.x0, self.x1, self.faces, tris, self.pad, self.tlo, self.thi)
        _swept_boxes_kernel(self.x0, self.x1, self.edges, eds, self.pad, self.elo, self.ehi)
        _swept_boxes_kernel(self.x0, self.x1, self.verts, moved, self.pad, self.vlo, self.vhi)
        self.tri_hash.insert(self.tlo, self.thi, tris)
        self.edge_hash.insert(self.elo, self.ehi, eds)
        if not self._vhash_ok:
            self.vert_hash.clear(self._cell, 2 * self.nv)
            self.vert_hash.insert(self.vlo, self.vhi, np.arange(self.nv, dtype=np.int64))
            self._vhash_ok = True
        else:
            self.vert_hash.insert(self.vlo, self.vhi, moved)
        # VT: moved vertices against all triangles, then touched triangles against unmoved vertices
        buf, m = _query(self.tri_hash, moved, self.vlo, self.vhi, self.verts, self.tlo, self.thi, self.faces,
                        self.mode0_t, self._buf, 0)
        vmode = moved_mask.astype(np.int8) * 2
        buf, m = _query(self.vert_hash, tris, self.tlo, self.thi, self.faces, self.vlo, self.vhi, self.verts,
                        vmode, buf, m, swap=True)
        vt = buf[:m].copy()
        # EE: touched edges against all edges; pairs of two touched edges once
        emode = np.zeros(len(self.edges), np.int8)
        emode[eds] = 1
        buf, m = _query(self.edge_hash, eds, self.elo, self.ehi, self.edges, self.elo, self.ehi, self.edges,
                        emode, buf, 0)
        ee = buf[:m].copy()
        self._buf = buf
        if timings is not None:
            timings["broad"] = timings.get("broad", 0.0) + time.perf_counter() - t0
        c, s, k = self._narrow_all(vt, ee, timings)
        self._last = (np.concatenate([cons[keep], c]), np.concatenate([sides[keep], s]),
                      np.concatenate([kind[keep], k]))
        return self._last


def detect_collisions(x0: np.ndarray, x1: np.ndarray, faces: np.ndarray, *, h: float = 0.005,
                      edges: np.ndarray | None = None, cell: float | None = None,
                      timings: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CCD over one step: vertex-triangle and edge-edge crossings of odd parity (spec 002 §3.6).

    Parameters
    ----------
    x0, x1 : (V, 3) float64 array_like
        Collision-free start positions and predicted end positions.
    faces : (F, 3) int64 array_like
    h : float
        Collision thickness ``spacing`` (also pads the swept boxes).
    edges : (E, 2) int64 array_like, optional
        Mesh edges (computed from ``faces`` if omitted).
    cell : float, optional
        Grid cell size of the broad phase.
    timings : dict, optional
        If given, ``broad`` and ``narrow`` seconds are added to it.

    Returns
    -------
    cons : (K, 4) int64 ndarray
        ``[free vertex, t0, t1, t2]``: VT rows (q, a, b, c), EE rows (a, b, c, d) (pseudo-triangle b, c, d).
    sides : (K,) float64 ndarray
        +1 or -1: the side of the (pseudo-)triangle plane the free vertex started on.
    kind : (K,) int8 ndarray
        0 for VT, 1 for EE.
    """
    h = check_range("h", h, 0.0, 1e6)
    x0, x1, faces = _check_step(x0, x1, faces)
    det = CollisionDetector(faces, x0.shape[0], h=h, edges=edges, cell=cell)
    return det.detect(x0, x1, timings=timings)


# ---------------------------------------------------------------------------------------------------------
# Numpy twin of the narrow phase (vectorised; the baseline of the benchmark)


def _np_cubic(x, u, y, v, z, w):
    Q = np.cross(v, w)
    R = np.cross(v, z) + np.cross(y, w)
    S = np.cross(y, z)
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)
    return dot(Q, u), dot(Q, x) + dot(R, u), dot(R, x) + dot(S, u), dot(S, x)


def _np_roots01(a, b, c, d):
    """Vectorised twin of ``_roots01``: (n, 3) candidate roots (NaN where none), bisection on brackets."""
    n = a.size
    scale = np.abs(a) + np.abs(b) + np.abs(c) + np.abs(d)
    culled = ((a > 0) & (b > 0) & (c > 0) & (d > 0)) | ((a < 0) & (b < 0) & (c < 0) & (d < 0))
    culled |= (d > 0) & (c > 0) & (d + c > np.abs(b) + np.abs(a))
    culled |= (d < 0) & (c < 0) & (d + c < -np.abs(b) - np.abs(a))
    culled |= np.abs(d) > np.abs(c) + np.abs(b) + np.abs(a)
    culled |= scale == 0
    f = lambda t: ((a * t + b) * t + c) * t + d
    qa, qb, qc = 3 * a, 2 * b, c
    with np.errstate(all="ignore"):
        disc = qb * qb - 4 * qa * qc
        sq = np.sqrt(np.maximum(disc, 0))
        qq = -0.5 * (qb + np.where(qb >= 0, sq, -sq))
        r1 = np.where(np.abs(qa) > 1e-300, qq / qa, np.where(np.abs(qb) > 1e-300, -qc / qb, np.nan))
        r2 = np.where((np.abs(qa) > 1e-300) & (qq != 0), qc / qq, np.nan)
        r1 = np.where((np.abs(qa) > 1e-300) & (disc < 0), np.nan, r1)
        r2 = np.where(disc < 0, np.nan, r2)
    crit = np.sort(np.column_stack([r1, r2]), axis=1)
    crit = np.where((crit > 0) & (crit < 1), crit, np.nan)
    pts = np.column_stack([np.zeros(n), crit, np.ones(n)])
    pts = np.sort(pts, axis=1)                                       # NaN sorted last
    eps = 1e-13 * scale
    roots = []
    for i in range(3):
        lo, hi = pts[:, i].copy(), pts[:, i + 1].copy()
        valid = ~np.isnan(lo) & ~np.isnan(hi)
        flo, fhi = f(np.nan_to_num(lo)), f(np.nan_to_num(hi))
        br = valid & (np.abs(flo) > eps) & (np.abs(fhi) > eps) & ((flo < 0) != (fhi < 0)) & ~culled
        l, r_, fl = lo[br], hi[br], flo[br]
        aa, bb, cc, dd = a[br], b[br], c[br], d[br]
        for _ in range(60):
            mid = 0.5 * (l + r_)
            fm = ((aa * mid + bb) * mid + cc) * mid + dd
            left = (fm < 0) == (fl < 0)
            l = np.where(left, mid, l)
            r_ = np.where(left, r_, mid)
        col = np.full(n, np.nan)
        col[br] = 0.5 * (l + r_)
        roots.append(col)
        touch = ~np.isnan(lo) & (np.abs(flo) <= eps) & ~culled
        col2 = np.full(n, np.nan)
        col2[touch] = lo[touch]
        roots.append(col2)
    last = np.nanmax(np.where(np.isnan(pts), -1, pts), axis=1)
    col3 = np.full(n, np.nan)
    t3 = (np.abs(f(last)) <= eps) & ~culled
    col3[t3] = last[t3]
    roots.append(col3)
    R = np.column_stack(roots)
    R = np.sort(R, axis=1)
    dup = np.zeros_like(R, dtype=bool)
    dup[:, 1:] = (R[:, 1:] - R[:, :-1]) <= 1e-10
    R[dup] = np.nan
    return R


def _np_lerp(X0, X1, t):
    return X0 + t[:, None] * (X1 - X0)


def _np_inside(p, a, b, c, tol):
    r_num, s_num, den = barycentric_numpy(b - a, c - a, p - a)
    with np.errstate(all="ignore"):
        r = r_num / den
        s = s_num / den
    return (den > 1e-300) & (r >= -tol) & (s >= -tol) & (r + s <= 1 + tol)


def _np_segdist(p0, p1, q0, q1):
    """Vectorised twin of ``_seg_dist_s``: minimum distance between segment pairs (App. B.3)."""
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e, f = dot(d1, d1), dot(d2, d2), dot(d2, r)
    c, b = dot(d1, r), dot(d1, d2)
    with np.errstate(all="ignore"):
        den = a * e - b * b
        s = np.where(den > 1e-300, np.clip((b * f - c * e) / den, 0, 1), 0.0)
        t = (b * s + f) / e
        s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
        t = np.clip(t, 0, 1)
        # degenerate segments
        s = np.where(a <= 1e-300, 0.0, np.where(e <= 1e-300, np.clip(-c / a, 0, 1), s))
        t = np.where(a <= 1e-300, np.clip(f / e, 0, 1), np.where(e <= 1e-300, 0.0, t))
        s = np.where((a <= 1e-300) & (e <= 1e-300), 0.0, s)
        t = np.where((a <= 1e-300) & (e <= 1e-300), 0.0, t)
    d = r + d1 * s[:, None] - d2 * t[:, None]
    return np.sqrt(dot(d, d))


def detect_collisions_numpy(x0, x1, faces, *, h: float = 0.005, edges=None, cell=None,
                            timings: dict | None = None):
    """Numpy twin of :func:`detect_collisions` (vectorised narrow phase, same broad phase)."""
    h = check_range("h", h, 0.0, 1e6)
    x0, x1, faces = _check_step(x0, x1, faces)
    edges = mesh_edges_of(faces) if edges is None else np.asarray(edges, np.int64)
    verts = np.arange(x0.shape[0], dtype=np.int64)[:, None]
    pad = h + 1e-9 * (1.0 + float(np.abs(x0).max(initial=0.0)))
    t0 = time.perf_counter()
    vt = broad_phase(x0, x1, verts, faces, pad=pad, cell=cell)
    ee = broad_phase(x0, x1, edges, edges, pad=pad, cell=cell, same_set=True)
    t1 = time.perf_counter()
    scale = float(np.mean(np.linalg.norm(x0[edges[:, 0]] - x0[edges[:, 1]], axis=1))) if edges.size else 1.0
    out = []
    for kind, pairs in ((0, vt), (1, ee)):
        if kind == 0:
            idx = np.column_stack([pairs[:, 0], faces[pairs[:, 1]]])
            P0, A0, B0, C0 = (x0[idx[:, k]] for k in range(4))
            P1, A1, B1, C1 = (x1[idx[:, k]] for k in range(4))
            xx, yy, zz = P0 - A0, B0 - A0, C0 - A0
            coef = _np_cubic(xx, P1 - A1 - xx, yy, B1 - A1 - yy, zz, C1 - A1 - zz)
        else:
            idx = np.column_stack([edges[pairs[:, 0]], edges[pairs[:, 1]]])
            P0, A0, B0, C0 = (x0[idx[:, k]] for k in range(4))   # a, b, c, d at t = 0
            P1, A1, B1, C1 = (x1[idx[:, k]] for k in range(4))
            xx, yy, zz = B0 - P0, C0 - P0, A0 - P0
            coef = _np_cubic(xx, B1 - P1 - xx, yy, C1 - P1 - yy, zz, A1 - P1 - zz)
        R = _np_roots01(*coef)
        hits = np.zeros(len(idx), np.int64)
        for j in range(R.shape[1]):
            has = ~np.isnan(R[:, j])
            if not has.any():
                continue
            t = R[has, j]
            sel = np.flatnonzero(has)
            p, a, b, c = (_np_lerp(X0[sel], X1[sel], t) for X0, X1 in ((P0, P1), (A0, A1), (B0, B1), (C0, C1)))
            if kind == 0:
                ok = _np_inside(p, a, b, c, 1e-6)
            else:
                ok = _np_segdist(p, a, b, c) <= 1e-6 * scale
            hits[sel[ok]] += 1
        odd = hits % 2 == 1
        cons = idx[odd]
        X0 = [x0[cons[:, k]] for k in range(4)]
        X1 = [x1[cons[:, k]] for k in range(4)]
        sd = np.einsum("ij,ij->i", X0[0] - X0[1], np.cross(X0[2] - X0[1], X0[3] - X0[1]))
        sd1 = -np.einsum("ij,ij->i", X1[0] - X1[1], np.cross(X1[2] - X1[1], X1[3] - X1[1]))
        sd = np.where(sd == 0, sd1, sd)
        out.append((cons, np.where(sd >= 0, 1.0, -1.0), np.full(len(cons), kind, np.int8)))
    t2 = time.perf_counter()
    if timings is not None:
        timings["broad"] = timings.get("broad", 0.0) + t1 - t0
        timings["narrow"] = timings.get("narrow", 0.0) + t2 - t1
    return tuple(np.concatenate([o[i] for o in out]) for i in range(3))


# ---------------------------------------------------------------------------------------------------------
# Collision constraints


def _project_collision_numpy(p, w, cons, sides, h, k, iterations):
    """Readable numpy twin of ``_project_collision`` (same constraint order, same step limiter)."""
    for _ in range(iterations):
        for (iq, ia, ib, ic), s in zip(cons, sides):
            q, a, b, c = p[iq], p[ia], p[ib], p[ic]
            N = np.cross(b - a, c - a)
            nN = np.linalg.norm(N)
            if nN < 1e-300:
                continue
            n = N / nN
            r = q - a
            C = s * r.dot(n) - h                                   # Eq. 4.6 / 4.7
            if C >= 0:
                continue
            rp = r - r.dot(n) * n
            g_q, g_b, g_c = s * n, s * np.cross(c - a, rp) / nN, s * np.cross(rp, b - a) / nN
            g_a = -(g_q + g_b + g_c)
            grads = ((iq, g_q), (ia, g_a), (ib, g_b), (ic, g_c))
            den = sum(w[i] * gi.dot(gi) for i, gi in grads)
            if den < 1e-300:
                continue
            lam = k * C / den
            gm = max(w[i] * np.linalg.norm(gi) for i, gi in grads)
            if abs(lam) * gm > 2.0 * abs(C):
                lam *= 2.0 * abs(C) / (abs(lam) * gm)
            for i, gi in grads:
                p[i] = p[i] - lam * w[i] * gi


def solve_collisions(p: np.ndarray, w: np.ndarray, cons: np.ndarray, sides: np.ndarray, *,
                     h: float = 0.005, k_collision: float = 1.0, iterations: int = 10) -> np.ndarray:
    """Project unilateral collision constraints in place (Eqs. 4.6–4.7, Alg. 1 lines 16–20).

    C = s (q - a) . n - h >= 0 with n the unit normal of (a, b, c) and s the start-of-step side.
    """
    h = check_range("h", h, 0.0, 1e6)
    k_collision = check_range("k_collision", k_collision, 0.0, 1.0)
    iterations = check_int("iterations", iterations, 0, 1_000_000)
    if not (isinstance(p, np.ndarray) and p.dtype == np.float64 and p.ndim == 2 and p.shape[1] == 3
            and p.flags.c_contiguous):
        raise ValueError("p must be a C-contiguous (V, 3) float64 ndarray (it is updated in place)")
    if not np.all(np.isfinite(p)):
        raise ValueError("p must contain only finite values (no NaN or inf)")
    w = check_array("w", w, shape=(p.shape[0],))
    if np.any(w < 0):
        raise ValueError("w (inverse masses) must be >= 0")
    cons = check_index("cons", cons, shape=(None, 4), low=0, high=p.shape[0] - 1, table="vertices")
    sides = check_array("sides", sides, shape=(cons.shape[0],))
    if cons.shape[0]:
        _project_collision(p, np.ascontiguousarray(w, dtype=np.float64), cons, sides, h, k_collision, iterations)
    return p


# ---------------------------------------------------------------------------------------------------------
# Static intersection check (sanity check, V23)


def count_static_intersections(x: np.ndarray, faces: np.ndarray, *, edges: np.ndarray | None = None) -> int:
    """Number of (edge, triangle) pairs that intersect, excluding pairs sharing a vertex (spec §3.5 sanity check).

    Returns
    -------
    int
        0 for an intersection-free mesh.
    """
    x = check_array("x", x, shape=(None, 3), max_abs=MAX_COORD)
    faces = check_index("faces", faces, shape=(None, 3), low=0, high=x.shape[0] - 1, table="vertices")
    edges = mesh_edges_of(faces) if edges is None else check_index(
        "edges", edges, shape=(None, 2), low=0, high=x.shape[0] - 1, table="vertices")
    pairs = broad_phase(x, x, edges, faces, pad=1e-12 * (1 + float(np.abs(x).max(initial=0))))
    return int(_seg_tri_count(x, pairs, edges, faces))

"""Continuous collision detection and collision constraints (spec 002 §3.3.4–3.3.5, §3.6; C11–C13).

Broad phase: a uniform grid (sorted-key spatial hash) over padded swept AABBs, queried with a stamp
array per query (the analogue of the thesis's time stamps). Narrow phase: Provot's coplanarity cubic
(Eqs. 4.2–4.5, B.2 vector form per ERRATUM A.6), coefficient culling, hybrid Newton/bisection root
finding on brackets from the critical points, barycentric (B.7) and segment-distance (B.8–B.11)
verification, parity rule (ERRATUM A.15). Constraints: unilateral vertex-triangle (Eq. 4.6) and
edge-edge (Eq. 4.7) with thickness h, side from the start-of-step state.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import check_array, check_int, check_range

__all__ = ["cubic_coefficients", "cubic_roots01", "broad_phase", "detect_collisions",
           "detect_collisions_numpy", "solve_collisions", "count_static_intersections", "mesh_edges_of"]

# ---------------------------------------------------------------------------------------------------------
# Broad phase


@numba.njit(cache=True, nogil=True)
def _grid_build(lo, hi, origin, inv_cell, dims):
    n = lo.shape[0]
    counts = np.zeros(n + 1, np.int64)
    for e in range(n):
        c = 1
        for a in range(3):
            i0 = min(max(int(np.floor((lo[e, a] - origin[a]) * inv_cell)), 0), dims[a] - 1)
            i1 = min(max(int(np.floor((hi[e, a] - origin[a]) * inv_cell)), 0), dims[a] - 1)
            c *= i1 - i0 + 1
        counts[e + 1] = counts[e] + c
    keys = np.empty(counts[n], np.int64)
    elems = np.empty(counts[n], np.int64)
    for e in range(n):
        x0 = min(max(int(np.floor((lo[e, 0] - origin[0]) * inv_cell)), 0), dims[0] - 1)
        x1 = min(max(int(np.floor((hi[e, 0] - origin[0]) * inv_cell)), 0), dims[0] - 1)
        y0 = min(max(int(np.floor((lo[e, 1] - origin[1]) * inv_cell)), 0), dims[1] - 1)
        y1 = min(max(int(np.floor((hi[e, 1] - origin[1]) * inv_cell)), 0), dims[1] - 1)
        z0 = min(max(int(np.floor((lo[e, 2] - origin[2]) * inv_cell)), 0), dims[2] - 1)
        z1 = min(max(int(np.floor((hi[e, 2] - origin[2]) * inv_cell)), 0), dims[2] - 1)
        k = counts[e]
        for iz in range(z0, z1 + 1):
            for iy in range(y0, y1 + 1):
                for ix in range(x0, x1 + 1):
                    keys[k] = ix + dims[0] * (iy + dims[1] * iz)
                    elems[k] = e
                    k += 1
    order = np.argsort(keys, kind="mergesort")
    return keys[order], elems[order]


@numba.njit(cache=True, nogil=True)
def _grid_query(qlo, qhi, qverts, keys, elems, everts, elo, ehi, origin, inv_cell, dims, same_set):
    nq = qlo.shape[0]
    n_el = everts.shape[0]
    stamp = np.full(n_el, -1, np.int64)
    cap = 1024
    out = np.empty((cap, 2), np.int64)
    m = 0
    for q in range(nq):
        x0 = min(max(int(np.floor((qlo[q, 0] - origin[0]) * inv_cell)), 0), dims[0] - 1)
        x1 = min(max(int(np.floor((qhi[q, 0] - origin[0]) * inv_cell)), 0), dims[0] - 1)
        y0 = min(max(int(np.floor((qlo[q, 1] - origin[1]) * inv_cell)), 0), dims[1] - 1)
        y1 = min(max(int(np.floor((qhi[q, 1] - origin[1]) * inv_cell)), 0), dims[1] - 1)
        z0 = min(max(int(np.floor((qlo[q, 2] - origin[2]) * inv_cell)), 0), dims[2] - 1)
        z1 = min(max(int(np.floor((qhi[q, 2] - origin[2]) * inv_cell)), 0), dims[2] - 1)
        for iz in range(z0, z1 + 1):
            for iy in range(y0, y1 + 1):
                for ix in range(x0, x1 + 1):
                    key = ix + dims[0] * (iy + dims[1] * iz)
                    j = np.searchsorted(keys, key)
                    while j < keys.size and keys[j] == key:
                        e = elems[j]
                        j += 1
                        if stamp[e] == q:
                            continue
                        stamp[e] = q
                        if same_set and e <= q:
                            continue
                        shared = False
                        for a in range(qverts.shape[1]):
                            for b in range(everts.shape[1]):
                                if qverts[q, a] == everts[e, b]:
                                    shared = True
                        if shared:
                            continue
                        if (qhi[q, 0] < elo[e, 0] or qlo[q, 0] > ehi[e, 0] or qhi[q, 1] < elo[e, 1]
                                or qlo[q, 1] > ehi[e, 1] or qhi[q, 2] < elo[e, 2] or qlo[q, 2] > ehi[e, 2]):
                            continue                # exact swept-box overlap test
                        if m == cap:
                            cap *= 2
                            new = np.empty((cap, 2), np.int64)
                            new[:m] = out[:m]
                            out = new
                        out[m, 0] = q
                        out[m, 1] = e
                        m += 1
    return out[:m]


def _swept_boxes(x0, x1, elems, pad):
    pts = np.concatenate([x0[elems], x1[elems]], axis=1)        # (n, 2k, 3)
    return pts.min(axis=1) - pad, pts.max(axis=1) + pad


def broad_phase(x0: np.ndarray, x1: np.ndarray, query: np.ndarray, target: np.ndarray, *,
                pad: float, cell: float | None = None, same_set: bool = False) -> np.ndarray:
    """Candidate pairs (query element, target element) whose padded swept AABBs share a grid cell.

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
        Cell size; default 1.5 x the mean target box extent.
    same_set : bool
        Query and target are the same elements: keep each unordered pair once (q < t).

    Returns
    -------
    (K, 2) int64 ndarray
        Candidate pairs; pairs sharing a vertex are excluded.
    """
    if query.shape[0] == 0 or target.shape[0] == 0:
        return np.zeros((0, 2), np.int64)
    tlo, thi = _swept_boxes(x0, x1, target, pad)
    qlo, qhi = _swept_boxes(x0, x1, query, pad)
    lo = np.minimum(tlo.min(axis=0), qlo.min(axis=0))
    hi = np.maximum(thi.max(axis=0), qhi.max(axis=0))
    if cell is None:
        cell = 1.5 * float(np.mean(thi - tlo)) + 1e-12
    dims = np.minimum(np.ceil((hi - lo) / cell).astype(np.int64) + 1, 1 << 20)
    while np.prod(dims.astype(np.float64)) > 2.0 ** 62:
        cell *= 2
        dims = np.ceil((hi - lo) / cell).astype(np.int64) + 1
    keys, elems = _grid_build(tlo, thi, lo, 1.0 / cell, dims)
    return _grid_query(qlo, qhi, np.ascontiguousarray(query), keys, elems, np.ascontiguousarray(target),
                       tlo, thi, lo, 1.0 / cell, dims, same_set)


# ---------------------------------------------------------------------------------------------------------
# Narrow phase: scalar numba kernels


@numba.njit(cache=True, nogil=True)
def _cubic(x, u, y, v, z, w):
    """Coefficients of (y + t v) x (z + t w) . (x + t u) (spec 002 §3.6.2)."""
    Q = np.cross(v, w)
    R = np.cross(v, z) + np.cross(y, w)
    S = np.cross(y, z)
    return Q.dot(u), Q.dot(x) + R.dot(u), R.dot(x) + S.dot(u), S.dot(x)


@numba.njit(cache=True, nogil=True)
def _horner(a, b, c, d, t):
    return ((a * t + b) * t + c) * t + d


@numba.njit(cache=True, nogil=True)
def _culled(a3, a2, a1, a0):
    """Coefficient culling [50]: True when the cubic certainly has no root in [0, 1]."""
    if (a0 > 0 and a1 > 0 and a2 > 0 and a3 > 0) or (a0 < 0 and a1 < 0 and a2 < 0 and a3 < 0):
        return True
    if a0 > 0 and a1 > 0 and a0 + a1 > abs(a2) + abs(a3):
        return True
    if a0 < 0 and a1 < 0 and a0 + a1 < -abs(a2) - abs(a3):
        return True
    if abs(a0) > abs(a1) + abs(a2) + abs(a3):
        return True
    return False


@numba.njit(cache=True, nogil=True)
def _rtsafe(a, b, c, d, lo, hi, flo):
    """Hybrid Newton/bisection on a bracket with f(lo) f(hi) < 0 (Numerical Recipes rtsafe)."""
    t = 0.5 * (lo + hi)
    for _ in range(100):
        f = _horner(a, b, c, d, t)
        if f == 0.0:
            return t
        if (f < 0) == (flo < 0):
            lo = t
        else:
            hi = t
        df = (3 * a * t + 2 * b) * t + c
        tn = t - f / df if df != 0.0 else 0.5 * (lo + hi)
        if not (lo < tn < hi):
            tn = 0.5 * (lo + hi)
        if abs(tn - t) < 1e-15 or hi - lo < 1e-15:
            return tn
        t = tn
    return t


@numba.njit(cache=True, nogil=True)
def _roots01(a, b, c, d, out):
    """All roots of the cubic in [0, 1], ascending, into ``out``; returns the count (spec §3.6.3)."""
    scale = abs(a) + abs(b) + abs(c) + abs(d)
    if scale == 0.0 or _culled(a, b, c, d):
        return 0
    eps = 1e-13 * scale
    # split [0, 1] at the critical points (roots of 3a t^2 + 2b t + c)
    pts = np.empty(4)
    npts = 0
    pts[npts] = 0.0
    npts += 1
    qa, qb, qc = 3 * a, 2 * b, c
    if abs(qa) > 1e-300:
        disc = qb * qb - 4 * qa * qc
        if disc >= 0:
            sq = np.sqrt(disc)
            qq = -0.5 * (qb + (sq if qb >= 0 else -sq))
            r1 = qq / qa
            r2 = qc / qq if qq != 0 else r1
            if r1 > r2:
                r1, r2 = r2, r1
            if 0 < r1 < 1:
                pts[npts] = r1
                npts += 1
            if 0 < r2 < 1 and r2 != r1:
                pts[npts] = r2
                npts += 1
    elif abs(qb) > 1e-300:
        r1 = -qc / qb
        if 0 < r1 < 1:
            pts[npts] = r1
            npts += 1
    pts[npts] = 1.0
    npts += 1
    m = 0
    for i in range(npts):
        t = pts[i]
        if abs(_horner(a, b, c, d, t)) <= eps:
            if m == 0 or t - out[m - 1] > 1e-10:
                out[m] = t
                m += 1
        if i + 1 < npts:
            lo, hi = pts[i], pts[i + 1]
            flo, fhi = _horner(a, b, c, d, lo), _horner(a, b, c, d, hi)
            if abs(flo) > eps and abs(fhi) > eps and (flo < 0) != (fhi < 0):
                r = _rtsafe(a, b, c, d, lo, hi, flo)
                if m == 0 or r - out[m - 1] > 1e-10:
                    out[m] = r
                    m += 1
    return m


@numba.njit(cache=True, nogil=True)
def _vt_inside(p, a, b, c, tol):
    u = b - a
    v = c - a
    w = p - a
    uu, vv, uv = u.dot(u), v.dot(v), u.dot(v)
    wu, wv = w.dot(u), w.dot(v)
    den = uu * vv - uv * uv
    if den <= 1e-300:
        return False
    r = (vv * wu - uv * wv) / den          # Eq. B.7
    s = (uu * wv - uv * wu) / den
    return r >= -tol and s >= -tol and r + s <= 1 + tol


@numba.njit(cache=True, nogil=True)
def _seg_dist(p0, p1, q0, q1):
    """Minimum distance between segments p0p1 and q0q1 (App. B.3, robust clamped form)."""
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = d1.dot(d1)
    e = d2.dot(d2)
    f = d2.dot(r)
    if a <= 1e-300 and e <= 1e-300:
        return np.sqrt(r.dot(r))
    if a <= 1e-300:
        s = 0.0
        t = min(max(f / e, 0.0), 1.0)
    else:
        c = d1.dot(r)
        if e <= 1e-300:
            t = 0.0
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = d1.dot(d2)
            den = a * e - b * b
            s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 1e-300 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    dd = p0 + d1 * s - q0 - d2 * t
    return np.sqrt(dd.dot(dd))


@numba.njit(cache=True, nogil=True)
def _side(q, a, b, c):
    n = np.cross(b - a, c - a)
    return (q - a).dot(n)


@numba.njit(cache=True, nogil=True)
def _narrow(x0, x1, pairs, qel, tel, kind, bary_tol, dist_tol):
    """kind 0: VT (qel vertices (Q,1), tel triangles); kind 1: EE (edges vs edges).

    Returns constraints (K, 4) [free, t0, t1, t2], side signs (K,), first contact times (K,).
    """
    n = pairs.shape[0]
    cons = np.empty((n, 4), np.int64)
    sides = np.empty(n)
    tfirst = np.empty(n)
    roots = np.empty(4)
    m = 0
    for k in range(n):
        if kind == 0:
            ip = qel[pairs[k, 0], 0]
            ia, ib, ic = tel[pairs[k, 1], 0], tel[pairs[k, 1], 1], tel[pairs[k, 1], 2]
            P0, A0, B0, C0 = x0[ip], x0[ia], x0[ib], x0[ic]
            P1, A1, B1, C1 = x1[ip], x1[ia], x1[ib], x1[ic]
            xx = P0 - A0
            yy = B0 - A0
            zz = C0 - A0
            a3, a2, a1, a0 = _cubic(xx, (P1 - A1) - xx, yy, (B1 - A1) - yy, zz, (C1 - A1) - zz)
        else:
            ia, ib = qel[pairs[k, 0], 0], qel[pairs[k, 0], 1]
            ic, idd = tel[pairs[k, 1], 0], tel[pairs[k, 1], 1]
            A0, B0, C0, D0 = x0[ia], x0[ib], x0[ic], x0[idd]
            A1, B1, C1, D1 = x1[ia], x1[ib], x1[ic], x1[idd]
            xx = C0 - A0
            yy = D0 - A0
            zz = B0 - A0
            a3, a2, a1, a0 = _cubic(xx, (C1 - A1) - xx, yy, (D1 - A1) - yy, zz, (B1 - A1) - zz)
        nr = _roots01(a3, a2, a1, a0, roots)
        hits = 0
        first = 2.0
        for r in range(nr):
            t = roots[r]
            if kind == 0:
                ok = _vt_inside(P0 + t * (P1 - P0), A0 + t * (A1 - A0), B0 + t * (B1 - B0),
                                C0 + t * (C1 - C0), bary_tol)
            else:
                pa, pb = A0 + t * (A1 - A0), B0 + t * (B1 - B0)
                pc, pd = C0 + t * (C1 - C0), D0 + t * (D1 - D0)
                ok = _seg_dist(pa, pb, pc, pd) <= dist_tol
            if ok:
                hits += 1
                if t < first:
                    first = t
        if hits % 2 == 1:            # parity rule (ERRATUM A.15)
            if kind == 0:
                cons[m, 0], cons[m, 1], cons[m, 2], cons[m, 3] = ip, ia, ib, ic
                sd = _side(P0, A0, B0, C0)
                if sd == 0.0:
                    sd = -_side(P1, A1, B1, C1)
            else:
                cons[m, 0], cons[m, 1], cons[m, 2], cons[m, 3] = ia, ib, ic, idd
                sd = _side(A0, B0, C0, D0)
                if sd == 0.0:
                    sd = -_side(A1, B1, C1, D1)
            sides[m] = 1.0 if sd >= 0 else -1.0
            tfirst[m] = first
            m += 1
    return cons[:m], sides[:m], tfirst[:m]


# ---------------------------------------------------------------------------------------------------------
# Public wrappers


def cubic_coefficients(x, u, y, v, z, w) -> tuple[float, float, float, float]:
    """Coefficients (A, B, C, D) of f(t) = [(y + t v) x (z + t w)] . (x + t u) (Eqs. 4.2–4.5, B.2)."""
    args = [np.asarray(a, dtype=np.float64) for a in (x, u, y, v, z, w)]
    return tuple(float(c) for c in _cubic(*args))


def cubic_roots01(a: float, b: float, c: float, d: float) -> np.ndarray:
    """All real roots of a t^3 + b t^2 + c t + d in [0, 1], ascending (spec 002 §3.6.3)."""
    out = np.empty(4)
    m = _roots01(float(a), float(b), float(c), float(d), out)
    return out[:m].copy()


def mesh_edges_of(faces: np.ndarray) -> np.ndarray:
    """Unique undirected edges (E, 2) int64 of a triangle mesh."""
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0)


def _check_step(x0, x1, faces):
    x0 = check_array("x0", x0, shape=(None, 3))
    x1 = check_array("x1", x1, shape=x0.shape)
    faces = check_array("faces", faces, shape=(None, 3), dtype=np.int64)
    if faces.size and (faces.min() < 0 or faces.max() >= x0.shape[0]):
        raise ValueError(f"faces must index vertices in [0, {x0.shape[0] - 1}]")
    return x0, x1, faces


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
    import time
    h = check_range("h", h, 0.0, 1e6)
    x0, x1, faces = _check_step(x0, x1, faces)
    edges = mesh_edges_of(faces) if edges is None else check_array("edges", edges, shape=(None, 2),
                                                                    dtype=np.int64)
    verts = np.arange(x0.shape[0], dtype=np.int64)[:, None]
    pad = h + 1e-9 * (1.0 + float(np.abs(x0).max(initial=0.0)))
    t0 = time.perf_counter()
    vt = broad_phase(x0, x1, verts, faces, pad=pad, cell=cell)
    ee = broad_phase(x0, x1, edges, edges, pad=pad, cell=cell, same_set=True)
    t1 = time.perf_counter()
    scale = float(np.mean(np.linalg.norm(x0[edges[:, 0]] - x0[edges[:, 1]], axis=1))) if edges.size else 1.0
    c1, s1, _ = _narrow(x0, x1, vt, verts, faces, 0, 1e-6, 1e-6 * scale)
    c2, s2, _ = _narrow(x0, x1, ee, edges, edges, 1, 1e-6, 1e-6 * scale)
    t2 = time.perf_counter()
    if timings is not None:
        timings["broad"] = timings.get("broad", 0.0) + t1 - t0
        timings["narrow"] = timings.get("narrow", 0.0) + t2 - t1
        timings["candidates"] = timings.get("candidates", 0) + vt.shape[0] + ee.shape[0]
    kind = np.concatenate([np.zeros(len(c1), np.int8), np.ones(len(c2), np.int8)])
    return np.concatenate([c1, c2]), np.concatenate([s1, s2]), kind


# ---------------------------------------------------------------------------------------------------------
# Numpy twin of the narrow phase (vectorised; the baseline of the benchmark)


def _np_cubic(x, u, y, v, z, w):
    Q = np.cross(v, w)
    R = np.cross(v, z) + np.cross(y, w)
    S = np.cross(y, z)
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)  # noqa: E731
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
    f = lambda t: ((a * t + b) * t + c) * t + d  # noqa: E731
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
    u, v, w = b - a, c - a, p - a
    dot = lambda x, y: np.einsum("ij,ij->i", x, y)  # noqa: E731
    uu, vv, uv, wu, wv = dot(u, u), dot(v, v), dot(u, v), dot(w, u), dot(w, v)
    den = uu * vv - uv * uv
    with np.errstate(all="ignore"):
        r = (vv * wu - uv * wv) / den
        s = (uu * wv - uv * wu) / den
    return (den > 1e-300) & (r >= -tol) & (s >= -tol) & (r + s <= 1 + tol)


def _np_segdist(p0, p1, q0, q1):
    return np.array([_seg_dist(p0[i], p1[i], q0[i], q1[i]) for i in range(p0.shape[0])])


def detect_collisions_numpy(x0, x1, faces, *, h: float = 0.005, edges=None, cell=None,
                            timings: dict | None = None):
    """Numpy twin of :func:`detect_collisions` (vectorised narrow phase, same broad phase)."""
    import time
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


@numba.njit(cache=True, nogil=True)
def _project_collision(p, w, cons, sides, h, k, iterations):
    for _ in range(iterations):
        for c in range(cons.shape[0]):
            iq, ia, ib, ic = cons[c, 0], cons[c, 1], cons[c, 2], cons[c, 3]
            s = sides[c]
            q, a, b, cc = p[iq], p[ia], p[ib], p[ic]
            N = np.cross(b - a, cc - a)
            nN = np.sqrt(N.dot(N))
            if nN < 1e-300:
                continue
            n = N / nN
            r = q - a
            C = s * r.dot(n) - h                     # Eq. 4.6 / 4.7
            if C >= 0:
                continue
            rp = r - r.dot(n) * n
            gq = s * n
            gb = s * np.cross(cc - a, rp) / nN
            gc = s * np.cross(rp, b - a) / nN
            ga = -(gq + gb + gc)
            den = w[iq] * gq.dot(gq) + w[ia] * ga.dot(ga) + w[ib] * gb.dot(gb) + w[ic] * gc.dot(gc)
            if den < 1e-300:
                continue
            lam = k * C / den
            p[iq] -= lam * w[iq] * gq
            p[ia] -= lam * w[ia] * ga
            p[ib] -= lam * w[ib] * gb
            p[ic] -= lam * w[ic] * gc


def solve_collisions(p: np.ndarray, w: np.ndarray, cons: np.ndarray, sides: np.ndarray, *,
                     h: float = 0.005, k_collision: float = 1.0, iterations: int = 10) -> np.ndarray:
    """Project unilateral collision constraints in place (Eqs. 4.6–4.7, Alg. 1 lines 16–20).

    C = s (q - a) . n - h >= 0 with n the unit normal of (a, b, c) and s the start-of-step side.
    """
    h = check_range("h", h, 0.0, 1e6)
    k_collision = check_range("k_collision", k_collision, 0.0, 1.0)
    iterations = check_int("iterations", iterations, 0, 1_000_000)
    cons = check_array("cons", cons, shape=(None, 4), dtype=np.int64)
    sides = check_array("sides", sides, shape=(cons.shape[0],))
    if cons.shape[0]:
        _project_collision(p, np.ascontiguousarray(w, dtype=np.float64), cons, sides, h, k_collision, iterations)
    return p


# ---------------------------------------------------------------------------------------------------------
# Static intersection check (sanity check, V23)


@numba.njit(cache=True, nogil=True)
def _seg_tri_count(x, pairs, edges, faces):
    cnt = 0
    for k in range(pairs.shape[0]):
        e = pairs[k, 0]
        f = pairs[k, 1]
        p0, p1 = x[edges[e, 0]], x[edges[e, 1]]
        a, b, c = x[faces[f, 0]], x[faces[f, 1]], x[faces[f, 2]]
        n = np.cross(b - a, c - a)
        d0 = (p0 - a).dot(n)
        d1 = (p1 - a).dot(n)
        if (d0 > 0 and d1 > 0) or (d0 < 0 and d1 < 0) or d0 == d1:
            continue
        t = d0 / (d0 - d1)
        q = p0 + t * (p1 - p0)
        if _vt_inside(q, a, b, c, 0.0):
            cnt += 1
    return cnt


def count_static_intersections(x: np.ndarray, faces: np.ndarray, *, edges: np.ndarray | None = None) -> int:
    """Number of (edge, triangle) pairs that intersect, excluding pairs sharing a vertex (spec §3.5 sanity check).

    Returns
    -------
    int
        0 for an intersection-free mesh.
    """
    x = check_array("x", x, shape=(None, 3))
    faces = check_array("faces", faces, shape=(None, 3), dtype=np.int64)
    edges = mesh_edges_of(faces) if edges is None else np.asarray(edges, np.int64)
    pairs = broad_phase(x, x, edges, faces, pad=1e-12 * (1 + float(np.abs(x).max(initial=0))))
    return int(_seg_tri_count(x, pairs, edges, faces))

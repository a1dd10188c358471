"""Depth cueing against a coarse convex hull (spec 000_vine §2.2, checklist item 8; thesis Eqs. 5.8–5.11).

The hull is Qhull stopped early (``TA270`` → 274 vertices). Per frame: the eye midpoint E is tested for
being inside the hull by ray parity (Eqs. 5.9–5.10), ``d_c`` is the closest distance from E to the hull
(0 inside), ``d_f`` the furthest hull vertex, and colours blend toward the background with
``C = (1 − f) C_init + f C_bg`` (Eq. 5.8). Here the blend is evaluated per vertex on the CPU (a shader-free
variant suited to stills and small meshes); ``f`` uses the normalised forms of ERRATUM A.4.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.spatial import ConvexHull

from plantvr._barycentric import barycentric_nb, barycentric_numpy
from plantvr._validation import check_choice, check_int, check_point, check_points, check_range
from plantvr.types import TriMesh

__all__ = ["CoarseHull", "coarse_hull", "depth_cue_colors", "depth_factor", "hull_distances", "inside_hull"]


@dataclass(eq=False)
class CoarseHull(TriMesh):
    """Coarse convex hull, a :class:`~plantvr.types.TriMesh`: vertices (H, 3) float64 and outward faces (T, 3)
    int64 into them."""


def coarse_hull(points: np.ndarray, *, n_vertices: int = 274, sample: int = 1_000_000,
                rng: int | np.random.Generator | None = 0) -> CoarseHull:
    """Qhull stopped after ``n_vertices`` hull vertices (thesis: 274 for the gerbera).

    Parameters
    ----------
    points : (V, 3) float ndarray
    n_vertices : int
        Vertex budget, in [5, 100000]; ``TA{n_vertices - 4}`` (4 initial simplex vertices).
    sample : int
        Random subset size for very large meshes, in [100, 10**9].
    rng : int, Generator or None

    Returns
    -------
    CoarseHull
        An inner approximation; model points may lie slightly outside it (clamp the depth, spec §2.2.3).

    References
    ----------
    .. [1] Thesis §5.2.1 (Quickhull, Barber et al.); spec §2.2.3 ``TA270``.
    """
    pts = check_points("points", points, min_rows=4)
    n_vertices = check_int("n_vertices", n_vertices, 5, 100000)
    sample = check_int("sample", sample, 100, 10 ** 9)
    rng = np.random.default_rng(rng)
    if len(pts) > sample:
        pts = pts[rng.choice(len(pts), sample, replace=False)]
    hull = ConvexHull(pts, qhull_options=f"TA{n_vertices - 4}")
    used = np.unique(hull.simplices)
    remap = np.full(len(pts), -1, np.int64)
    remap[used] = np.arange(len(used))
    tri = remap[hull.simplices]
    verts = pts[used]
    # orient outward using the hull's centroid (convex: centroid is inside)
    centre = verts.mean(axis=0)
    a, b, c = verts[tri[:, 0]], verts[tri[:, 1]], verts[tri[:, 2]]
    n = np.cross(b - a, c - a)
    flip = np.einsum("ij,ij->i", n, a - centre) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return CoarseHull(verts, tri)


def inside_hull(hull: CoarseHull, eye, *, rng: int | np.random.Generator | None = 0) -> bool:
    """Ray-parity inside test (thesis §5.2.2): one ray from E; 1 hit = inside, 0 or 2 = outside.

    Solves ``[A−B, A−C, d] [β γ t]ᵀ = A − E`` (Eq. 5.10) for all triangles at once by Cramer's rule
    (scalar triple products, i.e. Möller–Trumbore); β, γ are the weights of B and C (ERRATUM A.5). A ray
    that passes within 1e-9 of an edge is re-cast in another random direction.
    """
    E = check_point("eye", eye)
    rng = np.random.default_rng(rng)
    V, T = hull.vertices, hull.faces
    A = V[T[:, 0]]
    e1, e2 = V[T[:, 1]] - A, V[T[:, 2]] - A
    s = E - A
    for _ in range(16):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        beta = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        gamma = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        eps = 1e-9
        near_edge = ok & (t > 0) & ((np.abs(beta) < eps) | (np.abs(gamma) < eps) | (np.abs(beta + gamma - 1) < eps))
        if near_edge.any():
            continue
        hits = ok & (t > 0) & (beta > 0) & (gamma > 0) & (beta + gamma < 1)
        return int(hits.sum()) == 1
    raise ValueError("inside_hull: every ray grazed an edge; the eye lies on the hull")


def _closest_on_triangles(E, A, B, C):
    """Closest point to E on each triangle (plane projection, else clamp onto edges; thesis Fig. 5.5)."""
    n = np.cross(B - A, C - A)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    Ep = E - np.einsum("ij,ij->i", E - A, n)[:, None] * n
    # barycentric of Ep
    beta_num, gamma_num, den = barycentric_numpy(B - A, C - A, Ep - A)
    beta, gamma = beta_num / den, gamma_num / den
    inside = (beta >= 0) & (gamma >= 0) & (beta + gamma <= 1)
    best = Ep.copy()
    bestd = np.full(len(A), np.inf)
    for P, Q in ((A, B), (B, C), (C, A)):
        pq = Q - P
        t = np.clip(np.einsum("ij,ij->i", Ep - P, pq) / np.einsum("ij,ij->i", pq, pq), 0.0, 1.0)
        X = P + t[:, None] * pq
        dist = np.linalg.norm(X - E, axis=1)
        take = ~inside & (dist < bestd)
        best[take] = X[take]
        bestd[take] = dist[take]
    return best


@numba.njit(cache=True, nogil=True, inline="always")
def _seg_dist2(ex, ey, ez, px, py, pz, qx, qy, qz, sx, sy, sz):  # pragma: no cover
    """Squared distance from E to the segment PQ at the clamped projection of S (= E_p)."""
    ux, uy, uz = qx - px, qy - py, qz - pz
    t = ((sx - px) * ux + (sy - py) * uy + (sz - pz) * uz) / (ux * ux + uy * uy + uz * uz)
    t = min(max(t, 0.0), 1.0)
    dx, dy, dz = px + t * ux - ex, py + t * uy - ey, pz + t * uz - ez
    return dx * dx + dy * dy + dz * dz


@numba.njit(cache=True, nogil=True)
def _closest_point_triangle(E, A, B, C):  # pragma: no cover - numba kernel, twin: _closest_on_triangles
    """Distance from E to triangle ABC: plane projection E_p if inside, else clamp E_p onto the edges."""
    ex, ey, ez = E[0], E[1], E[2]
    ax, ay, az = A[0], A[1], A[2]
    bx, by, bz = B[0] - ax, B[1] - ay, B[2] - az
    cx, cy, cz = C[0] - ax, C[1] - ay, C[2] - az
    nx, ny, nz = by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx
    nn = np.sqrt(nx * nx + ny * ny + nz * nz)
    nx, ny, nz = nx / nn, ny / nn, nz / nn
    h = (ex - ax) * nx + (ey - ay) * ny + (ez - az) * nz
    px, py, pz = ex - h * nx, ey - h * ny, ez - h * nz
    beta_num, gamma_num, den = barycentric_nb(bx, by, bz, cx, cy, cz, px - ax, py - ay, pz - az)
    beta, gamma = beta_num / den, gamma_num / den
    if beta >= 0 and gamma >= 0 and beta + gamma <= 1:
        return abs(h)
    Bx, By, Bz = B[0], B[1], B[2]
    Cx, Cy, Cz = C[0], C[1], C[2]
    d2 = _seg_dist2(ex, ey, ez, ax, ay, az, Bx, By, Bz, px, py, pz)
    d2 = min(d2, _seg_dist2(ex, ey, ez, Bx, By, Bz, Cx, Cy, Cz, px, py, pz))
    d2 = min(d2, _seg_dist2(ex, ey, ez, Cx, Cy, Cz, ax, ay, az, px, py, pz))
    return np.sqrt(d2)


@numba.njit(cache=True, nogil=True)
def _hull_distances_kernel(V, T, E, inside):  # pragma: no cover - numba kernel, twin: _hull_distances_numpy
    d_f = 0.0
    for i in range(V.shape[0]):
        dx, dy, dz = V[i, 0] - E[0], V[i, 1] - E[1], V[i, 2] - E[2]
        d_f = max(d_f, np.sqrt(dx * dx + dy * dy + dz * dz))
    if inside:
        return 0.0, d_f
    d_c = np.inf
    for j in range(T.shape[0]):
        d_c = min(d_c, _closest_point_triangle(E, V[T[j, 0]], V[T[j, 1]], V[T[j, 2]]))  # views: no copies
    return d_c, d_f


def _hull_distances_numpy(hull: CoarseHull, E: np.ndarray) -> tuple[float, float]:
    V, T = hull.vertices, hull.faces
    d_f = float(np.linalg.norm(V - E, axis=1).max())
    if inside_hull(hull, E):
        return 0.0, d_f
    X = _closest_on_triangles(E, V[T[:, 0]], V[T[:, 1]], V[T[:, 2]])
    return float(np.linalg.norm(X - E, axis=1).min()), d_f


def _inside_halfspace(hull: CoarseHull, E: np.ndarray) -> bool:
    V, T = hull.vertices, hull.faces
    n = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    return bool((np.einsum("ij,ij->i", n, E - V[T[:, 0]]) <= 0).all())


@numba.njit(cache=True, nogil=True)
def _ray_hits(V, T, E, d):  # pragma: no cover - numba kernel, twin: inside_hull
    """(hits, grazed) of the ray E + t d against all triangles (Eq. 5.10 by Cramer's rule)."""
    hits = 0
    for j in range(T.shape[0]):
        A = V[T[j, 0]]
        e1 = V[T[j, 1]] - A
        e2 = V[T[j, 2]] - A
        p = np.cross(d, e2)
        det = np.dot(e1, p)
        if abs(det) <= 1e-12:
            continue
        s = E - A
        beta = np.dot(s, p) / det
        q = np.cross(s, e1)
        gamma = np.dot(d, q) / det
        t = np.dot(e2, q) / det
        if t > 0:
            if abs(beta) < 1e-9 or abs(gamma) < 1e-9 or abs(beta + gamma - 1) < 1e-9:
                return 0, True
            if beta > 0 and gamma > 0 and beta + gamma < 1:
                hits += 1
    return hits, False


def _inside_fast(hull: CoarseHull, E: np.ndarray, rng) -> bool:
    for _ in range(16):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        hits, grazed = _ray_hits(hull.vertices, hull.faces, E, d)
        if not grazed:
            return hits == 1
    raise ValueError("inside_hull: every ray grazed an edge; the eye lies on the hull")


def hull_distances(hull: CoarseHull, eye) -> tuple[float, float]:
    """``(d_c, d_f)``: closest distance from E to the hull (0 inside) and furthest hull vertex distance.

    The inside test is the ray parity of :func:`inside_hull`; the closest point per triangle projects E on
    the plane and clamps onto the edges (Fig. 5.5) in a numba kernel, whose numpy twin is tested equal.

    References
    ----------
    .. [1] Thesis §5.2.2 steps 2–4 (spec §2.2.4).
    """
    E = check_point("eye", eye)
    inside = _inside_fast(hull, E, np.random.default_rng(0))
    d_c, d_f = _hull_distances_kernel(hull.vertices, hull.faces, E, inside)
    return float(d_c), float(d_f)


def depth_factor(d: np.ndarray, d_c: float, d_f: float, *, p: float = 0.85, s: float = 3.0,
                 mode: str = "p_exp") -> np.ndarray:
    """Blend factor f(d) in (0, p] (Eq. 5.11, normalised per ERRATUM A.4).

    Parameters
    ----------
    d : ndarray
        Distances from the eye midpoint.
    d_c, d_f : float
        Closest / furthest hull distances.
    p : float
        Maximum blend, in [0, 1] (thesis 0.85).
    s : float
        Steepness, in (0, 100].
    mode : {"p_exp", "fog", "literal"}
        ``p_exp``: ``p·exp(s(x−1))``; ``fog``: ``p(1−e^{−sx})/(1−e^{−s})``; ``literal``: Eq. 5.11 as
        printed, clamped to [0, p]. x is the normalised depth clamped to [0, 1].
    """
    p = check_range("p", p, 0.0, 1.0)
    s = check_range("s", s, 0.0, 100.0, low_open=True)
    if not isinstance(mode, str):
        raise ValueError(f"mode must be one of ['p_exp', 'fog', 'literal'], got {mode!r:.80}")
    mode = check_choice("mode", mode, ("p_exp", "fog", "literal"))
    d_c = check_range("d_c", d_c, -1e300, 1e300)
    d_f = check_range("d_f", d_f, -1e300, 1e300)
    try:
        dd = np.asarray(d, np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"d must be an array of distances, got {type(d).__name__}") from None
    if not np.all(np.isfinite(dd)):
        raise ValueError("d must contain only finite distances (no NaN or inf)")
    span = max(float(d_f) - float(d_c), 1e-12)
    x = np.clip((dd - d_c) / span, 0.0, 1.0)
    if mode == "p_exp":
        return p * np.exp(s * (x - 1.0))                       # ERRATUM A.4 (normalised variant)
    if mode == "fog":
        return p * (1.0 - np.exp(-s * x)) / (1.0 - np.exp(-s))
    return np.clip(np.exp(s * x), 0.0, p)


def depth_cue_colors(colors: np.ndarray, points: np.ndarray, eye, hull: CoarseHull, *,
                     background=(0, 0, 0), p: float = 0.85, s: float = 3.0, mode: str = "p_exp") -> np.ndarray:
    """Blend per-vertex colours toward the background by distance (Eq. 5.8), shader-free.

    Parameters
    ----------
    colors : (V, 3) or (V, 4) uint8 ndarray
    points : (V, 3) float ndarray
        Vertex positions in the same frame as ``eye`` and ``hull``.
    eye : (3,) float
        Eye midpoint E.
    hull : CoarseHull
    background : 3 ints
        Background colour (dark by default: "further = darker", spec §2.2.1 [INFERRED]).

    Returns
    -------
    ndarray like ``colors`` (alpha kept)
    """
    colors = np.asarray(colors)
    if colors.dtype != np.uint8 or colors.ndim != 2 or colors.shape[1] not in (3, 4):
        raise ValueError(f"colors must be uint8 of shape (V, 3) or (V, 4), got {colors.dtype} {colors.shape}")
    pts = np.asarray(points, np.float32)
    if pts.shape != (len(colors), 3):
        raise ValueError(f"points must have shape ({len(colors)}, 3), got {pts.shape}")
    bg = check_point("background", background)
    d_c, d_f = hull_distances(hull, eye)
    d = np.linalg.norm(pts - np.asarray(eye, np.float32), axis=1)
    f = depth_factor(d, d_c, d_f, p=p, s=s, mode=mode).astype(np.float32)[:, None]
    out = colors.copy()
    out[:, :3] = np.clip(np.rint((1 - f) * colors[:, :3] + f * bg.astype(np.float32)), 0, 255).astype(np.uint8)
    return out

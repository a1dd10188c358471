"""Position-based dynamics: distance and signed dihedral bending constraints (spec 002 §3.2–§3.3.2; C5–C7).

Gauss-Seidel projection (Eq. 3.10, ERRATUM A.1) of Eq. 3.11 distance constraints and the thesis's signed
dihedral bending constraint (Eq. 3.13, App. A behaviour via the closed-form signed-angle gradient of
spec §3.3.2), or Jacobi projection with per-vertex averaging (the thesis's GPU path, §3.10, V26). Each
numba kernel has a numpy twin with the same constraint order.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import (
    MAX_COORD, MAX_COUNT, check_array, check_choice, check_index, check_int, check_range,
)

__all__ = [
    "bend_quads",
    "cloth_patch",
    "dihedral_gradient",
    "edge_lengths",
    "mesh_edges",
    "signed_dihedrals",
    "solve_internal",
    "solve_internal_jacobi_numpy",
    "solve_internal_numpy",
]


def cloth_patch(nx: int, ny: int | None = None, *, spacing: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Flat rectangular grid of ``nx`` x ``ny`` vertices in the z = 0 plane, two triangles per cell.

    The cloth patch of V26 and the petal strips of the PBD/CCD tests (App. B.5).

    Parameters
    ----------
    nx : int
        Vertices along x (>= 2).
    ny : int, optional
        Vertices along y (>= 2); ``nx`` if omitted.
    spacing : float
        Grid step in x and y, in metres (> 0).

    Returns
    -------
    x : (nx * ny, 3) float64 ndarray
        Vertex ``i * ny + j`` at ``(i * spacing, j * spacing, 0)``.
    faces : (2 (nx - 1) (ny - 1), 3) int64 ndarray
        Triangles ``(a, b, c)`` and ``(a, c, d)`` of cell (i, j), with a = (i, j), b = (i + 1, j),
        c = (i + 1, j + 1), d = (i, j + 1), cells in row-major order; normals along +z.

    Examples
    --------
    >>> x, faces = cloth_patch(2, 3)
    >>> x.shape, faces.tolist()
    ((6, 3), [[0, 3, 4], [0, 4, 1], [1, 4, 5], [1, 5, 2]])
    """
    nx = check_int("nx", nx, 2, 1_000_000)
    ny = nx if ny is None else check_int("ny", ny, 2, 1_000_000)
    spacing = check_range("spacing", spacing, 0.0, np.inf, low_open=True)
    gx, gy = np.meshgrid(np.arange(nx) * spacing, np.arange(ny) * spacing, indexing="ij")
    x = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
    idx = np.arange(nx * ny, dtype=np.int64).reshape(nx, ny)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    faces = np.stack([np.stack([a, b, c], axis=-1), np.stack([a, c, d], axis=-1)], axis=2)
    return x, faces.reshape(-1, 3)


def mesh_edges(faces: np.ndarray) -> np.ndarray:
    """Unique undirected edges (E, 2) int64 of a triangle mesh, sorted, ``i < j``."""
    faces = check_index("faces", faces, shape=(None, 3), low=0, high=MAX_COUNT - 1, table="vertices")
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0)


def bend_quads(faces: np.ndarray) -> np.ndarray:
    """Bending quadruples (B, 4) int64 ``(p1, p2, p3, p4)`` for every interior manifold edge.

    Triangle (p1, p2, p3) holds the directed edge p1->p2 and triangle (p1, p4, p2) the edge p2->p1
    (the ordering of Eq. 3.12), so the orientation of the mesh fixes the sign convention.
    """
    faces = check_index("faces", faces, shape=(None, 3), low=0, high=MAX_COUNT - 1, table="vertices")
    if faces.shape[0] == 0:
        return np.zeros((0, 4), np.int64)
    V = int(faces.max()) + 1
    d = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)                  # directed edges, 3 per face
    opp = faces[:, [2, 0, 1]].reshape(-1)                            # vertex opposite each directed edge
    keys = d[:, 0] * V + d[:, 1]
    rkeys = d[:, 1] * V + d[:, 0]
    sorter = np.argsort(keys, kind="stable")
    pos = np.minimum(np.searchsorted(keys[sorter], rkeys), keys.size - 1)
    partner = sorter[pos]
    found = (keys[partner] == rkeys) & (d[:, 0] < d[:, 1])
    idx = np.flatnonzero(found)
    return np.column_stack([d[idx, 0], d[idx, 1], opp[idx], opp[partner[idx]]]).astype(np.int64)


def edge_lengths(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Length of every edge, (E,) float64 (rest values of Eq. 3.11)."""
    x = check_array("x", x, shape=(None, 3))
    edges = check_index("edges", edges, shape=(None, 2), low=0, high=x.shape[0] - 1, table="vertices")
    return np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)


def signed_dihedrals(x: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Signed bend angle phi of every quad, (B,) float64 radians in (-pi, pi] (Eq. 3.13, flat = 0).

    References
    ----------
    .. [1] Owens 2016, Eq. 3.13 and App. A; ERRATUM A.5 (signed range, wrapped differences).
    """
    x = check_array("x", x, shape=(None, 3))
    quads = check_index("quads", quads, shape=(None, 4), low=0, high=x.shape[0] - 1, table="vertices")
    p1, p2, p3, p4 = (x[quads[:, k]] for k in range(4))
    e = p2 - p1
    n1 = np.cross(p3 - p1, e)
    n2 = np.cross(e, p4 - p1)
    en = e / np.linalg.norm(e, axis=1, keepdims=True)
    n1n = np.linalg.norm(n1, axis=1)
    n2n = np.linalg.norm(n2, axis=1)
    sin = np.einsum("ij,ij->i", en, np.cross(n1, n2)) / (n1n * n2n)
    cos = np.einsum("ij,ij->i", n1, n2) / (n1n * n2n)
    return np.arctan2(sin, cos)


def dihedral_gradient(p1, p2, p3, p4):
    """Closed-form gradient (g1, g2, g3, g4) of the signed bend angle (spec 002 §3.3.2) for one quad."""
    p1, p2, p3, p4 = (check_array(f"p{k + 1}", q, shape=(3,)) for k, q in enumerate((p1, p2, p3, p4)))
    e = p2 - p1
    N1 = np.cross(p3 - p1, e)
    N2 = np.cross(e, p4 - p1)
    le = np.linalg.norm(e)
    g3 = le * N1 / N1.dot(N1)
    g4 = le * N2 / N2.dot(N2)
    t3 = (p3 - p1).dot(e) / e.dot(e)
    t4 = (p4 - p1).dot(e) / e.dot(e)
    g1 = -((1 - t3) * g3 + (1 - t4) * g4)
    g2 = -(t3 * g3 + t4 * g4)
    return g1, g2, g3, g4


#: Largest rest bend angle magnitude (radians) :func:`solve_internal` accepts: blended rest angles lie in
#: (-2 pi, 2 pi); the kernels' wrapping loop needs a bounded difference.
_MAX_REST_PHI = 4 * np.pi

#: Largest bending correction of one vertex per projection, as a fraction of the hinge edge length.
_MAX_STEP = 0.25


@numba.njit(cache=True, nogil=True, inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(cache=True, nogil=True, inline="always")
def _norm2(x, y, z):
    return x * x + y * y + z * z


@numba.njit(cache=True, nogil=True, inline="always")
def _axpy(p, i, f, x, y, z):
    """``p[i] += f * (x, y, z)``; a step ``p[i] -= a * g`` is ``_axpy(p, i, -a, *g)``, to the same bits."""
    p[i, 0] += f * x
    p[i, 1] += f * y
    p[i, 2] += f * z


@numba.njit(cache=True, nogil=True, inline="always")
def _weighted_den(w, i1, i2, i3, i4, g1, g2, g3, g4):
    """``sum_j w_j |g_j|^2`` over a four-vertex constraint (the denominator of Eq. 3.10, ERRATUM A.1)."""
    return (w[i1] * _norm2(g1[0], g1[1], g1[2]) + w[i2] * _norm2(g2[0], g2[1], g2[2])
            + w[i3] * _norm2(g3[0], g3[1], g3[2]) + w[i4] * _norm2(g4[0], g4[1], g4[2]))


@numba.njit(cache=True, nogil=True, inline="always")
def _max_weighted_step(w, i1, i2, i3, i4, g1, g2, g3, g4):
    """``max_j w_j |g_j|``: the largest move per unit multiplier, for the step limiters."""
    return max(w[i1] * np.sqrt(_norm2(g1[0], g1[1], g1[2])), w[i2] * np.sqrt(_norm2(g2[0], g2[1], g2[2])),
               w[i3] * np.sqrt(_norm2(g3[0], g3[1], g3[2])), w[i4] * np.sqrt(_norm2(g4[0], g4[1], g4[2])))


@numba.njit(cache=True, nogil=True, inline="always")
def _move4(p, w, s, i1, i2, i3, i4, g1, g2, g3, g4):
    """``p_j -= s w_j g_j`` for the four vertices of a constraint, in order (Eq. 3.10)."""
    _axpy(p, i1, -(s * w[i1]), g1[0], g1[1], g1[2])
    _axpy(p, i2, -(s * w[i2]), g2[0], g2[1], g2[2])
    _axpy(p, i3, -(s * w[i3]), g3[0], g3[1], g3[2])
    _axpy(p, i4, -(s * w[i4]), g4[0], g4[1], g4[2])


@numba.njit(cache=True, nogil=True, inline="always")
def _distance_terms(p, w, i, j, rest, k):
    """``(ok, c, d)``: vertex i moves by ``-w_i c d`` and j by ``+w_j c d`` (Eq. 3.11 with Eq. 3.10)."""
    dx = p[i, 0] - p[j, 0]
    dy = p[i, 1] - p[j, 1]
    dz = p[i, 2] - p[j, 2]
    ln = np.sqrt(_norm2(dx, dy, dz))
    ws = w[i] + w[j]
    if ws == 0.0 or ln < 1e-300:
        return False, 0.0, dx, dy, dz
    return True, (ln - rest) * k / (ws * ln), dx, dy, dz


@numba.njit(cache=True, nogil=True, inline="always")
def _bend_terms(p, w, i1, i2, i3, i4, rest, k):
    """``(ok, s, g1, g2, g3, g4)`` of one signed bending projection: vertex j moves by ``-s w_j g_j``.

    ``ok`` is False for a degenerate quad (Eq. 3.10, Eq. 3.13, closed-form gradient of spec §3.3.2).
    """
    ex = p[i2, 0] - p[i1, 0]
    ey = p[i2, 1] - p[i1, 1]
    ez = p[i2, 2] - p[i1, 2]
    ax = p[i3, 0] - p[i1, 0]
    ay = p[i3, 1] - p[i1, 1]
    az = p[i3, 2] - p[i1, 2]
    bx = p[i4, 0] - p[i1, 0]
    by = p[i4, 1] - p[i1, 1]
    bz = p[i4, 2] - p[i1, 2]
    n1x, n1y, n1z = _cross(ax, ay, az, ex, ey, ez)
    n2x, n2y, n2z = _cross(ex, ey, ez, bx, by, bz)
    ee = _norm2(ex, ey, ez)
    n11 = _norm2(n1x, n1y, n1z)
    n22 = _norm2(n2x, n2y, n2z)
    z = (0.0, 0.0, 0.0)
    if ee < 1e-300 or n11 < 1e-300 * ee or n22 < 1e-300 * ee:
        return False, 0.0, z, z, z, z
    le = np.sqrt(ee)
    cx, cy, cz = _cross(n1x, n1y, n1z, n2x, n2y, n2z)
    sin = (ex * cx + ey * cy + ez * cz) / le
    cos = n1x * n2x + n1y * n2y + n1z * n2z
    phi = np.arctan2(sin, cos)
    c = phi - rest
    while c > np.pi:                 # wrap to (-pi, pi]: ERRATUM A.5
        c -= 2 * np.pi
    while c <= -np.pi:
        c += 2 * np.pi
    g3 = (le * n1x / n11, le * n1y / n11, le * n1z / n11)
    g4 = (le * n2x / n22, le * n2y / n22, le * n2z / n22)
    t3 = (ax * ex + ay * ey + az * ez) / ee
    t4 = (bx * ex + by * ey + bz * ez) / ee
    g1 = (-((1 - t3) * g3[0] + (1 - t4) * g4[0]), -((1 - t3) * g3[1] + (1 - t4) * g4[1]),
          -((1 - t3) * g3[2] + (1 - t4) * g4[2]))
    g2 = (-(t3 * g3[0] + t4 * g4[0]), -(t3 * g3[1] + t4 * g4[1]), -(t3 * g3[2] + t4 * g4[2]))
    # ERRATUM A.1: the denominator of Eq. 3.10 sums w_j |grad_{p_j} C|^2 over the constraint's vertices j
    den = _weighted_den(w, i1, i2, i3, i4, g1, g2, g3, g4)
    if den < 1e-300:
        return False, 0.0, z, z, z, z
    s = k * c / den
    # Step limiter [INFERRED]: a free hinge vertex with a near-zero gradient would take a huge step.
    gm = _max_weighted_step(w, i1, i2, i3, i4, g1, g2, g3, g4)
    if abs(s) * gm > _MAX_STEP * le:
        s *= _MAX_STEP * le / (abs(s) * gm)
    return True, s, g1, g2, g3, g4


@numba.njit(cache=True, nogil=True)
def _bend_delta(p, w, q, rest, k, d):
    """Correction (4, 3) of one signed bending projection into ``d``; False if degenerate (Eq. 3.10).

    Kept as a called (not inlined) kernel for Jacobi: accumulating straight from inlined ``_bend_terms`` in
    the Jacobi loop measured ~30 % slower.
    """
    ok, s, g1, g2, g3, g4 = _bend_terms(p, w, q[0], q[1], q[2], q[3], rest, k)
    if ok:
        for a, g in enumerate((g1, g2, g3, g4)):
            f = -(s * w[q[a]])
            d[a, 0] = f * g[0]
            d[a, 1] = f * g[1]
            d[a, 2] = f * g[2]
    return ok


@numba.njit(cache=True, nogil=True)
def _solve_internal_jacobi_numba(p, w, edges, rest_len, k_len, quads, rest_phi, k_bend, iterations, omega):
    V = p.shape[0]
    acc = np.zeros((V, 3))
    cnt = np.zeros(V)
    d = np.empty((4, 3))
    for _ in range(iterations):
        acc[:] = 0.0
        cnt[:] = 0.0
        for c in range(edges.shape[0]):          # every correction from the same positions p
            i, j = edges[c, 0], edges[c, 1]
            ok, s, dx, dy, dz = _distance_terms(p, w, i, j, rest_len[c], k_len[c])
            if ok:
                _axpy(acc, i, -(w[i] * s), dx, dy, dz)
                _axpy(acc, j, w[j] * s, dx, dy, dz)
                if w[i] > 0:
                    cnt[i] += 1.0
                if w[j] > 0:
                    cnt[j] += 1.0
        for c in range(quads.shape[0]):
            if _bend_delta(p, w, quads[c], rest_phi[c], k_bend[c], d):
                for a in range(4):
                    v = quads[c, a]
                    if w[v] > 0:
                        _axpy(acc, v, 1.0, d[a, 0], d[a, 1], d[a, 2])
                        cnt[v] += 1.0
        for v in range(V):                       # averaged, relaxed update (spec §3.10 option c)
            if cnt[v] > 0:
                _axpy(p, v, omega / cnt[v], acc[v, 0], acc[v, 1], acc[v, 2])


@numba.njit(cache=True, nogil=True)
def _solve_internal_numba(p, w, edges, rest_len, k_len, quads, rest_phi, k_bend, iterations):
    for _ in range(iterations):
        for c in range(edges.shape[0]):
            i, j = edges[c, 0], edges[c, 1]
            ok, s, dx, dy, dz = _distance_terms(p, w, i, j, rest_len[c], k_len[c])
            if ok:
                _axpy(p, i, -(w[i] * s), dx, dy, dz)
                _axpy(p, j, w[j] * s, dx, dy, dz)
        for c in range(quads.shape[0]):
            i1, i2, i3, i4 = quads[c, 0], quads[c, 1], quads[c, 2], quads[c, 3]
            ok, s, g1, g2, g3, g4 = _bend_terms(p, w, i1, i2, i3, i4, rest_phi[c], k_bend[c])
            if ok:
                _move4(p, w, s, i1, i2, i3, i4, g1, g2, g3, g4)


def _distance_step_numpy(p, w, i, j, rest, k):
    d = p[i] - p[j]
    ln = np.linalg.norm(d)
    ws = w[i] + w[j]
    if ws == 0.0 or ln < 1e-300:
        return
    n = d / ln
    C = ln - rest
    p[i] -= k * w[i] / ws * C * n            # Eq. 3.11 with Eq. 3.10
    p[j] += k * w[j] / ws * C * n


def _bend_terms_numpy(pts, wq, rest, k):
    """``(s, g)`` of one signed bending projection of the quad ``pts`` (4, 3) with inverse masses ``wq`` (4,):
    vertex j moves by ``-s wq_j g_j``; None if the quad is degenerate (twin of ``_bend_terms``)."""
    e = pts[1] - pts[0]
    N1 = np.cross(pts[2] - pts[0], e)
    N2 = np.cross(e, pts[3] - pts[0])
    ee = e.dot(e)
    if ee < 1e-300 or N1.dot(N1) < 1e-300 * ee or N2.dot(N2) < 1e-300 * ee:
        return None
    phi = np.arctan2(e.dot(np.cross(N1, N2)) / np.sqrt(ee), N1.dot(N2))
    C = (phi - rest + np.pi) % (2 * np.pi) - np.pi       # wrap (ERRATUM A.5)
    if C == -np.pi:
        C = np.pi
    g = np.array(dihedral_gradient(*pts))
    den = np.sum(wq * np.einsum("ij,ij->i", g, g))
    if den < 1e-300:
        return None
    s = k * C / den
    gm = np.max(wq * np.linalg.norm(g, axis=1))
    if abs(s) * gm > _MAX_STEP * np.sqrt(ee):                # same step limiter as the kernel
        s *= _MAX_STEP * np.sqrt(ee) / (abs(s) * gm)
    return s, g


def _bend_step_numpy(p, w, q, rest, k):
    terms = _bend_terms_numpy(p[q], w[q], rest, k)
    if terms is not None:
        s, g = terms
        p[q] -= s * w[q, None] * g                           # Eq. 3.10 (ERRATUM A.1)


def solve_internal_jacobi_numpy(p, w, edges, rest_len, k_len, quads, rest_phi, k_bend, iterations, omega):
    """Numpy twin of the Jacobi kernel: all corrections from the same positions, averaged per vertex."""
    V = p.shape[0]
    for _ in range(iterations):
        acc = np.zeros((V, 3))
        cnt = np.zeros(V)
        i, j = edges[:, 0], edges[:, 1]
        d = p[i] - p[j]
        ln = np.linalg.norm(d, axis=1)
        ws = w[i] + w[j]
        ok = (ws > 0) & (ln >= 1e-300)
        s = np.zeros(len(edges))
        s[ok] = (ln[ok] - rest_len[ok]) * k_len[ok] / (ws[ok] * ln[ok])
        for c in np.flatnonzero(ok):                # constraint order, as the kernel sums
            acc[i[c]] -= w[i[c]] * s[c] * d[c]
            acc[j[c]] += w[j[c]] * s[c] * d[c]
            cnt[i[c]] += w[i[c]] > 0
            cnt[j[c]] += w[j[c]] > 0
        for c in range(len(quads)):
            q = quads[c]
            terms = _bend_terms_numpy(p[q], w[q], rest_phi[c], k_bend[c])
            if terms is None:
                continue
            s, g = terms
            dq = (p[q] - s * w[q, None] * g) - p[q]       # the move of one Gauss-Seidel step from p
            for a in range(4):
                if w[q[a]] > 0:
                    acc[q[a]] += dq[a]
                    cnt[q[a]] += 1
        m = cnt > 0
        p[m] += (omega / cnt[m])[:, None] * acc[m]


def solve_internal_numpy(p, w, edges, rest_len, k_len, quads, rest_phi, k_bend, iterations):
    """Numpy twin of the internal-constraint Gauss-Seidel kernel (same order, same result)."""
    for _ in range(iterations):
        for c in range(edges.shape[0]):
            _distance_step_numpy(p, w, edges[c, 0], edges[c, 1], rest_len[c], k_len[c])
        for c in range(quads.shape[0]):
            _bend_step_numpy(p, w, quads[c], rest_phi[c], k_bend[c])


def solve_internal(p: np.ndarray, w: np.ndarray, edges: np.ndarray, rest_len: np.ndarray,
                   quads: np.ndarray, rest_phi: np.ndarray, *, k_stretch: float | np.ndarray = 0.99,
                   k_bend: float | np.ndarray = 0.99, iterations: int = 50, backend: str = "numba",
                   method: str = "gauss-seidel", omega: float = 1.0) -> np.ndarray:
    """Project distance and signed bending constraints in place (Alg. 1 lines 5–9; spec §3.10).

    Parameters
    ----------
    p : (V, 3) float64 ndarray
        Predicted positions, updated in place.
    w : (V,) float64 ndarray
        Inverse masses (0 = attached vertex, never moved).
    edges : (E, 2) int64 ndarray
    rest_len : (E,) float64 ndarray
        Rest lengths d (Eq. 3.11).
    quads : (B, 4) int64 ndarray
        Bending quadruples from :func:`bend_quads`.
    rest_phi : (B,) float64 ndarray
        Signed rest bend angles, radians.
    k_stretch, k_bend : float or per-constraint ndarray
        Stiffness in [0, 1] (App. C.1 defaults 0.99), arrays for per-object overrides.
    iterations : int
        Solver iterations (App. C.1 example 50).
    backend : {"numba", "numpy"}
    method : {"gauss-seidel", "jacobi"}
        Gauss-Seidel (the thesis's CPU path: each projection sees the previous ones) or Jacobi (its GPU
        path: every correction computed from the same positions, then averaged per vertex over the
        constraints that moved it and relaxed by ``omega``; independent of the constraint order).
    omega : float
        Jacobi over-relaxation in (0, 2) (ignored by Gauss-Seidel).

    Returns
    -------
    (V, 3) float64 ndarray
        ``p`` itself.
    """
    if not (isinstance(p, np.ndarray) and p.dtype == np.float64 and p.ndim == 2 and p.shape[1] == 3
            and p.flags.c_contiguous):
        raise ValueError("p must be a C-contiguous (V, 3) float64 ndarray (it is updated in place)")
    check_array("p", p, shape=(None, 3), max_abs=MAX_COORD)     # finite, inside the coordinate bound
    V = p.shape[0]
    w = check_array("w", w, shape=(V,))
    if np.any(w < 0):
        raise ValueError("w (inverse masses) must be >= 0")
    edges = check_array("edges", edges, shape=(None, 2), dtype=np.int64)
    quads = check_array("quads", quads, shape=(None, 4), dtype=np.int64)
    rest_len = check_array("rest_len", rest_len, shape=(edges.shape[0],), max_abs=4 * MAX_COORD)
    # the kernels wrap phi - rest into (-pi, pi] by steps of 2 pi: a huge rest angle would never wrap (hang)
    rest_phi = check_array("rest_phi", rest_phi, shape=(quads.shape[0],), max_abs=_MAX_REST_PHI)
    for name, arr in (("edges", edges), ("quads", quads)):
        if arr.size and (arr.min() < 0 or arr.max() >= V):
            raise ValueError(f"{name} must index vertices in [0, {V - 1}]")
    if rest_len.size and rest_len.min() < 0:
        raise ValueError(f"rest_len must be >= 0, got {rest_len.min()!r}")
    k_len = _stiffness("k_stretch", k_stretch, edges.shape[0])
    k_b = _stiffness("k_bend", k_bend, quads.shape[0])
    iterations = check_int("iterations", iterations, 0, 1_000_000)
    method = check_choice("method", method, ("gauss-seidel", "jacobi"))
    omega = check_range("omega", omega, 0.0, 2.0, low_open=True, high_open=True)
    if backend not in ("numba", "numpy"):
        raise ValueError(f"backend must be one of ['numba', 'numpy'], got {backend!r}")
    if method == "jacobi":
        kernel = _solve_internal_jacobi_numba if backend == "numba" else solve_internal_jacobi_numpy
        kernel(p, w, edges, rest_len, k_len, quads, rest_phi, k_b, iterations, omega)
        return p
    if backend == "numba":
        _solve_internal_numba(p, w, edges, rest_len, k_len, quads, rest_phi, k_b, iterations)
    elif backend == "numpy":
        solve_internal_numpy(p, w, edges, rest_len, k_len, quads, rest_phi, k_b, iterations)
    else:
        raise ValueError(f"backend must be one of ['numba', 'numpy'], got {backend!r}")
    return p


def _stiffness(name, k, n):
    if np.ndim(k) == 0:
        return np.full(n, check_range(name, k, 0.0, 1.0))
    k = check_array(name, k, shape=(n,))
    if np.any(k < 0) or np.any(k > 1):
        raise ValueError(f"{name} must be in [0, 1], got values in [{k.min()}, {k.max()}]")
    return k

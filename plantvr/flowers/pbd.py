"""Position-based dynamics: distance and signed dihedral bending constraints (spec 002 §3.2–§3.3.2; C5–C7).

Gauss-Seidel projection (Eq. 3.10, ERRATUM A.1) of Eq. 3.11 distance constraints and the thesis's signed
dihedral bending constraint (Eq. 3.13, App. A behaviour via the closed-form signed-angle gradient of
spec §3.3.2), or Jacobi projection with per-vertex averaging (the thesis's GPU path, §3.10, V26). Each
numba kernel has a numpy twin with the same constraint order.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import check_array, check_choice, check_int, check_range

__all__ = [
    "bend_quads",
    "dihedral_gradient",
    "edge_lengths",
    "mesh_edges",
    "signed_dihedrals",
    "solve_internal",
    "solve_internal_jacobi_numpy",
    "solve_internal_numpy",
]


def mesh_edges(faces: np.ndarray) -> np.ndarray:
    """Unique undirected edges (E, 2) int64 of a triangle mesh, sorted, ``i < j``."""
    faces = check_array("faces", faces, shape=(None, 3), dtype=np.int64)
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0)


def bend_quads(faces: np.ndarray) -> np.ndarray:
    """Bending quadruples (B, 4) int64 ``(p1, p2, p3, p4)`` for every interior manifold edge.

    Triangle (p1, p2, p3) holds the directed edge p1->p2 and triangle (p1, p4, p2) the edge p2->p1
    (the ordering of Eq. 3.12), so the orientation of the mesh fixes the sign convention.
    """
    faces = check_array("faces", faces, shape=(None, 3), dtype=np.int64)
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
    return np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)


def signed_dihedrals(x: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Signed bend angle phi of every quad, (B,) float64 radians in (-pi, pi] (Eq. 3.13, flat = 0).

    References
    ----------
    .. [1] Owens 2016, Eq. 3.13 and App. A; ERRATUM A.5 (signed range, wrapped differences).
    """
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


#: Largest bending correction of one vertex per projection, as a fraction of the hinge edge length.
_MAX_STEP = 0.25


@numba.njit(cache=True, nogil=True)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(cache=True, nogil=True)
def _project_distance(p, w, i, j, rest, k):
    dx = p[i, 0] - p[j, 0]
    dy = p[i, 1] - p[j, 1]
    dz = p[i, 2] - p[j, 2]
    ln = np.sqrt(dx * dx + dy * dy + dz * dz)
    ws = w[i] + w[j]
    if ws == 0.0 or ln < 1e-300:
        return
    c = (ln - rest) * k / (ws * ln)
    p[i, 0] -= w[i] * c * dx
    p[i, 1] -= w[i] * c * dy
    p[i, 2] -= w[i] * c * dz
    p[j, 0] += w[j] * c * dx
    p[j, 1] += w[j] * c * dy
    p[j, 2] += w[j] * c * dz


@numba.njit(cache=True, nogil=True)
def _bend_delta(p, w, q, rest, k, d):
    """Correction (4, 3) of one signed bending projection into ``d``; False if degenerate (Eq. 3.10)."""
    i1, i2, i3, i4 = q[0], q[1], q[2], q[3]
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
    ee = ex * ex + ey * ey + ez * ez
    n11 = n1x * n1x + n1y * n1y + n1z * n1z
    n22 = n2x * n2x + n2y * n2y + n2z * n2z
    if ee < 1e-300 or n11 < 1e-300 * ee or n22 < 1e-300 * ee:
        return False
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
    g3x, g3y, g3z = le * n1x / n11, le * n1y / n11, le * n1z / n11
    g4x, g4y, g4z = le * n2x / n22, le * n2y / n22, le * n2z / n22
    t3 = (ax * ex + ay * ey + az * ez) / ee
    t4 = (bx * ex + by * ey + bz * ez) / ee
    g1x = -((1 - t3) * g3x + (1 - t4) * g4x)
    g1y = -((1 - t3) * g3y + (1 - t4) * g4y)
    g1z = -((1 - t3) * g3z + (1 - t4) * g4z)
    g2x = -(t3 * g3x + t4 * g4x)
    g2y = -(t3 * g3y + t4 * g4y)
    g2z = -(t3 * g3z + t4 * g4z)
    # ERRATUM A.1: the denominator of Eq. 3.10 sums w_j |grad_{p_j} C|^2 over the constraint's vertices j
    den = (w[i1] * (g1x * g1x + g1y * g1y + g1z * g1z) + w[i2] * (g2x * g2x + g2y * g2y + g2z * g2z)
           + w[i3] * (g3x * g3x + g3y * g3y + g3z * g3z) + w[i4] * (g4x * g4x + g4y * g4y + g4z * g4z))
    if den < 1e-300:
        return False
    s = k * c / den
    # Step limiter [INFERRED]: a free hinge vertex with a near-zero gradient would take a huge step.
    gm = max(w[i1] * np.sqrt(g1x * g1x + g1y * g1y + g1z * g1z), w[i2] * np.sqrt(g2x * g2x + g2y * g2y + g2z * g2z),
             w[i3] * np.sqrt(g3x * g3x + g3y * g3y + g3z * g3z), w[i4] * np.sqrt(g4x * g4x + g4y * g4y + g4z * g4z))
    if abs(s) * gm > _MAX_STEP * le:
        s *= _MAX_STEP * le / (abs(s) * gm)
    d[0, 0] = -(s * w[i1] * g1x)
    d[0, 1] = -(s * w[i1] * g1y)
    d[0, 2] = -(s * w[i1] * g1z)
    d[1, 0] = -(s * w[i2] * g2x)
    d[1, 1] = -(s * w[i2] * g2y)
    d[1, 2] = -(s * w[i2] * g2z)
    d[2, 0] = -(s * w[i3] * g3x)
    d[2, 1] = -(s * w[i3] * g3y)
    d[2, 2] = -(s * w[i3] * g3z)
    d[3, 0] = -(s * w[i4] * g4x)
    d[3, 1] = -(s * w[i4] * g4y)
    d[3, 2] = -(s * w[i4] * g4z)
    return True


@numba.njit(cache=True, nogil=True)
def _project_bend(p, w, q, rest, k):
    """Gauss-Seidel bending projection in place (scalar updates; the same formulas as _bend_delta)."""
    i1, i2, i3, i4 = q[0], q[1], q[2], q[3]
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
    ee = ex * ex + ey * ey + ez * ez
    n11 = n1x * n1x + n1y * n1y + n1z * n1z
    n22 = n2x * n2x + n2y * n2y + n2z * n2z
    if ee < 1e-300 or n11 < 1e-300 * ee or n22 < 1e-300 * ee:
        return
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
    g3x, g3y, g3z = le * n1x / n11, le * n1y / n11, le * n1z / n11
    g4x, g4y, g4z = le * n2x / n22, le * n2y / n22, le * n2z / n22
    t3 = (ax * ex + ay * ey + az * ez) / ee
    t4 = (bx * ex + by * ey + bz * ez) / ee
    g1x = -((1 - t3) * g3x + (1 - t4) * g4x)
    g1y = -((1 - t3) * g3y + (1 - t4) * g4y)
    g1z = -((1 - t3) * g3z + (1 - t4) * g4z)
    g2x = -(t3 * g3x + t4 * g4x)
    g2y = -(t3 * g3y + t4 * g4y)
    g2z = -(t3 * g3z + t4 * g4z)
    # ERRATUM A.1: the denominator of Eq. 3.10 sums w_j |grad_{p_j} C|^2 over the constraint's vertices j
    den = (w[i1] * (g1x * g1x + g1y * g1y + g1z * g1z) + w[i2] * (g2x * g2x + g2y * g2y + g2z * g2z)
           + w[i3] * (g3x * g3x + g3y * g3y + g3z * g3z) + w[i4] * (g4x * g4x + g4y * g4y + g4z * g4z))
    if den < 1e-300:
        return
    s = k * c / den
    # Step limiter [INFERRED]: a free hinge vertex with a near-zero gradient would take a huge step.
    gm = max(w[i1] * np.sqrt(g1x * g1x + g1y * g1y + g1z * g1z), w[i2] * np.sqrt(g2x * g2x + g2y * g2y + g2z * g2z),
             w[i3] * np.sqrt(g3x * g3x + g3y * g3y + g3z * g3z), w[i4] * np.sqrt(g4x * g4x + g4y * g4y + g4z * g4z))
    if abs(s) * gm > _MAX_STEP * le:
        s *= _MAX_STEP * le / (abs(s) * gm)
    p[i1, 0] -= s * w[i1] * g1x
    p[i1, 1] -= s * w[i1] * g1y
    p[i1, 2] -= s * w[i1] * g1z
    p[i2, 0] -= s * w[i2] * g2x
    p[i2, 1] -= s * w[i2] * g2y
    p[i2, 2] -= s * w[i2] * g2z
    p[i3, 0] -= s * w[i3] * g3x
    p[i3, 1] -= s * w[i3] * g3y
    p[i3, 2] -= s * w[i3] * g3z
    p[i4, 0] -= s * w[i4] * g4x
    p[i4, 1] -= s * w[i4] * g4y
    p[i4, 2] -= s * w[i4] * g4z


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
            dx = p[i, 0] - p[j, 0]
            dy = p[i, 1] - p[j, 1]
            dz = p[i, 2] - p[j, 2]
            ln = np.sqrt(dx * dx + dy * dy + dz * dz)
            ws = w[i] + w[j]
            if ws == 0.0 or ln < 1e-300:
                continue
            s = (ln - rest_len[c]) * k_len[c] / (ws * ln)
            acc[i, 0] -= w[i] * s * dx
            acc[i, 1] -= w[i] * s * dy
            acc[i, 2] -= w[i] * s * dz
            acc[j, 0] += w[j] * s * dx
            acc[j, 1] += w[j] * s * dy
            acc[j, 2] += w[j] * s * dz
            if w[i] > 0:
                cnt[i] += 1.0
            if w[j] > 0:
                cnt[j] += 1.0
        for c in range(quads.shape[0]):
            if _bend_delta(p, w, quads[c], rest_phi[c], k_bend[c], d):
                for a in range(4):
                    v = quads[c, a]
                    if w[v] > 0:
                        acc[v, 0] += d[a, 0]
                        acc[v, 1] += d[a, 1]
                        acc[v, 2] += d[a, 2]
                        cnt[v] += 1.0
        for v in range(V):                       # averaged, relaxed update (spec §3.10 option c)
            if cnt[v] > 0:
                f = omega / cnt[v]
                p[v, 0] += f * acc[v, 0]
                p[v, 1] += f * acc[v, 1]
                p[v, 2] += f * acc[v, 2]


@numba.njit(cache=True, nogil=True)
def _solve_internal_numba(p, w, edges, rest_len, k_len, quads, rest_phi, k_bend, iterations):
    for _ in range(iterations):
        for c in range(edges.shape[0]):
            _project_distance(p, w, edges[c, 0], edges[c, 1], rest_len[c], k_len[c])
        for c in range(quads.shape[0]):
            _project_bend(p, w, quads[c], rest_phi[c], k_bend[c])


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


def _bend_step_numpy(p, w, q, rest, k):
    pts = p[q]
    e = pts[1] - pts[0]
    N1 = np.cross(pts[2] - pts[0], e)
    N2 = np.cross(e, pts[3] - pts[0])
    ee = e.dot(e)
    if ee < 1e-300 or N1.dot(N1) < 1e-300 * ee or N2.dot(N2) < 1e-300 * ee:
        return
    phi = np.arctan2(e.dot(np.cross(N1, N2)) / np.sqrt(ee), N1.dot(N2))
    C = (phi - rest + np.pi) % (2 * np.pi) - np.pi       # wrap (ERRATUM A.5)
    if C == -np.pi:
        C = np.pi
    g = np.array(dihedral_gradient(*pts))
    den = np.sum(w[q] * np.einsum("ij,ij->i", g, g))
    if den < 1e-300:
        return
    s = k * C / den
    gm = np.max(w[q] * np.linalg.norm(g, axis=1))
    if abs(s) * gm > _MAX_STEP * np.sqrt(ee):                # same step limiter as the kernel
        s *= _MAX_STEP * np.sqrt(ee) / (abs(s) * gm)
    p[q] -= s * w[q, None] * g                           # Eq. 3.10 (ERRATUM A.1)


def _bend_delta_numpy(p, w, q, rest, k):
    """(4, 3) correction of one bending projection from positions ``p`` (None if degenerate)."""
    tmp = p[q].copy()
    before = tmp.copy()
    _bend_step_numpy(tmp, w[q], np.arange(4), rest, k)
    return tmp - before


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
            pts = p[q]
            e = pts[1] - pts[0]
            N1 = np.cross(pts[2] - pts[0], e)
            N2 = np.cross(e, pts[3] - pts[0])
            ee = e.dot(e)
            if ee < 1e-300 or N1.dot(N1) < 1e-300 * ee or N2.dot(N2) < 1e-300 * ee:
                continue
            g = np.array(dihedral_gradient(*pts))
            if np.sum(w[q] * np.einsum("ij,ij->i", g, g)) < 1e-300:
                continue
            dq = _bend_delta_numpy(p, w, q, rest_phi[c], k_bend[c])
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
    V = p.shape[0]
    w = check_array("w", w, shape=(V,))
    if np.any(w < 0):
        raise ValueError("w (inverse masses) must be >= 0")
    edges = check_array("edges", edges, shape=(None, 2), dtype=np.int64)
    quads = check_array("quads", quads, shape=(None, 4), dtype=np.int64)
    rest_len = check_array("rest_len", rest_len, shape=(edges.shape[0],))
    rest_phi = check_array("rest_phi", rest_phi, shape=(quads.shape[0],))
    for name, arr in (("edges", edges), ("quads", quads)):
        if arr.size and (arr.min() < 0 or arr.max() >= V):
            raise ValueError(f"{name} must index vertices in [0, {V - 1}]")
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

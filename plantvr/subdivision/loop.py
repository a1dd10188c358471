"""Loop subdivision of triangle meshes with boundaries (spec 001_subdivision §3.2, ERRATA A1–A3).

Vectorised numpy: the edge table is sorted once; every further level derives the children's edge table
combinatorially (each edge splits in two, each face adds three interior edges), so levels after the
first need no sort at all.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import MAX_COUNT, check_choice, check_index, check_int

from ._checks import check_mesh

__all__ = ["boundary_loops", "cap_boundaries", "edge_table", "loop_weight", "subdivide_loop"]


def loop_weight(n: np.ndarray, *, weight_rule: str = "loop_cos") -> np.ndarray:
    """Loop's even-vertex neighbour weight k(n) (spec §3.2, Eq. E17).

    Parameters
    ----------
    n : (V,) int or float ndarray
        Vertex valences (number of neighbours), ``>= 3``.
    weight_rule : {"loop_cos", "as_printed_sin"}
        ``"loop_cos"`` (default) is Loop's rule, ``k = (5/8 - (3/8 + cos(2π/n)/4)^2) / n``
        (ERRATUM A1: the report prints sin); ``"as_printed_sin"`` reproduces the printed formula.

    Returns
    -------
    (V,) float64 ndarray
        Weights; 3/16 at n = 3 in both rules.

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.4.2; spec 001 ERRATUM A1.

    Examples
    --------
    >>> loop_weight(np.array([3, 6])).tolist()
    [0.1875, 0.0625]
    """
    check_choice("weight_rule", weight_rule, ("loop_cos", "as_printed_sin"))
    n = check_index("n", n, shape=np.shape(n) if not isinstance(n, str) else (None,), low=0, high=MAX_COUNT
                    ).astype(np.float64)
    trig = np.cos if weight_rule == "loop_cos" else np.sin  # ERRATUM A1
    with np.errstate(divide="ignore", invalid="ignore"):
        k = (0.625 - (0.375 + 0.25 * trig(2.0 * np.pi / n)) ** 2) / n
    return np.where(n == 3, 3.0 / 16.0, k)


def _edge_table_numpy(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Readable twin of :func:`_edge_table_numba` (sort the undirected edge keys)."""
    he = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    lo = np.minimum(he[:, 0], he[:, 1]).astype(np.int64)
    hi = np.maximum(he[:, 0], he[:, 1]).astype(np.int64)
    key = lo * np.int64(n_vertices) + hi
    uniq, inv = np.unique(key, return_inverse=True)
    edges = np.stack([uniq // n_vertices, uniq % n_vertices], axis=1)
    return edges, inv.reshape(-1, 3).astype(np.int64)


@numba.njit(cache=True, nogil=True)
def _edge_table_numba(faces, n_vertices):  # pragma: no cover - compiled; twin-tested against numpy
    nf = faces.shape[0]
    nh = 3 * nf
    lo = np.empty(nh, np.int64)
    hi = np.empty(nh, np.int64)
    for f in range(nf):
        for c in range(3):
            a = faces[f, c]
            b = faces[f, (c + 1) % 3]
            h = 3 * f + c
            if a < b:
                lo[h] = a
                hi[h] = b
            else:
                lo[h] = b
                hi[h] = a
    ptr = np.zeros(n_vertices + 1, np.int64)
    for h in range(nh):
        ptr[lo[h] + 1] += 1
    for v in range(n_vertices):
        ptr[v + 1] += ptr[v]
    fill = ptr[:-1].copy()
    bucket = np.empty(nh, np.int64)
    for h in range(nh):
        bucket[fill[lo[h]]] = h
        fill[lo[h]] += 1
    edge_of = np.empty(nh, np.int64)
    e_lo = np.empty(nh, np.int64)
    e_hi = np.empty(nh, np.int64)
    ne = 0
    for v in range(n_vertices):
        s, t = ptr[v], ptr[v + 1]
        # insertion sort of the (few) half-edges of this bucket by hi, so edge ids follow (lo, hi) order
        for i in range(s + 1, t):
            x = bucket[i]
            j = i - 1
            while j >= s and hi[bucket[j]] > hi[x]:
                bucket[j + 1] = bucket[j]
                j -= 1
            bucket[j + 1] = x
        prev = -1
        for i in range(s, t):
            h = bucket[i]
            if hi[h] != prev:
                e_lo[ne] = v
                e_hi[ne] = hi[h]
                prev = hi[h]
                ne += 1
            edge_of[h] = ne - 1
    edges = np.empty((ne, 2), np.int64)
    edges[:, 0] = e_lo[:ne]
    edges[:, 1] = e_hi[:ne]
    return edges, edge_of.reshape(nf, 3)


def edge_table(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges and the face→edge map (numba kernel, O(F); numpy twin sorts).

    Parameters
    ----------
    faces : (F, 3) int64 ndarray
        Triangles.
    n_vertices : int
        Number of vertices.

    Returns
    -------
    edges : (E, 2) int64 ndarray
        Unique edges, ``edges[:, 0] < edges[:, 1]``, sorted lexicographically.
    face_edges : (F, 3) int64 ndarray
        Edge ids of the face edges (0,1), (1,2), (2,0).
    """
    n_vertices = check_int("n_vertices", n_vertices, 0, MAX_COUNT)
    faces = check_index("faces", faces, shape=(None, 3), low=0, high=max(n_vertices - 1, 0))
    if faces.size and not n_vertices:
        raise ValueError("faces index vertices, but n_vertices is 0")
    return _edge_table_numba(faces, n_vertices)


def _wsum(idx: np.ndarray, vals: np.ndarray, n: int) -> np.ndarray:
    out = np.empty((n, vals.shape[1]))
    for c in range(vals.shape[1]):
        out[:, c] = np.bincount(idx, weights=vals[:, c], minlength=n)
    return out


def _step(V, F, E, FE, weight_rule, boundary_rule, topology=True):
    nV, nE, nF = len(V), len(E), len(F)
    e_flat = FE.ravel()
    cnt = np.bincount(e_flat, minlength=nE)
    if cnt.max(initial=0) > 2:
        bad = int(np.flatnonzero(cnt > 2)[0])
        raise ValueError(f"faces: edge {E[bad].tolist()} is shared by {cnt[bad]} faces; Loop subdivision needs a "
                         f"manifold mesh (each edge in 1 or 2 faces)")
    bnd = cnt == 1
    opp = F[:, [2, 0, 1]].ravel()
    far = _wsum(e_flat, V[opp], nE)
    v0, v1 = V[E[:, 0]], V[E[:, 1]]
    odd = 0.375 * (v0 + v1) + 0.125 * far          # Eq. E15
    odd[bnd] = 0.5 * (v0[bnd] + v1[bnd])          # Eq. E16
    valence = np.bincount(E.ravel(), minlength=nV)
    nb = _wsum(E[:, 0], v1, nV) + _wsum(E[:, 1], v0, nV)
    k = loop_weight(valence, weight_rule=weight_rule)
    even = (1.0 - valence * k)[:, None] * V + k[:, None] * nb   # Eq. E18, ERRATUM A2 (n neighbours)
    if bnd.any():
        Eb = E[bnd]
        bv = np.zeros(nV, bool)
        bv[Eb.ravel()] = True
        if boundary_rule == "fixed":            # ERRATUM A3 [INFERRED]: base and tips stay fixed
            even[bv] = V[bv]
        else:                                   # standard Loop boundary mask 3/4, 1/8, 1/8
            bsum = _wsum(Eb[:, 0], V[Eb[:, 1]], nV) + _wsum(Eb[:, 1], V[Eb[:, 0]], nV)
            even[bv] = 0.75 * V[bv] + 0.125 * bsum[bv]
    isolated = valence == 0
    if isolated.any():
        even[isolated] = V[isolated]
    # topology of the next level
    a, b, c = F[:, 0], F[:, 1], F[:, 2]
    eab, ebc, eca = FE[:, 0], FE[:, 1], FE[:, 2]
    oab, obc, oca = eab + nV, ebc + nV, eca + nV
    F2 = np.stack([a, oab, oca, oab, b, obc, oca, obc, c, oab, obc, oca], axis=1).reshape(-1, 3)
    if not topology:
        return np.vstack([even, odd]), F2, None, None
    E2 = np.empty((2 * nE + 3 * nF, 2), np.int64)
    eid = np.arange(nE)
    E2[0:2 * nE:2, 0] = E[:, 0]
    E2[0:2 * nE:2, 1] = nV + eid
    E2[1:2 * nE:2, 0] = nV + eid
    E2[1:2 * nE:2, 1] = E[:, 1]
    fin = 2 * nE + 3 * np.arange(nF)
    E2[2 * nE::3] = np.stack([oab, oca], 1)
    E2[2 * nE + 1::3] = np.stack([oab, obc], 1)
    E2[2 * nE + 2::3] = np.stack([obc, oca], 1)

    def half(e, v):  # half of old edge e that touches old vertex v
        return 2 * e + (E[e, 1] == v)

    FE2 = np.stack([
        half(eab, a), fin + 0, half(eca, a),
        half(eab, b), half(ebc, b), fin + 1,
        fin + 2, half(ebc, c), half(eca, c),
        fin + 1, fin + 2, fin + 0,
    ], axis=1).reshape(-1, 3)
    return np.vstack([even, odd]), F2, E2, FE2


def subdivide_loop(vertices, faces, levels: int = 1, *, weight_rule: str = "loop_cos",
                   boundary_rule: str = "fixed") -> tuple[np.ndarray, np.ndarray]:
    """Loop subdivision, ``levels`` times (spec §3.2).

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
        Control points.
    faces : (F, 3) int ndarray
        Triangles; every edge in one (boundary) or two faces.
    levels : int
        Number of subdivision levels, 0–8.
    weight_rule : {"loop_cos", "as_printed_sin"}
        See :func:`loop_weight` (ERRATUM A1).
    boundary_rule : {"fixed", "loop_cubic"}
        Even boundary vertices stay fixed (default; the report's base and tips "must remain fixed",
        ERRATUM A3) or follow the standard 3/4–1/8 mask (as trimesh and VTK do).

    Returns
    -------
    vertices : (V', 3) float64 ndarray
        The old (even) vertices first, in their original order, then one odd vertex per edge.
    faces : (4**levels * F, 3) int64 ndarray
        Child ``4 f + i`` of face ``f`` is (a, e_ab, e_ca), (e_ab, b, e_bc), (e_ca, e_bc, c), (e_ab, e_bc, e_ca);
        winding is preserved.

    Raises
    ------
    ValueError
        If an argument is malformed or an edge has more than two faces.

    References
    ----------
    .. [1] Loop, C. Smooth subdivision surfaces based on triangles (1987); Pieterse, Yggdrasil report §4.4.2;
       spec 001 ERRATA A1, A2, A3.
    """
    V, F = check_mesh(vertices, faces)
    levels = check_int("levels", levels, 0, 8)
    check_choice("weight_rule", weight_rule, ("loop_cos", "as_printed_sin"))
    check_choice("boundary_rule", boundary_rule, ("fixed", "loop_cubic"))
    if len(F) * 4 ** levels > MAX_COUNT:
        raise ValueError(f"levels: {levels} levels of {len(F)} faces give {len(F) * 4 ** levels} faces, more than "
                         f"the {MAX_COUNT} allowed")
    if levels == 0 or len(F) == 0:
        return V.copy(), F.copy()
    E, FE = edge_table(F, len(V))
    for lv in range(levels):
        V, F, E, FE = _step(V, F, E, FE, weight_rule, boundary_rule, topology=lv < levels - 1)
    return V, F


def boundary_loops(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Directed boundary edges and the loop (connected component) each belongs to.

    Returns
    -------
    bedges : (B, 2) int64 ndarray
        Boundary edges in face orientation.
    label : (B,) int64 ndarray
        Loop id of each boundary edge, 0 ... n_loops - 1.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n_vertices = check_int("n_vertices", n_vertices, 0, MAX_COUNT)
    faces = check_index("faces", faces, shape=(None, 3), low=0, high=max(n_vertices - 1, 0))
    he = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    key = np.minimum(he[:, 0], he[:, 1]) * np.int64(n_vertices) + np.maximum(he[:, 0], he[:, 1])
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    bedges = he[cnt[inv.ravel()] == 1]
    if len(bedges) == 0:
        return bedges, np.zeros(0, np.int64)
    vs, vloc = np.unique(bedges.ravel(), return_inverse=True)
    vloc = vloc.reshape(-1, 2)
    m = coo_matrix((np.ones(len(vloc)), (vloc[:, 0], vloc[:, 1])), shape=(len(vs), len(vs)))
    _, lab = connected_components(m, directed=False)
    return bedges, lab[vloc[:, 0]].astype(np.int64)


def cap_boundaries(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Close every boundary loop with a fan around its centroid (spec V11 "fan-capping").

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int ndarray
        A manifold mesh with open boundary loops.

    Returns
    -------
    vertices : (V + L, 3) float64 ndarray
        One centroid vertex per boundary loop appended.
    faces : (F + B, 3) int64 ndarray
        One cap triangle per boundary edge appended, wound consistently with the mesh.
    """
    V, F = check_mesh(vertices, faces)
    be, lab = boundary_loops(F, len(V))
    if len(be) == 0:
        return V.copy(), F.copy()
    nl = int(lab.max()) + 1
    cnt = np.bincount(lab, minlength=nl)[:, None]
    cen = _wsum(lab, V[be[:, 0]], nl) / cnt
    caps = np.stack([be[:, 1], be[:, 0], len(V) + lab], axis=1)
    return np.vstack([V, cen]), np.vstack([F, caps])

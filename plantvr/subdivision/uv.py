"""Per-corner texture coordinates, their linear subdivision and an OBJ reader (spec 001_subdivision §2.6, §2.7, §3.3).

The OBJ writer is :func:`plantvr.io.obj.write_obj`.

UVs live on face corners, ``(F, 3, 2)`` arrays, so seams cost nothing: branches get the report's cylindrical
map (U from the loop index, V repeating every two segments), every other face (joints, caps) gets UVs by
propagation across its longest parameterised edge, and Loop subdivision carries them linearly (midpoints).
"""
from __future__ import annotations

import os

import numpy as np

from plantvr._barycentric import barycentric_numpy
from plantvr._validation import MAX_COORD, MAX_COUNT, check_array, check_choice, check_int

from ._checks import check_mesh
from .loop import edge_table

__all__ = [
    "branch_uvs",
    "control_uvs",
    "propagate_uvs",
    "read_obj",
    "subdivide_uvs",
    "vertex_normals",
]


def branch_uvs(cm) -> tuple[np.ndarray, np.ndarray]:
    """Cylindrical per-corner UVs of the tube faces of a control mesh (spec §2.6, C10).

    Strip ``i`` of a branch, column ``j`` of ``S``: ``u`` runs ``j/S → (j+1)/S`` (the last column ends at 1.0,
    a seam), ``v`` runs ``0.5 (i mod 2) → +0.5``, so two segments map to one tile height.

    Parameters
    ----------
    cm : ControlMesh
        From :func:`~plantvr.subdivision.build_control_mesh`; its first ``2 S ΣN`` faces are the tubes.

    Returns
    -------
    uv : (F, 3, 2) float64 ndarray
        Corner UVs; NaN on faces that are not tube faces (joints, caps).
    known : (F,) bool ndarray
        True on tube faces.

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.3.2, Fig. 4.21: "The U component is calculated based on a vertex' loop
       index. The value of V is interpolated along the length of the branch, repeating with every 2 segments."
    """
    S = cm.first_loop.shape[1]
    N = cm.n_segments
    nseg = int(N.sum())
    i = np.arange(nseg) - np.repeat(np.cumsum(N) - N, N)                # strip index within its branch
    v_lo = np.repeat(0.5 * (i % 2), S)                                   # (nseg*S,)
    j = np.tile(np.arange(S), nseg)
    u0, u1 = j / S, (j + 1) / S                                          # last column ends at 1.0 (seam)
    v_hi = v_lo + 0.5
    abc = np.stack([np.c_[u0, v_lo], np.c_[u1, v_lo], np.c_[u0, v_hi]], axis=1)      # face ABC
    bdc = np.stack([np.c_[u1, v_lo], np.c_[u1, v_hi], np.c_[u0, v_hi]], axis=1)      # face BDC
    tube = np.stack([abc, bdc], axis=1).reshape(-1, 3, 2)
    uv = np.full((len(cm.faces), 3, 2), np.nan)
    uv[:len(tube)] = tube
    known = np.zeros(len(cm.faces), bool)
    known[:len(tube)] = True
    return uv, known


def propagate_uvs(vertices, faces, uv, known, *, wrap: str = "triangle") -> np.ndarray:
    """Give every face without UVs coordinates from its parameterised neighbours (spec §2.6, C11).

    In waves: each face without UVs that touches a parameterised face takes the neighbour across its longest
    such edge, copies that neighbour's corner UVs for the two shared vertices, unfolds its third vertex about
    the edge into the neighbour's plane and maps it through the neighbour's affine 3D → UV map ("the texture
    coordinates are interpolated across the vertices of the un-parameterized triangle").

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int ndarray
        Manifold triangles.
    uv : (F, 3, 2) float64 ndarray
        Corner UVs; rows of faces with ``known`` False are ignored.
    known : (F,) bool ndarray
        Faces whose UVs are given.
    wrap : {"triangle", "coordinate", "none"}
        ``"triangle"`` (default) shifts a new face's three UVs by one integer vector so their centroid lies in
        [0, 1)²; ``"coordinate"`` wraps each coordinate on its own as the report prints it (ERRATUM A8: "less
        than 0", not "less than 1"), which can tear a face across the tile; ``"none"`` leaves them.

    Returns
    -------
    (F, 3, 2) float64 ndarray
        UVs on every face reachable from a known one; faces in a component without any known face get a
        planar projection onto their own best-fit plane [INFERRED].

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.3.3, Fig. 4.22; spec 001 ERRATUM A8.
    """
    V, F = check_mesh(vertices, faces)
    UV = check_array("uv", uv, shape=(len(F), 3, 2), finite=False).copy()
    known = np.asarray(known) if not isinstance(known, str) else None
    if known is None or known.dtype != bool:
        raise ValueError(f"known must be a bool array of shape ({len(F)},), got "
                         f"{type(known).__name__ if known is None else known.dtype}")
    known = check_array("known", known, shape=(len(F),), dtype=bool).copy()
    if np.any(np.abs(UV[known]) > MAX_COORD) or not np.all(np.isfinite(UV[known])):
        raise ValueError(f"uv of the known faces must be finite and lie in [-{MAX_COORD:g}, {MAX_COORD:g}]")
    wrap = check_choice("wrap", wrap, ("triangle", "coordinate", "none"))
    if known.all() or len(F) == 0:
        return UV
    E, FE = edge_table(F, len(V))
    # the (at most two) faces of every edge
    ef = np.full((len(E), 2), -1, np.int64)
    fe = FE.ravel()
    order = np.argsort(fe, kind="stable")
    first = np.ones(len(fe), bool)
    first[1:] = fe[order][1:] != fe[order][:-1]
    slot = np.where(first, 0, 1)
    ef[fe[order], slot] = order // 3
    elen = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    while True:
        todo = np.flatnonzero(~known)
        if todo.size == 0:
            break
        # neighbour across each of the three edges of every pending face
        e3 = FE[todo]                                                    # (T, 3)
        a_f = ef[e3]                                                     # (T, 3, 2)
        nb = np.where(a_f[..., 0] == todo[:, None], a_f[..., 1], a_f[..., 0])
        ok = (nb >= 0) & known[np.maximum(nb, 0)]
        score = np.where(ok, elen[e3], -1.0)
        has = ok.any(axis=1)
        if not has.any():
            break
        t = todo[has]
        k = np.argmax(score[has], axis=1)                                # longest parameterised edge
        n = nb[has, k]
        # t's edge k runs from corner k to corner k + 1
        ca, cb, cc = k, (k + 1) % 3, (k + 2) % 3
        va, vb = F[t, ca], F[t, cb]
        n_corners = F[n]
        ia = np.argmax(n_corners == va[:, None], axis=1)
        ib = np.argmax(n_corners == vb[:, None], axis=1)
        im = 3 - ia - ib
        qa, qb, qm = UV[n, ia], UV[n, ib], UV[n, im]
        pa, pb, pm, pc = V[va], V[vb], V[F[n, im]], V[F[t, cc]]
        # unfold t's third vertex about the shared edge into n's plane, on the side opposite n's third vertex
        e = pb - pa
        el = np.linalg.norm(e, axis=1, keepdims=True)
        eh = e / np.where(el > 0, el, 1.0)
        rel_c = pc - pa
        along_c = np.einsum("ij,ij->i", rel_c, eh)
        h_c = np.linalg.norm(rel_c - along_c[:, None] * eh, axis=1)
        rel_m = pm - pa
        w = rel_m - np.einsum("ij,ij->i", rel_m, eh)[:, None] * eh
        wn = np.linalg.norm(w, axis=1, keepdims=True)
        w = w / np.where(wn > 0, wn, 1.0)
        pc2 = pa + along_c[:, None] * eh - h_c[:, None] * w
        # n's affine map: p = pa + s (pb - pa) + r (pm - pa)  ->  uv = qa + s (qb - qa) + r (qm - qa)
        s_num, r_num, det = barycentric_numpy(e, rel_m, pc2 - pa)
        det = np.where(np.abs(det) > 1e-300, det, 1.0)
        s, r = s_num / det, r_num / det
        qc = qa + s[:, None] * (qb - qa) + r[:, None] * (qm - qa)
        new = np.empty((len(t), 3, 2))
        new[np.arange(len(t)), ca] = qa
        new[np.arange(len(t)), cb] = qb
        new[np.arange(len(t)), cc] = qc
        if wrap == "triangle":
            new -= np.floor(new.mean(axis=1, keepdims=True))
        elif wrap == "coordinate":
            new = new - np.floor(new)                                    # ERRATUM A8: < 0 -> +1, > 1 -> -1
        UV[t] = new
        known[t] = True
    rest = np.flatnonzero(~known)
    if rest.size:                                                        # no parameterised face reachable
        P = V[F[rest]]
        c = P.mean(axis=1, keepdims=True)
        _, _, vt = np.linalg.svd(P - c)
        UV[rest] = np.einsum("fij,fkj->fik", P - c, vt[:, :2])
    return UV


def control_uvs(cm, *, wrap: str = "triangle") -> np.ndarray:
    """Per-corner UVs of a whole control mesh: cylindrical tubes, then joint (and cap) propagation.

    Parameters
    ----------
    cm : ControlMesh
        The control mesh.
    wrap : {"triangle", "coordinate", "none"}
        See :func:`propagate_uvs`.

    Returns
    -------
    (F, 3, 2) float64 ndarray
        Finite UVs on every face.
    """
    uv, known = branch_uvs(cm)
    return propagate_uvs(cm.vertices, cm.faces, uv, known, wrap=wrap)


def subdivide_uvs(uv, levels: int = 1) -> np.ndarray:
    """Linear per-corner UV subdivision matching :func:`~plantvr.subdivision.subdivide_loop`'s face order (§3.3).

    Child ``4 f + i`` of face ``f`` = (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca), with ``ab`` the
    midpoint of the corner UVs of a and b. Parent corner UVs are kept, so seams survive every level.

    Parameters
    ----------
    uv : (F, 3, 2) float64 ndarray
        Corner UVs.
    levels : int
        Levels, 0–8.

    Returns
    -------
    (4**levels * F, 3, 2) float64 ndarray

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.4.3: "the texture coordinate of a new edge point is set as the midpoint
       of the texture coordinates associated with the edge".
    """
    T = check_array("uv", uv, shape=(None, 3, 2), max_abs=MAX_COORD)
    levels = check_int("levels", levels, 0, 8)
    if len(T) * 4 ** levels > MAX_COUNT:
        raise ValueError(f"levels: {levels} levels of {len(T)} faces give {len(T) * 4 ** levels} faces, more than "
                         f"the {MAX_COUNT} allowed")
    for _ in range(levels):
        a, b, c = T[:, 0], T[:, 1], T[:, 2]
        ab, bc, ca = 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)
        T = np.stack([a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca], axis=1).reshape(-1, 3, 2)
    return T


def vertex_normals(vertices, faces) -> np.ndarray:
    """Vertex normal = normalised mean of the unit normals of the faces around it (spec §2.5).

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int ndarray
        Outward (counter-clockwise) triangles; face normal ``(B - A) × (C - A)``.

    Returns
    -------
    (V, 3) float64 ndarray
        Unit normals (zero for unused vertices).
    """
    V, F = check_mesh(vertices, faces)
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-300)
    vn = np.zeros_like(V)
    for c in range(3):
        for d in range(3):
            vn[:, d] += np.bincount(F[:, c], weights=fn[:, d], minlength=len(V))
    return vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)


def read_obj(path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read a triangle OBJ with optional per-corner UVs, keeping vertex order (no merging or splitting).

    Parameters
    ----------
    path : str or Path
        An OBJ with ``v``, optional ``vt``/``vn`` and triangular ``f`` lines (``v``, ``v/vt``, ``v//vn`` or
        ``v/vt/vn``, 1-based or negative).

    Returns
    -------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int64 ndarray
    uv : (F, 3, 2) float64 ndarray or None
        Per-corner UVs, None when the faces carry no ``vt`` index.

    Raises
    ------
    ValueError
        If the file is missing, a face is not a triangle or an index is out of range.
    """
    from plantvr._fileio import MAX_READ_BYTES, read_text

    text = read_text(path, what="path: OBJ file", max_bytes=MAX_READ_BYTES)
    where = f"path: OBJ file {os.fspath(path)!r}"

    def nums(tok: list[str], k: int, ln: int, what: str) -> list[float]:
        if len(tok) < k:
            raise ValueError(f"{where} line {ln}: {what} needs {k} numbers, got {len(tok)}")
        try:
            x = [float(t) for t in tok[:k]]
        except ValueError:
            raise ValueError(f"{where} line {ln}: {what} has a non-numeric value in {' '.join(tok)!r}") from None
        if not all(np.isfinite(x)) or max(map(abs, x)) > MAX_COORD:
            raise ValueError(f"{where} line {ln}: {what} values must be finite and lie in "
                             f"[-{MAX_COORD:g}, {MAX_COORD:g}]")
        return x

    v, vt, f, f_ln, n_vn = [], [], [], [], 0
    for ln, line in enumerate(text.splitlines(), 1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        if tok[0] == "v":
            v.append(nums(tok[1:], 3, ln, "vertex"))
        elif tok[0] == "vt":
            vt.append(nums(tok[1:], 2, ln, "texture coordinate"))
        elif tok[0] == "vn":
            nums(tok[1:], 3, ln, "normal")
            n_vn += 1
        elif tok[0] == "f":
            if len(tok) != 4:
                raise ValueError(f"path: line {ln} is a face with {len(tok) - 1} corners; only triangles are read")
            corners = [c.split("/") for c in tok[1:]]
            if any(len(c) > 3 for c in corners):
                raise ValueError(f"{where} line {ln}: face corner {tok[1:]} is not v, v/vt, v//vn or v/vt/vn")
            f.append(corners)
            f_ln.append(ln)
        if len(v) + len(vt) + len(f) > MAX_COUNT:
            raise ValueError(f"{where} has more than {MAX_COUNT} elements")
    V = np.array(v, float).reshape(-1, 3)
    T = np.array(vt, float).reshape(-1, 2)

    def idx(s: str, n: int, what: str, ln: int) -> int:
        try:
            i = int(s)
        except ValueError:
            raise ValueError(f"{where} line {ln}: {what} index {s!r} is not an integer") from None
        i = i - 1 if i > 0 else n + i
        if not 0 <= i < n:
            raise ValueError(f"path: {what} index {s} out of range 1..{n} (line {ln})")
        return i

    F = np.array([[idx(c[0], len(V), "vertex", ln) for c in face] for face, ln in zip(f, f_ln)],
                 np.int64).reshape(-1, 3)
    for face, ln in zip(f, f_ln):               # every index given must be an integer inside its table
        for c in face:
            if len(c) > 1 and c[1] != "":
                idx(c[1], len(T), "texture", ln)
            if len(c) > 2 and c[2] != "":
                idx(c[2], n_vn, "normal", ln)
    has_uv = bool(f) and all(len(c) > 1 and c[1] != "" for face in f for c in face)
    UV = (T[np.array([[idx(c[1], len(T), "texture", ln) for c in face] for face, ln in zip(f, f_ln)],
                     np.int64)] if has_uv else None)
    return V, F, UV

"""Points close to triangular meshes: Turk's triangle point offset along the Phong normal (spec 003_implicit_sca §3.7, C-14)."""
from __future__ import annotations

import numpy as np
import trimesh

from plantvr._validation import MAX_COORD, check_array, check_choice, check_int, check_points, check_range

__all__ = ["face_cdf", "sample_mesh_near", "MAX_SAMPLES"]

#: Most points one call draws.
MAX_SAMPLES = 10**8


def face_cdf(vertices, faces) -> np.ndarray:
    """Area CDF over faces: ``cdf[i] = sum_{j<i} A_j / sum A`` with ``cdf[0] = 0`` and ``cdf[F] = 1`` (Eq. 6.1).

    Parameters
    ----------
    vertices : (V, 3) float64 array_like
        Mesh vertices.
    faces : (F, 3) int array_like
        Triangles.

    Returns
    -------
    (F + 1,) float64 ndarray
        Monotone CDF.

    References
    ----------
    .. [1] Kochhar 2010, §6.3, Eq. 6.1.
    """
    v = check_points("vertices", vertices, min_rows=3)
    try:
        f = check_array("faces", faces, shape=(None, 3), dtype=np.int64, min_rows=1)
    except OverflowError:
        raise ValueError("faces must be an (F, 3) array of vertex indices, got non-finite or huge values") from None
    if f.min() < 0 or f.max() >= len(v):
        raise ValueError(f"faces must index vertices in [0, {len(v) - 1}], got range [{f.min()}, {f.max()}]")
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    total = area.sum()
    if total <= 0:
        raise ValueError("faces must have a positive total area")
    cdf = np.r_[0.0, np.cumsum(area)] / total
    cdf[-1] = 1.0
    return cdf


def sample_mesh_near(vertices, faces, n: int, *, offset=(0.02, 0.1), selection: str = "area", rng=None,
                     vertex_normals=None):
    """Points near a mesh: random face, Turk point ``(1-s-t) v1 + s v2 + t v3``, offset ``u`` along the normal.

    Parameters
    ----------
    vertices : (V, 3) float64 array_like
        Mesh vertices (oriented 2-manifold assumed, thesis §6.3).
    faces : (F, 3) int array_like
        Triangles.
    n : int
        Number of points.
    offset : (float, float)
        ``(u_min, u_max)``; u ~ U[u_min, u_max] along the normalized interpolated (Phong) normal.
    selection : {"area", "uniform"}
        Face choice: area-weighted by Eq. 6.1 (``searchsorted(cdf, u, "right") - 1``) or uniform by index.
    rng : int | numpy.random.Generator | None
        Seed or generator.
    vertex_normals : (V, 3) float64 array_like, optional
        Vertex normals (default: trimesh's area-weighted vertex normals).

    Returns
    -------
    points : (n, 3) float64 ndarray
        Offset points.
    face_index : (n,) int64 ndarray
        Chosen faces.

    References
    ----------
    .. [1] Kochhar 2010, §6.3, Eq. 6.1, Fig. 6.6; Turk 1990; spec 003 §3.7.
    """
    cdf = face_cdf(vertices, faces)
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n = check_int("n", n, 0, MAX_SAMPLES)
    check_choice("selection", selection, ("area", "uniform"))
    try:
        u_min, u_max = float(offset[0]), float(offset[1])
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"offset must be a pair (u_min, u_max), got {offset!r}") from None
    check_range("offset[0]", u_min, -MAX_COORD, MAX_COORD)
    check_range("offset[1]", u_max, u_min, MAX_COORD)
    if vertex_normals is None:
        vn = trimesh.Trimesh(v, f, process=False).vertex_normals
    else:
        vn = check_array("vertex_normals", vertex_normals, shape=(len(v), 3), max_abs=MAX_COORD)
    rng = np.random.default_rng(rng)
    if selection == "area":
        idx = np.searchsorted(cdf, rng.random(n), side="right") - 1
        idx = np.clip(idx, 0, len(f) - 1)
    else:
        idx = rng.integers(0, len(f), n)
    st = rng.random((n, 2))
    fold = st.sum(axis=1) >= 1.0                 # fold (s, t) -> (1-s, 1-t): uniform over the triangle
    st[fold] = 1.0 - st[fold]
    s, t = st[:, 0:1], st[:, 1:2]
    tri = f[idx]
    p = (1 - s - t) * v[tri[:, 0]] + s * v[tri[:, 1]] + t * v[tri[:, 2]]
    nrm = (1 - s - t) * vn[tri[:, 0]] + s * vn[tri[:, 1]] + t * vn[tri[:, 2]]
    ln = np.linalg.norm(nrm, axis=1)
    nrm /= np.where(ln > 0, ln, 1.0)[:, None]        # a zero normal (degenerate fan) gives no offset, not NaN
    u = rng.uniform(u_min, u_max, (n, 1))
    return p + u * nrm, idx

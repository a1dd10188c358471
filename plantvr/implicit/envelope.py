"""Crown envelopes from point clouds (issue 22 "Trees from scans"; spec 003_implicit_sca §2 BlobTree, §3 markers).

A terrestrial laser scan of a crown becomes the closed volume that implicit-crown space colonization fills:

* ``method="implicit"``: a BlobTree :class:`~plantvr.implicit.blobtree.Blend` of point primitives, one per
  occupied cell of a grid of edge ``radius / 2`` (at the cell's centroid), so the field is > 0.5 within about
  ``radius / 2`` of the scan and the crown is one smooth blob (thesis §3.3 summation blend);
* ``method="alpha"``: the alpha shape (Edelsbrunner & Mücke 1994) of the points as a :class:`~plantvr.types.TriMesh`:
  the boundary of the Delaunay tetrahedra whose circumradius is below ``alpha``, wound outward.
"""
from __future__ import annotations

import numpy as np

from plantvr import grid
from plantvr._validation import check_choice, check_int, check_points, check_range
from plantvr.types import TriMesh

from .blobtree import Blend, Node, sphere

__all__ = ["METHODS", "alpha_shape", "crown_from_points", "implicit_envelope"]

METHODS = ("alpha", "implicit")
#: Most point primitives an implicit envelope holds.
MAX_PRIMITIVES = 200_000


def _default_scale(points: np.ndarray) -> float:
    """A length that spans a few points: 4 × the mean spacing of the points in their bounding box."""
    ext = np.ptp(points, axis=0)
    vol = float(np.prod(np.maximum(ext, 1e-12 * max(float(ext.max()), 1e-300))))
    return 4.0 * (vol / len(points)) ** (1.0 / 3.0)


def implicit_envelope(points, *, radius: float | None = None, max_primitives: int = 20_000) -> Node:
    """BlobTree blend of point primitives around ``points`` (see module docstring).

    Parameters
    ----------
    points : (N, 3) float64 array_like
        Scan points, N >= 1.
    radius : float, optional
        Radius of influence R of each primitive, in (0, inf); default 4 × the mean point spacing.
    max_primitives : int
        At most this many primitives, in [1, MAX_PRIMITIVES]; the grid cell grows until they fit.

    Returns
    -------
    Node
        Inside where ``F > 0.5`` (usable by :func:`plantvr.implicit.sampling.sample_inside` and the crown SCA).
    """
    pts = check_points("points", points, min_rows=1)
    r = _default_scale(pts) if radius is None else check_range("radius", radius, 0.0, np.inf, low_open=True,
                                                                 high_open=True)
    cap = check_int("max_primitives", max_primitives, 1, MAX_PRIMITIVES)
    h = 0.5 * r
    lo, hi = grid.bounds(pts)
    while True:
        # the occupied cells of the dense grid on the points' box, in cell-id order (= (i, j, k) order)
        dims = np.floor((hi - lo) / h).astype(np.int64) + 1
        if np.prod(dims.astype(np.float64)) < 2.0 ** 62:
            _, inv, cnt = np.unique(grid.dense_cell_ids(pts, lo, h, dims), return_inverse=True, return_counts=True)
        else:                                   # cell ids would overflow int64: unique (i, j, k) rows, same order
            key = np.floor((pts - lo) / h).astype(np.int64)
            _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        if len(cnt) <= cap:
            break
        h *= 1.25
    inv = inv.ravel()
    cent = np.zeros((len(cnt), 3))
    np.add.at(cent, inv, pts)
    cent /= cnt[:, None]
    return Blend(*[sphere(c, r) for c in cent]) if len(cent) > 1 else sphere(cent[0], r)


def alpha_shape(points, *, alpha: float | None = None) -> TriMesh:
    """Alpha shape of ``points``: boundary triangles of the Delaunay tetrahedra with circumradius < ``alpha``.

    Parameters
    ----------
    points : (N, 3) float64 array_like
        N >= 4 points, not all coplanar.
    alpha : float, optional
        In (0, inf]; ``inf`` gives the convex hull. Default 2 × the mean point spacing (4 / 2 of
        :func:`implicit_envelope`'s radius).

    Returns
    -------
    TriMesh
        Faces wound counter-clockwise seen from outside; unused vertices removed. Closed when the kept
        tetrahedra form a solid without pinched edges (a dense sample of a solid crown); check
        ``mesh.is_watertight``.

    References
    ----------
    .. [1] Edelsbrunner, Mücke 1994, "Three-dimensional alpha shapes", ACM TOG 13(1).
    """
    from scipy.spatial import Delaunay, QhullError

    pts = check_points("points", points, min_rows=4)
    if alpha is None:
        a = 0.5 * _default_scale(pts)
    elif isinstance(alpha, (int, float, np.floating)) and alpha == np.inf:
        a = np.inf
    else:
        a = check_range("alpha", alpha, 0.0, np.inf, low_open=True, high_open=True)
    try:
        tri = Delaunay(pts)
    except QhullError:
        raise ValueError("points must span a volume (not all coplanar) for an alpha shape") from None
    T = tri.simplices
    P = pts[T]  # (K, 4, 3)
    A = 2.0 * (P[:, 1:] - P[:, :1])
    b = (P[:, 1:] ** 2).sum(-1) - (P[:, :1] ** 2).sum(-1)
    det = np.linalg.det(A)
    ok = np.abs(det) > 1e-300
    c = np.zeros((len(T), 3))
    c[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    R = np.where(ok, np.linalg.norm(c - P[:, 0], axis=1), np.inf)
    keep = T[R < a]
    if not len(keep):
        raise ValueError(f"alpha = {a:g} keeps no tetrahedron; use a larger alpha")
    # the 4 faces of each kept tet, each wound outward from the tet: (opposite vertex k excluded)
    faces = np.concatenate([keep[:, [1, 2, 3]], keep[:, [0, 3, 2]], keep[:, [0, 1, 3]], keep[:, [0, 2, 1]]])
    opp = np.concatenate([keep[:, 0], keep[:, 1], keep[:, 2], keep[:, 3]])
    v0, v1, v2 = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
    n = np.cross(v1 - v0, v2 - v0)
    flip = np.einsum("ij,ij->i", n, pts[opp] - v0) > 0  # normal must point away from the opposite vertex
    faces[flip] = faces[flip][:, [0, 2, 1]]
    key = np.sort(faces, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    bnd = faces[cnt[inv.ravel()] == 1]
    used, remap = np.unique(bnd, return_inverse=True)
    return TriMesh(pts[used].copy(), remap.reshape(-1, 3).astype(np.int64))


def crown_from_points(points, *, method: str = "alpha", alpha: float | None = None, radius: float | None = None,
                      max_primitives: int = 20_000) -> Node | TriMesh:
    """Crown envelope of a point cloud: an alpha-shape :class:`TriMesh` or an implicit BlobTree node.

    Parameters
    ----------
    points : (N, 3) float64 array_like
        Scan points (e.g. :func:`plantvr.io.points.read_points`).
    method : {"alpha", "implicit"}
        See :func:`alpha_shape` and :func:`implicit_envelope`.
    alpha, radius, max_primitives
        Passed to the chosen method.

    Returns
    -------
    TriMesh or Node
        The mesh samples with :func:`plantvr.implicit.mesh_sampling.sample_mesh_near` (or its inside with a
        point-in-mesh test); the node with :func:`plantvr.implicit.sampling.sample_inside`; either feeds
        :func:`plantvr.implicit.crown.grow_in_crown`.
    """
    method = check_choice("method", method, METHODS)
    if method == "alpha":
        return alpha_shape(points, alpha=alpha)
    return implicit_envelope(points, radius=radius, max_primitives=max_primitives)

"""Self-intersection test of a triangle mesh, adjacent pairs excluded (spec 001_subdivision §8.2 V13).

Broad phase: a k-d tree over face centroids finds every pair whose bounding spheres (centroid, farthest
corner) overlap. Narrow phase: a pair intersects when an edge of one triangle crosses the interior of the
other (Möller–Trumbore on segments, vectorised). Pairs that share a vertex are adjacent and skipped, as V13
asks; coplanar overlaps are not reported (they do not occur between the non-adjacent faces of these meshes).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from plantvr._validation import MAX_COUNT, check_int, check_range

from ._checks import check_mesh

__all__ = ["self_intersections"]


def _segments_hit(p0, p1, a, b, c, eps):
    """(K,) bool: segment p0→p1 crosses triangle abc strictly inside (barycentric margin ``eps``)."""
    d = p1 - p0
    e1, e2 = b - a, c - a
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    ok = np.abs(det) > 1e-300
    inv = 1.0 / np.where(ok, det, 1.0)
    s = p0 - a
    u = inv * np.einsum("ij,ij->i", s, h)
    q = np.cross(s, e1)
    v = inv * np.einsum("ij,ij->i", d, q)
    t = inv * np.einsum("ij,ij->i", e2, q)
    # the endpoints must lie strictly on opposite sides of the plane: rejects coplanar neighbours (a straight
    # tube's consecutive quads) whose tiny, noisy determinant would otherwise pass the barycentric test
    n = np.cross(e1, e2)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    s0 = np.einsum("ij,ij->i", p0 - a, n)
    s1 = np.einsum("ij,ij->i", p1 - a, n)
    tol = eps * np.maximum(np.linalg.norm(d, axis=1), np.linalg.norm(e1, axis=1))
    sides = (s0 * s1 < 0) & (np.abs(s0) > tol) & (np.abs(s1) > tol)
    return ok & sides & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)


def self_intersections(vertices, faces, *, eps: float = 1e-9, chunk: int = 2_000_000) -> np.ndarray:
    """Pairs of non-adjacent faces that intersect (spec V13).

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int ndarray
    eps : float
        Relative margin (barycentric and along the edge, 0–0.1): touching at a vertex or an edge does not count.
    chunk : int
        Candidate pairs tested at a time (memory bound).

    Returns
    -------
    (K, 2) int64 ndarray
        Face index pairs ``i < j`` that intersect; empty for a clean mesh.

    References
    ----------
    .. [1] Möller, T. A fast triangle-triangle intersection test (1997); Möller & Trumbore, Fast, minimum storage
       ray-triangle intersection (1997). Spec 001 V13.
    """
    V, F = check_mesh(vertices, faces)
    eps = check_range("eps", eps, 0.0, 0.1)
    chunk = check_int("chunk", chunk, 1, MAX_COUNT)
    if len(F) < 2:
        return np.zeros((0, 2), np.int64)
    T = V[F]
    cen = T.mean(axis=1)
    rad = np.linalg.norm(T - cen[:, None], axis=2).max(axis=1)
    tree = cKDTree(cen)
    # pairs with |c_i - c_j| <= r_i + r_j, found in radius classes so one big face does not widen every query
    order = np.argsort(rad, kind="stable")
    rank = np.empty(len(F), np.int64)
    rank[order] = np.arange(len(F))
    out = []
    start = 0
    for q in (0.5, 0.9, 0.99, 1.0):
        stop = len(F) if q == 1.0 else max(start, int(q * len(F)))
        grp = order[start:stop]
        start = stop
        if grp.size == 0:
            continue
        rmax = float(rad[grp].max())
        # a pair is found once, in the class of its higher-ranked (larger) face: |c_i - c_j| <= r_i + rmax
        nb = tree.query_ball_point(cen, rad + rmax, return_sorted=False)
        lens = np.fromiter((len(x) for x in nb), np.int64, len(nb))
        I = np.repeat(np.arange(len(F)), lens)
        J = np.fromiter((j for x in nb for j in x), np.int64, int(lens.sum()))
        in_grp = np.zeros(len(F), bool)
        in_grp[grp] = True
        keep = in_grp[J] & (rank[I] < rank[J])
        I, J = I[keep], J[keep]
        keep = np.linalg.norm(cen[I] - cen[J], axis=1) <= rad[I] + rad[J]
        I, J = I[keep], J[keep]
        shared = (F[I][:, :, None] == F[J][:, None, :]).any(axis=(1, 2))
        I, J = I[~shared], J[~shared]
        for s in range(0, len(I), chunk):
            i, j = I[s:s + chunk], J[s:s + chunk]
            A, B = T[i], T[j]
            hit = np.zeros(len(i), bool)
            for X, Y in ((A, B), (B, A)):
                for k in range(3):
                    hit |= _segments_hit(X[:, k], X[:, (k + 1) % 3], Y[:, 0], Y[:, 1], Y[:, 2], eps)
            out.append(np.stack([np.minimum(i, j)[hit], np.maximum(i, j)[hit]], axis=1))
    if not out:
        return np.zeros((0, 2), np.int64)
    return np.unique(np.concatenate(out), axis=0).astype(np.int64)

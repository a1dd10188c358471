"""Barycentric coordinates of a point in a triangle's plane from the 2x2 Gram system (base module).

With edges ``u = b - a``, ``v = c - a`` and ``w = p - a``, the coordinates ``(s, t)`` of ``p = a + s u + t v``
(least squares off the plane) solve ``[[u.u, u.v], [u.v, v.v]] [s, t] = [w.u, w.v]``. The collision test of
:mod:`plantvr.flowers` (thesis Eq. B.7), the closest-point search of :mod:`plantvr.vine.depthcue` (Fig. 5.5) and
the UV unfolding of :mod:`plantvr.subdivision.uv` all solve it by Cramer's rule with :func:`gram_solve`.

:func:`gram_solve` is plain elementwise arithmetic: called on floats or on (N,) arrays (numpy twins, which keep
their own ``einsum`` dot products) and, as :func:`gram_solve_nb`, inside numba kernels, with the same operations in
the same order, so the twins agree bit for bit; :func:`barycentric_numpy` feeds it row-wise ``einsum`` dot
products of (N, 3) edge arrays. Numpy and numba only.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["barycentric_nb", "barycentric_numpy", "gram_solve", "gram_solve_nb"]


def gram_solve(uu, uv, vv, wu, wv):
    """Cramer's rule on the Gram system: ``(s_num, t_num, det)`` with ``s = s_num / det``, ``t = t_num / det``.

    Parameters
    ----------
    uu, uv, vv, wu, wv : float or (N,) float64 ndarray
        Dot products ``u.u``, ``u.v``, ``v.v``, ``w.u`` and ``w.v``.

    Returns
    -------
    s_num, t_num, det : float or (N,) float64 ndarray
        ``det = uu vv - uv²`` is 0 for a degenerate triangle; the caller chooses the guard before dividing.
    """
    return vv * wu - uv * wv, uu * wv - uv * wu, uu * vv - uv * uv


gram_solve_nb = numba.njit(cache=True, nogil=True, inline="always")(gram_solve)


@numba.njit(cache=True, nogil=True, inline="always")
def barycentric_nb(ux, uy, uz, vx, vy, vz, wx, wy, wz):  # pragma: no cover - numba helper
    """:func:`gram_solve` of scalar edge vectors ``u``, ``v`` and ``w`` (dot products summed x, y, z)."""
    return gram_solve_nb(ux * ux + uy * uy + uz * uz, ux * vx + uy * vy + uz * vz, vx * vx + vy * vy + vz * vz,
                         wx * ux + wy * uy + wz * uz, wx * vx + wy * vy + wz * vz)


def barycentric_numpy(u, v, w):
    """:func:`gram_solve` of (N, 3) float64 edge arrays ``u``, ``v``, ``w`` (row dot products by ``einsum``)."""
    def dot(x, y):
        return np.einsum("ij,ij->i", x, y)
    return gram_solve(dot(u, u), dot(u, v), dot(v, v), dot(w, u), dot(w, v))

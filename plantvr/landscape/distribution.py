"""Tree-distribution kernels (Eqs. 6.1–6.2) and Ripley's K (Eq. 6.6) (spec 004_treesketch §3.4.2, §3.9)."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .._validation import check_array, check_range

__all__ = ["clustering_kernel", "inhibitory_kernel", "ripley_k"]


def _smooth(x: np.ndarray) -> np.ndarray:
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)  # 6x^5 - 15x^4 + 10x^3


def _check_kernel(d, r, a, s):
    d = np.asarray(d, float)
    r = check_range("r", r, 0.0, np.inf)
    a = check_range("a", a, r, np.inf, low_open=True)
    return d, r, a


def clustering_kernel(d, *, r: float, a: float, s: float) -> np.ndarray:
    """Eq. 6.1: 0 for d <= r; (s - 1)(6x^5 - 15x^4 + 10x^3) + 1 with x = 1 - (d - r)/(a - r) for r < d <= a; 1 beyond.

    ``d`` distance to an existing tree, ``r`` its occupied radius, ``a`` the active radius (> r), ``s`` >= 0 the
    scale (values s > 1 attract: the kernel peaks at s just outside r).
    """
    d, r, a = _check_kernel(d, r, a, s)
    s = check_range("s", s, 0.0, np.inf)
    x = 1.0 - (d - r) / (a - r)
    k = (s - 1.0) * _smooth(np.clip(x, 0.0, 1.0)) + 1.0
    return np.where(d <= r, 0.0, np.where(d <= a, k, 1.0))


def inhibitory_kernel(d, *, r: float, a: float, s: float) -> np.ndarray:
    """Eq. 6.2: 0 for d <= r; 1 - 1/s + (1/s)(6x^5 - 15x^4 + 10x^3) with x = (d - r)/(a - r) for r < d <= a; 1 beyond.

    ERRATUM E9: s < 1 would give negative probabilities and is rejected; larger s = weaker inhibition.
    """
    d, r, a = _check_kernel(d, r, a, s)
    s = check_range("s", s, 1.0, np.inf)  # ERRATUM E9
    x = (d - r) / (a - r)
    k = 1.0 - 1.0 / s + _smooth(np.clip(x, 0.0, 1.0)) / s
    return np.where(d <= r, 0.0, np.where(d <= a, k, 1.0))


def ripley_k(points: np.ndarray, t, *, area: float | None = None, box: tuple[float, float] | None = None
             ) -> np.ndarray:
    """Eq. 6.6: K(t) = lambda^-1 sum_{i != j} I(d_ij < t) / n, lambda = n / A (2D points (n, 2)).

    With ``box`` = (width, height) distances wrap around the rectangle [0, w) x [0, h) (toroidal edge
    correction), so complete spatial randomness gives K(t) = pi t^2 without edge bias (ERRATUM E10: the
    uniform reference is CSR). Without ``box`` no correction is made and ``area`` must be given.
    """
    pts = check_array("points", points, shape=(None, 2), min_rows=2)
    t = np.atleast_1d(np.asarray(t, float))
    if box is not None:
        w = check_range("box[0]", box[0], 0.0, np.inf, low_open=True)
        h = check_range("box[1]", box[1], 0.0, np.inf, low_open=True)
        A = w * h
        kd = cKDTree(np.mod(pts, [w, h]), boxsize=[w, h])
    else:
        if area is None:
            raise ValueError("area must be given when box is None")
        A = check_range("area", area, 0.0, np.inf, low_open=True)
        kd = cKDTree(pts)
    n = len(pts)
    # count_neighbors counts ordered pairs with d <= t, self pairs included; nextafter turns <= into <
    pairs = kd.count_neighbors(kd, np.nextafter(t, -np.inf)).astype(float) - n
    return A / n * pairs / n

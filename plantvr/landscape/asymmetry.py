"""Neighbourhood asymmetry (Eqs. 6.3–6.4) and its fading landscape tropism (Eq. 6.5) (spec 004_treesketch §3.6)."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .._validation import MAX_COORD, MAX_COUNT, check_array, check_int, check_range
from .terrain import pair

__all__ = ["cell_geometry", "landscape_tropism", "neighbour_asymmetry"]


def neighbour_asymmetry(bases: np.ndarray, areas: np.ndarray, radius, *, centroids: np.ndarray | None = None,
                        bounding: np.ndarray | None = None, alpha_a: float = 1.0, alpha_d: float = 2.0
                        ) -> np.ndarray:
    """Neighbourhood-asymmetry vectors **V**_i of Eq. 6.4 (horizontal, (N, 2)).

    **P**_ij = w_ij (T_i - T_j) / |T_i - T_j| with w_ij = alpha_a A_j / A_i + alpha_d (1 - |T_i - T_j| / r_i) for the
    neighbours j within r_i of T_i (Eq. 6.3); **V**_i = clamp(|T_i - C_i| / B_i, 0, 1) sum_j **P**_ij, C_i the
    centroid and B_i the bounding-circle radius of the tree's crown region (ratio 1 when not given).

    Parameters
    ----------
    bases : (N, 2) float64 array
        Ground positions T_i (x, z), metres.
    areas : (N,) float64 array
        Projected crown areas A_i (> 0); only ratios matter (ERRATUM E3).
    radius : float or (N,) float64 array
        Neighbourhood radii r_i (> 0); default in the spec: the scaled crown width.
    centroids, bounding : (N, 2) and (N,) float64 arrays, optional
        Region centroids C_i and bounding radii B_i (:func:`cell_geometry`).
    alpha_a, alpha_d : float
        Neighbour-size and proximity weights ("alpha_a = 1.0, alpha_d = 2.0 for results shown in this thesis").

    Returns
    -------
    (N, 2) float64 array

    References
    ----------
    .. [1] Longay thesis §6.5.2, Eqs. 6.3–6.4, Figs. 6.18–6.19; spec 004 §3.6 (clamp of the ratio [INFERRED]).
    """
    T = check_array("bases", bases, shape=(None, 2), max_abs=MAX_COORD)
    n = len(T)
    A = check_array("areas", areas, shape=(n,), max_abs=1e24)
    if np.any(A <= 1e-24):
        raise ValueError("areas must be positive (in [1e-24, 1e24])")
    if np.ndim(radius) == 0:
        r = np.full(n, check_range("radius", radius, 0.0, 2 * MAX_COORD, low_open=True))
    else:
        r = check_array("radius", radius, shape=(n,))
    if not np.all(np.isfinite(r) & (r > 0) & (r <= 2 * MAX_COORD)):
        raise ValueError(f"radius must be positive and at most {2 * MAX_COORD:g}, got {radius!r}"[:300])
    alpha_a = check_range("alpha_a", alpha_a, 0.0, np.inf)
    alpha_d = check_range("alpha_d", alpha_d, 0.0, np.inf)
    ratio = np.ones(n)
    if (centroids is None) != (bounding is None):
        raise ValueError("centroids and bounding must be given together")
    if centroids is not None:
        C = check_array("centroids", centroids, shape=(n, 2), max_abs=2 * MAX_COORD)
        B = check_array("bounding", bounding, shape=(n,), max_abs=4 * MAX_COORD)
        ratio = np.clip(np.linalg.norm(T - C, axis=1) / np.where(B > 0, B, np.inf), 0.0, 1.0)
    kd = cKDTree(T)
    V = np.zeros((n, 2))
    for i in range(n):
        nb = np.array([j for j in kd.query_ball_point(T[i], r[i]) if j != i], np.int64)
        if not len(nb):
            continue
        d = T[i] - T[nb]
        dist = np.linalg.norm(d, axis=1)
        ok = dist > 0
        w = alpha_a * A[nb[ok]] / A[i] + alpha_d * (1.0 - dist[ok] / r[i])
        V[i] = ratio[i] * np.sum(w[:, None] * d[ok] / dist[ok, None], axis=0)
    return V


def cell_geometry(bases: np.ndarray, size: tuple[float, float], *, weights: np.ndarray | None = None,
                  resolution: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """Centroid C_i and bounding-circle radius B_i (about C_i) of each tree's crown region on the plot, the
    regions being the multiplicatively weighted Voronoi cells (|q - T_i| / w_i minimal) rasterised at
    ``resolution`` x ``resolution`` (the 2D stand-in for the boundary propagation of §3.5)."""
    T = check_array("bases", bases, shape=(None, 2), min_rows=1, max_abs=MAX_COORD)
    w = np.ones(len(T)) if weights is None else check_array("weights", weights, shape=(len(T),), max_abs=1e12)
    if not np.all(w >= 1e-12):
        raise ValueError("weights must be positive (in [1e-12, 1e12])")
    res = check_int("resolution", resolution, 2, 4096)
    if res * res * len(T) > 64 * MAX_COUNT:
        raise ValueError(f"resolution {res} with {len(T)} trees is too much work (cells x trees above {64 * MAX_COUNT})")
    W, H = pair("size", size)
    gx, gz = np.meshgrid((np.arange(res) + 0.5) * W / res, (np.arange(res) + 0.5) * H / res)
    q = np.column_stack([gx.ravel(), gz.ravel()])
    owner = np.empty(len(q), np.int64)
    for s in range(0, len(q), 8192):  # chunks keep the (cells x trees) distance table small
        d = np.linalg.norm(q[s:s + 8192, None] - T[None], axis=2) / w[None]
        owner[s:s + 8192] = np.argmin(d, axis=1)
    cnt = np.bincount(owner, minlength=len(T))
    C = np.stack([np.bincount(owner, q[:, k], len(T)) for k in range(2)], 1) / np.maximum(cnt, 1)[:, None]
    C[cnt == 0] = T[cnt == 0]
    B = np.zeros(len(T))
    np.maximum.at(B, owner, np.linalg.norm(q - C[owner], axis=1))
    return C, B


def landscape_tropism(V: np.ndarray, S_t: np.ndarray, height: float, h_max: float) -> np.ndarray:
    """Eq. 6.5: **F** = (1 - a)(**V** + **S**_t) + a **S**_t with the fade a = (h / h_max)^(1/2) (ERRATUM E8:
    ``asym_fade``); h = 0 gives **V** + **S**_t, h >= h_max gives **S**_t. ``V`` (3,) or (B, 3), ``S_t`` (B, 3);
    not normalised."""
    h_max = check_range("h_max", h_max, 0.0, MAX_COORD, low_open=True)
    height = check_range("height", height, 0.0, 2 * MAX_COORD)
    S = check_array("S_t", np.atleast_2d(np.asarray(S_t, float)) if np.ndim(S_t) == 1 else S_t, shape=(None, 3),
                    max_abs=1e12)
    V = check_array("V", V, shape=(3,) if np.ndim(V) == 1 else (len(S), 3), max_abs=1e12)
    a = min(height / h_max, 1.0) ** 0.5
    out = (1.0 - a) * (V + S) + a * S
    return out[0] if np.ndim(S_t) == 1 else out

"""Markers painted by the wand: Poisson darts in the brush sphere (spec 000_treewand §2.2, §4.3).

The dart test runs in a numba kernel over a hashed grid of the accepted markers (cells of at least twice the
rejection radius), so a paint costs O(darts + markers near the brush) instead of the O(darts²) of comparing
every candidate with every accepted one (issue 20: ``darts_per_paint = 10**6`` is an accepted value);
:func:`poisson_darts_numpy` is the readable twin and gives the same markers.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import MAX_COORD, MAX_COUNT, check_int, check_point, check_points, check_range

from plantvr.grid import HASH_LIMIT, cell_coord, chain_within, hash_cell

from .spatial import REACH

__all__ = ["uniform_in_ball", "poisson_darts", "poisson_darts_numpy"]


def uniform_in_ball(n: int, rng: np.random.Generator) -> np.ndarray:
    """Return ``n`` points uniformly distributed in the unit ball."""
    n = check_int("n", n, 0, MAX_COUNT)
    rng = np.random.default_rng(rng)
    v = rng.normal(size=(n, 3))
    v /= np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    return v * rng.random((n, 1)) ** (1.0 / 3.0)


def poisson_darts(center: np.ndarray, radius: float, n_darts: int, existing: np.ndarray, rejection: float,
                  rng: int | np.random.Generator | None) -> np.ndarray:
    """Throw ``n_darts`` candidates in the sphere; keep those farther than ``rejection`` from every marker.

    Only the existing markers within ``radius + rejection`` of ``center`` are compared, so the cost grows
    with the brush, not with all markers (§2.2: rejection radius = occupation radius).

    Parameters
    ----------
    center : (3,) float64 array_like
        Brush centre, within ±MAX_COORD.
    radius : float
        Brush radius in [0, MAX_COORD].
    n_darts : int
        Candidates, in [0, MAX_COUNT].
    existing : (M, 3) float64 array_like
        Markers already there, within ±REACH.
    rejection : float
        Rejection radius in [0, MAX_COORD]; a candidate closer than it to a kept marker is dropped.
    rng : int, numpy Generator or None
        Random source.

    Returns
    -------
    (K, 3) float64 ndarray
        The kept candidates, in throwing order.

    References
    ----------
    .. [1] Tree Wand thesis §9.2 (Poisson darts); spec 000_treewand §2.2.
    """
    center = check_point("center", center)
    radius = check_range("radius", radius, 0.0, MAX_COORD)
    n_darts = check_int("n_darts", n_darts, 0, MAX_COUNT)
    existing = check_points("existing", existing, max_abs=REACH)
    rejection = check_range("rejection", rejection, 0.0, MAX_COORD)
    return _poisson_darts(center, radius, n_darts, existing, rejection, np.random.default_rng(rng))


def _near(center, radius, existing, rejection):
    if not len(existing):
        return existing.reshape(0, 3)
    return existing[np.sum((existing - center) ** 2, axis=1) <= (radius + rejection) ** 2]


def _poisson_darts(center, radius, n_darts, existing, rejection, rng) -> np.ndarray:
    """:func:`poisson_darts` without the door checks (the engine's path)."""
    cand = center + radius * uniform_in_ball(n_darts, rng)
    near = np.ascontiguousarray(_near(center, radius, existing, rejection), np.float64)
    r2 = rejection * rejection
    if r2 == 0.0 or not len(cand):  # nothing is ever closer than 0
        return cand.reshape(-1, 3)
    cap = len(near) + len(cand)
    nb = 1 << max(4, int(2 * cap - 1).bit_length())
    keep = np.zeros(len(cand), np.bool_)
    # Cells of at least 2r hold every neighbour closer than r within one cell, also after rounding; at least
    # 2^-30 of the brush span, so a tiny r cannot push the cell indices (relative to the centre) out of range.
    h = max(2.0 * rejection, (radius + rejection) * 2.0 ** -30)
    _darts_kernel(np.ascontiguousarray(cand), near, center, r2, h, nb - 1, keep)
    return cand[keep].reshape(-1, 3)


@numba.njit(cache=True, nogil=True, inline="always")
def _dart_hit(head, nxt, pts, cx, cy, cz, mask, x, y, z, r2):
    """True when an accepted point in the 27 cells around cell ``(cx, cy, cz)`` lies closer than ``sqrt(r2)``."""
    for ix in range(cx - 1, cx + 2):
        for iy in range(cy - 1, cy + 2):
            for iz in range(cz - 1, cz + 2):
                if chain_within(head[hash_cell(ix, iy, iz, mask)], nxt, pts, x, y, z, r2):
                    return True
    return False


@numba.njit(cache=True, nogil=True)
def _darts_kernel(cand, near, center, r2, h, mask, keep):
    """Sequential dart test over a hashed grid (cell ``h`` >= twice the rejection radius, indexed relative to
    ``center``) of the accepted points; sets ``keep`` for the candidates kept."""
    inv = 1.0 / h
    cap = near.shape[0] + cand.shape[0]
    head = np.full(mask + 1, -1, np.int64)
    nxt = np.empty(cap, np.int64)
    pts = np.empty((cap, 3))
    n = 0
    for i in range(near.shape[0] + cand.shape[0]):
        src = near if i < near.shape[0] else cand
        k = i if i < near.shape[0] else i - near.shape[0]
        x, y, z = src[k, 0], src[k, 1], src[k, 2]
        cx = cell_coord(x - center[0], inv, -HASH_LIMIT, HASH_LIMIT)
        cy = cell_coord(y - center[1], inv, -HASH_LIMIT, HASH_LIMIT)
        cz = cell_coord(z - center[2], inv, -HASH_LIMIT, HASH_LIMIT)
        if i >= near.shape[0]:
            if _dart_hit(head, nxt, pts, cx, cy, cz, mask, x, y, z, r2):
                continue
            keep[k] = True
        pts[n, 0] = x
        pts[n, 1] = y
        pts[n, 2] = z
        b = hash_cell(cx, cy, cz, mask)
        nxt[n] = head[b]
        head[b] = n
        n += 1


def poisson_darts_numpy(center: np.ndarray, radius: float, n_darts: int, existing: np.ndarray, rejection: float,
                        rng: np.random.Generator) -> np.ndarray:
    """numpy twin of :func:`poisson_darts`: each candidate against every accepted marker (O(darts²))."""
    cand = center + radius * uniform_in_ball(n_darts, rng)
    near = _near(center, radius, existing, rejection)
    kept = []
    r2 = rejection * rejection
    pool = near
    for c in cand:
        if len(pool) and np.min(np.sum((pool - c) ** 2, axis=1)) < r2:
            continue
        kept.append(c)
        pool = np.vstack([pool, c[None]]) if len(pool) else c[None].copy()
    return np.array(kept).reshape(-1, 3)

"""Floret fate from position: the cone test and distance thresholds (spec 002 §4.6, Eqs. 6.1–6.2, ERRATUM A.4; C20).

A floret P is a ray floret when no other floret lies in its cone K(P) (apex P, axis pointing away
from the head centre O). With thresholds, d_min(P) decides between disc, small ray and large ray.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import check_array, check_int, check_point, check_range

__all__ = ["DISC", "LARGE_RAY", "SMALL_RAY", "cone_dmin", "floret_fate", "ray_florets"]

DISC, SMALL_RAY, LARGE_RAY = 0, 1, 2
#: Floret pairs one vectorised block of :func:`cone_dmin` holds (about 100 MB of work arrays).
_MAX_BLOCK_PAIRS = 4_000_000


def cone_dmin(positions: np.ndarray, *, alpha_deg: float, centre=(0.0, 0.0, 0.0),
              centres: np.ndarray | None = None, full_angle: bool = False, literal: bool = False,
              block: int = 2048) -> np.ndarray:
    """d_min(P) of Eq. 6.2: distance to the nearest other floret inside the cone K(P).

    Parameters
    ----------
    positions : (n, 3) float64 array_like
        Floret positions.
    alpha_deg : float
        Cone opening angle in degrees, read as the half-angle by default (ERRATUM A.4).
    centre : (3,) float64 array_like
        Centre O of the head (used when ``centres`` is None).
    centres : (n, 3) float64 array_like, optional
        Per-floret centre O of the highest-level head or umbellet containing it (hierarchical heads).
    full_angle : bool
        Read ``alpha_deg`` as the full opening angle (half-angle = alpha / 2).
    literal : bool
        Use the inequality as printed (PQ . OP < cos alpha); kept only to document ERRATUM A.4.
    block : int
        Rows per vectorised block (memory bound, no effect on the result).

    Returns
    -------
    (n,) float64 ndarray
        d_min per floret; ``inf`` where the cone holds no other floret.

    References
    ----------
    .. [1] Owens 2016, Ch. 6, Eqs. 6.1–6.2. ERRATUM A.4: finite iff PQ^ . OP^ > cos(alpha), Q != P.
    """
    P = check_array("positions", positions, shape=(None, 3), max_abs=1e12)
    block = check_int("block", block, 1, 1_000_000)
    amax = 360.0 if full_angle else 180.0
    alpha = check_range("alpha_deg", alpha_deg, 0.0, amax)
    half = np.deg2rad(alpha / 2 if full_angle else alpha)
    if centres is None:
        O = np.broadcast_to(check_point("centre", centre), P.shape)
    else:
        O = check_array("centres", centres, shape=P.shape, max_abs=1e12)
    op = P - O
    nrm = np.linalg.norm(op, axis=1, keepdims=True)
    axis = np.divide(op, nrm, out=np.zeros_like(op), where=nrm > 0)
    cos_a = np.cos(half)
    n = P.shape[0]
    block = min(block, max(1, _MAX_BLOCK_PAIRS // max(n, 1)))   # memory bound: rows x n pairs per block
    out = np.full(n, np.inf)
    for start in range(0, n, block):
        stop = min(n, start + block)
        d = P[None, :, :] - P[start:stop, None, :]              # PQ for P in block, all Q
        dist = np.linalg.norm(d, axis=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            cosang = np.einsum("bqk,bk->bq", d, axis[start:stop]) / dist
        inside = cosang < cos_a if literal else cosang > cos_a   # ERRATUM A.4
        # [INFERRED] the floret at the centre O has no outward direction: its cone is all of space,
        # so it is never a ray floret (else every centripetally produced head gains one spurious ray)
        inside |= nrm[start:stop] == 0
        inside &= dist > 0                                       # Q != P
        out[start:stop] = np.where(inside, dist, np.inf).min(axis=1)
    return out


def ray_florets(positions: np.ndarray, *, alpha_deg: float, centre=(0.0, 0.0, 0.0),
                full_angle: bool = False) -> np.ndarray:
    """Boolean mask of ray florets by the simplest rule: no other floret in the cone (Fig. 6.1c)."""
    return np.isinf(cone_dmin(positions, alpha_deg=alpha_deg, centre=centre, full_angle=full_angle))


def floret_fate(d_min: np.ndarray, *, th_a: float | None = None, th_b: float | None = None,
                small_size: float = 0.5, large_size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Floret type and relative petal size from d_min and thresholds (spec 002 §4.6, Fig. 6.4).

    * no thresholds: ray iff d_min = inf (large ray);
    * Th_a only: ray iff d_min > Th_a; Th_b only: ray iff d_min > Th_b;
    * both: large ray if d_min > Th_b, small ray if Th_a < d_min <= Th_b with size proportional to
      d_min (``small_size * d_min / Th_b``, capped below ``large_size``), disc otherwise.

    Returns
    -------
    kind : (n,) int8 ndarray
        ``DISC`` (0), ``SMALL_RAY`` (1) or ``LARGE_RAY`` (2).
    size : (n,) float64 ndarray
        Relative ray-petal size (0 for disc florets); non-decreasing in d_min.
    """
    d = check_array("d_min", d_min, shape=(None,), finite=False)
    if np.any(np.isnan(d)) or np.any(d < 0):
        raise ValueError("d_min must be >= 0 (inf allowed), got NaN or a negative value")
    small_size = check_range("small_size", small_size, 0.0, 1e12)
    large_size = check_range("large_size", large_size, small_size, 1e12)
    if th_a is not None:
        th_a = check_range("th_a", th_a, 0.0, 1e12, low_open=True)
    if th_b is not None:
        th_b = check_range("th_b", th_b, 0.0 if th_a is None else th_a, 1e12, low_open=True)
    kind = np.zeros(d.size, np.int8)
    size = np.zeros(d.size)
    if th_a is None and th_b is None:
        kind[np.isinf(d)] = LARGE_RAY
    elif th_b is None:
        kind[d > th_a] = LARGE_RAY
    elif th_a is None:
        kind[d > th_b] = LARGE_RAY
    else:
        small = (d > th_a) & (d <= th_b)
        kind[small] = SMALL_RAY
        size[small] = np.minimum(small_size * d[small] / th_b, large_size)
        kind[d > th_b] = LARGE_RAY
    size[kind == LARGE_RAY] = large_size
    return kind, size

"""Tree distribution by deformation kernels (Eqs. 6.1–6.2, row/column inverse-CDF sampling, masks, species
choice) and Ripley's K (Eq. 6.6) (spec 004_treesketch §3.4.2, §3.4.3, §3.9)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._validation import (
    MAX_COORD,
    MAX_COUNT,
    check_array,
    check_choice,
    check_int,
    check_range,
    check_values,
)
from .terrain import MAX_CELLS, check_field, pair

__all__ = ["Distribution", "Species", "clustering_kernel", "distribute", "inhibitory_kernel", "ripley_k",
           "row_prefix", "sample_field"]


#: Largest field weight :func:`sample_field` accepts (the row sums stay finite for any field size).
MAX_WEIGHT = 2.0 ** 900


def _smooth(x: np.ndarray) -> np.ndarray:
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)  # 6x^5 - 15x^4 + 10x^3


def _check_kernel(d, r, a, s):
    d = check_values("d", d)
    r = check_range("r", r, 0.0, MAX_COORD)
    a = check_range("a", a, r, 2 * MAX_COORD, low_open=True)
    if not (a - r) > 1e-12 * max(a, 1.0):
        raise ValueError(f"a must exceed r by more than round-off, got r={r!r}, a={a!r}")
    return d, r, a


def clustering_kernel(d, *, r: float, a: float, s: float) -> np.ndarray:
    """Eq. 6.1: 0 for d <= r; (s - 1)(6x^5 - 15x^4 + 10x^3) + 1 with x = 1 - (d - r)/(a - r) for r < d <= a; 1 beyond.

    ``d`` distance to an existing tree, ``r`` its occupied radius, ``a`` the active radius (> r), ``s`` >= 0 the
    scale (values s > 1 attract: the kernel peaks at s just outside r).
    """
    d, r, a = _check_kernel(d, r, a, s)
    s = check_range("s", s, 0.0, 1e12)
    x = 1.0 - (d - r) / (a - r)
    k = (s - 1.0) * _smooth(np.clip(x, 0.0, 1.0)) + 1.0
    return np.where(d <= r, 0.0, np.where(d <= a, k, 1.0))


def inhibitory_kernel(d, *, r: float, a: float, s: float) -> np.ndarray:
    """Eq. 6.2: 0 for d <= r; 1 - 1/s + (1/s)(6x^5 - 15x^4 + 10x^3) with x = (d - r)/(a - r) for r < d <= a; 1 beyond.

    ERRATUM E9: s < 1 would give negative probabilities and is rejected; larger s = weaker inhibition.
    """
    d, r, a = _check_kernel(d, r, a, s)
    s = check_range("s", s, 1.0, 1e12)  # ERRATUM E9
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
    pts = check_array("points", points, shape=(None, 2), min_rows=2, max_abs=MAX_COORD)
    t = check_array("t", np.atleast_1d(np.asarray(t, float)), shape=(None,), max_abs=1e12)
    if box is not None:
        w, h = pair("box", box)
        A = w * h
        kd = cKDTree(np.mod(pts, [w, h]), boxsize=[w, h])
    else:
        if area is None:
            raise ValueError("area must be given when box is None")
        A = check_range("area", area, 0.0, 1e24, low_open=True)
        kd = cKDTree(pts)
    n = len(pts)
    # count_neighbors counts ordered pairs with d <= t, self pairs included; nextafter turns <= into <
    pairs = kd.count_neighbors(kd, np.nextafter(t, -np.inf)).astype(float) - n
    return A / n * pairs / n


# -- sampling a probability field (§3.4.2, Fig. 6.5) ----------------------------------------------------------
def row_prefix(field: np.ndarray) -> np.ndarray:
    """Prefix sums of the row sums with a leading 0: R[0] = 0, R[i+1] = R[i] + sum(field[i]) (Fig. 6.5)."""
    field = check_field("field", field, max_abs=MAX_WEIGHT)
    return np.concatenate([[0.0], np.cumsum(field.sum(1))])


def sample_field(field: np.ndarray, n: int = 1, *, mask: np.ndarray | None = None,
                 rng: int | np.random.Generator | None = None) -> np.ndarray:
    """Draw ``n`` positions from a probability field by inverse CDF, rows first (spec 004 §3.4.2).

    k ~ U(0, R[max]) picks row r with R[r] <= k < R[r+1] and y = r + (k - R[r]) / (R[r+1] - R[r]); then the
    column the same way within row r. Masked-out cells (``mask`` False: outside the brush, excluded, under water)
    have probability 0.

    Parameters
    ----------
    field : (ny, nx) float64 array
        Non-negative weights.
    n : int
        Samples.
    mask : (ny, nx) bool array, optional
        Allowed cells.
    rng : int or Generator or None

    Returns
    -------
    (n, 2) float64 array
        (x, y) in cell units: cell (i, j) spans [j, j+1) x [i, i+1).

    References
    ----------
    .. [1] Longay thesis §6.4.1, Fig. 6.5; spec 004 §3.4.2 (prefix with a leading 0 [INFERRED]).
    """
    field = check_field("field", field, max_abs=MAX_WEIGHT)
    n = check_int("n", n, 0, 10 ** 9)
    if n * (field.shape[1] + 1) > MAX_COUNT:
        raise ValueError(f"n must be at most {MAX_COUNT // (field.shape[1] + 1)} for a field {field.shape[1]} cells "
                         f"wide (memory), got {n}")
    if np.any(field < 0):
        raise ValueError("field must be non-negative")
    w = field if mask is None else np.where(check_array("mask", mask, shape=field.shape, dtype=bool), field, 0.0)
    rng = np.random.default_rng(rng)
    R = np.concatenate([[0.0], np.cumsum(w.sum(1))])
    if not R[-1] > 0:
        raise ValueError("field has no positive cell where the mask allows placement")
    k = rng.uniform(0.0, R[-1], n)
    r = np.clip(np.searchsorted(R, k, "right") - 1, 0, len(R) - 2)
    y = r + (k - R[r]) / (R[r + 1] - R[r])
    C = np.concatenate([np.zeros((w.shape[0], 1)), np.cumsum(w, 1)], 1)[r]  # (n, nx+1) prefix of each chosen row
    m = rng.uniform(0.0, 1.0, n) * C[:, -1]
    c = np.clip((C <= m[:, None]).sum(1) - 1, 0, w.shape[1] - 1)
    lo, hi = C[np.arange(n), c], C[np.arange(n), c + 1]
    x = c + np.where(hi > lo, (m - lo) / np.where(hi > lo, hi - lo, 1.0), 0.5)
    return np.column_stack([x, y])


@dataclass(frozen=True)
class Species:
    """A species for distribution: relative probability P_i, trunk width T_w (m; occupied radius S T_w / 2)
    and the range of the per-instance scale S (§3.2, §3.4.3)."""

    probability: float = 1.0
    trunk_width: float = 0.5
    scale: tuple[float, float] = (0.8, 1.2)


@dataclass(frozen=True)
class Distribution:
    """Placed trees: ``xy`` (N, 2) metres, ``species`` (N,) int, ``scale`` (N,), and the final ``fields``
    (n_species, ny, nx)."""

    xy: np.ndarray
    species: np.ndarray
    scale: np.ndarray
    fields: np.ndarray


def distribute(n: int, species: list[Species], interactions: dict, *, size: tuple[float, float] = (30.0, 30.0),
               shape: tuple[int, int] = (128, 128), mask: np.ndarray | None = None,
               rng: int | np.random.Generator | None = None) -> Distribution:
    """Add ``n`` trees one by one with the deformation-kernel method (spec 004 §3.4.2–3.4.3).

    Each addition chooses a species by cumulative P_i, a scale uniform in its range, a position from that
    species' field (times ``mask``) by :func:`sample_field`, then multiplies the kernel of every ordered pair
    (placed species i -> species j) into field j, centred at the new tree (r = S T_w / 2).

    Parameters
    ----------
    n : int
        Trees to add.
    species : list of Species
    interactions : dict {(i, j): (kind, s, a)}
        ``kind`` "cluster" (Eq. 6.1) or "inhibit" (Eq. 6.2), scale s, active radius a (m); missing pairs do not
        interact beyond the occupied radius.
    size : (float, float)
        Plot (width, depth) in metres, covered by the field.
    shape : (int, int)
        Field (ny, nx).
    mask : (ny, nx) bool array, optional
        Allowed cells (brush disc, not excluded, not under water).
    rng : int or Generator or None

    Returns
    -------
    Distribution

    References
    ----------
    .. [1] Longay thesis §6.4, Eqs. 6.1–6.2, Figs. 6.4–6.9; spec 004 §3.4 (ERRATUM E9 for s < 1).
    """
    n = check_int("n", n, 0, 10 ** 7)
    if not isinstance(species, (list, tuple)) or not species or \
            not all(isinstance(sp, Species) for sp in species):
        raise ValueError(f"species must be a list of at least one Species, got {species!r}"[:300])
    ns = len(species)
    if ns > 1000:
        raise ValueError(f"species must list at most 1000 species, got {ns}")
    if not isinstance(interactions, dict):
        raise ValueError(f"interactions must be a dict {{(i, j): (kind, s, a)}}, got {type(interactions).__name__}")
    probs = np.array([check_range(f"species[{i}].probability", sp.probability, 0.0, 1.0)
                      for i, sp in enumerate(species)])
    if not probs.sum() > 0:
        raise ValueError("at least one species probability must be positive")
    for i, sp in enumerate(species):
        check_range(f"species[{i}].trunk_width", sp.trunk_width, 0.0, MAX_COORD)
        lo, hi = pair(f"species[{i}].scale", sp.scale, high=1e6)
        if hi < lo:
            raise ValueError(f"species[{i}].scale must be (low, high) with low <= high, got {sp.scale!r}")
    kern = {}
    for key, val in interactions.items():
        if not isinstance(key, tuple) or len(key) != 2 or not isinstance(val, (tuple, list)) or len(val) != 3:
            raise ValueError(f"interactions must map (i, j) to (kind, s, a), got {key!r}: {val!r}")
        (i, j), (kind, sval, a) = key, val
        at = f"interactions[{key!r}]"                      # every error names the parameter and the entry
        check_int(f"{at} species", i, 0, ns - 1)
        check_int(f"{at} species", j, 0, ns - 1)
        kind = check_choice(f"{at} kind", kind, ("cluster", "inhibit"))
        sval = check_range(f"{at} s", sval, 1.0 if kind == "inhibit" else 0.0, 1e12)  # ERRATUM E9
        kern[(int(i), int(j))] = (kind, sval, check_range(f"{at} a", a, 0.0, 2 * MAX_COORD, low_open=True))
    ny, nx = pair("shape", shape, kind="int", low=1, high=8192)
    if ns * ny * nx > 2 * MAX_CELLS:
        raise ValueError(f"shape {shape!r} with {ns} species needs {ns * ny * nx} field cells, more than {2 * MAX_CELLS}")
    W, H = pair("size", size)
    allow = None if mask is None else check_array("mask", mask, shape=(ny, nx), dtype=bool)
    rng = np.random.default_rng(rng)
    fields = np.ones((ns, ny, nx))
    cx, cy = W / nx, H / ny
    xs, ys = (np.arange(nx) + 0.5) * cx, (np.arange(ny) + 0.5) * cy
    cum = np.cumsum(probs)
    out_xy, out_sp, out_sc = np.zeros((n, 2)), np.zeros(n, np.int64), np.zeros(n)
    for t in range(n):
        i = int(np.searchsorted(cum, rng.uniform(0.0, cum[-1]), "right"))
        i = min(i, ns - 1)
        S = rng.uniform(*species[i].scale)
        p = sample_field(fields[i], 1, mask=allow, rng=rng)[0] * (cx, cy)
        out_xy[t], out_sp[t], out_sc[t] = p, i, S
        r = S * species[i].trunk_width / 2
        for j in range(ns):
            kind, sval, a = kern.get((i, j), ("inhibit", 1.0, r + 1e-9))
            a = max(a, r + 1e-9)
            x0, x1 = np.searchsorted(xs, p[0] - a), np.searchsorted(xs, p[0] + a, "right")
            y0, y1 = np.searchsorted(ys, p[1] - a), np.searchsorted(ys, p[1] + a, "right")
            if x0 >= x1 or y0 >= y1:
                continue
            d = np.hypot(xs[None, x0:x1] - p[0], ys[y0:y1, None] - p[1])
            k = (clustering_kernel if kind == "cluster" else inhibitory_kernel)(d, r=r, a=a, s=sval)
            fields[j, y0:y1, x0:x1] *= k
            if fields[j, y0:y1, x0:x1].max() > 2.0 ** 800:  # attraction piles up: rescale by an exact power of 2
                fields[j] *= 2.0 ** -400  # (relative weights, hence every later sample, unchanged)
    return Distribution(out_xy, out_sp, out_sc, fields)

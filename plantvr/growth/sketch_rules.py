"""TreeSketch growth rules as array functions (spec 004_treesketch §1.4.1, §1.4.4–1.4.7, §2.11).

Eq. 4.3 shoot lengths (:func:`shoot_lengths`), the barycentric weights and set-point tropism of Eq. 4.5
(:func:`barycentric`, :func:`set_point_tropism`), the deflection angle of §1.4.7 (:func:`deflect_heading`),
autonomous attraction points of §1.4.1 (:func:`autonomous_points`), gravimorphism Eqs. 4.6–4.7
(:func:`ellipse_distance`, :func:`gravimorphism`) and the cut of a prune at its branching point, §2.11
(:func:`branch_point`). Arrays in, arrays out; :class:`~plantvr.growth.sketch.SketchEngine` applies them.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validation import MAX_COORD, MAX_COUNT, check_array, check_int, check_points, check_range, check_values
from .directions import _rotate, normalize
from .sketch_params import ELLIPSE_RANGE, _check_bool

__all__ = [
    "autonomous_points",
    "barycentric",
    "branch_path",
    "branch_point",
    "deflect_heading",
    "ellipse_distance",
    "gravimorphism",
    "set_point_tropism",
    "shed_roots",
    "shoot_lengths",
]

_Y = np.array([0.0, 1.0, 0.0])

def _rows3(name: str, value: Any) -> np.ndarray:
    """``value`` as a finite (N, 3) float64 array (a single (3,) row is promoted)."""
    try:
        a = np.asarray(value, float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an (N, 3) array, got {type(value).__name__}") from None
    return check_array(name, np.atleast_2d(a), shape=(None, 3))


def barycentric(alpha: float, beta: float, gamma: float) -> tuple[float, float, float]:
    """Normalise non-negative weights to the triangle alpha + beta + gamma = 1 (Eq. 4.5, ERRATUM E7).

    Raises ``ValueError`` when a weight is negative or all are zero.
    """
    a = check_range("alpha (w_heading)", alpha, 0.0, np.inf)
    b = check_range("beta (w_tropism)", beta, 0.0, np.inf)
    c = check_range("gamma (w_env)", gamma, 0.0, np.inf)
    s = a + b + c
    if s <= 0:
        raise ValueError(f"growth weights must not all be zero, got {(alpha, beta, gamma)!r}")
    if not math.isfinite(s):  # huge weights: normalise by the largest first (1e308 thrice is (1/3, 1/3, 1/3))
        m = max(a, b, c)
        a, b, c = a / m, b / m, c / m
        s = a + b + c
    return a / s, b / s, c / s


def set_point_tropism(heading: np.ndarray, theta: float, *, main_axis: np.ndarray | None = None,
                      trunk_up: bool = False, rng: int | np.random.Generator | None = None,
                      eps: float = 1e-3) -> np.ndarray:
    """Tropism vectors **T** = cos(theta) **Y** + sin(theta) **h** (spec 004 §1.4.5, Eq. 4.5).

    Parameters
    ----------
    heading : (B, 3) float64 array
        Current bud headings **H** (unit).
    theta : float
        Set-point angle from the vertical, radians, in [0, pi] (0 = up, pi = down, pi/2 = plagiotropism).
    main_axis : (B,) bool array, optional
        Buds on the main axis (order 0); with ``trunk_up`` their **T** is **Y**.
    trunk_up : bool
        The trunk-up switch (Fig. 4.19).
    rng : int or Generator or None
        Draws the random horizontal plane for near-vertical headings (|H x Y| < eps).

    Returns
    -------
    (B, 3) float64 array of unit vectors.

    References
    ----------
    .. [1] Longay thesis §4.4.2, Eq. 4.5; spec 004 §1.4.5 (closed form and eps [INFERRED]).
    """
    theta = check_range("theta", theta, 0.0, math.pi)
    H = _rows3("heading", heading)
    if main_axis is not None:
        main_axis = check_array("main_axis", main_axis, shape=(len(H),), dtype=bool)
    trunk_up = _check_bool("trunk_up", trunk_up)
    eps = check_range("eps", eps, 0.0, 1.0)
    hp = H - (H @ _Y)[:, None] * _Y
    near = np.linalg.norm(np.cross(H, _Y), axis=1) < eps
    if near.any():
        phi = np.random.default_rng(rng).uniform(0.0, 2.0 * math.pi, int(near.sum()))
        hp[near] = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], 1)
    hp = normalize(hp, fallback=np.array([1.0, 0.0, 0.0]))
    T = math.cos(theta) * _Y + math.sin(theta) * hp
    if trunk_up and main_axis is not None:
        T[np.asarray(main_axis, bool)] = _Y
    return T


def deflect_heading(heading: np.ndarray, lateral: np.ndarray, delta: float) -> np.ndarray:
    """Rotate the continuing heading by -delta about **H** x **lateral**, away from the lateral bud (§1.4.7).

    Rows whose heading and lateral direction are parallel are returned unchanged. ``delta`` in radians.
    """
    H = _rows3("heading", heading)
    L = _rows3("lateral", lateral)
    if len(L) not in (1, len(H)):
        raise ValueError(f"lateral must have 1 or {len(H)} rows like heading, got {len(L)}")
    delta = check_range("delta", delta, -2 * math.pi, 2 * math.pi)
    axis = np.cross(H, L)
    n = np.linalg.norm(axis, axis=1)
    out = H.copy()
    ok = n > 1e-12
    if ok.any() and delta != 0.0:
        out[ok] = _rotate(H[ok], axis[ok] / n[ok, None], -delta)
    return normalize(out)


def shoot_lengths(vigor: np.ndarray, n_max: int) -> np.ndarray:
    """Eq. 4.3: n = floor(v / v_max * n_max) internodes per enabled bud; v_max = max over the given buds.

    ``vigor`` holds the vigor of the *enabled* buds only. The bud with v = v_max gets exactly n_max; a bud
    with v < v_max / n_max gets 0 (dormant). All-zero vigor gives zeros.
    """
    n_max = check_int("n_max", n_max, 0, 10_000)
    v = check_array("vigor", vigor, shape=(None,))
    if v.size == 0:
        return np.zeros(0, np.int64)
    vmax = float(v.max())
    if not vmax > 0:
        return np.zeros(v.shape, np.int64)
    n = np.floor(v / vmax * n_max).astype(np.int64)
    n[v == vmax] = n_max  # exact for the most vigorous bud, whatever the rounding
    return n


def autonomous_points(pos: np.ndarray, heading: np.ndarray, vigor: np.ndarray, *, density: int,
                      r_in: float, r_out: float, half_angle: float,
                      rng: int | np.random.Generator | None = None) -> np.ndarray:
    """Attraction points for autonomous growth (§1.4.1 [INFERRED]): k_i = 1 + floor(K v_i / v_max) per bud,
    uniform in the cone sector between radii ``r_in`` and ``r_out`` around each heading (half angle, radians).

    Returns a (sum k_i, 3) array, buds in input order.
    """
    density = check_int("density", density, 0, 10_000)
    r_in = check_range("r_in", r_in, 0.0, np.inf)
    r_out = check_range("r_out", r_out, r_in, np.inf)
    half_angle = check_range("half_angle", half_angle, 0.0, math.pi)
    if r_out > MAX_COORD:
        raise ValueError(f"r_out must be in [{r_in}, {MAX_COORD:g}], got {r_out!r}")
    pos = check_points("pos", pos)
    H = normalize(check_array("heading", heading, shape=(len(pos), 3)))
    v = check_array("vigor", vigor, shape=(len(pos),))
    if len(pos) * (1 + density) > MAX_COUNT:
        raise ValueError(f"pos and density ask for up to {len(pos) * (1 + density)} points, more than {MAX_COUNT}")
    rng = np.random.default_rng(rng)
    if len(pos) == 0:
        return np.zeros((0, 3))
    vmax = float(v.max())
    k = 1 + (np.floor(density * v / vmax).astype(np.int64) if vmax > 0 else np.zeros(len(v), np.int64))
    idx = np.repeat(np.arange(len(pos)), k)
    m = len(idx)
    cz = rng.uniform(math.cos(half_angle), 1.0, m)
    phi = rng.uniform(0.0, 2.0 * math.pi, m)
    r = (rng.uniform(r_in ** 3, r_out ** 3, m)) ** (1.0 / 3.0)
    h = H[idx]
    a = normalize(np.cross(h, _Y), fallback=np.array([1.0, 0.0, 0.0]))
    a = normalize(a - np.sum(a * h, 1, keepdims=True) * h, fallback=np.array([0.0, 0.0, 1.0]))
    b = np.cross(h, a)
    sz = np.sqrt(np.maximum(1.0 - cz * cz, 0.0))
    d = cz[:, None] * h + sz[:, None] * (np.cos(phi)[:, None] * a + np.sin(phi)[:, None] * b)
    return pos[idx] + r[:, None] * d


def ellipse_distance(chi: np.ndarray, *, s_v: float, s_p: float, e_v: float) -> np.ndarray:
    """Distance d from the axis to the control ellipse along the polar direction chi (radians from +V).

    Closed form of spec 004 §1.4.6 [INFERRED]: the largest real root of A t^2 + B t + C = 0 with
    A = cos^2 chi / s_v^2 + sin^2 chi / s_p^2, B = -2 e_v cos chi / s_v^2, C = e_v^2 / s_v^2 - 1, clamped >= 0;
    0 where the ray misses the ellipse. The neutral ellipse (1, 1, 0) gives d = 1.
    """
    lo, hi = ELLIPSE_RANGE
    s_v = check_range("s_v", s_v, lo, hi)
    s_p = check_range("s_p", s_p, lo, hi)
    e_v = check_range("e_v", e_v, -hi, hi)
    chi = check_values("chi", chi)
    c, s = np.cos(chi), np.sin(chi)
    A = c * c / s_v ** 2 + s * s / s_p ** 2
    B = -2.0 * e_v * c / s_v ** 2
    C = e_v ** 2 / s_v ** 2 - 1.0
    disc = B * B - 4.0 * A * C
    root = (-B + np.sqrt(np.maximum(disc, 0.0))) / (2.0 * A)
    return np.where(disc >= 0.0, np.maximum(root, 0.0), 0.0)


def gravimorphism(parent_heading: np.ndarray, bud_dir: np.ndarray, *, s_v: float = 1.0, s_p: float = 1.0,
                  e_v: float = 0.0) -> np.ndarray:
    """Eq. 4.6: b = cos^2 tau + d sin^2 tau for lateral buds on axes with headings ``parent_heading`` (B, 3).

    tau = angle(H, Y); chi = the bud's polar angle about H measured from **V** (the upward normal of H in its
    vertical plane) toward **P** = **V** x **H**; d = :func:`ellipse_distance`. Multiply L^kappa by b (Eq. 4.7).

    References
    ----------
    .. [1] Longay thesis §4.4.3, Eqs. 4.6–4.7; spec 004 §1.4.6, §5.1 (HVP frame), ERRATUM E1 (epitony = upper).
    """
    H = normalize(_rows3("parent_heading", parent_heading))
    D = _rows3("bud_dir", bud_dir)
    if len(D) != len(H):
        raise ValueError(f"bud_dir must have {len(H)} rows like parent_heading, got {len(D)}")
    cos_t = np.clip(H @ _Y, -1.0, 1.0)
    V = normalize(_Y - cos_t[:, None] * H, fallback=np.array([1.0, 0.0, 0.0]))
    P = np.cross(V, H)
    chi = np.arctan2(np.sum(D * P, 1), np.sum(D * V, 1))
    d = ellipse_distance(chi, s_v=s_v, s_p=s_p, e_v=e_v)
    return cos_t ** 2 + d * (1.0 - cos_t ** 2)


def branch_path(parent: np.ndarray, base: int, end: int) -> np.ndarray:
    """Nodes from ``base`` down to ``end`` (``end`` in the subtree of ``base``) of a forward-ordered tree."""
    base = check_int("base", base, 0, len(parent) - 1)
    end = check_int("end", end, 0, len(parent) - 1)
    path = [end]
    while path[-1] != base:
        if path[-1] <= 0:
            raise ValueError(f"end node {end} is not in the subtree of base node {base}")
        path.append(int(parent[path[-1]]))
    return np.array(path[::-1], np.int64)


def branch_point(parent: np.ndarray, alive: np.ndarray, node: int, *, protected=()) -> int:
    """Where a prune of ``node`` cuts: the first node at or above ``node`` whose parent has another live child
    (the branch's start at its nearest proximal branching point, spec 004 §2.11 [INFERRED: proximal]).

    A node in ``protected`` (width constraints) on the way up stops the walk just above it, so a prune above a
    constraint leaves a stub (§5.3.3). Returns -1 when nothing may be cut (``node`` itself protected, the
    base point or the first internode). ``parent`` (n,) int, ``alive`` (n,) bool.
    """
    parent = check_array("parent", parent, shape=(None,), dtype=np.int64)
    n = len(parent)
    if n and (np.any(parent >= np.arange(n)) or np.any(parent < -1)):
        raise ValueError("parent must be an (n,) int array with -1 <= parent[i] < i")
    alive = check_array("alive", alive, shape=(n,), dtype=bool)
    node = check_int("node", node, 0, n - 1)
    if not alive[node]:
        raise ValueError(f"node {node} is not alive")
    protected = {check_int("protected node", k, 0, n - 1) for k in protected}
    if node <= 1 or node in protected:
        return -1
    live_children = np.bincount(parent[np.asarray(alive, bool) & (parent >= 0)], minlength=len(parent))
    c = node
    while True:
        p = int(parent[c])
        if p in protected or live_children[p] >= 2:
            return c
        if p <= 1:  # reached the first internode without a branching point: cut at the tapped node
            return node
        c = p


def shed_roots(parent: np.ndarray, alive: np.ndarray, main_child: np.ndarray, vigor: np.ndarray, threshold: float,
               *, protected=()) -> np.ndarray:
    """Lateral branches to shed (spec 004 §1.4.8 [INFERRED] normalised form): the branch rooted at internode i
    is shed when ``(v_i / v_base) / (N_i / N_total) < Th``, N the live internode counts (of i's subtree, of the
    tree). ``Th <= 0`` never sheds; a branch holding a ``protected`` node (width constraints, the selection),
    or on the path supporting one, is kept. Arrays (n,) of a forward-ordered tree (``main_child`` the terminal
    slot of each node); returns the root nodes, ascending."""
    n = len(parent)
    none = np.zeros(0, np.int64)
    n_internodes = int(alive[1:].sum())
    if threshold <= 0 or n_internodes < 2 or not vigor[0] > 0:
        return none
    size = np.ones(n)
    size[~alive] = 0
    for i in range(n - 1, 1, -1):  # subtree internode counts
        if alive[i]:
            size[parent[i]] += size[i]
    is_lat = alive & (parent >= 0) & (main_child[np.maximum(parent, 0)] != np.arange(n))
    is_lat[:2] = False
    with np.errstate(divide="ignore", invalid="ignore"):  # dead nodes (size 0) are never roots
        ratio = (vigor / vigor[0]) / (size / n_internodes)
    roots = np.flatnonzero(is_lat & (ratio < threshold))
    keep = np.zeros(n, bool)
    for k in protected:
        while k >= 0 and not keep[k]:
            keep[k] = True
            k = parent[k]
    return roots[~keep[roots]]

"""TreeSketch growth variants on the Tree Wand engine (spec 004_treesketch §1.4.1, §1.4.4, §1.4.5, §1.4.7, §1.5).

:class:`SketchEngine` is a small subclass of :class:`plantvr.growth.engine.GrowthEngine` that changes only
what the TreeSketch model changes:

* relative resource scaling, Eq. 4.3: an enabled bud grows n = floor(v / v_max * n_max) internodes per
  step, v_max the largest vigor over the *enabled* buds (buds with at least one selecting marker);
* growth direction Eq. 4.5 with barycentric weights (alpha, beta, gamma) = (w_heading, w_tropism, w_env)
  normalised to sum 1, applied once per new internode with **T** recomputed from the updated heading and **E**
  fixed per shoot (§1.4.5 [INFERRED]);
* set-point tropism **T** = cos(theta) **Y** + sin(theta) **h** (``tropism_angle`` = theta), a random horizontal
  plane when **H** is near vertical, and the trunk-up switch (**T** = **Y** on the main axis);
* deflection angle delta (§1.4.7, placement "creation"): the continuing heading at every new node is rotated
  by -delta about **H** x (lateral direction), i.e. away from the lateral bud;
* marker policy: ``"directed"`` keeps user points until consumed (no ageing), ``"autonomous"`` generates
  k_i = 1 + floor(K v_i / v_max) points in each bud's perception sector before a step and clears all points
  after it (§1.4.1);
* gravimorphism, Eqs. 4.6–4.7: the control ellipse (s_v, s_p, e_v) gives each lateral bud a factor b, written to
  the engine's per-node ``tree.light_factor`` so that the signal is Q = b L^kappa (§1.4.6);
* the shedding threshold Th (§1.4.8 [INFERRED] normalised form) in place of Tree Wand's shedding, with
  constrained branches and the selected branch protected;
* sketch-based tropism (§2.7): **T** = the mean stroke direction of a bud's selecting points;
* selective growth (§2.8, V11): only buds in the subtree of the selected node grow, every node still occupies;
* pipe-model widths with width constraints (§2.10) and pruning at the nearest branching point (§2.11).

Randomness is drawn from generators seeded by (seed, iteration, purpose), so a replay from the same seed
and the same commands is bit-identical.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validation import (
    MAX_COORD,
    MAX_COUNT,
    check_array,
    check_int,
    check_point,
    check_points,
    check_range,
    check_values,
)
from ..params import PARAM_BY_NAME, TREEWAND, WINDOWS, Param, ParamTable, check_params
from .bending import BendResult, bend_path, pipe_widths
from .directions import _rotate, bud_headings, normalize, transport_lateral
from .engine import GrowthEngine, _Buds, marker_counts, sum_per_bud
from .tree import BUD, NO_SLOT

__all__ = [
    "SKETCH_ROWS",
    "TREESKETCH",
    "SketchEngine",
    "autonomous_points",
    "barycentric",
    "branch_point",
    "deflect_heading",
    "ellipse_distance",
    "gravimorphism",
    "set_point_tropism",
    "shoot_lengths",
    "split_values",
]

_Y = np.array([0.0, 1.0, 0.0])

#: Largest |coarse index| and pyramid offset of the shadow grid (plantvr.growth.shadow): nodes farther out than
#: (GRID_COARSE - 2) * fine_cells - GRID_OFFSET cells from the origin cannot be indexed (issue 20:
#: ``base_length = 1e-20`` after growth crashed ``ShadowGrid.add``).
try:
    from .shadow import COARSE_LIMIT as GRID_COARSE
    from .shadow import MAX_OFFSET as GRID_OFFSET
except ImportError:  # pragma: no cover - an older shadow grid without stated bounds
    GRID_COARSE, GRID_OFFSET = 2 ** 14, 64
#: Bounds of the gravimorphism ellipse's semi-axes and offset: beyond them Eq. 4.6 overflows to NaN vigor.
ELLIPSE_RANGE = (1e-6, 1e6)
#: Most neighbour sites a crown region may list (the region test is a (points x sites) distance table).
MAX_SITES = 10_000


def _row(name, kind, default, ref, doc, **kw) -> Param:
    return Param(name=name, kind=kind, default=default, window="sketch", ref=ref, doc=doc, **kw)


#: The TreeSketch rows of :data:`TREESKETCH` (spec 004 §1.4, §2.3, §2.5): the scalar :class:`SketchEngine` options
#: (the gravimorphism ellipse as its three numbers) and the stroke brush of :class:`~plantvr.growth.sketch_tools.
#: StrokeEmitter`. The engine's option checks and the architecture panel read their ranges from here.
SKETCH_ROWS: tuple[Param, ...] = (
    _row("n_max", int, 3, "§1.4.4 Eq. 4.3", "Maximum shoot length: internodes per step of the most vigorous bud.",
         symbol="n_max", range=(1, 1000)),
    _row("deflection", float, 0.0, "§1.4.7", "Deflection angle of the continuing heading, away from the lateral bud.",
         symbol="δ", unit="deg", range=(0.0, 90.0)),
    _row("trunk_up", bool, False, "§1.4.5 Fig. 4.19", "Tropism straight up on the main axis.", range=(0, 1)),
    _row("stroke_tropism", bool, False, "§2.7", "Tropism follows the stroke direction of a bud's selecting points.",
         range=(0, 1)),
    _row("mode", str, "directed", "§1.4.1", "Marker policy: user points kept until consumed, or generated per step.",
         choices=("directed", "autonomous")),
    _row("point_density", int, 4, "§1.4.1", "K of autonomous growth: up to 1 + K points per bud and step.",
         symbol="K", range=(0, 1000)),
    _row("ellipse_sv", float, 1.0, "§1.4.6 Eq. 4.6", "Gravimorphism control ellipse: semi-axis along V (up).",
         symbol="s_v", range=ELLIPSE_RANGE, slider=(0.05, 20.0), log=True),
    _row("ellipse_sp", float, 1.0, "§1.4.6 Eq. 4.6", "Gravimorphism control ellipse: semi-axis along P (side).",
         symbol="s_p", range=ELLIPSE_RANGE, slider=(0.05, 20.0), log=True),
    _row("ellipse_ev", float, 0.0, "§1.4.6 Eq. 4.6", "Gravimorphism control ellipse: offset of its centre along V.",
         symbol="e_v", range=(-ELLIPSE_RANGE[1], ELLIPSE_RANGE[1]), slider=(-10.0, 10.0)),
    _row("shed_threshold", float, 0.0, "§1.4.8", "Shedding threshold Th of the normalised rule (0: never shed).",
         symbol="Th", range=(0.0, 1e12), slider=(0.0, 10.0)),
    _row("stroke_rate", float, 20.0, "§2.5", "Brush: points per unit volume per second of brushing.",
         range=(0.0, 1e9), low_open=True, slider=(0.1, 1000.0), log=True),
    _row("stroke_spacing", float, 0.5, "§2.5", "Sketch (brush radius 0): distance between points on the stroke.",
         unit="m", range=(1e-9, MAX_COORD), slider=(0.01, 10.0), log=True),
)
_ROW = {p.name: p for p in SKETCH_ROWS}
#: The TreeSketch parameter table: every Tree Wand row, then :data:`SKETCH_ROWS`.
TREESKETCH = ParamTable("treesketch", [*TREEWAND.params, *SKETCH_ROWS],
                        {**WINDOWS, "sketch": ("TreeSketch", "#8e44ad")})
#: SketchEngine options that are rows of :data:`TREESKETCH` (``ellipse`` is the three ``ellipse_*`` rows).
TABLE_OPTIONS = ("n_max", "deflection", "trunk_up", "stroke_tropism", "mode", "point_density", "ellipse",
                 "shed_threshold")
_ELLIPSE_ROWS = ("ellipse_sv", "ellipse_sp", "ellipse_ev")


def _check_bool(name: str, value: Any) -> bool:
    """``value`` as a bool; only True/False (or 0/1) are accepted, so ``"no"`` is not silently True."""
    if isinstance(value, (bool, np.bool_)) or (isinstance(value, (int, np.integer)) and value in (0, 1)):
        return bool(value)
    raise ValueError(f"{name} must be True or False, got {value!r}")


def _rows3(name: str, value: Any) -> np.ndarray:
    """``value`` as a finite (N, 3) float64 array (a single (3,) row is promoted)."""
    try:
        a = np.asarray(value, float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an (N, 3) array, got {type(value).__name__}") from None
    return check_array(name, np.atleast_2d(a), shape=(None, 3))


def grid_reach(params: dict[str, Any]) -> float:
    """Largest |x| or |z| (and |y| / 3) a node or marker may have for the shadow grid of ``params`` to index it."""
    return ((GRID_COARSE - 2) * params["fine_cells"] - GRID_OFFSET) * params["base_length"]


def check_grid_reach(params: dict[str, Any], pos: np.ndarray, *, name: str = "base_length") -> None:
    """Raise ``ValueError`` (naming ``name``) unless every point of ``pos`` (N, 3) lies where the shadow grid of
    ``params`` (cell ``base_length``, ``fine_cells``) can index it: |x|, |z| and |y| / 3 within :func:`grid_reach`."""
    if not len(pos):
        return
    ext = max(float(np.abs(pos[:, [0, 2]]).max()), float(np.abs(pos[:, 1]).max()) / 3.0)
    reach = grid_reach(params)
    if ext > reach:
        if name == "base_length":
            raise ValueError(f"base_length must be at least {params['base_length'] * ext / reach:.3g} for a tree "
                             f"reaching {ext:.6g} from the origin (the shadow grid indexes "
                             f"{reach / params['base_length']:.0f} cells), got {params['base_length']!r}")
        raise ValueError(f"{name} must lie within {reach:.6g} of the origin (|y| within {3 * reach:.6g}) for the "
                         f"shadow grid of base_length {params['base_length']!r}, got {ext:.6g}")


def split_values(values: dict[str, Any], ellipse=(1.0, 1.0, 0.0)) -> tuple[dict[str, Any], dict[str, Any]]:
    """:data:`TREESKETCH` values, checked and split into engine parameters (the Tree Wand rows) and
    :class:`SketchEngine` options; the ``ellipse_*`` rows become ``ellipse`` when any is given (the others
    taken from ``ellipse``); the stroke rows belong to neither and are dropped."""
    values = TREESKETCH.validate(values)
    params = {k: v for k, v in values.items() if k in TREEWAND}
    opts = {k: v for k, v in values.items() if k in TABLE_OPTIONS}
    if any(k in values for k in _ELLIPSE_ROWS):
        opts["ellipse"] = tuple(values.get(k, e) for k, e in zip(_ELLIPSE_ROWS, ellipse))
    return params, opts


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


class SketchEngine(GrowthEngine):
    """:class:`GrowthEngine` with the TreeSketch variants (spec 004 §1.4–1.5, §2.7–2.11) as options.

    Parameters
    ----------
    params : dict
        The engine's parameter dict (``plantvr.params.defaults()``); ``tropism_angle`` (degrees) is the
        set-point theta, ``w_heading``/``w_tropism``/``w_env`` the barycentric (alpha, beta, gamma),
        ``light_exponent`` kappa (ERRATUM E6: one parameter for Eqs. 4.2 and 4.7).
    rng : int or Generator or None
        Seed; every random draw is derived from (seed, iteration, purpose).
    n_max : int
        Maximum shoot length of Eq. 4.3 (internodes per step), >= 1.
    trunk_up : bool
        **T** = **Y** on the main axis.
    deflection : float
        Deflection angle delta, degrees in [0, 90].
    mode : {"directed", "autonomous"}
        Marker policy (§1.4.1).
    point_density : int
        K of autonomous growth.
    ellipse : (s_v, s_p, e_v)
        Gravimorphism control ellipse (Eq. 4.6); (1, 1, 0) is neutral (b = 1).
    shed_threshold : float
        Th >= 0 of the normalised shedding rule (0: never shed), replacing Tree Wand's shedding.
    stroke_tropism : bool
        Sketch-based tropism: **T** follows the stroke direction of a bud's selecting points (§2.7).
    region : dict or None
        The tree's crown space in a landscape (spec §3.5, §3.7): ``{"sites": (K, 2) neighbour bases (x, z) relative
        to this tree's base, "weights": (K,) their weights, "weight": this tree's weight, "h_max": height cap}``.
        Autonomous points outside the multiplicatively weighted Voronoi cell of the base (|q| / w <= |q - s_k| /
        w_k for every k) or above ``h_max`` are dropped, and growth halts once a node reaches ``h_max``.
    asymmetry : (2,) float or None
        Neighbourhood-asymmetry vector **V** = (x, z) of a landscape tree (Eq. 6.4); the tropism becomes
        **F** = (1 - a)(**V** + **T**) + a **T**, a = (h / h_max)^(1/2) with h the tree height and h_max the region's
        (Eq. 6.5; no fade without a region), normalised before Eq. 4.5.
    depth : dict or None
        Depth constraint (App. B): ``{"normal": (3,), "depth": d}``; attraction points farther than d from the
        plane through the tree base with that normal (the view direction when enabled) are removed before they
        affect growth.
    bud_lifetime : int or None
        Lateral buds still dormant this many iterations after their node was made are dropped (the slot becomes
        absent), which bounds the bud count (§1.4.9 [INFERRED, not in the thesis]); None keeps every bud.
    """

    def __init__(self, params: dict[str, Any], *, rng: int | np.random.Generator | None = None, n_max: int = 3,
                 trunk_up: bool = False, deflection: float = 0.0, mode: str = "directed", point_density: int = 4,
                 ellipse: tuple[float, float, float] = (1.0, 1.0, 0.0), shed_threshold: float = 0.0,
                 stroke_tropism: bool = False, bud_lifetime: int | None = None, region: dict | None = None,
                 depth: dict | None = None, asymmetry=None):
        params = check_params(params)
        opts = self._check_options(dict(n_max=n_max, trunk_up=trunk_up, deflection=deflection, mode=mode,
                                        point_density=point_density, ellipse=ellipse, shed_threshold=shed_threshold,
                                        stroke_tropism=stroke_tropism, bud_lifetime=bud_lifetime, region=region,
                                        depth=depth, asymmetry=asymmetry))
        barycentric(params["w_heading"], params["w_tropism"], params["w_env"])
        if isinstance(rng, (int, np.integer)) and not isinstance(rng, (bool, np.bool_)):
            seed = check_int("rng (seed)", rng, 0, 2 ** 63 - 1)
        elif rng is None or isinstance(rng, (np.random.Generator, np.random.SeedSequence)):
            seed = int(np.random.default_rng(rng).integers(2 ** 62))
        else:
            raise ValueError(f"rng must be a seed in [0, {2 ** 63 - 1}], a numpy Generator or None, got {rng!r}")
        self.sketch = opts
        self.seed = seed
        self.selected: int | None = None
        self.width_constraints: dict[int, float] = {}
        self.width_info = None
        self._stroke_dirs: dict[bytes, np.ndarray] = {}
        self.bud_override: dict[tuple[int, int], np.ndarray] = {}
        super().__init__(params, rng=np.random.default_rng([seed, 0x5EED]))

    @classmethod
    def _option_checks(cls) -> dict[str, Any]:
        return {"n_max": _ROW["n_max"].check,
                "trunk_up": lambda v: _check_bool("trunk_up", v),
                "deflection": _ROW["deflection"].check,
                "mode": lambda v: _ROW["mode"].check(v if isinstance(v, str) else repr(v)[:80]),
                "point_density": _ROW["point_density"].check,
                "ellipse": cls._check_ellipse,
                "shed_threshold": _ROW["shed_threshold"].check,
                "stroke_tropism": lambda v: _check_bool("stroke_tropism", v),
                "bud_lifetime": cls._check_life, "region": cls._check_region,
                "depth": cls._check_depth, "asymmetry": cls._check_asym}

    @classmethod
    def _check_options(cls, opts: dict[str, Any]) -> dict[str, Any]:
        """Checked copies of TreeSketch options (constructor keywords); nothing is written."""
        checks = cls._option_checks()
        new = {}
        for k, v in opts.items():
            if k not in checks:
                raise ValueError(f"unknown SketchEngine option {k!r}; expected one of {sorted(checks)}")
            new[k] = checks[k](v)
        return new

    @staticmethod
    def _check_asym(v) -> list | None:
        if v is None:
            return None
        return check_array("asymmetry", v, shape=(2,), max_abs=MAX_COORD).tolist()

    @staticmethod
    def _check_depth(depth) -> dict | None:
        if depth is None:
            return None
        if not isinstance(depth, dict) or set(depth) != {"normal", "depth"}:
            raise ValueError(f"depth must be a dict with keys normal, depth, got {depth!r}")
        n = check_point("depth normal", depth["normal"])
        if not np.linalg.norm(n) > 1e-12:
            raise ValueError(f"depth normal must be a non-zero vector, got {n.tolist()}")
        return {"normal": (n / np.linalg.norm(n)).tolist(),
                "depth": check_range("depth", depth["depth"], 0.0, 1e12)}

    def in_depth(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: points inside the depth slab (all True without a depth constraint)."""
        pts = np.asarray(points, float).reshape(-1, 3)
        d = self.sketch["depth"]
        if d is None:
            return np.ones(len(pts), bool)
        return np.abs((pts - self.tree.pos[0]) @ np.asarray(d["normal"])) <= d["depth"]

    def add_markers(self, points: np.ndarray) -> None:
        """Append markers (age 0); with a depth constraint, points outside the slab are dropped (V16).

        ``points`` (N, 3) (or a flat array of N * 3 values) inside ±``MAX_COORD``; at most ``MAX_COUNT`` markers.
        """
        points = self._check_marker_points("points", points)
        if len(self.markers) + len(points) > MAX_COUNT:
            raise ValueError(f"points would make {len(self.markers) + len(points)} markers, more than {MAX_COUNT}")
        check_grid_reach(self.params, points, name="points")
        if self.__dict__.get("sketch") is not None and self.sketch["depth"] is not None:
            points = points[self.in_depth(points)]
        super().add_markers(points)

    @staticmethod
    def _check_marker_points(name: str, points) -> np.ndarray:
        try:
            arr = np.asarray(points, float)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be an (N, 3) array of points, got {type(points).__name__}") from None
        if arr.ndim == 1 and arr.size % 3 == 0:  # a flat list of coordinates, as before
            arr = arr.reshape(-1, 3)
        return check_points(name, arr)

    def paint(self, center: np.ndarray, radius: float, n_darts: int | None = None) -> int:
        """Throw Poisson darts in the brush sphere (§2.2), checked at the door; returns the markers added."""
        center = check_point("center", center)
        radius = check_range("radius", radius, 0.0, MAX_COORD, low_open=True)
        if n_darts is not None:
            n_darts = check_int("n_darts", n_darts, 1, PARAM_BY_NAME["darts_per_paint"].range[1])
        return super().paint(center, radius, n_darts)

    def prune_preview(self, center: np.ndarray, radius: float) -> np.ndarray:
        """Mask of the nodes a prune brush at ``center`` (3,) with ``radius`` would remove (§4.4)."""
        return super().prune_preview(check_point("center", center),
                                     check_range("radius", radius, 0.0, 2 * MAX_COORD))

    def prune(self, center: np.ndarray, radius: float) -> int:
        """Remove what :meth:`prune_preview` shows; returns the number of internodes removed."""
        return super().prune(check_point("center", center), check_range("radius", radius, 0.0, 2 * MAX_COORD))

    def checked_params(self, params: dict[str, Any]) -> dict[str, Any]:
        """The parameters :meth:`set_params` would apply (``self.params`` updated by ``params``), checked against
        the table and against this tree (the shadow grid must index it); nothing is written."""
        new = {**self.params, **check_params(params, partial=True)}
        barycentric(new["w_heading"], new["w_tropism"], new["w_env"])
        if new["branching"] != self.params["branching"] and self.tree.n_internodes:
            raise ValueError(f"branching cannot change on a grown tree (its nodes have {self.tree.nslots} slots), "
                             f"got {new['branching']!r}; start a new engine")
        t = self.tree
        check_grid_reach(new, np.concatenate([t.pos[: t.n][t.alive[: t.n]], self.markers]))
        return new

    def set_params(self, params: dict[str, Any]) -> None:
        """Change growth parameters; every value is checked (:meth:`checked_params`) before any is applied."""
        super().set_params(self.checked_params(params))

    @staticmethod
    def _check_region(region) -> dict | None:
        if region is None:
            return None
        if not isinstance(region, dict) or set(region) != {"sites", "weights", "weight", "h_max"}:
            raise ValueError(f"region must be a dict with keys sites, weights, weight, h_max, got {region!r}")
        sites, weights = region["sites"], region["weights"]
        sites = np.zeros((0, 2)) if np.size(sites) == 0 else \
            check_array("region sites", sites, shape=(None, 2), max_abs=2 * MAX_COORD)
        weights = np.zeros(0) if np.size(weights) == 0 else check_array("region weights", weights, shape=(None,))
        if len(sites) > MAX_SITES:
            raise ValueError(f"region sites must list at most {MAX_SITES} neighbours, got {len(sites)}")
        if len(weights) != len(sites) or not np.all((weights >= 1e-12) & (weights <= 1e12)):
            raise ValueError(f"region weights must be ({len(sites)},) like the sites, each in [1e-12, 1e12]")
        return {"sites": sites.tolist(), "weights": weights.tolist(),
                "weight": check_range("region weight", region["weight"], 1e-12, 1e12),
                "h_max": check_range("region h_max", region["h_max"], 0.0, MAX_COORD, low_open=True)}

    def in_region(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: points inside the tree's crown space (all True without a region)."""
        reg = self.sketch["region"]
        pts = np.asarray(points, float).reshape(-1, 3)
        if reg is None:
            return np.ones(len(pts), bool)
        ok = pts[:, 1] <= reg["h_max"]
        sites = np.asarray(reg["sites"]).reshape(-1, 2)
        if len(sites):
            q = pts[:, [0, 2]]
            own = np.linalg.norm(q, axis=1) / reg["weight"]
            other = np.linalg.norm(q[:, None] - sites[None], axis=2) / np.asarray(reg["weights"])[None]
            ok &= own <= other.min(1)
        return ok

    @property
    def halted(self) -> bool:
        """Landscape mode: growth stops once a branch reaches the region's h_max (§6.6)."""
        reg = self.sketch["region"]
        t = self.tree
        return reg is not None and bool(t.n) and float(t.pos[t.alive, 1].max()) >= reg["h_max"]

    @staticmethod
    def _check_life(value) -> int | None:
        return None if value is None else check_int("bud_lifetime", value, 1, 10 ** 9)

    @staticmethod
    def _check_ellipse(ellipse) -> tuple[float, float, float]:
        if isinstance(ellipse, (str, bytes)) or not hasattr(ellipse, "__len__") or len(ellipse) != 3:
            raise ValueError(f"ellipse must be (s_v, s_p, e_v), got {ellipse!r}")
        return tuple(check_range(f"ellipse {_ROW[k].symbol}", v, *_ROW[k].range) for k, v in zip(_ELLIPSE_ROWS, ellipse))

    def set_options(self, **opts: Any) -> None:
        """Change TreeSketch options (the keywords of the constructor except ``rng``); all checked first."""
        new = self._check_options(opts)
        self.sketch.update(new)
        if "ellipse" in new:
            self.update_light()

    def _rng(self, purpose: int) -> np.random.Generator:
        """Generator for (seed, iteration, purpose): 1 = autonomous points, 2 = tropism planes."""
        return np.random.default_rng([self.seed, self.step_count, purpose])

    # -- state: the TreeSketch fields ride along with the engine's (whole-state undo and pickling) -----
    def _sketch_state(self) -> dict:
        return {"sketch": {k: (dict(v) if isinstance(v, dict) else v) for k, v in self.sketch.items()},
                "seed": self.seed, "selected": self.selected, "width_constraints": dict(self.width_constraints),
                "stroke_dirs": {k: v.copy() for k, v in self._stroke_dirs.items()},
                "bud_override": {k: v.copy() for k, v in self.bud_override.items()}}

    def _set_sketch_state(self, s: dict) -> None:
        self.sketch, self.seed, self.selected = dict(s["sketch"]), s["seed"], s["selected"]
        self.width_constraints = dict(s["width_constraints"])
        self._stroke_dirs = {k: v.copy() for k, v in s["stroke_dirs"].items()}
        self.bud_override = {k: v.copy() for k, v in s.get("bud_override", {}).items()}
        self.width_info = None

    def get_state(self, *, grid: bool = True) -> dict[str, Any]:
        """:meth:`GrowthEngine.get_state` with the TreeSketch fields (``"sketch_state"``: options, seed,
        selection, width constraints, stroke directions, bud overrides), all copies; pickling uses it too."""
        return {**super().get_state(grid=grid), "sketch_state": self._sketch_state()}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore what :meth:`get_state` returned (the TreeSketch fields first: light and widths depend on them)."""
        self._set_sketch_state(state["sketch_state"])
        super().set_state(state)

    def table_values(self) -> dict[str, Any]:
        """The engine's parameters and table options as :data:`TREESKETCH` values (stroke rows excluded)."""
        sv, sp, ev = self.sketch["ellipse"]
        opts = {k: self.sketch[k] for k in TABLE_OPTIONS if k != "ellipse"}
        return {**self.params, **opts, "ellipse_sv": sv, "ellipse_sp": sp, "ellipse_ev": ev}

    # -- light: gravimorphism (Eqs. 4.6-4.7) and widths (§2.10) ---------------------------------------
    def _vigor(self) -> None:
        self._gravimorphism()
        super()._vigor()

    def _gravimorphism(self) -> None:
        """Write b of Eq. 4.6 into ``tree.light_factor`` so the engine's signal is Q = b L^kappa (Eq. 4.7).

        The factor is per node and applies to every bud slot of the node; only lateral buds are affected
        (§1.4.6 [INFERRED]), so a node whose terminal bud is still a bud (a tip) keeps b = 1, and a node with a
        main child gets b of its lateral bud(s) (the mean over both slots in opposite branching).
        """
        t = self.tree
        lf = t.light_factor
        s_v, s_p, e_v = self.sketch["ellipse"]
        if (s_v, s_p, e_v) == (1.0, 1.0, 0.0):
            lf[:] = 1.0
            return
        node, slot = np.nonzero((t.child[:, 1:] == BUD) & t.alive[:, None] & (t.child[:, :1] != BUD))
        slot = slot + 1
        lf[:] = 1.0
        if not len(node):
            return
        b = gravimorphism(t.head[node], self._bud_dirs(node, slot), s_v=s_v, s_p=s_p, e_v=e_v)
        acc = np.bincount(node, b, t.n)
        cnt = np.bincount(node, minlength=t.n)
        has = cnt > 0
        lf[has] = acc[has] / cnt[has]

    def update_light(self) -> None:
        """Light, vigor and widths; with width constraints the pipe model is solved per subtree (§2.10)."""
        super().update_light()
        if self.width_constraints:
            self._apply_widths()

    def _apply_widths(self) -> None:
        p, t = self.params, self.tree
        cons = {k: v for k, v in self.width_constraints.items() if k < t.n and t.alive[k]}
        res = pipe_widths(t.parent, t.alive, tip_diameter=max(2.0 * p["tip_radius"], 1e-9), exponent=p["radius_exp"],
                          constraints=cons)
        t.radius[:] = 0.5 * res.diameter
        self.width_info = res

    def set_width(self, node: int, diameter: float | None) -> None:
        """Add, change or (``diameter=None``) remove the width constraint on the internode ending at ``node``
        (``diameter`` in [1e-9, MAX_COORD])."""
        node = check_int("node", node, 1, self.tree.n - 1)
        if not self.tree.alive[node]:
            raise ValueError(f"node {node} is not alive")
        if diameter is None:
            self.width_constraints.pop(node, None)
        else:
            self.width_constraints[node] = check_range("diameter", diameter, 1e-9, MAX_COORD)
        self.update_light()

    # -- editing: bending, selection, pruning at a branching point -----------------------------------
    def branch_path(self, base: int, end: int) -> np.ndarray:
        """Nodes from ``base`` down to ``end`` (``end`` in the subtree of ``base``), for :meth:`bend`."""
        t = self.tree
        base = check_int("base", base, 0, t.n - 1)
        end = check_int("end", end, 0, t.n - 1)
        path = [end]
        while path[-1] != base:
            if path[-1] <= 0:
                raise ValueError(f"end node {end} is not in the subtree of base node {base}")
            path.append(int(t.parent[path[-1]]))
        return np.array(path[::-1], np.int64)

    def bend(self, base: int, end: int, target, *, max_iter: int = 100) -> BendResult:
        """Bend the path ``base`` .. ``end`` so that ``end`` reaches ``target`` (§2.9, :func:`bend_path`).

        Node positions and frames (head, lat) of the path and of everything hanging from it move rigidly with
        their supporting internode; the light grid is rebuilt. Always solved from the current pose as rest.
        """
        t = self.tree
        path = self.branch_path(base, end)
        target = check_point("target", target)
        radius = np.where(t.radius > 0, t.radius, self.params["tip_radius"])
        res = bend_path(t.pos, t.parent, radius, path, target, max_iter=max_iter)
        t.pos[:] = res.pos
        t.head[:] = normalize(np.einsum("nij,nj->ni", res.rot, t.head))
        t.lat[:] = normalize(np.einsum("nij,nj->ni", res.rot, t.lat))
        self.rebuild_light()
        return res


    def select(self, node: int | None, direction=None) -> None:
        """Selective growth (§2.8): only buds in the subtree of ``node`` may grow; ``None`` ends the mode.

        With ``direction`` (3,), the bud at ``node`` (its lateral bud if it has one, else its terminal bud) is
        re-oriented along it, as TreeSketch turns the nearest bud toward the initial brush-stroke direction.
        """
        t = self.tree
        if node is not None:
            node = check_int("node", node, 0, t.n - 1)
            if not t.alive[node]:
                raise ValueError(f"node {node} is not alive")
        if direction is not None:
            if node is None:
                raise ValueError("direction needs a selected node")
            d = check_point("direction", direction)
            if not np.linalg.norm(d) > 0:
                raise ValueError("direction must be a non-zero vector")
            slots = [k for k in range(1, t.nslots) if t.child[node, k] == BUD] + \
                ([0] if t.child[node, 0] == BUD else [])
            if not slots:
                raise ValueError(f"node {node} has no bud to re-orient")
            self.bud_override[(node, slots[0])] = d / np.linalg.norm(d)
        self.selected = node

    def prune_at(self, node: int) -> int:
        """Prune the branch through ``node`` at its nearest branching point (§2.11); returns internodes removed.

        Widths are then recomputed as if the branch had never existed; a width constraint on the way leaves a
        stub (:func:`branch_point`).
        """
        t = self.tree
        node = check_int("node", node, 0, t.n - 1)
        cut = branch_point(t.parent, t.alive, node, protected=self.width_constraints)
        if cut < 0:
            return 0
        n = self._remove(t.subtree_mask([cut]))
        self.update_light()
        return n

    def _remove(self, mask: np.ndarray) -> int:
        """Engine removal; node ids held here (constraints, selection) follow a compaction."""
        t = self.tree
        n_before = t.n
        survive = t.alive & ~mask
        gone = super()._remove(mask)
        if self.tree.n != n_before:  # compacted: survivors keep their order
            remap = np.cumsum(survive) - 1
            remap[~survive] = -1
            self.width_constraints = {int(remap[k]): v for k, v in self.width_constraints.items()
                                      if k < n_before and remap[k] >= 0}
            if self.selected is not None:
                self.selected = int(remap[self.selected]) if remap[self.selected] >= 0 else None
            self.bud_override = {(int(remap[n]), k): v for (n, k), v in self.bud_override.items()
                                 if n < n_before and remap[n] >= 0}
        else:
            self.width_constraints = {k: v for k, v in self.width_constraints.items() if self.tree.alive[k]}
            if self.selected is not None and not self.tree.alive[self.selected]:
                self.selected = None
        return gone

    # -- markers: strokes, directed and autonomous policies ------------------------------------------
    def add_stroke_points(self, points: np.ndarray, directions: np.ndarray) -> None:
        """Add attraction points that remember a stroke direction (unit rows) for sketch-based tropism."""
        points = self._check_marker_points("points", points)
        directions = normalize(check_array("directions", directions, shape=(None, 3)))
        if len(directions) != len(points):
            raise ValueError(f"directions must have {len(points)} rows like points, got {len(directions)}")
        if len(self.markers) + len(points) > MAX_COUNT:
            raise ValueError(f"points would make {len(self.markers) + len(points)} markers, more than {MAX_COUNT}")
        check_grid_reach(self.params, points, name="points")
        for p, d in zip(points, directions):
            self._stroke_dirs[p.tobytes()] = d
        self.add_markers(points)

    def stroke_directions(self, points: np.ndarray) -> np.ndarray:
        """Stroke direction of each marker row (zeros for markers not made by a stroke)."""
        zero = np.zeros(3)
        points = np.zeros((0, 3)) if np.size(points) == 0 else check_array("points", points, shape=(None, 3))
        return np.array([self._stroke_dirs.get(np.ascontiguousarray(p).tobytes(), zero) for p in points]
                        ).reshape(-1, 3)

    def _age_markers(self) -> None:
        """Directed: points persist until consumed (no ageing); autonomous: all points are cleared (§1.4.1)."""
        if self.sketch["mode"] == "autonomous":
            self.markers, self.marker_age = np.zeros((0, 3)), np.zeros(0, np.int64)
        if len(self._stroke_dirs) > 2 * len(self.markers) + 64:
            keep = {m.tobytes() for m in self.markers}
            self._stroke_dirs = {k: v for k, v in self._stroke_dirs.items() if k in keep}

    def buds(self) -> _Buds:
        """Every bud slot of the live tree (cached within a step while the tree does not change)."""
        cached = self.__dict__.get("_buds_cache")
        return cached if cached is not None else super().buds()

    def _add_autonomous_points(self) -> None:
        p = self.params
        b = self.buds()
        if not len(b.node):
            return
        pts = autonomous_points(b.pos, b.dir, b.vigor, density=self.sketch["point_density"],
                                r_in=p["occupation_radius"], r_out=max(p["view_radius"], p["occupation_radius"]),
                                half_angle=math.radians(p["view_angle"]) / 2, rng=self._rng(1))
        keep = self.in_region(pts)
        reach = grid_reach(p)  # points the shadow grid could not index are not generated (tiny base_length)
        keep &= (np.abs(pts[:, [0, 2]]).max(1) <= reach) & (np.abs(pts[:, 1]) <= 3 * reach)
        self.add_markers(pts[keep])

    # -- step ---------------------------------------------------------------------------------------
    def _before_step(self) -> None:
        """TreeSketch iteration (§1.5) = the engine's step with these hooks and the §1.4.8 shedding rule."""
        self._buds_cache = super().buds()  # the tree does not change until _grow: one bud pass serves both
        if self.sketch["mode"] == "autonomous" and not self.halted:
            self._add_autonomous_points()

    def _after_step(self) -> None:
        self._drop_old_buds()
        if self.bud_override:  # a re-oriented bud that grew (or died) needs no override any more
            t = self.tree
            self.bud_override = {(n, k): v for (n, k), v in self.bud_override.items()
                                 if n < t.n and t.alive[n] and t.child[n, k] == BUD}

    def _drop_old_buds(self) -> None:
        life = self.sketch["bud_lifetime"]
        if life is None:
            return
        t = self.tree
        old = t.alive & (t.born <= self.step_count + 1 - life)
        lat = t.child[:, 1:]
        lat[old[:, None] & (lat == BUD)] = NO_SLOT

    def shed_mask(self) -> np.ndarray:
        """Branches to shed (§1.4.8 [INFERRED]): a lateral branch rooted at internode i is shed when
        (v_i / v_base) / (N_i / N_total) < Th, N = internode counts. Th = 0 never sheds; branches holding a width
        constraint or the selected node, and their supporting path, are protected. Closed under descendants."""
        t = self.tree
        th = self.sketch["shed_threshold"]
        mask = np.zeros(t.n, bool)
        if th <= 0 or t.n_internodes < 2 or not t.vigor[0] > 0:
            return mask
        alive = t.alive
        size = np.ones(t.n)
        size[~alive] = 0
        for i in range(t.n - 1, 1, -1):  # subtree internode counts
            if alive[i]:
                size[t.parent[i]] += size[i]
        par = np.maximum(t.parent, 0)
        is_lat = alive & (t.parent >= 0) & (t.child[par, 0] != np.arange(t.n))
        is_lat[:2] = False
        with np.errstate(divide="ignore", invalid="ignore"):  # dead nodes (size 0) are never roots
            ratio = (t.vigor / t.vigor[0]) / (size / t.n_internodes)
        roots = np.flatnonzero(is_lat & (ratio < th))
        if not len(roots):
            return mask
        keep = np.zeros(t.n, bool)
        for k in list(self.width_constraints) + ([self.selected] if self.selected is not None else []):
            while k >= 0 and not keep[k]:
                keep[k] = True
                k = t.parent[k]
        roots = roots[~keep[roots]]
        return t.subtree_mask(roots) if len(roots) else mask

    # -- buds: deflection and selective growth --------------------------------------------------------
    def _bud_dirs(self, node: np.ndarray, slot: np.ndarray) -> np.ndarray:
        p, t = self.params, self.tree
        kw = {"main_angle": math.radians(p["main_branch_angle"]), "lateral_angle": math.radians(p["branch_angle"]),
              "opposite": t.nslots == 3, "opposite_main": p["opposite_main"]}
        d = super()._bud_dirs(node, slot)
        delta = math.radians(self.sketch["deflection"])
        main = slot == 0
        if delta and main.any():
            lat = bud_headings(t.head[node[main]], t.lat[node[main]], np.ones(int(main.sum()), np.int64), **kw)
            d[main] = deflect_heading(d[main], lat, delta)
        for (n, k), v in self.bud_override.items():  # few entries: one vector test each
            d[(node == n) & (slot == k)] = v
        return d

    def _active_buds(self) -> _Buds:
        try:
            b = super()._active_buds()
        finally:
            self._buds_cache = None
        if self.selected is not None:
            b = b.subset(self.tree.subtree_mask([self.selected])[b.node])
        return b

    # -- growth: Eq. 4.3 shoots, Eq. 4.5 per internode ------------------------------------------------
    def _grow(self, buds: _Buds, owner: np.ndarray) -> int:
        p, t = self.params, self.tree
        hit, _count, enabled = marker_counts(owner, len(buds.node))
        if not len(enabled):
            self._new_nodes = np.zeros(0, np.int64)
            return 0
        n = shoot_lengths(buds.vigor[enabled], self.sketch["n_max"])
        grow, n = enabled[n > 0], n[n > 0]
        if not len(grow):
            self._new_nodes = np.zeros(0, np.int64)
            return 0
        # E = normalize(sum of unit vectors to the selecting markers), spec §1.3.1 [INFERRED]
        o = owner[hit]
        u = normalize(self.markers[hit] - buds.pos[o])
        sums = sum_per_bud(o, u, len(buds.node))
        E = normalize(sums[grow], fallback=buds.dir[grow])
        S = None
        if self.sketch["stroke_tropism"] and self._stroke_dirs:  # §2.7: T = mean stroke direction
            sd = self.stroke_directions(self.markers[hit])
            ssum = sum_per_bud(o, sd, len(buds.node))[grow]
            S = np.linalg.norm(ssum, axis=1) > 1e-12
            ssum[S] /= np.linalg.norm(ssum[S], axis=1)[:, None]
        al, be, ga = barycentric(p["w_heading"], p["w_tropism"], p["w_env"])
        fade = V_na = None
        if self.sketch["asymmetry"] is not None:
            vx, vz = self.sketch["asymmetry"]
            V_na = np.array([vx, 0.0, vz])
            reg = self.sketch["region"]
            h = float(t.pos[t.alive, 1].max() - t.pos[0, 1])
            fade = min(h / reg["h_max"], 1.0) ** 0.5 if reg is not None else 0.0
        theta = math.radians(p["tropism_angle"])
        delta = math.radians(self.sketch["deflection"])
        phyl = math.radians(p["phyllotaxis_angle"])
        lat_angle = math.radians(p["branch_angle"])
        node, slot = buds.node[grow], buds.slot[grow]
        order = t.order[node] + (slot > 0)
        main_axis = order == 0
        H = buds.dir[grow].copy()
        prev_head, prev_lat = t.head[node].copy(), t.lat[node].copy()
        parent, tip = node.copy(), buds.pos[grow].copy()
        length = buds.length[grow]
        rng = self._rng(2)
        new_all = []
        for k in range(int(n.max())):
            a = np.flatnonzero(n > k)
            if k > 0:  # continuing heading at the node just made: deflected away from its lateral bud
                lat_dir = np.cos(lat_angle) * prev_head[a] + np.sin(lat_angle) * prev_lat[a]
                H[a] = deflect_heading(prev_head[a], lat_dir, delta) if delta else prev_head[a]
            T = set_point_tropism(H[a], theta, main_axis=main_axis[a], trunk_up=self.sketch["trunk_up"], rng=rng)
            if S is not None:
                T = np.where(S[a, None], ssum[a], T)
            if fade is not None:  # Eq. 6.5, ERRATUM E8 (asym_fade)
                T = normalize((1.0 - fade) * (V_na + T) + fade * T, fallback=T)
            d = normalize(al * H[a] + be * T + ga * E[a], fallback=H[a])
            lat = transport_lateral(prev_lat[a], prev_head[a], d, phyl)
            pos = tip[a] + length[a, None] * d
            new = t.append_many(pos, parent[a], d, lat, order[a], born=self.step_count + 1)
            if k == 0:
                t.child[node, slot] = new
            else:
                t.child[parent[a], 0] = new
            parent[a], tip[a], prev_head[a], prev_lat[a] = new, pos, d, lat
            new_all.append(new)
        self._new_nodes = np.concatenate(new_all)
        return len(self._new_nodes)

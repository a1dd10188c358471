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
  after it (§1.4.1).

Randomness is drawn from generators seeded by (seed, iteration, purpose), so a replay from the same seed
and the same commands is bit-identical.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validation import check_choice, check_int, check_range
from .directions import _rotate, bud_headings, normalize, transport_lateral
from .engine import GrowthEngine, _Buds
from .tree import BUD

__all__ = [
    "SketchEngine",
    "autonomous_points",
    "barycentric",
    "deflect_heading",
    "ellipse_distance",
    "gravimorphism",
    "set_point_tropism",
    "shoot_lengths",
]

_Y = np.array([0.0, 1.0, 0.0])


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
    H = np.atleast_2d(np.asarray(heading, float))
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
    H = np.atleast_2d(np.asarray(heading, float))
    axis = np.cross(H, np.atleast_2d(np.asarray(lateral, float)))
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
    v = np.asarray(vigor, float)
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
    rng = np.random.default_rng(rng)
    pos, H, v = np.asarray(pos, float), normalize(np.asarray(heading, float)), np.asarray(vigor, float)
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
    s_v = check_range("s_v", s_v, 0.0, np.inf, low_open=True)
    s_p = check_range("s_p", s_p, 0.0, np.inf, low_open=True)
    e_v = check_range("e_v", e_v, -np.inf, np.inf)
    chi = np.asarray(chi, float)
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
    H = normalize(np.atleast_2d(np.asarray(parent_heading, float)))
    D = np.atleast_2d(np.asarray(bud_dir, float))
    cos_t = np.clip(H @ _Y, -1.0, 1.0)
    V = normalize(_Y - cos_t[:, None] * H, fallback=np.array([1.0, 0.0, 0.0]))
    P = np.cross(V, H)
    chi = np.arctan2(np.sum(D * P, 1), np.sum(D * V, 1))
    d = ellipse_distance(chi, s_v=s_v, s_p=s_p, e_v=e_v)
    return cos_t ** 2 + d * (1.0 - cos_t ** 2)


class SketchEngine(GrowthEngine):
    """:class:`GrowthEngine` with the TreeSketch variants (spec 004 §1.4–1.5) as options.

    Parameters
    ----------
    params : dict
        The engine's parameter dict (``plantvr.params.defaults()``); ``tropism_angle`` (degrees) is the
        set-point theta, ``w_heading``/``w_tropism``/``w_env`` the barycentric (alpha, beta, gamma).
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
    """

    def __init__(self, params: dict[str, Any], *, rng: int | np.random.Generator | None = None, n_max: int = 3,
                 trunk_up: bool = False, deflection: float = 0.0, mode: str = "directed", point_density: int = 4):
        opts = {"n_max": check_int("n_max", n_max, 1, 1000), "trunk_up": bool(trunk_up),
                    "deflection": check_range("deflection", deflection, 0.0, 90.0),
                    "mode": check_choice("mode", mode, ("directed", "autonomous")),
                    "point_density": check_int("point_density", point_density, 0, 1000)}
        barycentric(params["w_heading"], params["w_tropism"], params["w_env"])
        check_range("tropism_angle", params["tropism_angle"], 0.0, 180.0)
        if isinstance(rng, (int, np.integer)):
            seed = int(rng)
        else:
            seed = int(np.random.default_rng(rng).integers(2 ** 62))
        self.sketch = opts
        self.seed = seed
        super().__init__(params, rng=np.random.default_rng([seed, 0x5EED]))

    def _rng(self, purpose: int) -> np.random.Generator:
        """Generator for (seed, iteration, purpose): 1 = autonomous points, 2 = tropism planes."""
        return np.random.default_rng([self.seed, self.step_count, purpose])

    # -- step: marker policy ------------------------------------------------------------------------
    def step(self):
        """One TreeSketch iteration (§1.5) on the engine's step; the marker policy follows ``mode``."""
        if self.sketch["mode"] == "autonomous":
            self._add_autonomous_points()
        life = self.params["marker_lifetime"]
        self.params["marker_lifetime"] = np.iinfo(np.int64).max  # directed: points persist until consumed
        try:
            stats = super().step()
        finally:
            self.params["marker_lifetime"] = life
        if self.sketch["mode"] == "autonomous":
            self.markers, self.marker_age = np.zeros((0, 3)), np.zeros(0, np.int64)
        return stats

    def _add_autonomous_points(self) -> None:
        p, t = self.params, self.tree
        node, slot = np.nonzero((t.child == BUD) & t.alive[:, None])
        if not len(node):
            return
        head = self._bud_dirs(node, slot)
        pts = autonomous_points(t.pos[node], head, t.bud_vigor[node, slot], density=self.sketch["point_density"],
                                r_in=p["occupation_radius"], r_out=max(p["view_radius"], p["occupation_radius"]),
                                half_angle=math.radians(p["view_angle"]) / 2, rng=self._rng(1))
        self.add_markers(pts)

    # -- buds: deflection ---------------------------------------------------------------------------
    def _bud_dirs(self, node: np.ndarray, slot: np.ndarray) -> np.ndarray:
        p, t = self.params, self.tree
        kw = {"main_angle": math.radians(p["main_branch_angle"]), "lateral_angle": math.radians(p["branch_angle"]),
                  "opposite": t.nslots == 3, "opposite_main": p["opposite_main"]}
        d = bud_headings(t.head[node], t.lat[node], slot, **kw)
        delta = math.radians(self.sketch["deflection"])
        main = slot == 0
        if delta and main.any():
            lat = bud_headings(t.head[node[main]], t.lat[node[main]], np.ones(int(main.sum()), np.int64), **kw)
            d[main] = deflect_heading(d[main], lat, delta)
        return d

    def _active_buds(self) -> _Buds:
        b = super()._active_buds()
        b.dir = self._bud_dirs(b.node, b.slot)
        b.vigor = self.tree.bud_vigor[b.node, b.slot]
        return b

    # -- growth: Eq. 4.3 shoots, Eq. 4.5 per internode ------------------------------------------------
    def _grow(self, buds: _Buds, owner: np.ndarray) -> int:
        p, t = self.params, self.tree
        hit = owner >= 0
        count = np.bincount(owner[hit], minlength=len(buds.node))
        enabled = np.flatnonzero(count > 0)
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
        sums = np.stack([np.bincount(o, u[:, k], len(buds.node)) for k in range(3)], 1)
        E = normalize(sums[grow], fallback=buds.dir[grow])
        al, be, ga = barycentric(p["w_heading"], p["w_tropism"], p["w_env"])
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

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
and the same commands is bit-identical. The rules themselves are array functions in :mod:`.sketch_rules`, the
parameter table and option checks are in :mod:`.sketch_params` (its public names are importable from here).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validation import MAX_COORD, MAX_COUNT, check_array, check_int, check_point, check_points, check_range
from ..params import PARAM_BY_NAME, check_params
from .bending import BendResult, bend_path, pipe_widths
from .directions import bud_headings, normalize, transport_lateral
from .engine import GrowthEngine, _Buds, marker_counts, sum_per_bud
from .sketch_params import (_ROW, SKETCH_ROWS, TABLE_OPTIONS, TREESKETCH, _check_asym, _check_bool, _check_depth,
                            _check_ellipse, _check_life, _check_region, check_grid_reach, grid_reach, split_values)
from .sketch_rules import (autonomous_points, barycentric, branch_path, branch_point, deflect_heading, gravimorphism,
                           set_point_tropism, shed_roots, shoot_lengths)
from .tree import BUD, NO_SLOT

__all__ = ["SKETCH_ROWS", "TREESKETCH", "SketchEngine", "split_values"]



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
                "ellipse": _check_ellipse,
                "shed_threshold": _ROW["shed_threshold"].check,
                "stroke_tropism": lambda v: _check_bool("stroke_tropism", v),
                "bud_lifetime": _check_life, "region": _check_region,
                "depth": _check_depth, "asymmetry": _check_asym}

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
        return branch_path(self.tree.parent, base, end)

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
        """Branches to shed (§1.4.8 [INFERRED], :func:`shed_roots`), with the width constraints and the selected
        node protected; closed under descendants."""
        t = self.tree
        protected = list(self.width_constraints) + ([self.selected] if self.selected is not None else [])
        roots = shed_roots(t.parent, t.alive, t.child[:, 0], t.vigor, self.sketch["shed_threshold"],
                           protected=protected)
        return t.subtree_mask(roots) if len(roots) else np.zeros(t.n, bool)

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

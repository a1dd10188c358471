"""The Tree Wand growth step, headless (spec 000_treewand §2.10, Alg. 9.2).

:class:`GrowthEngine` owns the tree, the markers and the shadow grid, and runs on numpy arrays only;
:class:`plantvr.Model` wraps it with validated traits, a worker thread and snapshots.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from plantvr._validation import MAX_COORD, MAX_COUNT, check_int, check_point, check_points, check_range
from plantvr.params import check_params

from ._colonize_kernels import owner_sums_kernel
from .colonize import TreeWandAssigner, assign_treewand
from .directions import bud_headings, growth_directions, normalize, transport_lateral, tropism_vectors
from .lengths import internode_lengths
from .markers import _poisson_darts
from .shadow import ShadowGrid, ShadowGridFull, keys_from_array, keys_to_array, shadow_lut
from .spatial import REACH, PointGrid, _within_any_trusted
from .tree import BUD, Tree
from .vigor import accumulate_light_kernel, distribute_vigor_kernel, pipe_radius_kernel, shed_mask_kernel

__all__ = ["GrowthEngine", "StepStats"]

#: Shortest internode length a bud produces: Eq. 9.17 with a denormal base length rounds to 0 otherwise.
MIN_LENGTH = float(np.finfo(np.float64).tiny)
#: Smallest cell of the occupation grids: below it a grid over ±REACH would clip every marker into one cell.
_MIN_CELL = REACH * 2.0 ** -40
#: Parameters the shadow grid is built from: a change rebuilds it.
_SHADOW_KEYS = ("shadow_intensity", "shadow_falloff", "shadow_depth", "base_length", "fine_cells",
                "shadow_loop_inclusive")


@dataclass(frozen=True)
class StepStats:
    """What one growth step did (§6.4: the data of Figs. 12.8/12.9)."""

    step: int
    ms: float
    internodes: int
    active_buds: int
    markers: int
    grown: int
    shed: int

    @property
    def bm(self) -> int:
        """Active buds × live markers, the x axis of Fig. 12.9."""
        return self.active_buds * self.markers


@dataclass
class _Buds:
    node: np.ndarray
    slot: np.ndarray
    pos: np.ndarray = field(default=None)
    dir: np.ndarray = field(default=None)
    length: np.ndarray = field(default=None)
    vigor: np.ndarray = field(default=None)

    def subset(self, mask: np.ndarray) -> "_Buds":
        """The buds where ``mask`` holds (every array field is indexed)."""
        return _Buds(*(None if v is None else v[mask] for v in
                       (self.node, self.slot, self.pos, self.dir, self.length, self.vigor)))


def sum_per_bud(owner: np.ndarray, values: np.ndarray, n_buds: int) -> np.ndarray:
    """(n_buds, 3) sums of the rows of ``values`` (M, 3) grouped by ``owner`` (M,) in [0, n_buds)."""
    return np.stack([np.bincount(owner, values[:, k], n_buds) for k in range(3)], 1)


class _Phases:
    """Wall and CPU milliseconds per named phase of one step (``with phases("assign"): ...``).

    CPU is the calling thread's (``time.thread_time``), except for the phases in ``parallel`` (numba ``prange``
    kernels), which take the process's (all threads; numba's idle workers may spin a little after a parallel
    region, which is counted there too).
    """

    parallel = frozenset({"assign"})

    def __init__(self):
        self.ms: dict[str, tuple[float, float]] = {}
        self._name = None

    def __call__(self, name: str) -> "_Phases":
        self._name = name
        return self

    def __enter__(self):
        clock = time.process_time if self._name in self.parallel else time.thread_time
        self._t = (time.perf_counter(), clock(), clock)

    def __exit__(self, *exc):
        w, c = self.ms.get(self._name, (0.0, 0.0))
        self.ms[self._name] = (w + 1e3 * (time.perf_counter() - self._t[0]), c + 1e3 * (self._t[2]() - self._t[1]))


def _read_only(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a``: the marker array is replaced on every change and never written in place, so
    states and snapshots share it instead of copying 200k markers per step (issue 24)."""
    if not a.flags.writeable:
        return a
    v = a.view()
    v.flags.writeable = False
    return v


def marker_counts(owner: np.ndarray, n_buds: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(hit, count, chosen)`` of a marker assignment ``owner`` (M,) in [-1, n_buds): the markers that have a
    bud (bool), the markers of each bud (n_buds,) and the buds with at least one (the buds that grow, §2.4)."""
    hit = owner >= 0
    count = np.bincount(owner[hit], minlength=n_buds)
    return hit, count, np.flatnonzero(count > 0)


class GrowthEngine:
    """Tree, markers and light grid, advanced by :meth:`step` (Alg. 9.2). Parameters are a checked dict.

    ``phase_ms`` holds the last step's ``{phase: (wall ms, CPU ms)}`` (:class:`_Phases`; benchmarks/interactive.py).
    ``_fast = False`` runs the issue-23 code path (serial assignment, ``np.bincount`` sums, a marker copy every
    step): the twin the fast path is tested and benchmarked against; both grow the same tree bit for bit.
    ``markers`` is replaced by a new array on every change, never written in place (snapshots and states share
    it).
    """

    _fast = True

    def __init__(self, params: dict[str, Any], *, rng: int | np.random.Generator | None = None):
        params = check_params(params)
        if isinstance(rng, (bool, np.bool_)) or not (rng is None or isinstance(rng, (
                int, np.integer, np.random.Generator, np.random.SeedSequence, np.random.BitGenerator))):
            raise ValueError(f"rng must be a non-negative int seed, a numpy Generator or None, got {rng!r}")
        if isinstance(rng, (int, np.integer)):
            check_int("rng", rng, 0, 2 ** 128 - 1)
        self.params = params
        self.rng = np.random.default_rng(rng)
        self.reset()

    # -- state --------------------------------------------------------------------------------------
    def reset(self) -> None:
        """"Start new tree": remove every internode, leaving the base (§4.5 item 7). Markers are dropped."""
        p = self.params
        self.tree = Tree.seed(p["base_length"], 3 if p["branching"] == "opposite" else 2)
        self.markers = np.zeros((0, 3))
        self.marker_age = np.zeros(0, np.int64)
        self.step_count = 0
        self.history: list[StepStats] = []
        self.phase_ms: dict[str, tuple[float, float]] = {}
        self._asg = None  # marker grid kept across steps (fast path), valid while _asg_for is self.markers
        self._asg_for = None
        self._new_nodes = np.arange(self.tree.n)
        self.rebuild_light()

    def set_params(self, params: dict[str, Any]) -> None:
        """Apply parameters (checked against the table first; nothing changes if one is rejected); a change of
        shadow or topology settings rebuilds what depends on it."""
        params = check_params(params, partial=True)
        old = self.params
        self.params = {**old, **params}
        self._follow(old)

    def _follow(self, old: dict[str, Any]) -> None:
        """Make light, vigor and radius follow :attr:`params` after they were computed with ``old``."""
        if any(old[k] != self.params[k] for k in _SHADOW_KEYS):
            self.rebuild_light()
        else:
            self.update_light()

    def rebuild_light(self) -> None:
        """Rebuild the shadow grid from every live node, then light, vigor and radius (§2.6, after loading).

        The cell is the base length (§2.6) unless the live nodes' pyramids would need more than the grid's cell
        cap (e.g. a tiny ``base_length`` set on a grown tree, issue 20): then the cell doubles until they fit.
        """
        p = self.params
        self._lut = shadow_lut(p["shadow_intensity"], p["shadow_falloff"], p["shadow_depth"],
                               p["shadow_loop_inclusive"])
        t = self.tree
        live = np.flatnonzero(t.alive)
        cell = p["base_length"]
        while True:
            self.grid = ShadowGrid(cell, p["fine_cells"])
            try:
                self.grid._add_cells(self.grid.cells_of(t.pos[live]), *self._lut)
                break
            except ShadowGridFull:
                if not cell * 2.0 < np.inf:  # cannot happen (one cell always fits); stay shadowless
                    self.grid = ShadowGrid(cell, p["fine_cells"])
                    break
                cell *= 2.0
        t.shadow_cast[:] = t.alive
        self.update_light()

    def _cast(self, nodes: np.ndarray, sign: float = 1.0) -> None:
        """Add (remove) the shadow pyramids of ``nodes``; a grid that would outgrow its cap is rebuilt coarser."""
        t = self.tree
        try:
            self.grid._add_cells(self.grid.cells_of(t.pos[nodes]), *self._lut, sign=sign)
        except ShadowGridFull:
            self.rebuild_light()

    def update_light(self, phases: _Phases | None = None) -> None:
        """Recompute illumination L, then light, vigor and pipe radius over the whole tree (§2.5, §2.8)."""
        ph = phases or _Phases()
        p, t = self.params, self.tree
        with ph("light"):
            s = self.grid._read_cells(self.grid.cells_of(t.pos))
            t.L[:] = np.clip(1.0 - s, 0.0, 1.0)  # ambiguity A.20: L = clamp(1 - s, 0, 1)
        with ph("vigor"):
            self._vigor()
        with ph("radius"):
            pipe_radius_kernel(t.child, t.alive, p["tip_radius"], p["radius_exp"], t.radius)

    def _light_phases(self, ph: _Phases) -> None:
        """:meth:`update_light` timed per phase; a variant's override (which takes no timer) is one phase."""
        if type(self).update_light is GrowthEngine.update_light:
            self.update_light(ph)
        else:
            with ph("light"):
                self.update_light()

    def _vigor(self) -> None:
        p, t = self.params, self.tree
        accumulate_light_kernel(t.child, t.alive, t.L, t.light_factor, p["light_exponent"], p["apical_dominance"],
                                t.Q, t.Qw, t.Qslot)
        distribute_vigor_kernel(t.child, t.alive, t.Qslot, t.Qw, p["apical_dominance"], p["vigor_mult"], t.vigor,
                                t.bud_vigor)

    # -- commands -----------------------------------------------------------------------------------
    def paint(self, center: np.ndarray, radius: float, n_darts: int | None = None) -> int:
        """Throw Poisson darts in the brush sphere (§2.2); returns the number of markers added.

        ``center`` (3,) within ±MAX_COORD, ``radius`` in [0, MAX_COORD], ``n_darts`` in [0, MAX_COUNT]
        (default ``darts_per_paint``).
        """
        center = check_point("center", center)
        radius = check_range("radius", radius, 0.0, MAX_COORD)
        n = self.params["darts_per_paint"] if n_darts is None else check_int("n_darts", n_darts, 0, MAX_COUNT)
        new = _poisson_darts(center, radius, n, self.markers, self.params["occupation_radius"], self.rng)
        self._append_markers(new)
        return len(new)

    def add_markers(self, points: np.ndarray) -> None:
        """Append markers as they are (age 0), e.g. an imported or scripted marker cloud: (N, 3) within ±REACH."""
        points = check_points("points", points, max_abs=REACH)
        if len(self.markers) + len(points) > MAX_COUNT:
            raise ValueError(f"points would make {len(self.markers) + len(points)} markers, more than "
                             f"MAX_COUNT = {MAX_COUNT}")
        self._append_markers(points)

    def _append_markers(self, points: np.ndarray) -> None:
        self.markers = _read_only(np.concatenate([self.markers, points]))
        self.marker_age = np.concatenate([self.marker_age, np.zeros(len(points), np.int64)])

    def prune_preview(self, center: np.ndarray, radius: float) -> np.ndarray:
        """Mask of the nodes a prune would remove: internodes whose midpoint is in the brush, with subtrees (§4.4).

        ``center`` (3,) within ±MAX_COORD, ``radius`` in [0, 2 MAX_COORD].
        """
        center = check_point("center", center)
        radius = check_range("radius", radius, 0.0, 2 * MAX_COORD)
        t = self.tree
        par = np.maximum(t.parent, 0)
        mid = 0.5 * (t.pos + t.pos[par])
        hit = np.flatnonzero((np.sum((mid - center) ** 2, axis=1) <= radius * radius) & t.alive)
        hit = hit[hit >= 2]  # never the base point or the first internode
        return t.subtree_mask(hit)

    def prune(self, center: np.ndarray, radius: float) -> int:
        """Remove what :meth:`prune_preview` shows; returns the number of internodes removed."""
        n = self._remove(self.prune_preview(center, radius))
        if n:
            self.update_light()
        return n

    def _remove(self, mask: np.ndarray) -> int:
        t = self.tree
        gone = t.remove(mask)
        cast = gone[t.shadow_cast[gone]]
        t.shadow_cast[cast] = False
        self._cast(cast, -1.0)
        if t.n > 64 and t.alive.sum() < 0.7 * t.n:
            remap = t.compact()
            self._new_nodes = remap[self._new_nodes]
            self._new_nodes = self._new_nodes[self._new_nodes >= 0]
        return len(gone)

    # -- the growth step ----------------------------------------------------------------------------
    def step(self) -> StepStats:
        """One TREEGROWTHSTEP (Alg. 9.2) and marker ageing (§2.2)."""
        t0 = time.perf_counter()
        ph = _Phases()
        self._before_step()
        with ph("occupy"):
            self._occupy()
        with ph("buds"):
            buds = self._active_buds()
        grown = 0
        if len(buds.node) and len(self.markers):
            with ph("assign"):
                owner = self._assign(buds)
            with ph("growth"):
                grown = self._grow(buds, owner)
        t = self.tree
        with ph("shadow"):
            t.shadow_cast[self._new_nodes] = True
            self._cast(self._new_nodes)
        self._light_phases(ph)
        with ph("shed"):
            shed = self._remove(self.shed_mask())
        if shed:
            self._light_phases(ph)  # refresh after removals ([INFERRED], §2.10)
        with ph("age"):
            self._age_markers()
        self._after_step()
        self.phase_ms = ph.ms
        self.step_count += 1
        t = self.tree
        stats = StepStats(self.step_count, 1e3 * (time.perf_counter() - t0), t.n_internodes, len(buds.node),
                          len(self.markers), grown, shed)
        self.history.append(stats)
        return stats

    def _assign(self, buds: _Buds) -> np.ndarray:
        """Eq. 9.4 owner (M,) of every marker among ``buds`` (-1: none). The fast path keeps the marker grid
        across steps (:meth:`_keep_markers` follows kills and expiry; painting or a new marker array rebuilds
        it) and runs the parallel kernel; both equal :func:`assign_treewand` bit for bit."""
        p = self.params
        kw = {"view_radius": p["view_radius"], "view_angle": math.radians(p["view_angle"])}
        if not self._fast:
            return assign_treewand(self.markers, buds.pos, buds.dir, buds.length, **kw)
        a = getattr(self, "_asg", None)
        if a is None or getattr(self, "_asg_for", None) is not self.markers or a.m != len(self.markers) or \
                (a.view_radius, a.view_angle) != (kw["view_radius"], kw["view_angle"]):
            a = TreeWandAssigner(self.markers, **kw)
            a.view_angle = kw["view_angle"]
            self._asg, self._asg_for = a, self.markers
        return a.assign(buds.pos, buds.dir, buds.length, parallel=True)

    def _keep_markers(self, keep: np.ndarray) -> None:
        """``markers, marker_age = markers[keep], marker_age[keep]``; a kept marker grid follows (fast path)."""
        a = getattr(self, "_asg", None)
        follow = self._fast and a is not None and getattr(self, "_asg_for", None) is self.markers
        self.markers, self.marker_age = _read_only(self.markers[keep]), self.marker_age[keep]
        if follow:
            a.keep_rows(keep)
            self._asg_for = self.markers
        else:
            self._asg = self._asg_for = None

    def _before_step(self) -> None:
        """Hook run first in :meth:`step` (variants add their own points here)."""

    def _after_step(self) -> None:
        """Hook run after marker ageing in :meth:`step`."""

    def shed_mask(self) -> np.ndarray:
        """Nodes to shed this step (§2.5): vigor below the direct or subtree internode count."""
        t = self.tree
        return shed_mask_kernel(t.child, t.parent, t.alive, t.vigor, self.params["shed_count"] == "subtree")

    def _age_markers(self) -> None:
        """Markers live ``marker_lifetime`` growth steps (§2.2); variants with persistent points override this."""
        self.marker_age += 1
        keep = self.marker_age < self.params["marker_lifetime"]
        if self._fast and (not len(keep) or keep.all()):  # nothing expires: no O(M) copy of the markers
            return
        self._keep_markers(keep)

    # -- whole state (undo atoms) and pickling (dask tasks) -------------------------------------------
    def get_state(self, *, grid: bool = True) -> dict[str, Any]:
        """Copies of everything :meth:`step` and the commands change: the tree arrays, markers, step count and
        statistics, the random generator's state, the nodes whose shadows are pending, the parameters the
        derived values were computed with and (``grid``) the shadow grid, so :meth:`set_state` restores the
        engine exactly; without the grid it is rebuilt from the tree (sums in another order)."""
        state = {"params": dict(self.params), "tree": self.tree.arrays(), "nslots": self.tree.nslots,
                 "markers": _read_only(self.markers), "marker_age": self.marker_age.copy(),
                 "step_count": self.step_count,
                 "history": tuple(self.history), "rng": self.rng.bit_generator.state,
                 "new_nodes": np.array(self._new_nodes, np.int64)}
        if grid:
            g = self.grid
            state["grid"] = {"cell": float(g.cell[0]), "fine": g.F, "blocks": g.blocks[: g.nblocks].copy(),
                             "keys": keys_to_array(g.keys)}
        return state

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore what :meth:`get_state` returned (the current :attr:`params` stay: light, vigor and radius are
        recomputed when the state's were computed with other values)."""
        arrays = state["tree"]
        n = len(arrays["pos"])
        tree = Tree(state["nslots"], max(n, 1))
        for k, v in arrays.items():
            tree._data[k][:n] = v
        tree.n = n
        self.tree = tree
        self.markers, self.marker_age = _read_only(state["markers"]), state["marker_age"].copy()
        self.step_count, self.history = state["step_count"], list(state["history"])
        self.rng.bit_generator.state = state["rng"]
        self._new_nodes = state["new_nodes"].copy()
        g = state.get("grid")
        if g is None:
            self.rebuild_light()
            return
        self.grid = ShadowGrid(g["cell"], g["fine"])
        keys_from_array(self.grid.keys, np.ascontiguousarray(g["keys"], np.int64).reshape(-1, 2))
        if len(g["blocks"]):
            self.grid.blocks, self.grid.nblocks = g["blocks"].copy(), len(g["blocks"])
        if state["params"] != self.params:
            self._follow(state["params"])

    def __getstate__(self) -> dict:
        return self.get_state(grid=False)

    def __setstate__(self, state: dict) -> None:
        self.params = state["params"]
        self.rng = np.random.default_rng()
        self.set_state(state)

    def _occupy(self) -> None:
        """Remove markers within the occupation radius of a node (§2.3): new nodes vs all markers,
        and markers painted since the last step vs all nodes."""
        new, self._new_nodes = self._new_nodes, np.zeros(0, np.int64)  # shadows of these are cast already
        if not len(self.markers):
            return
        t, r = self.tree, self.params["occupation_radius"]
        live = t.pos[t.alive]
        dead = np.zeros(len(self.markers), bool)
        fresh = np.flatnonzero(self.marker_age == 0)
        h = max(r, _MIN_CELL)  # the test is exact for any cell size; the floor keeps cells apart for a tiny r
        if len(fresh):
            dead[fresh] = _within_any_trusted(PointGrid._trusted(self.markers[fresh], h), live, r)
        new = new[t.alive[new]]
        a = getattr(self, "_asg", None)
        if len(new) and self._fast and a is not None and getattr(self, "_asg_for", None) is self.markers \
                and r <= a.view_radius:  # the kept marker grid: no O(M) sort
            dead |= a.within(t.pos[new], r)
        elif len(new):
            dead |= _within_any_trusted(PointGrid._trusted(self.markers, max(h, self.params["view_radius"])),
                                        t.pos[new], r)
        if dead.any():
            self._keep_markers(~dead)

    def buds(self) -> _Buds:
        """Every bud slot of the live tree: node, slot, position and initial heading (Eqs. 9.1/9.2)."""
        t = self.tree
        node, slot = np.nonzero((t.child == BUD) & t.alive[:, None])
        return _Buds(node, slot, t.pos[node], self._bud_dirs(node, slot), None, t.bud_vigor[node, slot])

    def _bud_dirs(self, node: np.ndarray, slot: np.ndarray) -> np.ndarray:
        """Initial heading of the buds (node, slot) (Eqs. 9.1/9.2); variants override this hook."""
        p, t = self.params, self.tree
        if self._fast and type(self)._bud_dirs is GrowthEngine._bud_dirs:  # variants may turn heads in place
            return self._heading_table()[node, slot]
        return bud_headings(t.head[node], t.lat[node], slot, main_angle=math.radians(p["main_branch_angle"]),
                            lateral_angle=math.radians(p["branch_angle"]), opposite=t.nslots == 3,
                            opposite_main=p["opposite_main"])

    def _heading_table(self) -> np.ndarray:
        """(n, 3, 3) Eq. 9.1/9.2 heading of every slot of every row, kept across steps: a node's head and lateral
        vectors never change after it is appended, so only new rows are computed (elementwise, so each row is the
        same bit for bit as :func:`bud_headings` of all buds); a new tree, compaction or an angle change starts
        over."""
        p, t = self.params, self.tree
        key = (p["main_branch_angle"], p["branch_angle"], p["opposite_main"], t.nslots, getattr(t, "epoch", 0))
        c = getattr(self, "_htab", None)
        if c is None or c[0] is not t or c[1] != key or c[3] > t.n:
            c = (t, key, np.empty((max(t.n, 64), 3, 3)), 0)
        _, _, table, rows = c
        if rows < t.n:
            if len(table) < t.n:
                grown = np.empty((max(2 * len(table), t.n), 3, 3))
                grown[:rows] = table[:rows]
                table = grown
            r = np.repeat(np.arange(rows, t.n), 3)
            slot = np.tile(np.arange(3), t.n - rows)
            table[rows:t.n] = bud_headings(t.head[r], t.lat[r], slot, main_angle=math.radians(p["main_branch_angle"]),
                                           lateral_angle=math.radians(p["branch_angle"]), opposite=t.nslots == 3,
                                           opposite_main=p["opposite_main"]).reshape(-1, 3, 3)
            c = (t, key, table, t.n)
        self._htab = c
        return table[: t.n]

    def _active_buds(self) -> _Buds:
        p, t = self.params, self.tree
        allb = self.buds()
        vmax = float(allb.vigor.max()) if len(allb.vigor) else 0.0  # Eq. 9.17: "any bud on the tree"
        b = allb.subset(allb.vigor > p["activation_threshold"])
        b.length = internode_lengths(p["length_mode"], base=p["base_length"], mult=p["max_len_mult"],
                                     order=t.order[b.node] + (b.slot > 0), vigor=b.vigor, vmax=vmax)
        np.maximum(b.length, MIN_LENGTH, out=b.length)  # a no-op unless base_length is denormal
        return b

    def _grow(self, buds: _Buds, owner: np.ndarray) -> int:
        """GROWINTERNODES: buds with ≥ 1 marker add one internode along Eq. 9.5 (§2.4)."""
        p, t = self.params, self.tree
        if self._fast:  # one pass, the same sums bit for bit (tests/growth/test_interactive.py)
            count, sums = owner_sums_kernel(owner, self.markers, len(buds.node))
            grow = np.flatnonzero(count > 0)
        else:
            hit, count, grow = marker_counts(owner, len(buds.node))
            sums = sum_per_bud(owner[hit], self.markers[hit], len(buds.node)) if len(grow) else None
        if not len(grow):
            return 0
        b = buds.dir[grow]
        e = normalize(sums[grow] / count[grow, None] - buds.pos[grow], fallback=b)
        node, slot = buds.node[grow], buds.slot[grow]
        order = t.order[node] + (slot > 0)
        tr = tropism_vectors(b, t.lat[node], math.radians(p["tropism_angle"]))
        T = np.where(order >= p["tropism_min_order"], p["w_tropism"], 0.0)
        d = growth_directions(b, tr, e, p["w_heading"], T, p["w_env"])
        lat = transport_lateral(t.lat[node], t.head[node], d, math.radians(p["phyllotaxis_angle"]))
        new = t.append_many(buds.pos[grow] + buds.length[grow, None] * d, node, d, lat, order,
                            born=self.step_count + 1)
        t.child[node, slot] = new
        self._new_nodes = new
        return len(new)

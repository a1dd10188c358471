"""Colonization at scale (spec 003_implicit_sca §1.3–1.6, spec 000_treewand §2.3 Eq. 9.4; issue 13).

One marker grid and one incremental update serve classic space colonization (Runions et al. 2007)
and Tree Wand's perception-cone assignment; the modes differ in the assignment rule only.

Public API
----------
``space_colonization(markers, roots, *, influence_radius, kill_radius, step_size, max_steps=500,
children_limit=None, stall_steps=None) -> ColonizationResult``
    Classic mode, whole run.  Step semantics (issue 13): setup — every marker finds its nearest node,
    distance < d_k removes it, distance < d_i assigns it; step — every node with at least one assigned
    marker (and fewer children than ``children_limit``) adds one child at ``p + D·normalize(Σ
    normalize(m − p))`` using the previous assignment (synchronous), then assignment and killing are
    updated; stop when no markers are left, no node grew, or after ``max_steps``.  Guards of spec 003
    §1.4: pulls that cancel (|Σ| < 1e-9) do not grow, and a node never adds a child within 1e-3·D of
    an existing child (duplicate guard), so identical growth never repeats; ``stall_steps`` (off by
    default, spec 003 proposes 20) also stops after that many steps without a kill.
``SpaceColonizer(markers, roots, *, influence_radius, kill_radius, step_size, children_limit=None)``
    The same, one ``step()`` at a time (for interactive growth); ``nodes``, ``parent``,
    ``markers_left``, ``n_live``.
``space_colonization_reference(...)``
    numpy + ``scipy.spatial.cKDTree`` rebuild-and-requery version of the same semantics (the oracle).
``assign_treewand(markers, bud_pos, bud_dir, bud_len, *, view_radius, view_angle) -> owner (M,) int64``
    Eq. 9.4: each marker to the perceiving bud with the smallest d/l; ties to the lowest bud index;
    -1 if none.  ``assign_treewand_reference`` is the brute-force O(b·m) oracle.
``TreeWandAssigner(markers, *, view_radius, view_angle)``
    Keeps a marker grid across steps for the Tree Wand engine:
    ``update(bud_pos, bud_dir, bud_len, changed, *, alive=None) -> owner (M,) int32`` — incremental
    Eq. 9.4: buds are indexed by a stable id (arrays may grow), ``changed`` lists the ids added, moved,
    re-headed, re-lengthed or (de)activated since the last call (None: recompute all); markers owned by
    changed buds are released and re-offered to the buds near them (a per-call grid over buds), and the
    changed buds are offered to the markers in their view spheres, so the cost grows with the buds
    changed.  Equal to the brute-force reference at every call (tested).
    ``assign(bud_pos, bud_dir, bud_len)`` — stateless full assignment over the same grid.
    ``kill_within(points, radius)`` — occupation zones: swap-removes markers (state of ``update``
    follows), cost ~ points × markers near them.  ``alive`` (input-row mask), ``live_index``.
    New markers (painting) need a new assigner (the grid is built once).

How the speed is obtained
-------------------------
Markers are sorted once into a uniform grid (cell = influence radius / 3, which measured 2-3x faster than
cell = d_i at 200k markers; cells wholly beyond d_i or beyond the cell's worst current distance are
skipped); killing swaps a marker to the end of its cell's live range.  Each marker keeps (nearest node, squared distance); after a step only
markers within d_i of the nodes added in that step are examined.  Growth directions are exact int64
sums of quantised unit vectors (2**-38 resolution), updated as markers come and go, so only nodes whose
marker set changed are re-evaluated — a node with an unchanged set would reproduce a child the
duplicate guard rejects.  Per-marker state: 16 bytes (+ ≤ 10 bytes/marker of grid cells).
Tree Wand mode also skips grid cells whose bounding sphere misses a bud's perception cone, tests a cell's
markers in a branch-free pass without square roots before the exact test, offers buds in cell order, and keeps
the owner by input row in step (4 more bytes per marker), so an update never makes an O(M) pass.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np

from plantvr._threading import parallel_region
from plantvr._validation import check_array, check_int, check_points, check_range
from plantvr.grid import sort_by_cell
from plantvr.growth import _colonize_kernels as K
from plantvr.growth.spatial import REACH

__all__ = [
    "ColonizationResult",
    "SpaceColonizer",
    "TreeWandAssigner",
    "assign_treewand",
    "assign_treewand_reference",
    "space_colonization",
    "space_colonization_reference",
]

MAX_MARKERS = 2 ** 24  # int64 direction sums stay exact up to 2**25 markers per node


@dataclass(frozen=True)
class ColonizationResult:
    """Outcome of a space-colonization run.

    Attributes
    ----------
    nodes : (N, 3) float64 ndarray
        Node positions; roots first, then nodes in creation order.
    parent : (N,) int64 ndarray
        Parent index, -1 for roots; ``parent[i] < i``.
    markers_left : (K, 3) float64 ndarray
        Markers still alive, in input order.
    steps : int
        Growth steps performed (steps in which at least one node grew).
    step_ms : (steps,) float64 ndarray
        Wall-clock milliseconds of each step (growth + update).
    growth_steps : int
        Last step that killed a marker (0 if none did).
    step_cpu_ms : (steps,) float64 ndarray
        Process CPU milliseconds of each step.
    step_nodes, step_markers : (steps,) int64 ndarray
        Node count and live-marker count at the start of each step.
    setup_ms, setup_cpu_ms : float
        Wall / CPU milliseconds of the setup (grid build, initial assignment and kill).
    """

    nodes: np.ndarray
    parent: np.ndarray
    markers_left: np.ndarray
    steps: int
    step_ms: np.ndarray
    growth_steps: int
    step_cpu_ms: np.ndarray = None
    step_nodes: np.ndarray = None
    step_markers: np.ndarray = None
    setup_ms: float = 0.0
    setup_cpu_ms: float = 0.0


# ------------------------------------------------------------------------------------------------------------
# validation
# ------------------------------------------------------------------------------------------------------------
def _check_classic(markers, roots, influence_radius, kill_radius, step_size, max_steps, children_limit,
                   stall_steps):
    markers = check_points("markers", markers, min_rows=1)
    if len(markers) > MAX_MARKERS:
        raise ValueError(f"markers must have at most {MAX_MARKERS} rows, got {len(markers)}")
    try:
        r = np.asarray(roots, dtype=np.float64)
    except (TypeError, ValueError):
        r = None
    if r is not None and r.shape == (3,):
        roots = r.reshape(1, 3)
    roots = check_points("roots", roots, min_rows=1)
    di = check_range("influence_radius", influence_radius, 0.0, np.inf, low_open=True, high_open=True)
    dk = check_range("kill_radius", kill_radius, 0.0, di, low_open=True, high_open=True)
    d = check_range("step_size", step_size, 0.0, np.inf, low_open=True, high_open=True)
    max_steps = check_int("max_steps", max_steps, 0, 10 ** 9)
    limit = -1 if children_limit is None else check_int("children_limit", children_limit, 1, 2 ** 31 - 1)
    stall = -1 if stall_steps is None else check_int("stall_steps", stall_steps, 1, 10 ** 9)
    return markers, roots, di, dk, d, max_steps, limit, stall


def _check_bool(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a bool, got {type(value).__name__}")
    return bool(value)


def _state_bytes_per_marker(obj, names) -> float:
    """Bytes of per-marker and grid state (arrays ``names`` of ``obj``) per marker, positions excluded."""
    return sum(getattr(obj, n).nbytes for n in names) / max(len(obj.orig), 1)


# ------------------------------------------------------------------------------------------------------------
# classic mode, incremental kernel
# ------------------------------------------------------------------------------------------------------------
class SpaceColonizer:
    """Classic space colonization with incremental nearest-node maintenance (see module docstring).

    Parameters
    ----------
    markers : (M, 3) float64 array_like
        Attraction points.
    roots : (R, 3) or (3,) float64 array_like
        Start node(s).
    influence_radius : float
        d_i, in (0, inf); a marker influences its nearest node only when closer than d_i.
    kill_radius : float
        d_k, in (0, d_i); a marker closer than d_k to any node is removed.
    step_size : float
        D, in (0, inf); length of every new internode.
    children_limit : int or None
        At most this many children per node (None: unlimited).
    canonical : bool
        Runions et al. (2007) as published and as public implementations grow it: every node with attracting
        markers grows every step (no duplicate guard, no cancel guard; only an exactly zero sum, which has no
        direction, does not grow). Default False: the guarded mode (see :func:`space_colonization`).

    References
    ----------
    .. [1] Runions, Lane, Prusinkiewicz 2007, "Modeling trees with a space colonization algorithm";
       spec 003_implicit_sca §1.3–1.4 (duplicate guard [INFERRED]); issue 13 step semantics; issue 22 canonical.
    """

    def __init__(self, markers, roots, *, influence_radius: float, kill_radius: float, step_size: float,
                 children_limit: int | None = None, canonical: bool = False, _cells_per_radius: int = 3):
        markers, roots, di, dk, d, _, limit, _ = _check_classic(
            markers, roots, influence_radius, kill_radius, step_size, 0, children_limit, None)
        self.canonical = _check_bool("canonical", canonical)
        _cells_per_radius = check_int("_cells_per_radius", _cells_per_radius, 1, 8)
        self.di2, self.dk2, self.step_size, self.children_limit = di * di, dk * dk, d, limit
        self.dup2 = -1.0 if self.canonical else (K.DUP_FRACTION * d) ** 2
        self.cancel = K.CANONICAL_CANCEL if self.canonical else K.CANCEL
        self._active = np.zeros(0, np.int64)  # canonical mode: nodes with a non-zero pull
        (self.origin, self.h, self.dims, self.reach, self.pos_s, self.orig, self.cell_start,
         self.cell_live) = K.build_grid(markers, di, _cells_per_radius)
        self.cell_maxbest = np.full(len(self.cell_live), np.inf)
        m = len(markers)
        self.owner = np.full(m, -1, np.int32)
        self.best = np.full(m, np.inf)
        self.n_live = m
        cap = max(64, 2 * len(roots))
        self._alloc(cap)
        self.n = len(roots)
        self._nodes[: self.n] = roots
        self._parent[: self.n] = -1
        self.n_dirty = 0
        self.killed_total = 0
        self._update(0, self.n)

    def _alloc(self, cap):
        def grow(a, shape, dtype, fill):
            b = np.full(shape, fill, dtype)
            if a is not None:
                b[: len(a)] = a
            return b
        old = getattr(self, "_nodes", None)
        g = (lambda name: getattr(self, name, None)) if old is not None else (lambda name: None)
        self._nodes = grow(g("_nodes"), (cap, 3), np.float64, 0.0)
        self._parent = grow(g("_parent"), cap, np.int64, -1)
        self._first_child = grow(g("_first_child"), cap, np.int32, -1)
        self._next_sibling = grow(g("_next_sibling"), cap, np.int32, -1)
        self._n_children = grow(g("_n_children"), cap, np.int32, 0)
        self._acc = grow(g("_acc"), (cap, 3), np.int64, 0)
        self._dirty_flag = grow(g("_dirty_flag"), cap, np.uint8, 0)
        self._dirty_list = grow(g("_dirty_list"), cap, np.int64, 0)

    def _update(self, n_old, n_new):
        killed, self.n_dirty = K.add_nodes_kernel(
            self._nodes, n_old, n_new, self.origin, self.h, self.dims, self.reach, self.cell_start,
            self.cell_live, self.cell_maxbest, self.pos_s, self.orig, self.owner, self.best, self._acc, self._dirty_flag,
            self._dirty_list, self.n_dirty, self.di2, self.dk2)
        self.n_live -= killed
        self.killed_total += killed
        return killed

    def step(self) -> tuple[int, int]:
        """Run one synchronous growth step; returns ``(nodes added, markers killed)``."""
        if self.n_live == 0:
            return 0, 0
        need = self.n + self.n_dirty + len(self._active)
        if need > len(self._nodes):
            self._alloc(max(2 * len(self._nodes), need))
        n_old = self.n
        lst, n_list = self._dirty_list, self.n_dirty
        if self.canonical:  # every node with a pull grows again, not only those whose markers changed
            dirty = self._dirty_list[: self.n_dirty]
            self._dirty_flag[dirty] = 0
            act = np.union1d(self._active, dirty)
            self._active = lst = act[np.any(self._acc[act] != 0, axis=1)]
            n_list = len(lst)
        self.n = K.grow_kernel(self._nodes, self._parent, self._first_child, self._next_sibling,
                               self._n_children, self.n, self._acc, lst, n_list,
                               self._dirty_flag, self.children_limit, self.step_size, self.dup2, self.cancel)
        self.n_dirty = 0
        if self.n == n_old:
            return 0, 0
        killed = self._update(n_old, self.n)
        return self.n - n_old, killed

    @property
    def nodes(self) -> np.ndarray:
        """(N, 3) float64 node positions (a copy)."""
        return self._nodes[: self.n].copy()

    @property
    def parent(self) -> np.ndarray:
        """(N,) int64 parent indices, -1 for roots (a copy)."""
        return self._parent[: self.n].copy()

    @property
    def live_index(self) -> np.ndarray:
        """(K,) int64 input rows of the markers still alive, ascending."""
        return K.live_orig_kernel(self.cell_start, self.cell_live, self.orig)

    @property
    def state_bytes_per_marker(self) -> float:
        """Marker state beyond positions, grid included, in bytes per marker (issue 13: ≤ 32)."""
        return _state_bytes_per_marker(self, ("orig", "owner", "best", "cell_start", "cell_live", "cell_maxbest"))

    @property
    def markers_left(self) -> np.ndarray:
        """(K, 3) float64 live markers in input order."""
        inv = np.empty(len(self.orig), np.int64)
        inv[self.orig] = np.arange(len(self.orig))
        return self.pos_s[inv[self.live_index]]


def space_colonization(markers, roots, *, influence_radius: float, kill_radius: float, step_size: float,
                       max_steps: int = 500, children_limit: int | None = None,
                       stall_steps: int | None = None, canonical: bool = False) -> ColonizationResult:
    """Grow a tree by classic space colonization (Runions et al. 2007) with the incremental kernel.

    Parameters
    ----------
    markers : (M, 3) float64 array_like
        Attraction points (M >= 1, finite).
    roots : (R, 3) or (3,) float64 array_like
        Start node(s).
    influence_radius : float
        d_i in (0, inf).
    kill_radius : float
        d_k in (0, d_i).
    step_size : float
        D in (0, inf), the internode length.
    max_steps : int
        At most this many growth steps, in [0, 1e9].
    children_limit : int or None
        Maximum children per node, >= 1 (None: unlimited).
    stall_steps : int or None
        Stop after this many consecutive steps without a kill (spec 003 stall guard; None: off).
    canonical : bool
        Grow as Runions et al. (2007) publish it and public implementations do: every node with attracting
        markers adds a child every step, even when its markers did not change (the same child again, on top of
        the previous one) and even when the pulls nearly cancel; only an exactly zero sum does not grow. Node
        counts then equal a plain numpy + cKDTree implementation (tests/growth/test_canonical_sca.py).

    Returns
    -------
    ColonizationResult
        Nodes, parents, markers left and per-step timings.

    Notes
    -----
    The guarded mode (``canonical=False``) stays the default: a node whose markers sit out of reach (a marker
    pair pulling sideways, a marker behind the kill radius of nothing) grows the same child on top of the
    previous one every step in canonical mode, so the tree piles coincident nodes and zero-length branches
    (which every mesher has to drop) until ``max_steps``; the guards stop exactly that and change nothing
    else (a node whose markers changed grows as in canonical mode).

    References
    ----------
    .. [1] Runions et al. 2007; spec 003_implicit_sca §1.3–1.4 (guards [INFERRED]); issue 13; issue 22.
    """
    _check_classic(markers, roots, influence_radius, kill_radius, step_size, max_steps, children_limit,
                   stall_steps)
    _check_bool("canonical", canonical)
    max_steps = int(max_steps)
    t0, c0 = time.perf_counter(), time.process_time()
    sc = SpaceColonizer(markers, roots, influence_radius=influence_radius, kill_radius=kill_radius,
                        step_size=step_size, children_limit=children_limit, canonical=canonical)
    setup_ms, setup_cpu = (time.perf_counter() - t0) * 1e3, (time.process_time() - c0) * 1e3
    return _drive(sc.step, lambda: sc.n, lambda: sc.n_live, max_steps, stall_steps,
                  lambda: (sc.nodes, sc.parent, sc.markers_left), setup_ms, setup_cpu)


def _drive(step, n_nodes, n_live, max_steps, stall_steps, final, setup_ms, setup_cpu):
    ms, cpu, sn, sm = [], [], [], []
    growth_steps = 0
    since_kill = 0
    for k in range(1, max_steps + 1):
        if n_live() == 0:
            break
        nn, nl = n_nodes(), n_live()
        t0, c0 = time.perf_counter(), time.process_time()
        added, killed = step()
        t1, c1 = time.perf_counter(), time.process_time()
        if added == 0:
            break
        ms.append((t1 - t0) * 1e3)
        cpu.append((c1 - c0) * 1e3)
        sn.append(nn)
        sm.append(nl)
        if killed:
            growth_steps = k
            since_kill = 0
        else:
            since_kill += 1
            if stall_steps is not None and since_kill >= stall_steps:
                break
    nodes, parent, left = final()
    return ColonizationResult(nodes=nodes, parent=parent, markers_left=left, steps=len(ms),
                              step_ms=np.asarray(ms, np.float64), growth_steps=growth_steps,
                              step_cpu_ms=np.asarray(cpu, np.float64), step_nodes=np.asarray(sn, np.int64),
                              step_markers=np.asarray(sm, np.int64), setup_ms=setup_ms, setup_cpu_ms=setup_cpu)


# ------------------------------------------------------------------------------------------------------------
# classic mode, numpy + cKDTree reference (rebuild and requery every step)
# ------------------------------------------------------------------------------------------------------------
class _ReferenceColonizer:
    def __init__(self, markers, roots, di, dk, d, limit, exact_ties, canonical=False):
        self.markers, self.di2, self.dk2, self.d, self.limit = markers, di * di, dk * dk, d, limit
        self.di = di
        self.k = 4 if exact_ties else 1
        self.canonical = canonical
        self.dup2 = -1.0 if canonical else (K.DUP_FRACTION * d) ** 2
        self.cancel = K.CANONICAL_CANCEL if canonical else K.CANCEL
        self.nodes = roots.copy()
        self.parent = np.full(len(roots), -1, np.int64)
        self.children = [[] for _ in range(len(roots))]
        self.live = np.arange(len(markers))
        self.owner = np.full(0, -1, np.int64)
        self._assign()

    def _assign(self):
        """Nearest node of every live marker (tree rebuilt), kill below d_k, assign below d_i."""
        from scipy.spatial import cKDTree

        pts = self.markers[self.live]
        nodes, first = self.nodes, None
        if self.canonical:  # coincident children: one point per position, standing for its lowest index
            nodes, first = np.unique(self.nodes, axis=0, return_index=True)
        n = len(nodes)
        k = min(self.k, n)
        _, idx = cKDTree(nodes).query(pts, k=k, distance_upper_bound=self.di * (1 + 1e-9))
        idx = idx.reshape(len(pts), k)
        valid = idx < n
        safe = np.where(valid, idx, 0)
        dd = pts[:, None, :] - nodes[safe]
        if first is not None:
            safe = first[safe]
        d2 = dd[..., 0] * dd[..., 0] + dd[..., 1] * dd[..., 1] + dd[..., 2] * dd[..., 2]
        d2 = np.where(valid, d2, np.inf)
        if k > 1:  # exact squared distances, ties to the lowest node index
            mn = d2.min(axis=1)
            idx = np.where((d2 == mn[:, None]) & valid, safe, np.iinfo(np.int64).max).min(axis=1)
            d2 = mn
        else:
            idx, d2 = safe[:, 0], d2[:, 0]
        killed = d2 < self.dk2
        self.live = self.live[~killed]
        idx, d2 = idx[~killed], d2[~killed]
        self.owner = np.where(d2 < self.di2, idx, -1)
        return int(killed.sum())

    def step(self):
        if len(self.live) == 0:
            return 0, 0
        n = len(self.nodes)
        sel = self.owner >= 0
        own = self.owner[sel]
        acc = np.zeros((n, 3), np.int64)
        np.add.at(acc, own, K.quantize_numpy(self.markers[self.live[sel]] - self.nodes[own]))
        self.nodes, self.parent = K.grow_numpy(self.nodes, self.parent, self.children, acc, np.unique(own),
                                               self.limit, self.d, self.dup2, self.cancel)
        if len(self.nodes) == n:
            return 0, 0
        killed = self._assign()
        return len(self.nodes) - n, killed


def space_colonization_reference(markers, roots, *, influence_radius: float, kill_radius: float,
                                 step_size: float, max_steps: int = 500, children_limit: int | None = None,
                                 stall_steps: int | None = None, exact_ties: bool = True,
                                 canonical: bool = False) -> ColonizationResult:
    """Classic space colonization, rebuilding a ``cKDTree`` of all nodes and re-querying every live marker each step.

    Same parameters, semantics and result as :func:`space_colonization` (the oracle it is tested
    against).  ``exact_ties=True`` queries 4 neighbours so equidistant nodes resolve to the lowest
    index exactly; ``False`` queries 1 (the plain baseline timed by ``benchmarks/colonize.py``).
    With ``canonical=True`` exact ties are frequent (coincident children), so they are resolved over the
    coincident nodes, not over 4 neighbours.

    Returns
    -------
    ColonizationResult
        As :func:`space_colonization`.
    """
    markers, roots, di, dk, d, max_steps, limit, _ = _check_classic(
        markers, roots, influence_radius, kill_radius, step_size, max_steps, children_limit, stall_steps)
    t0, c0 = time.perf_counter(), time.process_time()
    canonical = _check_bool("canonical", canonical)
    rc = _ReferenceColonizer(markers, roots, di, dk, d, limit, exact_ties, canonical)
    setup_ms, setup_cpu = (time.perf_counter() - t0) * 1e3, (time.process_time() - c0) * 1e3
    return _drive(rc.step, lambda: len(rc.nodes), lambda: len(rc.live), max_steps, stall_steps,
                  lambda: (rc.nodes.copy(), rc.parent.copy(), markers[rc.live]), setup_ms, setup_cpu)


# ------------------------------------------------------------------------------------------------------------
# Tree Wand assignment (Eq. 9.4)
# ------------------------------------------------------------------------------------------------------------
def _check_buds(bud_pos, bud_dir, bud_len):
    bud_pos = check_points("bud_pos", bud_pos, max_abs=REACH)  # nodes overshoot a marker by one internode
    b = len(bud_pos)
    bud_dir = check_array("bud_dir", bud_dir, shape=(b, 3))
    bud_len = check_array("bud_len", bud_len, shape=(b,))
    if b and not np.all(bud_len > 0):
        raise ValueError(f"bud_len must be in (0, inf), got min {bud_len.min()!r}")
    n = np.sqrt((bud_dir * bud_dir).sum(axis=1)) if b else np.zeros(0)
    if b and not np.all(n > 0):
        raise ValueError("bud_dir must be non-zero vectors (a zero row was given)")
    return bud_pos, bud_dir / n[:, None] if b else bud_dir, bud_len


def _check_cone(view_radius, view_angle):
    vr = check_range("view_radius", view_radius, 0.0, np.inf, low_open=True, high_open=True)
    va = check_range("view_angle", view_angle, 0.0, 2 * math.pi)
    return vr, math.cos(va / 2.0)


def assign_treewand(markers, bud_pos, bud_dir, bud_len, *, view_radius: float, view_angle: float,
                    parallel: bool = False) -> np.ndarray:
    """Assign each marker to its perceiving bud with the smallest d/l (spec 000_treewand §2.3, Eq. 9.4).

    Parameters
    ----------
    markers : (M, 3) float64 array_like
        Marker positions (may be empty).
    bud_pos : (B, 3) float64 array_like
        Positions of the candidate (active) buds.
    bud_dir : (B, 3) float64 array_like
        Bud headings (normalised here).
    bud_len : (B,) float64 array_like
        l, the internode length each bud would produce, > 0.
    view_radius : float
        Perception radius, in (0, inf); d <= view_radius is perceived.
    view_angle : float
        Full apex angle of the perception cone, radians, in [0, 2π].
    parallel : bool
        Run the ``prange`` kernel (grid slabs on all numba threads); the same result bit for bit.

    Returns
    -------
    owner : (M,) int64 ndarray
        Index of the assigned bud, -1 where no bud perceives the marker; ties go to the lowest index.

    References
    ----------
    .. [1] Tree Wand thesis §9.4, Eq. 9.4; view angle read as full apex angle (spec 000_treewand §2.3 [INFERRED]).
    """
    markers = check_points("markers", markers, max_abs=REACH)
    bud_pos, _, _ = _check_buds(bud_pos, bud_dir, bud_len)
    vr, cos_half = _check_cone(view_radius, view_angle)
    parallel = _check_bool("parallel", parallel)
    if len(markers) == 0 or len(bud_pos) == 0:
        return np.full(len(markers), -1, np.int64)
    # assign() normalises bud_dir itself: normalising twice would change last bits versus the reference
    owner = TreeWandAssigner(markers, view_radius=vr, view_angle=view_angle).assign(bud_pos, bud_dir, bud_len,
                                                                                   parallel=parallel)
    return owner.astype(np.int64)


def assign_treewand_reference(markers, bud_pos, bud_dir, bud_len, *, view_radius: float,
                              view_angle: float) -> np.ndarray:
    """Brute-force O(b·m) version of :func:`assign_treewand` (the thesis's own method, §12.2); same result.

    Returns
    -------
    owner : (M,) int64 ndarray
        As :func:`assign_treewand`.
    """
    markers = check_points("markers", markers, max_abs=REACH)
    bud_pos, bud_dir, bud_len = _check_buds(bud_pos, bud_dir, bud_len)
    vr, cos_half = _check_cone(view_radius, view_angle)
    return K.treewand_assign_numpy(markers, bud_pos, bud_dir, bud_len, vr, cos_half)[0]


class TreeWandAssigner:
    """Marker grid kept across Tree Wand steps (spec 000_treewand §2.2–2.3).

    Parameters
    ----------
    markers : (M, 3) float64 array_like
        Marker positions, M >= 1.
    view_radius : float
        Perception radius, in (0, inf); also the grid cell size.
    view_angle : float
        Full apex angle of the perception cone, radians, in [0, 2π].
    """

    def __init__(self, markers, *, view_radius: float, view_angle: float, _cells_per_radius: int = 3):
        markers = check_points("markers", markers, min_rows=1, max_abs=REACH)
        self.view_radius, self.cos_half = _check_cone(view_radius, view_angle)
        _cells_per_radius = check_int("_cells_per_radius", _cells_per_radius, 1, 8)
        (self.origin, self.h, self.dims, self.reach, self.pos_s, self.orig, self.cell_start,
         self.cell_live) = K.build_grid(markers, self.view_radius, _cells_per_radius)
        self.m = len(markers)
        self._owner_s = self._owner_in = self._best_s = None  # incremental state, made by _state() when needed
        self._prev_pos = None

    def _state(self) -> None:
        """Allocate the incremental state (owner and best by sorted slot, owner by input row) on first use, so a
        stateless :meth:`assign` (the engine's path) never pays for it."""
        if self._owner_s is None:
            self._owner_s = np.full(len(self.pos_s), -1, np.int32)  # by sorted slot (keep_rows leaves dead slots)
            self._owner_in = np.full(self.m, -1, np.int32)
            self._best_s = np.full(len(self.pos_s), np.inf)

    def assign(self, bud_pos, bud_dir, bud_len, *, parallel: bool = False) -> np.ndarray:
        """Eq. 9.4 assignment of the live markers to these buds; returns owner (M,) int32 by input row (-1: none/dead).

        ``parallel`` runs :func:`~plantvr.growth._colonize_kernels.treewand_assign_parallel` (equal bit for bit).
        """
        bud_pos, bud_dir, bud_len = _check_buds(bud_pos, bud_dir, bud_len)
        parallel = _check_bool("parallel", parallel)
        owner_in = np.full(self.m, -1, np.int32)
        args = (bud_pos, bud_dir, bud_len, np.arange(len(bud_pos), dtype=np.int64), self.origin, self.h, self.dims,
                self.reach, self.cell_start, self.cell_live, self.pos_s, self.orig,
                np.full(len(self.pos_s), -1, np.int32), np.full(len(self.pos_s), np.inf), owner_in, self.view_radius,
                self.cos_half)
        if parallel:
            with parallel_region():
                K.treewand_assign_parallel(*args, numba.get_num_threads())
        else:
            K.treewand_assign_kernel(*args)
        return owner_in

    def keep_rows(self, keep) -> None:
        """Follow ``markers[keep]``: drop the markers of the rows where ``keep`` (M,) bool is False and renumber the
        rest (one pass, no re-sort); afterwards :meth:`assign` indexes the rows of ``markers[keep]``. Only for
        the stateless :meth:`assign` (the incremental state of :meth:`update` is dropped)."""
        keep = check_array("keep", keep, shape=(self.m,), dtype=bool)
        self.m = int(K.keep_rows_kernel(keep, self.cell_start, self.cell_live, self.pos_s, self.orig))
        self._owner_s = self._owner_in = self._best_s = None
        self._prev_pos = None

    def within(self, points, radius: float) -> np.ndarray:
        """(M,) bool by input row: the live markers within ``radius`` (in [0, view_radius]) of any of ``points``
        (the test of :func:`plantvr.growth.spatial.within_any`), from this grid (no new sort)."""
        points = check_points("points", points, max_abs=REACH)
        r = check_range("radius", radius, 0.0, self.view_radius)
        out = np.zeros(self.m, bool)
        if len(points):
            K.rows_within_kernel(points, r, self.origin, self.h, self.dims, self.reach, self.cell_start,
                                 self.cell_live, self.pos_s, self.orig, out)
        return out

    def kill_within(self, points, radius: float) -> int:
        """Remove live markers closer than ``radius`` to any of ``points`` (occupation zones); returns the count.

        Cost ~ points × markers within ``radius`` of them; the incremental state of :meth:`update` follows.
        """
        points = check_points("points", points, max_abs=REACH)
        r = check_range("radius", radius, 0.0, self.view_radius, low_open=True)
        if len(points) == 0:
            return 0
        self._state()
        return int(K.kill_within_kernel(points, r * r, self.origin, self.h, self.dims, self.reach, self.cell_start,
                                        self.cell_live, self.pos_s, self.orig, self._owner_s, self._best_s,
                                        self._owner_in))

    def update(self, bud_pos, bud_dir, bud_len, changed=None, *, alive=None) -> np.ndarray:
        """Incremental Eq. 9.4 assignment: cost grows with the buds changed, not with the markers alive.

        Parameters
        ----------
        bud_pos, bud_dir, bud_len : (B, 3), (B, 3), (B,) float64 array_like
            State of every bud, indexed by a stable bud id (ids only grow; B may grow between calls).
        changed : (C,) int array_like or None
            Ids whose position, heading, length or liveness differ from the previous call, plus new ids.
            None (and the first call) recomputes everything.
        alive : (B,) bool array_like or None
            Buds taking part (the active buds); default all.  Dead buds still need a positive length.

        Returns
        -------
        owner : (M,) int32 ndarray
            Bud id per input marker row (smallest d/l, ties to the lowest id), -1 if none or dead; a copy of
            state kept in step by every kernel, so no O(M) pass is needed.
        """
        bud_pos, bud_dir, bud_len = _check_buds(bud_pos, bud_dir, bud_len)
        nb = len(bud_pos)
        alive = np.ones(nb, bool) if alive is None else check_array("alive", alive, shape=(nb,), dtype=bool)
        ids_all = np.flatnonzero(alive).astype(np.int64)
        self._state()
        if changed is None or self._prev_pos is None:
            self._owner_s.fill(-1)
            self._owner_in.fill(-1)
            self._best_s.fill(np.inf)
            self._offer(bud_pos, bud_dir, bud_len, ids_all)
        else:
            changed = np.unique(check_array("changed", changed, shape=(None,), dtype=np.int64))
            if changed.size and (changed[0] < 0 or changed[-1] >= nb):
                raise ValueError(f"changed must hold bud ids in [0, {nb - 1}]")
            old = changed[changed < len(self._prev_pos)]
            affected = np.empty(len(self.pos_s), np.int64)
            n_aff = K.treewand_release_kernel(self._prev_pos[old], old, self.origin, self.h, self.dims, self.reach,
                                              self.cell_start, self.cell_live, self.orig, self._owner_s,
                                              self._best_s, self._owner_in, self.view_radius, affected, 0)
            self._offer(bud_pos, bud_dir, bud_len, changed[alive[changed]])
            if n_aff:
                order, start = sort_by_cell(bud_pos[ids_all], self.origin, self.h, self.dims, np.int64)
                K.treewand_reassign_kernel(affected[:n_aff], self.pos_s, self.orig, self._owner_s, self._best_s,
                                           self._owner_in, bud_pos, bud_dir, bud_len, ids_all[order], start,
                                           self.origin, self.h, self.dims, self.reach, self.view_radius,
                                           self.cos_half)
        self._prev_pos = bud_pos.copy()
        return self._owner_in.copy()

    def _offer(self, bud_pos, bud_dir, bud_len, ids):
        """Offer buds ``ids`` to the live markers (kernel), in cell order for cache locality (order-independent)."""
        ijk = np.floor((bud_pos[ids] - self.origin) / (self.h * (self.reach + 1)))
        ids = ids[np.lexsort((ijk[:, 2], ijk[:, 1], ijk[:, 0]))]
        K.treewand_assign_kernel(bud_pos[ids], bud_dir[ids], bud_len[ids], ids, self.origin, self.h, self.dims,
                                 self.reach, self.cell_start, self.cell_live, self.pos_s, self.orig, self._owner_s,
                                 self._best_s, self._owner_in, self.view_radius, self.cos_half)

    @property
    def live_index(self) -> np.ndarray:
        """(K,) int64 input rows of the live markers, ascending."""
        return K.live_orig_kernel(self.cell_start, self.cell_live, self.orig)

    @property
    def state_bytes_per_marker(self) -> float:
        """Marker state beyond positions, grid included, in bytes per marker (issue 13: ≤ 32)."""
        self._state()
        return _state_bytes_per_marker(self, ("orig", "_owner_s", "_owner_in", "_best_s", "cell_start",
                                              "cell_live"))

    @property
    def alive(self) -> np.ndarray:
        """(M,) bool mask of live markers by input row."""
        a = np.zeros(self.m, bool)
        a[self.live_index] = True
        return a

"""A forest of independently grown trees on dask.distributed (spec 004_treesketch §3.5–3.7; issue 11).

Every tree is a seeded :class:`~plantvr.growth.engine.GrowthEngine` with crown markers painted above its base.
Growth runs in rounds: in each round every tree advances ``steps_per_round`` steps as an independent task
(``client.map``), then, on the caller, markers that lie within the occupation radius of another tree's live
nodes are removed (crown competition for space, a simple stand-in for the voxel boundary propagation of §3.5).

With ``sketch=`` (TreeSketch options) every tree is a :class:`~plantvr.growth.sketch.SketchEngine` growing
autonomously (spec §3.7) inside its crown space: the multiplicatively weighted Voronoi cell of its base among its
neighbours (a stand-in for the layered boundary propagation of §3.5, which it resembles without the
connectedness guarantee) capped at h_max = crown_height + crown_radius, where growth halts.

With ``regions="voxels"`` the crown spaces come from the competition for crown space on layered voxels
(:mod:`plantvr.landscape.crowns`, spec §3.5): every tree keeps its markers (painted, or autonomous with
``sketch=``) inside the voxels it claimed, and :func:`regrow_tree` regrows one tree from its seed state while every
other tree is carried over unchanged (§3.8).

Tasks ship small parameter records (seed stream, base, painted crown or TreeSketch options, cropped crown space)
and seed the engine on the worker; results come back as compact arrays (tree arrays, meshes with int32 faces on the
wire), and tree states stay on their workers between competition rounds (only live nodes and markers come back).
Trees are batched into a few tasks per worker, independent trees (``compete=False`` or autonomous TreeSketch) in
one wave. The result depends only on the seed: a synchronous run, 1 or 2 worker processes and a remote cluster
give the same bytes. ``client=None`` starts a LocalCluster (2 workers) and closes it afterwards; a scheduler address
string connects to that scheduler for the call; ``client="sync"`` (or dask missing) runs the same tasks in the
calling thread. ``Forest.stats`` holds the task timing (:class:`plantvr.scaleout.TaskStats`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .._validation import MAX_COORD, MAX_COUNT, check_array, check_int, check_range
from ..growth.engine import GrowthEngine
from ..growth.sketch import SketchEngine
from ..growth.sketch_params import _check_bool
from ..params import Param, ParamTable, check_params, defaults
from ..scaleout import (  # check_client is re-exported: forest callers check their client here
    TaskStats,
    check_client,
    check_progress,
    chunks,
    connect,
    n_workers_of,
    timed,
    track,
)
from ..types import TreeArrays
from .asymmetry import cell_geometry, neighbour_asymmetry
from .crowns import (
    CrownVoxels,
    VoxelSketchEngine,
    claim_segments,
    crown_voxels,
    in_tree_region,
    region_geometry,
    tree_region,
)
from .placement import poisson_disc
from .terrain import check_field, heightfield, pair, sample_height

__all__ = [
    "FOREST",
    "Forest",
    "check_client",
    "check_sketch",
    "compete_finish_task",
    "compete_round_task",
    "crown_regions",
    "engine_from_state",
    "engine_state",
    "finish_task",
    "forest_task",
    "grow_finish_task",
    "grow_forest",
    "grow_tree_task",
    "grow_trees_task",
    "regrow_tree",
    "round_task",
    "seed_task",
    "summary_task",
    "terrain_mesh",
    "tree_mesh_task",
    "warm_up",
]


def _row(name, kind, default, doc, ref, **kw) -> Param:
    return Param(name=name, kind=kind, default=default, doc=doc, ref=ref, window="forest", **kw)


#: The forest's settings (:func:`grow_forest` keywords; the forest document's parameters).
FOREST = ParamTable("forest", (
    _row("n_trees", int, 10, "Requested trees; fewer when the plot cannot hold them at min_dist.", "§3.6",
         range=(1, 100_000), slider=(1, 400)),
    _row("width", float, 60.0, "Plot extent along x.", "§3.6", unit="m", range=(0.0, MAX_COORD), low_open=True,
         slider=(5.0, 2000.0), log=True),
    _row("depth", float, 60.0, "Plot extent along z.", "§3.6", unit="m", range=(0.0, MAX_COORD), low_open=True,
         slider=(5.0, 2000.0), log=True),
    _row("min_dist", float, 8.0, "Poisson-disc distance between tree bases.", "§3.6", unit="m",
         range=(0.0, MAX_COORD), low_open=True, slider=(0.5, 200.0), log=True),
    _row("rounds", int, 4, "Growth rounds (markers claimed by neighbours are removed between rounds).", "§3.5",
         range=(0, 10_000), slider=(0, 40)),
    _row("steps_per_round", int, 5, "Growth steps of every tree per round.", "§3.5", range=(1, 10_000),
         slider=(1, 40)),
    _row("crown_height", float, 7.0, "Height of the painted crown centre above the base.", "§3.5", unit="m",
         range=(0.0, 1e6), slider=(0.0, 60.0)),
    _row("crown_radius", float, 5.0, "Radius of the painted crown.", "§3.5", unit="m", range=(0.0, 1e6),
         low_open=True, slider=(0.2, 50.0), log=True),
    _row("n_darts", int, 300, "Poisson-dart candidates painted per crown.", "§3.5", range=(0, 10_000_000),
         slider=(0, 2000)),
    _row("terrain_amplitude", float, 3.0, "Height range of the seeded terrain.", "§3.2", unit="m",
         range=(0.0, 1e6), slider=(0.0, 40.0)),
    _row("seed", int, 0, "Seed of the terrain, the placement and every tree.", "§3.6", range=(0, 2 ** 63 - 1)),
    _row("compete", bool, True, "Remove markers claimed by neighbours between rounds.", "§3.5", range=(0, 1)),
    _row("regions", str, "voronoi", "Crown space: weighted Voronoi cells or layered voxels.", "§3.5",
         choices=("voronoi", "voxels")),
    _row("geometry", bool, False, "Also build every tree's branch mesh.", "§3.10", range=(0, 1)),
), {"forest": ("Forest", "#4f7a28")})


@dataclass(eq=False)
class Forest:
    """Grown forest: ``bases`` (N, 3) world base points (y up), ``trees`` one dict of tree arrays per tree in
    world coordinates (``pos`` shifted by the base), ``heights`` the terrain, ``timings`` seconds per round (one
    entry for the whole growth when autonomous TreeSketch trees run all their rounds in one task),
    ``meshes`` the branch meshes (world coordinates) when grown with ``geometry=True``, ``voxels`` the crown-space
    claims of ``regions="voxels"``, ``seeds`` every tree's initial engine state and ``config`` the growth settings
    (both for :meth:`regrow`), ``stats`` the task timing of the growth (:class:`plantvr.scaleout.TaskStats`
    as a dict; not state). :class:`plantvr.documents.forest.ForestDocument` holds one as its state; the glTF
writer of :mod:`plantvr.io` writes one."""

    bases: np.ndarray
    trees: list[dict[str, np.ndarray]]
    heights: np.ndarray
    size: tuple[float, float]
    timings: list[float] = field(default_factory=list)
    meshes: list[tuple[np.ndarray, np.ndarray]] | None = None
    voxels: CrownVoxels | None = None
    seeds: list[dict[str, Any]] | None = None
    config: dict[str, Any] | None = None
    stats: dict[str, Any] | None = None

    @property
    def n_internodes(self) -> int:
        """Live internodes over all trees."""
        return int(sum(t["alive"][1:].sum() for t in self.trees))

    def regrow(self, tree: int, *, params: dict[str, Any] | None = None, sketch: dict[str, Any] | None = None
               ) -> Forest:
        """:func:`regrow_tree` of this forest."""
        return regrow_tree(self, tree, params=params, sketch=sketch)


def terrain_mesh(heights: np.ndarray, size: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Height field (ny, nx) over [0, size[0]] x [0, size[1]] (x columns, z rows, y up) as a triangle mesh
    (vertices (ny nx, 3), faces (2 (ny-1)(nx-1), 3), normals up); the grid nodes are those of
    :func:`~plantvr.landscape.terrain.sample_height`."""
    h = check_field("heights", heights)
    ny, nx = h.shape
    if ny < 2 or nx < 2:
        raise ValueError(f"heights must be at least 2 x 2, got {h.shape}")
    W, D = pair("size", size)
    X, Z = np.meshgrid(np.linspace(0.0, W, nx), np.linspace(0.0, D, ny))
    v = np.column_stack([X.ravel(), h.ravel(), Z.ravel()])
    idx = np.arange(ny * nx).reshape(ny, nx)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([c, b, d])])
    return v, f


def engine_state(e: GrowthEngine) -> dict[str, Any]:
    """Plain, picklable state of an engine (its ``__getstate__``: tree arrays, markers, marker ages, step count,
    RNG state; a SketchEngine adds its options), without the step history."""
    return {**e.__getstate__(), "history": []}


def engine_from_state(params: dict[str, Any], state: dict[str, Any]) -> GrowthEngine:
    """Rebuild the engine of :func:`engine_state` (light grid recomputed from the live nodes) with ``params``."""
    cls = (VoxelSketchEngine if "voxel_region" in state else SketchEngine) if "sketch_state" in state else GrowthEngine
    e = cls.__new__(cls)
    e.__setstate__({**state, "params": dict(params) if params else state["params"],
                    "tree": {k: v.copy() for k, v in state["tree"].items()},
                    "markers": state["markers"].copy(), "marker_age": state["marker_age"].copy()})
    return e


def grow_tree_task(params: dict[str, Any], state: dict[str, Any], steps: int) -> dict[str, Any]:
    """One tree's round: rebuild, step ``steps`` times, return the new state (pure function of its inputs)."""
    e = engine_from_state(params, state)
    for _ in range(steps):
        e.step()
    return engine_state(e)


def grow_trees_task(params: dict[str, Any], states: list[dict[str, Any]], steps: int) -> list[dict[str, Any]]:
    """A batch of :func:`grow_tree_task` calls in one task (fewer, larger tasks amortise dask's overhead)."""
    return [grow_tree_task(params, s, steps) for s in states]


def tree_mesh_task(tree: dict[str, np.ndarray], lod: tuple[int, int] = (6, 32)) -> tuple[np.ndarray, np.ndarray]:
    """Branch mesh (vertices (V, 3) float64, faces (F, 3) int64) of one tree's arrays (plantvr.geometry)."""
    from ..geometry.mesh import build_branch_mesh

    alive = tree["alive"]
    if alive.sum() < 2:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    main = np.where(tree["child"][:, 0] >= 0, tree["child"][:, 0], -1)
    radius = np.where(alive, np.maximum(tree["radius"], 1e-6), tree["radius"])
    m = build_branch_mesh(tree["pos"], tree["parent"], radius, alive=alive, main_child=main, lod=lod)
    return m.vertices, m.faces


def tree_meshes_task(trees: list[dict[str, np.ndarray]]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Batch of :func:`tree_mesh_task`."""
    return [tree_mesh_task(t) for t in trees]


def warm_up() -> float:
    """Grow one small tree for a few rounds so numba kernels are loaded in this process; returns seconds.

    Run it on every worker (``client.run(warm_up)``) before timing: the first growth in a fresh process
    spends seconds loading compiled kernels.
    """
    import time

    t = time.perf_counter()
    p = defaults()
    s = _seed_states(p, np.zeros((1, 3)), 0, 5.0, 4.0, 200)[0][0]
    for _ in range(3):
        s = grow_tree_task(p, s, 4)
    tree_mesh_task(s["tree"])
    return time.perf_counter() - t


def round_task(params: dict[str, Any], states: list[dict[str, Any]], drops: list, steps: int) -> list[dict]:
    """Drop the markers claimed by neighbours (``drops[i]`` bool mask or None), then grow ``steps`` steps."""
    out = []
    for st, d in zip(states, drops):
        if d is not None and d.any():
            st = {**st, "markers": st["markers"][~d], "marker_age": st["marker_age"][~d]}
        out.append(grow_tree_task(params, st, steps) if steps else st)
    return out


def summary_task(states: list[dict[str, Any]]) -> list[tuple[np.ndarray, np.ndarray]]:
    """What competition needs from each tree: live node positions and markers (tree-local)."""
    return [(st["tree"]["pos"][st["tree"]["alive"]], st["markers"]) for st in states]


def finish_task(states: list[dict[str, Any]], drops: list, bases: np.ndarray, geometry: bool) -> list[tuple]:
    """Apply the last drops; return (tree arrays in world coordinates, mesh or None) per tree."""
    out = []
    for st, b in zip(round_task({}, states, drops, 0), bases):
        t = {k: v.copy() for k, v in st["tree"].items()}
        t["pos"] = t["pos"] + b
        out.append((t, tree_mesh_task(t) if geometry else None))
    return out


def grow_finish_task(params: dict[str, Any], states: list[dict[str, Any]], rounds: int, steps: int,
                     bases: np.ndarray, geometry: bool) -> list[tuple]:
    """Independent trees: every round of :func:`grow_tree_task`, then :func:`finish_task`, in one task."""
    out = []
    for st in states:
        for _ in range(rounds):
            st = grow_tree_task(params, st, steps)
        out.append(st)
    return finish_task(out, [None] * len(out), bases, geometry)


#: Tasks per worker of a forest wave: a few per worker balance uneven trees at a small per-task overhead.
_PER_WORKER = 6


def _pack_mesh(m: tuple[np.ndarray, np.ndarray] | None) -> tuple | None:
    """A mesh as it travels back from a task: faces as int32 when they fit (a third fewer bytes)."""
    if m is None:
        return None
    v, f = m
    if f.dtype == np.int64 and (not f.size or f.max() < 2 ** 31):
        return v, f.astype(np.int32), "int64"
    return v, f, f.dtype.str


def _unpack_mesh(m: tuple | None) -> tuple[np.ndarray, np.ndarray] | None:
    """Inverse of :func:`_pack_mesh` (the same bytes as the task's mesh)."""
    return None if m is None else (m[0], m[1].astype(m[2]))


def _state(params: dict[str, Any], item: dict[str, Any]) -> dict[str, Any]:
    """An engine state from a parameter record (seeded here) or a state as it is."""
    return seed_task(params, item) if "spawn" in item else item


def forest_task(params: dict[str, Any], items: list[dict[str, Any]], rounds: int, steps: int,
                bases: np.ndarray, geometry: bool) -> list[tuple]:
    """Independent trees, one batch: seed each from its record, grow every round (:func:`grow_tree_task`),
    return (seed state, tree arrays in world coordinates, packed mesh or None) per tree."""
    out = []
    for item, b in zip(items, bases):
        seed = _state(params, item)
        st = seed
        for _ in range(rounds):
            st = grow_tree_task(params, st, steps)
        (t, m), = finish_task([st], [None], b[None], geometry)
        out.append((seed, t, _pack_mesh(m)))
    return out


def compete_round_task(params: dict[str, Any], prev: Any, drops: list, steps: int) -> tuple:
    """One round of a competing batch: ``prev`` is the batch's parameter records (first round) or the previous
    round's timed result; drop the claimed markers, grow; returns (states, summaries, seed states or None)."""
    if isinstance(prev, list):
        states = [seed_task(params, r) for r in prev]
        seeds = states
    else:
        states, seeds = prev[0][0], None
    states = round_task(params, states, drops, steps)
    return states, summary_task(states), seeds


def compete_finish_task(params: dict[str, Any], prev: Any, drops: list, bases: np.ndarray, geometry: bool
                        ) -> list[tuple]:
    """The last drops and the meshes of a competing batch: (seed state or None, world tree arrays, packed mesh)."""
    if isinstance(prev, list):
        states = seeds = [seed_task(params, r) for r in prev]
    else:
        states, seeds = prev[0][0], [None] * len(prev[0][0])
    return [(sd, t, _pack_mesh(m)) for sd, (t, m) in zip(seeds, finish_task(states, drops, bases, geometry))]


def _small(timed_round: tuple) -> tuple:
    """What the caller needs of a timed :func:`compete_round_task` (summaries, seed states, seconds, CPU)."""
    (_, summaries, seeds), wall, cpu = timed_round
    return summaries, seeds, wall, cpu


class _Waves:
    """Submit timed tasks to a runner (``"sync"``: call now) and gather them with progress."""

    def __init__(self, runner: Any, stats: TaskStats, progress: bool):
        self.runner, self.stats, self.progress = runner, stats, progress

    def submit(self, fn, *args):
        if self.runner == "sync":
            return timed(fn, *args)
        return self.runner.submit(timed, fn, *args, pure=False)

    def small(self, x):
        return _small(x) if self.runner == "sync" else self.runner.submit(_small, x, pure=False)

    def gather(self, xs: list, desc: str, *, timed_results: bool = True) -> list:
        if self.runner != "sync":
            track(xs, progress=self.progress, desc=desc)
            xs = self.runner.gather(xs)
        if timed_results:
            self.stats.add(0.0, [(w, c) for _, w, c in xs])
            return [r for r, _, _ in xs]
        return xs


def _competing(waves: _Waves, p, records, parts, bases, rounds, steps, geometry, radius) -> tuple[list, list]:
    """Rounds with crown competition between them (a barrier per round); batches stay on their workers."""
    import time

    prev: list = [[records[i] for i in c] for c in parts]
    drops: list = [None] * len(records)
    seeds: list = [None] * len(records)
    timings = []
    for r in range(rounds):
        t0 = time.perf_counter()
        prev = [waves.submit(compete_round_task, p, b, [drops[i] for i in c], steps) for b, c in zip(prev, parts)]
        small = waves.gather([waves.small(x) for x in prev], f"round {r + 1}/{rounds}", timed_results=False)
        waves.stats.add(0.0, [(w, c) for *_, w, c in small])
        summaries = [x for sm, *_ in small for x in sm]
        if r == 0:
            seeds = [x for _, sd, *_ in small for x in sd]
        drops = _compete_masks(summaries, bases, radius)
        timings.append(time.perf_counter() - t0)
    got = waves.gather([waves.submit(compete_finish_task, p, b, [drops[i] for i in c], bases[c], geometry)
                        for b, c in zip(prev, parts)], "meshes")
    if rounds:
        got = [[(sd, t, m) for sd, (_, t, m) in zip((seeds[i] for i in c), part)] for part, c in zip(got, parts)]
    return got, timings


def _compete_masks(summaries: list[tuple[np.ndarray, np.ndarray]], bases: np.ndarray, radius: float) -> list:
    """Per tree, the mask of its markers within ``radius`` of a live node of another tree (None: none).

    Vectorised: a marker is claimed when the ball around it holds more nodes of all trees than of its own
    tree (both counted by cKDTree ball queries on the same world coordinates)."""
    nodes = [nd + bases[i] for i, (nd, _) in enumerate(summaries)]
    allp = np.concatenate(nodes) if nodes else np.zeros((0, 3))
    kd = cKDTree(allp)
    drops = []
    for i, (_, m) in enumerate(summaries):
        if not len(m):
            drops.append(None)
            continue
        q = m + bases[i]
        total = kd.query_ball_point(q, radius, return_length=True)
        own = cKDTree(nodes[i]).query_ball_point(q, radius, return_length=True) if len(nodes[i]) else 0
        d = np.asarray(total > own)
        drops.append(d if d.any() else None)
    return drops


def _compete(states: list[dict], bases: np.ndarray, radius: float) -> None:
    """In-place version of the competition on full states (tests)."""
    drops = _compete_masks(summary_task(states), bases, radius)
    for s, d in zip(states, drops):
        if d is not None:
            s["markers"], s["marker_age"] = s["markers"][~d], s["marker_age"][~d]


def _hero_tree(name: str, t: Any) -> dict[str, np.ndarray]:
    """A hero tree as engine arrays (``pos``, ``parent``, ``radius``, ``order``, ``alive``, ``child``, copies): a
    :class:`~plantvr.types.TreeArrays` (every node live, ``child[:, 0]`` its main child), or a dict of a grown
    tree's arrays, checked through :meth:`TreeArrays.from_arrays` (shapes, finite bounded positions and radii,
    parents before children) plus its ``alive`` and ``child`` arrays."""
    if isinstance(t, TreeArrays):
        n = len(t)
        if n > MAX_COUNT:
            raise ValueError(f"{name} must have at most {MAX_COUNT} nodes, got {n}")
        return {"pos": t.pos.copy(), "parent": t.parent.copy(), "radius": t.radius.copy(), "order": t.order.copy(),
                "alive": np.ones(n, bool), "child": t.main_child[:, None].copy()}
    if not isinstance(t, dict) or not {"pos", "parent", "alive", "radius", "child"} <= set(t):
        raise ValueError(f"{name} must be a TreeArrays or hold the arrays pos, parent, alive, radius, child")
    n = len(np.asarray(t["pos"]))
    if n > MAX_COUNT:
        raise ValueError(f"{name} must have at most {MAX_COUNT} nodes, got {n}")
    try:
        ta = TreeArrays.from_arrays(t["pos"], t["parent"], t["radius"], t.get("order"))
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None
    child = np.asarray(t["child"])
    if child.ndim != 2 or len(child) != n or child.dtype.kind not in "iu" or (child.size and child.max() >= n) \
            or (child.size and child.min() < -2):
        raise ValueError(f"{name} child must be ({n}, slots) indices below {n} (or -1 / -2)")
    alive = np.asarray(t["alive"])
    if alive.shape != (n,) or alive.dtype != bool:
        raise ValueError(f"{name} alive must be a ({n},) bool array")
    out = {key: np.asarray(v).copy() for key, v in t.items()}
    out.update(pos=ta.pos.copy(), radius=ta.radius.copy())
    return out


def crown_regions(bases: np.ndarray, *, reach: float, h_max: float, weights: np.ndarray | None = None
                  ) -> list[dict[str, Any]]:
    """Per tree, the SketchEngine ``region`` of its crown space: neighbours within ``reach`` (x, z distance) as
    sites relative to the base, with their weights (default 1: plain Voronoi cells), and the height cap."""
    bases = check_array("bases", bases, shape=(None, 3), max_abs=MAX_COORD)
    reach = check_range("reach", reach, 0.0, 4 * MAX_COORD)
    h_max = check_range("h_max", h_max, 0.0, MAX_COORD, low_open=True)
    w = np.ones(len(bases)) if weights is None else check_array("weights", weights, shape=(len(bases),), max_abs=1e12)
    xz = bases[:, [0, 2]]
    kd = cKDTree(xz)
    out = []
    for i, nb in enumerate(kd.query_ball_point(xz, reach)):
        nb = sorted(j for j in nb if j != i)
        out.append({"sites": (xz[nb] - xz[i]).tolist(), "weights": w[nb].tolist(), "weight": float(w[i]),
                    "h_max": float(h_max)})
    return out


def _voxel_setup(bases, size, crown_height, crown_radius, scales, shape):
    """Crown voxels of every tree (spec §3.5): rates from the projected crown areas pi (S C_w / 2)^2 (ERRATUM
    E3), h_max = S (crown_height + crown_radius), starting circles of radius 0.1 S crown_radius [INFERRED]."""
    areas = np.pi * (scales * crown_radius) ** 2
    h_max = scales * (crown_height + crown_radius)
    return crown_voxels(bases[:, [0, 2]], areas, h_max, size=size, shape=shape,
                        trunk_radius=0.1 * scales * crown_radius)


def _hero_segments(tree: dict[str, np.ndarray], base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World segments (starts, ends) of a hero tree's live internodes (``pos`` tree-local, base at the origin)."""
    idx = np.flatnonzero(tree["alive"] & (tree["parent"] >= 0))
    return tree["pos"][tree["parent"][idx]] + base, tree["pos"][idx] + base


def _tree_records(params, bases, seed, crown_height, crown_radius, n_darts, sketch=None, size=None, lean=False,
                  regions="voronoi", scales=None, voxel_shape=(20, 128, 128), heroes=()):
    """Per tree, the small parameter record its task seeds the engine from (and the crown voxels in
    ``regions="voxels"`` mode): ``spawn`` (forest seed, tree index), then ``paint`` (crown centre height,
    radius, darts) or ``sketch`` options with the ``region`` (Voronoi cell) or ``h_max``, and ``vreg`` (the
    tree's cropped voxels) with voxel regions. ``heroes``: (tree-local tree
    arrays, world base) of pre-designed trees that do not compete but claim the voxels their segments pass
    through (spec §3.5), before the grown trees' regions are cut out."""
    S = np.ones(len(bases)) if scales is None else scales
    voronoi = voxels = None
    xz = bases[:, [0, 2]]
    if regions == "voxels":
        voxels = _voxel_setup(bases, size, crown_height, crown_radius, S, voxel_shape)
        if heroes:
            n = len(bases)
            hh = [max(float(t["pos"][t["alive"], 1].max()), 1e-6) for t, _ in heroes]
            voxels = CrownVoxels(voxels.owner, voxels.size, voxels.layer_height, np.r_[voxels.h_max, hh])
            for k, (t, b) in enumerate(heroes):
                s0, s1 = _hero_segments(t, np.array([b[0], 0.0, b[2]]))  # layers above the hero base
                voxels = claim_segments(voxels, n + k, s0, s1)
    if sketch is not None:
        if regions == "voronoi":
            voronoi = crown_regions(bases, reach=4.0 * crown_radius * S.max(), h_max=crown_height + crown_radius,
                                    weights=None if scales is None else S ** 2)
            if scales is not None:
                voronoi = [{**r, "h_max": float(s * r["h_max"])} for r, s in zip(voronoi, S)]
        if lean:  # Eqs. 6.3-6.4 with the geometry of the same regions
            if voxels is not None:
                C, B = region_geometry(voxels)
            else:
                C, B = cell_geometry(xz, size, weights=None if scales is None else S ** 2)
            C, B = C[:len(bases)], B[:len(bases)]
            V = neighbour_asymmetry(xz, S ** 2, 2.0 * crown_radius * S, centroids=C, bounding=B)
            sketch = [{**sketch, "asymmetry": v.tolist()} for v in V]
    records = []
    for i in range(len(bases)):
        rec: dict[str, Any] = {"spawn": (int(seed), i)}
        if voxels is not None:
            rec["vreg"] = {**tree_region(voxels, i), "base": bases[i].copy()}
        if sketch is None:
            rec["paint"] = (float(S[i] * crown_height), float(S[i] * crown_radius), int(n_darts))
        else:
            rec["sketch"] = {"mode": "autonomous", **(sketch[i] if isinstance(sketch, list) else sketch)}
            rec["region"] = None if voxels is not None else voronoi[i]
            if voxels is not None:
                rec["h_max"] = float(voxels.h_max[i])
        records.append(rec)
    return records, voxels


def seed_task(params: dict[str, Any], rec: dict[str, Any]) -> dict[str, Any]:
    """A tree's initial engine state from its parameter record (:func:`_tree_records`: seed stream, painted crown
    or TreeSketch options, crown space); a pure function of its inputs, run on the workers."""
    ss = np.random.SeedSequence(rec["spawn"][0], spawn_key=(rec["spawn"][1],))  # == SeedSequence(seed).spawn(n)[i]
    vreg = rec.get("vreg")
    if "paint" in rec:
        h, r, n_darts = rec["paint"]
        e = GrowthEngine(params, rng=np.random.default_rng(ss))
        e.paint(np.array([0.0, h, 0.0]), r, n_darts)
        if vreg is not None:  # painted markers are kept only inside the tree's voxels
            keep = in_tree_region(vreg, e.markers, vreg["base"])
            e.markers, e.marker_age = e.markers[keep], e.marker_age[keep]
    else:
        rs = int(ss.generate_state(1, np.uint64)[0] >> np.uint64(2))
        if vreg is None:
            e = SketchEngine(params, rng=rs, **rec["sketch"], region=rec["region"])
        else:
            reg = {"sites": [], "weights": [], "weight": 1.0, "h_max": rec["h_max"]}
            e = VoxelSketchEngine(params, rng=rs, voxel_region=vreg, **rec["sketch"], region=reg)
    return engine_state(e)


def _seed_states(params, bases, seed, crown_height, crown_radius, n_darts, sketch=None, size=None, lean=False,
                 regions="voronoi", scales=None, voxel_shape=(20, 128, 128), heroes=()):
    """Initial engine states of :func:`_tree_records` (and the crown voxels in ``regions="voxels"`` mode)."""
    records, voxels = _tree_records(params, bases, seed, crown_height, crown_radius, n_darts, sketch, size, lean,
                                    regions, scales, voxel_shape, heroes)
    return [seed_task(params, r) for r in records], voxels


def check_sketch(sketch: dict[str, Any] | None) -> dict[str, Any] | None:
    """A copy of the TreeSketch options of a forest (None stays None), every option checked.

    Raises ``ValueError`` for a non-dict, for the options :func:`grow_forest` sets per tree (``region``,
    ``asymmetry``, ``rng``, ``voxel_region``) and for any option :class:`~plantvr.growth.sketch.SketchEngine`
    refuses (the message prefixed ``sketch:``).
    """
    if sketch is None:
        return None
    if not isinstance(sketch, dict):
        raise ValueError(f"sketch must be a dict of SketchEngine options or None, got {sketch!r}")
    bad = sorted(set(sketch) & {"region", "asymmetry", "rng", "voxel_region"})
    if bad:
        raise ValueError(f"sketch must not set {bad} (grow_forest sets each tree's own)")
    try:
        SketchEngine._check_options({"mode": "autonomous", **sketch})
    except ValueError as exc:
        raise ValueError(f"sketch: {exc}") from None
    return dict(sketch)


def grow_forest(n_trees: int = 10, *, size: tuple[float, float] = (60.0, 60.0), min_dist: float = 8.0,
                rounds: int = 4, steps_per_round: int = 5, crown_height: float = 7.0, crown_radius: float = 5.0,
                n_darts: int = 300, terrain_amplitude: float = 3.0, params: dict[str, Any] | None = None,
                seed: int = 0, client: Any = None, n_workers: int = 2, processes: bool = False,
                compete: bool = True, tasks_per_round: int | None = None, geometry: bool = False,
                sketch: dict[str, Any] | None = None, lean: bool = False, regions: str = "voronoi",
                voxel_shape: tuple[int, int, int] = (20, 128, 128),
                scale_range: tuple[float, float] = (1.0, 1.0), positions: np.ndarray | None = None,
                scales: np.ndarray | None = None, heroes: list[dict[str, Any]] | None = None,
                progress: bool = False) -> Forest:
    """Place ``n_trees`` by Poisson disc on a seeded terrain and grow them as independent dask tasks.

    Parameters
    ----------
    n_trees : int
        Requested trees; fewer when the area cannot hold them at ``min_dist``.
    client : None, "sync", a scheduler address or a dask ``Client``
        ``None`` starts ``LocalCluster(n_workers, processes=processes, threads_per_worker=1)`` and closes it
        after; ``"sync"`` (also the fallback without dask) runs tasks in this thread; an address
        (``"tcp://host:port"``) connects a client to that scheduler for this call; a client is used as is.
        Tasks get parameter records (seed stream, base, crown) and return compact arrays; the timing of the
        tasks is in ``Forest.stats``. Use process workers for a speed-up (thread workers share the GIL).
    tasks_per_round : int, optional
        Trees are grown in this many batches per round (default: 6 per worker); the result does not depend on
        it.
    compete : bool
        Remove markers claimed by neighbours (within the occupation radius of their nodes) between rounds.

    geometry : bool
        Also build each tree's branch mesh (world coordinates) as a task; stored in ``Forest.meshes``.
    sketch : dict, optional
        TreeSketch options (:class:`~plantvr.growth.sketch.SketchEngine` keywords, e.g. ``{"n_max": 3}``): grow
        every tree autonomously inside its crown space (weighted Voronoi cell, h_max) instead of painted crowns.
    lean : bool
        With ``sketch``: add the neighbourhood-asymmetry tropism (Eqs. 6.3–6.5, alpha_a = 1, alpha_d = 2,
        r_i = the crown width 2 crown_radius), so trees at cluster edges lean into open space.
    regions : {"voronoi", "voxels"}
        Crown space of each tree. ``"voronoi"``: with ``sketch``, the multiplicatively weighted Voronoi cell of
        its base among its neighbours (painted trees are not restricted). ``"voxels"``: competition for crown
        space on layered voxels (:func:`~plantvr.landscape.crowns.crown_voxels`, spec §3.5) over the plot; each
        tree's markers (painted or autonomous) are kept only inside its voxels, and ``Forest.voxels`` holds the
        claims. Trees depend on their regions only, which depend on the representative shapes, not on growth.
    voxel_shape : (int, int, int)
        (layers, rows along z, columns along x) of the voxel grid; layers span the tallest h_max.
    scale_range : (float, float)
        Per-tree scale S_i drawn uniformly (its own seeded stream): crown height and radius, h_max and the
        crown area (competition rate, Voronoi weight S^2) scale with it. (1, 1) keeps every tree equal.
    positions : (N, 2) float64 array, optional
        Tree bases (x, z) in metres, e.g. a :func:`~plantvr.landscape.distribution.distribute` result's ``xy``,
        instead of the Poisson-disc placement (``n_trees`` and ``min_dist`` are then not used).
    scales : (N,) float64 array, optional
        Per-tree scales S_i (> 0) instead of ``scale_range`` (e.g. the distribution's ``scale``).
    heroes : list of dict, optional
        Hero trees (spec §3.4.3, §3.5), ``{"tree": a TreeArrays, or a grown tree's arrays (``pos``, ``parent``,
        ``alive``, ``radius``, ``child``), with the base at the origin, "position": (x, z)}``: placed as they are,
        not grown and not regrown; with ``regions="voxels"`` they claim every voxel their internodes pass through before
        the other trees' regions are cut out. They come after the grown trees in ``Forest.trees``.
    progress : bool
        Show tasks completing: dask's progress bar in a notebook, tqdm in scripts.

    Returns
    -------
    Forest
        Identical bytes for a seed whatever the client or the worker count.
    """
    import time

    n_trees, seed, terrain_amplitude = (FOREST["n_trees"].check(n_trees), FOREST["seed"].check(seed),
                                        FOREST["terrain_amplitude"].check(terrain_amplitude))
    compete, geometry, lean, processes = (_check_bool("compete", compete), _check_bool("geometry", geometry),
                                          _check_bool("lean", lean), _check_bool("processes", processes))
    if params is not None and not isinstance(params, dict):
        raise ValueError(f"params must be a dict of growth parameters or None, got {type(params).__name__}")
    client = check_client(client)
    progress = check_progress(progress)
    rounds, steps_per_round = FOREST["rounds"].check(rounds), FOREST["steps_per_round"].check(steps_per_round)
    min_dist = FOREST["min_dist"].check(min_dist)
    crown_height, crown_radius = FOREST["crown_height"].check(crown_height), FOREST["crown_radius"].check(crown_radius)
    n_darts = FOREST["n_darts"].check(n_darts)
    n_workers = check_int("n_workers", n_workers, 1, 1024)
    if tasks_per_round is not None:
        tasks_per_round = check_int("tasks_per_round", tasks_per_round, 1, 1_000_000)
    if n_trees * n_darts > MAX_COUNT:
        raise ValueError(f"n_trees * n_darts must be at most {MAX_COUNT}, got {n_trees} * {n_darts}")
    size = pair("size", size)
    regions = FOREST["regions"].check(regions)
    if isinstance(voxel_shape, (str, bytes)) or not hasattr(voxel_shape, "__len__") or len(voxel_shape) != 3:
        raise ValueError(f"voxel_shape must be (layers, ny, nx), got {voxel_shape!r}")
    voxel_shape = (check_int("voxel_shape[0]", voxel_shape[0], 1, 4096),
                   check_int("voxel_shape[1]", voxel_shape[1], 1, 8192),
                   check_int("voxel_shape[2]", voxel_shape[2], 1, 8192))
    s_lo, s_hi = pair("scale_range", scale_range, high=1e6)
    if s_hi < s_lo:
        raise ValueError(f"scale_range must be (low, high) with low <= high, got {scale_range!r}")
    p = check_params({**defaults(), **(params or {})})
    sketch = check_sketch(sketch)  # every option checked before anything is grown
    if heroes is not None and not isinstance(heroes, (list, tuple)):
        raise ValueError(f"heroes must be a list of dicts or None, got {type(heroes).__name__}")
    rng = np.random.default_rng(seed)
    hf = heightfield((64, 64), amplitude=terrain_amplitude, rng=rng)
    if positions is None:
        xz = poisson_disc(size, min_dist, max_points=n_trees, rng=rng)
    else:
        xz = check_array("positions", positions, shape=(None, 2), min_rows=1, max_abs=MAX_COORD)
        if len(xz) > 100_000:
            raise ValueError(f"positions must hold at most 100000 trees, got {len(xz)}")
        if len(xz) * n_darts > MAX_COUNT:
            raise ValueError(f"positions * n_darts must be at most {MAX_COUNT}, got {len(xz)} * {n_darts}")
        if np.any(xz < 0) or np.any(xz > size):
            raise ValueError(f"positions must lie in [0, {size[0]}] x [0, {size[1]}]")
    bases = np.column_stack([xz[:, 0], sample_height(hf, size, xz), xz[:, 1]])
    hero_in = []
    for k, h in enumerate(heroes or []):
        if not isinstance(h, dict) or set(h) != {"tree", "position"}:
            raise ValueError(f"heroes[{k}] must be a dict with keys tree, position, got {h!r}")
        t = _hero_tree(f"heroes[{k}] tree", h["tree"])
        q = check_array(f"heroes[{k}] position", h["position"], shape=(2,), max_abs=MAX_COORD)
        if not t["alive"].any():
            raise ValueError(f"heroes[{k}] tree has no live node")
        hb = np.array([q[0], float(sample_height(hf, size, q[None])[0]), q[1]])
        hero_in.append((t, hb))
    if scales is not None:
        scales = check_array("scales", scales, shape=(len(bases),), max_abs=1e6)
        if not np.all(scales > 0):
            raise ValueError(f"scales must be positive, got min {scales.min()!r}")
    elif (s_lo, s_hi) != (1.0, 1.0):
        scales = np.random.default_rng([seed, 0x5CA1E]).uniform(s_lo, s_hi, len(bases))
    records, voxels = _tree_records(p, bases, seed, crown_height, crown_radius, n_darts, sketch, size, bool(lean),
                                    regions, scales, voxel_shape, hero_in)
    n = len(records)
    # autonomous TreeSketch trees clear their markers every step, and trees without competition share nothing,
    # so each batch seeds, grows all its rounds and meshes in one task (the same per-round calls, no barrier)
    fused = (sketch is not None and sketch.get("mode", "autonomous") == "autonomous") or not compete
    with connect(client, n_workers=n_workers, processes=processes) as runner:
        stats = TaskStats(n_workers_of(runner))
        parts = chunks(n, stats.n_workers, per_worker=_PER_WORKER, tasks=tasks_per_round)
        waves = _Waves(runner, stats, progress)
        t_all = time.perf_counter()
        if fused:
            got = waves.gather([waves.submit(forest_task, p, [records[i] for i in c], rounds, steps_per_round,
                                             bases[c], geometry) for c in parts], "trees")
            timings = [time.perf_counter() - t_all]
        else:
            got, timings = _competing(waves, p, records, parts, bases, rounds, steps_per_round, geometry,
                                      p["occupation_radius"])
        stats.wall_s = time.perf_counter() - t_all
    done = [x for part in got for x in part]
    seeds = [sd for sd, _, _ in done]
    trees = [t for _, t, _ in done]
    meshes = [_unpack_mesh(m) for _, _, m in done] if geometry else None
    for t, hb in hero_in:  # hero trees as they are, in world coordinates
        trees.append({**t, "pos": t["pos"] + hb})
        if meshes is not None:
            meshes.append(tree_mesh_task(trees[-1]))
    config = {"params": p, "rounds": rounds, "steps_per_round": steps_per_round, "geometry": bool(geometry),
              "independent": sketch is not None or not compete, "scales": scales}
    if hero_in:
        bases = np.concatenate([bases, [hb for _, hb in hero_in]])
    return Forest(bases, trees, hf, size, timings, meshes, voxels, seeds, config, stats.as_dict())


def regrow_tree(forest: Forest, tree: int, *, params: dict[str, Any] | None = None,
                sketch: dict[str, Any] | None = None) -> Forest:
    """Regrow one tree of ``forest`` with new growth parameters or TreeSketch options (spec §3.8, V26).

    The tree restarts from its seed state (same base, seed and crown space) and runs the forest's rounds; every
    other tree, and its mesh, is carried over unchanged (the same arrays). Needs independent trees: a TreeSketch
    forest, or one grown with ``compete=False`` (painted crowns that compete for markers each round cannot be
    regrown alone).

    Parameters
    ----------
    forest : Forest
        Made by :func:`grow_forest`.
    tree : int
        Index of the tree.
    params : dict, optional
        Overrides of the forest's growth parameters for this tree.
    sketch : dict, optional
        New SketchEngine options for this tree (TreeSketch forests only), checked before anything is grown.

    Returns
    -------
    Forest
        A new forest; ``forest`` is not changed. Changes are relative to the forest's own settings (the seed
        states are kept), so regrowing again without overrides restores the original tree.
    """
    if not isinstance(forest, Forest):
        raise ValueError(f"forest must be a Forest, got {type(forest).__name__}")
    if params is not None and not isinstance(params, dict):
        raise ValueError(f"params must be a dict of growth parameters or None, got {type(params).__name__}")
    if sketch is not None and not isinstance(sketch, dict):
        raise ValueError(f"sketch must be a dict of SketchEngine options or None, got {type(sketch).__name__}")
    if forest.seeds is None or forest.config is None:
        raise ValueError("forest has no seed states; regrow needs a Forest made by grow_forest")
    tree = check_int("tree", tree, 0, len(forest.trees) - 1)
    if tree >= len(forest.seeds):
        raise ValueError(f"tree {tree} is a hero tree (placed as designed); only trees 0..{len(forest.seeds) - 1} grow")
    cfg = forest.config
    if not cfg["independent"]:
        raise ValueError("regrow needs independent trees: grow the forest with sketch= or compete=False")
    p = check_params({**cfg["params"], **(params or {})})
    if (params or {}).get("branching", p["branching"]) != cfg["params"]["branching"]:
        raise ValueError("params cannot change branching when regrowing a tree (its seed has the forest's)")
    state = forest.seeds[tree]
    if sketch:
        bad = sorted(set(sketch) & {"region", "asymmetry", "voxel_region"})
        if bad:
            raise ValueError(f"sketch must not set {bad} (the tree keeps its crown space)")
        if "sketch_state" not in state:
            raise ValueError("sketch options need a TreeSketch forest (grow_forest(sketch=...))")
        e = engine_from_state(p, state)
        e.set_options(**sketch)  # checked first: a rejected option raises before any growth
        state = engine_state(e)
    for _ in range(cfg["rounds"]):
        state = grow_tree_task(p, state, cfg["steps_per_round"])
    (t, mesh), = finish_task([state], [None], forest.bases[tree:tree + 1], cfg["geometry"])
    trees = list(forest.trees)
    trees[tree] = t
    meshes = None
    if forest.meshes is not None:
        meshes = list(forest.meshes)
        meshes[tree] = mesh if mesh is not None else tree_mesh_task(t)
    return Forest(forest.bases, trees, forest.heights, forest.size, list(forest.timings), meshes, forest.voxels,
                  forest.seeds, cfg)



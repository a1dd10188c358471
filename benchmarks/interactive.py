"""The Tree Wand interactive loop at the thesis's largest scale (spec 000_treewand §6.4, §3.5; issue 24).

One loop is what a user feels after a stroke: a growth step, the incremental re-mesh of the branches
(``IncrementalBranchMesh.update``) and the leaves (``IncrementalLeafMesh.update``), the step's undo record
(``Document.undoable``: one whole-state copy, shared with the next step) and the snapshot publication
(``Model.changed`` -> ``make_snapshot``), as ``Model.step`` and ``Model.grow`` run them. Each phase is timed over N consecutive loops (median;
wall and CPU: the step's process CPU, which counts numba's worker threads,
the other phases' thread CPU) on a grown tree with 200,000 painted markers, beside
the baseline run from the same start state in the same process: the step before issue 24 (``GrowthEngine._fast =
False``, the serial twin, which grows the same tree bit for bit; checked at the end) and a full rebuild of the
meshes (``build_branch_mesh``, a fresh leaf mesh). The step's own phases (assignment, shadow, light, vigor,
radius, ...) are printed against tree size. Targets: whole loop <= 33 ms at 22,000 internodes; step <= 40 ms at
51,500 internodes.

Scenes (``--scene``): ``stroke`` (default) paints the markers on the crown top, so a few dozen to a few hundred
internodes grow per step; ``wand`` is benchmarks/growth.py's scene (the tree grows ~10 % per step).

Reproduce: ``python benchmarks/interactive.py`` (full, grows 5.6k/22k/51.5k trees, a few minutes) or
``--quick`` (< 30 s). The machine may be shared: read the CPU columns.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from growth import grown_engine, painted_markers

from plantvr.documents.treewand import Model
from plantvr.geometry import IncrementalBranchMesh, IncrementalLeafMesh, build_branch_mesh


def stroke_markers(nodes: np.ndarray, count: int, spacing: float, rng, scene: str = "stroke") -> np.ndarray:
    """``count`` painted markers. ``wand`` (benchmarks/growth.py): a block over the crown's upper quarter, so most
    of the crown's buds perceive some and the tree grows ~10 % per step. ``stroke``: the same block lifted to sit
    on the crown top, as a stroke painted where the crown should grow next: the top buds grow into it (a few
    hundred internodes per step, as in benchmarks/geometry.py's update scene) while 200,000 markers stay live."""
    pts = painted_markers(nodes, count, spacing, rng)
    if scene == "stroke":
        lo, hi = nodes.min(0), nodes.max(0)
        pts = pts + np.array([0.0, 0.25 * (hi[1] - lo[1]), 0.0])
    return pts


STEP_PHASES = ("occupy", "buds", "assign", "growth", "shadow", "light", "vigor", "radius", "shed", "age")


class _Clock:
    """Wall and CPU milliseconds of a block: process CPU (numba's threads too) or, ``serial``, this thread's."""

    def __init__(self, serial: bool = True):
        self.clock = time.thread_time if serial else time.process_time

    def __enter__(self):
        self.t = (time.perf_counter(), self.clock())
        return self

    def __exit__(self, *exc):
        self.wall = 1e3 * (time.perf_counter() - self.t[0])
        self.cpu = 1e3 * (self.clock() - self.t[1])


def _model(engine, markers: np.ndarray, fast: bool) -> Model:
    """A Model holding a copy of ``engine``'s tree and ``markers`` (aged one step, as after a stroke)."""
    p = engine.params
    m = Model(seed=0, shadow_intensity=p["shadow_intensity"], activation_threshold=p["activation_threshold"])
    e = m._engine
    e._fast = fast
    e.tree = engine.tree.copy()
    e._new_nodes = np.zeros(0, np.int64)
    e.rebuild_light()
    e.add_markers(markers)
    e._occupy()
    e.marker_age[:] = 1
    m.changed("tree", command="step", save=False)
    return m


def _geometry(m: Model):
    """Incremental branch and leaf meshes of the model's snapshot, with the options the views use."""
    p, snap = m.params, m.latest
    tip = p["tip_radius"]
    br = IncrementalBranchMesh(snap.pos, snap.parent, snap.radius, main_child=snap.main_child, lod=(6, 32),
                               tip_radius=tip, bezier_w=p["bezier_weight"], bark_rate=p["bark_rate"])
    lv = IncrementalLeafMesh(radius_threshold=3 * tip, petiole_radius=0.3 * tip, leaf_size=p["leaf_size"],
                             petiole_length=p["petiole_length"], e_twist=p["petiole_twist"],
                             e_up=p["petiole_bend_up"], e_right=p["petiole_bend_right"],
                             iterations=p["leaf_iterations"], leaf_shape=p["leaf_texture"])
    b = snap.buds
    lv.update(b["pos"], b["dir"], b["radius"], b["up"])
    return br, lv


def run_loops(engine, markers: np.ndarray, loops: int, *, fast: bool) -> dict:
    """``loops`` interactive loops from ``engine``'s tree with ``markers``; per-phase lists of (wall, cpu) ms."""
    m = _model(engine, markers, fast)
    br, lv = _geometry(m)
    rec: dict[str, list] = {}
    p = m.params
    for _ in range(loops):
        # what Model.step / grow do per step: the step, its undo record and the snapshot's publication
        with m._lock, _Clock(serial=False) as c_cmd, m.undoable("tree"):
            with _Clock(serial=False) as c_step:
                m._engine.step()
            with _Clock() as c_snap:
                m.changed("tree", command="step", save=False)
        for k, v in m._engine.phase_ms.items():
            rec.setdefault(k, []).append(v)
        undo = (c_cmd.wall - c_step.wall - c_snap.wall, c_cmd.cpu - c_step.cpu - c_snap.cpu)
        snap = m.latest
        with _Clock() as c_br:
            if fast:
                br.update(snap.pos, snap.parent, snap.radius, main_child=snap.main_child)
            else:
                build_branch_mesh(snap.pos, snap.parent, snap.radius, main_child=snap.main_child, lod=(6, 32),
                                  tip_radius=p["tip_radius"], bezier_w=p["bezier_weight"], bark_rate=p["bark_rate"])
        b = snap.buds
        with _Clock() as c_lv:
            if fast:
                lv.update(b["pos"], b["dir"], b["radius"], b["up"])
            else:
                _, fresh = _geometry_leaves_only(m)
                fresh.update(b["pos"], b["dir"], b["radius"], b["up"])
        for k, c in (("step", c_step), ("snapshot", c_snap), ("branches", c_br), ("leaves", c_lv)):
            rec.setdefault(k, []).append((c.wall, c.cpu))
        rec.setdefault("undo", []).append(undo)
        rec.setdefault("loop", []).append((c_cmd.wall + c_br.wall + c_lv.wall, c_cmd.cpu + c_br.cpu + c_lv.cpu))
    rec["_tree"] = m._engine.tree.arrays()
    rec["_internodes"] = m._engine.tree.n_internodes
    rec["_markers"] = len(m._engine.markers)
    return rec


def _geometry_leaves_only(m: Model):
    p = m.params
    tip = p["tip_radius"]
    return None, IncrementalLeafMesh(radius_threshold=3 * tip, petiole_radius=0.3 * tip, leaf_size=p["leaf_size"],
                                     petiole_length=p["petiole_length"], e_twist=p["petiole_twist"],
                                     e_up=p["petiole_bend_up"], e_right=p["petiole_bend_right"],
                                     iterations=p["leaf_iterations"], leaf_shape=p["leaf_texture"])


def _med(rec, k):
    v = np.array(rec.get(k, [(0.0, 0.0)]))
    return float(np.median(v[:, 0])), float(np.median(v[:, 1]))


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="reduced sizes for CI (< 30 s)")
    ap.add_argument("--loops", type=int, default=None, help="loops per size (default 7, quick 3)")
    ap.add_argument("--scene", choices=("stroke", "wand"), default="stroke", help="where the markers are painted")
    ap.add_argument("--sizes", type=str, default=None, help="comma-separated internode counts")
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",")] if a.sizes else ([2_000, 5_600] if a.quick else
                                                                   [5_600, 22_000, 51_500])
    n_markers = 50_000 if a.quick else 200_000
    loops = a.loops or (3 if a.quick else 7)
    rng = np.random.default_rng(1)
    warm = grown_engine(60)  # compile (or load cached) kernels outside the timings
    mk = painted_markers(warm.tree.pos[warm.tree.alive], 500, warm.params["occupation_radius"], rng)
    run_loops(warm, mk, 2, fast=True)
    run_loops(warm, mk, 2, fast=False)
    out = {}
    print(f"interactive loop: median of {loops} consecutive loops, {n_markers} painted markers ({a.scene}); "
          f"'wall/cpu' ms; cpu: thread CPU, process CPU (numba threads) for assign and step")
    for n in sizes:
        e = grown_engine(n)
        mk = stroke_markers(e.tree.pos[e.tree.alive], n_markers, e.params["occupation_radius"], rng, a.scene)
        new = run_loops(e, mk, loops, fast=True)
        old = run_loops(e, mk, loops, fast=False)
        same = all(np.array_equal(new["_tree"][k], old["_tree"][k]) for k in new["_tree"])
        assert same, "the fast step grew another tree than its serial twin"
        row = {}
        print(f"\n{e.tree.n_internodes} internodes at start ({new['_internodes']} after {loops} steps, "
              f"{new['_markers']} live markers); "
              f"same tree as the baseline: {same}")
        print(f"  {'phase':>10} {'ours wall/cpu':>16} {'baseline wall/cpu':>18}")
        for k in STEP_PHASES + ("step", "undo", "snapshot", "branches", "leaves", "loop"):
            (wn, cn), (wo, co) = _med(new, k), _med(old, k)
            row[k] = {"wall": wn, "cpu": cn, "base_wall": wo, "base_cpu": co}
            label = {"branches": "branches*", "leaves": "leaves*"}.get(k, k)
            print(f"  {label:>10} {wn:>7.2f}/{cn:<8.2f} {wo:>8.2f}/{co:<9.2f}")
        print("  * baseline = full rebuild (build_branch_mesh; a fresh leaf mesh)")
        out[n] = row
    big = max(out)
    mid = min(out, key=lambda n: abs(n - 22_000))
    print(f"\ntarget 1: whole loop at {mid} internodes: {out[mid]['loop']['wall']:.1f} ms wall, "
          f"{out[mid]['loop']['cpu']:.1f} ms CPU (target <= 33 ms; baseline {out[mid]['loop']['base_wall']:.1f} / "
          f"{out[mid]['loop']['base_cpu']:.1f})")
    print(f"target 2: step at {big} internodes: {out[big]['step']['wall']:.1f} ms wall, "
          f"{out[big]['step']['cpu']:.1f} ms CPU (target <= 40 ms; baseline {out[big]['step']['base_wall']:.1f} / "
          f"{out[big]['step']['base_cpu']:.1f})")
    return {str(k): v for k, v in out.items()}


if __name__ == "__main__":
    main()

"""Benchmark: colonization kernel vs numpy + cKDTree rebuild-and-requery (issue 13; Figs. 12.8/12.9 style).

Usage::

    python benchmarks/colonize.py [--markers FILE] [--di 3] [--dk 0.5] [--D 0.25] [--max-steps 500]
                                  [--children-limit 2] [--mode classic|treewand] [--semantics both|canonical|guarded]
                                  [--json] [--quick]

Classic mode runs each workload in two semantics (issue 22), each against a baseline with *the same semantics*:

* ``canonical`` — Runions et al. (2007) as public implementations grow it (``canonical=True``: every attracted
  node grows every step, no guards). Baseline: numpy + cKDTree rebuild-and-requery with the same rule
  (``space_colonization_reference(..., canonical=True)``, whose node counts equal the plain implementation of
  tests/growth/test_canonical_sca.py). This is the figure to compare with published implementations.
* ``guarded`` — PlantVR's default (duplicate and cancel guards of spec 003 §1.4). Its baseline is the same
  numpy + cKDTree code *with the same guards*, which no public implementation has: the ratio measures the
  kernel against a rebuild-and-requery of the same rule, not against a published code.

FILE is raw little-endian float32 N x 3 (no header) or a ``.npy``.  Without a file the built-in workload
is N uniform points in a ball of radius 10 centred at (0, 0, 10), root at the origin, N = 10k, 50k, 200k
(``--quick``: 10k only, 30 steps).  CPU seconds are process CPU time (``time.process_time``); the growth
phase runs to the last step that killed a marker.  Per-step ms (median, max, tables) are process CPU ms
too, because wall-clock is unreliable on a shared machine (both implementations are single-threaded);
``median_wall_ms`` is added for reference.

``--mode treewand`` grows the same tree with the classic kernel, with one bud per node (heading =
internode direction, l = D, view radius = d_i, view angle 90°), and keeps the Eq. 9.4 assignment with
``TreeWandAssigner.update`` (incremental: only the buds added in a step) every step.  Whenever the node
count passes 1k, 2k, 5k, 10k, 20k, 50k it also times a full ``TreeWandAssigner.assign`` and a cKDTree
baseline (tree over live markers rebuilt, ``query_ball_point`` per bud, vectorised cone test and
lexsort), checking that all three give the same owners.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from plantvr.growth.colonize import (
    SpaceColonizer,
    TreeWandAssigner,
    space_colonization,
    space_colonization_reference,
)

NODE_MARKS = (1000, 2000, 5000, 10000, 20000, 50000)


def load_markers(path: str) -> np.ndarray:
    """Read markers from a ``.npy`` (N, 3) or raw little-endian float32 N x 3 file."""
    if path.endswith(".npy"):
        arr = np.load(path)
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise ValueError(f"markers file must hold an (N, 3) array, got shape {arr.shape}")
        return np.asarray(arr, np.float64)
    size = os.path.getsize(path)
    if size == 0 or size % 12:
        raise ValueError(f"markers file must be raw float32 N x 3 (a positive multiple of 12 bytes), "
                         f"got {size} bytes (truncated?)")
    return np.fromfile(path, dtype="<f4").reshape(-1, 3).astype(np.float64)


def ball_workload(n: int, seed: int = 0) -> np.ndarray:
    """N uniform points in the ball of radius 10 centred at (0, 0, 10)."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    return v * 10.0 * rng.random(n)[:, None] ** (1.0 / 3.0) + np.array([0.0, 0.0, 10.0])


def _row(impl, res, cpu_s, n):
    growth = (res.setup_cpu_ms + res.step_cpu_ms[: res.growth_steps].sum()) / 1e3
    return dict(impl=impl, markers=n, steps=int(res.steps), nodes=len(res.nodes),
                markers_left=len(res.markers_left), cpu_s=round(cpu_s, 4), growth_cpu_s=round(growth, 4),
                median_ms=round(float(np.median(res.step_cpu_ms)), 3) if res.steps else 0.0,
                max_ms=round(float(res.step_cpu_ms.max()), 3) if res.steps else 0.0,
                median_wall_ms=round(float(np.median(res.step_ms)), 3) if res.steps else 0.0)


def _at(res, counts, mark):
    """ms of the first step whose start count passes ``mark`` (counts rising) or falls to it (falling)."""
    idx = np.flatnonzero(counts >= mark) if counts is res.step_nodes else np.flatnonzero(counts <= mark)
    return (float(res.step_cpu_ms[idx[0]]), int(counts[idx[0]])) if idx.size else (None, None)


def _tables(n, ours, ref, out):
    out(f"  Fig 12.8-style: CPU ms per step against nodes (N = {n})")
    out(f"    {'nodes >=':>9} {'kernel ms':>10} {'cKDTree ms':>11}")
    for mark in NODE_MARKS:
        a, _ = _at(ours, ours.step_nodes, mark)
        b, _ = _at(ref, ref.step_nodes, mark) if ref is not None else (None, None)
        if a is None and b is None:
            continue
        out(f"    {mark:>9} {a if a is not None else float('nan'):>10.2f} {b if b is not None else float('nan'):>11.2f}")
    out(f"  Fig 12.9-style: CPU ms per step against live markers (N = {n})")
    out(f"    {'live <=':>9} {'kernel ms':>10} {'cKDTree ms':>11}")
    for frac in (1.0, 0.9, 0.75, 0.5, 0.25, 0.1):
        mark = int(frac * n)
        a, _ = _at(ours, ours.step_markers, mark)
        b, _ = _at(ref, ref.step_markers, mark) if ref is not None else (None, None)
        if a is None and b is None:
            continue
        out(f"    {mark:>9} {a if a is not None else float('nan'):>10.2f} {b if b is not None else float('nan'):>11.2f}")


_LABEL = {
    "canonical": "canonical (Runions 2007 as published; baseline: numpy + cKDTree, same semantics)",
    "guarded": "guarded (PlantVR default; baseline: numpy + cKDTree WITH THE SAME GUARDS, not a public code)",
}


def run_classic(markers, args, out):
    rows = []
    for sem in (("canonical", "guarded") if args.semantics == "both" else (args.semantics,)):
        rows += _run_classic(markers, args, out, sem)
    return rows


def _run_classic(markers, args, out, semantics):
    canonical = semantics == "canonical"
    kw = dict(influence_radius=args.di, kill_radius=args.dk, step_size=args.D, max_steps=args.max_steps,
              children_limit=args.children_limit, canonical=canonical)
    n = len(markers)
    root = np.zeros(3)
    c0 = time.process_time()
    ours = space_colonization(markers, root, **kw)
    rows = [_row("kernel", ours, time.process_time() - c0, n)]
    ref = None
    if not args.no_reference:
        c0 = time.process_time()
        ref = space_colonization_reference(markers, root, exact_ties=False, **kw)
        rows.append(_row("ckdtree", ref, time.process_time() - c0, n))
    state = SpaceColonizer(markers, root, influence_radius=args.di, kill_radius=args.dk,
                           step_size=args.D, canonical=canonical).state_bytes_per_marker
    rows[0]["state_bytes_per_marker"] = round(state, 1)
    for r in rows:
        r["semantics"] = semantics
    if not args.json:
        out(f"classic, {_LABEL[semantics]}")
        out(f"  N = {n}, d_i = {args.di}, d_k = {args.dk}, D = {args.D}, children_limit = {args.children_limit}")
        out(f"  marker state beyond positions: {state:.1f} bytes per marker (target <= 32)")
        out(f"  {'impl':<8} {'steps':>5} {'nodes':>7} {'left':>6} {'cpu_s':>8} {'growth_cpu_s':>12} "
            f"{'median_ms':>9} {'max_ms':>8}")
        for r in rows:
            out(f"  {r['impl']:<8} {r['steps']:>5} {r['nodes']:>7} {r['markers_left']:>6} {r['cpu_s']:>8.3f} "
                f"{r['growth_cpu_s']:>12.3f} {r['median_ms']:>9.2f} {r['max_ms']:>8.2f}")
        if ref is not None:
            same = len(ours.nodes) == len(ref.nodes) and np.array_equal(ours.nodes, ref.nodes)
            rows[0]["speedup_growth"] = round(rows[1]["growth_cpu_s"] / max(rows[0]["growth_cpu_s"], 1e-9), 2)
            rows[0]["speedup_run"] = round(rows[1]["cpu_s"] / max(rows[0]["cpu_s"], 1e-9), 2)
            rows[0]["identical_nodes"] = bool(same)
            out(f"  [{semantics}] growth-phase CPU: cKDTree / kernel = {rows[0]['speedup_growth']:.1f}x;"
                f" whole run {rows[0]['speedup_run']:.1f}x; node counts {len(ours.nodes)} vs {len(ref.nodes)};"
                f" identical nodes: {same}")
        _tables(n, ours, ref, out)
    return rows


def _treewand_ckdtree(markers, pos, dirs, lens, vr, cos_half):
    """cKDTree baseline of Eq. 9.4 over the given (live) markers; same arithmetic as the brute-force reference."""
    from scipy.spatial import cKDTree

    lists = cKDTree(markers).query_ball_point(pos, vr * (1 + 1e-9))
    cnt = np.fromiter((len(x) for x in lists), np.int64, len(lists))
    mi = np.fromiter((i for x in lists for i in x), np.int64, int(cnt.sum()))
    bi = np.repeat(np.arange(len(pos)), cnt)
    v = markers[mi] - pos[bi]
    d2 = v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2]
    d = np.sqrt(d2)
    dot = v[:, 0] * dirs[bi, 0] + v[:, 1] * dirs[bi, 1] + v[:, 2] * dirs[bi, 2]
    ok = (d2 != 0) & (d <= vr) & (dot >= d * cos_half)
    mi, bi, key = mi[ok], bi[ok], d[ok] / lens[bi[ok]]
    order = np.lexsort((bi, key, mi))
    mi, bi = mi[order], bi[order]
    first = np.ones(len(mi), bool)
    first[1:] = mi[1:] != mi[:-1]
    owner = np.full(len(markers), -1, np.int64)
    owner[mi[first]] = bi[first]
    return owner


def run_treewand(markers, args, out):
    n = len(markers)
    angle = math.pi / 2
    sc = SpaceColonizer(markers, np.zeros(3), influence_radius=args.di, kill_radius=args.dk, step_size=args.D)
    ta = TreeWandAssigner(markers, view_radius=args.di, view_angle=angle)
    marks = [m for m in NODE_MARKS if m <= 0.5 * n] or [NODE_MARKS[0]]
    ours_ms, ref_ms, ours_cpu, ref_cpu, samples, same_all = [], [], 0.0, 0.0, [], True
    last_n = 0
    inc_ms, inc_all = [], []
    for _ in range(args.max_steps):
        if not marks:
            break
        added, _ = sc.step()
        if added == 0:
            break
        nodes, parent = sc.nodes, sc.parent
        dirs = nodes - nodes[np.maximum(parent, 0)]
        dirs[parent < 0] = [0, 0, 1.0]
        lens = np.full(len(nodes), args.D)
        ta.kill_within(nodes[last_n:], args.dk)  # keep ta's live markers = the colonizer's
        c0 = time.process_time()
        owner_inc = ta.update(nodes, dirs, lens, None if last_n == 0 else np.arange(last_n, sc.n))
        inc_all.append((time.process_time() - c0) * 1e3)
        last_n = sc.n
        if sc.n < marks[0]:
            continue
        while marks and sc.n >= marks[0]:
            marks.pop(0)
        inc_ms.append(inc_all[-1])
        live = sc.live_index
        c0 = time.process_time()
        owner = ta.assign(nodes, dirs, lens)
        ours_ms.append((time.process_time() - c0) * 1e3)
        ours_cpu += time.process_time() - c0
        same_all &= bool(np.array_equal(owner, owner_inc))
        if not args.no_reference:
            unit = dirs / np.linalg.norm(dirs, axis=1)[:, None]
            c0 = time.process_time()
            ref = _treewand_ckdtree(markers[live], nodes, unit, lens, args.di, math.cos(angle / 2))
            ref_ms.append((time.process_time() - c0) * 1e3)
            ref_cpu += time.process_time() - c0
            same_all &= bool(np.array_equal(owner[live], ref))
        samples.append((sc.n, len(live)))
    rows = []
    for impl, ms, cpu in (("kernel_incremental", inc_ms, sum(inc_all) / 1e3), ("kernel", ours_ms, ours_cpu),
                          ("ckdtree", ref_ms, ref_cpu)):
        if ms:
            rows.append(dict(impl=impl, markers=n, steps=len(ms), nodes=int(sc.n), markers_left=int(sc.n_live),
                             cpu_s=round(cpu, 4), growth_cpu_s=round(cpu, 4),
                             median_ms=round(float(np.median(ms)), 3), max_ms=round(float(np.max(ms)), 3),
                             state_bytes_per_marker=round(ta.state_bytes_per_marker, 1)))
    if not args.json:
        out(f"treewand assignment (Eq. 9.4, one bud per node, view radius {args.di}, view angle 90 deg), N = {n}")
        out(f"  marker state beyond positions: {ta.state_bytes_per_marker:.1f} bytes per marker (target <= 32)")
        out(f"  {'buds':>7} {'live':>7} {'update ms':>10} {'full ms':>8} {'cKDTree ms':>11}   (CPU ms; update = "
            f"incremental, buds added that step)")
        for i, (b, lv) in enumerate(samples):
            r = f"{ref_ms[i]:>11.2f}" if ref_ms else f"{'-':>11}"
            out(f"  {b:>7} {lv:>7} {inc_ms[i]:>10.2f} {ours_ms[i]:>8.2f} {r}")
        if ref_ms:
            out(f"  identical owners: {same_all}")
    return rows


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns ``{"results": [one dict per implementation and workload]}``."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--markers", help="raw little-endian float32 N x 3 file or .npy")
    p.add_argument("--di", type=float, default=3.0, help="influence radius d_i")
    p.add_argument("--dk", type=float, default=0.5, help="kill radius d_k")
    p.add_argument("--D", type=float, default=0.25, help="step size D")
    p.add_argument("--max-steps", type=int, default=500)
    p.add_argument("--children-limit", type=int, default=None)
    p.add_argument("--mode", choices=("classic", "treewand"), default="classic")
    p.add_argument("--semantics", choices=("both", "canonical", "guarded"), default="both",
                   help="classic mode: canonical (Runions 2007), guarded (PlantVR default) or both")
    p.add_argument("--sizes", type=int, nargs="+", default=None, help="built-in workload sizes")
    p.add_argument("--json", action="store_true", help="one JSON object per implementation")
    p.add_argument("--quick", action="store_true", help="N = 10k, 30 steps (CI)")
    p.add_argument("--no-reference", action="store_true", help="skip the cKDTree baseline")
    args = p.parse_args(argv)
    if args.quick:
        args.max_steps = min(args.max_steps, 30)
    out = print
    # compile the kernels outside the timings
    warm = ball_workload(200, 1)
    space_colonization(warm, np.zeros(3), influence_radius=3.0, kill_radius=0.5, step_size=0.25, max_steps=5)
    space_colonization(warm, np.zeros(3), influence_radius=3.0, kill_radius=0.5, step_size=0.25, max_steps=5,
                       canonical=True)
    TreeWandAssigner(warm, view_radius=3.0, view_angle=1.0).assign(warm[:3], warm[:3], np.ones(3))
    if args.markers:
        workloads = [load_markers(args.markers)]
    else:
        sizes = args.sizes or ([10_000] if args.quick else [10_000, 50_000, 200_000])
        workloads = [ball_workload(n) for n in sizes]
    results = []
    for markers in workloads:
        rows = (run_classic if args.mode == "classic" else run_treewand)(markers, args, out)
        results.extend(rows)
        if args.json:
            for r in rows:
                out(json.dumps(r))
    return {"mode": args.mode, "results": results}


if __name__ == "__main__":
    main()

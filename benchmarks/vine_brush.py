"""ViNE brush benchmark (spec 000_vine §2.4.4, V13): index build, one stamp at 10²/10⁴/10⁵ hits, undo/redo.

Mesh: a synthetic flower head (marching cubes) tiled to the gerbera class (18 M vertices) or, with
``--quick``, to 300 k vertices. Figures are printed beside their baselines from the same run: a brute-force
float32 numpy distance pass and scipy ``cKDTree.query_ball_point``.

Run: ``python benchmarks/vine_brush.py [--quick] [--vertices N]``.
"""
from __future__ import annotations

# ruff: noqa: B023  (closures are timed immediately inside the loop that binds them)
import argparse
import time

import numpy as np
from _common import best_time, radius_for
from scipy.spatial import cKDTree

from plantvr.documents.labels import Segmentation
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.vine.synth import synth_flowerhead, tile_mesh


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="300k vertices, fewer repetitions (CI)")
    ap.add_argument("--vertices", type=int, default=None, help="target vertex count (default 18M)")
    ap.add_argument("--no-kdtree", action="store_true", help="skip the cKDTree baseline build")
    a = ap.parse_args(argv)
    n_target = a.vertices or (300_000 if a.quick else 18_000_000)
    reps = 5 if a.quick else 9
    head = synth_flowerhead(96 if a.quick else 256, rng=0)
    s = extract_isosurface(head.volume, head.level)
    v, f = tile_mesh(s.vertices, s.faces, n_target)
    V = len(v)
    print(f"mesh: {V:,} vertices, {len(f):,} faces (tiled synthetic heads)")
    out: dict = {"vertices": V, "faces": len(f)}

    t = time.perf_counter()
    seg = Segmentation(v, f)
    _ = seg.index
    out["grid_build_s"] = time.perf_counter() - t
    out["grid_bytes_per_vertex"] = seg.index.nbytes / V
    print(f"index build: grid {out['grid_build_s']:.2f} s ({out['grid_bytes_per_vertex']:.2f} B/vertex)", end="")
    tree = None
    if not a.no_kdtree:
        t = time.perf_counter()
        tree = cKDTree(v, leafsize=32, balanced_tree=False, compact_nodes=False)
        out["kdtree_build_s"] = time.perf_counter() - t
        kd_bytes = (tree.data.nbytes + tree.indices.nbytes) / V
        print(f" | baseline cKDTree {out['kdtree_build_s']:.2f} s (>= {kd_bytes:.0f} B/vertex)")
    else:
        print()
    out["label_bytes_per_vertex"] = seg.labels.nbytes / V

    rng = np.random.default_rng(0)
    centres = v[rng.integers(0, V, 8)].astype(np.float64)
    for hits in (100, 10_000, 100_000):
        if hits > V // 3:
            continue
        radii = [radius_for(seg.index, c, hits) for c in centres[:3]]
        k = [0]

        def stamp():
            i = k[0] % 3
            seg.paint(centres[i], radii[i], 1 + (k[0] // 3) % 2)     # alternate labels: always a real change
            k[0] += 1
        stamp()
        t_grid = best_time(stamp, reps)
        t_query = best_time(lambda: seg.index.query(centres[0], radii[0]), reps)
        v32, c32, r2 = v, centres[0].astype(np.float32), np.float32(radii[0] ** 2)
        t_brute = best_time(lambda: np.nonzero(((v32 - c32) ** 2).sum(1) <= r2)[0], 3)
        row = {"stamp_ms": 1e3 * t_grid, "grid_query_ms": 1e3 * t_query, "brute_ms": 1e3 * t_brute}
        msg = (f"{hits:>7,} hits: paint stamp incl. undo record {row['stamp_ms']:.2f} ms | grid query "
               f"{row['grid_query_ms']:.2f} ms | brute-force numpy {row['brute_ms']:.1f} ms")
        if tree is not None:
            row["kdtree_ms"] = 1e3 * best_time(lambda: np.asarray(tree.query_ball_point(centres[0], radii[0]),
                                                                np.int64), reps)
            msg += f" | cKDTree query+array {row['kdtree_ms']:.2f} ms"
        print(msg)
        out[f"hits_{hits}"] = row

    # undo / redo of a large operation (10^6 vertices at full size)
    big = min(1_000_000, V // 3)
    r = radius_for(seg.index, centres[4], big)
    seg.paint(centres[4], r, 7)
    e = seg.history.undo_stack[-1]
    t_u = best_time(lambda: (seg.undo(), seg.redo()), 3) / 2
    out["undo_op_vertices"] = len(e)
    out["undo_ms"] = 1e3 * t_u
    out["undo_record_bytes_per_changed_vertex"] = e.nbytes / len(e)
    t_copy = best_time(lambda: seg.labels.copy(), 3)
    print(f"undo/redo of a {len(e):,}-vertex operation: {out['undo_ms']:.1f} ms "
          f"({out['undo_record_bytes_per_changed_vertex']:.0f} B/changed vertex) | baseline full label copy "
          f"{1e3 * t_copy:.1f} ms ({V:,} B)")
    # depth cueing per frame against the coarse hull (spec §2.2.4: "per-frame cost is trivial")
    from plantvr.vine.depthcue import _hull_distances_numpy, coarse_hull, hull_distances
    t = time.perf_counter()
    hull = coarse_hull(v, sample=200_000 if a.quick else 1_000_000)
    out["hull_build_s"] = time.perf_counter() - t
    eye = v.max(0).astype(np.float64) * 1.3
    hull_distances(hull, eye)
    out["hull_frame_ms"] = 1e3 * best_time(lambda: hull_distances(hull, eye), 50)
    out["hull_frame_numpy_ms"] = 1e3 * best_time(lambda: _hull_distances_numpy(hull, eye), 20)
    print(f"depth cue: coarse hull {len(hull.vertices)} vertices built in {out['hull_build_s']:.2f} s; per frame "
          f"(inside test, d_c, d_f) {out['hull_frame_ms']:.3f} ms | numpy twin {out['hull_frame_numpy_ms']:.3f} ms")
    print(f"labels: {out['label_bytes_per_vertex']:.0f} B/vertex per buffer; triple buffer {3 * V / 2**20:.0f} MiB")
    return out


if __name__ == "__main__":
    main()

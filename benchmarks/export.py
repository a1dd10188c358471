"""Tree export benchmark (issue 16): USD, skinned glTF, LOD chain and billboard beside the plain PLY export.

For a random tree with pipe-model radii and a leaf at every tip, prints the time of each exporter of
``plantvr.geometry`` beside two baselines measured in the same run: the plain PLY export (``export_tree`` to
.ply, trimesh's binary PLY writer) and trimesh's own glb export of the same concatenated mesh. The issue's target:
USD and glb of a 22,000-internode tree with leaves <= 2 s each. ``--quick`` runs 3,000 internodes (< 30 s).
``--lod-iou`` renders each LOD level's silhouette IoU (with leaves) against level 0 at the nearest distance
``lod_by_distance`` uses it; ``--forest`` times the View's LOD trees (LOD by camera distance) on a grown forest, with the
triangles of every tree at level 0 as baseline.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import best_of

from plantvr.geometry import build_branch_mesh
from plantvr.geometry.leaves import build_leaves
from plantvr.geometry.lod import lod_chain
from plantvr.geometry.synthetic import random_tree
from plantvr.io.tree import export_skinned_glb, export_tree
from plantvr.io.usd import export_usd


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="3,000 internodes for CI (< 30 s)")
    ap.add_argument("--internodes", type=int, default=None, help="tree size (default 22,000; 3,000 with --quick)")
    ap.add_argument("--billboard", action="store_true", help="also time the billboard atlas (offscreen rendering)")
    ap.add_argument("--lod-iou", action="store_true",
                    help="also render each LOD level's silhouette IoU (with leaves) at the nearest distance it is used")
    ap.add_argument("--forest", action="store_true",
                    help="also time the View's LOD trees (LOD by distance) on a small grown forest: build, update, triangles")
    args = ap.parse_args(argv)
    n = args.internodes or (3_000 if args.quick else 22_000)
    repeat = 1 if args.quick else 3
    pos, parent, radius, mc = random_tree(n, seed=1)
    tips = np.flatnonzero(np.bincount(parent[1:], minlength=len(pos)) == 0)
    d = pos[tips] - pos[parent[tips]]
    d /= np.linalg.norm(d, axis=1)[:, None]
    build_branch_mesh(pos[:50], parent[:50], radius[:50])                      # JIT warm-up
    t_mesh, mesh = best_of(lambda: build_branch_mesh(pos, parent, radius, main_child=mc), repeat)
    t_leaf, leaves = best_of(lambda: build_leaves(pos[tips], d, radius[tips], leaf_size=0.3, petiole_length=0.05,
                                                rng=0), repeat)
    st = np.zeros(len(pos), np.int64)
    from plantvr.geometry.lod import axis_start
    ax = axis_start(parent, mc)
    for i in range(2, len(pos)):
        st[i] = st[parent[i]] + (ax[i] == i)
    res: dict = {"internodes": n, "triangles": len(mesh.faces), "leaves": len(tips),
                 "leaf_triangles": len(leaves.faces), "mesh_s": t_mesh, "leaves_s": t_leaf}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        import trimesh

        res["ply_s"], _ = best_of(lambda: export_tree(tmp / "t.ply", mesh, leaves), repeat)
        both = trimesh.util.concatenate([mesh.to_trimesh(), leaves.to_trimesh()])
        res["trimesh_glb_s"], _ = best_of(lambda: both.export(tmp / "tm.glb"), repeat)
        export_usd(tmp / "warm.usdc", mesh, leaves)
        res["usd_s"], _ = best_of(lambda: export_usd(tmp / "t.usdc", mesh, leaves, order=st), repeat)
        res["usd_mesh_leaves_s"], _ = best_of(lambda: export_usd(tmp / "m.usdc", mesh, leaves, order=st,
                                                               leaf_instancer=False), repeat)
        res["skinned_glb_s"], _ = best_of(lambda: export_skinned_glb(tmp / "s.glb", mesh, pos, parent, radius,
                                                                   main_child=mc, leaves=leaves, leaf_node=tips),
                                        repeat)
        res["usd_bytes"] = (tmp / "t.usdc").stat().st_size
        res["glb_bytes"] = (tmp / "s.glb").stat().st_size
    res["lod_chain_s"], chain = best_of(lambda: lod_chain(pos, parent, radius, main_child=mc), repeat)
    res["lod_triangles"] = [lv.triangles for lv in chain]
    if args.billboard:
        from plantvr.view.billboard import make_billboard
        # rendered from LOD 1 (same silhouette, IoU >= 0.9; a fifth of the triangles, which llvmpipe pays for)
        res["billboard_s"], _ = best_of(lambda: make_billboard([chain[1].mesh, leaves], resolution=256), 1)
    if args.lod_iou:
        from plantvr.view.billboard import LOD_SCREEN_PX, silhouette_iou
        res["lod_iou"] = [float(silhouette_iou([chain[0].mesh, leaves], [lv.mesh, leaves], views=2,
                                               resolution=int(px)).min())
                          for lv, px in zip(chain[1:], LOD_SCREEN_PX)]
    if args.forest:
        res.update(_forest(quick=args.quick))
    print(f"tree: {n} internodes, {res['triangles']} branch + {res['leaf_triangles']} leaf triangles "
          f"({res['leaves']} leaves); mesh {res['mesh_s']:.3f} s, leaves {res['leaves_s']:.3f} s")
    print(f"{'export':<38}{'s':>8}{'x PLY':>8}")
    base = res["ply_s"]
    rows = [("PLY, export_tree (baseline)", "ply_s"), ("glb, trimesh export (baseline)", "trimesh_glb_s"),
            ("USD .usdc, leaves instanced", "usd_s"), ("USD .usdc, leaves as a mesh", "usd_mesh_leaves_s"),
            ("glb skinned + growth animation", "skinned_glb_s"), ("LOD chain, 4 levels (build)", "lod_chain_s")]
    if "billboard_s" in res:
        rows.append(("billboard atlas 2 x 256 px (LOD 1)", "billboard_s"))
    for label, key in rows:
        print(f"{label:<38}{res[key]:>8.3f}{res[key] / base:>8.2f}")
    if "lod_iou" in res:
        print("LOD silhouette IoU with leaves at 384 / 192 / 96 px (target >= 0.9):",
              [round(x, 3) for x in res["lod_iou"]])
    if "forest_trees" in res:
        print(f"View with LOD trees, {res['forest_trees']} trees: build {res['forest_build_s']:.2f} s, update per camera move "
              f"{1e3 * res['forest_update_s']:.2f} ms; triangles near / mid / far {res['forest_tris']} "
              f"(all at level 0: {res['forest_tris_full']})")
    print(f"LOD triangles: {res['lod_triangles']}; target USD and glb <= 2 s at 22,000 internodes: "
          f"{'met' if max(res['usd_s'], res['skinned_glb_s']) <= 2.0 else 'NOT met'} at {n}")
    return res


def _forest(quick: bool) -> dict:
    """The View with LOD trees on a grown forest: build time, time of one update() after a camera move, visible triangles."""
    from types import SimpleNamespace

    from plantvr.landscape import grow_forest
    from plantvr.types import TreeArrays
    from plantvr.view import LOD, View

    n = 6 if quick else 30
    f = grow_forest(n, size=(40.0 * np.sqrt(n), 40.0 * np.sqrt(n)), min_dist=10.0, rounds=2, steps_per_round=5,
                    client="sync", seed=2)
    t = time.perf_counter()
    v = View({f"t{k}": TreeArrays.from_tree(SimpleNamespace(**t)) for k, t in enumerate(f.trees)},
             window_size=(1280, 720), lod=LOD(billboard_px=128))
    v.plotter.camera.RemoveObserver(v._camera_tag)  # time update_lod() by hand, not on every camera change
    v._camera_tag = None
    build = time.perf_counter() - t
    c = v.centers.mean(0)
    tris, times = [], []
    for back in (10.0, 100.0, 1000.0):
        v.plotter.camera_position = [tuple(c + np.array([0.0, 2.0, -back - np.ptp(v.centers[:, 2]) / 2])),
                                     tuple(c), (0, 1, 0)]
        t = time.perf_counter()
        v.update_lod()
        times.append(time.perf_counter() - t)
        tris.append(v.triangles)
    full = int(sum(layer.tris[0] for layer in v.layers.values()))
    v.close()
    return {"forest_trees": len(f.trees), "forest_build_s": build, "forest_update_s": float(np.mean(times)),
            "forest_tris": tris, "forest_tris_full": full}


if __name__ == "__main__":
    main()

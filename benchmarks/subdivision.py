"""Benchmark Yggdrasil (spec 001_subdivision §5.4): control-mesh build vs branch count, Loop subdivision
vs trimesh and VTK, all measured in the same run.

    python benchmarks/subdivision.py            # full sizes (and a ~213k-face self-intersection check) (10k branches, ~1 M-face Loop level)
    python benchmarks/subdivision.py --quick    # CI sizes, < 30 s
"""
from __future__ import annotations

import argparse
import os

import numpy as np
from _common import best_time


def _vtk_loop(V: np.ndarray, F: np.ndarray, levels: int):
    """Return a callable that runs vtkLoopSubdivisionFilter on a prebuilt vtkPolyData."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray

    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(V), deep=True))
    cells = vtk.vtkCellArray()
    conn = numpy_to_vtkIdTypeArray(np.ascontiguousarray(F.ravel().astype(np.int64)), deep=True)
    offs = numpy_to_vtkIdTypeArray(np.arange(0, 3 * len(F) + 1, 3, dtype=np.int64), deep=True)
    cells.SetData(offs, conn)
    poly = vtk.vtkPolyData()
    poly.SetPoints(pts)
    poly.SetPolys(cells)

    def run():
        f = vtk.vtkLoopSubdivisionFilter()
        f.SetNumberOfSubdivisions(levels)
        f.SetInputData(poly)
        f.Update()
        return f.GetOutput()

    return run


def _tube_union_baseline(g) -> None:
    """Naive baseline: one trimesh cylinder per branch, concatenated (no joints, not one surface)."""
    import trimesh

    parts = []
    for s, e, r0, r1 in zip(g.start, g.end, g.r0, g.r1):
        parts.append(trimesh.creation.cylinder(radius=0.5 * (r0 + r1), segment=np.stack([s, e]), sections=4))
    trimesh.util.concatenate(parts)


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark and print every figure beside its baseline.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (``--quick`` for CI sizes).

    Returns
    -------
    dict
        ``{"build": [...], "loop": [...]}`` rows of measured seconds.
    """
    import trimesh

    from plantvr.subdivision import build_control_mesh, graph_from_arrays, subdivide_loop
    from plantvr.subdivision.graph import random_tree

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="reduced sizes for CI (< 30 s)")
    args = ap.parse_args(argv)
    quick = args.quick
    repeat = 1 if quick else 3
    out: dict = {"build": [], "loop": []}

    print("== control mesh build (random grown trees, 4 sides, radius compensation) ==")
    print(f"{'branches':>9} {'faces':>9} {'ours s':>8} {'us/branch':>9} {'Qhull joints s':>14} {'naive tubes s':>14}")
    sizes = [300, 1000] if quick else [1000, 3000, 10000]
    for nb in sizes:
        g = graph_from_arrays(*random_tree(nb + 1, rng=nb))
        cm = build_control_mesh(g)
        t = best_time(lambda g=g: build_control_mesh(g), repeat)
        tq = best_time(lambda g=g: build_control_mesh(g, hull="qhull"), 1)
        tb = best_time(lambda g=g: _tube_union_baseline(g), 1) if nb <= 3000 else float("nan")
        row = {"branches": nb, "faces": len(cm.faces), "ours_s": t, "qhull_s": tq, "tubes_baseline_s": tb}
        out["build"].append(row)
        print(f"{nb:>9} {len(cm.faces):>9} {t:>8.3f} {1e6 * t / nb:>9.1f} {tq:>14.3f} {tb:>14.3f}")

    print(f"\n== Loop subdivision, one level of a closed tree mesh (best of {repeat}) ==")
    print(f"{'faces in':>9} {'ours s':>8} {'trimesh s':>9} {'VTK s':>8} {'x trimesh':>9} {'x VTK':>6} {'max|d| trimesh':>14} {'max|d| VTK':>11}")
    targets = [60_000] if quick else [100_000, 330_000, 1_000_000]
    try:
        import vtk  # noqa: F401
        have_vtk = True
    except ImportError:  # pragma: no cover
        have_vtk = False
    for target in targets:
        # a random tree whose capped control mesh (~38 faces per branch) reaches ~target faces in 2 levels
        g = graph_from_arrays(*random_tree(max(20, int(target / (38 * 16))) + 1, rng=5))
        cm = build_control_mesh(g, cap=True)
        V, F = subdivide_loop(cm.vertices, cm.faces, 2)
        ours = best_time(lambda V=V, F=F: subdivide_loop(V, F, 1), repeat)
        Vo, _ = subdivide_loop(V, F, 1)
        tri = best_time(lambda V=V, F=F: trimesh.remesh.subdivide_loop(V, F, iterations=1),
                    1 if len(F) > 400_000 else repeat)
        Vt, _ = trimesh.remesh.subdivide_loop(V, F, iterations=1)
        from scipy.spatial import cKDTree

        dt = float(cKDTree(Vt).query(Vo)[0].max())
        if have_vtk:
            run = _vtk_loop(V, F, 1)
            tv = best_time(run, repeat)
            from vtk.util.numpy_support import vtk_to_numpy

            Pv = vtk_to_numpy(run().GetPoints().GetData()).astype(float)
            dv = float(cKDTree(Pv).query(Vo)[0].max())
        else:
            tv, dv = float("nan"), float("nan")
        row = {"faces": len(F), "ours_s": ours, "trimesh_s": tri, "vtk_s": tv, "maxdiff_trimesh": dt,
               "maxdiff_vtk": dv}
        out["loop"].append(row)
        print(f"{len(F):>9} {ours:>8.3f} {tri:>9.3f} {tv:>8.3f} {tri / ours:>9.1f} {tv / ours:>6.1f} {dt:>14.2e} {dv:>11.2e}")

    # three levels at once: our derived-topology path vs trimesh iterations=3
    g = graph_from_arrays(*random_tree(301, rng=6))
    cm = build_control_mesh(g, cap=True)
    V, F = cm.vertices, cm.faces
    ours3 = best_time(lambda: subdivide_loop(V, F, 3), repeat)
    tri3 = best_time(lambda: trimesh.remesh.subdivide_loop(V, F, iterations=3), 1)
    print(f"\nthree levels from {len(F)} faces: ours {ours3:.3f} s, trimesh {tri3:.3f} s ({tri3 / ours3:.1f}x)")
    out["loop3"] = {"faces": len(F), "ours_s": ours3, "trimesh_s": tri3}

    # bark UVs (tubes + joint propagation, spec §2.6) and OBJ with per-corner UVs (§2.7) beside trimesh's
    # OBJ exporter (geometry only here: one UV per vertex cannot hold the seams)
    import tempfile
    from pathlib import Path

    from plantvr.io.obj import write_obj
    from plantvr.subdivision import control_uvs, subdivide_uvs

    g = graph_from_arrays(*random_tree((300 if quick else 3000) + 1, rng=8))
    cm = build_control_mesh(g)
    tu = best_time(lambda: control_uvs(cm), repeat)
    uv2 = subdivide_uvs(control_uvs(cm), 2)
    V2, F2 = subdivide_loop(cm.vertices, cm.faces, 2)
    with tempfile.TemporaryDirectory() as d:
        tw = best_time(lambda: write_obj(Path(d) / "a.obj", V2, F2, uv2), 1)
        tt = best_time(lambda: trimesh.Trimesh(V2, F2, process=False).export(Path(d) / "b.obj"), 1)
    print(f"\nUVs of a {len(g)}-branch control mesh ({len(cm.faces)} faces): {tu:.3f} s; OBJ v/vt/vn of level 2 "
          f"({len(F2)} faces): ours {tw:.2f} s, trimesh export (no UVs) {tt:.2f} s")
    out["uv_obj"] = {"faces_control": len(cm.faces), "uv_s": tu, "faces_obj": len(F2), "obj_s": tw,
                     "trimesh_obj_s": tt}
    # self-intersection check (spec V13; issue 22): uniform grid + numba kernel vs the k-d tree path
    from plantvr.subdivision import self_intersections, tree_mesh

    m = tree_mesh(graph_from_arrays(*random_tree((40 if quick else 431), rng=5)), levels=2)
    V2, F2 = m.vertices, m.faces
    self_intersections(V2[:300], np.arange(90).reshape(-1, 3))               # compile outside the clock
    tg = best_time(lambda: self_intersections(V2, F2), repeat)
    tk = best_time(lambda: self_intersections(V2, F2, method="kdtree"), 1)
    same = bool(np.array_equal(self_intersections(V2, F2), self_intersections(V2, F2, method="kdtree")))
    print(f"\nself-intersections of a level-2 tree ({len(F2)} faces): grid {tg:.2f} s, k-d tree baseline {tk:.2f} s "
          f"({tk / tg:.0f}x), same pairs: {same}")
    out["self_intersections"] = {"faces": len(F2), "grid_s": tg, "kdtree_s": tk, "same_pairs": same}
    return out


if __name__ == "__main__":
    main()

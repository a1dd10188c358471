"""Tree geometry benchmark (spec 000_treewand §3, §8.2; issue targets): full mesh and incremental update.

Full build, for several tree sizes: ``build_branch_mesh`` (numba, LOD 10/64 and 6/32) and the leaves at every bud
of a thin internode, beside a plain pyvista ``tube()`` of the same skeleton (10 sides) and the per-segment numpy
twin (timed on a sample and scaled). Target: 50,000 internodes with leaves <= 0.5 s.

Incremental update at 22,000 internodes over consecutive growth steps (1 % of the tips extend, new laterals on
0.5 % of the nodes, pipe radii recomputed, so radii change down to the root): ``IncrementalBranchMesh.update``
beside the older copy-based ``update_branch_mesh``, a full rebuild and ``pv.tube()``. Target <= 11 ms. The
machine is shared, so wall times are best-of-N and each figure also gives the process CPU time (single-threaded
numba for the update, which is what one idle core would take). ``--quick`` runs small sizes (< 30 s);
``--render DIR`` also writes two offscreen PNGs (LOD 10/64 with leaves, LOD 6/32 without).
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np
from _common import best_of

from plantvr.geometry.synthetic import random_tree
from plantvr.geometry import IncrementalBranchMesh, IncrementalLeafMesh, build_branch_mesh, update_branch_mesh
from plantvr.geometry import _kernels as K
from plantvr.geometry.leaves import build_leaves


def pipe_radii(parent, tip_radius=0.01, exponent=2.5):
    """Eq. 9.15 radii by a reverse fold."""
    n = len(parent)
    acc = np.zeros(n)
    for i in range(n - 1, 0, -1):
        if acc[i] == 0:
            acc[i] = tip_radius ** exponent
        if parent[i] > 0:
            acc[parent[i]] += acc[i]
    r = acc ** (1 / exponent)
    r[0] = r[1]
    return r


def _buds(pos, parent, radius):
    """Every empty bud slot of the binary tree (a main bud on tips, a lateral bud on one-child nodes), with
    directions and up vectors that depend only on the node (so a bud keeps its row content between steps)."""
    n = len(pos)
    nk = np.bincount(parent[1:], minlength=n)
    tips, lat = np.flatnonzero(nk == 0), np.flatnonzero(nk <= 1)
    tips, lat = tips[tips > 0], lat[lat > 0]
    node = np.concatenate([tips, lat])
    d = pos[node] - pos[parent[node]]
    d /= np.linalg.norm(d, axis=1)[:, None]
    e1 = np.cross(d, [0.3, 0.5, 0.81])
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    e2 = np.cross(d, e1)
    phi = 2.4 * node[:, None]
    a = np.cos(phi) * e1 + np.sin(phi) * e2
    lateral = (np.arange(len(node)) >= len(tips))[:, None]
    heading = np.where(lateral, np.cos(0.8) * d + np.sin(0.8) * a, d)
    return pos[node], heading, radius[node], np.where(lateral, np.cos(0.8) * a - np.sin(0.8) * d, a)


def _tube_baseline(pos, parent, radius, n_sides=10):
    import pyvista as pv
    idx = np.arange(1, len(pos))
    pts = np.concatenate([pos[parent[idx]], pos[idx]])
    m = len(idx)
    lines = np.column_stack([np.full(m, 2), np.arange(m), np.arange(m) + m]).ravel()
    pd = pv.PolyData(pts, lines=lines)
    pd.point_data["radius"] = np.concatenate([radius[idx], radius[idx]])

    def run():
        return pd.tube(scalars="radius", absolute=True, n_sides=n_sides, capping=False)
    return run


LEAF_KW = dict(radius_threshold=0.03, leaf_size=0.3, petiole_length=0.05, petiole_radius=0.003)


def _grow_step(pos, parent, main, rng, frac_tip=0.01, frac_lateral=0.005):
    """One synthetic growth step: 1 % of the tips extend, 0.5 % of the nodes sprout a lateral; pipe radii."""
    n = len(pos)
    nk = np.bincount(parent[1:], minlength=n)
    tips = np.flatnonzero(nk == 0)
    tips = rng.choice(tips[tips > 0], max(1, int(frac_tip * len(tips))), replace=False)
    one = np.flatnonzero(nk == 1)
    lat = rng.choice(one[one > 0], max(1, int(frac_lateral * n)), replace=False)
    src = np.concatenate([tips, lat])
    d = pos[src] - pos[parent[src]]
    d /= np.linalg.norm(d, axis=1)[:, None]
    d[len(tips):] += 0.8 * rng.normal(size=(len(lat), 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    new = n + np.arange(len(src))
    pos2 = np.vstack([pos, pos[src] + 0.3 * d])
    parent2 = np.concatenate([parent, src])
    main2 = np.concatenate([main, np.full(len(src), -1)])
    main2[tips] = new[:len(tips)]
    return pos2, parent2, pipe_radii(parent2), main2


def _cpu(fn):
    """(wall s, process CPU s, result) of one call."""
    c, t = time.process_time(), time.perf_counter()
    out = fn()
    return time.perf_counter() - t, time.process_time() - c, out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small sizes for CI (< 30 s)")
    ap.add_argument("--render", default=None, help="directory for two offscreen PNGs")
    args = ap.parse_args(argv)
    import numba
    sizes = [2_000, 5_000] if args.quick else [5_000, 22_000, 50_000]
    results: dict = {"build": [], "incremental": [], "load": os.getloadavg()[0], "cores": os.cpu_count()}
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; best of 3 wall times")
    print(f"{'internodes':>10} {'tris':>9} {'leaves':>7} {'ours ms':>8} {'6/32 ms':>8} {'leaves ms':>9} "
          f"{'ours+leaves':>11} {'(cpu ms)':>8} {'pv.tube ms':>10} {'numpy twin ms':>13}")
    for n in sizes:
        pos, parent, radius, mc = random_tree(n, seed=n)
        bp, bd, br, bu = _buds(pos, parent, radius)

        def build(lod=(10, 64)):
            return build_branch_mesh(pos, parent, radius, main_child=mc, tip_radius=0.01, lod=lod)

        def leaves():
            return build_leaves(bp, bd, br, bud_up=bu, **LEAF_KW)

        build(), leaves()                                  # JIT warm-up (cached on disk afterwards)
        t_ours, mesh = best_of(build)
        t_fast, _ = best_of(lambda: build((6, 32)))
        t_leaf, lv = best_of(leaves)
        cpu = min(_cpu(lambda: (build(), leaves()))[1] for _ in range(3))
        t_tube, tube = best_of(_tube_baseline(pos, parent, radius), repeat=1)
        sample = np.arange(0, len(mesh.segments), max(1, len(mesh.segments) // 300), dtype=np.int64)
        V, NRM, UV, NID, F = (np.empty_like(a) for a in (mesh.vertices, mesh.normals, mesh.uv, mesh.node_id,
                                                          mesh.faces))
        t0 = time.perf_counter()
        K._eval_segments_numpy(mesh.segments.records, mesh.counts, mesh.options["u_steps"], mesh.segments.nodes,
                               mesh.segments.caps, sample, mesh.v_off, mesh.f_off, 1.0, V, NRM, UV, NID, F)
        t_twin = (time.perf_counter() - t0) * len(mesh.segments) / len(sample)
        row = dict(internodes=n, triangles=len(mesh.faces), leaves=len(lv.frames), leaf_triangles=len(lv.faces),
                   ours_s=t_ours, ours_6_32_s=t_fast, leaves_s=t_leaf, ours_leaves_s=t_ours + t_leaf,
                   ours_leaves_cpu_s=cpu, pv_tube_s=t_tube, pv_tube_triangles=int(tube.n_cells),
                   numpy_twin_s=t_twin)
        results["build"].append(row)
        print(f"{n:>10} {len(mesh.faces):>9} {len(lv.frames):>7} {1e3 * t_ours:>8.1f} {1e3 * t_fast:>8.1f} "
              f"{1e3 * t_leaf:>9.1f} {1e3 * (t_ours + t_leaf):>11.1f} {1e3 * cpu:>8.1f} {1e3 * t_tube:>10.1f} "
              f"{1e3 * t_twin:>13.0f}")
    results["incremental"] = _incremental(2_000 if args.quick else 22_000, 3 if args.quick else 6, numba)
    if args.render:
        results["render"] = _render(args.render)
    return results


def _incremental(n, steps, numba):
    """Consecutive growth steps on one IncrementalBranchMesh vs. the copy-based update, a rebuild, pv.tube."""
    pos, parent, radius, mc = random_tree(n, seed=1)
    rng = np.random.default_rng(0)
    trees = [(pos, parent, radius, mc)]
    for _ in range(steps):
        trees.append(_grow_step(*trees[-1][:2], trees[-1][3], rng))
    print(f"\nincremental update after one growth step at {n} internodes ({steps} consecutive steps; the "
          f"update twice: numba threads = {numba.get_num_threads()} and 1)")
    print(f"{'step':>4} {'new':>5} {'changed':>8} {'verts rewritten':>15} {'update ms':>9} {'1-thread ms':>11} "
          f"{'(cpu ms)':>8} {'leaves +/-':>10} {'leaf upd ms':>11} {'(cpu ms)':>8} {'copy-update ms':>14} "
          f"{'full rebuild ms':>15} {'+leaves ms':>10} {'pv.tube ms':>10}")
    kw = dict(tip_radius=0.01)
    rows = []
    threads = numba.get_num_threads()
    IncrementalBranchMesh(*trees[0][:3], main_child=trees[0][3], **kw).update(*trees[1][:3], main_child=trees[1][3])
    incs = {t: IncrementalBranchMesh(*trees[0][:3], main_child=trees[0][3], **kw) for t in (threads, 1)}
    leaves = IncrementalLeafMesh(**LEAF_KW)
    leaves.update(*_buds(*trees[0][:3]))
    old = build_branch_mesh(*trees[0][:3], main_child=trees[0][3], **kw)
    update_branch_mesh(build_branch_mesh(*trees[0][:3], main_child=trees[0][3], **kw), *trees[1][:3],
                       main_child=trees[1][3])                                   # warm-up
    for k in range(1, steps + 1):
        p, par, r, m = trees[k]
        res = {}
        for t, inc in incs.items():
            numba.set_num_threads(t)
            res[t] = _cpu(lambda: inc.update(p, par, r, main_child=m))
        numba.set_num_threads(threads)
        upd = res[threads][2]
        t_copy, _, (old, _) = _cpu(lambda: update_branch_mesh(old, p, par, r, main_child=m))
        buds = _buds(p, par, r)
        numba.set_num_threads(1)
        t_leaf, c_leaf, lres = _cpu(lambda: leaves.update(*buds))
        numba.set_num_threads(threads)
        t_full, _ = best_of(lambda: build_branch_mesh(p, par, r, main_child=m, **kw), repeat=1)
        t_full_leaves, _ = best_of(lambda: build_leaves(buds[0], buds[1], buds[2], bud_up=buds[3], **LEAF_KW),
                                 repeat=1)
        t_tube, _ = best_of(_tube_baseline(p, par, r), repeat=1)
        rewritten = int((upd.vertex_ranges[:, 1] - upd.vertex_ranges[:, 0]).sum()) if not upd.relayout else -1
        row = dict(step=k, internodes=len(p) - 1, new=len(p) - len(trees[k - 1][0]), changed=len(upd.changed),
                   vertices_rewritten=rewritten, relayout=upd.relayout, update_s=res[threads][0],
                   update_1thread_s=res[1][0], update_1thread_cpu_s=res[1][1], copy_update_s=t_copy,
                   leaves_added=lres["added"], leaves_removed=lres["removed"], leaf_update_1thread_s=t_leaf,
                   leaf_update_1thread_cpu_s=c_leaf, full_s=t_full, full_leaves_s=t_full_leaves, pv_tube_s=t_tube)
        rows.append(row)
        print(f"{k:>4} {row['new']:>5} {row['changed']:>8} {rewritten:>15} {1e3 * row['update_s']:>9.1f} "
              f"{1e3 * row['update_1thread_s']:>11.1f} {1e3 * row['update_1thread_cpu_s']:>8.1f} "
              f"{lres['added']:>5}/{lres['removed']:<4} {1e3 * t_leaf:>11.1f} {1e3 * c_leaf:>8.1f} "
              f"{1e3 * t_copy:>14.1f} {1e3 * t_full:>15.1f} {1e3 * t_full_leaves:>10.1f} {1e3 * t_tube:>10.1f}")
    med = {k: float(np.median([r[k] for r in rows])) for k in (
        "update_s", "update_1thread_s", "update_1thread_cpu_s", "leaf_update_1thread_s", "leaf_update_1thread_cpu_s",
        "copy_update_s", "full_s", "full_leaves_s")}
    print("median: " + ", ".join(f"{k} {1e3 * v:.1f} ms" for k, v in med.items()))
    ok = incs[1].to_branch_mesh()
    ref = build_branch_mesh(*trees[-1][:3], main_child=trees[-1][3], **kw)
    same = all(np.array_equal(getattr(ok, a), getattr(ref, a)) for a in ("vertices", "faces", "normals", "uv"))
    print(f"after {steps} steps: compacted incremental mesh == full rebuild: {same}")
    return dict(rows=rows, median=med, equal_to_rebuild=same)


def _render(outdir):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    from plantvr.geometry.textures import bark_texture, leaf_texture
    os.makedirs(outdir, exist_ok=True)
    pos, parent, radius, mc = random_tree(400, seed=3, tip_radius=0.015)
    bp, bd, br, bu = _buds(pos, parent, radius)
    paths = []
    for lod, leaves, name in (((10, 64), True, "tree_lod10_64_leaves.png"), ((6, 32), False, "tree_lod6_32.png")):
        m = build_branch_mesh(pos, parent, radius, main_child=mc, lod=lod, bark_rate=2.0)
        p = pv.Plotter(off_screen=True, window_size=(700, 800))
        bark = pv.PolyData(m.vertices, np.column_stack([np.full(len(m.faces), 3), m.faces]).ravel())
        bark.active_texture_coordinates = m.uv
        p.add_mesh(bark, texture=pv.Texture(np.ascontiguousarray(bark_texture("furrowed")[::-1, :, :3])),
                   show_edges=not leaves, edge_color="#331a00", line_width=0.5)
        if leaves:
            lv = build_leaves(bp, bd, br, bud_up=bu, radius_threshold=0.03, leaf_size=0.35, petiole_length=0.05)
            lf = pv.PolyData(lv.vertices, np.column_stack([np.full(len(lv.faces), 3), lv.faces]).ravel())
            lf.active_texture_coordinates = lv.uv
            p.add_mesh(lf, texture=pv.Texture(np.ascontiguousarray(leaf_texture("ovate")[::-1])))
        p.camera_position = "xy"
        p.camera.azimuth = 25
        p.camera.elevation = 10
        path = os.path.join(outdir, name)
        p.screenshot(path)
        p.close()
        paths.append(path)
        print("wrote", path)
    return paths


if __name__ == "__main__":
    main()

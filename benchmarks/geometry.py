"""Tree geometry benchmark (spec 000_treewand §3, §8.2): full mesh build and incremental update vs baselines.

Prints, for several tree sizes, the time of ``build_branch_mesh`` (numba) beside a plain pyvista ``tube()`` of the
same skeleton and the per-segment numpy twin (naive loop, timed on a sample and scaled), the leaf-mesh time, and
the incremental update after one growth step beside a full rebuild. ``--quick`` runs small sizes (< 30 s);
``--render DIR`` also writes two offscreen PNGs (LOD 10/64 with leaves, LOD 6/32 without).
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

from plantvr.geometry import build_branch_mesh, update_branch_mesh
from plantvr.geometry import _kernels as K
from plantvr.geometry.leaves import build_leaves


def random_tree(n_internodes: int, seed: int = 0, tip_radius: float = 0.01, exponent: float = 2.5):
    """Random binary tree (y up) with pipe-model radii; returns pos, parent, radius, main_child."""
    rng = np.random.default_rng(seed)
    n = n_internodes + 1
    pos, head = np.zeros((n, 3)), np.zeros((n, 3))
    parent, main = np.full(n, -1, np.int64), np.full(n, -1, np.int64)
    nk = np.zeros(n, np.int64)
    pos[1] = head[1] = (0, 1.0, 0)
    parent[1], main[0], nk[0] = 0, 1, 1
    buds = [1, 1]
    noise = rng.normal(size=(n, 3))
    for i in range(2, n):
        k = rng.integers(len(buds))
        p = buds[k]
        buds[k] = buds[-1]
        buds.pop()
        a = noise[i] - (noise[i] @ head[p]) * head[p]
        a /= np.linalg.norm(a)
        ang = np.deg2rad(45.0 if nk[p] else 8.0)
        d = np.cos(ang) * head[p] + np.sin(ang) * a + (0, 0.15, 0)
        d /= np.linalg.norm(d)
        pos[i], head[i], parent[i] = pos[p] + 0.3 * d, d, p
        if nk[p] == 0:
            main[p] = i
        nk[p] += 1
        buds += [i, i]
    return pos, parent, pipe_radii(parent, tip_radius, exponent), main


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


def _best(fn, repeat=3):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _buds(pos, parent, radius):
    tips = np.flatnonzero(np.bincount(parent[1:], minlength=len(pos)) == 0)
    tips = tips[tips > 0]
    d = pos[tips] - pos[parent[tips]]
    d /= np.linalg.norm(d, axis=1)[:, None]
    return pos[tips], d, radius[tips]


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


def _grow_step(pos, parent, main, frac, rng):
    tips = np.flatnonzero(np.bincount(parent[1:], minlength=len(pos)) == 0)
    tips = rng.choice(tips[tips > 0], max(1, int(frac * len(tips))), replace=False)
    d = pos[tips] - pos[parent[tips]]
    d /= np.linalg.norm(d, axis=1)[:, None]
    new = len(pos) + np.arange(len(tips))
    pos2 = np.vstack([pos, pos[tips] + 0.3 * d])
    parent2 = np.concatenate([parent, tips])
    main2 = np.concatenate([main, np.full(len(tips), -1)])
    main2[tips] = new
    return pos2, parent2, pipe_radii(parent2), main2


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small sizes for CI (< 30 s)")
    ap.add_argument("--render", default=None, help="directory for two offscreen PNGs")
    args = ap.parse_args(argv)
    sizes = [2_000, 5_000] if args.quick else [5_000, 22_000, 50_000]
    results: dict = {"build": [], "incremental": []}
    print(f"{'internodes':>10} {'tris':>10} {'ours ms':>9} {'+leaves ms':>10} {'pv.tube ms':>10} "
          f"{'numpy twin ms':>13}")
    for n in sizes:
        pos, parent, radius, mc = random_tree(n, seed=n)
        build = lambda: build_branch_mesh(pos, parent, radius, main_child=mc, tip_radius=0.01)  # noqa: E731
        build()                                            # JIT warm-up (cached on disk afterwards)
        t_ours, mesh = _best(build)
        bp, bd, br = _buds(pos, parent, radius)
        t_leaf, leaves = _best(lambda: build_leaves(bp, bd, br, radius_threshold=0.03, leaf_size=0.3,
                                                    petiole_length=0.05, rng=0))
        t_tube, tube = _best(_tube_baseline(pos, parent, radius), repeat=1)
        sample = np.arange(0, len(mesh.segments), max(1, len(mesh.segments) // 300), dtype=np.int64)
        V, NRM, UV, NID, F = (np.empty_like(a) for a in (mesh.vertices, mesh.normals, mesh.uv, mesh.node_id,
                                                          mesh.faces))
        t0 = time.perf_counter()
        K._eval_segments_numpy(mesh.segments.records, mesh.counts, mesh.options["u_steps"], mesh.segments.nodes,
                               mesh.segments.caps, sample, mesh.v_off, mesh.f_off, 1.0, V, NRM, UV, NID, F)
        t_twin = (time.perf_counter() - t0) * len(mesh.segments) / len(sample)
        row = dict(internodes=n, triangles=len(mesh.faces), leaf_triangles=len(leaves.faces), ours_s=t_ours,
                   leaves_s=t_leaf, pv_tube_s=t_tube, pv_tube_triangles=int(tube.n_cells), numpy_twin_s=t_twin)
        results["build"].append(row)
        print(f"{n:>10} {len(mesh.faces):>10} {1e3 * t_ours:>9.1f} {1e3 * (t_ours + t_leaf):>10.1f} "
              f"{1e3 * t_tube:>10.1f} {1e3 * t_twin:>13.0f}")
    # incremental update after one growth step (1 % of tips grow one internode; pipe radii recomputed)
    n = 5_000 if args.quick else 22_000
    pos, parent, radius, mc = random_tree(n, seed=1)
    rng = np.random.default_rng(0)
    print(f"\nincremental update at {n} internodes (best of 3)")
    print(f"{'step':>24} {'changed segs':>12} {'update ms':>10} {'full rebuild ms':>15}")
    for label, frac in (("radius-only (tip thicken)", None), ("growth step, 1% tips", 0.01)):
        base = build_branch_mesh(pos, parent, radius, main_child=mc, tip_radius=0.01)
        if frac is None:
            p2, par2, m2 = pos, parent, mc
            r2 = radius.copy()
            r2[np.flatnonzero(np.bincount(parent[1:], minlength=len(pos)) == 0)[-1]] *= 1.001
        else:
            p2, par2, r2, m2 = _grow_step(pos, parent, mc, frac, rng)
        times = []
        for _ in range(3):
            old = build_branch_mesh(pos, parent, radius, main_child=mc, tip_radius=0.01)
            t = time.perf_counter()
            new, changed = update_branch_mesh(old, p2, par2, r2, main_child=m2)
            times.append(time.perf_counter() - t)
        t_full, _ = _best(lambda: build_branch_mesh(p2, par2, r2, main_child=m2, tip_radius=0.01))
        del base
        results["incremental"].append(dict(step=label, internodes=n, changed=len(changed),
                                           segments=len(new.segments), update_s=min(times), full_s=t_full))
        print(f"{label:>24} {len(changed):>12} {1e3 * min(times):>10.1f} {1e3 * t_full:>15.1f}")
    if args.render:
        results["render"] = _render(args.render)
    return results


def _render(outdir):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    from plantvr.geometry.textures import bark_texture, leaf_texture
    os.makedirs(outdir, exist_ok=True)
    pos, parent, radius, mc = random_tree(400, seed=3, tip_radius=0.015)
    bp, bd, br = _buds(pos, parent, radius)
    paths = []
    for lod, leaves, name in (((10, 64), True, "tree_lod10_64_leaves.png"), ((6, 32), False, "tree_lod6_32.png")):
        m = build_branch_mesh(pos, parent, radius, main_child=mc, lod=lod, bark_rate=2.0)
        p = pv.Plotter(off_screen=True, window_size=(700, 800))
        bark = pv.PolyData(m.vertices, np.column_stack([np.full(len(m.faces), 3), m.faces]).ravel())
        bark.active_texture_coordinates = m.uv
        p.add_mesh(bark, texture=pv.Texture(np.ascontiguousarray(bark_texture("furrowed")[::-1, :, :3])),
                   show_edges=not leaves, edge_color="#331a00", line_width=0.5)
        if leaves:
            lv = build_leaves(bp, bd, br, radius_threshold=0.03, leaf_size=0.35, petiole_length=0.05, rng=0)
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

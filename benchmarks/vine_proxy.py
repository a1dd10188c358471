"""ViNE display proxy benchmark (issue 14): proxy build (merge, decimate, map, labels) and the per-stamp delta
update, beside a full recompute of every proxy label (numba kernel and its numpy twin) in the same run.

Mesh: a synthetic flower head tiled to the gerbera class (18 M vertices / 36 M faces) or, with ``--quick``,
to 300 k vertices. The proxy budget defaults to 1.5 M triangles (``--quick``: 60 k).

Memory: peak RSS of the process (``ru_maxrss``, mesh and segmentation included). The baseline is the one-pass
build (``chunk_faces`` above the mesh size: fast-simplification sees the whole mesh), run in a forked child
from the same state so its peak is comparable; ``--no-baseline`` skips it (at 36 M faces it needs ~16 GiB).

Run: ``python benchmarks/vine_proxy.py [--quick] [--vertices N] [--faces F] [--chunk-faces C] [--no-baseline]``.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from _common import current_rss_gib, in_forked_child, peak_rss_gib, radius_for

from plantvr.documents.labels import Segmentation
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.vine.proxy import DisplayProxy, _proxy_labels_numpy
from plantvr.vine.synth import synth_flowerhead, tile_mesh


def _one_pass(seg, budget) -> tuple[float, float, float, int]:
    """In the forked child: the one-pass build (no chunking); (seconds, peak RSS GiB, RSS at start GiB, proxy
    vertices)."""
    start = current_rss_gib()
    t = time.perf_counter()
    px = DisplayProxy(seg, target_faces=budget, chunk_faces=2 ** 31 - 1, observe=False)
    return time.perf_counter() - t, peak_rss_gib(), start, px.n_vertices


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="300k vertices (CI)")
    ap.add_argument("--vertices", type=int, default=None, help="target vertex count (default 18M)")
    ap.add_argument("--faces", type=int, default=None, help="proxy triangle budget (default 1.5M)")
    ap.add_argument("--chunk-faces", type=int, default=6_000_000,
                    help="most faces per fast-simplification call (DisplayProxy chunk_faces)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the one-pass build in a forked child")
    a = ap.parse_args(argv)
    n_target = a.vertices or (300_000 if a.quick else 18_000_000)
    budget = a.faces or (60_000 if a.quick else 1_500_000)
    head = synth_flowerhead(96 if a.quick else 256, rng=0)
    s = extract_isosurface(head.volume, head.level)
    # warm the numba kernels on one head so the build time below is not compile time
    DisplayProxy(Segmentation(s.vertices, s.faces), target_faces=len(s.faces) // 4).close()
    v, f = tile_mesh(s.vertices, s.faces, n_target)
    del head, s
    seg = Segmentation(v, f)
    del v, f
    before = current_rss_gib()
    print(f"mesh: {seg.n_vertices:,} vertices, {len(seg.faces):,} faces; proxy budget {budget:,} triangles; "
          f"RSS before the build {before:.2f} GiB (peak so far {peak_rss_gib():.2f} GiB)", flush=True)
    out: dict = {"vertices": seg.n_vertices, "faces": len(seg.faces), "budget": budget, "rss_before_gib": before}
    base = None if a.no_baseline else in_forked_child(_one_pass, seg, budget)
    if base is not None:
        out.update(one_pass_build_s=base[0], one_pass_peak_rss_gib=base[1])
        print(f"baseline one-pass build (fast-simplification on the whole mesh, forked child): {base[0]:.2f} s, "
              f"peak RSS {base[1]:.2f} GiB, {base[3]:,} proxy vertices", flush=True)
    elif not a.no_baseline:
        print("baseline one-pass build: the child died (out of memory?)", flush=True)

    t = time.perf_counter()
    px = DisplayProxy(seg, target_faces=budget, chunk_faces=a.chunk_faces)
    build = time.perf_counter() - t
    peak = peak_rss_gib()
    out.update(build_s=build, proxy_vertices=px.n_vertices, proxy_faces=len(px.faces),
               mapping_bytes_per_vertex=px.nbytes / seg.n_vertices, peak_rss_gib=peak,
               **{f"{k}_s": val for k, val in px.timings.items()})
    vs = f"  vs one-pass {base[0]:.2f} s, {base[1]:.2f} GiB" if base is not None else ""
    print(f"proxy build (chunk_faces {a.chunk_faces:,}) {build:.2f} s "
          f"({', '.join(f'{k} {val:.2f} s' for k, val in px.timings.items())}): "
          f"{px.n_vertices:,} vertices, {len(px.faces):,} faces; mapping {px.nbytes / seg.n_vertices:.1f} B/vertex; "
          f"peak RSS {peak:.2f} GiB{vs}", flush=True)

    # baselines: full recompute of all proxy labels
    reps = 3
    ts = []
    for _ in range(reps):
        t = time.perf_counter()
        px.recompute()
        ts.append(time.perf_counter() - t)
    full_numba = min(ts)
    t = time.perf_counter()
    ref = _proxy_labels_numpy(px.owner, px.n_vertices, seg.labels, seg.colors.paintable_lut())
    full_numpy = time.perf_counter() - t
    assert np.array_equal(ref, px.labels)
    out.update(recompute_numba_ms=full_numba * 1e3, recompute_numpy_ms=full_numpy * 1e3)
    print(f"full recompute: numba {full_numba * 1e3:.1f} ms, numpy twin {full_numpy * 1e3:.1f} ms (baselines)")

    rng = np.random.default_rng(0)
    for hits in (10_000, 100_000):
        c = seg.vertices[rng.integers(seg.n_vertices)].astype(np.float64)
        r = radius_for(seg.index, c, hits, steps=30)
        times, changed = [], []
        for k in range(6):
            lab = 1 + k % 5
            ids, _old = seg.index.paint(c, r, seg.labels, seg.colors.paintable_lut(), lab)  # full-res stamp
            t = time.perf_counter()
            ch = px.update(ids)
            times.append(time.perf_counter() - t)
            changed.append(len(ch))
        assert np.array_equal(px.labels, _proxy_labels_numpy(px.owner, px.n_vertices, seg.labels,
                                                             seg.colors.paintable_lut()))
        dt = float(np.min(times))
        out[f"delta_{hits}_ms"] = dt * 1e3
        out[f"delta_{hits}_proxy_changed"] = int(np.median(changed))
        print(f"delta update, {hits:,} full-res hits: {dt * 1e3:.2f} ms, {int(np.median(changed)):,} proxy "
              f"vertices changed ({int(np.median(changed)) * 4:,} B of RGBA to send)  vs full recompute "
              f"{full_numba * 1e3:.1f} ms ({full_numba / dt:.0f}x)")
    px.close()
    return out


if __name__ == "__main__":
    main()

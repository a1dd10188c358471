"""PLY export benchmark (spec 000_vine §2.7, item 24): numpy structured-array writer vs trimesh export.

Both write the same binary PLY with per-vertex RGBA; trimesh reads our file back as the oracle.
Run: ``python benchmarks/vine_ply.py [--quick] [--vertices N]`` (default 2 M vertices / 4 M faces).
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
import tracemalloc

import numpy as np
import trimesh

from plantvr.io.ply import write_ply
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.vine.synth import synth_flowerhead, tile_mesh


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="200k vertices (CI)")
    ap.add_argument("--vertices", type=int, default=None)
    a = ap.parse_args(argv)
    n = a.vertices or (200_000 if a.quick else 2_000_000)
    head = synth_flowerhead(96 if a.quick else 192, rng=0)
    s = extract_isosurface(head.volume, head.level)
    v, f = tile_mesh(s.vertices, s.faces, n)
    rng = np.random.default_rng(0)
    colors = rng.integers(0, 256, (len(v), 4)).astype(np.uint8)
    out = {"vertices": len(v), "faces": len(f)}
    print(f"mesh: {len(v):,} vertices, {len(f):,} faces")
    with tempfile.TemporaryDirectory() as d:
        ours, theirs = os.path.join(d, "ours.ply"), os.path.join(d, "trimesh.ply")
        tracemalloc.start()
        t = time.perf_counter()
        write_ply(ours, v, f, colors=colors)
        out["ours_s"] = time.perf_counter() - t
        out["ours_peak_mib"] = tracemalloc.get_traced_memory()[1] / 2 ** 20
        tracemalloc.stop()
        m = trimesh.Trimesh(v, f, vertex_colors=colors, process=False)
        tracemalloc.start()
        t = time.perf_counter()
        m.export(theirs)
        out["trimesh_s"] = time.perf_counter() - t
        out["trimesh_peak_mib"] = tracemalloc.get_traced_memory()[1] / 2 ** 20
        tracemalloc.stop()
        t = time.perf_counter()
        back = trimesh.load(ours, process=False)
        out["trimesh_read_s"] = time.perf_counter() - t
        ok = (np.array_equal(np.asarray(back.vertices, np.float32), v) and np.array_equal(back.faces, f)
              and np.array_equal(back.visual.vertex_colors, colors))
        out["round_trip_ok"] = bool(ok)
        out["ours_mib"] = os.path.getsize(ours) / 2 ** 20
        out["trimesh_mib"] = os.path.getsize(theirs) / 2 ** 20
    print(f"write: ours {out['ours_s']:.2f} s (peak +{out['ours_peak_mib']:.0f} MiB, {out['ours_mib']:.0f} MiB file) | "
          f"baseline trimesh export {out['trimesh_s']:.2f} s (peak +{out['trimesh_peak_mib']:.0f} MiB, "
          f"{out['trimesh_mib']:.0f} MiB file) -> {out['trimesh_s'] / out['ours_s']:.1f}x")
    print(f"trimesh reads ours back in {out['trimesh_read_s']:.2f} s; identical: {ok}")
    return out


if __name__ == "__main__":
    main()

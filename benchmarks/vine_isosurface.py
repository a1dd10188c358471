"""Isosurface benchmark (spec 000_vine §1.5, item 2; issue 14): slab-wise VTK flying edges (the default of
``extract_isosurface``) vs flying edges on the whole volume vs scikit-image marching cubes (slab-wise, and on the
whole volume where it fits), on a large synthetic vessel volume (``plantvr.vine.synth.synth_vessels``).

Each method runs in a forked child of the process that holds the volume, so its peak RSS (``ru_maxrss``, the
volume included) and its CPU time are its own; wall time is the best of ``--reps`` runs. CPU time is printed
too because wall time on a shared 2-core machine depends on the neighbours. Targets (issue 14): slab-wise no
slower than whole-volume flying edges; the 1624x1624x710 class uint8 volume in <= 8 GiB peak.

Run: ``python benchmarks/vine_isosurface.py [--quick] [--shape X Y Z] [--slab N] [--reps R] [--skimage-whole]``
(default 812 812 355, an eighth of the 1624 1624 710 class; ``--full`` is that class). Baselines: VTK flying
edges on the whole volume, both as the core's slab kernel called once (zero-copy VTK views, fixed up in place: a
lower bound) and through ``extract_isosurface`` with one slab (the same Surface product: (x, y, z) float32, uint32
outward faces).
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from _common import cpu_seconds, current_rss_gib, in_forked_child, peak_rss_gib

from plantvr.adapters.vtk_isosurface import extract_isosurface, flying_edges_slab
from plantvr.vine.synth import synth_vessels

_GIB = 2 ** 30


def _whole_flying_edges(vol: np.ndarray, level: float):
    """Baseline: one flying-edges pass over the whole volume (the core's slab kernel with one slab), output as
    zero-copy views of VTK's arrays."""
    return flying_edges_slab(vol, level, 0, 1)


def _whole_skimage(vol: np.ndarray, level: float):
    from skimage.measure import marching_cubes
    v, f, _, _ = marching_cubes(vol, level)
    return v, f, None


def _measure(fn, reps: int):
    """In the forked child: (best wall s, best CPU s, peak RSS GiB, RSS at start GiB, vertices, faces)."""
    start = current_rss_gib()
    best, cpu, res = np.inf, np.inf, None
    for _ in range(reps):
        res = None
        c, t = cpu_seconds(), time.perf_counter()
        res = fn()
        best, cpu = min(best, time.perf_counter() - t), min(cpu, cpu_seconds() - c)
    v, f = (res.vertices, res.faces) if hasattr(res, "vertices") else res[:2]
    return best, cpu, peak_rss_gib(), start, len(v), len(f)


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="288x288x144 volume (CI)")
    ap.add_argument("--full", action="store_true", help="the 1624x1624x710 class")
    ap.add_argument("--shape", type=int, nargs=3, default=None)
    ap.add_argument("--slab", type=int, default=16)
    ap.add_argument("--reps", type=int, default=None, help="runs per method (best wall time); default 3, full 1")
    ap.add_argument("--no-skimage", action="store_true", help="skip scikit-image")
    ap.add_argument("--skimage-whole", action="store_true",
                    help="also run scikit-image on the whole volume (float copy: 8+ bytes per voxel)")
    a = ap.parse_args(argv)
    shape = tuple(a.shape) if a.shape else (
        (288, 288, 144) if a.quick else (1624, 1624, 710) if a.full else (812, 812, 355))
    reps = a.reps or (1 if a.full else 3)
    t = time.perf_counter()
    vol, level = synth_vessels(shape, rng=0)
    print(f"vessel volume {shape} uint8 ({vol.nbytes / _GIB:.2f} GiB, made in {time.perf_counter() - t:.1f} s), "
          f"level {level}; RSS {current_rss_gib():.2f} GiB", flush=True)
    warm = np.zeros((8, 8, 8), np.uint8)
    warm[3:5, 3:5, 3:5] = 255
    extract_isosurface(warm, level)                        # imports and first-call costs outside the timing
    extract_isosurface(warm, level, method="skimage")
    _whole_flying_edges(warm, level)
    nx = vol.shape[0]
    methods = [("slab-wise flying edges (default, 2 threads)", lambda: extract_isosurface(vol, level, slab=a.slab)),
               ("slab-wise flying edges, 1 thread", lambda: extract_isosurface(vol, level, slab=a.slab, workers=1)),
               ("baseline whole-volume VTK flying edges (zero-copy output)", lambda: _whole_flying_edges(vol, level)),
               ("baseline whole-volume flying edges, same Surface output",
                lambda: extract_isosurface(vol, level, slab=nx, workers=1))]
    if not a.no_skimage:
        methods.append(("baseline slab-wise scikit-image", lambda: extract_isosurface(vol, level, slab=a.slab,
                                                                                      method="skimage")))
        if a.skimage_whole or vol.size <= 2 ** 26:
            methods.append(("baseline whole-volume scikit-image", lambda: _whole_skimage(vol, level)))
    out: dict = {"shape": shape, "slab": a.slab}
    keys = ("slab_fe", "slab_fe_1thread", "whole_fe", "whole_fe_surface", "slab_skimage", "whole_skimage")
    for key, (name, fn) in zip(keys, methods):
        r = in_forked_child(_measure, fn, 1 if key.endswith("skimage") and not a.quick else reps)
        if r is None:
            print(f"{name}: the child died (out of memory?)", flush=True)
            continue
        wall, cpu, peak, start, nv, nf = r
        out.update({f"{key}_s": wall, f"{key}_cpu_s": cpu, f"{key}_peak_gib": peak, f"{key}_vertices": nv})
        print(f"{name}: {wall:.2f} s (CPU {cpu:.2f} s), peak RSS {peak:.2f} GiB (+{peak - start:.2f} over the "
              f"volume), {nv:,} V / {nf:,} F", flush=True)
    for base in ("whole_fe", "whole_fe_surface"):
        if "slab_fe_s" in out and f"{base}_s" in out:
            print(f"slab-wise vs {base}: {out[f'{base}_s'] / out['slab_fe_s']:.2f}x wall (1 thread "
                  f"{out[f'{base}_s'] / out['slab_fe_1thread_s']:.2f}x), "
                  f"{out[f'{base}_cpu_s'] / out['slab_fe_1thread_cpu_s']:.2f}x CPU (1 thread), peak "
                  f"{out['slab_fe_peak_gib']:.2f} vs {out[f'{base}_peak_gib']:.2f} GiB "
                  f"(target: no slower; <= 8 GiB at 1624x1624x710)")
    if "slab_skimage_s" in out:
        print(f"slab-wise flying edges vs slab-wise scikit-image: {out['slab_skimage_s'] / out['slab_fe_s']:.1f}x "
              f"faster")
    return out


if __name__ == "__main__":
    main()

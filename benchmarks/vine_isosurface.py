"""Isosurface benchmark (spec 000_vine §1.5, item 2): slab-wise marching cubes vs whole-volume scikit-image,
and VTK flying edges as an outside reference (VTK is never imported by plantvr.vine).

Peak extra memory is measured with tracemalloc (numpy allocations only). Run:
``python benchmarks/vine_isosurface.py [--quick] [--shape X Y Z] [--slab N]`` (default 512 512 256).
"""
from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np
from skimage.measure import marching_cubes

from plantvr.vine.isosurface import extract_isosurface
from plantvr.vine.synth import synth_flowerhead


def _measure(fn):
    tracemalloc.start()
    t = time.perf_counter()
    r = fn()
    dt = time.perf_counter() - t
    peak = tracemalloc.get_traced_memory()[1] / 2 ** 20
    tracemalloc.stop()
    return r, dt, peak


def _flying_edges(vol, level):
    import vtk
    from vtk.util import numpy_support
    img = vtk.vtkImageData()
    img.SetDimensions(*vol.shape[::-1])
    arr = numpy_support.numpy_to_vtk(np.ascontiguousarray(vol).ravel(), deep=False)
    img.GetPointData().SetScalars(arr)
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputData(img)
    fe.SetValue(0, level)
    fe.ComputeNormalsOn()
    fe.Update()
    out = fe.GetOutput()
    return out.GetNumberOfPoints(), out.GetNumberOfCells()


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="128^3 volume (CI)")
    ap.add_argument("--shape", type=int, nargs=3, default=None)
    ap.add_argument("--slab", type=int, default=32)
    ap.add_argument("--no-vtk", action="store_true")
    a = ap.parse_args(argv)
    shape = tuple(a.shape) if a.shape else ((128, 128, 128) if a.quick else (512, 512, 256))
    head = synth_flowerhead(shape, rng=0)
    vol, level = head.volume, head.level
    print(f"volume {shape} uint8 ({vol.nbytes / 2**20:.0f} MiB), level {level}")
    out = {"shape": shape}
    warm = np.zeros((8, 8, 8), np.float32)
    warm[3:5, 3:5, 3:5] = 255
    marching_cubes(warm, level)                                       # warm-up (lazy imports)
    s, t, peak = _measure(lambda: extract_isosurface(vol, level, slab=a.slab))
    out.update(slab_s=t, slab_peak_mib=peak, vertices=len(s.vertices), faces=len(s.faces))
    print(f"slab-wise (slab={a.slab}): {t:.2f} s, peak +{peak:.0f} MiB, {len(s.vertices):,} V / {len(s.faces):,} F")
    (v, _f, _, _), t, peak = _measure(lambda: marching_cubes(vol, level))
    out.update(whole_s=t, whole_peak_mib=peak, whole_vertices=len(v))
    print(f"baseline whole-volume skimage: {t:.2f} s, peak +{peak:.0f} MiB (float copy of the volume: "
          f"{vol.size * 4 / 2**20:.0f} MiB), {len(v):,} V")
    if not a.no_vtk:
        import vtk  # noqa: F401  (import outside the timing)
        _flying_edges((warm > 0).astype(np.uint8) * 255, level)
        (nv, nf), t, _ = _measure(lambda: _flying_edges(vol, level))
        out.update(vtk_flying_edges_s=t, vtk_vertices=nv)
        print(f"reference VTK flying edges (benchmark only): {t:.2f} s, {nv:,} V / {nf:,} F")
    return out


if __name__ == "__main__":
    main()

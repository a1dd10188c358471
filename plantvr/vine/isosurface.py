"""Slab-wise isosurface (VTK flying edges or scikit-image marching cubes) with seam merging and outward winding
(spec 000_vine §1.5, checklist item 2; issue 14).

The volume is meshed in slabs along axis 0 that share one voxel plane, so memory stays bounded by one slab
and its mesh: flying edges keeps ~1 byte of edge cases per voxel of its input and scikit-image converts its
input to float32, which for a whole 1624x1624x710 uint8 volume would be 1.9 and 7.5 GiB. Vertices of adjacent
slabs on a shared plane are computed from the same voxel values by the same interpolation, so they coincide
exactly and are merged by exact coordinate matching.

Flying edges (``vtkmodules.vtkFiltersCore.vtkFlyingEdges3D``, a numeric VTK filter; no rendering module is
imported) is the default: ~9x faster than scikit-image on the same slabs, with the same vertices (same linear
interpolation on the same voxel edges) and the same triangles up to the case table. scikit-image stays as the
oracle in the tests.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skimage.measure import marching_cubes

from plantvr._validation import check_choice, check_int, check_range
from plantvr.vine.volume import _check_volume

__all__ = ["Surface", "extract_isosurface", "signed_volume"]


@dataclass(frozen=True)
class Surface:
    """A triangle mesh from marching cubes.

    Attributes
    ----------
    vertices : (V, 3) float32 ndarray
        Positions in voxel index units times ``spacing``.
    faces : (F, 3) uint32 ndarray
        Counter-clockwise seen from outside (positive signed volume for closed parts).
    normals : (V, 3) float32 ndarray
        Unit outward vertex normals.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Signed volume of a triangle mesh (positive when faces wind counter-clockwise seen from outside)."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def _seam_keys(v: np.ndarray) -> np.ndarray:
    yz = np.ascontiguousarray(v[:, 1:3].astype(np.float32))
    return yz.view(np.uint64).ravel()


def _slab_skimage(raw: np.ndarray, level: float, s: int, step: int):
    """scikit-image marching cubes of one slab: (vertices, faces wound outward, normals) or None."""
    block = raw.astype(np.float32)                       # only this slab is ever float
    try:
        v, f, n, _ = marching_cubes(block, level, step_size=step, allow_degenerate=False)
    except (ValueError, RuntimeError):
        return None
    del block
    v[:, 0] += s
    return v, f[:, ::-1], n                              # scikit-image winds inward (spec §1.5 step 5)


def _slab_flying_edges(raw: np.ndarray, level: float, s: int, step: int):
    """VTK flying edges of one slab: (vertices, faces wound outward, normals) or None."""
    from vtkmodules.util import numpy_support
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D

    block = np.ascontiguousarray(raw[::step, ::step, ::step] if step > 1 else raw)
    img = vtkImageData()
    img.SetDimensions(block.shape[2], block.shape[1], block.shape[0])   # VTK x is our (fastest) axis 2
    img.SetSpacing(step, step, step)
    img.SetOrigin(0.0, 0.0, float(s))                    # global coordinates computed by VTK in double
    img.GetPointData().SetScalars(numpy_support.numpy_to_vtk(block.ravel(), deep=False))
    fe = vtkFlyingEdges3D()
    fe.SetInputData(img)
    fe.SetValue(0, level)
    fe.ComputeNormalsOn()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    fe.Update()
    out = fe.GetOutput()
    if out.GetNumberOfPoints() == 0 or out.GetNumberOfCells() == 0:
        return None
    # zero-copy views (they keep VTK's arrays alive): (z, y, x) -> (x, y, z); the copy happens once, in _concat
    v = numpy_support.vtk_to_numpy(out.GetPoints().GetData())[:, ::-1]
    n = numpy_support.vtk_to_numpy(out.GetPointData().GetNormals())[:, ::-1]
    f = numpy_support.vtk_to_numpy(out.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f = f if keep.all() else f[keep]
    return v, f[:, ::-1], n                              # VTK winds outward; reversing the axes mirrors it


def extract_isosurface(volume: np.ndarray, level: float, *, slab: int = 64, step_size: int = 1,
                       spacing: tuple[float, float, float] = (1.0, 1.0, 1.0),
                       method: str = "flying_edges") -> Surface:
    """Extract the isosurface of a uint8/uint16 volume slab by slab (flying edges or Lewiner marching cubes).

    Parameters
    ----------
    volume : (X, Y, Z) uint8 or uint16 ndarray
        Bright structures (values above ``level``) are inside. May be a memory map.
    level : float
        Iso-value, strictly between the volume's dtype limits.
    slab : int
        Voxel planes per slab along axis 0 (slabs overlap by one plane), in [2, 65536]. Peak extra memory is
        about ``slab * Y * Z`` bytes (flying edges; ``4 *`` that for scikit-image) plus the slab's mesh.
    step_size : int
        Step in voxels, in [1, 16] (flying edges meshes every ``step_size``-th voxel, scikit-image marches
        ``step_size``-sized cubes: the same samples). With ``step_size > 1`` the slab is rounded to a multiple
        of it so seams stay aligned.
    spacing : tuple of 3 float
        Voxel size, each in (0, 1e6].
    method : {"flying_edges", "skimage"}
        ``flying_edges``: VTK ``vtkFlyingEdges3D`` per slab (default, fastest). ``skimage``:
        ``skimage.measure.marching_cubes`` (Lewiner) per slab.

    Returns
    -------
    Surface
        Seamless mesh: no duplicated vertices on slab seams; faces wound outward (F ≈ 2V when closed).

    References
    ----------
    .. [1] Spec 000_vine §1.5 steps 4–6: slabs with one voxel of overlap, seam merge by exact coordinates,
       winding flipped (``faces[:, [0, 2, 1]]``) because scikit-image's descent winding points inward.
    .. [2] Issue 14: flying edges per slab, no slower than flying edges on the whole volume.
    """
    volume = _check_volume("volume", volume)
    top = float(np.iinfo(volume.dtype).max)
    level = check_range("level", level, 0.0, top, low_open=True, high_open=True)
    step_size = check_int("step_size", step_size, 1, 16)
    slab = check_int("slab", slab, 2, 65536)
    if len(tuple(spacing)) != 3:
        raise ValueError(f"spacing must be 3 numbers, got {spacing!r}")
    spacing = tuple(check_range("spacing", s, 0.0, 1e6, low_open=True) for s in spacing)
    method = check_choice("method", method, ("flying_edges", "skimage"))
    mesher = _slab_flying_edges if method == "flying_edges" else _slab_skimage
    slab = max(step_size, (slab // step_size) * step_size)
    nx = volume.shape[0]
    last = ((nx - 1) // step_size) * step_size           # last plane the mesher reaches
    verts_parts, faces_parts, norm_parts = [], [], []
    n_total = 0
    prev_keys = prev_ids = None                          # seam vertices of the previous slab
    for s in range(0, last, slab):
        e = min(s + slab, last)
        raw = np.asarray(volume[s:e + 1])
        if raw.shape[0] < 2 or raw.max() <= level or raw.min() >= level:
            prev_keys = prev_ids = None
            continue
        m = mesher(raw, level, s, step_size)
        del raw
        if m is None:
            prev_keys = prev_ids = None
            continue
        v, f, n = m
        ids = np.arange(n_total, n_total + len(v), dtype=np.int64)
        keep = np.ones(len(v), bool)
        on_start = np.flatnonzero(v[:, 0] == s)
        if prev_keys is not None and on_start.size:
            k = _seam_keys(v[on_start])
            pos = np.minimum(np.searchsorted(prev_keys, k), len(prev_keys) - 1)
            hit = prev_keys[pos] == k
            ids[on_start[hit]] = prev_ids[pos[hit]]
            keep[on_start[hit]] = False
        n_keep = int(keep.sum())
        ids[keep] = np.arange(n_total, n_total + n_keep)  # renumber the kept vertices densely
        verts_parts.append(np.asarray(v[keep] if n_keep < len(v) else v, np.float32))
        norm_parts.append(np.asarray(n[keep] if n_keep < len(v) else n, np.float32))
        faces_parts.append(ids.astype(np.uint32)[f])    # uint32 parts: one (F, 3) copy at the end, not three
        # (f[:, ::-1] reverses each triangle: an odd permutation, the same as the spec's [0, 2, 1])
        n_total += n_keep
        on_end = np.flatnonzero(v[:, 0] == e)
        if on_end.size:
            k = _seam_keys(v[on_end])
            order = np.argsort(k, kind="stable")
            prev_keys, prev_ids = k[order], ids[on_end][order]
        else:
            prev_keys = prev_ids = None
        del v, f, n, ids, keep, m
    if not verts_parts:
        raise ValueError(f"level {level!r} gives no surface: the volume does not cross it")
    if n_total >= 2 ** 32:
        raise ValueError(f"the surface has {n_total} vertices, more than uint32 faces can index")
    vertices = _concat(verts_parts)
    if spacing != (1.0, 1.0, 1.0):
        vertices *= np.asarray(spacing, np.float32)
    faces = _concat(faces_parts)
    normals = _concat(norm_parts)
    return Surface(vertices=vertices, faces=faces, normals=normals)


def _concat(parts: list) -> np.ndarray:
    """Concatenate and free the parts as they are copied (peak: the result plus one part, not twice the mesh)."""
    out = np.empty((sum(len(p) for p in parts), *parts[0].shape[1:]), parts[0].dtype)
    o = 0
    while parts:
        p = parts.pop(0)
        out[o:o + len(p)] = p
        o += len(p)
        del p
    return out

"""Open what ``plantvr segment`` is given (spec 000_vine §1.5, checklist items 1–3; issues 14, 22): a volume file
(read by :func:`plantvr.io.volume.read_volume`, so the surface is in the scan's physical units), a mesh file or a
synthetic flower head, as a :class:`~plantvr.documents.labels.Segmentation`."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plantvr._validation import check_int, check_range
from plantvr.documents.labels import Segmentation, check_grid

__all__ = ["Source", "open_source"]

MESH_SUFFIXES = (".ply", ".obj", ".stl", ".off", ".glb", ".gltf")


@dataclass
class Source:
    """What ``plantvr segment`` opened.

    Attributes
    ----------
    seg : Segmentation
        The surface, in the volume's physical units (:attr:`~Segmentation.spacing`, :attr:`~Segmentation.origin`).
    volume : (X, Y, Z) ndarray or None
        The volume the surface came from (None for a mesh file), downsampled when asked.
    level : float or None
        Iso-value used, in the volume's own units.
    truth : (V,) uint8 ndarray or None
        Ground-truth component label of every vertex (synthetic heads only).
    description : str
        One line on what was read (format, dtype, shape, axes, spacing, origin), empty for meshes and heads.
    geometry : VolumeGeometry or None
        Where each voxel of :attr:`volume` is (downsampled with it): pass it to
        :func:`plantvr.io.label_volume.write_label_volume` so painted labels land on the scan's own voxels. None for
        meshes and synthetic heads.
    """

    seg: Segmentation
    volume: np.ndarray | None
    level: float | None
    truth: np.ndarray | None
    description: str = ""
    geometry: object = None


def open_source(source: str | os.PathLike, *, level: float | None = None, size: int = 96,
                downsample: bool = False, slab: int = 16) -> Source:
    """Open ``synth`` / ``synth:N`` (a synthetic N³ flower head), a volume file or a mesh file.

    Parameters
    ----------
    source : str or path
        ``"synth"`` or ``"synth:N"``; a volume in any format :func:`~plantvr.io.volume.read_volume` reads
        (TIFF, NRRD, NIfTI, MetaImage, .vti, HDF5, Zarr, DICOM, .npy/.npz); or a mesh (``.ply``, ``.obj``,
        ``.stl``, ``.off``, ``.glb``, ``.gltf``; vertex order kept).
    level : float, optional
        Iso-value in the volume's own units, strictly inside its data range (default: the synthetic head's own,
        or Otsu's threshold of the volume). Volumes may be uint8/16/32, int8/16/32 or float32/64.
    size : int
        Synthetic head size when ``source == "synth"``, in [16, 1024].
    downsample : bool
        2x block-mean downsampling of a volume before meshing (as for the gerbera): the grid then has twice the
        spacing, and its voxel 0 sits half a fine voxel further on.
    slab : int
        Slices per slab of the slab-wise isosurface, in [2, 4096].

    Returns
    -------
    Source
    """
    from plantvr.adapters.vtk_isosurface import extract_isosurface
    from plantvr.vine.volume import downsample2, suggest_level
    if not isinstance(source, (str, os.PathLike)):
        raise ValueError(f"source must be 'synth', 'synth:N' or a volume/mesh path, got {type(source).__name__}")
    s = os.fspath(source)
    if not s.strip():
        raise ValueError("source must be 'synth', 'synth:N' or a volume/mesh path, got ''")
    size = check_int("size", size, 16, 1024)
    slab = check_int("slab", slab, 2, 4096)
    if not isinstance(downsample, (bool, np.bool_)):
        raise ValueError(f"downsample must be True or False, got {downsample!r}")
    if s == "synth" or s.startswith("synth:"):
        if ":" in s:
            try:
                size = int(s.split(":", 1)[1])
            except ValueError:
                raise ValueError(f"source must be 'synth' or 'synth:N' with an integer N, got {s!r}") from None
            size = check_int("size", size, 16, 1024)
        from plantvr.vine.synth import synth_flowerhead, vertex_labels_from_volume
        head = synth_flowerhead(size, rng=0)
        lev = head.level if level is None else check_range("level", level, 0.0, 255.0, low_open=True,
                                                             high_open=True)
        surf = extract_isosurface(head.volume, lev)
        truth = vertex_labels_from_volume(surf.vertices, head.volume, head.labels)
        seg = Segmentation(surf.vertices, surf.faces, normals=surf.normals)
        return Source(seg, head.volume, lev, truth)
    p = Path(s)
    if not p.exists():
        raise ValueError(f"source must be 'synth', 'synth:N' or an existing volume/mesh file, got {s!r}")
    if p.suffix.lower() in MESH_SUFFIXES:
        import trimesh
        try:
            m = trimesh.load(p, force="mesh", process=False)
            v, f = np.asarray(m.vertices, np.float32), np.asarray(m.faces)
        except Exception as exc:  # noqa: BLE001 - trimesh's loaders raise many types on a corrupt file
            raise ValueError(f"could not read mesh {s!r}: {type(exc).__name__}: {exc}") from None
        if len(v) == 0 or len(f) == 0:
            raise ValueError(f"mesh {s!r} has no triangles")
        try:
            seg = Segmentation(v, f)
        except ValueError as exc:          # a damaged file: faces past the vertices, coordinates out of range
            raise ValueError(f"mesh {s!r} is not a valid triangle mesh: {exc}") from None
        return Source(seg, None, None, None)
    from plantvr.io.volume import read_volume
    vol = read_volume(p)
    arr = np.asarray(vol.array)
    sp, org = check_grid(vol.spacing, vol.origin)
    unit = f" {vol.meta['unit']}" if vol.meta.get("unit") else ""
    text = (f"volume: {vol.format} {arr.dtype} {'x'.join(map(str, arr.shape))} (axes {vol.meta.get('axes', '?')}), "
            f"spacing {', '.join(f'{x:g}' for x in sp)}{unit}, origin {', '.join(f'{x:g}' for x in org)}; "
            "the surface, the brush and distances are in these units")
    geometry = vol.geometry
    if downsample:
        arr = downsample2(arr)
        sp, org = tuple(2.0 * x for x in sp), tuple(o + 0.5 * x for o, x in zip(org, sp))
        g = geometry                                   # voxel 0 of the coarse grid: the centre of 2x2x2 fine ones
        geometry = type(g)(tuple(arr.shape), 2.0 * g.spacing, g.origin + (0.5 * g.spacing) @ g.direction,
                           g.direction, g.axes, g.unit)
    lo, hi = float(arr.min()), float(arr.max())
    if lo == hi:
        raise ValueError(f"volume {s!r} is constant (every voxel is {lo:g}): it has no surface to extract")
    lev = suggest_level(arr) if level is None else check_range("level", level, lo, hi, low_open=True,
                                                                high_open=True)
    seg = Segmentation.from_volume(arr, lev, spacing=sp, origin=org, slab=slab)
    return Source(seg, arr, lev, None, text, geometry)

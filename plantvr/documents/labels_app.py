"""The headless half of ``plantvr segment`` (spec 000_vine §1.5, checklist items 1–3, 24, 27; issue 14): open a
volume, a mesh or a synthetic flower head as a :class:`~plantvr.documents.labels.Segmentation`, and paint a
scripted demo.

The browser half (the trame review page and ``main_segment``) lives in :mod:`plantvr.view.vine_app`, because
documents never import UI code (import-linter layers contract).
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plantvr._validation import check_int, check_range
from plantvr.documents.labels import Segmentation

__all__ = ["Source", "open_source", "paint_demo"]

_MESH_SUFFIXES = (".ply", ".obj", ".stl", ".off", ".glb", ".gltf")


@dataclass
class Source:
    """What ``plantvr segment`` opened.

    Attributes
    ----------
    seg : Segmentation
    volume : (X, Y, Z) ndarray or None
        The volume the surface came from (None for a mesh file).
    level : float or None
        Iso-value used.
    truth : (V,) uint8 ndarray or None
        Ground-truth component label of every vertex (synthetic heads only).
    """

    seg: Segmentation
    volume: np.ndarray | None
    level: float | None
    truth: np.ndarray | None


def open_source(source: str | os.PathLike, *, level: float | None = None, size: int = 96,
                downsample: bool = False) -> Source:
    """Open ``synth`` / ``synth:N`` (a synthetic N³ flower head), a volume file or a mesh file.

    Parameters
    ----------
    source : str or path
        ``"synth"`` or ``"synth:N"``; a volume (``.tif``, ``.tiff``, ``.npy``, ``.npz``, ``.nrrd``); or a mesh
        (``.ply``, ``.obj``, ``.stl``, ``.off``, ``.glb``, ``.gltf``; vertex order kept).
    level : float, optional
        Iso-value in the volume's own units, strictly inside its data range (default: the synthetic head's own,
        or Otsu's threshold of the volume). Volumes may be uint8/16/32, int8/16/32 or float32/64.
    size : int
        Synthetic head size when ``source == "synth"``, in [16, 1024].
    downsample : bool
        2x block-mean downsampling of a volume before meshing (as for the gerbera).

    Returns
    -------
    Source
    """
    from plantvr.adapters.vtk_isosurface import extract_isosurface
    from plantvr.vine.volume import downsample2, load_volume, suggest_level
    if not isinstance(source, (str, os.PathLike)):
        raise ValueError(f"source must be 'synth', 'synth:N' or a volume/mesh path, got {type(source).__name__}")
    s = os.fspath(source)
    if not s.strip():
        raise ValueError("source must be 'synth', 'synth:N' or a volume/mesh path, got ''")
    size = check_int("size", size, 16, 1024)
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
    if p.suffix.lower() in _MESH_SUFFIXES:
        import trimesh
        try:
            m = trimesh.load(p, force="mesh", process=False)
            v, f = np.asarray(m.vertices, np.float32), np.asarray(m.faces)
        except Exception as exc:  # noqa: BLE001 - trimesh's loaders raise many types on a corrupt file
            raise ValueError(f"could not read mesh {s!r}: {type(exc).__name__}: {exc}") from None
        if len(v) == 0 or len(f) == 0:
            raise ValueError(f"mesh {s!r} has no triangles")
        return Source(Segmentation(v, f), None, None, None)
    vol = load_volume(p)
    if downsample:
        vol = downsample2(vol)
    lo, hi = float(vol.min()), float(vol.max())
    if lo == hi:
        raise ValueError(f"volume {s!r} is constant (every voxel is {lo:g}): it has no surface to extract")
    lev = suggest_level(vol) if level is None else check_range("level", level, lo, hi, low_open=True,
                                                                high_open=True)
    surf = extract_isosurface(vol, lev)
    return Source(Segmentation(surf.vertices, surf.faces, normals=surf.normals), vol, lev, None)


def paint_demo(seg: Segmentation, *, truth: np.ndarray | None = None, stamps: int = 24,
               rng: int | np.random.Generator | None = 0) -> int:
    """Paint a scripted demo through the sphere brush (each stamp one undoable operation).

    With ground truth, every stamp is centred on a vertex of one component and painted in that component's
    label, so the result looks like a (partial) component segmentation; without, stamps of colours 1..12 go
    to random vertices.

    Parameters
    ----------
    seg : Segmentation
    truth : (V,) uint8 ndarray, optional
        Ground-truth label per vertex (labels must exist in the colour table).
    stamps : int
        Number of brush stamps, in [1, 100000].
    rng : int, numpy.random.Generator or None

    Returns
    -------
    int
        Number of vertices painted (non-zero labels afterwards).
    """
    stamps = check_int("stamps", stamps, 1, 100_000)
    rng = np.random.default_rng(rng)
    diag = float(np.linalg.norm(np.ptp(seg.vertices, axis=0)))
    if truth is not None:
        truth = np.asarray(truth)
        if truth.shape != (seg.n_vertices,):
            raise ValueError(f"truth must have shape ({seg.n_vertices},), got {truth.shape}")
        comps = [k for k in np.unique(truth) if 0 < k < len(seg.colors)]
    for i in range(stamps):
        if truth is not None and comps:
            k = int(comps[i % len(comps)])
            ids = np.nonzero(truth == k)[0]
            v = int(rng.choice(ids))
        else:
            k = 1 + i % (len(seg.colors) - 1)
            v = int(rng.integers(seg.n_vertices))
        seg.paint(seg.vertices[v].astype(np.float64), 0.035 * diag, k)
    return int(np.count_nonzero(seg.labels))

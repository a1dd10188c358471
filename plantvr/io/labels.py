"""Segmentation and per-label mesh files: PLY, glTF, one mesh per label, the label table as CSV (spec 000_vine
§2.7 export, §6 "named labels and per-label mesh export"; issue 15; issue 21).

Every mesh file goes through the writer registry (:func:`plantvr.io.writers.save`: the one writer of each
format), atomically.
"""
from __future__ import annotations

import os

import numpy as np

from plantvr._fileio import atomic_write
from plantvr._validation import check_choice, check_int
from plantvr.vine.labelstats import _check_mesh, face_labels, label_mesh

from .writers import Part, save, writer_for

__all__ = ["LABEL_FORMATS", "export_gltf", "export_label_meshes", "export_label_table", "export_ply",
           "write_label_meshes"]

LABEL_FORMATS = ("ply", "obj", "glb")
"""Formats of :func:`write_label_meshes`."""


def export_ply(seg, path: str | os.PathLike, *, visible_only: bool = False, with_labels: bool = True) -> None:
    """Write a segmentation as a binary PLY with per-vertex RGBA colours (and a ``label`` property).

    Parameters
    ----------
    seg : plantvr.documents.labels.Segmentation
    path : str or path-like
    visible_only : bool
        Only the faces shown (:meth:`Segmentation.visible_faces`).
    with_labels : bool
        Add the ``label`` uchar property.
    """
    faces = seg.visible_faces() if visible_only else seg.faces
    save(path, Part("segmentation", seg.vertices, faces, colors=seg.vertex_colors(),
                    labels=seg.labels if with_labels else None), file_type="ply")


def export_gltf(seg, path: str | os.PathLike, *, visible_only: bool = False) -> None:
    """Write a segmentation as glTF with per-vertex RGBA colours (COLOR_0), vertex order kept: ``.glb``, or
    ``.gltf`` with its buffer ``<stem>.bin`` beside it."""
    p = os.fspath(path)
    writer_for(p, allowed=("glb", "gltf"))
    faces = seg.visible_faces() if visible_only else seg.faces
    save(p, Part("mesh", seg.vertices, faces, colors=seg.vertex_colors()), allowed=("glb", "gltf"))


def export_label_table(seg, path: str | os.PathLike, names: dict | None = None) -> None:
    """Write the segmentation's per-label statistics (:meth:`Segmentation.label_table`) as CSV."""
    table = seg.label_table(names)
    with atomic_write(path, "w") as fh:
        table.to_csv(fh, index=False)


def export_label_meshes(seg, directory: str | os.PathLike, *, fmt: str = "ply", which=None,
                        prefix: str = "label") -> dict[int, str]:
    """One mesh file per label of a segmentation, coloured with its colour table (:func:`write_label_meshes`)."""
    return write_label_meshes(directory, seg.vertices, seg.faces, seg.labels, fmt=fmt, colors=seg.colors,
                              which=which, prefix=prefix)


def write_label_meshes(directory: str | os.PathLike, vertices: np.ndarray, faces: np.ndarray,
                       labels: np.ndarray, *, fmt: str = "ply", colors=None, which=None,
                       prefix: str = "label") -> dict[int, str]:
    """Write one mesh file per label (faces whose three vertices carry it; :func:`plantvr.vine.label_mesh`).

    Parameters
    ----------
    directory : path
        Existing directory.
    vertices, faces, labels : ndarray
        The mesh and its (V,) uint8 labels.
    fmt : {"ply", "obj", "glb"}
        PLY with colours and labels, OBJ with vertex colours, binary glTF with COLOR_0; vertex order kept.
    colors : ColorTable, optional
        Vertex colours (the label's colour).
    which : iterable of int, optional
        Labels to write; default every label with at least one face.
    prefix : str
        File name prefix: ``{prefix}_{label:03d}.{fmt}``.

    Returns
    -------
    dict of int to str
        Label to written path.
    """
    v, f, lab = _check_mesh(vertices, faces, labels)
    fmt = check_choice("fmt", fmt, LABEL_FORMATS)
    d = os.fspath(directory)
    if not os.path.isdir(d):
        raise ValueError(f"directory must be an existing directory, got {d!r}")
    fl = face_labels(f, lab)
    have = np.flatnonzero(np.bincount(fl[fl >= 0], minlength=256))
    todo = have if which is None else sorted({check_int("which", k, 0, 255) for k in which})
    out = {}
    for k in todo:
        sv, sf, ids = label_mesh(v, f, lab, int(k))
        path = os.path.join(d, f"{prefix}_{int(k):03d}.{fmt}")
        rgba = None if colors is None else np.repeat(colors.rgba[int(k)][None], len(sv), axis=0)
        # PLY carries the labels, OBJ and glTF the colours (each format's writer takes what it holds)
        save(path, Part(f"{prefix}_{int(k):03d}", sv, sf, colors=rgba, labels=lab[ids]), file_type=fmt,
             normals=False, per_format={"obj": {"comment": "PlantVR label mesh"}})
        out[int(k)] = path
    return out

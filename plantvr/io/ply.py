"""The one PLY writer: binary little-endian PLY through numpy structured arrays (spec 000_vine §2.7, item 24;
spec 000_treewand §3; issue 21; issue 30).

One ``tofile`` per element, so a 36 M-face mesh is written in about the time it takes to copy it. Every PLY
PlantVR writes (segmentations, label meshes, tree meshes, subdivision surfaces) is emitted by :func:`emit_ply`,
the ``ply`` row of the writer registry (:data:`plantvr.io.writers.WRITERS`); :func:`write_ply` is its
array-taking front door.
"""
from __future__ import annotations

import os

import numpy as np

from plantvr._fileio import atomic_write  # noqa: F401  (kept importable: failure tests patch it here)
from plantvr._validation import check_array, check_int

from .parts import Part, as_parts, merged, save_with

__all__ = ["emit_ply", "write_ply"]


def write_ply(path: str | os.PathLike, vertices: np.ndarray, faces: np.ndarray, *, colors: np.ndarray | None = None,
              labels: np.ndarray | None = None, normals: np.ndarray | None = None,
              double: bool = False, comment: str = "PlantVR ViNE segmentation", chunk: int = 1 << 20) -> None:
    """Write a binary little-endian PLY mesh with optional vertex colours, labels and normals (through the
    writer registry: :func:`plantvr.io.writers.save`, whatever the suffix).

    Parameters
    ----------
    path : str or path-like
    vertices : (V, 3) float ndarray
        Written as float32 (``double``: float64).
    faces : (F, 3) integer ndarray
        Vertex ids < V, written as int32 lists of 3.
    colors : (V, 3) or (V, 4) uint8 ndarray, optional
        Written as ``red green blue [alpha]`` uchar properties.
    labels : (V,) uint8 ndarray, optional
        Written as a ``label`` uchar property.
    normals : (V, 3) float ndarray, optional
        Written as ``nx ny nz`` float32.
    double : bool
        Write the positions as ``double`` (float64) instead of ``float``.
    comment : str
        The header's ``comment`` line (one line of printable ASCII).
    chunk : int
        Rows packed per write, in [1, 2**31]; bounds the extra memory.

    References
    ----------
    .. [1] Spec 000_vine §2.7 step 1: PLY "with colours stored at the vertices" [T §6.4].
    """
    save_with(emit_ply, path, Part("mesh", vertices, faces, normals=normals, colors=colors, labels=labels),
              double=double, comment=comment, chunk=chunk)


def emit_ply(res, name: str, parts, *, double: bool = False, comment: str = "PlantVR ViNE segmentation",
             chunk: int = 1 << 20, normals: bool = True, **_other) -> None:
    """The PLY emitter of the writer registry: ``parts`` as one binary PLY ``name`` in ``res``'s folder.

    Parts are concatenated; normals (unless ``normals`` is False), colours and labels are written when every
    part has them. Everything is checked before a byte is written. Options as :func:`write_ply`.
    """
    m = merged(as_parts(parts), "normals", "colors", "labels")
    vertices, faces, colors, labels = m["vertices"], m["faces"], m["colors"], m["labels"]
    normals = m["normals"] if normals else None
    v = check_array("vertices", vertices, shape=(None, 3), dtype=np.float64 if double else np.float32)
    chunk = check_int("chunk", chunk, 1, 2 ** 31)
    if not isinstance(comment, str) or not comment.isascii() or not comment.isprintable():
        raise ValueError(f"comment must be one line of printable ASCII, got {comment!r}")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu":
        raise ValueError(f"faces must be an integer array of shape (F, 3), got {f.dtype} {f.shape}")
    if f.size and (int(f.max()) >= len(v) or int(f.min()) < 0):
        raise ValueError(f"faces must index vertices in [0, {len(v) - 1}], got range [{f.min()}, {f.max()}]")
    if len(v) >= 2 ** 31:
        raise ValueError(f"vertices must number fewer than 2**31 for int32 PLY faces, got {len(v)}")
    ft, fname = ("<f8", "double") if double else ("<f4", "float")
    fields = [("x", ft), ("y", ft), ("z", ft)]
    props = [f"{fname} x", f"{fname} y", f"{fname} z"]
    if normals is not None:
        normals = check_array("normals", normals, shape=(len(v), 3), dtype=np.float32)
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
        props += ["float nx", "float ny", "float nz"]
    if colors is not None:
        colors = np.asarray(colors)
        if colors.dtype != np.uint8 or colors.shape not in ((len(v), 3), (len(v), 4)):
            raise ValueError(f"colors must be uint8 of shape ({len(v)}, 3) or ({len(v)}, 4), "
                             f"got {colors.dtype} {colors.shape}")
        names = ["red", "green", "blue", "alpha"][:colors.shape[1]]
        fields += [(n, "u1") for n in names]
        props += [f"uchar {n}" for n in names]
    if labels is not None:
        labels = np.asarray(labels)
        if labels.dtype not in (np.uint8, np.uint16) or labels.shape != (len(v),):
            raise ValueError(f"labels must be uint8 or uint16 of shape ({len(v)},), got {labels.dtype} {labels.shape}")
        wide = labels.dtype == np.uint16
        fields.append(("label", "<u2" if wide else "u1"))
        props.append("ushort label" if wide else "uchar label")
    vdt = np.dtype(fields)
    fdt = np.dtype([("n", "u1"), ("v", "<i4", (3,))])
    header = ["ply", "format binary_little_endian 1.0", f"comment {comment}",
              f"element vertex {len(v)}", *[f"property {p}" for p in props],
              f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    with res.open(name) as fh:                            # a failed write leaves the old file, no leftovers
        fh.write(("\n".join(header) + "\n").encode("ascii"))
        for a in range(0, len(v), chunk):                 # chunked: peak memory ~ chunk rows, not the mesh
            b = min(a + chunk, len(v))
            vert = np.empty(b - a, dtype=vdt)
            vert["x"], vert["y"], vert["z"] = v[a:b, 0], v[a:b, 1], v[a:b, 2]
            if normals is not None:
                vert["nx"], vert["ny"], vert["nz"] = normals[a:b, 0], normals[a:b, 1], normals[a:b, 2]
            if colors is not None:
                for i, n in enumerate(["red", "green", "blue", "alpha"][:colors.shape[1]]):
                    vert[n] = colors[a:b, i]
            if labels is not None:
                vert["label"] = labels[a:b]
            vert.tofile(fh)
        for a in range(0, len(f), chunk):
            b = min(a + chunk, len(f))
            face = np.empty(b - a, dtype=fdt)
            face["n"] = 3
            face["v"] = f[a:b]
            face.tofile(fh)

"""The one Wavefront OBJ writer: positions, UVs, normals, materials with their textures, and frame sequences
(spec 001_subdivision §2.7, C15; spec 000_treewand §3.3; spec 002_inflorescences §2.4, V8; issue 21).

Rows are formatted by one printf-style pass per chunk (no Python call per row). :func:`emit_obj` is the one OBJ
emitter, the ``obj`` row of the writer registry (:data:`plantvr.io.writers.WRITERS`); :func:`write_obj` and
:func:`write_obj_sequence` are its front doors. Every file goes through the registry's atomic resolver: a
textured OBJ's ``.mtl`` and PNGs and the ``.obj`` that names them (renamed last), or all the frames of a sequence,
replace the old files together.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from plantvr._fileio import make_folder
from plantvr._validation import MAX_COORD, check_array
from plantvr.subdivision._checks import check_mesh
from plantvr.subdivision.uv import vertex_normals

from .parts import AtomicResolver, Part, as_parts, check_image, merged, save_with

__all__ = ["MAX_OBJ_FRAMES", "emit_obj", "write_obj", "write_obj_sequence"]

#: Most frames of one OBJ sequence.
MAX_OBJ_FRAMES = 100_000


def _check_bool(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _fmt_rows(line: str, A: np.ndarray, chunk: int = 100_000) -> str:
    """``line % row`` for every row of ``A`` (one printf-style pass per chunk, no per-row Python call)."""
    A = A.tolist() if A.dtype.kind == "f" else A.astype(np.int64).tolist()
    out = []
    for i in range(0, len(A), chunk):
        rows = A[i:i + chunk]
        out.append((line * len(rows)) % tuple(x for r in rows for x in r))
    return "".join(out)


def _check_name(name: str, what: str = "name") -> str:
    if not isinstance(name, str) or not name or any(c.isspace() for c in name):
        raise ValueError(f"{what} must be a non-empty str without whitespace, got {name!r}")
    return name


def write_obj(path, vertices, faces, uv=None, *, normals=True, name: str = "yggdrasil", colors=None,
              materials=None, comment: str = "PlantVR Yggdrasil mesh") -> Path:
    """Wavefront OBJ with ``v``, ``vt`` (de-duplicated), ``vn`` and 1-based ``f v/vt/vn`` (§2.7, C15), through
    the writer registry (:func:`plantvr.io.writers.save`, whatever the suffix).

    Floats are written with 17 significant digits, so :func:`plantvr.subdivision.read_obj` gives back the
    exact arrays.

    Parameters
    ----------
    path : str or Path
        Output file.
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int ndarray
    uv : (F, 3, 2) or (V, 2) float64 ndarray, optional
        Per-corner UVs (seams, one vertex with several UVs, are kept) or per-vertex UVs.
    normals : bool or (V, 3) float ndarray
        Write per-vertex ``vn``: computed (:func:`plantvr.subdivision.vertex_normals`) when True, or given.
    name : str
        The ``g`` group name.
    colors : (V, 3|4) uint8 ndarray, optional
        Vertex colours, written after the position as ``r g b`` in [0, 1] (alpha is dropped).
    materials : list of (name, n_faces, image), optional
        Consecutive face ranges and their materials: writes ``<stem>.mtl`` (``map_Kd <stem>_<name>.png``) and
        the (H, W, 3|4) uint8 images beside the file, and a ``usemtl`` line before each range. The counts must
        add up to F.
    comment : str
        Text of the first (``#``) line, before the counts.

    Returns
    -------
    Path

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.2.5 ("the indexing starts at one").
    """
    if normals is None:
        raise ValueError("normals must be True, False or a (V, 3) array, got None")
    given = not isinstance(normals, (bool, np.bool_))
    _check_name(name)
    if not isinstance(comment, str):
        raise ValueError(f"comment must be a str of one line, got {comment!r}")
    part = Part(name, vertices, faces, normals=normals if given else None, uv=uv, colors=colors)
    return save_with(emit_obj, path, part, normals=True if given else bool(normals), group=name, comment=comment,
                     materials=materials)


def emit_obj(res, name: str, parts, *, normals=True, group: str | bool | None = None,
             comment: str | None = "PlantVR Yggdrasil mesh", float_format: str = "%.17g", materials=None,
             **_other) -> None:
    """The OBJ emitter of the writer registry: ``parts`` as one OBJ ``name`` in ``res``'s folder, with its
    ``.mtl`` and texture PNGs beside it when the parts have images.

    Parts are concatenated (UVs and normals when every part has them). A part with an image becomes a material
    (``usemtl <part name>`` over its faces; ``<stem>_<part name>.png``); vertex colours are written only when no
    part is textured.

    Parameters
    ----------
    res : plantvr.io.writers.AtomicResolver
    name : str
        The main file's name.
    parts : list of plantvr.io.writers.Part
    normals : bool
        Write ``vn``: the parts' normals, or computed ones (:func:`plantvr.subdivision.vertex_normals`).
    group : str, False or None
        The ``g`` line (None: the first part's name; False: none).
    comment : str or None
        Text of the first (``#``) line, before the counts (None: no header line).
    float_format : {"%.17g", "%r"}
        Coordinates as 17 significant digits or as Python's shortest round-trip form.
    materials : list of (name, n_faces, image), optional
        Face ranges and their textures instead of one material per textured part (:func:`write_obj`).
    """
    parts = as_parts(parts)
    m = merged(parts, "uv", "normals", "colors")
    V, F = check_mesh(m["vertices"], m["faces"])
    uv = m["uv"]
    if uv is not None:
        uv = np.asarray(uv)
        if uv.ndim == 2:
            uv = check_array("uv", uv, shape=(len(V), 2), max_abs=MAX_COORD)[F]
        uv = check_array("uv", uv, shape=(len(F), 3, 2), max_abs=MAX_COORD)
    _check_bool("normals", normals)
    if not normals:
        vn = None
    elif m["normals"] is None:
        vn = vertex_normals(V, F)
    else:
        vn = check_array("normals", m["normals"], shape=(len(V), 3), max_abs=MAX_COORD)
    group = parts[0].name if group is None else group
    if group is not False:
        _check_name(group)
    if float_format not in ("%.17g", "%r"):
        raise ValueError(f"float_format must be '%.17g' or '%r', got {float_format!r}")
    textured = materials is None and any(p.image is not None for p in parts)
    colors = None if textured else m["colors"]
    if colors is not None:
        colors = np.asarray(colors)
        if colors.dtype != np.uint8 or colors.shape not in ((len(V), 3), (len(V), 4)):
            raise ValueError(f"colors must be uint8 of shape ({len(V)}, 3) or ({len(V)}, 4), "
                             f"got {colors.dtype} {colors.shape}")
    if comment is not None and (not isinstance(comment, str) or "\n" in comment):
        raise ValueError(f"comment must be a str of one line, got {comment!r}")
    if textured:
        if not all(p.image is not None for p in parts):
            raise ValueError("image must be given for every part or for none")
        materials = [(p.name, len(np.asarray(p.faces)), p.image) for p in parts]
    stem = Path(name).stem
    mats = []
    if materials is not None:
        for k, item in enumerate(materials):
            if not isinstance(item, (tuple, list)) or len(item) != 3:
                raise ValueError(f"materials[{k}] must be (name, n_faces, image), got {item!r}")
            mname, n, img = item
            _check_name(mname, f"materials[{k}] name")
            mats.append((mname, int(n), check_image(f"materials[{k}] image", img)))
        if sum(n for _, n, _ in mats) != len(F) or any(n < 0 for _, n, _ in mats):
            raise ValueError(f"materials face counts must be >= 0 and add up to the {len(F)} faces")
    fmt3 = " ".join([float_format] * 3)
    head = "" if comment is None else f"# {comment}: {len(V)} vertices, {len(F)} faces\n"
    if mats:
        head += f"mtllib {stem}.mtl\n"
    if group is not False:
        head += f"g {group}\n"
    if colors is None:
        blocks = [_fmt_rows(f"v {fmt3}\n", V)]
    else:
        blocks = [_fmt_rows(f"v {fmt3} %.6g %.6g %.6g\n",
                            np.column_stack([V, colors[:, :3].astype(np.float64) / 255.0]))]
    idx = [F + 1]
    if uv is not None:
        tab, inv = np.unique(uv.reshape(-1, 2), axis=0, return_inverse=True)
        blocks.append(_fmt_rows(f"vt {float_format} {float_format}\n", tab))
        idx.append(inv.reshape(-1, 3) + 1)
    if vn is not None:
        blocks.append(_fmt_rows(f"vn {fmt3}\n", vn))
        idx.append(F + 1)
    corner = {1: "%d", 2: "%d/%d" if uv is not None else "%d//%d", 3: "%d/%d/%d"}[len(idx)]
    rows = np.stack(idx, axis=2).reshape(len(F), -1)
    fline = "f " + " ".join([corner] * 3) + "\n"
    if mats:
        start = 0
        for mname, n, _ in mats:
            blocks.append(f"usemtl {mname}\n" + _fmt_rows(fline, rows[start:start + n]))
            start += n
    else:
        blocks.append(_fmt_rows(fline, rows))
    if mats:                                  # material and textures, then the .obj that names them (renamed last)
        mtl = []
        for mname, _, img in mats:
            tex = f"{stem}_{mname}.png"
            res.write_png(tex, img)
            mtl.append(f"newmtl {mname}\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd {tex}\n"
                       + ("map_d " + tex + "\n" if img.shape[2] == 4 else ""))
        res.write(f"{stem}.mtl", "\n".join(mtl))
    with res.open(name, "w") as fh:           # a failed save leaves the old files and no temporary file
        fh.write(head)
        fh.writelines(blocks)


def write_obj_sequence(folder: str, faces: np.ndarray, frames: np.ndarray, *, prefix: str = "frame",
                       fixed: np.ndarray | None = None) -> list[str]:
    """Write frames as ``<prefix>_<k>.obj`` (same faces) and an optional ``weight.txt`` (spec 002 §2.4, V8).

    Coordinates are written as Python ``repr`` (shortest round-trip form). Everything is checked and formatted
    before a file is touched; each file is written atomically, and frames of an earlier, longer sequence with
    the same prefix are removed (they would be read back as part of it).

    Parameters
    ----------
    folder : str
        Created if missing (one level: its own folder must exist).
    faces : (F, 3) int64 ndarray
    frames : (K, V, 3) float64 ndarray
    prefix : str
        Letters, digits, ``_ - .``, not ending in a digit.
    fixed : (A,) int64 ndarray, optional
        Anchored vertex ids, one per line in ``weight.txt``.

    Returns
    -------
    list of str
        The frame paths, in order.
    """
    faces = check_array("faces", faces, shape=(None, 3), dtype=np.int64)
    frames = check_array("frames", frames, shape=(None, None, 3), max_abs=MAX_COORD)
    if not isinstance(prefix, str) or not re.fullmatch(r"[A-Za-z0-9_.-]*[A-Za-z_.-]|", prefix):
        raise ValueError(f"prefix must be letters, digits, '_', '-', '.' and not end in a digit, got {prefix!r}")
    if len(frames) > MAX_OBJ_FRAMES:
        raise ValueError(f"frames must hold at most {MAX_OBJ_FRAMES} frames, got {len(frames)}")
    n_v = frames.shape[1]
    if faces.size and (faces.min() < 0 or faces.max() >= n_v):
        raise ValueError(f"faces must index the {n_v} vertices of a frame, got range [{faces.min()}, {faces.max()}]")
    if fixed is not None:
        fixed = check_array("fixed", fixed, shape=(None,), dtype=np.int64)
        if fixed.size and (fixed.min() < 0 or fixed.max() >= n_v):
            raise ValueError(f"fixed must index the {n_v} vertices of a frame, got range "
                             f"[{fixed.min()}, {fixed.max()}]")
    folder = os.fspath(make_folder(folder))      # one level; its parent must exist (plantvr._fileio's rule)
    names = [f"{prefix}_{k:04d}.obj" for k in range(len(frames))]
    with AtomicResolver(folder) as res:          # every frame (and weight.txt) replaces the old files together
        for nm, X in zip(names, frames):
            emit_obj(res, nm, [Part(nm, X, faces)], normals=False, group=False, comment=None, float_format="%r")
        if fixed is not None:
            res.write("weight.txt", "".join(f"{int(i)}\n" for i in fixed))
    paths = [os.path.join(folder, nm) for nm in names]
    pat = re.compile(re.escape(prefix) + r"_?(\d+)\.obj$")
    keep = set(names)
    for f in os.listdir(folder):
        if pat.fullmatch(f) and f not in keep and os.path.isfile(os.path.join(folder, f)):
            os.unlink(os.path.join(folder, f))
    return paths

"""The one writer registry of PlantVR: format → writer, and the atomic resolver every file of a save goes through
(issue 30; issue 21 "one writer per format"; issue 20 "nothing loses work").

Modelled on trimesh's exporter table (``trimesh.exchange.export._mesh_exporters``): :data:`WRITERS` maps each
format to exactly one emitter, the only function in PlantVR that writes that format's bytes.

==========  ======================  ========================================================================
format      suffixes                emitter
==========  ======================  ========================================================================
``ply``     ``.ply``                :func:`plantvr.io.ply.emit_ply`: binary PLY, normals, colours, labels
``obj``     ``.obj``                :func:`plantvr.io.obj.emit_obj`: OBJ with ``.mtl`` and texture PNGs
``gltf``    ``.gltf``               :func:`plantvr.io.gltf.emit_gltf`: JSON and its ``<stem>.bin``
``glb``     ``.glb``                :func:`plantvr.io.gltf.emit_gltf`: one binary file
``usd``     ``.usd .usda .usdc``    :func:`plantvr.io.usd.emit_usd`: a tree stage, texture PNGs beside it
==========  ======================  ========================================================================

Every emitter takes the same description of what to write (:mod:`plantvr.io.parts`), a list of :class:`Part` (a named triangle mesh
with optional normals, UVs, per-vertex colours and labels, a texture image and material options), and writes
through an :class:`AtomicResolver`: the main file and its side files (a ``.gltf``'s ``.bin``, an OBJ's ``.mtl``
and PNGs, a USD layer's textures, the frames of a sequence) go to temporary files beside their targets through
:func:`plantvr._fileio.atomic_write` and replace the old files only once all of them are written, the main
file last; a save that fails half way leaves every old file and no temporary file. A missing folder is refused
by :func:`plantvr._fileio.check_target`'s rule before anything is written.

What a format cannot hold is left out by its writer: a textured part's vertex colours are written only by
PLY (which has no textures), labels only by PLY, images only by OBJ, glTF and USD.

:func:`writer_for` is the one suffix lookup (a ValueError names the allowed formats); :func:`save` writes a
description to a path. Scene graphs beyond a list of parts (instanced landscapes, skinned trees) are built as
a :class:`plantvr.io.gltf.Gltf` document and saved through the same glTF writer.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .gltf import emit_gltf
from .obj import emit_obj
from .parts import AtomicResolver, Part, format_of, save_with
from .ply import emit_ply
from .usd import USD_SUFFIXES, emit_usd

__all__ = ["FORMATS", "SUFFIXES", "WRITERS", "Part", "Writer", "save", "writer_for"]


# -- the table ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Writer:
    """One row of :data:`WRITERS`: a format, its suffixes and its one emitter.

    ``emit(resolver, name, parts, **options)`` writes the main file ``name`` (and its side files) into the
    resolver's folder (:mod:`plantvr.io.parts`, which the emitters import, so the io layer has no cycle).
    """

    format: str
    suffixes: tuple[str, ...]
    emit: Callable[..., None]
    options: Mapping[str, Any] = field(default_factory=dict)

    def write(self, resolver: AtomicResolver, name: str, parts, **options) -> None:
        self.emit(resolver, name, parts, **{**self.options, **options})


#: Format → :class:`Writer`: the one writer of each mesh format (as ``trimesh.exchange.export._mesh_exporters``).
WRITERS: dict[str, Writer] = {
    "ply": Writer("ply", (".ply",), emit_ply),
    "obj": Writer("obj", (".obj",), emit_obj),
    "gltf": Writer("gltf", (".gltf",), emit_gltf, {"binary": False}),
    "glb": Writer("glb", (".glb",), emit_gltf, {"binary": True}),
    "usd": Writer("usd", tuple(USD_SUFFIXES), emit_usd),
}

#: The formats, in table order.
FORMATS = tuple(WRITERS)

#: Output suffix → format.
SUFFIXES = {s: w.format for w in WRITERS.values() for s in w.suffixes}


def writer_for(path: str | os.PathLike | None = None, file_type: str | None = None, *,
               allowed: tuple[str, ...] | None = None) -> Writer:
    """The writer of ``file_type`` (a format or a suffix, any case), or of ``path``'s suffix.

    Parameters
    ----------
    path : path-like, optional
    file_type : str, optional
        ``"ply"``, ``"obj"``, ``"gltf"``, ``"glb"``, ``"usd"`` (or ``".usda"``, ``"usdc"``...).
    allowed : tuple of str, optional
        Formats the caller writes (default all).

    Raises
    ------
    ValueError
        Naming the suffix or file type and the allowed formats.
    """
    allowed = FORMATS if allowed is None else tuple(allowed)
    if file_type is not None:
        if not isinstance(file_type, str):
            raise ValueError(f"file_type must be a str, got {type(file_type).__name__}")
        key = file_type.lower()
        fmt = key if key in FORMATS else SUFFIXES.get(key if key.startswith(".") else f".{key}")
        what = f"file_type {file_type!r}"
    else:
        fmt = format_of(path, {s: f for s, f in SUFFIXES.items() if f in allowed})
    if fmt not in allowed:
        sfx = [s for s, f in SUFFIXES.items() if f in allowed]
        raise ValueError(f"{what} is not a format written here: file_type must be one of {list(allowed)} (or "
                         f"the path suffix one of {sfx})")
    return WRITERS[fmt]


def save(path: str | os.PathLike, parts, *, file_type: str | None = None, allowed: tuple[str, ...] | None = None,
         per_format: Mapping[str, Mapping[str, Any]] | None = None, **options) -> Path:
    """Write ``parts`` (see :class:`Part`, or a :class:`plantvr.io.gltf.Gltf` document for glTF) to ``path``
    with the writer of its format, every file of the save atomically.

    Parameters
    ----------
    path : path-like
        The main file; its folder must exist.
    parts : Part, list of Part, a mesh, or a Gltf
    file_type : str, optional
        Format (default: by ``path``'s suffix; see :func:`writer_for`).
    allowed : tuple of str, optional
        Formats the caller writes.
    per_format : dict, optional
        Options for one format only (``{"ply": {"comment": ...}}``), over ``options``.
    **options
        Writer options; each writer takes those it knows (``comment``, ``group``, ``normals``, ``double``,
        ``float_format``, ``generator``...) and ignores the others.

    Returns
    -------
    pathlib.Path
    """
    w = writer_for(path, file_type, allowed=allowed)
    opts = {**options, **dict((per_format or {}).get(w.format, {}))}
    return save_with(w.write, path, parts, **opts)

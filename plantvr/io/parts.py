"""What a save writes and where (issue 30): :class:`Part`, the common description every emitter of the writer
registry (:mod:`plantvr.io.writers`) takes, and :class:`AtomicResolver`, through which every file of one save
(the main file and its side files) is written atomically (issue 20 "nothing loses work"). The emitters
(:mod:`plantvr.io.ply`, :mod:`~plantvr.io.obj`, :mod:`~plantvr.io.gltf`, :mod:`~plantvr.io.usd`) import this
module; the registry imports them.
"""
from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np

from plantvr import _fileio
from plantvr._fileio import check_target

__all__ = ["AtomicResolver", "Part", "as_parts", "check_image", "format_of", "merged", "save_with"]


@dataclass(eq=False)
class Part:
    """One named triangle mesh of a save, with what a format may carry beside positions.

    Attributes
    ----------
    name : str
        glTF mesh/node and material name, OBJ material name, texture file suffix (``<stem>_<name>.png``).
    vertices : (V, 3) float ndarray
    faces : (F, 3) int ndarray
    normals : (V, 3) float ndarray, optional
    uv : (V, 2) or (F, 3, 2) float ndarray, optional
        OpenGL convention (origin at the image's bottom left; glTF's ``1 - v`` is written by its writer).
    colors : (V, 3|4) uint8 ndarray, optional
        Per-vertex colours.
    labels : (V,) uint8 or uint16 ndarray, optional
        Per-vertex labels (PLY ``label`` property).
    image : (H, W, 3|4) uint8 ndarray, optional
        Texture (base colour) image.
    material : dict
        Material options of formats with materials: ``name``, ``rgba``, ``metallic``, ``roughness``,
        ``double_sided``, ``alpha_mode``, ``alpha_cutoff``.
    """

    name: str
    vertices: Any
    faces: Any
    normals: Any = None
    uv: Any = None
    colors: Any = None
    labels: Any = None
    image: Any = None
    material: dict = field(default_factory=dict)


def as_parts(parts) -> list[Part]:
    """``parts`` as a list of :class:`Part`: one Part, a list of them, or anything with ``vertices`` and
    ``faces`` (a TriMesh, trimesh.Trimesh, ControlMesh; named ``"mesh"``)."""
    if isinstance(parts, Part) or hasattr(parts, "vertices"):
        parts = [parts]
    if not isinstance(parts, (list, tuple)) or not parts:
        raise ValueError(f"parts must be a non-empty list of Part, got {type(parts).__name__}")
    out = []
    for k, p in enumerate(parts):
        if isinstance(p, Part):
            out.append(p)
        elif hasattr(p, "vertices") and hasattr(p, "faces"):
            out.append(Part("mesh", p.vertices, p.faces))
        else:
            raise ValueError(f"parts[{k}] must be a Part or a mesh with vertices and faces, got {type(p).__name__}")
        if not isinstance(out[-1].name, str) or not out[-1].name:
            raise ValueError(f"parts[{k}] name must be a non-empty str, got {out[-1].name!r}")
    return out


# -- the atomic resolver ------------------------------------------------------------------------------------------
class AtomicResolver:
    """Where every file of one save is written: side files and the main file go to temporary files (through
    :func:`plantvr._fileio.atomic_write`) and replace their targets together when the ``with`` block ends
    cleanly, the main file last; on any exception every temporary file is removed and the old files stay.

    Parameters
    ----------
    folder : path-like
        The existing folder the files go into.
    main : str, optional
        The main file's name (renamed last).
    batch : int
        Most files held open at once; a save of more files (a long frame sequence) is committed in batches of
        this many, each batch atomic.

    Use :meth:`for_path` for a save to one path (checks the folder by :func:`plantvr._fileio.check_target`).
    """

    def __init__(self, folder: str | os.PathLike, *, main: str | None = None, batch: int = 256) -> None:
        self.folder = Path(folder)
        if not self.folder.is_dir():
            what = "is not a folder" if self.folder.exists() else "does not exist"
            raise ValueError(f"cannot write into {os.fspath(self.folder)!r}: the folder {what} (create it first; "
                             f"no writer creates folders)")
        self.main = main
        self.batch = batch
        self.names: list[str] = []
        self._pending = 0                                            # side files in the open batch
        self._stack: contextlib.ExitStack | None = None
        self._main_stack: contextlib.ExitStack | None = None

    @classmethod
    def for_path(cls, path: str | os.PathLike, *, name: str = "path") -> AtomicResolver:
        """A resolver for a save whose main file is ``path`` (its folder must exist: ``check_target``)."""
        folder = check_target(path, name=name)
        return cls(folder, main=Path(path).name)

    def __enter__(self) -> AtomicResolver:
        self._stack = contextlib.ExitStack()
        self._main_stack = contextlib.ExitStack()
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        stack, main = self._stack, self._main_stack
        self._stack = self._main_stack = None
        # side files are renamed first (their stack unwinds), the main file last; an exception unwinds both
        # without renaming anything still pending
        try:
            stack.__exit__(exc_type, exc, tb)
        except BaseException as e:
            main.__exit__(type(e), e, e.__traceback__)
            raise
        main.__exit__(exc_type, exc, tb)
        return False

    def _check_name(self, name: str) -> Path:
        if not isinstance(name, str) or not name or os.path.basename(name) != name or name in (".", ".."):
            raise ValueError(f"side file name must be a bare file name, got {name!r}")
        if name in self.names:
            raise ValueError(f"{name!r} is written twice in one save")
        return self.folder / name

    @contextlib.contextmanager
    def open(self, name: str, mode: str = "wb") -> Iterator[IO[Any]]:
        """A file object for ``name`` in the folder; its bytes replace the file when the save commits."""
        if self._stack is None:
            raise RuntimeError("AtomicResolver.open outside its with block")
        target = self._check_name(name)
        check_target(target)
        is_main = name == self.main
        stack = self._main_stack if is_main else self._stack
        if not is_main:
            if self._pending >= self.batch:
                self._stack.close()                                  # commit this batch (very long sequences)
                self._stack = contextlib.ExitStack()
                self._pending = 0
            stack = self._stack
            self._pending += 1
        fh = stack.enter_context(_fileio.atomic_write(target, mode))    # looked up here: tests patch it
        self.names.append(name)
        yield fh
        fh.flush()                    # on disk now: the commit only renames (a full disk fails before any rename)
        _fileio.os.fsync(fh.fileno())

    def write(self, name: str, data: bytes | str) -> Path:
        """Write ``data`` (bytes, or text as UTF-8) as ``name``; returns the target path."""
        with self.open(name, "w" if isinstance(data, str) else "wb") as fh:
            fh.write(data)
        return self.folder / name

    def write_png(self, name: str, image: np.ndarray) -> Path:
        """Write an (H, W, 3|4) uint8 image as PNG ``name`` (bytes as :func:`plantvr._fileio.write_png`)."""
        if not name.lower().endswith(".png"):
            raise ValueError(f"name must end in .png, got {name!r}")
        img = check_image("image", image)
        from PIL import Image

        with self.open(name) as fh:
            Image.fromarray(img).save(fh, format="PNG")
        return self.folder / name


def check_image(name: str, image) -> np.ndarray:
    """An (H, W, 3|4) uint8 image, or a ValueError naming ``name``."""
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
        raise ValueError(f"{name} must be (H, W, 3 or 4) uint8, got {img.dtype} {img.shape}")
    return img


def merged(parts: list[Part], *fields: str) -> dict[str, Any]:
    """The parts as one mesh: vertices, faces (offset), and each of ``fields`` concatenated when every part has
    it (None when none has; a ValueError when only some have). One part's arrays are passed as they are."""
    out: dict[str, Any] = {}
    if len(parts) == 1:
        p = parts[0]
        out["vertices"], out["faces"] = p.vertices, p.faces
        for f in fields:
            out[f] = getattr(p, f)
        return out
    vs = [np.asarray(p.vertices) for p in parts]
    fs = [np.asarray(p.faces) for p in parts]
    for k, (v, f) in enumerate(zip(vs, fs)):
        if v.ndim != 2 or f.ndim != 2 or f.dtype.kind not in "iu":
            raise ValueError(f"parts[{k}] must have (V, 3) vertices and (F, 3) integer faces, got {v.shape}, "
                             f"{f.dtype} {f.shape}")
    offs = np.cumsum([0] + [len(v) for v in vs])
    out["vertices"] = np.concatenate(vs)
    out["faces"] = np.concatenate([f + o for f, o in zip(fs, offs)])
    for f in fields:
        have = [getattr(p, f) is not None for p in parts]
        if any(have) and not all(have):
            raise ValueError(f"{f} must be given for every part or for none, got them for parts "
                             f"{[k for k, h in enumerate(have) if h]}")
        out[f] = np.concatenate([np.asarray(getattr(p, f)) for p in parts]) if all(have) else None
    return out


def save_with(emit: Callable[..., None], path: str | os.PathLike, parts, **options) -> Path:
    """Write ``parts`` to ``path`` with the emitter ``emit`` (``emit(resolver, name, parts, **options)``), every
    file of the save through one :class:`AtomicResolver` (the folder must exist)."""
    with AtomicResolver.for_path(path) as res:
        emit(res, Path(path).name, parts, **options)
    return Path(path)


def format_of(path: str | os.PathLike, suffixes: dict[str, str]) -> str:
    """The format of ``path``'s suffix (any case) in ``suffixes`` (suffix → format), or a ValueError naming the
    formats and suffixes allowed (the writer registry's lookup, :func:`plantvr.io.writers.writer_for`)."""
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a file path, got {type(path).__name__}")
    suffix = Path(path).suffix.lower()
    if suffix not in suffixes:
        raise ValueError(f"path suffix {suffix!r} is not a format written here: file_type must be one of "
                         f"{list(dict.fromkeys(suffixes.values()))} (or the path suffix one of {list(suffixes)})")
    return suffixes[suffix]

"""Session files of the ViNE labels document (spec 000_vine §2.7 persistence; checklist item 24; issues 21, 22).

:class:`SegmentationFile` is the file side of :class:`~plantvr.documents.labels.Segmentation` (its base class):
the state arrays (mesh or its fingerprint, labels, colour table, visibility, views, undo/redo history, voxel
grid), ``save`` and ``load`` of one ``.npz`` file, the door checks of every array read back (sizes before
inflating, then dtypes, shapes and ranges), ``restore`` (a logged command) and autosave. Format 1 holds uint8
labels, format 2 uint16 (issue 22). :func:`check_grid` validates the voxel grid a mesh was extracted on.
:mod:`plantvr.documents.labels_bundle` reuses the state arrays and their checks.
"""
from __future__ import annotations

import os
import zlib
from itertools import pairwise
from pathlib import Path
from typing import TypeVar

import numpy as np

from plantvr._fileio import MAX_READ_BYTES, atomic_write, npy_headers, read_npz
from plantvr._validation import MAX_COORD, check_array, check_point
from plantvr.document import check_digest, file_digest
from plantvr.history import ArrayEdit
from plantvr.vine._filecheck import check_elements
from plantvr.vine.colors import MAX_COLORS, NARROW_COLORS, ColorTable
from plantvr.vine.views import SavedView

__all__ = ["MAX_SESSION_BYTES", "MAX_VIEWS", "SegmentationFile", "check_grid"]

_FORMAT = 1
#: Session format of a segmentation with uint16 labels (labels and history values uint16, up to 65536 colours).
_FORMAT_WIDE = 2
_LABEL_DTYPES = {_FORMAT: np.dtype(np.uint8), _FORMAT_WIDE: np.dtype(np.uint16)}

#: Cap on the inflated size of a session file :meth:`SegmentationFile.load` / :meth:`~SegmentationFile.restore` reads
#: (bytes; a 36 M-face session with its mesh and a full undo history is about 1.5 GB).
MAX_SESSION_BYTES = MAX_READ_BYTES

#: Largest number of saved views a session file may hold.
MAX_VIEWS = 1_000_000

_STATE_NAMES = ("format", "vertices", "faces", "normals", "labels", "rgba", "visible", "views", "undo_idx",
                "undo_old", "undo_new", "undo_off", "redo_idx", "redo_old", "redo_new", "redo_off",
                "history_limits", "mesh", "grid")


def check_grid(spacing, origin) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """Validate a voxel grid: ``spacing`` 3 numbers in (0, 1e6], ``origin`` 3 finite numbers within ±1e6;
    returns them as tuples of float (the grid
    :meth:`~plantvr.documents.labels.Segmentation.from_volume` meshes on)."""
    sp = check_array("spacing", spacing, shape=(3,))
    if np.any(sp <= 0) or np.any(sp > 1e6):
        raise ValueError(f"spacing must be positive, each in (0, 1e6], got {sp.tolist()}")
    org = check_point("origin", origin, max_abs=MAX_COORD)
    return tuple(float(x) for x in sp), tuple(float(x) + 0.0 for x in org)


_S = TypeVar("_S", bound="SegmentationFile")


class SegmentationFile:
    """Save, load, restore and autosave of a :class:`~plantvr.documents.labels.Segmentation` (its base class).

    A mixin: it reads the segmentation's mesh, labels, colour table, views and history, and builds one with
    ``cls(...)``; :class:`~plantvr.documents.labels.Segmentation` puts it before
    :class:`~plantvr.document.Document`.
    """

    def mesh_fingerprint(self) -> int:
        """CRC32 of the vertex/face counts and a strided sample of both arrays (ties label files to a mesh)."""
        step_v = max(1, self.n_vertices // 4096)
        step_f = max(1, len(self.faces) // 4096)
        crc = zlib.crc32(np.array([self.n_vertices, len(self.faces)], np.int64).tobytes())
        crc = zlib.crc32(np.ascontiguousarray(self.vertices[::step_v]).tobytes(), crc)
        return zlib.crc32(np.ascontiguousarray(self.faces[::step_f]).tobytes(), crc)

    def _state_arrays(self, include_mesh: bool = True) -> dict:
        def pack(stack):
            edits = list(stack)
            offs = np.cumsum([0] + [len(e) for e in edits]).astype(np.int64)
            cat = (lambda xs, dt: np.concatenate(xs).astype(dt) if xs else np.zeros(0, dt))
            return (cat([e.indices for e in edits], np.int64), cat([e.old for e in edits], dt),
                    cat([e.new for e in edits], dt), offs)
        dt = self.labels.dtype
        fmt = _FORMAT_WIDE if self._wide else _FORMAT
        ui, uo, un, uoff = pack(self.history.undo_items)
        ri, ro, rn, roff = pack(self.history.redo_items)
        d = dict(format=np.array([fmt], np.int64), vertices=self.vertices, faces=self.faces,  # noqa: C408
                 labels=self.labels, rgba=self.colors.rgba, visible=self.colors.visible,
                 views=np.array([v.to_array() for v in self.views], np.float64).reshape(-1, 13),
                 undo_idx=ui, undo_old=uo, undo_new=un, undo_off=uoff,
                 redo_idx=ri, redo_old=ro, redo_new=rn, redo_off=roff,
                 history_limits=np.array([self.history.max_items, self.history.max_bytes], np.int64),
                 grid=np.array([*self.spacing, *self.origin], np.float64))
        if self.normals is not None:
            d["normals"] = self.normals
        if not include_mesh:
            for k in ("vertices", "faces", "normals"):
                d.pop(k, None)
            d["mesh"] = np.array([self.n_vertices, len(self.faces), self.mesh_fingerprint()], np.int64)
        return d

    def save(self, path: str | os.PathLike, *, compress: bool = False, include_mesh: bool = True) -> Path:
        """Save mesh, labels, colour table, visibility, views and undo/redo history to one ``.npz`` file.

        Written atomically (:func:`plantvr._fileio.atomic_write`: a temporary file beside ``path``, fsync,
        rename), so a save that fails half way leaves the previous file as it was and no temporary file.
        With ``include_mesh=False`` only the segmentation state is written (about 1 byte per vertex plus the
        history), tied to this mesh by a fingerprint; :meth:`restore` it onto a segmentation of the same mesh.
        Returns the path written.
        """
        if self._stroke is not None:
            raise ValueError("a stroke is open; end_stroke() before saving")
        arrays = self._state_arrays(include_mesh)
        with atomic_write(path) as fh:
            (np.savez_compressed if compress else np.savez)(fh, **arrays)
        return Path(os.fspath(path))

    @staticmethod
    def _element_bounds(n_vertices: int | None) -> dict[str, int]:
        """Largest element count of each state array for a mesh of ``n_vertices`` (None: not known yet)."""
        b = {"format": 1, "history_limits": 2, "mesh": 3, "grid": 6, "rgba": 4 * MAX_COLORS, "visible": MAX_COLORS,
             "views": 13 * MAX_VIEWS, "undo_off": 10_001, "redo_off": 10_001}
        if n_vertices is not None:
            b.update(labels=n_vertices, normals=3 * n_vertices)
            for side in ("undo", "redo"):                 # at most 10000 edits of at most V vertices each
                b.update({f"{side}_{k}": 10_000 * n_vertices for k in ("idx", "old", "new")})
        return b

    @staticmethod
    def _read_arrays(path, *, what: str, base: SegmentationFile | None = None) -> dict:
        """The state arrays of a session file, every size checked before it is inflated."""
        heads = npy_headers(path, what=what, max_members=64)
        n = base.n_vertices if base is not None and "vertices" not in heads else None
        if n is not None and "labels" in heads and heads["labels"][0] != (n,):
            raise ValueError(f"{what} {os.fspath(path)!r} belongs to another mesh: it labels "
                             f"{list(heads['labels'][0])} vertices, this mesh has {n}")
        if "vertices" in heads:
            shape, _ = heads["vertices"]
            n = int(shape[0]) if len(shape) == 2 else None
        check_elements(heads, SegmentationFile._element_bounds(n), what=what, path=path)
        return read_npz(path, what=what, max_bytes=MAX_SESSION_BYTES, allowed=_STATE_NAMES)

    @staticmethod
    def _read_state(path, base: SegmentationFile | None = None) -> dict:
        if not os.path.isfile(path):
            raise ValueError(f"segmentation file {os.fspath(path)!r} does not exist")
        d = SegmentationFile._read_arrays(path, what="segmentation file", base=base)
        return SegmentationFile._check_state(d, path, base)

    @staticmethod
    def _check_state(d: dict, path, base: SegmentationFile | None = None) -> dict:
        """Validate a state dict (from a session file or a bundle); raises ``ValueError`` naming ``path``."""
        if "vertices" not in d and "mesh" in d:
            if base is None:
                raise ValueError(f"segmentation file {os.fspath(path)!r} holds no mesh (labels only); "
                                 "use seg.restore(path) on a segmentation of the same mesh")
            want = [base.n_vertices, len(base.faces), base.mesh_fingerprint()]
            if d["mesh"].tolist() != want:
                raise ValueError(f"segmentation file {os.fspath(path)!r} belongs to another mesh "
                                 f"(vertices, faces, fingerprint) {d['mesh'].tolist()} != {want}")
            d["vertices"], d["faces"] = base.vertices, base.faces
            if base.normals is not None:
                d["normals"] = base.normals
        need = ("format", "vertices", "faces", "labels", "rgba", "visible", "views", "undo_idx", "undo_old",
                "undo_new", "undo_off", "redo_idx", "redo_old", "redo_new", "redo_off", "history_limits")
        missing = [k for k in need if k not in d]
        where = f"segmentation file {os.fspath(path)!r}"
        if missing:
            raise ValueError(f"{where} is missing arrays {missing}")
        fmt = d["format"]
        if fmt.dtype.kind not in "iu" or fmt.shape != (1,) or int(fmt[0]) not in _LABEL_DTYPES:
            raise ValueError(f"{where}: format must be [{_FORMAT}] or [{_FORMAT_WIDE}], got {fmt.tolist()}")
        ldt = _LABEL_DTYPES[int(fmt[0])]
        n_max = NARROW_COLORS if ldt == np.uint8 else MAX_COLORS
        v, lab, f = d["vertices"], d["labels"], d["faces"]
        if v.dtype != np.float32 or v.ndim != 2 or v.shape[1] != 3 or len(v) < 1:
            raise ValueError(f"{where}: vertices must be float32 (V, 3) with V >= 1, got {v.dtype} {v.shape}")
        if not np.all(np.isfinite(v)) or float(np.abs(v).max()) > MAX_COORD:
            raise ValueError(f"{where}: vertices must be finite and within +-{MAX_COORD:g}")
        if f.dtype.kind not in "iu" or f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"{where}: faces must be integer (F, 3), got {f.dtype} {f.shape}")
        if f.size and (int(f.min()) < 0 or int(f.max()) >= len(v)):
            raise ValueError(f"{where}: faces index vertices out of range [0, {len(v) - 1}]")
        nrm = d.get("normals")
        if nrm is not None and (nrm.dtype != np.float32 or nrm.shape != v.shape or not np.all(np.isfinite(nrm))):
            raise ValueError(f"{where}: normals must be finite float32 {v.shape}, got {nrm.dtype} {nrm.shape}")
        if lab.dtype != ldt or lab.shape != (len(v),):
            raise ValueError(f"{where}: labels must be {ldt.name} ({len(v)},) in format {int(fmt[0])}, got "
                             f"{lab.dtype} {lab.shape}")
        rgba, vis = d["rgba"], d["visible"]
        if rgba.dtype != np.uint8 or rgba.ndim != 2 or rgba.shape[1] != 4 or not 1 <= len(rgba) <= n_max \
                or vis.shape != (len(rgba),) or vis.dtype.kind not in "bui":
            raise ValueError(f"{where}: colour table must be uint8 (N, 4), N in [1, {n_max}], with N visibility "
                             "flags")
        if lab.size and int(lab.max()) >= len(rgba):
            raise ValueError(f"{where}: labels must be < {len(rgba)} (colour table size), got max {lab.max()}")
        lim = d["history_limits"]
        if lim.dtype.kind not in "iu" or lim.shape != (2,) or not 1 <= int(lim[0]) <= 10000 \
                or not 0 <= int(lim[1]) <= 2 ** 62:
            raise ValueError(f"{where}: history_limits must be [max_items in [1, 10000], max_bytes in "
                             f"[0, 2**62]], got {lim.tolist()}")
        for side in ("undo", "redo"):
            idx, old, new, off = (d[f"{side}_{k}"] for k in ("idx", "old", "new", "off"))
            if idx.dtype.kind not in "iu" or off.dtype.kind not in "iu" or old.dtype != ldt \
                    or new.dtype != ldt or idx.ndim != 1 or old.ndim != 1 or new.ndim != 1:
                raise ValueError(f"{where}: {side} history arrays have the wrong dtypes or shapes")
            if not (len(idx) == len(old) == len(new)) or off.ndim != 1 or off.size < 1 or off[0] != 0 \
                    or off[-1] != len(idx) or np.any(np.diff(off) < 0) or off.size - 1 > 10000:
                raise ValueError(f"{where}: {side} history arrays are inconsistent")
            if idx.size and (idx.min() < 0 or idx.max() >= len(v)):
                raise ValueError(f"{where}: {side} history indexes vertices out of range")
            if (old.size and old.max() >= len(rgba)) or (new.size and new.max() >= len(rgba)):
                raise ValueError(f"{where}: {side} history labels exceed the colour table")
        grid = d.get("grid")  # voxel spacing and origin of the mesh (absent in files saved before they were kept)
        if grid is not None:
            if grid.dtype != np.float64 or grid.shape != (6,):
                raise ValueError(f"{where}: grid must be float64 (6,) [spacing, origin], got {grid.dtype} "
                                 f"{grid.shape}")
            try:
                check_grid(grid[:3], grid[3:])
            except ValueError as exc:
                raise ValueError(f"{where}: {exc}") from None
        views = d["views"]
        if views.dtype != np.float64 or views.ndim != 2 or views.shape[1] != 13:
            raise ValueError(f"{where}: views must be float64 (N, 13), got {views.dtype} {views.shape}")
        for i, a in enumerate(views):
            try:
                SavedView.from_array(a)
            except ValueError as exc:
                raise ValueError(f"{where}: view {i} is invalid ({exc})") from None
        return d

    @classmethod
    def load(cls: type[_S], path: str | os.PathLike, *, index: str = "grid") -> _S:
        """Load a session written by :meth:`save`; a corrupt file raises ``ValueError``."""
        d = cls._read_state(path)
        return cls._from_state(d, index=index)

    @classmethod
    def _from_state(cls: type[_S], d: dict, *, index: str = "grid") -> _S:
        table = ColorTable(d["rgba"], wide=d["labels"].dtype == np.uint16)
        table.visible = d["visible"].astype(bool)
        lim = d["history_limits"]
        seg = cls(d["vertices"], d["faces"], labels=d["labels"], colors=table, normals=d.get("normals"),
                  index=index, max_undo=int(lim[0]), max_undo_bytes=int(lim[1]))
        views = [SavedView.from_array(a) for a in d["views"]]
        itype = np.int32 if len(d["vertices"]) < 2 ** 31 else np.int64
        stacks = {}
        for side in ("undo", "redo"):
            idx, old, new, off = (d[f"{side}_{k}"] for k in ("idx", "old", "new", "off"))
            stacks[side] = [ArrayEdit(idx[a:b].astype(itype), old[a:b].copy(), new[a:b].copy())
                            for a, b in pairwise(off)]
        seg.history.restore(stacks["undo"], stacks["redo"])
        seg.views = views
        if "grid" in d:
            seg.spacing, seg.origin = check_grid(d["grid"][:3], d["grid"][3:])
        return seg

    @staticmethod
    def _check_restore(path, digest: str | None = None) -> tuple[Path, str]:
        """Door check of :meth:`restore`: the absolute path and the file's digest now (equal to a logged one)."""
        if not isinstance(path, (str, os.PathLike)):
            raise ValueError(f"path must be a str or path-like, got {type(path).__name__}")  # noqa: TRY004
        path = Path(os.fspath(path)).absolute()
        if not path.is_file():
            raise ValueError(f"segmentation file {str(path)!r} does not exist")
        now = file_digest(path)
        check_digest(f"segmentation file {str(path)!r}", digest, now)
        return path, now

    def restore(self, path: str | os.PathLike, digest: str | None = None) -> None:
        """Replace this session's state with a saved file's (full or labels-only, its undo history with it); on
        any error nothing changes. Logged as ``restore(path, digest)``: the absolute path and the SHA-256 of the
        bytes loaded; a replay is refused at its door when the file's bytes differ (see :func:`file_digest`)."""
        path, digest = self._check_restore(path, digest)
        d = self._read_state(path, base=self)
        if file_digest(path) != digest:
            raise ValueError(f"cannot load {str(path)!r}: the file changed while it was read")
        same_mesh = d["vertices"] is self.vertices
        other = self._from_state(d, index=self.index_kind)
        with self._lock:
            self._adopt(other, same_mesh=same_mesh)
            self.log.record("restore", path=str(path), digest=digest)

    def enable_autosave(self, path: str | os.PathLike | None) -> Path | None:
        """After every completed operation, save the labels-only state to ``path`` (None turns it off).

        Saves at once (unless a stroke is open). A crash then loses at most the operation in progress; reload
        with :meth:`restore`. A failed autosave raises from the command that triggered it.
        """
        if path is None:
            return super().enable_autosave(None)
        self._autosave_path = Path(os.fspath(path))
        self._autosave()
        return self._autosave_path

    def _autosave(self) -> None:
        # the labels-only state (about 1 byte per vertex plus the history), written once no stroke is open
        if self._autosave_path is None or self._stroke is not None:
            return
        if self._hold:
            self._dirty = True
            return
        self.save(self._autosave_path, include_mesh=False)

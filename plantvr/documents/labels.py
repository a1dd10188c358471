"""The ViNE labels document: mesh + per-vertex labels + colour table + history + views (spec 000_vine §1.6,
§2.4–2.7; checklist items 13–17, 24, 26; issue 21).

``Segmentation.paint(center, radius, label)`` is the one command every input (code, mouse, headset replay)
ends in. It validates everything before writing, records only changed entries for undo (one
:class:`~plantvr.history.ArrayEdit` per operation in the document's :class:`~plantvr.history.History`), logs
itself in the document's :class:`~plantvr.commandlog.CommandLog` and publishes a
:class:`~plantvr.document.Change` with the changed vertex ids, so views update colours in place::

    seg.observe(lambda ch: print(ch["new"].kind, ch["new"].ids), names="change")

Labels are uint8 (1 byte per vertex) while the colour table has at most 256 entries and uint16 once it needs
more (``Segmentation(..., labels=<uint16 array>)``, a wide :class:`~plantvr.vine.colors.ColorTable`, or
``add_color`` past 256 entries, which widens the labels once); a uint8 session behaves and saves exactly as
before, a uint16 one saves as format 2 (issue 22).

Change kinds: ``"labels"`` (ids: the vertices whose label changed; an empty array when a stroke ends),
``"colors"``, ``"visibility"``, ``"views"`` and ``"all"`` (ids None).

This module holds the document and its commands; its region commands over the mesh graph (fill, split, merge) and
per-label statistics are :class:`~plantvr.documents.labels_regions.LabelRegions`, its session file (save, load,
restore, autosave and the door checks of the arrays read back) is
:class:`~plantvr.documents.labels_file.SegmentationFile`: its two base classes.
"""
from __future__ import annotations

import contextlib

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_choice, check_point, check_range
from plantvr.commandlog import CommandLog
from plantvr.document import Document
from plantvr.documents.labels_file import SegmentationFile, check_grid
from plantvr.documents.labels_regions import LabelRegions
from plantvr.history import ArrayEdit, Group
from plantvr.types import LabelledSurface
from plantvr.vine.colors import MAX_COLORS, ColorTable
from plantvr.grid import bounds
from plantvr.vine.index import GridIndex, KDTreeIndex
from plantvr.vine.stamps import merge_stamps
from plantvr.vine.views import SavedView

__all__ = ["Segmentation", "check_grid"]

#: Attributes of the mesh (and what is built from it once, and the voxel grid it was meshed on), shared by a
#: replay's scratch copy.
_MESH_ATTRS = ("vertices", "faces", "normals", "index_kind", "max_radius", "_index", "_graph", "spacing", "origin")
#: Attributes of the session state a restore, a bundle or a replay takes over.
_SESSION_ATTRS = ("labels", "colors", "views", "_stroke")   # and the history (Document.take_history)


class Segmentation(LabelRegions, SegmentationFile, Document):
    """Per-vertex colour-label segmentation of a triangle mesh (the ViNE document, kind ``"vine"``).

    Parameters
    ----------
    vertices : (V, 3) float32 ndarray
        Vertex positions (model space). Kept as float32; never reordered.
    faces : (F, 3) integer ndarray
        Triangles, ids < V.
    labels : (V,) uint8 or uint16 ndarray, optional
        Initial labels (default all 0 = unpainted); uint16 labels make a wide (uint16) segmentation.
    colors : ColorTable, optional
        Default: :data:`~plantvr.vine.colors.DEFAULT_PALETTE`, extended with distinct colours to cover the
        largest label given. A table of more than 256 entries (or a wide one) makes the labels uint16.
    normals : (V, 3) float32 ndarray, optional
    index : {"grid", "kdtree"}
        Brush spatial index (``grid`` is the measured-faster default; ``kdtree`` is the scipy oracle).
    max_undo : int
        Undo depth (thesis: 20).
    max_undo_bytes : int
        Byte budget for undo + redo records.

    Attributes
    ----------
    labels : (V,) uint8 or uint16 ndarray
        One byte per vertex into ``colors`` (spec §2.4.2); two once the table holds more than 256 entries.
    spacing, origin : tuple of 3 float
        The voxel grid the mesh was extracted on (:meth:`from_volume`): voxel size and the position of voxel 0
        along each volume axis, in the volume's physical units, so ``vertex = index * spacing + origin``;
        ``(1, 1, 1)`` and ``(0, 0, 0)`` (voxel units) for a mesh given directly. Re-meshing the volume (the
        review app's iso slider, a bundle without its mesh) uses them, so the mesh stays in the same units.
    version : int
        Bumped by every change of labels, colours, visibility or views.
    log : CommandLog
        Every command applied, replayable by name (:meth:`replay`).
    """

    KIND = "vine"
    COMMANDS = ("paint", "begin_stroke", "end_stroke", "abort_stroke", "undo", "redo", "set_visible",
                "set_color", "add_color", "fill", "split_label", "merge_labels", "add_view", "restore")
    EVENTS = ("labels", "colors", "visibility", "views")

    def __init__(self, vertices, faces, *, labels=None, colors: ColorTable | None = None, normals=None,
                 index: str = "grid", max_undo: int = 20, max_undo_bytes: int = 512 * 2 ** 20):
        v = check_array("vertices", vertices, shape=(None, 3), dtype=np.float32, min_rows=1, max_abs=MAX_COORD)
        f = np.asarray(faces)
        if f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu":
            raise ValueError(f"faces must be an integer array of shape (F, 3), got {f.dtype} {f.shape}")
        if f.size and (int(f.min()) < 0 or int(f.max()) >= len(v)):
            raise ValueError(f"faces must index vertices in [0, {len(v) - 1}], got range [{f.min()}, {f.max()}]")
        if colors is not None and not isinstance(colors, ColorTable):
            raise ValueError(f"colors must be a ColorTable, got {type(colors).__name__}")
        if labels is None:
            colors = ColorTable() if colors is None else colors
            lab = np.zeros(len(v), colors.label_dtype)
        else:
            lab = np.asarray(labels)
            if lab.dtype not in (np.uint8, np.uint16) or lab.shape != (len(v),):
                raise ValueError(f"labels must be uint8 or uint16 of shape ({len(v)},), got {lab.dtype} {lab.shape}")
            top = int(lab.max()) if lab.size else 0
            if colors is None:
                colors = ColorTable.with_size(max(top + 1, len(ColorTable())))
            if top >= len(colors):
                raise ValueError(f"labels must be < {len(colors)} (colour table size), got max {lab.max()}")
        wide = lab.dtype == np.uint16 or colors.wide
        lab = lab.astype(np.uint16 if wide else np.uint8)   # a copy; uint8 labels widen for a wide table
        if normals is not None:
            normals = check_array("normals", normals, shape=(len(v), 3), dtype=np.float32)
        if not isinstance(index, str):
            raise ValueError(f"index must be one of ['grid', 'kdtree'], got {index!r:.80}")
        index = check_choice("index", index, ("grid", "kdtree"))
        super().__init__(max_undo=max_undo, max_undo_bytes=max_undo_bytes)
        if wide:
            colors.widen()
        self.vertices = v
        self.faces = np.ascontiguousarray(f.astype(np.uint32, copy=False))
        self.normals = normals
        self.labels = lab
        self.colors = colors
        self.views: list[SavedView] = []
        self.index_kind = index
        self._index = None
        self._stroke: list[ArrayEdit] | None = None   # the open stroke's stamps (also staged in the history)
        self._preserve: bool | tuple[int, ...] = False  # default brush mode of paint(); see paint()
        self._graph = None
        self.spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)
        self.origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
        lo, hi = bounds(v)
        ext = hi - lo
        self.max_radius = float(np.linalg.norm(ext)) + 1.0

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_volume(cls, volume: np.ndarray, level: float, *, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0),
                    downsample: bool = False, slab: int = 64, **kwargs) -> Segmentation:
        """Mesh a uint8/16/32, int8/16/32 or float32/64 volume at ``level`` (in the data's units; slab-wise
        marching cubes) and start a segmentation whose vertices are in the volume's physical units.

        Parameters
        ----------
        volume : (X, Y, Z) ndarray
            The scan, axes in array order (as :func:`plantvr.io.volume.read_volume` returns them).
        level : float
            Iso-value in the data's own units.
        spacing : (3,) float
            Voxel size along each array axis (e.g. ``Volume.spacing``), each in (0, 1e6].
        origin : (3,) float
            Position of voxel 0 along each array axis (``Volume.origin``), same units, within ±1e6.
        downsample : bool
            2x block-mean downsampling first; the grid then has twice the spacing and its voxel 0 (the mean of
            voxels 0 and 1) lies half a voxel further, so the surface stays in the same place.
        slab : int
            Meshing slab (planes along axis 0).
        **kwargs
            As for :class:`Segmentation`.

        Returns
        -------
        Segmentation
            Vertices ``index * spacing + origin`` (float32); :attr:`spacing` and :attr:`origin` hold the grid
            that was meshed (after downsampling), so brush radii and distances are in the same units.
        """
        from plantvr.adapters.vtk_isosurface import extract_isosurface
        from plantvr.vine.volume import downsample2
        sp, org = check_grid(spacing, origin)
        if not isinstance(downsample, (bool, np.bool_)):
            raise ValueError(f"downsample must be True or False, got {downsample!r}")  # noqa: TRY004
        if downsample:
            volume = downsample2(volume)
            sp, org = tuple(2.0 * x for x in sp), tuple(o + 0.5 * x for o, x in zip(org, sp))
        s = extract_isosurface(volume, level, slab=slab, spacing=sp)
        v = s.vertices
        if org != (0.0, 0.0, 0.0):
            v += np.asarray(org, np.float32)                 # in place: the surface's own float32 array
        seg = cls(v, s.faces, normals=s.normals, **kwargs)
        seg.spacing, seg.origin = sp, org
        return seg

    @property
    def index(self):
        """The brush spatial index, built on first use (once)."""
        if self._index is None:
            self._index = GridIndex(self.vertices) if self.index_kind == "grid" else KDTreeIndex(self.vertices)
        return self._index

    @property
    def graph(self):
        """Vertex adjacency (CSR, :class:`plantvr.vine.fill.MeshGraph`; edge lengths on first use), built once."""
        if self._graph is None:
            from plantvr.vine.fill import mesh_graph
            self._graph = mesh_graph(self.vertices, self.faces)
        return self._graph

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return int(self.vertices.shape[0])

    # ------------------------------------------------------------------ document
    def state_bytes(self) -> bytes:
        """Labels, colour table, visibility and saved views as bytes (replay and undo tests compare them)."""
        views = np.array([v.to_array() for v in self.views], np.float64).reshape(-1, 13)
        parts = (np.array([self.n_vertices, len(self.colors), len(views)], np.int64), self.labels,
                 self.colors.rgba, self.colors.visible.astype(np.uint8), views)
        return b"".join(np.ascontiguousarray(a).tobytes() for a in parts)

    def get_state(self) -> dict:
        """Copies of the labels, the colour table and the saved views (what a failed block or replay restores)."""
        return {"labels": self.labels.copy(), "colors": self.colors.copy(), "views": list(self.views)}

    def set_state(self, state: dict) -> None:
        with self._lock:
            self.labels = state["labels"].copy()
            self.colors = state["colors"].copy()
            self.views = list(state["views"])

    def transient_state(self):
        """The open stroke's stamps (its stage is in the history, which a rollback restores with it)."""
        return None if self._stroke is None else list(self._stroke)

    def set_transient_state(self, state) -> None:
        self._stroke = None if state is None else list(state)

    def scene(self) -> dict:
        """The surface a view draws: visible triangles with per-vertex colours through the colour table."""
        return {"surface": LabelledSurface(self)}

    def before_undo(self) -> None:
        if self._stroke is not None:
            self.end_stroke()                       # spec §2.5 [INFERRED]: finish the operation first

    def fold_atoms(self, atoms: tuple) -> ArrayEdit | Group | None:
        """A history block's label edits as one :class:`~plantvr.history.ArrayEdit` (one record per changed
        vertex, as a stroke's), so the history stays a list of edits a session file holds."""
        if not all(isinstance(a, ArrayEdit) and a.target == "labels" for a in atoms):
            return Group(atoms)
        return self._merge([a.indices for a in atoms], [a.old for a in atoms])   # None: no net change

    # ------------------------------------------------------------------ painting
    def _check_paint(self, center, radius, label, preserve=None):
        c = check_point("center", center)
        r = check_range("radius", radius, 0.0, self.max_radius)
        label = self._check_target("label", label)
        return c, r, label, self.check_preserve(preserve)

    def _check_target(self, name: str, label) -> int:
        label = self.colors.check_label(name, label)
        if not self.colors.visible[label]:
            raise ValueError(f"{name} {label} is hidden; show it before painting with it")
        return label

    @property
    def preserve(self) -> bool | tuple[int, ...]:
        """Default preserve-labels brush mode of :meth:`paint` (False, True or a tuple of paintable labels)."""
        return self._preserve

    @preserve.setter
    def preserve(self, value) -> None:
        self._preserve = self.check_preserve(False if value is None else value)

    def check_preserve(self, preserve) -> bool | tuple[int, ...]:
        """Validate a preserve-labels mode: False, True (only unlabelled 0 is painted) or labels that may be
        painted over (a tuple of ints, each in [0, len(colors) - 1])."""
        if preserve is None:
            preserve = self.preserve
        if isinstance(preserve, (bool, np.bool_)):
            return bool(preserve)
        if isinstance(preserve, (int, np.integer)):
            preserve = (preserve,)
        try:
            items = tuple(preserve)
        except TypeError:
            raise ValueError(f"preserve must be False, True or a collection of labels in [0, {len(self.colors) - 1}]"
                             f", got {preserve!r}") from None
        return tuple(sorted({self.colors.check_label("preserve", x) for x in items}))

    @property
    def _wide(self) -> bool:
        """True when the labels are uint16 (the colour table may hold up to 65536 entries)."""
        return self.labels.dtype == np.uint16

    def _widen(self) -> None:
        """Turn uint8 labels into uint16 ones, once (same values; the history's records stay valid)."""
        if self._wide:
            return
        self.labels = self.labels.astype(np.uint16)
        self.colors.widen()

    def _merge(self, idx_parts: list, old_parts: list) -> ArrayEdit | None:
        return merge_stamps(idx_parts, old_parts, self.labels)

    def _paint_lut(self, preserve) -> np.ndarray:
        lut = self.colors.paintable_lut()
        if preserve is True:
            allowed = np.zeros(len(lut), bool)
            allowed[0] = True
            lut &= allowed
        elif preserve is not False:
            allowed = np.zeros(len(lut), bool)
            allowed[list(preserve)] = True
            lut &= allowed
        return lut

    def paint(self, center, radius: float, label: int, preserve: bool | tuple[int, ...] | None = None) -> int:
        """Paint every visible vertex within ``radius`` of ``center`` (model space) with ``label``.

        Outside a stroke this is one undoable operation; inside ``with seg.stroke():`` it is one stamp of
        that operation. Vertices whose current colour is hidden are never changed (spec §2.6). With
        ``preserve`` (the "preserve labels" brush mode) finished labels are never overwritten: ``True``
        paints only unlabelled vertices (label 0), a collection paints only vertices whose label is in it;
        ``None`` uses :attr:`preserve` (default ``False``).

        Parameters
        ----------
        center : (3,) float
            Brush centre in model coordinates.
        radius : float
            Brush radius in model units, in [0, max_radius].
        label : int
            Colour-table index, visible, in [0, len(colors) - 1].

        Returns
        -------
        int
            Number of vertices whose label changed.

        References
        ----------
        .. [1] Thesis Eqs. 5.15–5.16, §5.4.3 (brush), §5.5 (undo), §5.6 (hidden colours unpaintable).
        """
        c, r, label, pres = self._check_paint(center, radius, label, preserve)
        with self._lock:
            self.log.record("paint", center=[float(x) for x in c], radius=r, label=label,
                            **({} if pres is False else {"preserve": pres if pres is True else list(pres)}))
            idx, old = self.index.paint(c, r, self.labels, self._paint_lut(pres), label)
            if self._stroke is not None:
                if idx.size:
                    stamp = ArrayEdit(idx, old, np.full(idx.size, label, self.labels.dtype))
                    self.history.push(stamp)                  # into the stroke's stage
                    self._stroke.append(stamp)
            else:
                edit = self._merge([idx], [old])
                if edit is not None:
                    self.history.push(edit)
        if idx.size:
            self.changed("labels", idx, command="paint")
        return int(idx.size)

    def paint_stroke(self, centers, radius: float, label: int,
                     preserve: bool | tuple[int, ...] | None = None) -> int:
        """Paint a sequence of stamps as one undoable operation; returns the number of vertices changed."""
        cs = check_array("centers", centers, shape=(None, 3), min_rows=1)
        for c in cs:
            self._check_paint(c, radius, label)
        pres = self.check_preserve(preserve)
        self.begin_stroke()
        try:
            for c in cs:
                self.paint(c, radius, label, pres)
        except BaseException:
            self.abort_stroke()
            raise
        edit = self.end_stroke()
        return 0 if edit is None else len(edit)

    @contextlib.contextmanager
    def stroke(self):
        """Group the ``paint`` calls inside the block into one undo item (a trigger press to release)."""
        self.begin_stroke()
        try:
            yield self
        except BaseException:
            self.abort_stroke()
            raise
        else:
            self.end_stroke()

    def _check_begin_stroke(self) -> None:
        if self._stroke is not None:
            raise ValueError("a stroke is already open; end_stroke() it first")

    def begin_stroke(self) -> None:
        """Start a painting operation (redo is cleared when it ends with a change)."""
        self._check_begin_stroke()
        with self._lock:
            self.log.record("begin_stroke")
            self.history.stage()
            self._stroke = []

    def _check_end_stroke(self) -> None:
        if self._stroke is None:
            raise ValueError("no stroke is open; call begin_stroke() first")

    def end_stroke(self) -> ArrayEdit | None:
        """Commit the open stroke as one undo item; returns it (None if nothing changed).

        The stage's stamps are folded into one record per changed vertex (:func:`~plantvr.vine.stamps.
        merge_stamps`): the stage is rolled back and the fold applied, which leaves the same labels.
        """
        self._check_end_stroke()
        with self._lock:
            stamps, self._stroke = self._stroke, None
            self.log.record("end_stroke")
            edit = self._merge([s.indices for s in stamps], [s.old for s in stamps])
            self.history.abort(self)
            if edit is not None:
                edit.redo(self)
                self.history.push(edit)
            elif stamps:
                self.history.clear_redo()             # it wrote labels (and wrote them back): redo is stale
        if stamps:
            self.changed("labels", np.zeros(0, np.int64), command="end_stroke")
        return edit

    def _check_abort_stroke(self) -> None:
        return None

    def abort_stroke(self) -> None:
        """Revert the open stroke's stamps (latest first) and record nothing."""
        if self._stroke is None:
            return
        with self._lock:
            self._stroke = None
            self.log.record("abort_stroke")
            change = self.history.abort(self)
        if change is not None:
            self.changed(*change, command="abort_stroke")

    # ------------------------------------------------------------------ replay
    def replay(self, log: CommandLog) -> None:
        """Apply a recorded command log (``seg.log`` of another session on the same mesh, or
        :meth:`CommandLog.load <plantvr.commandlog.CommandLog.load>` of one) by command name.

        The same replay gives identical label arrays (spec §2.0, checklist item 4). It is all or nothing: the
        whole log is applied to a scratch copy of this session, each event checked at its door against the
        copy's state just before it runs, and only when every event succeeded does this session take the
        result (observers get one ``"all"`` change, autosave writes once). An unknown command or a bad
        argument anywhere raises ``ValueError`` naming the event, and this session is left unchanged.
        """
        if not isinstance(log, CommandLog):
            raise ValueError(f"log must be a CommandLog, got {type(log).__name__}")  # noqa: TRY004
        if log.document is not None and log.document != self.KIND:
            raise ValueError(f"the log records a {log.document!r} session, not a {self.KIND!r} one"[:300])
        log.check()
        if not log.events:
            return
        scratch = self._scratch()
        for i, ev in enumerate(log.events):
            try:
                scratch.check_command(ev.command, ev.kwargs)
                getattr(scratch, ev.command)(**ev.kwargs)
            except (ValueError, TypeError) as exc:
                raise ValueError(f"event {i} ({ev.command}) cannot be applied: {exc}"[:500]) from None
        self._adopt(scratch, same_mesh=True, log=True, command="replay")

    def _scratch(self) -> Segmentation:
        """A copy sharing the mesh, index and graph, with its own labels, colours, history, views and log (no
        observers, no autosave): commands on it leave this session untouched."""
        c = type(self).__new__(type(self))
        Document.__init__(c, max_undo=self.history.max_items, max_undo_bytes=self.history.max_bytes)
        for k in _MESH_ATTRS:
            setattr(c, k, getattr(self, k))
        c.labels = self.labels.copy()
        c.colors = self.colors.copy()
        c.take_history(self.history.copy())
        c.views = list(self.views)
        c._stroke = None if self._stroke is None else list(self._stroke)
        c._preserve = self._preserve
        c.log.events = list(self.log.events)
        return c

    def _adopt(self, other: Segmentation, *, same_mesh: bool = False, log: bool = False,
               command: str = "restore") -> None:
        """Take over ``other``'s session state (and its mesh unless ``same_mesh``; its log with ``log``);
        observers, autosave and the brush mode stay. One ``"all"`` change."""
        with self._lock:
            for k in _SESSION_ATTRS + (() if same_mesh else _MESH_ATTRS):
                setattr(self, k, getattr(other, k))
            self.take_history(other.history)
            if log:
                self.log.events = other.log.events
        self.changed("all", command=command)

    # ------------------------------------------------------------------ colours and visibility
    def _check_set_color(self, label, rgb) -> tuple[int, np.ndarray]:
        return self.colors.check_label("label", label), self.colors.check_rgb("rgb", rgb)

    def set_color(self, label: int, rgb) -> None:
        """Recolour ``label`` in the table; labels are untouched."""
        label, _ = self._check_set_color(label, rgb)
        with self._lock:
            self.colors.set_color(label, rgb)
            self.log.record("set_color", label=label, rgb=[int(x) for x in self.colors.rgba[label]])
        self.changed("colors", command="set_color")

    def _check_add_color(self, rgb) -> np.ndarray:
        if len(self.colors) >= MAX_COLORS:
            raise ValueError(f"colour table is full ({MAX_COLORS} entries, one uint16 per vertex)")
        return self.colors.check_rgb("rgb", rgb)

    def add_color(self, rgb) -> int:
        """Append a colour to the table; returns its label.

        The 257th entry widens the labels to uint16 once (same values; observers get an ``"all"`` change, as
        the labels array is a new one); the table then grows to 65536 entries.
        """
        self._check_add_color(rgb)
        widen = len(self.colors) >= self.colors.capacity
        with self._lock:
            if widen:
                self._widen()
            k = self.colors.add_color(rgb)
            self.log.record("add_color", rgb=[int(x) for x in self.colors.rgba[k]])
        self.changed("all" if widen else "colors", command="add_color")
        return k

    def _check_set_visible(self, label, visible) -> tuple[int, bool]:
        label = self.colors.check_label("label", label)
        if not isinstance(visible, (bool, np.bool_)):
            raise ValueError(f"visible must be True or False, got {visible!r}")  # noqa: TRY004
        return label, bool(visible)

    def set_visible(self, label: int, visible: bool) -> None:
        """Show or hide every vertex of a colour; hidden vertices are not rendered and cannot be painted."""
        label, visible = self._check_set_visible(label, visible)
        with self._lock:
            self.colors.set_visible(label, visible)
            self.log.record("set_visible", label=label, visible=visible)
        self.changed("visibility", command="set_visible")

    def hide(self, label: int) -> None:
        """Hide a colour."""
        self.set_visible(label, False)

    def show(self, label: int) -> None:
        """Show a colour."""
        self.set_visible(label, True)

    def toggle_visible(self, label: int) -> bool:
        """Toggle a colour's visibility (the trackpad click); returns the new state."""
        label = self.colors.check_label("label", label)
        self.set_visible(label, not self.colors.visible[label])
        return bool(self.colors.visible[label])

    def vertex_visible(self) -> np.ndarray:
        """(V,) bool: vertices whose colour is visible."""
        return self.colors.visible[self.labels]

    def visible_faces(self) -> np.ndarray:
        """(F', 3) uint32: triangles whose three vertices are visible (spec §2.6 option 2)."""
        vis = self.vertex_visible()
        keep = vis[self.faces[:, 0]] & vis[self.faces[:, 1]] & vis[self.faces[:, 2]]
        return self.faces[keep]

    def vertex_colors(self) -> np.ndarray:
        """(V, 4) uint8 RGBA through the colour table."""
        return self.colors.rgba[self.labels]

    # ------------------------------------------------------------------ views
    @staticmethod
    def _check_add_view(view) -> SavedView:
        if isinstance(view, SavedView):
            return view
        if isinstance(view, (list, tuple, np.ndarray)):      # a logged view: its 13 numbers (SavedView.to_array)
            try:
                return SavedView.from_array(np.asarray(view, np.float64))
            except (ValueError, TypeError) as exc:
                raise ValueError(f"view must be a SavedView or its 13 numbers, got {view!r:.80} ({exc})") from None
        raise ValueError(f"view must be a SavedView, got {type(view).__name__}")

    def add_view(self, view) -> int:
        """Store a saved view (a :class:`SavedView`, or the 13 numbers of its ``to_array``); returns its number.
        Logged (as the 13 numbers) so a replay holds the same views; not an undo item (a camera bookmark)."""
        view = self._check_add_view(view)
        with self._lock:
            self.views.append(view)
            self.log.record("add_view", view=[float(x) for x in view.to_array()])
        self.changed("views", command="add_view")
        return len(self.views) - 1

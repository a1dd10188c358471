"""The ViNE layers of :class:`plantvr.View` (spec 000_vine §1.5, §2.6, §4.4(b), §4.5; issues 15, 30):

- :class:`~plantvr.types.LabelledSurface` → :class:`LabelledSurfaceLayer`: a segmentation (or its display proxy)
  in label colours, following its ``change`` events in place (per-vertex colour deltas, hidden colours dropped
  from the index buffer), with an optional shader-free depth cue;
- :class:`OrthoSlices` → :class:`VolumeSlicesLayer`: orthogonal slices of the raw volume with the iso-contour
  and the labelled surface cut (from :func:`plantvr.vine.slices.plane_segments`), recoloured after each paint.

Both are registered in :data:`plantvr.view.layers.LAYERS`, so :func:`~plantvr.view.layers.layer_class` picks
them by content type. The layers never edit labels.
"""
from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

from .._validation import check_array, check_int, check_range  # noqa: E402
from ..types import LabelledSurface  # noqa: E402
from ..vine.depthcue import coarse_hull, depth_cue_colors  # noqa: E402
from ..vine.slices import _check_axis, plane_segments, slice_contours  # noqa: E402
from .layers import LAYERS, Layer  # noqa: E402

__all__ = ["LabelledSurfaceLayer", "OrthoSlices", "VolumeSlicesLayer", "cut_polydata"]


class LabelledSurfaceLayer(Layer):
    """A labels document's visible surface in label colours (direct RGBA scalars ``"rgba"``, 4 B/vertex).

    The layer follows its content's ``source`` (a Segmentation or a DisplayProxy) by itself: a paint rewrites
    only the changed vertices' colours in place (VTK re-uploads the array), a hidden colour drops its triangles
    from the index buffer, a colour-table edit remaps every vertex once. The labels its colours show are kept
    (one byte a vertex), so :meth:`refresh`, called before a picture is taken, draws a paint whose change the
    kernel has not applied yet (trame's capture right after the mouse event that painted, issue 31), and the
    change, when it arrives, finds nothing left to draw. Back faces are culled (style ``culling``, thesis
    §5.7.3). A view's model pose (:meth:`plantvr.View.set_model_pose`) is the actor's ``user_matrix``;
    :meth:`paint_at` paints through it.

    Attributes
    ----------
    seg : Segmentation
        The full-resolution labels painted (the source itself, or the proxy's document).
    updates : int
        In-place colour or triangle updates applied.
    """

    in_place = ("rgba",)

    def __init__(self, plotter, name, style=None, **options):
        super().__init__(plotter, name, style)
        self.source = self.seg = None
        cue = options.get("depth_cue")
        self.depth_cue = cue is not None          # the view's option: the first refresh draws the cue
        self.background = (0, 0, 0) if cue is None else tuple(cue)   # the cue's target (further is darker, §2.2.1)
        self.updates = 0
        self._dirty = self._observing = False
        self._buffer = self._hull = None
        self._shown = None              # the labels the colours show
        self._cue_eye = None            # the eye (model frame) of the depth cue drawn

    @property
    def mesh(self) -> pv.PolyData:
        """The drawn ``PolyData`` (its ``"rgba"`` point array are the colours as drawn)."""
        return self.polys["main"]

    def update(self, content: LabelledSurface, **context) -> bool:
        """Draw a new source's surface; the same source is followed in place, so this returns whether it changed
        since the last call."""
        if self.content is not None and content.source is self.content.source:
            dirty, self._dirty = self._dirty, False
            return dirty
        self.draw(content)
        self.content, self._dirty = content, False
        return True

    def draw(self, content: LabelledSurface, **context) -> None:
        self.close()
        src = self.source = content.source
        self.seg = getattr(src, "seg", src)
        self._hull = self._buffer = self._cue_eye = None
        self._shown = np.array(src.labels)
        poly = pv.PolyData.from_regular_faces(np.asarray(src.vertices, np.float32),
                                              np.asarray(content.faces, np.int64))
        self._base = np.array(content.colors, np.uint8)
        poly.point_data["rgba"] = self._base.copy()
        if src.normals is not None:
            poly.point_data["Normals"] = src.normals
        self._show("main", poly, scalars="rgba", rgb=True, culling="back", smooth_shading=src.normals is not None,
                   show_scalar_bar=False)
        if src.normals is not None:
            self.mesh.point_data.active_normals_name = "Normals"
        src.observe(self._on_change, names="change")
        self._observing = True

    # ------------------------------------------------------------------ source → colours
    def _on_change(self, event) -> None:
        kind, ids = event["new"].kind, event["new"].ids
        if kind not in ("labels", "colors", "visibility", "all") or (ids is not None and ids.size == 0):
            return                                         # saved views, or a stroke's end: nothing to draw
        with self.lock:                                    # on the command's thread (a headset's: its mirror)
            self._follow(kind, ids)

    def _follow(self, kind: str, ids) -> None:
        if kind == "labels" and ids is not None:
            drawn = self._show_labels(np.asarray(ids, np.int64))
        else:
            src = self.source
            self._shown, self._base = np.array(src.labels), src.vertex_colors()
            if kind in ("visibility", "all"):
                self.mesh.faces = pv.CellArray.from_regular_cells(src.visible_faces().astype(np.int64))
            self._recolour()
            drawn = True
        self.updates += int(drawn)
        self._dirty |= drawn

    def _show_labels(self, ids: np.ndarray) -> bool:
        """Recolour the vertices ``ids`` whose label differs from the one drawn; returns whether any did."""
        src = self.source
        labels = src.labels[ids]
        new = self._shown[ids] != labels
        if not new.any():
            return False
        ids, labels = ids[new], labels[new]
        if self._shown.dtype != labels.dtype:              # the labels were widened (a 257th colour)
            self._shown = self._shown.astype(labels.dtype)
        self._shown[ids] = labels
        rgba = self._base[ids] = src.colors.rgba[labels]
        if self.depth_cue:
            if not np.array_equal(self._eye(), self._cue_eye):
                self._recolour()                           # the camera moved: every vertex's cue changed
                return True
            rgba = depth_cue_colors(rgba, src.vertices[ids], self._cue_eye, self._hull, background=self.background)
        self.mesh.point_data["rgba"][ids] = rgba            # in place: VTK re-uploads the array
        self.mesh.point_data.VTKObject.GetArray("rgba").Modified()
        return True

    def _eye(self) -> np.ndarray:
        """The camera position in the model frame (the depth cue's eye)."""
        m = np.asarray(self.actor.user_matrix, np.float64)
        return (np.linalg.inv(m) @ np.r_[np.asarray(self.plotter.camera.position, np.float64), 1.0])[:3]

    def _recolour(self) -> None:
        cols = self._base
        if self.depth_cue:
            self._cue_eye = self._eye()
            if self._hull is None:
                self._hull = coarse_hull(self.source.vertices)
            cols = depth_cue_colors(cols, self.source.vertices, self._cue_eye, self._hull, background=self.background)
        self.mesh.point_data["rgba"][:] = cols
        self.mesh.point_data.VTKObject.GetArray("rgba").Modified()

    def set_depth_cue(self, on: bool) -> None:
        """Toggle depth cueing (Eq. 5.8, p = 0.85, coarse-hull distances from the camera position, toward black)."""
        if not isinstance(on, (bool, np.bool_)):
            raise ValueError(f"on must be True or False, got {on!r}")
        with self.lock:
            self.depth_cue = bool(on)
            self._shown, self._base = np.array(self.source.labels), self.source.vertex_colors()
            self._recolour()

    def follow(self, buffer) -> None:
        """Read labels from a :class:`~plantvr.vine.buffers.TripleBuffer` instead of following the source's changes.

        Use this when painting runs on a :class:`~plantvr.vine.buffers.PaintWorker`: the worker thread never
        touches VTK; the render side calls :meth:`poll` (a view's ``screenshot`` does) and takes the latest
        completed labels (spec §4.3).
        """
        if not all(callable(getattr(buffer, k, None)) for k in ("acquire", "release")):
            raise ValueError(f"buffer must be a TripleBuffer (acquire, release), got {type(buffer).__name__}")
        self.close()
        self._buffer, self._buffer_version = buffer, -1

    def poll(self) -> bool:
        """Apply the newest completed label buffer, if any; returns whether the colours changed."""
        if self._buffer is None:
            return False
        labels, version = self._buffer.acquire()
        try:
            if version == self._buffer_version:
                return False
            shown = labels if self.source is self.seg else self.source.labels_from(labels)
            self._base = self.seg.colors.rgba[shown]
            self._buffer_version = version
        finally:
            self._buffer.release()
        self._recolour()
        self.updates += 1
        return True

    def refresh(self) -> bool:
        """Before a picture: apply the newest worker buffer (:meth:`follow`), else draw the labels painted since
        the last change this layer followed; redo the depth cue when the camera or the pose moved. Returns whether
        the colours changed."""
        with self.lock:
            labels = self.source.labels
            if self._buffer is not None:
                changed = self.poll()
            else:                           # (a restore to another mesh is redrawn by its change)
                changed = labels.shape == self._shown.shape and self._show_labels(
                    np.flatnonzero(self._shown != labels))
            if self.depth_cue and not np.array_equal(self._eye(), self._cue_eye):
                self._recolour()
                changed = True
            return changed

    # ------------------------------------------------------------------ painting
    def paint_at(self, point, *, radius: float, label: int) -> int:
        """Paint the full-resolution labels at a picked world-space point, through the model pose; returns the
        number of vertices changed."""
        m = np.asarray(self.actor.user_matrix, np.float64)
        s = float(np.cbrt(abs(np.linalg.det(m[:3, :3]))))
        c = (np.linalg.inv(m) @ np.r_[check_array("point", point, shape=(3,), dtype=np.float64), 1.0])[:3]
        return self.seg.paint(c, check_range("radius", radius, 0.0, 1e12) / s, label)

    def enable_mouse_painting(self, *, radius: float, label: int) -> None:
        """Paint with the sphere brush where the user clicks on the surface (desktop painting mode)."""
        self.brush_radius = check_range("radius", radius, 0.0, 1e12, low_open=True)
        self.brush_label = self.seg.colors.check_label("label", label)
        self.plotter.enable_surface_point_picking(
            callback=lambda p: self.paint_at(p, radius=self.brush_radius, label=self.brush_label),
            show_point=False, show_message=False)

    def close(self) -> None:
        if self._observing:
            self.source.unobserve(self._on_change, names="change")
            self._observing = False


@dataclass(frozen=True, eq=False)
class OrthoSlices:
    """Orthogonal slices of a raw volume, the scene content :class:`VolumeSlicesLayer` draws.

    Parameters
    ----------
    volume : (X, Y, Z) ndarray
        The raw scan (voxel (i, j, k) at model point (i, j, k) * spacing, as the isosurface).
    level : float, optional
        Iso-value: its contour is drawn on each slice as a thin white line.
    seg : Segmentation, optional
        Its surface cut is drawn in label colours and kept up to date.
    spacing : (3,) float
        Voxel size, positive.
    indices : dict, optional
        Slice index per axis, e.g. ``{"x": 30, "z": 12}``; default the middle of each axis.
    line_width : float
        Width of the labelled cut, in pixels, in (0, 50].
    opacity : float
        Slice opacity, in [0, 1].
    cmap : str
        Colour map of the intensities.
    """

    volume: np.ndarray
    level: float | None = None
    seg: Any = None
    spacing: Any = (1.0, 1.0, 1.0)
    indices: Mapping | None = None
    line_width: float = 5.0
    opacity: float = 1.0
    cmap: str = "gray"

    def __post_init__(self):
        vol = np.asarray(self.volume)
        if vol.ndim != 3 or min(vol.shape) < 1 or vol.dtype.kind not in "biuf":
            raise ValueError(f"volume must be a non-empty 3-D numeric array, got {vol.dtype} {vol.shape}")
        if vol.dtype.kind == "f" and not np.all(np.isfinite(vol)):
            raise ValueError("volume must contain only finite values (no NaN or inf)")
        if self.seg is not None and not all(hasattr(self.seg, k) for k in ("vertices", "faces", "labels",
                                                                           "colors", "observe")):
            raise ValueError(f"seg must be a Segmentation, got {type(self.seg).__name__}")
        sp = check_array("spacing", self.spacing, shape=(3,), max_abs=1e6)
        if np.any(sp <= 0):
            raise ValueError(f"spacing must be positive, got {sp.tolist()}")
        if self.level is not None:
            check_range("level", self.level, -np.inf, np.inf, low_open=True, high_open=True)
        indices = {a: vol.shape[k] // 2 for k, a in enumerate("xyz")} if self.indices is None else self.indices
        if not isinstance(indices, Mapping):
            raise ValueError(f"indices must be a dict of slice index per axis, got {type(indices).__name__}")
        idx = {}
        for a, i in indices.items():
            try:
                k = _check_axis(a)
            except ValueError as exc:
                raise ValueError(f"indices: {exc}") from None
            idx[k] = check_int(f"indices[{a!r}]", i, 0, vol.shape[k] - 1)
        object.__setattr__(self, "volume", vol)
        object.__setattr__(self, "spacing", tuple(float(s) for s in sp))
        object.__setattr__(self, "indices", idx)
        object.__setattr__(self, "line_width", check_range("line_width", self.line_width, 0.0, 50.0,
                                                           low_open=True))
        object.__setattr__(self, "opacity", check_range("opacity", self.opacity, 0.0, 1.0))
        if not isinstance(self.cmap, str):
            raise ValueError(f"cmap must be a colour map name, got {self.cmap!r}")


def cut_polydata(segments: np.ndarray, end_labels: np.ndarray | None, rgba: np.ndarray | None) -> pv.PolyData:
    """Line segments as PolyData; with labels, each segment is split at its midpoint and each half carries
    its end's colour (``rgb`` cell data, uint8)."""
    segs = np.asarray(segments, np.float64).reshape(-1, 2, 3)
    if end_labels is not None:
        mid = 0.5 * (segs[:, 0] + segs[:, 1])
        segs = np.concatenate([np.stack([segs[:, 0], mid], 1), np.stack([mid, segs[:, 1]], 1)])
        lab = np.concatenate([end_labels[:, 0], end_labels[:, 1]])
    pts = segs.reshape(-1, 3)
    n = len(segs)
    lines = np.column_stack([np.full(n, 2), 2 * np.arange(n), 2 * np.arange(n) + 1]).ravel()
    pd = pv.PolyData(pts, lines=lines) if n else pv.PolyData()
    if n and end_labels is not None:
        pd.cell_data["rgb"] = rgba[lab, :3]
    return pd


class VolumeSlicesLayer(Layer):
    """Up to three orthogonal slices of :class:`OrthoSlices` content: per axis ``k`` the parts ``slice{k}`` (the
    intensities), ``contour{k}`` (the iso-contour, white) and ``cut{k}`` (the segmentation's surface cut in label
    colours, redrawn after every paint, fill or split of the segmentation)."""

    def __init__(self, plotter, name, style=None, **options):
        super().__init__(plotter, name, style)
        self.indices: dict[int, int] = {}
        self._seg = None

    def draw(self, content: OrthoSlices, **context) -> None:
        self.remove()
        self.content, vol = content, content.volume
        self.image = pv.ImageData(dimensions=vol.shape, spacing=content.spacing)
        self.image.point_data["intensity"] = vol.ravel(order="F")
        lo, hi = float(vol.min()), float(vol.max())
        self.clim = (lo, hi if hi > lo else lo + 1)
        self.indices = {}
        for k, i in sorted(content.indices.items()):
            self.set_index(k, i)
        self._seg = content.seg
        if self._seg is not None:
            self._seg.observe(self._on_change, names="change")

    def _on_change(self, event) -> None:
        ids = event["new"].ids
        if event["new"].kind in ("labels", "colors", "all") and (ids is None or ids.size):
            for k in self.indices:
                self._draw_cut(k)

    def _draw_cut(self, k: int) -> None:
        seg, c = self.content.seg, self.content
        if seg is None:
            return
        segs, el = plane_segments(seg.vertices, seg.faces, k, self.indices[k] * c.spacing[k], labels=seg.labels)
        self._show(f"cut{k}", cut_polydata(segs, el, seg.colors.rgba) if len(segs) else None, scalars="rgb",
                   rgb=True, line_width=c.line_width, lighting=False, show_scalar_bar=False)

    def set_index(self, axis: int | str, index: int) -> None:
        """Move (or add) the slice along ``axis`` to voxel ``index``."""
        c = self.content
        k = _check_axis(axis)
        index = check_int("index", index, 0, c.volume.shape[k] - 1)
        self.indices[k] = index
        voi = [0, c.volume.shape[0] - 1, 0, c.volume.shape[1] - 1, 0, c.volume.shape[2] - 1]
        voi[2 * k] = voi[2 * k + 1] = index
        plane = self.image.extract_subset(voi).extract_surface(algorithm="dataset_surface")
        self._show(f"slice{k}", plane, scalars="intensity", cmap=c.cmap, clim=self.clim, opacity=c.opacity,
                   lighting=False, show_scalar_bar=False)
        cs = [] if c.level is None else slice_contours(c.volume, c.level, k, index, spacing=c.spacing)
        contour = None
        if cs:
            offs = np.cumsum([0] + [len(p) for p in cs])
            lines = np.concatenate([np.r_[len(p), np.arange(o, o + len(p))] for p, o in zip(cs, offs)])
            contour = pv.PolyData(np.concatenate(cs), lines=lines)
        self._show(f"contour{k}", contour, color="white", line_width=1.0, lighting=False)
        self._draw_cut(k)

    def close(self) -> None:
        if self._seg is not None:
            self._seg.unobserve(self._on_change, names="change")
            self._seg = None


LAYERS[LabelledSurface] = LabelledSurfaceLayer
LAYERS[OrthoSlices] = VolumeSlicesLayer

"""Orthogonal slices of the raw volume in the pyvista view, with the iso-contour and the labelled surface cut
(spec 000_vine §1.5 step 3, §6; issue 15).

The numeric cut comes from :func:`plantvr.vine.slices.plane_segments`; this module only draws it. Slices
follow the segmentation (its ``change`` trait): after a paint, fill or split the cut lines are recoloured.
"""
from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np
import pyvista as pv

from plantvr._validation import check_array, check_int, check_range
from plantvr.documents.labels import Segmentation
from plantvr.vine.slices import _check_axis, plane_segments, slice_contours

__all__ = ["VolumeSlices", "cut_polydata"]


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


class VolumeSlices:
    """Up to three orthogonal volume slices drawn into a pyvista plotter.

    Parameters
    ----------
    plotter : pyvista.Plotter
    volume : (X, Y, Z) ndarray
        The raw scan (voxel (i, j, k) at model point (i, j, k) * spacing, as the isosurface).
    level : float, optional
        Iso-value: its contour is drawn on each slice as a thin white line.
    seg : Segmentation, optional
        Its surface cut is drawn in label colours and kept up to date.
    spacing : (3,) float
    indices : dict, optional
        Slice index per axis, e.g. ``{"x": 30, "z": 12}``; default the middle of each axis.
    line_width : float
        Width of the labelled cut, in pixels, in (0, 50].
    opacity : float
        Slice opacity, in [0, 1].
    """

    def __init__(self, plotter: pv.Plotter, volume: np.ndarray, *, level: float | None = None,
                 seg: Segmentation | None = None, spacing=(1.0, 1.0, 1.0), indices: dict | None = None,
                 line_width: float = 5.0, opacity: float = 1.0, cmap: str = "gray"):
        vol = np.asarray(volume)
        if vol.ndim != 3 or min(vol.shape) < 1 or vol.dtype.kind not in "biuf":
            raise ValueError(f"volume must be a non-empty 3-D numeric array, got {vol.dtype} {vol.shape}")
        if vol.dtype.kind == "f" and not np.all(np.isfinite(vol)):
            raise ValueError("volume must contain only finite values (no NaN or inf)")
        if seg is not None and not isinstance(seg, Segmentation):
            raise ValueError(f"seg must be a Segmentation, got {type(seg).__name__}")
        sp = check_array("spacing", spacing, shape=(3,), max_abs=1e6)
        if np.any(sp <= 0):
            raise ValueError(f"spacing must be positive, got {sp.tolist()}")
        if level is not None:
            level = check_range("level", level, -np.inf, np.inf, low_open=True, high_open=True)
        self.line_width = check_range("line_width", line_width, 0.0, 50.0, low_open=True)
        self.opacity = check_range("opacity", opacity, 0.0, 1.0)
        if indices is None:
            indices = {a: vol.shape[k] // 2 for k, a in enumerate("xyz")}
        idx = {}
        for a, i in dict(indices).items():
            k = _check_axis(a)
            idx[k] = check_int(f"indices[{a!r}]", i, 0, vol.shape[k] - 1)
        self.plotter, self.volume, self.level, self.seg, self.spacing, self.cmap = plotter, vol, level, seg, sp, cmap
        self.image = pv.ImageData(dimensions=vol.shape, spacing=tuple(sp))
        self.image.point_data["intensity"] = vol.ravel(order="F")
        self.clim = (float(vol.min()), float(vol.max()) if vol.max() > vol.min() else float(vol.min()) + 1)
        self.indices: dict[int, int] = {}
        self.actors: dict[tuple[str, int], object] = {}
        for k, i in sorted(idx.items()):
            self.set_index(k, i)
        self._observing = seg is not None
        if seg is not None:
            seg.observe(self._on_change, names="change")

    def _on_change(self, event) -> None:
        ids = event["new"].ids
        if event["new"].kind in ("labels", "colors", "all") and (ids is None or ids.size):
            for k in list(self.indices):
                self._draw_cut(k)

    def _draw_cut(self, k: int) -> None:
        name = ("cut", k)
        if name in self.actors:
            self.plotter.remove_actor(self.actors.pop(name), render=False)
        if self.seg is None:
            return
        segs, el = plane_segments(self.seg.vertices, self.seg.faces, k, self.indices[k] * self.spacing[k],
                                  labels=self.seg.labels)
        if len(segs):
            pd = cut_polydata(segs, el, self.seg.colors.rgba)
            self.actors[name] = self.plotter.add_mesh(pd, scalars="rgb", rgb=True, line_width=self.line_width,
                                                      lighting=False, show_scalar_bar=False,
                                                      name=f"vine-cut-{k}")

    def set_index(self, axis: int | str, index: int) -> None:
        """Move (or add) the slice along ``axis`` to voxel ``index``."""
        k = _check_axis(axis)
        index = check_int("index", index, 0, self.volume.shape[k] - 1)
        self.indices[k] = index
        for kind in ("slice", "contour"):
            if (kind, k) in self.actors:
                self.plotter.remove_actor(self.actors.pop((kind, k)), render=False)
        voi = [0, self.volume.shape[0] - 1, 0, self.volume.shape[1] - 1, 0, self.volume.shape[2] - 1]
        voi[2 * k] = voi[2 * k + 1] = index
        plane = self.image.extract_subset(voi).extract_surface(algorithm="dataset_surface")
        self.actors[("slice", k)] = self.plotter.add_mesh(
            plane, scalars="intensity", cmap=self.cmap, clim=self.clim, opacity=self.opacity, lighting=False,
            show_scalar_bar=False, name=f"vine-slice-{k}")
        if self.level is not None:
            cs = slice_contours(self.volume, self.level, k, index, spacing=self.spacing)
            if cs:
                pts = np.concatenate(cs)
                offs = np.cumsum([0] + [len(c) for c in cs])
                lines = np.concatenate([np.r_[len(c), np.arange(o, o + len(c))] for c, o in zip(cs, offs)])
                self.actors[("contour", k)] = self.plotter.add_mesh(
                    pv.PolyData(pts, lines=lines), color="white", line_width=1.0, lighting=False,
                    name=f"vine-contour-{k}")
        self._draw_cut(k)

    def remove(self) -> None:
        """Remove every slice actor and stop following the segmentation."""
        for a in self.actors.values():
            self.plotter.remove_actor(a, render=False)
        self.actors.clear()
        if self._observing:
            self.seg.unobserve(self._on_change, names="change")
            self._observing = False

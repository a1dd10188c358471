"""Figures of segmentations with matplotlib: label areas, volume slices with the labelled surface cut
(spec 000_vine §2.7; issue 15). The numbers come from the cores (:mod:`plantvr.vine.labelstats`,
:mod:`plantvr.vine.slices`); this module only draws them, so the cores import no plotting library.
"""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection

from plantvr._validation import check_range
from plantvr.vine.colors import ColorTable
from plantvr.vine.slices import _AXES, check_slice, plane_segments, slice_contours

__all__ = ["plot_label_areas", "slice_figure"]


def plot_label_areas(table, *, ax=None, skip_zero: bool = True):
    """Bar chart of label surface areas, bars in the label colours (needs ``r, g, b`` columns for colour).

    Parameters
    ----------
    table : pandas.DataFrame
        From :func:`label_table`.
    ax : matplotlib Axes, optional
    skip_zero : bool
        Leave out label 0 (unpainted).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig, ax = plt.subplots(figsize=(6, 3.2), dpi=100)
    else:
        fig = ax.figure
    t = table[table["label"] != 0] if skip_zero else table
    if {"r", "g", "b"} <= set(t.columns):
        col = np.stack([t["r"], t["g"], t["b"]], axis=1) / 255.0
    else:
        col = None
    names = [f"{k}" + (f" {n}" if "name" in t.columns and n else "")
             for k, n in zip(t["label"], t["name"] if "name" in t.columns else [""] * len(t))]
    ax.bar(np.arange(len(t)), t["area"], color=col, edgecolor="black", linewidth=0.6)
    ax.set_xticks(np.arange(len(t)), names, rotation=45 if len(t) > 8 else 0, ha="right" if len(t) > 8 else "center")
    ax.set_xlabel("label")
    ax.set_ylabel("surface area (model units²)")
    ax.set_title("Surface area per label")
    fig.tight_layout()
    return fig


def slice_figure(volume: np.ndarray, axis: int | str, index: int, *, level: float | None = None,
                 vertices=None, faces=None, labels=None, colors=None, spacing=(1.0, 1.0, 1.0), ax=None,
                 linewidth: float = 2.0, title: str | None = None):
    """Draw one orthogonal volume slice with the iso-contour and the labelled surface cut (matplotlib).

    Parameters
    ----------
    volume : (X, Y, Z) ndarray
        The raw scan.
    axis : {0, 1, 2, "x", "y", "z"}
    index : int
        Slice index along ``axis``, in [0, shape[axis] - 1].
    level : float, optional
        Iso-value; draws the contour as a thin dashed white line.
    vertices, faces, labels : ndarray, optional
        The labelled surface (model units = voxel index × ``spacing``); its cut is drawn in label colours.
    colors : ColorTable, optional
        Colours for ``labels`` (default palette).
    spacing : (3,) float
        Voxel size.
    ax : matplotlib Axes, optional
    linewidth : float
        Width of the coloured cut, in points, in (0, 20].
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        The slice with ``origin="lower"``: the second remaining axis runs right, the first runs up, both in
        model units.
    """
    vol, a, index, sp = check_slice(volume, axis, index, spacing)
    linewidth = check_range("linewidth", linewidth, 0.0, 20.0, low_open=True)
    if (vertices is None) != (faces is None):
        raise ValueError("vertices and faces must be given together")
    colors = ColorTable() if colors is None else colors
    other = [k for k in range(3) if k != a]
    segs = None
    if vertices is not None:
        res = plane_segments(vertices, faces, a, index * sp[a], labels=labels)
        segs, seg_lab = res if labels is not None else (res, None)
    contours = [] if level is None else slice_contours(vol, level, a, index, spacing=sp)
    if ax is None:
        fig, ax = plt.subplots(figsize=(5, 5), dpi=100)
    else:
        fig = ax.figure
    img = np.take(vol, index, axis=a)
    # row = first remaining axis, column = second: extent in model units
    ext = (-0.5 * sp[other[1]], (img.shape[1] - 0.5) * sp[other[1]],
           -0.5 * sp[other[0]], (img.shape[0] - 0.5) * sp[other[0]])
    ax.imshow(img, cmap="gray", origin="lower", extent=ext, interpolation="nearest")
    if segs is not None and len(segs):
        p0, p1 = segs[:, 0][:, other[::-1]], segs[:, 1][:, other[::-1]]
        mid = 0.5 * (p0 + p1)
        if seg_lab is None:
            lines = np.stack([p0, p1], axis=1)
            lc = LineCollection(lines, colors="magenta", linewidths=linewidth)
        else:
            lines = np.concatenate([np.stack([p0, mid], axis=1), np.stack([mid, p1], axis=1)])
            lab = np.concatenate([seg_lab[:, 0], seg_lab[:, 1]])
            lc = LineCollection(lines, colors=colors.rgba[lab] / 255.0, linewidths=linewidth)
        ax.add_collection(lc)
    for c in contours:
        q = c[:, other[::-1]]
        ax.plot(q[:, 0], q[:, 1], color="white", lw=0.7, ls=(0, (3, 2)))
    ax.set_xlim(ext[0], ext[1])
    ax.set_ylim(ext[2], ext[3])
    ax.set_xlabel(f"{_AXES[other[1]]}")
    ax.set_ylabel(f"{_AXES[other[0]]}")
    ax.set_title(title if title is not None else f"{_AXES[a]} = {index}")
    fig.tight_layout()
    return fig

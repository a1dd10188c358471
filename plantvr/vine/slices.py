"""Orthogonal slices of the raw volume against the labelled surface (spec 000_vine §1.5 step 3 "2D slice
preview with the contour", §6; issue 15).

:func:`plane_segments` cuts the mesh with an axis-aligned plane and returns the cut as line segments whose
two halves carry the labels of the nearer mesh vertices, so the label colours can be drawn over the scan.
:func:`plantvr.view.plots.slice_figure` draws a volume slice (matplotlib), the isosurface contour at the iso-level
(``skimage.measure.find_contours``, the oracle for the cut: marching cubes and marching squares interpolate
the same grid edges) and the coloured cut.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import check_array, check_int, check_range

__all__ = ["check_slice", "plane_segments", "slice_contours"]

_AXES = "xyz"


def _check_axis(axis) -> int:
    if isinstance(axis, str):
        if axis not in _AXES:
            raise ValueError(f"axis must be 0, 1, 2 or one of 'x', 'y', 'z', got {axis!r}")
        return _AXES.index(axis)
    return check_int("axis", axis, 0, 2)


def check_slice(volume, axis, index, spacing) -> tuple[np.ndarray, int, int, np.ndarray]:
    """``(volume, axis, index, spacing)`` of one volume slice, checked: a 3-D volume, an axis 0-2 or
    ``'x'``/``'y'``/``'z'``, an index inside that axis, a finite ``(3,)`` voxel spacing."""
    vol = np.asarray(volume)
    if vol.ndim != 3:
        raise ValueError(f"volume must be 3-D, got shape {vol.shape}")
    ax = _check_axis(axis)
    index = check_int("index", index, 0, vol.shape[ax] - 1)
    return vol, ax, index, check_array("spacing", spacing, shape=(3,))


def plane_segments(vertices: np.ndarray, faces: np.ndarray, axis: int | str, position: float, *,
                   labels: np.ndarray | None = None):
    """Intersect a triangle mesh with the plane ``x[axis] == position``.

    Each face with vertices on both sides gives one segment between the points where two of its edges
    cross the plane (a vertex exactly on the plane counts as below, so no face is cut twice and an edge
    lying in the plane is reported once, by the face above it; faces touching the plane at a single vertex
    give no segment).

    Parameters
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) integer ndarray
    axis : {0, 1, 2, "x", "y", "z"}
        Plane normal.
    position : float
        Plane offset along ``axis`` (model units).
    labels : (V,) uint8 ndarray, optional
        Per-vertex labels; each segment end takes the label of the nearer end of its crossing edge.

    Returns
    -------
    segments : (S, 2, 3) float64 ndarray
        Segment end points (their ``axis`` coordinate equals ``position``).
    end_labels : (S, 2) uint8 ndarray
        Only when ``labels`` is given.
    """
    v = np.asarray(vertices)
    if v.dtype not in (np.float32, np.float64):
        v = check_array("vertices", v, shape=(None, 3), min_rows=1)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 1:
        raise ValueError(f"vertices must have shape (N, 3) with N >= 1, got {v.shape}")
    if not np.isfinite(v).all():
        raise ValueError("vertices must contain only finite values (no NaN or inf)")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu":
        raise ValueError(f"faces must be an integer array of shape (F, 3), got {f.dtype} {f.shape}")
    if f.size and (int(f.min()) < 0 or int(f.max()) >= len(v)):
        raise ValueError(f"faces must index vertices in [0, {len(v) - 1}], got range [{f.min()}, {f.max()}]")
    ax = _check_axis(axis)
    pos = check_range("position", position, -np.inf, np.inf, low_open=True, high_open=True)
    if labels is not None:
        labels = np.asarray(labels)
        if labels.shape != (len(v),) or labels.dtype not in (np.uint8, np.uint16):
            raise ValueError(f"labels must be uint8 or uint16 of shape ({len(v)},), got {labels.dtype} {labels.shape}")
    lab = np.zeros(1, np.uint8) if labels is None else labels
    segs, el = _plane_cut_numba(np.ascontiguousarray(v), np.ascontiguousarray(f), ax, pos, lab,
                                labels is not None)
    return segs if labels is None else (segs, el)


@numba.njit(cache=True, nogil=True)
def _plane_cut_numba(v, f, ax, pos, labels, with_labels):  # pragma: no cover - numba kernel, twin below
    """Two passes over the faces (count, then fill) of the rule in :func:`_plane_cut_numpy`."""
    nf = f.shape[0]
    n = 0
    for t in range(nf):
        k = 0
        for j in range(3):
            if np.float64(v[f[t, j], ax]) - pos > 0:
                k += 1
        if k == 1 or k == 2:
            n += 1
    segs = np.empty((n, 2, 3), np.float64)
    el = np.zeros((n, 2), np.uint8)
    m = 0
    up = np.zeros(3, np.bool_)
    for t in range(nf):
        k = 0
        for j in range(3):
            up[j] = np.float64(v[f[t, j], ax]) - pos > 0
            k += up[j]
        if k != 1 and k != 2:
            continue
        lone = 0
        for j in range(3):
            if up[j] == (k == 1):
                lone = j
                break
        a, b, c = f[t, lone], f[t, (lone + 1) % 3], f[t, (lone + 2) % 3]
        da = np.float64(v[a, ax]) - pos
        db = np.float64(v[b, ax]) - pos
        dc = np.float64(v[c, ax]) - pos
        t0 = da / (da - db)
        t1 = da / (da - dc)
        same = True
        for j in range(3):
            va = np.float64(v[a, j])
            x0 = va + t0 * (np.float64(v[b, j]) - va)
            x1 = va + t1 * (np.float64(v[c, j]) - va)
            if j == ax:
                x0 = pos
                x1 = pos
            segs[m, 0, j] = x0
            segs[m, 1, j] = x1
            if x0 != x1:
                same = False
        if same:                                # a face touching the plane at one vertex gives a point
            continue
        if with_labels:
            el[m, 0] = labels[a] if t0 <= 0.5 else labels[b]
            el[m, 1] = labels[a] if t1 <= 0.5 else labels[c]
        m += 1
    return segs[:m].copy(), el[:m].copy()


def _plane_cut_numpy(v, f, ax, pos, labels):
    """Numpy twin of :func:`_plane_cut_numba`: (segments, end labels or None)."""
    v = np.asarray(v, np.float64)
    d = v[:, ax] - pos
    up = d > 0
    up = d > 0
    f = f.astype(np.int64, copy=False)
    fu = up[f]
    n_up = fu.sum(axis=1)
    cut = (n_up == 1) | (n_up == 2)
    fc, fuc = f[cut], fu[cut]
    # the lone vertex (the one on the minority side) is first; its two edges cross the plane
    lone_is_up = (fuc.sum(axis=1) == 1)
    lone = np.where(lone_is_up, np.argmax(fuc, axis=1), np.argmin(fuc, axis=1))
    r = np.arange(len(fc))
    a = fc[r, lone]
    b = fc[r, (lone + 1) % 3]
    c = fc[r, (lone + 2) % 3]

    def cross(p, q):
        t = d[p] / (d[p] - d[q])
        pts = v[p] + t[:, None] * (v[q] - v[p])
        pts[:, ax] = pos
        return pts, t

    p0, t0 = cross(a, b)
    p1, t1 = cross(a, c)
    segs = np.stack([p0, p1], axis=1)
    keep = np.any(p0 != p1, axis=1)            # a face touching the plane at one vertex gives a point
    if not keep.all():
        segs, a, b, c, t0, t1 = segs[keep], a[keep], b[keep], c[keep], t0[keep], t1[keep]
    if labels is None:
        return segs, None
    l0 = np.where(t0 <= 0.5, labels[a], labels[b])
    l1 = np.where(t1 <= 0.5, labels[a], labels[c])
    return segs, np.stack([l0, l1], axis=1).astype(np.uint8)


def slice_contours(volume: np.ndarray, level: float, axis: int | str, index: int, *,
                   spacing=(1.0, 1.0, 1.0)) -> list[np.ndarray]:
    """Isocontours of one volume slice (``skimage.measure.find_contours``) in model coordinates.

    Returns a list of (N, 3) float64 polylines lying in the plane ``x[axis] == index * spacing[axis]``.
    """
    from skimage.measure import find_contours
    vol, ax, index, sp = check_slice(volume, axis, index, spacing)
    level = check_range("level", level, -np.inf, np.inf, low_open=True, high_open=True)
    img = np.take(vol, index, axis=ax).astype(np.float32)
    other = [k for k in range(3) if k != ax]
    out = []
    for c in find_contours(img, level):
        p = np.empty((len(c), 3))
        p[:, ax] = index * sp[ax]
        p[:, other[0]] = c[:, 0] * sp[other[0]]
        p[:, other[1]] = c[:, 1] * sp[other[1]]
        out.append(p)
    return out

"""Per-label meshes, statistics table and area chart (spec 000_vine §6 "named labels and per-label mesh
export", §2.7 export; issue 15). The files are written by :mod:`plantvr.io.labels`.

A label's mesh is the faces whose three vertices carry that label, with its vertices renumbered compactly.
The table has one row per label present: vertex count, face count, surface area (of the label's mesh),
bounding box of its vertices and the number of mesh-connected components (over edges whose two ends carry
the label, the parts :meth:`Segmentation.split_label` would make).
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import check_int
from plantvr.vine.fill import _check_mesh_arrays, _components_numba, mesh_graph

__all__ = ["face_labels", "label_mesh", "label_table"]


def _check_mesh(vertices, faces, labels):
    v, f = _check_mesh_arrays(vertices, faces)
    lab = np.asarray(labels)
    if lab.shape != (len(v),) or lab.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"labels must be uint8 or uint16 of shape ({len(v)},), got {lab.dtype} {lab.shape}")
    return v, f, lab


def face_labels(faces: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """(F,) int16: the label of each face whose three vertices agree, else -1."""
    la, lb, lc = labels[faces[:, 0]], labels[faces[:, 1]], labels[faces[:, 2]]
    return np.where((la == lb) & (lb == lc), la.astype(np.int16), np.int16(-1))


def label_mesh(vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray, label: int):
    """The sub-mesh of one label: faces whose three vertices carry ``label``, vertices renumbered.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) integer ndarray
    labels : (V,) uint8 ndarray
    label : int
        In [0, 255].

    Returns
    -------
    vertices : (V', 3) ndarray
        The used vertices, in their original order.
    faces : (F', 3) int64 ndarray
        Renumbered into ``vertices``.
    ids : (V',) int64 ndarray
        Original vertex ids (``vertices == original[ids]``).
    """
    v, f, lab = _check_mesh(vertices, faces, labels)
    label = check_int("label", label, 0, 255)
    sub = f[face_labels(f, lab) == label].astype(np.int64)
    ids = np.unique(sub)
    remap = np.full(len(v), -1, np.int64)
    remap[ids] = np.arange(ids.size)
    return v[ids], remap[sub], ids


def _face_areas(v, f) -> np.ndarray:
    a, b, c = (v[f[:, k]].astype(np.float64) for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


@numba.njit(cache=True, nogil=True)
def _label_stats_numba(v, f, lab):  # pragma: no cover - numba kernel, twin: _label_stats_numpy
    """One pass over vertices and faces: per-label vertex count, face count, area, bounding box."""
    counts = np.zeros(256, np.int64)
    nface = np.zeros(256, np.int64)
    area = np.zeros(256, np.float64)
    lo = np.full((256, 3), np.inf)
    hi = np.full((256, 3), -np.inf)
    for i in range(v.shape[0]):
        k = lab[i]
        counts[k] += 1
        for d in range(3):
            x = np.float64(v[i, d])
            lo[k, d] = min(lo[k, d], x)
            hi[k, d] = max(hi[k, d], x)
    for t in range(f.shape[0]):
        a, b, c = f[t, 0], f[t, 1], f[t, 2]
        k = lab[a]
        if lab[b] != k or lab[c] != k:
            continue
        e1x = np.float64(v[b, 0]) - np.float64(v[a, 0])
        e1y = np.float64(v[b, 1]) - np.float64(v[a, 1])
        e1z = np.float64(v[b, 2]) - np.float64(v[a, 2])
        e2x = np.float64(v[c, 0]) - np.float64(v[a, 0])
        e2y = np.float64(v[c, 1]) - np.float64(v[a, 1])
        e2z = np.float64(v[c, 2]) - np.float64(v[a, 2])
        cx = e1y * e2z - e1z * e2y
        cy = e1z * e2x - e1x * e2z
        cz = e1x * e2y - e1y * e2x
        area[k] += 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)
        nface[k] += 1
    return counts, nface, area, lo, hi


def _label_stats_numpy(v, f, lab):
    """Numpy twin of :func:`_label_stats_numba` (bbox rows of absent labels stay ±inf)."""
    counts = np.bincount(lab, minlength=256)
    present = np.flatnonzero(counts)
    fl = face_labels(f, lab)
    sel = fl >= 0
    area = np.bincount(fl[sel], weights=_face_areas(v, f[sel]), minlength=256)
    nface = np.bincount(fl[sel], minlength=256)
    order = np.argsort(lab, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)])[present]
    vs = v[order].astype(np.float64)
    lo = np.full((256, 3), np.inf)
    hi = np.full((256, 3), -np.inf)
    lo[present] = np.minimum.reduceat(vs, starts, axis=0)
    hi[present] = np.maximum.reduceat(vs, starts, axis=0)
    return counts, nface, area, lo, hi


@numba.njit(cache=True, nogil=True)
def _components_per_label_numba(comp, lab):  # pragma: no cover - numba kernel, twin: _components_per_label
    """Components are numbered by their smallest vertex id, so the first vertex of each is met in order."""
    out = np.zeros(256, np.int64)
    nxt = 0
    for i in range(comp.size):
        if comp[i] == nxt:
            out[lab[i]] += 1
            nxt += 1
    return out


def _components_per_label(comp, lab) -> np.ndarray:
    """Numpy twin of :func:`_components_per_label_numba`."""
    _, first = np.unique(comp[comp >= 0], return_index=True)
    return np.bincount(lab[comp >= 0][first], minlength=256)


def label_table(vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray, *, colors=None,
                names: dict | None = None, graph=None):
    """Per-label statistics as a pandas DataFrame, one row per label present, sorted by label.

    Parameters
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) integer ndarray
    labels : (V,) uint8 ndarray
    colors : ColorTable, optional
        Adds ``r, g, b`` columns (for charts).
    names : dict of int to str, optional
        Adds a ``name`` column.
    graph : MeshGraph, optional
        The mesh's vertex adjacency, if already built.

    Returns
    -------
    pandas.DataFrame
        Columns ``label, vertices, faces, area, xmin, ymin, zmin, xmax, ymax, zmax, components``
        (+ ``name``, ``r, g, b``). ``area`` (model units²) and ``faces`` count the label's mesh
        (:func:`label_mesh`); the bounding box spans all the label's vertices.
    """
    import pandas as pd

    v, f, lab = _check_mesh(vertices, faces, labels)
    g = mesh_graph(v, f) if graph is None else graph
    counts, nface, area, lo, hi = _label_stats_numba(v, f, lab)
    comp, _ = _components_numba(g.indptr, g.indices, lab, -1)
    ncomp = _components_per_label_numba(comp, lab)
    present = np.flatnonzero(counts)
    lo, hi = lo[present], hi[present]
    df = pd.DataFrame({
        "label": present.astype(np.int64), "vertices": counts[present], "faces": nface[present],
        "area": area[present],
        "xmin": lo[:, 0], "ymin": lo[:, 1], "zmin": lo[:, 2], "xmax": hi[:, 0], "ymax": hi[:, 1],
        "zmax": hi[:, 2], "components": ncomp[present]})
    if names is not None:
        df.insert(1, "name", [str(names.get(int(k), "")) for k in present])
    if colors is not None:
        rgba = colors.rgba[present]
        df["r"], df["g"], df["b"] = rgba[:, 0], rgba[:, 1], rgba[:, 2]
    return df

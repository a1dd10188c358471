"""The headless half of ``plantvr segment`` (spec 000_vine §1.5, checklist items 1–3, 24, 27; issue 14): paint a
scripted demo on a :class:`~plantvr.documents.labels.Segmentation` (opening the source is
:func:`plantvr.io.source.open_source`, because reading files is the io layer's).

The browser half (the trame review page, :mod:`plantvr.view.vine_app`, and ``main_segment``,
:mod:`plantvr.view.vine_cli`) lives in the view layer, because
documents never import UI code (import-linter layers contract).
"""
from __future__ import annotations


import numpy as np

from plantvr._validation import check_int
from plantvr.documents.labels import Segmentation

__all__ = ["paint_demo"]


def paint_demo(seg: Segmentation, *, truth: np.ndarray | None = None, stamps: int = 24,
               rng: int | np.random.Generator | None = 0) -> int:
    """Paint a scripted demo through the sphere brush (each stamp one undoable operation).

    With ground truth, every stamp is centred on a vertex of one component and painted in that component's
    label, so the result looks like a (partial) component segmentation; without, stamps of colours 1..12 go
    to random vertices.

    Parameters
    ----------
    seg : Segmentation
    truth : (V,) uint8 ndarray, optional
        Ground-truth label per vertex (labels must exist in the colour table).
    stamps : int
        Number of brush stamps, in [1, 100000].
    rng : int, numpy.random.Generator or None

    Returns
    -------
    int
        Number of vertices painted (non-zero labels afterwards).
    """
    stamps = check_int("stamps", stamps, 1, 100_000)
    rng = np.random.default_rng(rng)
    diag = float(np.linalg.norm(np.ptp(seg.vertices, axis=0)))
    if truth is not None:
        truth = np.asarray(truth)
        if truth.shape != (seg.n_vertices,):
            raise ValueError(f"truth must have shape ({seg.n_vertices},), got {truth.shape}")
        comps = [k for k in np.unique(truth) if 0 < k < len(seg.colors)]
    for i in range(stamps):
        if truth is not None and comps:
            k = int(comps[i % len(comps)])
            ids = np.nonzero(truth == k)[0]
            v = int(rng.choice(ids))
        else:
            k = 1 + i % (len(seg.colors) - 1)
            v = int(rng.integers(seg.n_vertices))
        seg.paint(seg.vertices[v].astype(np.float64), 0.035 * diag, k)
    return int(np.count_nonzero(seg.labels))

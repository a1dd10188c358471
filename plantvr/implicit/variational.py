"""Variational implicit surfaces (Turk & O'Brien; spec 003_implicit_sca §2.6, C-5).

``f(x) = sum_j w_j phi(|x - c_j|) + P(x)`` with ``phi(r) = r^3`` and linear P interpolates 0 on boundary constraints
and a positive value at interior constraints (``scipy.interpolate.RBFInterpolator``, kernel ``cubic``). It is mapped
to the library convention by ``F = clip(0.5 + gain f, 0, 1)``, so F = 0.5 exactly on the boundary constraints.
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import RBFInterpolator

from plantvr._validation import check_points, check_range

from .blobtree import Node

__all__ = ["Variational", "MAX_CONSTRAINTS"]

#: Most constraints (boundary + interior) of one surface: the RBF system is dense, (M + 4)^2 floats.
MAX_CONSTRAINTS = 10_000


class Variational(Node):
    """RBF surface through ``boundary`` points, with ``interior`` points inside.

    Parameters
    ----------
    boundary : (M, 3) float64 array_like
        Points on the surface (value 0).
    interior : (K, 3) float64 array_like
        Points inside (value ``interior_value`` > 0), K >= 1.
    interior_value : float
        Constraint value at interior points.
    gain : float
        Scale of ``f`` in the mapping ``F = clip(0.5 + gain f, 0, 1)``.
    margin : float
        Support box = constraint box grown by this fraction of its diagonal (F is 0 outside).

    References
    ----------
    .. [1] Kochhar 2010, §4.1 (variational curves and surfaces, ref [93]); Turk & O'Brien 1999 [EXT].
    """

    def __init__(self, boundary, interior, *, interior_value: float = 1.0, gain: float = 1.0, margin: float = 0.25):
        b = check_points("boundary", boundary, min_rows=4)
        i = check_points("interior", interior, min_rows=1)
        iv = check_range("interior_value", interior_value, 0.0, np.inf, low_open=True)
        self.gain = check_range("gain", gain, 0.0, np.inf, low_open=True)
        margin = check_range("margin", margin, 0.0, 10.0)
        if len(b) + len(i) > MAX_CONSTRAINTS:
            raise ValueError(f"boundary and interior must hold at most {MAX_CONSTRAINTS} points together, got "
                             f"{len(b) + len(i)}")
        centres = np.vstack([b, i])
        if len(np.unique(centres, axis=0)) != len(centres):
            raise ValueError("boundary and interior must not repeat a point (the RBF system would be singular)")
        values = np.r_[np.zeros(len(b)), np.full(len(i), iv)]
        try:
            self.rbf = RBFInterpolator(centres, values, kernel="cubic", degree=1)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise ValueError(f"boundary and interior give a singular RBF system (coplanar or degenerate "
                             f"points?): {exc}") from None
        lo, hi = centres.min(axis=0), centres.max(axis=0)
        pad = margin * float(np.linalg.norm(hi - lo))
        self.bbox = np.array([lo - pad, hi + pad])

    def _eval_inside(self, p, backend):
        return np.clip(0.5 + self.gain * self.rbf(p), 0.0, 1.0)

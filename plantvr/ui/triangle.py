"""Influence triangle: a draggable point whose barycentric coordinates are (H, T, E) (spec 000_treewand §4.9,
checklist item 28, TW-V11).

The corner of each influence is labelled; the sub-triangle opposite a corner (P with the other two
corners) is filled in that influence's colour, so its area / the triangle's area is that influence's weight.
The widget keeps no state beyond its synced ``weights`` trait, which is two-way linked to
``model.w_heading``, ``model.w_tropism`` and ``model.w_env`` through ``model.set_influence``.
"""
from __future__ import annotations

import math

import anywidget
import numpy as np
import traitlets

from .._validation import MAX_COORD, check_array, check_range
from ._assets import asset
from ._sync import SyncGuard

__all__ = ["CORNERS", "COLORS", "LABELS", "barycentric", "clamp_to_triangle", "point_from_weights",
           "sub_triangle_areas", "InfluenceTriangle"]

#: Corners in triangle units (y up): heading top, tropism bottom-left, environment bottom-right.
CORNERS = np.array([[0.5, math.sqrt(3) / 2], [0.0, 0.0], [1.0, 0.0]])
#: Fill colour of each influence (corner order H, T, E) — red, blue, green (§4.9 [INFERRED], corners labelled).
COLORS = ("#e0443a", "#3a6fe0", "#3aa845")
LABELS = ("H heading", "T tropism", "E environment")


def _points(name: str, value, width: int) -> tuple[np.ndarray, bool]:
    """Check one point ``(width,)`` or many ``(N, width)``; return ``(N, width)`` and whether it was one."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numbers of shape ({width},) or (N, {width}), got {value!r}") from None
    if arr.ndim == 1:
        return check_array(name, arr, shape=(width,), max_abs=MAX_COORD).reshape(1, width), True
    return check_array(name, arr, shape=(None, width), max_abs=MAX_COORD), False


def _area2(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Twice the signed area of triangles (a, b, c); arrays broadcast over leading axes."""
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])


def barycentric(p, corners=CORNERS) -> np.ndarray:
    """Barycentric coordinates of 2-D points (unclamped; negative outside).

    Parameters
    ----------
    p : (2,) or (N, 2) float array-like
        Points in the triangle's plane.
    corners : (3, 2) float array-like
        Triangle corners in (H, T, E) order.

    Returns
    -------
    (3,) or (N, 3) float64 ndarray
        Coordinate of corner X = signed area(P, other two corners) / area(triangle); they sum to 1.

    References
    ----------
    .. [1] Tree Wand thesis §11.4.4, Fig. 11.7; spec 000_treewand §4.9.
    """
    c = check_array("corners", corners, shape=(3, 2))
    pts, single = _points("p", p, 2)
    total = _area2(c[0], c[1], c[2])
    if abs(total) < 1e-300:
        raise ValueError("corners must span a triangle of non-zero area")
    w = np.stack([_area2(pts, c[1], c[2]), _area2(c[0], pts, c[2]), _area2(c[0], c[1], pts)], axis=-1) / total
    return w[0] if single else w


def point_from_weights(weights, corners=CORNERS) -> np.ndarray:
    """The point whose barycentric coordinates are ``weights`` (normalised to sum 1 first).

    Parameters
    ----------
    weights : (3,) or (N, 3) float array-like
        (H, T, E), non-negative, not all 0.
    corners : (3, 2) float array-like

    Returns
    -------
    (2,) or (N, 2) float64 ndarray
    """
    c = check_array("corners", corners, shape=(3, 2))
    w, single = _points("weights", weights, 3)
    if np.any(w < 0):
        raise ValueError(f"weights must be >= 0, got {w[np.any(w < 0, axis=1)][0].tolist()}")
    s = w.sum(1, keepdims=True)
    if np.any(s <= 0):
        raise ValueError("weights must not all be 0")
    out = (w / s) @ c
    return out[0] if single else out


def _closest_on_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(((p - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return a + t[:, None] * ab


def clamp_to_triangle(p, corners=CORNERS) -> np.ndarray:
    """Nearest point of the (closed) triangle to each 2-D point: inside points are returned unchanged.

    Parameters
    ----------
    p : (2,) or (N, 2) float array-like
    corners : (3, 2) float array-like

    Returns
    -------
    (2,) or (N, 2) float64 ndarray
        Points whose barycentric coordinates are all >= 0 (up to rounding).
    """
    c = check_array("corners", corners, shape=(3, 2))
    pts, single = _points("p", p, 2)
    pts = pts.copy()
    w = barycentric(pts, c)
    out = np.all(w >= 0, axis=1)
    if not out.all():
        q = pts[~out]
        cand = np.stack([_closest_on_segment(q, c[i], c[(i + 1) % 3]) for i in range(3)])  # (3, K, 2)
        d = np.linalg.norm(cand - q[None], axis=2)
        pts[~out] = cand[np.argmin(d, axis=0), np.arange(len(q))]
    return pts[0] if single else pts


def sub_triangle_areas(p, corners=CORNERS) -> np.ndarray:
    """Areas of the three coloured sub-triangles (P with the edge opposite each corner), corner order.

    Parameters
    ----------
    p : (2,) float array-like
        The (clamped) point.
    corners : (3, 2) float array-like

    Returns
    -------
    (3,) float64 ndarray
        Unsigned areas; divided by the triangle's area they are the weights (TW-V11).
    """
    c = check_array("corners", corners, shape=(3, 2))
    q = check_array("p", p, shape=(2,), max_abs=MAX_COORD)
    return 0.5 * np.abs(np.array([_area2(q, c[1], c[2]), _area2(c[0], q, c[2]), _area2(c[0], c[1], q)]))


class InfluenceTriangle(anywidget.AnyWidget):
    """Draggable influence triangle bound to a model's (H, T, E) (spec 000_treewand §4.9).

    Parameters
    ----------
    model : plantvr.Model, optional
        The model to link two-way; without one the widget is free-standing (``weights`` only).

    Attributes
    ----------
    weights : list of 3 float
        (H, T, E), synced with the browser; setting it (from the browser or Python) calls
        ``model.set_influence``, which normalises and validates.
    """

    _esm = asset("influence_triangle.js")
    _css = asset("influence_triangle.css")
    weights = traitlets.List(traitlets.Float(), default_value=[1 / 3, 1 / 3, 1 / 3],
                             minlen=3, maxlen=3).tag(sync=True)
    corners = traitlets.List(traitlets.List(traitlets.Float()),
                             default_value=CORNERS.tolist()).tag(sync=True)
    colors = traitlets.List(traitlets.Unicode(), default_value=list(COLORS)).tag(sync=True)
    labels = traitlets.List(traitlets.Unicode(), default_value=list(LABELS)).tag(sync=True)
    error = traitlets.Unicode("").tag(sync=True)

    def __init__(self, model=None, **kwargs):
        super().__init__(**kwargs)
        self.model = model
        self._busy = SyncGuard()
        if model is not None:
            self.weights = list(model.influence)
            model.observe(self._from_model, names=["w_heading", "w_tropism", "w_env"])
        self.observe(self._to_model, names=["weights"])

    def _from_model(self, change) -> None:
        if self._busy:
            return
        with self._busy:
            self.weights = [float(v) for v in self.model.influence]

    def _to_model(self, change) -> None:
        if self._busy or self.model is None:
            return
        with self._busy:
            try:
                self.model.set_influence(*change["new"])
                self.error = ""
            except ValueError as exc:  # keep the model; show the reason, snap the point back
                self.error = str(exc)
        self._from_model(None)

    def set_weights(self, H: float, T: float, E: float) -> None:
        """Set (H, T, E) (normalised by the model), as the browser would."""
        self.weights = [check_range(n, v, 0.0, math.inf) for n, v in (("H", H), ("T", T), ("E", E))]

    @property
    def point(self) -> np.ndarray:
        """(2,) point of the current weights in triangle units."""
        return point_from_weights(self.weights, self.corners)

    def close(self) -> None:
        """Unlink from the model and close the comm."""
        if self.model is not None:
            self.model.unobserve(self._from_model, names=["w_heading", "w_tropism", "w_env"])
        super().close()

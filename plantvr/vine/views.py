"""Quaternions, model-space brush transform and saved views (spec 000_vine §2.3, §2.4.3; checklist item 9).

World up is +y (OpenVR). A saved view keeps only the viewer's horizontal facing, plus the model scale.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantvr._validation import check_array, check_point, check_range

__all__ = [
    "SavedView",
    "load_view",
    "quat_conj",
    "quat_from_axis_angle",
    "quat_mul",
    "quat_rotate",
    "quat_to_matrix",
    "save_view",
    "world_to_model",
]


def _check_quat(name, q) -> np.ndarray:
    q = check_array(name, q, shape=(4,))
    n = np.linalg.norm(q)
    if not 0.5 < n < 2.0:
        raise ValueError(f"{name} must be a unit quaternion (w, x, y, z), got norm {n:.3g}")
    return q / n


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` of (w, x, y, z) quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (inverse of a unit quaternion)."""
    return np.array([q[0], -q[1], -q[2], -q[3]])


def quat_from_axis_angle(axis, angle: float) -> np.ndarray:
    """Unit quaternion ``[cos θ/2, sin θ/2 · â]`` (spec §2.1.3 reading of the thesis's ``[θ/2, r]``)."""
    a = check_point("axis", axis)
    n = np.linalg.norm(a)
    if n == 0:
        raise ValueError("axis must be non-zero, got (0, 0, 0)")
    h = 0.5 * float(angle)
    return np.concatenate([[np.cos(h)], np.sin(h) * a / n])


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(3, 3) rotation matrix of a unit quaternion."""
    w, x, y, z = np.asarray(q, np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vector(s) ``v`` (3,) or (N, 3) by unit quaternion ``q``."""
    return np.asarray(v, np.float64) @ quat_to_matrix(q).T


def world_to_model(center, radius: float, *, position, rotation, scale: float) -> tuple[np.ndarray, float]:
    """Brush centre and radius in model space: ``C_m = R⁻¹(C − P)/s``, ``R_m = R/s``.

    Parameters
    ----------
    center : (3,) float
        Brush centre in world space.
    radius : float
        Brush radius in world units, >= 0.
    position : (3,) float
        Model position P.
    rotation : (4,) float
        Model orientation, unit quaternion (w, x, y, z).
    scale : float
        Uniform model scale s > 0.

    Returns
    -------
    center_model : (3,) float64 ndarray
    radius_model : float

    References
    ----------
    .. [1] Spec 000_vine §2.4.3 [INFERRED]: the brush test of Eq. 5.16 in model space.
    """
    c = check_point("center", center)
    r = check_range("radius", radius, 0.0, np.inf, high_open=True)
    p = check_point("position", position)
    q = _check_quat("rotation", rotation)
    s = check_range("scale", scale, 0.0, np.inf, low_open=True, high_open=True)
    return quat_to_matrix(q).T @ (c - p) / s, r / s


def _yaw_matrix(view_dir) -> np.ndarray:
    d = check_point("view_dir", view_dir)
    h = np.array([d[0], 0.0, d[2]])
    n = np.linalg.norm(h)
    if n < 1e-9:
        raise ValueError("view_dir must not be vertical: its horizontal part is zero")
    h /= n
    theta = np.arctan2(h[0], h[2])
    a = np.pi - theta                                      # ERRATUM A.7: R_y(pi - theta) maps d to -z
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass(frozen=True)
class SavedView:
    """A view relative to the saver's yaw-only frame (spec §2.3, corrected Eqs. 5.12–5.14).

    Attributes
    ----------
    position : (3,) float64 ndarray
        ``P_saved = R_view (P − V)``.
    rotation : (3, 3) float64 ndarray
        ``R_saved = R_view R_mesh``.
    scale : float
        Model scale (saved too, spec §2.3 [INFERRED gap]).
    """

    position: np.ndarray
    rotation: np.ndarray
    scale: float

    def to_array(self) -> np.ndarray:
        """(13,) float64: position, row-major rotation, scale."""
        return np.concatenate([self.position, self.rotation.ravel(), [self.scale]])

    @classmethod
    def from_array(cls, a) -> SavedView:
        """Inverse of :meth:`to_array`; raises ``ValueError`` on malformed input."""
        a = check_array("view", a, shape=(13,))
        R = a[3:12].reshape(3, 3)
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6):
            raise ValueError("view rotation must be orthonormal")
        check_range("view scale", a[12], 0.0, np.inf, low_open=True, high_open=True)
        return cls(a[:3].copy(), R.copy(), float(a[12]))


def save_view(model_position, model_rotation, model_scale: float, *, viewer_position, view_dir) -> SavedView:
    """Save the model pose relative to the viewer's horizontal facing (thesis Eq. 5.13, corrected).

    Parameters
    ----------
    model_position : (3,) float
    model_rotation : (3, 3) float ndarray or (4,) unit quaternion
    model_scale : float
    viewer_position : (3,) float
        V, e.g. the eye midpoint.
    view_dir : (3,) float
        Head forward direction; only its horizontal part is used (roll and pitch ignored).

    Returns
    -------
    SavedView

    References
    ----------
    .. [1] Thesis Eqs. 5.12–5.13; ERRATA A.7 (``R_y(π − θ)``) and A.8 (``R_view (P − V)``).
    """
    P = check_point("model_position", model_position)
    Rm = _rot(model_rotation)
    s = check_range("model_scale", model_scale, 0.0, np.inf, low_open=True, high_open=True)
    V = check_point("viewer_position", viewer_position)
    Rv = _yaw_matrix(view_dir)
    return SavedView(Rv @ (P - V), Rv @ Rm, s)               # ERRATUM A.8


def load_view(view: SavedView, *, viewer_position, view_dir) -> tuple[np.ndarray, np.ndarray, float]:
    """Place the model for a (possibly different) viewer: ``P = V' + R'⁻¹ P_saved``, ``R = R'⁻¹ R_saved``.

    Returns
    -------
    position : (3,) float64 ndarray
    rotation : (3, 3) float64 ndarray
    scale : float

    References
    ----------
    .. [1] Thesis Eq. 5.14, corrected (spec §2.3).
    """
    V = check_point("viewer_position", viewer_position)
    Rv = _yaw_matrix(view_dir)
    return V + Rv.T @ view.position, Rv.T @ view.rotation, view.scale


def _rot(r) -> np.ndarray:
    r = np.asarray(r, np.float64)
    if r.shape == (4,):
        return quat_to_matrix(_check_quat("model_rotation", r))
    r = check_array("model_rotation", r, shape=(3, 3))
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-6):
        raise ValueError("model_rotation must be an orthonormal (3, 3) matrix or a unit quaternion")
    return r

"""Quaternion and rigid-transform helpers for the headset (spec 000_vine §2.1, §2.3; 000_treewand §4.2).

Quaternions are ``(w, x, y, z)`` float64 arrays (scalar first, unit length); matrices act on column
vectors; OpenVR's ``HmdMatrix34_t``/``HmdMatrix44_t`` rows are read into 4x4 numpy arrays.
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "gl_projection",
    "hmd34_to_array",
    "hmd44_to_array",
    "quat_conj",
    "quat_from_axis_angle",
    "quat_from_matrix",
    "quat_mul",
    "quat_rotate",
    "quat_to_matrix",
    "similarity",
]

_EPS = 1e-12


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` of two ``(w, x, y, z)`` quaternions."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion)."""
    return np.array([q[0], -q[1], -q[2], -q[3]])


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate the 3-vector ``v`` by the unit quaternion ``q`` (``q v q⁻¹``)."""
    return quat_to_matrix(q) @ np.asarray(v, float)


def quat_from_axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Unit quaternion of a rotation by ``angle`` radians about ``axis`` (identity for a null axis)."""
    axis = np.asarray(axis, float)
    n = np.linalg.norm(axis)
    if n < _EPS:
        return np.array([1.0, 0.0, 0.0, 0.0])
    s = np.sin(0.5 * angle) / n
    return np.array([np.cos(0.5 * angle), axis[0] * s, axis[1] * s, axis[2] * s])


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """3x3 rotation matrix of a unit quaternion."""
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def quat_from_matrix(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (w >= 0) of a 3x3 rotation matrix (Shepperd's method)."""
    r = np.asarray(r, float)[:3, :3]
    t = np.trace(r)
    if t > 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = np.array([0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s])
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(max(1.0 + r[i, i] - r[j, j] - r[k, k], _EPS))
        q = np.empty(4)
        q[0] = (r[k, j] - r[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (r[j, i] + r[i, j]) / s
        q[1 + k] = (r[k, i] + r[i, k]) / s
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def hmd34_to_array(m) -> np.ndarray:
    """4x4 pose matrix from an OpenVR ``HmdMatrix34_t`` (anything with ``.m`` indexable [3][4])."""
    out = np.eye(4)
    out[:3, :] = [[float(m.m[i][j]) for j in range(4)] for i in range(3)]
    return out


def hmd44_to_array(m) -> np.ndarray:
    """4x4 matrix from an OpenVR ``HmdMatrix44_t``."""
    return np.array([[float(m.m[i][j]) for j in range(4)] for i in range(4)])


def similarity(scale: float, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """4x4 matrix of ``x -> scale * R x + t``."""
    out = np.eye(4)
    out[:3, :3] = scale * np.asarray(rotation, float)
    out[:3, 3] = translation
    return out


def gl_projection(openvr_projection: np.ndarray, near: float, far: float) -> np.ndarray:
    """OpenGL (clip z in [-1, 1]) projection with OpenVR's x/y rows and the given clipping planes.

    OpenVR's ``GetProjectionMatrix`` maps depth to [0, 1] (Direct3D style); VTK expects OpenGL's
    [-1, 1]. The x, y and w rows do not depend on that convention and are kept.
    """
    p = np.array(openvr_projection, float, copy=True)
    p[2] = [0.0, 0.0, -(far + near) / (far - near), -2.0 * far * near / (far - near)]
    p[3] = [0.0, 0.0, -1.0, 0.0]
    return p

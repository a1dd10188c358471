"""The viewing ray of a page position for the ViNE review page's server-side picking (issue 14).

The page orbits in the browser and sends its vtk.js camera with each click or drag position;
:func:`camera_ray` turns them into the ray that :meth:`~plantvr.view.vine_app.VineReviewApp.pick_display`
casts against the drawn display proxy.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import check_array, check_range

__all__ = ["camera_ray"]


def camera_ray(camera: dict, x: float, y: float, size) -> tuple[np.ndarray, np.ndarray]:
    """The viewing ray through a canvas position for a vtk.js (or VTK) camera.

    Parameters
    ----------
    camera : dict
        ``position``, ``focalPoint``, ``viewUp`` (3 floats each), ``viewAngle`` (vertical, degrees) and, for a
        parallel projection, ``parallelProjection: true`` and ``parallelScale`` (half the view height).
    x, y : float
        Position in CSS pixels from the canvas's top-left corner (y down).
    size : (2,) float
        Canvas width and height in CSS pixels, each > 0.

    Returns
    -------
    origin, direction : (3,) float64 ndarrays
        Eye (perspective) or a point on the view plane behind the scene (parallel); unit direction.
    """
    if not isinstance(camera, dict):
        raise ValueError(f"camera must be a dict, got {type(camera).__name__}")  # noqa: TRY004
    pos = check_array("position", camera.get("position"), shape=(3,), dtype=np.float64)
    fp = check_array("focalPoint", camera.get("focalPoint"), shape=(3,), dtype=np.float64)
    up = check_array("viewUp", camera.get("viewUp"), shape=(3,), dtype=np.float64)
    w, h = check_array("size", size, shape=(2,), dtype=np.float64)
    if not (w > 0 and h > 0):
        raise ValueError(f"size must be positive, got {(w, h)}")
    x = check_range("x", x, -1e7, 1e7)
    y = check_range("y", y, -1e7, 1e7)
    f = fp - pos
    dist = float(np.linalg.norm(f))
    if dist == 0:
        raise ValueError("camera position and focalPoint coincide")
    f /= dist
    right = np.cross(f, up)
    if np.linalg.norm(right) == 0:
        raise ValueError("camera viewUp is parallel to the view direction")
    right /= np.linalg.norm(right)
    upv = np.cross(right, f)
    u, v = 2.0 * x / w - 1.0, 1.0 - 2.0 * y / h                    # normalised device coordinates
    if camera.get("parallelProjection"):
        s = check_range("parallelScale", camera.get("parallelScale"), 0.0, 1e12, low_open=True)
        origin = pos + s * (u * (w / h) * right + v * upv)
        return origin, f
    half = np.tan(np.radians(check_range("viewAngle", camera.get("viewAngle", 30.0), 0.0, 180.0,
                                         low_open=True, high_open=True)) / 2)
    d = f + half * (u * (w / h) * right + v * upv)
    return pos.copy(), d / np.linalg.norm(d)

"""3D view of the shared model with pyvista (offscreen, desktop or JupyterLab through trame) (spec 000_treewand §4.12).

One actor per kind of content: branches, markers, brush, prune preview. The view only reads
:attr:`plantvr.Model.snapshot` and redraws when ``model.version`` changes; it owns no model state.
"""
from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

from ..model import Model, Snapshot  # noqa: E402

__all__ = ["View", "branch_mesh"]

BARK = "#8b5a2b"
GROW, PRUNE = "#2ecc40", "#e03030"


def branch_mesh(snap: Snapshot, sides: int = 10) -> pv.PolyData:
    """Tube mesh of a snapshot's internodes, radius per internode (VTK tube filter on line segments)."""
    if snap.n_internodes == 0:
        return pv.PolyData()
    kids = np.flatnonzero(snap.parent >= 0)
    pts = np.concatenate([snap.pos[snap.parent[kids]], snap.pos[kids]])
    k = len(kids)
    lines = np.column_stack([np.full(k, 2), np.arange(k), np.arange(k) + k]).ravel()
    poly = pv.PolyData(pts, lines=lines)
    poly["radius"] = np.concatenate([snap.radius[kids], snap.radius[kids]])
    poly["order"] = np.concatenate([snap.order[kids], snap.order[kids]])
    return poly.tube(scalars="radius", absolute=True, n_sides=sides, capping=True)


class View:
    """A pyvista plotter showing ``model``: branches, markers and the brush.

    Parameters
    ----------
    model : plantvr.Model
        The shared model to observe.
    off_screen : bool, optional
        Render without a window (default: True when no display is available).
    window_size : (int, int)
        Pixels.
    """

    def __init__(self, model: Model, *, off_screen: bool | None = None, window_size=(900, 700),
                 show_markers: bool = True):
        if off_screen is None:
            off_screen = not os.environ.get("DISPLAY")
        self.model = model
        self.plotter = pv.Plotter(off_screen=off_screen, window_size=window_size)
        self.plotter.set_background("#f4f1ea", top="#cfe3f5")
        self._branches = pv.PolyData()
        self._markers = pv.PolyData()
        self._drawn = -1
        self.brush_center = np.zeros(3)
        self.brush_radius = model.brush_radius
        self._brush = pv.Sphere(radius=1.0, theta_resolution=24, phi_resolution=16)
        ground = pv.Disc(inner=0, outer=8, normal=(0, 1, 0), c_res=48)
        self.plotter.add_mesh(ground, color="#9cb37a", name="ground", pickable=False)
        self._brush_actor = self.plotter.add_mesh(self._brush, color=GROW, opacity=0.25, name="brush",
                                                  pickable=False)
        self._brush_actor.SetVisibility(False)
        model.observe(self._on_change, names=["version"])
        model.observe(self._on_mode, names=["prune_mode"])
        self.update()
        self.frame()

    def frame(self) -> None:
        """Point the camera at the whole tree (and markers) from a three-quarter view."""
        snap = self.model.snapshot
        pts = np.concatenate([snap.pos, snap.markers]) if len(snap.markers) else snap.pos
        lo, hi = pts.min(0), pts.max(0)
        c, size = 0.5 * (lo + hi), max(float(np.max(hi - lo)), 2.0)
        self.plotter.camera_position = [tuple(c + size * np.array([1.3, 0.45, 1.3])), tuple(c), (0, 1, 0)]

    def _on_change(self, change) -> None:
        self.update()

    def _on_mode(self, change) -> None:
        self._brush_actor.GetProperty().SetColor(pv.Color(PRUNE if change["new"] else GROW).float_rgb)
        self.plotter.render()

    def update(self) -> None:
        """Redraw from the latest snapshot if it changed (actors are updated in place, not re-added)."""
        snap = self.model.snapshot
        if snap.version == self._drawn:
            return
        self._drawn = snap.version
        mesh = branch_mesh(snap)
        if mesh.n_points:
            first = self._branches.n_points == 0
            self._branches.copy_from(mesh)
            if first:
                self.plotter.add_mesh(self._branches, color=BARK, smooth_shading=True, name="branches")
        if len(snap.markers):
            first = self._markers.n_points == 0
            self._markers.copy_from(pv.PolyData(np.asarray(snap.markers, float)))
            if first:
                self.plotter.add_mesh(self._markers, color="#f5d142", point_size=4, render_points_as_spheres=True,
                                      name="markers", pickable=False)
        elif self._markers.n_points:
            self._markers.copy_from(pv.PolyData(np.zeros((1, 3))))
        self.plotter.render()

    def set_brush(self, center, radius: float | None = None, visible: bool = True) -> None:
        """Place the brush sphere (green to grow, red to prune)."""
        self.brush_center = np.asarray(center, float)
        if radius is not None:
            self.brush_radius = float(radius)
        self._brush.copy_from(pv.Sphere(radius=self.brush_radius, center=self.brush_center,
                                        theta_resolution=24, phi_resolution=16))
        self._brush_actor.SetVisibility(visible)
        self.plotter.render()

    def screenshot(self, path: str | Path | None = None, *, window_size=None) -> np.ndarray:
        """Render offscreen and return the image (and write a PNG when ``path`` is given)."""
        self.update()
        return self.plotter.screenshot(str(path) if path else None, window_size=window_size, return_img=True)

    def show(self, jupyter_backend: str = "trame", **kwargs):
        """Show in JupyterLab (trame: ``"trame"`` remote-rendered, ``"client"``, ``"server"``) or a window."""
        return self.plotter.show(jupyter_backend=jupyter_backend, auto_close=False, **kwargs)

    def close(self) -> None:
        """Stop observing the model and free the render window."""
        self.model.unobserve(self._on_change, names=["version"])
        self.model.unobserve(self._on_mode, names=["prune_mode"])
        self.plotter.close()

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

from .._fileio import write_png  # noqa: E402
from .._validation import check_point, check_range, check_size  # noqa: E402
from ..documents.treewand import Model, Snapshot  # noqa: E402
from ..params import PARAMS  # noqa: E402
from ..export import IncrementalTreeGeometry  # noqa: E402

__all__ = ["View", "branch_mesh"]

BARK = "#8b5a2b"
GROW, PRUNE = "#2ecc40", "#e03030"
LEAF = "#4f8a2f"


def _poly(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray | None = None) -> pv.PolyData:
    poly = pv.PolyData(np.asarray(vertices, float), np.column_stack([np.full(len(faces), 3), faces]).ravel())
    if normals is not None:
        poly.point_data["Normals"] = normals
    return poly


def branch_mesh(snap: Snapshot, params: dict | None = None, *, leaves: bool = False,
                sides: int | None = None) -> tuple[pv.PolyData, pv.PolyData]:
    """Generalized-cylinder branches and leaves of a snapshot as pyvista meshes (spec 000_treewand §3).

    ``sides`` fixes the ring subdivisions of every branch (e.g. a cheap headset mesh); by default
    they follow the radius LOD (6 at the tip radius to 32 at 50×).
    """
    from ..export import tree_geometry  # noqa: PLC0415
    params = params or {p.name: p.default for p in PARAMS}
    if snap.n_internodes == 0:
        return pv.PolyData(), pv.PolyData()
    b, leaf = tree_geometry(snap, params, leaves=leaves, lod=(sides, sides) if sides else (6, 32))
    return _poly(b.vertices, b.faces, b.normals), (_poly(leaf.vertices, leaf.faces) if leaf is not None
                                                   else pv.PolyData())


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
                 show_markers: bool = True, show_leaves: bool = True):
        if not isinstance(model, Model):
            raise TypeError(f"model must be a plantvr.Model, got {type(model).__name__}")
        window_size = _check_window_size(window_size)
        if off_screen is None:
            off_screen = not os.environ.get("DISPLAY")
        self.model = model
        self.plotter = pv.Plotter(off_screen=off_screen, window_size=window_size)
        self.plotter.set_background("#f4f1ea", top="#cfe3f5")
        self._branches = pv.PolyData()
        self._leaves = pv.PolyData()
        self.show_leaves = show_leaves
        self.show_markers = show_markers
        self._marker_actor = None
        self._geometry = IncrementalTreeGeometry(leaves=show_leaves)
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
        mesh, leaves = self._meshes(snap)
        for target, new, kw in ((self._branches, mesh, dict(color=BARK, name="branches")),
                                (self._leaves, leaves, dict(color=LEAF, name="leaves"))):
            first = target.n_points == 0
            if new.n_points:
                target.copy_from(new)
                if first:
                    self.plotter.add_mesh(target, smooth_shading=True, **kw)
        if len(snap.markers):
            first = self._markers.n_points == 0
            self._markers.copy_from(pv.PolyData(np.asarray(snap.markers, float)))
            if first:
                self._marker_actor = self.plotter.add_mesh(
                    self._markers, color="#f5d142", point_size=4, render_points_as_spheres=True, name="markers",
                    pickable=False)
        if self._marker_actor is not None:
            self._marker_actor.SetVisibility(bool(len(snap.markers)) and self.show_markers)
        self.plotter.render()

    def _meshes(self, snap: Snapshot) -> tuple[pv.PolyData, pv.PolyData]:
        """Branch and leaf meshes of ``snap``, re-meshing only the segments and buds that changed."""
        if snap.n_internodes == 0:
            self._geometry = IncrementalTreeGeometry(leaves=self.show_leaves)
            return pv.PolyData(), pv.PolyData()
        g = self._geometry
        g.update(snap, self.model.params)
        b = g.branches
        leaves = g.leaf_mesh
        lv = _poly(leaves.vertices, leaves.faces) if leaves is not None and len(leaves.faces) else pv.PolyData()
        return _poly(b.vertices, b.faces, b.normals), lv

    def set_brush(self, center, radius: float | None = None, visible: bool = True) -> None:
        """Place the brush sphere (green to grow, red to prune)."""
        center = check_point("center", center)
        if radius is not None:
            radius = check_range("radius", radius, 0.0, 1e6, low_open=True)
        if not isinstance(visible, (bool, np.bool_)):
            raise TypeError(f"visible must be True or False, got {visible!r}")
        self.brush_center = center
        if radius is not None:
            self.brush_radius = radius
        self._brush.copy_from(pv.Sphere(radius=self.brush_radius, center=self.brush_center,
                                        theta_resolution=24, phi_resolution=16))
        self._brush_actor.SetVisibility(visible)
        self.plotter.render()

    def screenshot(self, path: str | Path | None = None, *, window_size=None) -> np.ndarray:
        """Render offscreen and return the image (and write a PNG atomically when ``path`` is given)."""
        if window_size is not None:
            window_size = _check_window_size(window_size)
        if path is not None and Path(path).suffix.lower() != ".png":
            raise ValueError(f"path must end in .png, got {str(path)!r}")
        self.update()
        img = self.plotter.screenshot(None, window_size=window_size, return_img=True)
        if path is not None:
            write_png(path, img)
        return img

    def show(self, jupyter_backend: str = "trame", **kwargs):
        """Show in JupyterLab (trame: ``"trame"`` remote-rendered, ``"client"``, ``"server"``) or a window."""
        return self.plotter.show(jupyter_backend=jupyter_backend, auto_close=False, **kwargs)

    def close(self) -> None:
        """Stop observing the model and free the render window."""
        self.model.unobserve(self._on_change, names=["version"])
        self.model.unobserve(self._on_mode, names=["prune_mode"])
        self.plotter.close()



def _check_window_size(window_size) -> tuple[int, int]:
    return check_size("window_size", window_size, 16, 16384)

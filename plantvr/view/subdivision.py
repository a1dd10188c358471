"""pyvista helpers for Yggdrasil meshes: control mesh and subdivided surface side by side (spec 001_subdivision §1.2, C16).

The numeric core (:mod:`plantvr.subdivision`) returns ``trimesh.Trimesh`` / :class:`ControlMesh` objects; this
module only turns them into ``pyvista.PolyData`` and draws them. Offscreen by default when there is no display
(``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow``); in JupyterLab call :meth:`SubdivisionView.show` for the
interactive (trame) view.
"""
from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np
import pyvista as pv

from .._fileio import write_png
from .._validation import check_array
from . import _check_window_size

__all__ = ["SubdivisionView", "checker_texture", "side_by_side", "textured_polydata", "to_polydata"]

BARK = "#a0703c"
CONTROL = "#d9c7a7"
EDGE = "#3b2a1a"


def to_polydata(mesh) -> pv.PolyData:
    """A triangle mesh as ``pyvista.PolyData`` (vertex order kept).

    Parameters
    ----------
    mesh : trimesh.Trimesh or ControlMesh or tuple of ndarray
        Anything with ``vertices`` (V, 3) and ``faces`` (F, 3) attributes, or a ``(vertices, faces)`` pair.

    Returns
    -------
    pyvista.PolyData
        Points are ``vertices`` as float64; one triangle cell per face.

    Raises
    ------
    ValueError
        If the vertices or faces are malformed.
    """
    if isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        V, F = mesh
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        V, F = mesh.vertices, mesh.faces
    else:
        raise ValueError(f"mesh must have vertices and faces or be a (vertices, faces) pair, "
                         f"got {type(mesh).__name__}")
    V = check_array("vertices", V, shape=(None, 3))
    F = check_array("faces", F, shape=(None, 3), dtype=np.int64)
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise ValueError(f"faces must index vertices in [0, {len(V) - 1}], got range [{F.min()}, {F.max()}]")
    cells = np.column_stack([np.full(len(F), 3, np.int64), F]).ravel()
    return pv.PolyData(np.array(V, dtype=float), cells)


def textured_polydata(vertices, faces, uv) -> pv.PolyData:
    """A mesh with per-corner UVs as ``PolyData`` with texture coordinates, one point per face corner.

    VTK stores one texture coordinate per point, so the corners are split for display only (spec §1.6: "vertices
    split at UV seams for display only"); never subdivide this copy.

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int ndarray
    uv : (F, 3, 2) float64 ndarray
        Corner UVs (e.g. :func:`plantvr.subdivision.control_uvs`).

    Returns
    -------
    pyvista.PolyData
        ``3 F`` points, ``F`` triangles, ``active_texture_coordinates`` set.
    """
    V = check_array("vertices", vertices, shape=(None, 3))
    F = check_array("faces", faces, shape=(None, 3), dtype=np.int64)
    T = check_array("uv", uv, shape=(len(F), 3, 2))
    poly = to_polydata((V[F].reshape(-1, 3), np.arange(3 * len(F)).reshape(-1, 3)))
    poly.active_texture_coordinates = T.reshape(-1, 2)
    return poly


def checker_texture(n: int = 8, size: int = 256) -> pv.Texture:
    """A repeating ``n`` x ``n`` checkerboard (with a stripe along v, like bark) for looking at UV maps."""
    y, x = np.mgrid[0:size, 0:size] * n // size
    img = np.where((x + y) % 2 == 0, 205, 120).astype(np.uint8)
    img[:, : size // (4 * n)] = 40                        # a dark stripe marks u = 0 (the seam)
    rgb = np.stack([img, (img * 0.8).astype(np.uint8), (img * 0.55).astype(np.uint8)], axis=-1)
    return pv.Texture(rgb)


class SubdivisionView:
    """Two linked 3D views: the control mesh (left, with edges) and the subdivided surface (right).

    Meshes are updated in place by :meth:`update`, so a live JupyterLab view (:meth:`show`) follows a
    slider or a text edit without re-adding actors.

    Parameters
    ----------
    control, surface : trimesh.Trimesh or ControlMesh or (V, F), optional
        Initial meshes (see :func:`to_polydata`).
    off_screen : bool, optional
        Render without a window; default True when there is no ``DISPLAY``.
    window_size : (int, int)
        Pixels of the whole two-panel window.
    titles : (str, str)
        Panel captions.
    """

    def __init__(self, control=None, surface=None, *, off_screen: bool | None = None,
                 window_size=(1000, 500), titles=("control mesh", "Loop subdivision")):
        window_size = _check_window_size(window_size)
        if off_screen is None:
            off_screen = not os.environ.get("DISPLAY")
        self.plotter = pv.Plotter(shape=(1, 2), off_screen=off_screen, window_size=list(window_size),
                                  border=False)
        self._control = pv.PolyData()
        self._surface = pv.PolyData()
        self._actors: dict[str, object] = {}
        self._titles = titles
        for col, title in enumerate(titles):
            self.plotter.subplot(0, col)
            self.plotter.set_background("#f4f1ea", top="#d6e6f5")
            self.plotter.add_text(title, font_size=11, color="#333333", name=f"title{col}")
        self.plotter.link_views()
        self._framed = False
        if control is not None or surface is not None:
            self.update(control, surface)

    def update(self, control=None, surface=None, *, reframe: bool = False) -> None:
        """Replace the control mesh and/or the subdivided surface (``None`` keeps the current one).

        Parameters
        ----------
        control, surface : trimesh.Trimesh or ControlMesh or (V, F), optional
            New meshes.
        reframe : bool
            Reset the camera to the new meshes (done automatically the first time).
        """
        new_c = to_polydata(control) if control is not None else None
        new_s = to_polydata(surface) if surface is not None else None
        for key, col, target, new, kw in (
                ("control", 0, self._control, new_c,
                 {"color": CONTROL, "show_edges": True, "edge_color": EDGE, "line_width": 1.0}),
                ("surface", 1, self._surface, new_s, {"color": BARK, "smooth_shading": True, "specular": 0.2})):
            if new is None:
                continue
            target.copy_from(new)
            if key not in self._actors:
                self.plotter.subplot(0, col)
                self._actors[key] = self.plotter.add_mesh(target, name=key, **kw)
        if reframe or not self._framed:
            self.frame()
        self.plotter.render()

    def frame(self) -> None:
        """Three-quarter view of both meshes (the views are linked, so one camera serves both)."""
        pts = [p.points for p in (self._control, self._surface) if p.n_points]
        if not pts:
            return
        P = np.concatenate(pts)
        lo, hi = P.min(0), P.max(0)
        c, size = 0.5 * (lo + hi), max(float(np.max(hi - lo)), 1e-6)
        self.plotter.subplot(0, 0)
        self.plotter.camera_position = [tuple(c + size * np.array([1.0, 0.3, 1.0])), tuple(c), (0, 1, 0)]
        self.plotter.reset_camera()          # keep the direction, fit the bounds
        self._framed = True

    @property
    def control(self) -> pv.PolyData:
        """The control mesh shown on the left (live; edited in place by :meth:`update`)."""
        return self._control

    @property
    def surface(self) -> pv.PolyData:
        """The subdivided surface shown on the right."""
        return self._surface

    def screenshot(self, path: str | Path | None = None) -> np.ndarray:
        """Render offscreen and return the (H, W, 3) uint8 image; also write a PNG when ``path`` is given."""
        if path is not None and Path(path).suffix.lower() != ".png":
            raise ValueError(f"path must end in .png, got {os.fspath(path)!r}")
        img = self.plotter.screenshot(None, return_img=True)
        if path is not None:
            write_png(path, img)
        return img

    def png(self) -> bytes:
        """The current picture as PNG bytes (for an ``ipywidgets.Image``)."""
        import io

        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(self.screenshot()).save(buf, format="PNG")
        return buf.getvalue()

    def show(self, **kw):
        """Show the interactive view (trame in JupyterLab, a window on a desktop); see ``pyvista.Plotter.show``."""
        return self.plotter.show(**kw)

    def close(self) -> None:
        """Release the render window."""
        self.plotter.close()


def side_by_side(control, surface, *, off_screen: bool | None = None, window_size=(1000, 500)) -> SubdivisionView:
    """Control mesh and subdivided surface in two linked panels (spec 001 C16).

    Parameters
    ----------
    control, surface : trimesh.Trimesh or ControlMesh or (V, F)
        The meshes.
    off_screen : bool, optional
        See :class:`SubdivisionView`.
    window_size : (int, int)
        Pixels.

    Returns
    -------
    SubdivisionView
        Call ``.screenshot()`` headless or ``.show()`` in JupyterLab.
    """
    return SubdivisionView(control, surface, off_screen=off_screen, window_size=window_size)

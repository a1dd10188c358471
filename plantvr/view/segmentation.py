"""pyvista view of a ViNE segmentation (spec 000_vine §2.6, §4.4(b), §4.5): categorical colours through the
colour table, in-place per-vertex colour updates, hidden colours dropped from the index buffer, optional
shader-free depth cueing, saved-view application, offscreen screenshots.

The view observes a :class:`plantvr.documents.labels.Segmentation` (or its display proxy) through its
``change`` trait; it never edits labels.
"""
from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np
import pyvista as pv

from plantvr.documents.labels import Segmentation
from plantvr.vine.depthcue import coarse_hull, depth_cue_colors
from plantvr.vine.proxy import DisplayProxy
from plantvr.vine.views import SavedView, load_view

__all__ = ["SegmentationView"]


class SegmentationView:
    """Offscreen (or notebook) pyvista view of a segmentation.

    Parameters
    ----------
    seg : Segmentation
    plotter : pyvista.Plotter, optional
        Existing plotter; default a new ``Plotter(off_screen=True, window_size=window_size)``.
    window_size : tuple of 2 int
    culling : {"back", None}
        Back-face culling (spec §4.5; thesis §5.7.3).
    background : str or 3 floats
        Dark by default, so depth cueing darkens with distance.
    proxy : DisplayProxy, optional
        Draw this decimated proxy of ``seg`` instead of the full mesh (issue 14). Picking and painting still act
        on the full-resolution labels; the proxy's colours follow them by per-vertex deltas.

    Notes
    -----
    Colours are direct RGBA scalars (4 B/vertex), updated sparsely for the painted ids and re-uploaded by VTK
    (``Modified()``); a colour-table edit remaps all vertices once (spec §4.4(b)).
    """

    def __init__(self, seg: Segmentation, *, plotter: pv.Plotter | None = None, window_size=(900, 700),
                 culling: str | None = "back", background="black", proxy: DisplayProxy | None = None):
        if not isinstance(seg, Segmentation):
            raise ValueError(f"seg must be a Segmentation, got {type(seg).__name__}")  # noqa: TRY004
        if proxy is not None and (not isinstance(proxy, DisplayProxy) or proxy.seg is not seg):
            raise ValueError("proxy must be a DisplayProxy built from seg")
        self.seg = seg
        self.proxy = proxy
        src = self.src = seg if proxy is None else proxy       # what is drawn: full mesh or proxy
        self.plotter = plotter or pv.Plotter(off_screen=True, window_size=list(window_size))
        self.plotter.set_background(background)
        self.mesh = pv.PolyData.from_regular_faces(src.vertices, src.visible_faces().astype(np.int64))
        self._base_rgba = src.vertex_colors()
        self.mesh.point_data["rgba"] = self._base_rgba.copy()
        self.actor = self.plotter.add_mesh(self.mesh, scalars="rgba", rgb=True, culling=culling,
                                           smooth_shading=src.normals is not None, show_scalar_bar=False)
        if src.normals is not None:
            self.mesh.point_data["Normals"] = src.normals
            self.mesh.point_data.active_normals_name = "Normals"
        self.depth_cue = False
        self._hull = None
        self._brush = None
        self.updates = 0
        src.observe(self._on_change, names="change")
        self._observing = True

    # ------------------------------------------------------------------ model → view
    def _rgba_array(self) -> np.ndarray:
        return self.mesh.point_data["rgba"]

    def _on_change(self, event) -> None:
        kind, ids = event["new"].kind, event["new"].ids
        if kind not in ("labels", "colors", "visibility", "all") or (ids is not None and ids.size == 0):
            return                                         # saved views, or a stroke's end: nothing to draw
        if kind == "labels" and ids is not None and not self.depth_cue:
            rgba = self.src.colors.rgba[self.src.labels[ids]]
            self._base_rgba[ids] = rgba
            arr = self._rgba_array()
            arr[ids] = rgba                                # in place: pyvista marks the VTK array modified
            self.mesh.point_data.VTKObject.GetArray("rgba").Modified()
        else:
            self._base_rgba = self.src.vertex_colors()
            if kind in ("visibility", "all"):
                self.mesh.faces = pv.CellArray.from_regular_cells(self.src.visible_faces().astype(np.int64))
            self._refresh_colors()
        self.updates += 1

    def _refresh_colors(self) -> None:
        cols = self._base_rgba
        if self.depth_cue:
            eye = np.asarray(self.plotter.camera.position, np.float64)
            cols = depth_cue_colors(cols, self.src.vertices, self._model_eye(eye), self._get_hull(),
                                    background=(0, 0, 0))
        self._rgba_array()[:] = cols
        self.mesh.point_data.VTKObject.GetArray("rgba").Modified()

    def _model_eye(self, eye: np.ndarray) -> np.ndarray:
        m = np.asarray(self.actor.user_matrix, np.float64)
        return (np.linalg.inv(m) @ np.r_[eye, 1.0])[:3]

    def _get_hull(self):
        if self._hull is None:
            self._hull = coarse_hull(self.src.vertices)
        return self._hull

    def follow(self, buffer) -> None:
        """Read labels from a :class:`~plantvr.vine.buffers.TripleBuffer` instead of observing the segmentation.

        Use this when painting runs on a :class:`~plantvr.vine.buffers.PaintWorker`: the worker thread never
        touches VTK; the render side calls :meth:`poll` (``screenshot`` does) and takes the latest completed
        labels (spec §4.3).
        """
        self._unobserve()
        self._buffer = buffer
        self._buffer_version = -1

    def poll(self) -> bool:
        """Apply the newest completed label buffer, if any; returns whether the colours changed."""
        buf = getattr(self, "_buffer", None)
        if buf is None:
            return False
        labels, version = buf.acquire()
        try:
            if version == self._buffer_version:
                return False
            shown = labels if self.proxy is None else self.proxy.labels_from(labels)
            self._base_rgba = self.seg.colors.rgba[shown]
            self._buffer_version = version
        finally:
            buf.release()
        self._refresh_colors()
        self.updates += 1
        return True

    def paint_at(self, point, *, radius: float, label: int) -> int:
        """Paint at a picked world-space point (mouse picking): converts through the model transform."""
        m = np.asarray(self.actor.user_matrix, np.float64)
        s = float(np.cbrt(abs(np.linalg.det(m[:3, :3]))))
        c = (np.linalg.inv(m) @ np.r_[np.asarray(point, np.float64), 1.0])[:3]
        return self.seg.paint(c, float(radius) / s, label)

    def enable_mouse_painting(self, *, radius: float, label: int) -> None:
        """Paint with the sphere brush where the user clicks on the surface (desktop painting mode)."""
        self.brush_radius, self.brush_label = float(radius), int(label)
        self.plotter.enable_surface_point_picking(
            callback=lambda p: self.paint_at(p, radius=self.brush_radius, label=self.brush_label),
            show_point=False, show_message=False)

    # ------------------------------------------------------------------ commands
    def set_depth_cue(self, on: bool) -> None:
        """Toggle depth cueing (Eq. 5.8, p = 0.85, coarse-hull distances from the camera position)."""
        self.depth_cue = bool(on)
        self._base_rgba = self.src.vertex_colors()
        self._refresh_colors()

    def show_brush(self, center, radius: float, label: int, *, opacity: float = 0.35) -> None:
        """Draw the partially transparent brush sphere in the label's colour (spec §2.4.1 preview)."""
        label = self.seg.colors.check_label("label", label)
        if self._brush is not None:
            self.plotter.remove_actor(self._brush)
        sphere = pv.Sphere(radius=float(radius), center=np.asarray(center, float))
        self._brush = self.plotter.add_mesh(sphere, color=self.seg.colors.rgba[label, :3] / 255, opacity=opacity)
        self._brush.user_matrix = self.actor.user_matrix

    def hide_brush(self) -> None:
        """Remove the brush sphere."""
        if self._brush is not None:
            self.plotter.remove_actor(self._brush)
            self._brush = None

    def set_model_pose(self, position, rotation: np.ndarray, scale: float) -> None:
        """Set the model transform ``x ↦ P + s R x`` (rotation as a (3, 3) matrix)."""
        m = np.eye(4)
        m[:3, :3] = float(scale) * np.asarray(rotation, float)
        m[:3, 3] = np.asarray(position, float)
        self.actor.user_matrix = m
        if self._brush is not None:
            self._brush.user_matrix = m

    def apply_view(self, view: SavedView, *, viewer_position=None, view_dir=None) -> None:
        """Load a saved view for the current camera (its position and horizontal facing, Eq. 5.14 corrected)."""
        cam = self.plotter.camera
        V = np.asarray(cam.position if viewer_position is None else viewer_position, float)
        d = (np.asarray(cam.focal_point) - np.asarray(cam.position)) if view_dir is None else np.asarray(view_dir)
        P, R, s = load_view(view, viewer_position=V, view_dir=d)
        self.set_model_pose(P, R, s)

    def screenshot(self, path: str | os.PathLike | None = None) -> np.ndarray:
        """Render offscreen and return (H, W, 3) uint8; also writes a PNG when ``path`` is given."""
        if self.poll():
            pass
        elif self.depth_cue:
            self._refresh_colors()
        self.plotter.render()
        img = self.plotter.screenshot(None, return_img=True)
        if path is not None:                        # written atomically: a failed write keeps the old image
            import io

            from PIL import Image

            from plantvr._fileio import write_atomic
            p = os.fspath(path)
            ext = os.path.splitext(p)[1].lower()
            if not ext:
                p, ext = p + ".png", ".png"
            fmt = Image.registered_extensions().get(ext)
            if fmt is None:
                raise ValueError(f"path must end in an image suffix such as .png, got {p!r}")
            buf = io.BytesIO()
            Image.fromarray(img).save(buf, format=fmt)
            write_atomic(p, buf.getvalue())
        return img

    def close(self) -> None:
        """Stop observing and close the plotter."""
        self._unobserve()
        self.plotter.close()

    def _unobserve(self) -> None:
        if self._observing:
            self.src.unobserve(self._on_change, names="change")
            self._observing = False

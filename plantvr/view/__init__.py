"""One 3D view of any document with pyvista: offscreen, desktop, or JupyterLab through trame (spec 000_treewand
§4.12; issue 21).

:class:`View` draws a document's ``scene()`` (``{name: content}``) with one actor layer per entry, of the class
:mod:`plantvr.view.layers` picks for the content's type (tree arrays, triangle meshes, points, instances). It
observes ``doc.observe(..., names="change")`` and, on every :class:`~plantvr.document.Change`, redraws only the
layers whose content changed; it owns no document state. A view of a plain ``{name: content}`` mapping (a
mesh being edited in a notebook) is updated with :meth:`View.update`. Options fold in what were separate
views: ``lod`` for a forest (each tree at the level of detail of its camera distance, billboards beyond) and
``panels`` for linked side-by-side panels (a control mesh beside its subdivided surface, :func:`side_by_side`).
A ViNE segmentation is drawn by the layers of :mod:`plantvr.view.vine_layers` (a labelled surface that follows
its labels in place, volume slices), placed by a model pose (:meth:`View.set_model_pose`, saved views).
"""
from __future__ import annotations

import contextlib
import functools
import io
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

from .._fileio import write_png  # noqa: E402
from .._validation import check_array, check_point, check_range, check_size  # noqa: E402
from ..document import kernel_loop  # noqa: E402
from ..vine.views import SavedView, load_view  # noqa: E402
from ._render_lock import lock_plotter  # noqa: E402
from .billboard import lod_by_distance  # noqa: E402
from .live_server import launch_live_server  # noqa: E402
from .options import ViewOptions, check_bool  # noqa: E402
from .polydata import brush_sphere, ground_disc  # noqa: E402
from .layers import (  # noqa: E402
    LOD,
    InstancesLayer,
    Layer,
    LodTreeLayer,
    MeshLayer,
    TreeLayer,
    scene_layers,
    sync_layers,
    tree_buds,
)
from .vine_layers import LabelledSurfaceLayer  # noqa: E402

__all__ = ["LOD", "View", "launch_live_server", "side_by_side"]

GROW, PRUNE = "#2ecc40", "#e03030"
CONTROL = "#d9c7a7"
EDGE = "#3b2a1a"


class View:
    """A pyvista plotter showing a document (or a ``{name: content}`` scene), one actor layer per scene entry.

    Parameters
    ----------
    doc : Document or mapping
        A document (anything with ``scene()`` and traitlets ``observe``: ``plantvr.Model``, the TreeSketch, ViNE,
        crown, inflorescence and forest documents), observed for changes; or a static ``{name: content}``
        mapping, changed with :meth:`update`.
    off_screen : bool, optional
        Render without a window (default: True when no display is available).
    window_size : (int, int)
        Pixels of the whole window.
    show_markers : bool
        Show the scene entry ``"markers"``.
    show_leaves : bool
        Draw leaves on trees that come with bud slots (when the parameters give ``leaf_size`` > 0).
    ground : bool, optional
        A ground disc at y = 0; default on for a single-panel view whose scene has a tree, no surface (a terrain)
        and no ``lod``.
    lod : bool or LOD, optional
        Draw every tree at the level of detail of its camera distance (forests; True: default :class:`LOD`).
    panels : sequence of sequence of str, optional
        Scene names drawn in each of several side-by-side panels with linked cameras (names not listed go to the
        first panel).
    titles : sequence of str, optional
        One caption per panel.
    styles : mapping, optional
        ``{name: add_mesh options}`` over each layer's defaults (e.g. ``{"control": {"show_edges": True}}``; a
        ``texture`` may be an image array).
    params : dict, optional
        Appearance parameters of trees in a static scene (a document's own ``params`` are used otherwise).
    background : colour, optional
        One background colour (any pyvista colour; dark for a depth-cued segmentation); default a sky gradient.
    depth_cue : bool
        Blend labelled surfaces' colours toward ``background`` (black without one) with distance from the camera
        (000_vine §2.2, Eq. 5.8); redone when the camera moved, before a picture.
    sides : (int, int)
        Cross-section sides of tree branches at the tips and at the base (:class:`~plantvr.view.layers.TreeLayer`).
    """

    def __init__(self, doc, *, off_screen: bool | None = None, window_size=(900, 700), show_markers: bool = True,
                 show_leaves: bool = True, ground: bool | None = None, lod: bool | LOD | None = None,
                 panels: Sequence[Sequence[str]] | None = None, titles: Sequence[str] | None = None,
                 styles: Mapping[str, dict] | None = None, params: dict | None = None, background=None,
                 depth_cue: bool = False, sides=(6, 32)):
        is_doc = callable(getattr(doc, "scene", None)) and callable(getattr(doc, "observe", None))
        if not is_doc and not isinstance(doc, Mapping):
            raise TypeError(f"doc must be a document (with scene()) or a {{name: content}} mapping, "
                            f"got {type(doc).__name__}")
        o = ViewOptions(window_size, show_markers, show_leaves, ground, lod, panels, titles, styles, params,
                        background, depth_cue, sides)
        scene = doc.scene() if is_doc else dict(doc)
        classes = scene_layers(scene, o.lod, arrays=not is_doc)
        if off_screen is None:
            off_screen = not os.environ.get("DISPLAY")
        self.doc = doc if is_doc else None
        self.lod, self.panels, self.styles = o.lod, o.panels, o.styles
        self.show_leaves, self.sides = o.show_leaves, o.sides
        #: the depth cue's target colour (None: no depth cue)
        self.depth_cue = o.depth_cue
        self.hidden: set[str] = set() if o.show_markers else {"markers"}
        self.layers: dict[str, Layer] = {}
        self.drawn_version = -1
        self.switches = 0
        self._params = o.params
        self._scene: dict[str, Any] = {} if is_doc else dict(scene)
        shape = (1, len(o.panels)) if len(o.panels) > 1 else (1, 1)
        self.plotter = pv.Plotter(shape=shape, off_screen=off_screen, window_size=list(o.window_size),
                                  border=False)
        for col in range(shape[1]):
            self.plotter.subplot(0, col)
            if o.background is None:
                self.plotter.set_background("#f4f1ea", top="#cfe3f5")
            else:
                self.plotter.set_background(o.background)
            if titles is not None:
                self.plotter.add_text(titles[col], font_size=11, color="#333333", name=f"title{col}")
        if shape[1] > 1:
            self.plotter.link_views()
        #: the render window's lock (:mod:`plantvr.view._render_lock`): held around layer updates, renders and
        #: screenshots here, and by trame's image capture on its server thread
        self.lock = lock_plotter(self.plotter)
        self.plotter.subplot(0, 0)
        if ground is None:
            kinds = set(classes.values())
            ground = o.lod is None and shape[1] == 1 and TreeLayer in kinds and not kinds & {MeshLayer, InstancesLayer}
        if ground:
            self.plotter.add_mesh(ground_disc(), color="#9cb37a", name="ground", pickable=False)
        self.brush_center = np.zeros(3)
        self.brush_radius = float(getattr(doc, "brush_radius", 1.0))
        self._brush = brush_sphere()
        self._brush_actor = self.plotter.add_mesh(self._brush, color=GROW, opacity=0.25, name="brush",
                                                  pickable=False)
        self._brush_actor.SetVisibility(False)
        self._camera_tag = None
        self._held = 0
        self._render_due = False
        self._deferred = False
        self.viewer = None            # the trame viewer of a live widget (:meth:`widget`), pushed after redraws
        self.pose = np.eye(4)         # the model pose of every layer (:meth:`set_model_pose`)
        self._apply(scene)
        if self.doc is not None:      # after the layers, so those that follow the document update first
            self.drawn_version = int(getattr(self.doc, "version", -1))
            self.doc.observe(self._on_change, names="change")
            if self.doc.has_trait("prune_mode"):
                self.doc.observe(self._on_mode, names="prune_mode")
                self._set_brush_colour(self.doc.prune_mode)
        self.frame()
        if o.lod is not None:
            self._camera_tag = self.plotter.camera.AddObserver("ModifiedEvent", lambda *_: self.update_lod())

    # -- scene -> layers ----------------------------------------------------------------------------------
    def _on_change(self, change) -> None:
        if self._held:
            return
        self._apply_deferred()
        new = change["new"]
        if new is not None:
            self.drawn_version = int(new.version)

    @contextlib.contextmanager
    def hold(self) -> Iterator[None]:
        """Draw nothing for the document's changes inside the block (a burst of commands, e.g. a regrow), then
        redraw once."""
        self._held += 1
        try:
            yield
        finally:
            self._held -= 1
            if not self._held and self.doc is not None:
                self._apply_deferred()
                self.drawn_version = int(self.doc.version)

    def _apply_deferred(self) -> list[str]:
        """Draw the document's scene, leaving the render to :meth:`_render_soon`."""
        self._deferred = True
        try:
            redrawn = self._apply(self.doc.scene())
        finally:
            self._deferred = False
        if redrawn:
            self._render_soon()
        return redrawn

    def _render_soon(self) -> None:
        """Render (and :meth:`push`) after a document change: at once in a script; in a kernel once after the
        message being handled, so a burst of commands (brush stamps, growth steps) renders once."""
        loop = kernel_loop()
        due, self._render_due = self._render_due, True
        if loop is None:
            self._render_now()
        elif not due:
            loop.call_soon(self._render_now)

    #: Render before :meth:`push` too, as before issue 31 (``benchmarks/paint_latency.py``'s baseline). A push's
    #: image capture renders the window itself, so a live view renders once per redraw without it.
    render_before_push = False

    def _render_now(self) -> None:
        if not self._render_due:                     # a live view's capture has sent it (:meth:`_before_capture`)
            return
        self._render_due = False
        with self.lock:
            if self.plotter.render_window is None:   # closed meanwhile
                return
            if self.viewer is None or self.render_before_push:
                self.plotter.render()
            self.push()

    def _before_capture(self) -> bool:
        """trame's capture of the live view is about to send a picture (on its server thread, under the lock): bring
        the layers up to date; returns whether the picture must be rendered anew, which leaves no render due."""
        changed = [lay.refresh() for lay in self.layers.values()]
        due, self._render_due = self._render_due, False
        return any(changed) or due

    def push(self) -> None:
        """Send the current picture to the browser of a live widget (:meth:`widget`); nothing without one."""
        if self.viewer is not None:
            self.viewer.update()

    def update(self, scene: Mapping[str, Any] | None = None) -> list[str]:
        """Redraw the layers whose content changed; returns their names.

        A document view reads ``doc.scene()`` (``scene`` must be None). A static view merges ``scene`` into what
        it shows (an entry set to None is removed); every entry is checked before anything is drawn.
        """
        if self.doc is not None:
            if scene is not None:
                raise ValueError("scene must be None for a document view: it draws doc.scene(); change the "
                                 "document instead")
            return self._apply(self.doc.scene())
        if scene is None:
            scene = {}
        if not isinstance(scene, Mapping):
            raise ValueError(f"scene must be a {{name: content}} mapping, got {type(scene).__name__}")
        merged = {**self._scene, **scene}
        merged = {k: v for k, v in merged.items() if v is not None}
        scene_layers(merged, self.lod, arrays=True)
        self._scene = merged
        return self._apply(merged)

    def _apply(self, scene: Mapping[str, Any]) -> list[str]:
        classes = scene_layers(scene, self.lod)
        params = self.params          # read from the document before the render lock (lock order: document first)
        with self.lock:
            return self._apply_locked(scene, classes, params)

    def _apply_locked(self, scene: Mapping[str, Any], classes: dict[str, type[Layer]], params: dict) -> list[str]:
        redrawn = sync_layers(self.layers, scene, classes, self._make_layer, params=params,
                              buds=functools.partial(tree_buds, self.doc), before=self._subplot)
        self.plotter.subplot(0, 0)
        if self.lod is not None and redrawn:
            self.update_lod()
        if redrawn and not self._deferred:
            self.plotter.render()
        return redrawn

    def _make_layer(self, name: str, cls: type[Layer]) -> Layer:
        layer = cls(self.plotter, name, self.styles.get(name), leaves=self.show_leaves, lod=self.lod,
                    sides=self.sides, depth_cue=self.depth_cue)
        layer.visible = name not in self.hidden
        layer.pose = self.pose
        return layer

    def _subplot(self, name: str) -> None:
        if len(self.panels) > 1:
            col = next((i for i, names in enumerate(self.panels) if name in names), 0)
            self.plotter.subplot(0, col)

    @property
    def params(self) -> dict[str, Any]:
        """Appearance parameters the tree layers use: the document's, else the view's ``params``."""
        return dict(getattr(self.doc, "params", None) or self._params)

    @property
    def tree(self):
        """The tree of the first tree layer (what the brush prunes), or None."""
        return next((lay.tree for lay in self.layers.values() if isinstance(lay, TreeLayer)), None)

    def pickable_actors(self) -> list:
        """Main actors of the tree and surface layers (what a brush picks on)."""
        return [lay.actor for lay in self.layers.values()
                if isinstance(lay, (TreeLayer, MeshLayer, LabelledSurfaceLayer)) and lay.actor is not None]

    def set_visible(self, name: str, visible: bool) -> None:
        """Show or hide the layer of scene entry ``name`` (kept across updates)."""
        check_bool("visible", visible)
        if visible:
            self.hidden.discard(name)
        else:
            self.hidden.add(name)
        if name in self.layers:
            with self.lock:
                self.layers[name].set_visible(visible)
                self.plotter.render()

    @property
    def show_markers(self) -> bool:
        """Whether the ``"markers"`` entry is shown."""
        return "markers" not in self.hidden

    @show_markers.setter
    def show_markers(self, visible: bool) -> None:
        self.set_visible("markers", visible)

    # -- forest level of detail -----------------------------------------------------------------------------
    def _lod_layers(self) -> list[LodTreeLayer]:
        return [lay for lay in self.layers.values() if isinstance(lay, LodTreeLayer)]

    def target_levels(self) -> np.ndarray:
        """LOD level :func:`~plantvr.view.billboard.lod_by_distance` picks for each tree for the current camera."""
        trees = self._lod_layers()
        if not trees:
            return np.zeros(0, np.int64)
        cam = self.plotter.camera
        d = np.linalg.norm(np.array([t.center for t in trees]) - np.asarray(cam.position, float), axis=1)
        return lod_by_distance(np.array([t.height for t in trees]), np.maximum(d, 1e-9),
                               fov_deg=float(cam.view_angle), viewport_px=int(self.plotter.window_size[1]),
                               thresholds=self.lod.thresholds)

    def update_lod(self) -> int:
        """Switch each tree to the level of its camera distance; returns the number of trees switched (called on
        every camera change of a view with ``lod``)."""
        changed = sum(t.set_level(int(lv)) for t, lv in zip(self._lod_layers(), self.target_levels()))
        self.switches += changed
        return changed

    @property
    def levels(self) -> np.ndarray:
        """(T,) int64 current level of each tree of a ``lod`` view (``BILLBOARD_LEVEL`` for the billboard)."""
        return np.array([t.level for t in self._lod_layers()], np.int64)

    @property
    def centers(self) -> np.ndarray:
        """(T, 3) centre of each tree's bounding box in a ``lod`` view (the point its distance is measured to)."""
        return np.array([t.center for t in self._lod_layers()]).reshape(-1, 3)

    @property
    def triangles(self) -> int:
        """Triangles of the tree actors now visible in a ``lod`` view."""
        return int(sum(t.triangles for t in self._lod_layers()))

    # -- camera, brush, output ------------------------------------------------------------------------------
    def _content_bounds(self) -> tuple[float, ...] | None:
        """(xmin, xmax, ymin, ymax, zmin, zmax) of every layer's points with an 8 % margin (a tree scene at least
        2 m wide)."""
        pts = [lay.points() for lay in self.layers.values()]
        pts = [p for p in pts if len(p)]
        if not pts:
            return None
        pts = np.concatenate(pts)
        lo, hi = pts.min(0), pts.max(0)
        c = 0.5 * (lo + hi)
        least = 2.0 if any(isinstance(lay, TreeLayer) for lay in self.layers.values()) else 1e-6
        half = np.maximum(0.5 * (hi - lo), 0.5 * least) * 1.08   # a margin: leaves reach past the nodes
        lo, hi = c - half, c + half
        return (lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])

    def frame(self) -> None:
        """Point the camera at the whole scene from a three-quarter view, fitted to its content (a tree scene
        keeps at least 2 m in view)."""
        b = self._content_bounds()
        if b is not None:
            self._fit(b, np.array([1.0, 0.35, 1.0]))

    def fit(self) -> None:
        """Fit the camera to the content again, keeping its direction (after a regrow changed the size)."""
        b = self._content_bounds()
        if b is not None:
            self.plotter.subplot(0, 0)
            pos, focal, _up = self.plotter.camera_position
            self._fit(b, np.subtract(pos, focal))

    def _fit(self, bounds, direction) -> None:
        """Put the camera on ``direction`` from the centre of ``bounds`` (y up), at the distance where every
        corner of the box is inside the picture (perspective, this panel's aspect ratio)."""
        self.plotter.subplot(0, 0)
        lo, hi = np.array(bounds[0::2], float), np.array(bounds[1::2], float)
        c = 0.5 * (lo + hi)
        v = np.asarray(direction, float)
        v = v / np.linalg.norm(v)
        up = np.array([0.0, 1.0, 0.0])
        if abs(v @ up) > 0.99:                      # looking straight down / up: z is up on the screen
            up = np.array([0.0, 0.0, -1.0])
        r = np.cross(up, v)
        r /= np.linalg.norm(r)
        u = np.cross(v, r)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - c
        t = np.tan(np.radians(self.plotter.camera.view_angle) / 2)
        aspect = max(float(self.plotter.renderer.GetTiledAspectRatio()), 1e-3)
        need = corners @ v + np.maximum(np.abs(corners @ u) / t, np.abs(corners @ r) / (t * aspect))
        d = max(float(need.max()) * 1.04, 1e-6)
        self.plotter.camera_position = [tuple(c + d * v), tuple(c), tuple(u)]
        self.plotter.reset_camera_clipping_range()

    def _on_mode(self, change) -> None:
        self._set_brush_colour(change["new"])
        self.plotter.render()

    def _set_brush_colour(self, prune: bool) -> None:
        self._brush_actor.GetProperty().SetColor(pv.Color(PRUNE if prune else GROW).float_rgb)

    def set_brush(self, center, radius: float | None = None, visible: bool = True, *, color=None) -> None:
        """Place the brush sphere (green to grow, red to prune, or ``color``: a label's, spec 000_vine §2.4.1),
        in model coordinates (:meth:`set_model_pose`)."""
        center = check_point("center", center)
        if radius is not None:
            radius = check_range("radius", radius, 0.0, 1e6, low_open=True)
        if not isinstance(visible, (bool, np.bool_)):
            raise TypeError(f"visible must be True or False, got {visible!r}")
        if color is not None:
            try:
                color = pv.Color(color)
            except ValueError:
                raise ValueError(f"color must be a colour (name, hex or RGB), got {color!r}"[:300]) from None
            self._brush_actor.GetProperty().SetColor(color.float_rgb)
        self.brush_center = center
        if radius is not None:
            self.brush_radius = radius
        with self.lock:                 # the unit sphere moved and scaled (no new geometry per mouse move)
            self._brush_actor.SetPosition(*self.brush_center)
            self._brush_actor.SetScale(self.brush_radius)
            self._brush_actor.SetVisibility(visible)
        self._render_soon()

    def set_model_pose(self, position, rotation, scale: float) -> None:
        """Place the whole scene (every layer and the brush) by the model transform ``x ↦ P + s R x``.

        Parameters
        ----------
        position : (3,) float
        rotation : (3, 3) float
            A rotation matrix.
        scale : float
            In (0, 1e6].
        """
        m = np.eye(4)
        m[:3, :3] = check_range("scale", scale, 0.0, 1e6, low_open=True) * check_array(
            "rotation", rotation, shape=(3, 3))
        m[:3, 3] = check_point("position", position)
        self.pose = m
        with self.lock:
            for lay in self.layers.values():
                lay.set_pose(m)
            self._brush_actor.user_matrix = m

    def apply_view(self, view: SavedView, *, viewer_position=None, view_dir=None) -> None:
        """Load a saved view (spec 000_vine §2.7) for the current camera, or ``viewer_position`` and
        ``view_dir``: its model pose for that position and horizontal facing (Eq. 5.14 corrected)."""
        if not isinstance(view, SavedView):
            raise ValueError(f"view must be a SavedView, got {type(view).__name__}")
        cam = self.plotter.camera
        eye = np.asarray(cam.position if viewer_position is None else viewer_position, float)
        d = np.subtract(cam.focal_point, cam.position) if view_dir is None else np.asarray(view_dir, float)
        self.set_model_pose(*load_view(view, viewer_position=eye, view_dir=d))

    def screenshot(self, path: str | Path | None = None, *, window_size=None) -> np.ndarray:
        """Render offscreen (at ``window_size`` for a full-resolution still) and return the (H, W, 3) uint8
        image; also write a PNG atomically when ``path`` is given."""
        if window_size is not None:
            window_size = check_size("window_size", window_size, 16, 16384)
        if path is not None and Path(path).suffix.lower() != ".png":
            raise ValueError(f"path must end in .png, got {str(path)!r}")
        if self.doc is not None:
            self.update()
        with self.lock:
            for lay in self.layers.values():
                lay.refresh()
            self.plotter.render()  # else a camera moved since the last render is not in the picture
            img = self.plotter.screenshot(None, window_size=window_size, return_img=True)
        if path is not None:
            write_png(path, img)
        return img

    def snapshot(self, *, eye=None) -> dict[str, tuple[pv.PolyData, Any]]:
        """What every layer shows, ``{actor name: (PolyData, actor)}`` (:meth:`Layer.snapshot
        <plantvr.view.layers.Layer.snapshot>`), for a renderer on another thread and GL context: the headset
        (:mod:`plantvr.vr`) draws a never-rendered View's layers this way. With ``eye`` (a model-space point) the
        camera is put there first and the layers that follow it (the depth cue) are brought up to date."""
        if eye is not None:
            eye = check_point("eye", eye)
        with self.lock:
            if eye is not None:
                self.plotter.camera.position = tuple(eye)
            out: dict[str, tuple] = {}
            for lay in self.layers.values():
                if eye is not None:
                    lay.refresh()
                out.update(lay.snapshot())
            return out

    def png(self) -> bytes:
        """The current picture as PNG bytes (for an ``ipywidgets.Image``)."""
        from PIL import Image  # noqa: PLC0415

        buf = io.BytesIO()
        Image.fromarray(self.screenshot()).save(buf, format="PNG")
        return buf.getvalue()

    def widget(self, *, width: int | None = None, height: int | None = None):
        """The live view for JupyterLab: a trame view rendered on the kernel (``"server"`` mode, only images go to
        the browser, so big meshes stay in the kernel), whose browser mouse events reach the plotter's VTK
        interactor (a :class:`~plantvr.view.interaction.BrushInteractor` attached to it paints and prunes).

        The picture follows the document: every redraw is pushed to the browser (:meth:`push`). Needs a
        running kernel with a browser on the same machine (the view is served by a trame server on a local
        port); headless, use :meth:`png` instead.

        Returns
        -------
        anywidget.AnyWidget
            The trame iframe widget (``trame_pyvista.jupyter.Widget``).

        Raises
        ------
        ValueError
            If ``trame-pyvista`` is not installed.
        """
        try:
            from trame_pyvista.jupyter import show_trame  # noqa: PLC0415
        except ImportError as exc:
            raise ValueError(f"View.widget needs trame-pyvista ({exc}); pip install trame-pyvista") from None
        w, h = self.plotter.window_size
        width = int(check_range("width", w if width is None else width, 16, 16384))
        height = int(check_range("height", h if height is None else height, 16, 16384))
        launch_live_server()
        widget = show_trame(self.plotter, mode="server", add_menu=False, width=f"{width}px",
                            height=f"{height}px")
        self.viewer = widget.viewer
        self.lock.on_capture(self._before_capture)
        return widget

    def show(self, jupyter_backend: str = "trame", **kwargs):
        """Show in JupyterLab (trame: ``"trame"`` remote-rendered, ``"client"``, ``"server"``) or a window."""
        if jupyter_backend in ("trame", "server", "client"):
            launch_live_server()  # before pyvista's own launcher, which would enable the wasm download
        return self.plotter.show(jupyter_backend=jupyter_backend, auto_close=False, **kwargs)

    def close(self) -> None:
        """Stop observing the document (and the layers what they follow) and free the render window."""
        for lay in self.layers.values():
            lay.close()
        if self.doc is not None:
            self.doc.unobserve(self._on_change, names="change")
            if self.doc.has_trait("prune_mode"):
                self.doc.unobserve(self._on_mode, names="prune_mode")
        if self._camera_tag is not None:
            self.plotter.camera.RemoveObserver(self._camera_tag)
            self._camera_tag = None
        self.viewer = None
        with self.lock:
            self.plotter.close()


def side_by_side(control, surface, *, off_screen: bool | None = None, window_size=(1000, 500),
                 titles=("control mesh", "Loop subdivision")) -> View:
    """A control mesh (left, with edges) and its subdivided surface (right) in two linked panels (spec
    001_subdivision C16): a static :class:`View` of ``{"control": control, "surface": surface}``; change either
    with ``view.update({"surface": mesh})``.

    Parameters
    ----------
    control, surface : TriMesh or trimesh.Trimesh or ControlMesh, optional
        The meshes (None: nothing yet).
    off_screen, window_size
        As in :class:`View`.
    titles : (str, str)
        Panel captions.
    """
    scene = {k: m for k, m in (("control", control), ("surface", surface)) if m is not None}
    return View(scene, off_screen=off_screen, window_size=window_size, panels=(("control",), ("surface",)),
                titles=titles, styles={"control": {"color": CONTROL, "show_edges": True, "edge_color": EDGE,
                                                   "line_width": 1.0, "smooth_shading": False, "specular": 0.0}})

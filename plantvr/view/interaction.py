"""Brush painting and pruning in the pyvista view, all through document commands (spec 000_treewand §4.3, §4.4;
checklist items 23, 24; TW-V17b, TW-V22).

:class:`BrushInteractor` turns pointer input into ``doc.paint_stroke`` / ``doc.prune_preview`` /
``doc.prune`` calls on the document of a :class:`plantvr.View` (the Tree Wand model, or any document with
those commands and ``brush_radius`` / ``prune_mode`` traits). The pointer is a picked point on the branches or,
in free space, a point on the mouse ray at a chosen depth. The same class serves three input sources:

* VTK mouse events (:meth:`BrushInteractor.attach`): move = hover, left press/drag = paint or prune,
  wheel = radius gesture, ``p`` toggles prune mode, ``m`` shows/hides markers;
* direct calls with world points (tests, scripted strokes);
* a desktop controller emulator (:meth:`BrushInteractor.handle`) fed with the headset's input events
  (pose + analogue trigger + thumb angle).

The interactor keeps no record of its own: every command it issues lands in the document's
:class:`~plantvr.commandlog.CommandLog` (``doc.log``), which replays the session (``doc.replay``).

In a browser (JupyterLab or a trame app) the view is server-rendered: trame's remote view sends the
mouse to the server, where ``vtkWebApplication.HandleInteractionEvent`` replays it on the plotter's
(offscreen) VTK interactor, so the observers of :meth:`BrushInteractor.attach` fire exactly as in a
desktop window, picking included; wheel events arrive as ``MouseWheelForward/BackwardEvent``.
:func:`trame_app` builds such a page with hover enabled (``enable_picking``: the remote view then sends
moves without a button, so the brush and the prune preview follow the mouse). pyvista's default
``plotter.show(jupyter_backend="trame")`` view sends only drags: painting and pruning work, hover does not.

The interactor owns no document state: the radius is ``doc.brush_radius`` and the mode ``doc.prune_mode``.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pyvista as pv
import vtk

from .._validation import check_point, check_range
from . import PRUNE, View
from ._render_lock import lock_trame_image_delivery
from .polydata import tube_polydata

__all__ = ["FULL_TRIGGER", "PREVIEW_TRIGGER", "BrushInteractor", "LabelBrush", "trame_app"]

#: Analogue trigger thresholds: above the first the brush shows (and prune previews), above the second it acts.
PREVIEW_TRIGGER, FULL_TRIGGER = 0.1, 0.99


class BrushInteractor:
    """Paint markers and prune branches in a :class:`plantvr.view.View` by pointing.

    Parameters
    ----------
    view : plantvr.view.View
        The view to draw the brush and prune preview in; its document receives every command.
    depth : float, optional
        Distance from the camera of the free-space brush when nothing is picked (default: distance to the
        focal point).
    spacing : float
        Minimum distance between paint stamps of one drag, in brush radii.
    """

    #: Multisamples of the view's window while a mouse stroke is held in a live view (:meth:`View.widget`):
    #: Mesa draws a picture 2-3x sooner without multisampling, so the stroke shows sooner (issue 31); the
    #: picture after the release is drawn with the window's own again. None: left as it is.
    stroke_samples: int | None = 0

    def __init__(self, view: View, *, depth: float | None = None, spacing: float = 0.5):
        if not isinstance(view, View) or view.doc is None:
            raise ValueError(f"view must be a plantvr.View of a document, got {type(view).__name__}")
        self.view = view
        self.doc = view.doc
        self.depth = None if depth is None else check_range("depth", depth, 0.0, 1e6, low_open=True)
        self.spacing = check_range("spacing", spacing, 0.0, 100.0)
        self.center: np.ndarray | None = None
        self.picked = False           # whether the last world_point hit a surface (not the free-space ray)
        self.preview = np.zeros(0, np.int64)
        self._pressed = False
        self._last_stamp: np.ndarray | None = None
        self._preview_mesh = pv.PolyData()
        self._preview_actor = None
        self._observers: list[int] = []
        self._saved_style = None
        self._samples: int | None = None    # the window's multisamples, while a stroke is held (_hold_stroke)
        self._picker = vtk.vtkCellPicker()
        self._picker.SetTolerance(0.002)
        self._last_pick: tuple | None = None   # (what the pick depends on, point, picked)
        self.doc.observe(self._on_mode, names=["prune_mode"])

    # -- pointer -> world ---------------------------------------------------------------------------
    def world_point(self, x: float, y: float) -> np.ndarray:
        """World point under display pixel (x, y): the picked branch surface, else the ray at :attr:`depth`.

        Parameters
        ----------
        x, y : float
            Display coordinates (VTK convention: origin bottom-left), pixels.

        Returns
        -------
        (3,) float64 ndarray
        """
        x, y = check_range("x", x, -1e6, 1e6), check_range("y", y, -1e6, 1e6)
        with self.view.lock:            # the pick reads the actors a redraw on another thread edits
            ren = self.view.plotter.renderer
            actors = [a for a in self.view.pickable_actors() if a.GetVisibility()]
            # the same pixel, window size, camera, depth and actors (their data and matrices): the same point,
            # picked once (a browser press arrives as a move and a press at one position)
            key = (x, y, self.depth, self.view.plotter.ren_win.GetSize(), ren.GetActiveCamera().GetMTime(),
                   *((a.GetMTime(), a.GetMapper().GetInput().GetMTime()) for a in actors))
            if self._last_pick is None or self._last_pick[0] != key:
                point = self._world_point(x, y, ren, actors)
                self._last_pick = (key, point, self.picked)
            _, point, self.picked = self._last_pick
            return point.copy()

    def _world_point(self, x: float, y: float, ren, actors: list) -> np.ndarray:
        if actors:
            self._picker.InitializePickList()
            for actor in actors:
                self._picker.AddPickList(actor)
            self._picker.PickFromListOn()
            if self._picker.Pick(float(x), float(y), 0.0, ren):
                self.picked = True
                return np.array(self._picker.GetPickPosition(), float)
        self.picked = False
        near, far = (self._display_to_world(ren, x, y, z) for z in (0.0, 1.0))
        cam = np.array(ren.GetActiveCamera().GetPosition(), float)
        d = far - near
        d /= np.linalg.norm(d)
        depth = self.depth
        if depth is None:
            depth = ren.GetActiveCamera().GetDistance()
        return cam + depth * d if ren.GetActiveCamera().GetParallelProjection() == 0 else near + depth * d

    @staticmethod
    def _display_to_world(ren, x, y, z) -> np.ndarray:
        ren.SetDisplayPoint(float(x), float(y), float(z))
        ren.DisplayToWorld()
        w = np.array(ren.GetWorldPoint(), float)
        return w[:3] / w[3]

    def world_to_display(self, point) -> np.ndarray:
        """(x, y) display pixel of a world point (the inverse of :meth:`world_point` on the ray)."""
        p = check_point("point", point)
        ren = self.view.plotter.renderer
        ren.SetWorldPoint(*p, 1.0)
        ren.WorldToDisplay()
        return np.array(ren.GetDisplayPoint()[:2], float)

    # -- commands ------------------------------------------------------------------------------------
    @property
    def radius(self) -> float:
        """The brush radius (``doc.brush_radius``)."""
        return float(self.doc.brush_radius)

    def hover(self, point) -> None:
        """Move the brush to ``point``; in prune mode, colour the subtrees that would go red (partial trigger)."""
        self.center = check_point("point", point)
        self.view.set_brush(self.center, self.radius, visible=True)
        if self.doc.prune_mode:
            self._show_preview(self.doc.prune_preview(self.center, self.radius))

    def press(self, point) -> int:
        """Full trigger / left press at ``point``: paint a stamp (a one-point ``paint_stroke``, grow mode) or prune
        (prune mode); returns the count."""
        self.hover(point)
        self._pressed = True
        if self.doc.prune_mode:
            n = self.doc.prune(self.center, self.radius)
            self._show_preview(self.doc.prune_preview(self.center, self.radius))
            return n
        self._last_stamp = self.center
        return self.doc.paint_stroke([self.center], self.radius)

    def drag(self, point) -> int:
        """Pointer moved with the trigger held: paint a stamp every ``spacing`` radii (grow) or prune (prune)."""
        if not self._pressed:
            self.hover(point)
            return 0
        self.hover(point)
        if self.doc.prune_mode:
            n = self.doc.prune(self.center, self.radius)
            if n:
                self._show_preview(self.doc.prune_preview(self.center, self.radius))
            return n
        if self._last_stamp is not None and np.linalg.norm(self.center - self._last_stamp) < self.spacing * self.radius:
            return 0
        self._last_stamp = self.center
        return self.doc.paint_stroke([self.center], self.radius)

    def release(self) -> None:
        """Trigger released: stop painting (the brush stays where it is)."""
        self._pressed = False
        self._last_stamp = None

    def leave(self) -> None:
        """Pointer left the view: hide brush and preview."""
        self.release()
        self.view.set_brush(self.view.brush_center, visible=False)
        self._show_preview(np.zeros(0, np.int64))

    def thumb(self, dphi: float) -> float:
        """Radius gesture: ``R ← R · 2^(Δφ / 2π)``, Δφ clockwise positive, clamped to the parameter's range.

        Returns the new radius (spec §4.3 [INFERRED] continuous form; TW-V22: one clockwise circle doubles).
        """
        dphi = check_range("dphi", dphi, -1e6, 1e6)
        lo, hi = type(self.doc).PARAMS["brush_radius"].range
        r = float(np.clip(self.radius * 2.0 ** (dphi / (2 * math.pi)), lo, hi))
        self.doc.brush_radius = r
        if self.center is not None:
            self.hover(self.center)
        return r

    def wheel(self, clicks: int) -> float:
        """Mouse-wheel radius gesture: 8 clicks forward double the radius, 8 back halve it."""
        return self.thumb(clicks * 2 * math.pi / 8)

    def toggle_prune(self) -> bool:
        """Switch the brush between grow (green) and prune (red); returns the new prune mode."""
        self.doc.set_prune_mode(not self.doc.prune_mode)
        return self.doc.prune_mode

    def set_markers_visible(self, visible: bool) -> None:
        """Show or hide the marker cloud."""
        if not isinstance(visible, (bool, np.bool_)):
            raise ValueError(f"visible must be True or False, got {visible!r}")
        self.view.set_visible("markers", bool(visible))

    def _on_mode(self, change) -> None:
        if not change["new"]:
            self._show_preview(np.zeros(0, np.int64))
        elif self.center is not None:
            self._show_preview(self.doc.prune_preview(self.center, self.radius))

    def _show_preview(self, idx: np.ndarray) -> None:
        """Draw the internodes ending at tree nodes ``idx`` as red tubes slightly thicker than the bark."""
        with self.view.lock:
            self._draw_preview(idx)

    def _draw_preview(self, idx: np.ndarray) -> None:
        self.preview = np.asarray(idx, np.int64)
        snap = self.view.tree
        if snap is None:
            return
        idx = self.preview[(self.preview < len(snap.parent))]
        idx = idx[snap.parent[idx] >= 0] if len(idx) else idx
        plotter = self.view.plotter
        if len(idx) == 0:
            if self._preview_actor is not None:
                self._preview_actor.SetVisibility(False)
                plotter.render()
            return
        radius = np.asarray(snap.radius[idx], float) * 1.6 + 1e-3
        self._preview_mesh.copy_from(tube_polydata(snap, idx, radius))
        if self._preview_actor is None:
            self._preview_actor = plotter.add_mesh(self._preview_mesh, color=PRUNE, name="prune_preview",
                                                   pickable=False, lighting=False)
        self._preview_actor.SetVisibility(True)
        plotter.render()

    # -- controller emulator ----------------------------------------------------------------------------
    def handle(self, event: dict[str, Any]) -> None:
        """Apply one headset-style input event (checked first, see :meth:`check_event`); the commands it
        issues are logged by the document.

        Events: ``{"type": "pose", "pos": [x, y, z], "trigger": t}`` (analogue trigger in [0, 1]: below
        0.1 hidden, below 0.99 preview, else act), ``{"type": "thumb", "dphi": a}`` (radians, clockwise
        positive), ``{"type": "toggle_prune"}``, ``{"type": "markers", "visible": b}``.
        """
        self._apply(self.check_event(event))

    @staticmethod
    def check_event(event: dict[str, Any]) -> dict[str, Any]:
        """Return ``event`` checked and normalised (plain JSON values), or raise ``ValueError`` naming the field."""
        kind = event.get("type") if isinstance(event, dict) else None

        def field(name: str, default: Any = None) -> Any:
            if name not in event and default is None:
                raise ValueError(f"a {kind!r} event needs the field {name!r}, got {sorted(event)}")
            return event.get(name, default)

        if kind == "pose":
            return {"type": "pose", "pos": check_point("pos", field("pos")).tolist(),
                    "trigger": check_range("trigger", field("trigger", 0.0), 0.0, 1.0)}
        if kind == "thumb":
            return {"type": "thumb", "dphi": check_range("dphi", field("dphi"), -1e6, 1e6)}
        if kind == "toggle_prune":
            return {"type": "toggle_prune"}
        if kind == "markers":
            visible = field("visible")
            if not isinstance(visible, (bool, np.bool_)):
                raise ValueError(f"visible must be True or False, got {visible!r}")
            return {"type": "markers", "visible": bool(visible)}
        raise ValueError(f"event type must be one of ['pose', 'thumb', 'toggle_prune', 'markers'], got {kind!r}")

    def _apply(self, event: dict[str, Any]) -> None:
        kind = event["type"]
        if kind == "pose":
            pos, t = np.asarray(event["pos"], float), event["trigger"]
            if t < PREVIEW_TRIGGER:
                self.leave()
            elif t < FULL_TRIGGER:
                self.release()
                self.hover(pos)
            elif self._pressed:
                self.drag(pos)
            else:
                self.press(pos)
        elif kind == "thumb":
            self.thumb(event["dphi"])
        elif kind == "toggle_prune":
            self.toggle_prune()
        else:
            self.set_markers_visible(event["visible"])

    # -- VTK mouse binding -----------------------------------------------------------------------------
    def attach(self) -> None:
        """Bind mouse input of the view's interactor: the camera stops rotating while the brush is attached.

        Move = hover, left drag = paint/prune, wheel = radius, key ``p`` = prune mode,
        key ``m`` = markers on/off. :meth:`detach` gives the mouse back to the camera.
        """
        iren = self.view.plotter.iren.interactor
        if self._observers:
            return
        self._saved_style = iren.GetInteractorStyle()
        iren.SetInteractorStyle(vtk.vtkInteractorStyleUser())

        def pos():
            x, y = iren.GetEventPosition()
            return self.world_point(x, y)

        def on_move(obj, ev):
            self.drag(pos())

        def on_wheel(obj, ev):
            self.wheel(1 if ev == "MouseWheelForwardEvent" else -1)

        def on_key(obj, ev):
            key = iren.GetKeySym()
            if key == "p":
                self.toggle_prune()
            elif key == "m":
                self.set_markers_visible(not self.view.show_markers)

        def on_press(obj, ev):
            self._hold_stroke(True)
            self.press(pos())

        def on_release(obj, ev):
            self.release()
            self._hold_stroke(False)

        def on_leave(obj, ev):
            self.leave()
            self._hold_stroke(False)

        for name, cb in (("MouseMoveEvent", on_move), ("LeftButtonPressEvent", on_press),
                         ("LeftButtonReleaseEvent", on_release),
                         ("MouseWheelForwardEvent", on_wheel), ("MouseWheelBackwardEvent", on_wheel),
                         ("KeyPressEvent", on_key), ("LeaveEvent", on_leave)):
            self._observers.append(iren.AddObserver(name, cb, 10.0))

    def _hold_stroke(self, held: bool) -> None:
        """A mouse stroke starts (``held``) or ends: draw a live view with :attr:`stroke_samples` multisamples
        meanwhile."""
        window = self.view.plotter.ren_win
        with self.view.lock:
            if held and self._samples is None and self.stroke_samples is not None and self.view.viewer is not None:
                self._samples = window.GetMultiSamples()
                window.SetMultiSamples(self.stroke_samples)
            elif not held and self._samples is not None:
                window.SetMultiSamples(self._samples)
                self._samples = None

    def detach(self) -> None:
        """Remove the mouse bindings and restore the camera interaction."""
        iren = self.view.plotter.iren.interactor
        for tag in self._observers:
            iren.RemoveObserver(tag)
        self._observers = []
        self._hold_stroke(False)
        if self._saved_style is not None:
            iren.SetInteractorStyle(self._saved_style)
            self._saved_style = None

    def close(self) -> None:
        """Detach and stop observing the document."""
        self.detach()
        self.doc.unobserve(self._on_mode, names=["prune_mode"])


class LabelBrush(BrushInteractor):
    """Paint a label on the surface of a ViNE :class:`~plantvr.documents.labels.Segmentation` in its view.

    The same pointer and mouse binding as :class:`BrushInteractor` (:meth:`attach`: left drag paints, the
    wheel sizes the brush); a press opens a stroke (``doc.begin_stroke``), every stamp is ``doc.paint(center,
    radius, label)`` on the picked surface point, the release closes it (``doc.end_stroke``), so one drag is
    one undo item and every stamp is in ``doc.log``. The label and radius are brush settings, not document
    state: :attr:`label` (a colour wheel's selection, linked by the workbench) and :attr:`radius`.

    Parameters
    ----------
    view : plantvr.view.View
        A view of a segmentation (a document with ``paint``, ``begin_stroke``, ``end_stroke``).
    label : int
        The label painted.
    radius : float, optional
        Brush radius in model units (default: 3 % of the mesh's bounding-box diagonal).
    spacing : float
        Minimum distance between stamps of one drag, in brush radii.

    Attributes
    ----------
    error : str
        The last refused stamp (a hidden label, say), "" when it painted.
    """

    def __init__(self, view: View, *, label: int = 1, radius: float | None = None, spacing: float = 0.25):
        doc = getattr(view, "doc", None)
        if not isinstance(view, View) or not all(callable(getattr(doc, n, None))
                                                 for n in ("paint", "begin_stroke", "end_stroke")):
            raise ValueError(f"view must be a plantvr.View of a segmentation, got {type(view).__name__}")
        diag = float(np.linalg.norm(np.ptp(np.asarray(doc.vertices, float), axis=0)))
        self.max_radius = float(doc.max_radius)
        self._radius = 0.03 * max(diag, 1e-6) if radius is None else check_range("radius", radius, 0.0,
                                                                                  self.max_radius, low_open=True)
        self.label = doc.colors.check_label("label", label)
        self.error = ""
        super().__init__(view, spacing=spacing)

    @property
    def radius(self) -> float:
        """The brush radius, model units."""
        return self._radius

    @radius.setter
    def radius(self, value: float) -> None:
        self._radius = check_range("radius", value, 0.0, self.max_radius, low_open=True)

    def hover(self, point) -> None:
        """Move the brush sphere to ``point``."""
        self.center = check_point("point", point)
        self.view.set_brush(self.center, self.radius, visible=True)

    def _stamp(self) -> int:
        try:
            n = self.doc.paint(self.center, self.radius, self.label)
        except ValueError as exc:  # a hidden or removed label: nothing painted, said in error
            self.error = str(exc)
            return 0
        self.error = ""
        self._last_stamp = self.center
        return n

    def press(self, point) -> int:
        """Left press at ``point``: open a stroke and paint one stamp; returns the vertices changed."""
        self.hover(point)
        if not self._pressed:
            self.doc.begin_stroke()
        self._pressed = True
        return 0 if self._take_miss() else self._stamp()

    def world_point(self, x: float, y: float) -> np.ndarray:
        """As :meth:`BrushInteractor.world_point`; a point off the surface is remembered, so the mouse paints
        only on the mesh (points given directly always paint)."""
        p = super().world_point(x, y)
        self._miss = not self.picked
        return p

    def _take_miss(self) -> bool:
        miss, self._miss = getattr(self, "_miss", False), False
        return miss

    def drag(self, point) -> int:
        """Pointer moved: with the button held, a stamp every ``spacing`` radii on the picked surface."""
        self.hover(point)
        if self._take_miss() or not self._pressed:
            return 0
        if self._last_stamp is not None and np.linalg.norm(self.center - self._last_stamp) < self.spacing * self.radius:
            return 0
        return self._stamp()

    def release(self) -> None:
        """Button released: close the stroke (one undo item)."""
        if self._pressed:
            self.doc.end_stroke()
        self._pressed = False
        self._last_stamp = None

    def thumb(self, dphi: float) -> float:
        """Radius gesture: ``R <- R * 2^(dphi / 2 pi)``, clamped to (0, max_radius]; returns the new radius."""
        dphi = check_range("dphi", dphi, -1e6, 1e6)
        self._radius = float(np.clip(self._radius * 2.0 ** (dphi / (2 * math.pi)), 1e-9, self.max_radius))
        if self.center is not None:
            self.hover(self.center)
        return self._radius

    def toggle_prune(self) -> bool:
        """A label brush has no prune mode (returns False)."""
        return False

    def _on_mode(self, change) -> None:
        pass

    def _show_preview(self, idx) -> None:
        pass


def trame_app(brush: BrushInteractor, *, server=None, width: int = 640, height: int = 480):
    """A trame page with the brush's view (server rendered, hover on) and a live status line.

    The brush is attached to the view's interactor; browser mouse events reach it through trame's
    server-side event replay (see the module docstring). Start the page with ``server.start(port=...)``, or
    in JupyterLab ``await layout.ready`` and display ``layout``.

    Parameters
    ----------
    brush : BrushInteractor
        Brush over the view to show; its document receives every command.
    server : trame server, optional
        Default: a new one named after the view.
    width, height : int
        Size of the view in the page, pixels.

    Returns
    -------
    (server, layout)
        The trame server and its ``DivLayout``; ``server.state`` has ``n_markers``, ``n_internodes``,
        ``n_paint`` (paint and prune commands logged since the page was made) and ``brush_radius``, kept in sync
        with the document.

    Raises
    ------
    ValueError
        If ``trame`` or ``trame-pyvista`` is not installed (the message says what to install).
    """
    try:
        from trame.app import get_server
        from trame.ui.html import DivLayout
        from trame.widgets import html
        from trame_pyvista import PyVistaRemoteView
    except ImportError as exc:
        raise ValueError(f"trame_app needs trame and trame-pyvista ({exc}); pip install trame trame-pyvista") from None
    if not isinstance(brush, BrushInteractor):
        raise ValueError(f"brush must be a BrushInteractor, got {type(brush).__name__}")
    width = int(check_range("width", width, 16, 8192))
    height = int(check_range("height", height, 16, 8192))
    lock_trame_image_delivery()
    doc = brush.doc
    start = len(doc.log)  # brush commands are counted from here
    server = server or get_server(f"plantvr_brush_{id(brush.view):x}", client_type="vue3")
    state = server.state

    def sync(change=None) -> None:
        state.n_markers = int(doc.n_markers)
        state.n_internodes = int(doc.n_internodes)
        state.n_paint = sum(1 for e in doc.log.events[start:] if e.command in ("paint", "paint_stroke", "prune"))
        state.brush_radius = round(float(doc.brush_radius), 3)
        state.flush()

    with state:
        sync()
    doc.observe(sync, names=["version", "brush_radius"])
    brush.attach()
    with DivLayout(server) as layout:
        html.Div("markers {{ n_markers }} · internodes {{ n_internodes }} · brush commands {{ n_paint }} · "
                 "radius {{ brush_radius }}", classes="plantvr-brush-status", id="plantvr-brush-status")
        with html.Div(style=f"width:{width}px;height:{height}px", id="plantvr-brush-view"):
            PyVistaRemoteView(brush.view.plotter, enable_picking=True, interactive_ratio=1, still_ratio=1)
    return server, layout

"""In-browser review of a ViNE segmentation with trame (spec 000_vine §2.4–2.6; issues 6 and 14).

The browser draws a decimated :class:`~plantvr.vine.proxy.DisplayProxy` on the user's own GPU (trame-vtk
``VtkLocalView``, vtk.js): the mesh and its colours are sent once, and after each paint, undo or redo only
the changed proxy vertices travel, as a colour delta ``(ids uint32, rgba uint8)`` that a small page hook
(``vine_delta.js``) writes into the vtk.js actor's scalar array in place, drawing once per animation frame
however many deltas arrived (8 B per changed proxy vertex instead of 4 B per proxy vertex). Hiding a colour or
a new iso-value changes the triangles, so those re-synchronise the scene (trame-vtk fetches arrays by content
hash: only the changed arrays travel).

Painting (issue 14): a click, or a drag with "paint: drag" on (or ctrl held), sends its positions in CSS pixels
and the page's vtk.js camera to the server (:meth:`VineReviewApp.stroke`; at most one request in flight, the
positions that arrive meanwhile travel together); the server casts the viewing ray (:func:`camera_ray`)
against the drawn proxy with VTK's ``vtkStaticCellLocator`` (no pick pass in the browser; ~0.1 ms) and the
sphere brush paints the *full-resolution* labels, a drag being one undo item. While a stroke (or an orbit
drag) runs the page draws a coarse level of detail (``interactive_faces``, 20k triangles by default, its
colours following by deltas too) and the display proxy again when it ends: software WebGL (SwiftShader on a
2-core CPU) draws a 24k-triangle frame in ~60 ms but a 200k-triangle one in ~0.65 s and a 1.5 M-triangle one in
~1.7 s (``benchmarks/vine_render.py``); a real GPU draws all of them at full rate.
``mode="remote"`` renders on the server instead (``VtkRemoteView``, images over the websocket; clicks picked
there with ``vtkCellPicker``) for comparison.

Controls: the colour wheel (§2.4.1 [T §5.4.1], §2.6 [T §5.6]: one slice per colour-table entry, the selected
slice raised and outlined, hidden colours drawn with radial lines; a click selects the slice under the mouse by
the rule of :func:`plantvr.vine.colors.slice_at`, a shift-click hides or shows it), brush radius, undo/redo,
hide/show of the selected colour, and, when started from a volume, an iso-value slider over the volume's
histogram that re-extracts the surface. The wheel is an SVG (:func:`plantvr.view.vine_svg.wheel_svg`) re-sent
when the selection, a colour or a visibility changes. The page's layout is :mod:`plantvr.view.vine_page`, the
access token guard and the server thread :mod:`plantvr.view.vine_access`, the ``plantvr segment`` command
:mod:`plantvr.view.vine_cli`.
"""
from __future__ import annotations

import asyncio
import functools
import itertools
import os
import secrets
import threading
import time

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np

from plantvr._validation import check_array, check_choice, check_int, check_range
from plantvr.documents.labels import Segmentation, check_grid
from plantvr.vine.colors import slice_at
from plantvr.vine.proxy import DisplayProxy

from ._render_lock import render_lock
from .vine_access import _free_port, access_guard, serve_in_thread
from .vine_pick import camera_ray
from .vine_page import build_page
from .vine_svg import WHEEL_RADIUS, histogram_svg, wheel_geometry, wheel_svg

__all__ = ["WHEEL_RADIUS", "VineReviewApp", "camera_ray", "histogram_svg", "wheel_geometry", "wheel_svg"]

_IDS = itertools.count()


def _drawing(method):
    """A command that edits what the view draws, run under its render window's lock (the server thread renders
    the remote view's picture; :mod:`plantvr.view._render_lock`)."""
    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with render_lock(self.view.plotter.ren_win):
            return method(self, *args, **kwargs)
    return locked


class VineReviewApp:
    """A trame page that reviews and paints a segmentation through its display proxy.

    Parameters
    ----------
    seg : Segmentation, optional
        The segmentation to review; give ``volume`` and ``level`` instead to mesh a volume.
    proxy : DisplayProxy, optional
        Display proxy of ``seg``; default one is built with ``target_faces``.
    target_faces : int
        Proxy triangle budget when the proxy is built here, in [4, 2**31 - 1].
    mode : {"local", "remote"}
        ``local``: the browser renders the proxy (vtk.js). ``remote``: the server renders and streams images.
    volume : (X, Y, Z) uint8/16/32, int8/16/32 or float32/64 ndarray, optional
        Source volume; enables the iso-value slider (over the data's range, in its units) and histogram.
    level : float, optional
        Iso-value for ``volume`` (default: Otsu, :func:`plantvr.vine.volume.suggest_level`).
    spacing, origin : (3,) float, optional
        The voxel grid of ``volume`` (voxel size and position of voxel 0 per array axis, physical units, as
        :func:`plantvr.io.volume.read_volume` returns them): the surface, the brush radius and every distance
        are then in those units, and the iso slider re-meshes on the same grid. Default: the segmentation's
        own grid (:attr:`Segmentation.spacing`, :attr:`~Segmentation.origin`; voxel units for a plain mesh).
    radius : float, optional
        Initial brush radius (default 2 % of the mesh diagonal), in the mesh's units.
    window_size : tuple of 2 int
        Server render-window size.
    colour_updates : {"delta", "array"}
        Local mode, after a paint/undo/redo: ``delta`` sends only the changed proxy vertices' colours (page
        hook, in place); ``array`` re-synchronises the scene, which re-sends the whole colour array (the
        former behaviour, kept as the benchmark's baseline).
    interactive_faces : int or None
        Local mode: triangle budget of the level-of-detail proxy the page draws instead of the display proxy
        while a stroke or an orbit drag runs (software WebGL draws ~20k triangles at >= 5 frames per second, see
        ``benchmarks/vine_render.py``), in [4, 2**31 - 1]; ``None`` (or a budget at or above the display
        proxy's) draws the display proxy throughout.

    Attributes
    ----------
    proxy, view : DisplayProxy, plantvr.View
        The display proxy and the (server-side) view, whose render window the page mirrors: its layer
        ``"surface"`` draws the proxy (:attr:`surface`), its layer ``"lod"`` the level of detail.
    lod : DisplayProxy or None
        The level of detail drawn while painting (decimated from the display proxy to ``interactive_faces``).
    last_pick : dict or None
        The last picked point, ``{"worldPosition": [x, y, z], ...}``.
    last_stroke : list of (3,) ndarray
        Brush centres (world space) of the last stroke.
    deltas, delta_vertices, resyncs, pushes : int
        Colour-delta batches sent, proxy vertices in them (both levels), scene resyncs the page asked for, pushes.
    stroke_stats : dict
        Server-side counts and seconds of the page's stroke requests: ``requests``, ``stamps``, ``misses``,
        ``pick_s``, ``paint_s``, ``delta_s``.
    """

    def __init__(self, seg: Segmentation | None = None, *, proxy: DisplayProxy | None = None,
                 target_faces: int = 1_500_000, mode: str = "local", volume: np.ndarray | None = None,
                 level: float | None = None, radius: float | None = None, window_size=(900, 700),
                 colour_updates: str = "delta", interactive_faces: int | None = 20_000,
                 spacing=None, origin=None):
        from trame.app import get_server
        mode = check_choice("mode", mode, ("local", "remote"))
        self.colour_updates = check_choice("colour_updates", colour_updates, ("delta", "array"))
        target_faces = check_int("target_faces", target_faces, 4, 2 ** 31 - 1)
        self.interactive_faces = (None if interactive_faces is None
                                  else check_int("interactive_faces", interactive_faces, 4, 2 ** 31 - 1))
        if seg is not None and not isinstance(seg, Segmentation):
            raise ValueError(f"seg must be a Segmentation, got {type(seg).__name__}")
        sp0, org0 = ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)) if seg is None else (seg.spacing, seg.origin)
        grid = check_grid(sp0 if spacing is None else spacing, org0 if origin is None else origin)
        if seg is None:
            if volume is None:
                raise ValueError("give a Segmentation (seg) or a volume to mesh")
            from plantvr.vine.volume import suggest_level
            level = suggest_level(volume) if level is None else level
            seg = Segmentation.from_volume(volume, level, spacing=grid[0], origin=grid[1])
        #: the voxel grid the iso slider re-meshes ``volume`` on (physical units)
        self.spacing, self.origin = grid
        self.mode = mode
        self.volume = volume
        self.target_faces = target_faces
        self.window_size = tuple(window_size)
        self.server = get_server(f"vine_review_{next(_IDS)}", client_type="vue3")
        self.state, self.ctrl = self.server.state, self.server.controller
        self.port: int | None = None
        self.url: str | None = None
        self.pushes = 0
        self.deltas = 0                     # colour deltas sent (local mode)
        self.delta_vertices = 0             # proxy vertices in them, in total
        self.resyncs = 0                    # full colour re-synchronisations asked for by the page
        self._pending: list[np.ndarray] = []
        self._lod_pending: list[np.ndarray] = []
        self._full = False
        self._stroking = False
        self._loc = self._loc_key = None
        self.last_pick: dict | None = None
        self.last_stroke: list[np.ndarray] = []     # brush centres of the last stroke (world space)
        #: server-side seconds and counts of the page's stroke requests (pick, paint, delta building)
        self.stroke_stats = {"requests": 0, "stamps": 0, "misses": 0, "pick_s": 0.0, "paint_s": 0.0,
                             "delta_s": 0.0}
        self._thread: threading.Thread | None = None
        #: the review page's credential (Jupyter-style): :attr:`url` carries it, requests without it are refused
        self.token = secrets.token_urlsafe(32)
        self._host = "127.0.0.1"
        self.ctrl.on_server_bind.add(self._secure)
        self._set_segmentation(seg, proxy)
        diag = float(np.linalg.norm(np.ptp(seg.vertices, axis=0)))
        r0 = 0.02 * diag if radius is None else check_range("radius", radius, 0.0, seg.max_radius, low_open=True)
        r_max = float(f"{0.25 * diag:.3g}")         # 3 significant digits: a millimetre scan in metres keeps a range
        self.state.update({
            "label": 1, "radius": r0, "radius_max": r_max, "radius_step": min(0.01, float(f"{r_max / 1000:.1g}")),
            "hidden": [],
            "painted": 0, "can_undo": False, "can_redo": False, "level": float(level or 0.0),
            "histogram": histogram_svg(volume, level) if volume is not None else "",
            "n_full": seg.n_vertices, "n_proxy": self.proxy.n_vertices,
            "n_lod": 0 if self.lod is None else self.lod.n_vertices, "paint_drag": False,
            "vine_delta": None, "vine_stale": False, "wheel": "", "message": "",
        })
        self._render_wheel()
        self._build_ui()

    # ------------------------------------------------------------------ model
    def _set_segmentation(self, seg: Segmentation, proxy: DisplayProxy | None) -> None:
        from plantvr.types import LabelledSurface
        from plantvr.view import View
        view = getattr(self, "view", None)
        if view is not None:
            self.proxy.close()
            if self.lod is not None:
                self.lod.close()
        self.seg = seg
        self.proxy = proxy if proxy is not None else DisplayProxy(seg, target_faces=self.target_faces)
        self.proxy.observe(self._on_proxy_change, names="change")
        self.lod = None
        self._lod_pending = []
        if self.mode == "local" and self.interactive_faces is not None \
                and len(self.proxy.faces) > self.interactive_faces:
            # the level of detail drawn while a stroke or an orbit drag runs: visible here (trame-vtk sends
            # hidden actors without their data), hidden by the page hook at rest
            self.lod = self.proxy.coarser(self.interactive_faces)     # not a second pass over the full mesh
            self.lod.observe(self._on_lod_change, names="change")
        scene = {"surface": LabelledSurface(self.proxy),
                 "lod": None if self.lod is None else LabelledSurface(self.lod)}
        if view is None:
            self.view = View({k: c for k, c in scene.items() if c is not None}, off_screen=True,
                             window_size=self.window_size, background=(0.08, 0.08, 0.1))
        else:
            view.update(scene)
        self.view.plotter.reset_camera()
        self.view.plotter.camera.elevation = -35

    @property
    def surface(self):
        """The view's layer of the display proxy (a :class:`~plantvr.view.vine_layers.LabelledSurfaceLayer`)."""
        return self.view.layers["surface"]

    def _on_lod_change(self, event) -> None:
        self._note(event["new"], self._lod_pending)

    def _on_proxy_change(self, event) -> None:
        self._note(event["new"], self._pending)
        self.state.can_undo = self.seg.history.can_undo
        self.state.can_redo = self.seg.history.can_redo

    def _note(self, change, pending: list) -> None:
        """Queue a proxy change: its vertex ids for a colour delta, or a scene re-synchronisation."""
        if change.kind == "labels" and change.ids is not None:
            pending.append(np.asarray(change.ids))
        elif change.kind in ("colors", "visibility", "all", "labels"):
            self._full = True

    def colour_delta(self, *, lod: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The proxy vertices changed since the last push and their colours as drawn (consumes them).

        Parameters
        ----------
        lod : bool
            Those of the interactive level of detail (:attr:`lod`) instead of the display proxy.

        Returns
        -------
        ids : (M,) uint32 ndarray
            Sorted proxy vertex ids.
        rgba : (M, 4) uint8 ndarray
            Their colours, as in the view's colour array.
        """
        pending, layer = (self._lod_pending, self.view.layers.get("lod")) if lod else (self._pending, self.surface)
        ids = (np.unique(np.concatenate(pending)) if pending else np.zeros(0, np.int64))
        pending.clear()
        if layer is None:
            return np.zeros(0, np.uint32), np.zeros((0, 4), np.uint8)
        return ids.astype(np.uint32), np.ascontiguousarray(layer.mesh.point_data["rgba"][ids], dtype=np.uint8)

    def _delta(self, *, fine: bool = True, lod: bool = True) -> dict | None:
        """One colour-delta batch ``{seq, n, ids, rgba, more}`` for the page hook, or None when nothing changed.

        ``n, ids, rgba`` recolour the actor whose colour array has ``n`` tuples; ``more`` lists further
        ``{n, ids, rgba}`` parts (the other level of detail) applied with the same sequence number.
        """
        parts = []
        for want, is_lod, px in ((fine, False, self.proxy), (lod, True, self.lod)):
            if not want or px is None:
                continue
            ids, rgba = self.colour_delta(lod=is_lod)
            if ids.size:
                parts.append({"n": int(px.n_vertices), "ids": ids.astype("<u4").tobytes(), "rgba": rgba.tobytes()})
                self.delta_vertices += int(ids.size)
        if not parts:
            return None
        if not self.state.vine_stale:                   # the scene a page loads now lacks this: it must resync
            self.state.vine_stale = True
        self.deltas += 1
        return {"seq": self.deltas, **parts[0], "more": parts[1:]}

    def _status(self) -> None:
        self.state.hidden = [int(k) for k in np.nonzero(~self.seg.colors.visible)[0]]
        self._render_wheel()
        self.state.painted = int(np.count_nonzero(self.seg.labels))
        self.state.can_undo = self.seg.history.can_undo
        self.state.can_redo = self.seg.history.can_redo

    def _push(self) -> None:
        """Send what changed to the browser.

        Local mode: a colour delta of the changed proxy vertices (both levels of detail) when only labels
        changed, else a scene re-synchronisation (changed arrays only). Remote mode: a new image.
        """
        self._status()
        self.pushes += 1
        if self.mode == "local" and self.colour_updates == "delta" and not self._full:
            d = self._delta()
            if d is not None:
                self.state.vine_delta = d
            return
        self._pending, self._lod_pending, self._full = [], [], False
        self.state.vine_stale = False
        self.ctrl.view_update()

    def resync(self, *_args) -> None:
        """The page missed a delta (or loaded late): re-synchronise the whole scene once."""
        self.resyncs += 1
        self._pending, self._lod_pending, self._full = [], [], False
        self.state.vine_stale = False
        self.ctrl.view_update()

    # ------------------------------------------------------------------ commands (also callable from code)
    def _close_stroke(self) -> None:
        """End a stroke the page left open (its release never came) before another command."""
        if self._stroking:
            self._stroking = False
            self.seg.end_stroke()

    @_drawing
    def paint_world(self, point, *, radius: float | None = None, label: int | None = None) -> int:
        """Paint the full-resolution labels with the sphere brush at a world-space point; returns the count."""
        self._close_stroke()
        r = float(self.state.radius if radius is None else radius)
        lab = int(self.state.label if label is None else label)
        n = self.surface.paint_at(point, radius=r, label=lab)
        self._push()
        return n

    def _locator(self):
        """vtkStaticCellLocator over the drawn display proxy (visible triangles), rebuilt when they change."""
        mesh = self.surface.mesh
        key = (id(mesh), mesh.GetPolys().GetMTime(), mesh.GetPoints().GetMTime())
        if self._loc_key != key:
            from vtkmodules.vtkCommonDataModel import vtkPolyData, vtkStaticCellLocator
            geom = vtkPolyData()                        # geometry only: colour edits must not trigger a rebuild
            geom.SetPoints(mesh.GetPoints())
            geom.SetPolys(mesh.GetPolys())
            loc = vtkStaticCellLocator()
            loc.SetDataSet(geom)
            loc.BuildLocator()
            b = np.asarray(mesh.bounds, np.float64).reshape(3, 2)
            self._loc, self._loc_key, self._loc_geom = loc, key, geom
            self._loc_box = (b.mean(axis=1), float(np.linalg.norm(b[:, 1] - b[:, 0])) or 1.0)
        return self._loc

    def pick_display(self, x: float, y: float, camera: dict, size) -> np.ndarray | None:
        """World point of the drawn proxy under a page position, or None when the ray misses.

        The page sends the position in CSS pixels from the canvas's top-left corner, the canvas size and its
        vtk.js camera (it orbits in the browser); the ray (:func:`camera_ray`) is cast on the server against
        the display proxy's visible triangles with VTK's ``vtkStaticCellLocator``.
        """
        if self.surface.mesh.n_cells == 0:
            return None
        o, d = camera_ray(camera, x, y, size)
        loc = self._locator()
        centre, diag = self._loc_box
        if camera.get("parallelProjection"):                # start behind the scene, seen from the camera
            o = o - d * (abs(float(np.dot(centre - o, d))) + 2.0 * diag)
        far = o + d * (float(np.linalg.norm(centre - o)) + 2.0 * diag)
        from vtkmodules.vtkCommonCore import reference
        t, sub, cell = reference(0.0), reference(0), reference(0)
        x_hit, pc = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        if not loc.IntersectWithLine(o, far, 0.0, t, x_hit, pc, sub, cell):
            return None
        return np.asarray(x_hit, np.float64)

    @_drawing
    def stroke(self, phase: str, points, camera: dict | None = None, size=None) -> dict | None:
        """A brush stroke from the page: ``phase`` ``begin``, ``move`` or ``end`` of a paint drag, or ``click``.

        Each page position in ``points`` ((K, 2) CSS px) is picked on the server (:meth:`pick_display`) and
        stamped with the sphere brush on the full-resolution labels; a ``begin`` … ``end`` drag is one undo
        item. The changed colours come back as the return value (the page hook applies them, one render per
        batch): while the stroke runs only the interactive level of detail's (the one the page draws then),
        at its end the display proxy's as well. A ``click`` is one undoable stamp, sent like an undo's delta.
        """
        phase = check_choice("phase", phase, ("begin", "move", "end", "click"))
        pts = check_array("points", np.asarray(points if points is not None and len(points) else np.zeros((0, 2)),
                                               np.float64).reshape(-1, 2), shape=(None, 2))
        st = self.stroke_stats
        st["requests"] += 1
        label, r = int(self.state.label), float(self.state.radius)
        if phase in ("begin", "click") and not self.seg.colors.visible[label]:
            self.state.message = f"colour {label} is hidden: show it to paint with it"
            return None
        if phase == "begin":
            self._close_stroke()
            self.seg.begin_stroke()
            self._stroking, self.last_stroke = True, []
        elif phase in ("move", "end") and not self._stroking:
            return None
        for x, y in pts:
            t0 = time.perf_counter()
            p = self.pick_display(x, y, camera, size)
            t1 = time.perf_counter()
            st["pick_s"] += t1 - t0
            if p is None:
                st["misses"] += 1
                continue
            self.last_pick = {"worldPosition": p.tolist(), "position": {"x": float(x), "y": float(y)}}
            if phase == "click":
                self.on_pick(self.last_pick)
                st["paint_s"] += time.perf_counter() - t1
                return None
            self.surface.paint_at(p, radius=r, label=label)
            self.last_stroke.append(p)
            st["stamps"] += 1
            st["paint_s"] += time.perf_counter() - t1
        t0 = time.perf_counter()
        if phase == "end":
            self.seg.end_stroke()
            self._stroking = False
            self.state.message = ""
            self._status()
        if self._full or self.colour_updates == "array":    # the whole scene (a table change; the baseline)
            self._push()
            st["delta_s"] += time.perf_counter() - t0
            return None
        d = self._delta(fine=phase == "end" or self.lod is None, lod=True)
        st["delta_s"] += time.perf_counter() - t0
        return d

    def on_press(self, position) -> None:
        """Remote mode: left button down in the view (display coordinates)."""
        self._press = position
        self._dragged = False

    def on_release(self, position) -> None:
        """Remote mode: left button up; a move of more than 4 pixels since the press was an orbit, not a click."""
        p = getattr(self, "_press", None)
        if p and position:
            self._dragged = abs(position["x"] - p["x"]) + abs(position["y"] - p["y"]) > 4

    def on_pick(self, event) -> None:
        """A picked surface point: ``{"worldPosition": [x, y, z]}`` (local mode, from :meth:`stroke`) or a
        remote view's click ``{"position": {"x", "y"}}`` (display pixels, picked on the server's render
        window). Paints one undoable stamp."""
        self.last_pick = event
        if getattr(self, "_dragged", False):                # remote mode: the click that ends an orbit drag
            self._dragged = False
            return
        if not event:
            return
        if "worldPosition" in event:
            p = event["worldPosition"]
        else:
            from vtkmodules.vtkRenderingCore import vtkCellPicker
            pos = event.get("position", {})
            picker = vtkCellPicker()
            picker.SetTolerance(0.0005)
            if not picker.Pick(float(pos.get("x", 0)), float(pos.get("y", 0)), 0, self.view.plotter.renderer):
                return
            p = picker.GetPickPosition()
        try:
            self.paint_world(np.asarray(p, np.float64))
            self.state.message = ""
        except ValueError as exc:                           # e.g. painting with a hidden colour
            self.state.message = str(exc)

    @_drawing
    def undo(self) -> None:
        """Undo the last painting operation (full resolution)."""
        self._close_stroke()
        self.seg.undo()
        self._push()

    @_drawing
    def redo(self) -> None:
        """Redo the last undone operation."""
        self._close_stroke()
        self.seg.redo()
        self._push()

    def toggle_paint(self) -> None:
        """Local mode: a left drag paints a stroke (on) or orbits the view (off; a click paints a stamp).
        A ctrl-left drag always paints."""
        self.state.paint_drag = not bool(self.state.paint_drag)

    def toggle_selected(self) -> None:
        """Hide or show the selected colour (on the full mesh and the proxy)."""
        self.toggle_visible()

    @_drawing
    def toggle_visible(self, label: int | None = None) -> bool:
        """Hide or show a colour (default: the selected one) on the full mesh and the proxy; returns the new
        visibility."""
        label = int(self.state.label) if label is None else check_int("label", label, 0, len(self.seg.colors) - 1)
        shown = self.seg.toggle_visible(label)
        self._push()
        return shown

    def select(self, label: int) -> None:
        """Make ``label`` the brush colour (the wheel's raised slice); hidden colours may be selected, but
        painting with them is refused."""
        self.state.label = check_int("label", label, 0, len(self.seg.colors) - 1)
        self.state.message = ""
        self._render_wheel()

    def wheel_click(self, x: float, y: float, shift: bool = False) -> int | None:
        """A click on the wheel at ``(x, y)`` CSS px from its top-left corner (the page sends it).

        The slice is :func:`plantvr.vine.colors.slice_at` of the position in wheel units (y up); inside the dead
        zone the selected label is kept. A plain click selects the slice, a shift-click hides or shows it.
        Clicks outside the (raised) wheel do nothing and return ``None``; otherwise the slice is returned.
        """
        x = check_range("x", x, -1e6, 1e6)
        y = check_range("y", y, -1e6, 1e6)
        lift, cen = wheel_geometry(WHEEL_RADIUS)
        u, v = (x - cen) / WHEEL_RADIUS, -(y - cen) / WHEEL_RADIUS
        if np.hypot(u, v) > (WHEEL_RADIUS + lift) / WHEEL_RADIUS:
            return None
        n = len(self.seg.colors)
        k = slice_at(u, v, n, last=min(int(self.state.label), n - 1))
        if shift:
            self.toggle_visible(k)
        else:
            self.select(k)
        return k

    def _render_wheel(self, **_state) -> None:
        """Re-draw the wheel for the current table, visibility and selection (only sent when it changed)."""
        c = self.seg.colors
        label = int(self.state.label)
        if not 0 <= label < len(c):                 # a new surface's table may be shorter
            label = self.state.label = 0
        svg = wheel_svg(c.rgba, c.visible, label)
        if svg != self.state.wheel:
            self.state.wheel = svg

    @_drawing
    def apply_level(self) -> None:
        """Re-extract the isosurface at the slider's iso-value and show it (volume mode)."""
        if self.volume is None:
            return
        level = float(self.state.level)
        seg = Segmentation.from_volume(self.volume, level, spacing=self.spacing, origin=self.origin)
        self._set_segmentation(seg, None)
        self.state.histogram = histogram_svg(self.volume, level)
        self.state.n_full, self.state.n_proxy = seg.n_vertices, self.proxy.n_vertices
        self.state.n_lod = 0 if self.lod is None else self.lod.n_vertices
        self._push()
        self.ctrl.view_reset_camera()

    # ------------------------------------------------------------------ page
    def _build_ui(self) -> None:
        self.layout = build_page(self)

    # ------------------------------------------------------------------ serving
    def _secure(self, wslink_server) -> None:
        """trame's ``on_server_bind``: put :func:`access_guard` in front of every route (page, assets, websocket)."""
        wslink_server.app.middlewares.append(access_guard(self.token, self.port, self._host))

    def start(self, port: int | None = None, *, open_browser: bool = False, thread: bool = True,
              host: str = "127.0.0.1") -> str:
        """Serve the page; returns its URL, which carries the access token (``?token=...``).

        With ``thread=True`` the server runs in a daemon thread; otherwise the URL is printed and this call
        blocks. Every request without the token (or the cookie the tokened URL sets), or from another origin,
        is refused (:func:`access_guard`).
        """
        self.port = _free_port() if not port else check_int("port", port, 1, 65535)
        if not isinstance(host, str) or not host:
            raise ValueError(f"host must be a non-empty string, got {host!r}")
        self._host = host
        self._render_wheel()                        # the label may have been set from code before serving
        if self.mode == "local":
            self._locator()                         # server-side picking: build the ray locator up front
        self.url = f"http://{host if ':' not in host else f'[{host}]'}:{self.port}/?token={self.token}"
        if open_browser:                            # trame would open the page without the token
            import webbrowser
            self.ctrl.on_server_ready.add(lambda **_: webbrowser.open(self.url))
        kw = {"open_browser": False, "show_connection_info": False, "disable_logging": True, "timeout": 0}
        if not thread:
            print(f"ViNE review page (keep the token private): {self.url}", flush=True)
            self.server.start(host=host, port=self.port, **kw)
            return self.url
        self._thread = serve_in_thread(self.server, host, self.port, **kw)
        return self.url

    def stop(self) -> None:
        """Stop the server (thread mode) and release the view."""
        loop = getattr(self.server, "_loop", None) or getattr(self.server, "loop", None)
        if self._thread is not None and loop is not None:
            asyncio.run_coroutine_threadsafe(self.server.stop(), loop)
            self._thread.join(timeout=5)
        self.proxy.close()
        if self.lod is not None:
            self.lod.close()
        self.view.close()

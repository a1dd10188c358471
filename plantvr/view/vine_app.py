"""In-browser review of a ViNE segmentation with trame (spec 000_vine §2.4–2.6; issues 6 and 14).

The browser draws a decimated :class:`~plantvr.vine.proxy.DisplayProxy` on the user's own GPU (trame-vtk
``VtkLocalView``, vtk.js): the mesh and its colours are sent once, and after each paint, undo or redo only
the changed proxy vertices travel, as a colour delta ``(ids uint32, rgba uint8)`` in the state variable
``vine_delta`` that a small page hook (``vine_delta.js``) writes into the vtk.js actor's scalar array in place
before re-rendering (8 B per changed proxy vertex instead of 4 B per proxy vertex). Hiding a colour or a new
iso-value changes the triangles, so those re-synchronise the scene (trame-vtk fetches arrays by content hash:
only the changed arrays travel). A click on the surface is picked in the browser (vtk.js hardware selector)
and its world position comes back to the server, where the sphere brush paints the *full-resolution* labels;
the proxy follows by per-vertex deltas. ``mode="remote"`` renders on the server instead (``VtkRemoteView``,
images over the websocket) for comparison; ``benchmarks/vine_render.py`` measures both.

Controls: the colour wheel (§2.4.1 [T §5.4.1], §2.6 [T §5.6]: one slice per colour-table entry, the selected
slice raised and outlined, hidden colours drawn with radial lines; a click selects the slice under the mouse by
the rule of :func:`plantvr.ui.wheel.slice_at`, a shift-click hides or shows it), brush radius, undo/redo,
hide/show of the selected colour, and, when started from a volume, an iso-value slider over the volume's
histogram that re-extracts the surface. The wheel is an SVG built here (:func:`wheel_svg`) and re-sent when the
selection, a colour or a visibility changes.
"""
from __future__ import annotations

import asyncio
import itertools
import os
import socket
import threading
import time
from pathlib import Path

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np

from plantvr._validation import check_array, check_choice, check_int, check_range
from plantvr.vine.proxy import DisplayProxy
from plantvr.vine.segmentation import Segmentation

__all__ = ["WHEEL_RADIUS", "VineReviewApp", "histogram_svg", "main_segment", "wheel_geometry", "wheel_svg"]

_IDS = itertools.count()
_DELTA_JS = Path(__file__).with_name("vine_delta.js")
_VIEW_REF = "vine_view"


def histogram_svg(volume: np.ndarray, level: float, *, bins: int = 64, width: int = 260, height: int = 48) -> str:
    """A small SVG bar chart of a volume's intensity histogram (log counts) with the iso-value as a red line."""
    from plantvr.vine.volume import histogram
    counts, edges = histogram(volume, bins=bins)
    c = np.log1p(np.asarray(counts, np.float64))
    c = c / max(c.max(), 1e-9)
    w = width / len(c)
    bars = "".join(f'<rect x="{i * w:.1f}" y="{height * (1 - h):.1f}" width="{max(w - 0.5, 0.5):.1f}" '
                   f'height="{height * h:.1f}" fill="#8aa"/>' for i, h in enumerate(c))
    x = width * (float(level) - float(edges[0])) / max(float(edges[-1] - edges[0]), 1e-9)
    return (f'<svg class="vine-histogram" width="{width}" height="{height}" style="background:#223">{bars}'
            f'<line x1="{x:.1f}" x2="{x:.1f}" y1="0" y2="{height}" stroke="#f33" stroke-width="2"/></svg>')


#: Wheel radius in CSS pixels; the selected slice is raised by a sixth of it, with a margin around.
WHEEL_RADIUS = 72.0


def wheel_geometry(radius: float) -> tuple[float, float]:
    """(raise, centre) in px of a wheel of ``radius`` px in [8, 1000]: the selected slice reaches
    ``radius + raise``; the wheel's square box has side ``2 * centre``."""
    radius = check_range("radius", radius, 8.0, 1000.0)
    lift = radius / 6.0
    return lift, radius + lift + 6.0


def _ink(rgb) -> str:
    """Black or white, whichever contrasts with ``rgb`` (luma 0.299/0.587/0.114)."""
    r, g, b = (float(v) for v in rgb[:3])
    return "#000" if 0.299 * r + 0.587 * g + 0.114 * b > 140 else "#fff"


def wheel_svg(rgba, visible, selected: int, *, radius: float = WHEEL_RADIUS) -> str:
    """The colour wheel as an SVG string (spec 000_vine §2.4.1, §2.6; Fig. 5.9, 5.11).

    Slice ``k`` spans angles ``[k, k + 1) * 2π / K`` counter-clockwise from +x (y up), the rule of
    :func:`plantvr.ui.wheel.slice_at`. The selected slice is drawn last, raised by ``radius / 6`` and outlined;
    a hidden colour keeps its slice, crossed by five contrasting radial lines. Each slice is a ``<g>`` with
    ``data-index``, class ``wheel-slice`` and, where they apply, ``selected`` and ``hidden``.

    Parameters
    ----------
    rgba : (K, 3 or 4) uint8 array_like
        The colour table, K in [1, 256].
    visible : (K,) bool array_like
        Visibility per colour.
    selected : int
        The active label, in [0, K).
    radius : float
        Wheel radius in px, in [8, 1000].

    Returns
    -------
    str
        ``<svg class="vine-wheel-svg" ...>`` of side ``2 * (radius + radius / 6 + 6)`` px.

    References
    ----------
    .. [1] spec 000_vine §2.4.1 (wheel, slice index [INFERRED]) and §2.6 (hidden colours: radial lines).
    """
    c = np.asarray(rgba)
    if c.ndim != 2 or c.shape[1] not in (3, 4) or not 1 <= c.shape[0] <= 256:
        raise ValueError(f"rgba must have shape (K, 3) or (K, 4) with K in [1, 256], got {c.shape}")
    c = check_array("rgba", c, shape=(None, c.shape[1]), dtype=np.float64)
    if np.any(c < 0) or np.any(c > 255):
        raise ValueError("rgba must be in [0, 255]")
    n = c.shape[0]
    vis = check_array("visible", visible, shape=(n,), dtype=bool)
    selected = check_int("selected", selected, 0, n - 1)
    radius = check_range("radius", radius, 8.0, 1000.0)
    from plantvr.ui.wheel import DEAD_ZONE
    lift, cen = wheel_geometry(radius)
    da = 2 * np.pi / n

    def xy(r, a):
        return cen + r * np.cos(a), cen - r * np.sin(a)

    def pt(r, a):
        return "{:.2f} {:.2f}".format(*xy(r, a))

    parts = []
    for k in [k for k in range(n) if k != selected] + [selected]:        # the selection on top
        sel, hid = k == selected, not vis[k]
        r, a0, a1 = (radius + lift if sel else radius), k * da, (k + 1) * da
        fill = "rgb({},{},{})".format(*(round(v) for v in c[k, :3]))
        if n == 1:
            d = (f"M {cen - r:.2f} {cen:.2f} a {r:.2f} {r:.2f} 0 1 0 {2 * r:.2f} 0 "
                 f"a {r:.2f} {r:.2f} 0 1 0 {-2 * r:.2f} 0")
        else:
            d = f"M {cen:.2f} {cen:.2f} L {pt(r, a0)} A {r:.2f} {r:.2f} 0 {int(da > np.pi)} 0 {pt(r, a1)} Z"
        cls = "wheel-slice" + (" selected" if sel else "") + (" hidden" if hid else "")
        g = [f'<g class="{cls}" data-index="{k}">',
             (f'<path d="{d}" fill="{fill}" stroke="{"#111" if sel else "#fff"}" '
              f'stroke-width="{3 if sel else 1}" stroke-linejoin="round"/>')]
        ink = _ink(c[k])
        if hid:                                                            # §2.6: radial lines across the slice
            for i in range(1, 6):
                a = a0 + i / 6 * da
                (x1, y1), (x2, y2) = xy(0.25 * r, a), xy(0.97 * r, a)
                g.append(f'<line class="wheel-hidden-line" x1="{x1:.2f}" y1="{y1:.2f}" x2="{x2:.2f}" '
                         f'y2="{y2:.2f}" stroke="{ink}" stroke-width="2"/>')
        tx, ty = xy(0.7 * r, a0 + da / 2)
        g.append(f'<text x="{tx:.2f}" y="{ty + 4:.2f}" text-anchor="middle" font-size="11" '
                 f'font-family="sans-serif" fill="{ink}" pointer-events="none">{k}</text></g>')
        parts.append("".join(g))
    side = 2 * cen
    return (f'<svg class="vine-wheel-svg" xmlns="http://www.w3.org/2000/svg" width="{side:.0f}" '
            f'height="{side:.0f}" viewBox="0 0 {side:.0f} {side:.0f}" style="display:block">{"".join(parts)}'
            f'<circle cx="{cen:.2f}" cy="{cen:.2f}" r="{DEAD_ZONE * radius:.2f}" fill="#2a2a30" stroke="#888"/>'
            "</svg>")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


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
    volume : (X, Y, Z) uint8/uint16 ndarray, optional
        Source volume; enables the iso-value slider and histogram.
    level : float, optional
        Iso-value for ``volume`` (default: Otsu, :func:`plantvr.vine.volume.suggest_level`).
    radius : float, optional
        Initial brush radius (default 2 % of the mesh diagonal).
    window_size : tuple of 2 int
        Server render-window size.
    colour_updates : {"delta", "array"}
        Local mode, after a paint/undo/redo: ``delta`` sends only the changed proxy vertices' colours (page
        hook, in place); ``array`` re-synchronises the scene, which re-sends the whole colour array (the
        former behaviour, kept as the benchmark's baseline).
    """

    def __init__(self, seg: Segmentation | None = None, *, proxy: DisplayProxy | None = None,
                 target_faces: int = 1_500_000, mode: str = "local", volume: np.ndarray | None = None,
                 level: float | None = None, radius: float | None = None, window_size=(900, 700),
                 colour_updates: str = "delta"):
        from trame.app import get_server
        mode = check_choice("mode", mode, ("local", "remote"))
        self.colour_updates = check_choice("colour_updates", colour_updates, ("delta", "array"))
        target_faces = check_int("target_faces", target_faces, 4, 2 ** 31 - 1)
        if seg is None:
            if volume is None:
                raise ValueError("give a Segmentation (seg) or a volume to mesh")
            from plantvr.vine.volume import suggest_level
            level = suggest_level(volume) if level is None else level
            seg = Segmentation.from_volume(volume, level)
        if not isinstance(seg, Segmentation):
            raise ValueError(f"seg must be a Segmentation, got {type(seg).__name__}")  # noqa: TRY004
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
        self._full = False
        self._thread: threading.Thread | None = None
        self._set_segmentation(seg, proxy)
        diag = float(np.linalg.norm(np.ptp(seg.vertices, axis=0)))
        r0 = 0.02 * diag if radius is None else check_range("radius", radius, 0.0, seg.max_radius, low_open=True)
        self.state.update({
            "label": 1, "radius": r0, "radius_max": round(0.25 * diag, 3), "hidden": [],
            "painted": 0, "can_undo": False, "can_redo": False, "level": float(level or 0.0),
            "histogram": histogram_svg(volume, level) if volume is not None else "",
            "n_full": seg.n_vertices, "n_proxy": self.proxy.n_vertices,
            "vine_delta": None, "wheel": "", "message": "",
        })
        self._render_wheel()
        self._build_ui()

    # ------------------------------------------------------------------ model
    def _set_segmentation(self, seg: Segmentation, proxy: DisplayProxy | None) -> None:
        from plantvr.view.segmentation import SegmentationView
        old = getattr(self, "view", None)
        plotter = None
        if old is not None:
            old.src.unobserve(old._on_change)
            old.plotter.remove_actor(old.actor)
            plotter = old.plotter
            self.proxy.close()
        self.seg = seg
        self.proxy = proxy if proxy is not None else DisplayProxy(seg, target_faces=self.target_faces)
        self.view = SegmentationView(seg, proxy=self.proxy, plotter=plotter, window_size=self.window_size,
                                     background=(0.08, 0.08, 0.1))
        self.proxy.observe(self._on_proxy_change)
        self.view.plotter.reset_camera()
        self.view.plotter.camera.elevation = -35

    def _on_proxy_change(self, kind, ids) -> None:
        if kind == "labels" and ids is not None:
            self._pending.append(np.asarray(ids))
        else:
            self._full = True
        self.state.can_undo = bool(self.seg.history.undo_stack)
        self.state.can_redo = bool(self.seg.history.redo_stack)

    def colour_delta(self) -> tuple[np.ndarray, np.ndarray]:
        """The proxy vertices changed since the last push and their colours as drawn (consumes them).

        Returns
        -------
        ids : (M,) uint32 ndarray
            Sorted proxy vertex ids.
        rgba : (M, 4) uint8 ndarray
            Their colours, as in the view's colour array.
        """
        ids = (np.unique(np.concatenate(self._pending)) if self._pending else np.zeros(0, np.int64))
        self._pending = []
        return ids.astype(np.uint32), np.ascontiguousarray(self.view.mesh.point_data["rgba"][ids], dtype=np.uint8)

    def _push(self) -> None:
        """Send what changed to the browser.

        Local mode: a colour delta of the changed proxy vertices when only labels changed, else a scene
        re-synchronisation (changed arrays only). Remote mode: a new image.
        """
        self.state.hidden = [int(k) for k in np.nonzero(~self.seg.colors.visible)[0]]
        self._render_wheel()
        self.state.painted = int(np.count_nonzero(self.seg.labels))
        self.pushes += 1
        if self.mode == "local" and self.colour_updates == "delta" and not self._full:
            ids, rgba = self.colour_delta()
            if ids.size:
                self.deltas += 1
                self.delta_vertices += int(ids.size)
                self.state.vine_delta = {"seq": self.deltas, "n": int(self.proxy.n_vertices),
                                         "ids": ids.astype("<u4").tobytes(), "rgba": rgba.tobytes()}
            return
        self._pending, self._full = [], False
        self.ctrl.view_update()

    def resync(self, *_args) -> None:
        """The page missed a delta (or loaded late): re-synchronise the whole scene once."""
        self.resyncs += 1
        self._pending, self._full = [], False
        self.ctrl.view_update()

    # ------------------------------------------------------------------ commands (also callable from code)
    def paint_world(self, point, *, radius: float | None = None, label: int | None = None) -> int:
        """Paint the full-resolution labels with the sphere brush at a world-space point; returns the count."""
        r = float(self.state.radius if radius is None else radius)
        lab = int(self.state.label if label is None else label)
        n = self.view.paint_at(point, radius=r, label=lab)
        self._push()
        return n

    def on_press(self, position) -> None:
        """Left button down in the view (display coordinates)."""
        self._press = position
        self._dragged = False

    def on_release(self, position) -> None:
        """Left button up: a move of more than 4 pixels since the press was an orbit, not a click."""
        p = getattr(self, "_press", None)
        if p and position:
            self._dragged = abs(position["x"] - p["x"]) + abs(position["y"] - p["y"]) > 4

    def on_pick(self, event) -> None:
        """Browser click: local mode brings the picked world position, remote mode the display position.

        The click that ends an orbit drag is ignored (the browser fires a click after any press and release).
        """
        self.last_pick = event
        if getattr(self, "_dragged", False):
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

    def undo(self) -> None:
        """Undo the last painting operation (full resolution)."""
        self.seg.undo()
        self._push()

    def redo(self) -> None:
        """Redo the last undone operation."""
        self.seg.redo()
        self._push()

    def toggle_selected(self) -> None:
        """Hide or show the selected colour (on the full mesh and the proxy)."""
        self.toggle_visible()

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

        The slice is :func:`plantvr.ui.wheel.slice_at` of the position in wheel units (y up); inside the dead
        zone the selected label is kept. A plain click selects the slice, a shift-click hides or shows it.
        Clicks outside the (raised) wheel do nothing and return ``None``; otherwise the slice is returned.
        """
        from plantvr.ui.wheel import slice_at
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

    def apply_level(self) -> None:
        """Re-extract the isosurface at the slider's iso-value and show it (volume mode)."""
        if self.volume is None:
            return
        level = float(self.state.level)
        seg = Segmentation.from_volume(self.volume, level)
        self._set_segmentation(seg, None)
        self.state.histogram = histogram_svg(self.volume, level)
        self.state.n_full, self.state.n_proxy = seg.n_vertices, self.proxy.n_vertices
        self._push()
        self.ctrl.view_reset_camera()

    # ------------------------------------------------------------------ page
    def _build_ui(self) -> None:
        from trame.ui.vuetify3 import SinglePageLayout
        from trame.widgets import client, html
        from trame.widgets import vtk as vtk_widgets
        from trame.widgets import vuetify3 as v3
        ctrl = self.ctrl
        ctrl.undo, ctrl.redo, ctrl.toggle_selected = self.undo, self.redo, self.toggle_selected
        ctrl.apply_level = self.apply_level
        self.server.trigger("vine_resync")(self.resync)
        self.state.change("label")(self._render_wheel)
        side = 2 * wheel_geometry(WHEEL_RADIUS)[1]
        # click position relative to the wheel's box (its SVG fills it exactly) and the shift key
        where = ("[$event.clientX - $event.currentTarget.getBoundingClientRect().left, "
                 "$event.clientY - $event.currentTarget.getBoundingClientRect().top, $event.shiftKey]")
        with SinglePageLayout(self.server) as layout:
            layout.title.set_text("ViNE review")
            with layout.toolbar:
                v3.VSpacer()
                v3.VSlider(v_model=("radius",), min=0.0, max=("radius_max",), step=0.01, label="radius",
                           hide_details=True, density="compact", style="max-width: 220px",
                           classes="vine-radius mx-2")
                v3.VBtn("undo", click=ctrl.undo, disabled=("!can_undo",), classes="vine-undo")
                v3.VBtn("redo", click=ctrl.redo, disabled=("!can_redo",), classes="vine-redo")
                v3.VBtn("hide/show", click=ctrl.toggle_selected, classes="vine-toggle")
            # fill v-main between the 64 px toolbar and the 20 px footer (no page scroll, status line above the
            # footer); a fixed figure: following vuetify's --v-layout-* variables, set as the footer mounts, makes
            # vtk.js's ResizeObserver report an undelivered-notifications loop
            fill = "height: calc(100vh - 84px);"
            with layout.content, html.Div(classes="d-flex", style=fill):
                with html.Div(classes="vine-panel d-flex flex-column align-center pa-2",
                              style=f"flex: 0 0 {side + 24:.0f}px; overflow: hidden; background: #1b1b20; "
                                    "color: #ddd; font: 13px sans-serif;"):
                    html.Div(v_html=("wheel",), classes="vine-wheel", click=(self.wheel_click, where),
                             style=f"width: {side:.0f}px; height: {side:.0f}px; cursor: pointer; user-select: none;")
                    html.Div("label {{ label }}{{ hidden.includes(label) ? ' (hidden)' : '' }}",
                             classes="vine-label mt-1")
                    html.Div("click: select, shift-click: hide/show", style="font-size: 11px; color: #999;")
                    html.Div("{{ message }}", classes="vine-message", style="font-size: 11px; color: #f88; "
                             f"max-width: {side:.0f}px;")
                with html.Div(style="position: relative; flex: 1 1 0; min-width: 0; height: 100%; "
                                    "overflow: hidden;"):
                    kw = {"picking_modes": ("picking_modes", ["click"]), "click": (self.on_pick, "[$event]"),
                          "interactor_settings": ("interactor_settings", _INTERACTOR),
                          # a DOM click also ends every orbit drag: press/release positions tell them apart
                          "interactor_events": ("interactor_events", ["LeftButtonPress", "LeftButtonRelease"]),
                          "LeftButtonPress": (self.on_press, "[$event.position]"),
                          "LeftButtonRelease": (self.on_release, "[$event.position]")}
                    if self.mode == "local":
                        view = vtk_widgets.VtkLocalView(self.view.plotter.ren_win, classes="vine-view",
                                                        ref=_VIEW_REF, **kw)
                        client.Script(_DELTA_JS.read_text())
                        client.ClientStateChange(value="vine_delta", trigger_on_create=True,
                                                 change=f"trame.utils.vine && trame.utils.vine.apply('{_VIEW_REF}', "
                                                        "vine_delta)")
                    else:
                        view = vtk_widgets.VtkRemoteView(self.view.plotter.ren_win, classes="vine-view",
                                                         interactive_ratio=1, **kw)
                    ctrl.view_update = view.update
                    ctrl.view_reset_camera = view.reset_camera
                    with html.Div(style="position: absolute; left: 8px; bottom: 8px; color: #ddd; "
                                        "font: 12px sans-serif;", classes="vine-status"):
                        html.Div("{{ n_full.toLocaleString() }} vertices, proxy {{ n_proxy.toLocaleString() }}; "
                                 "painted {{ painted.toLocaleString() }}")
                        if self.volume is not None:
                            html.Div(v_html=("histogram",))
                            v3.VSlider(v_model=("level",), min=1, max=float(np.iinfo(self.volume.dtype).max) - 1,
                                       step=1, hide_details=True, density="compact", style="width: 260px",
                                       label="iso", classes="vine-level", end=ctrl.apply_level)
        self.layout = layout

    # ------------------------------------------------------------------ serving
    def start(self, port: int | None = None, *, open_browser: bool = False, thread: bool = True,
              host: str = "127.0.0.1") -> str:
        """Serve the page; returns its URL. With ``thread=True`` the server runs in a daemon thread."""
        self.port = _free_port() if not port else check_int("port", port, 1, 65535)
        self._render_wheel()                        # the label may have been set from code before serving
        self.url = f"http://{host}:{self.port}/"
        kw = {"port": self.port, "open_browser": open_browser, "show_connection_info": False, "disable_logging": True,
                  "timeout": 0, "host": host}
        if not thread:
            self.server.start(**kw)
            return self.url

        def run():
            asyncio.set_event_loop(asyncio.new_event_loop())
            self.server.start(thread=True, **kw)
        self._thread = threading.Thread(target=run, name="vine-trame", daemon=True)
        self._thread.start()
        deadline = time.time() + 30
        while time.time() < deadline:
            try:
                with socket.create_connection((host, self.port), timeout=0.2):
                    return self.url
            except OSError:
                time.sleep(0.1)
        raise RuntimeError(f"trame server did not start on {self.url}")

    def stop(self) -> None:
        """Stop the server (thread mode) and release the view."""
        loop = getattr(self.server, "_loop", None) or getattr(self.server, "loop", None)
        if self._thread is not None and loop is not None:
            asyncio.run_coroutine_threadsafe(self.server.stop(), loop)
            self._thread.join(timeout=5)
        self.proxy.close()
        self.view.close()


#: Left drag rotates, middle/shift-left pans, right/wheel zooms (clicks without a drag pick and paint).
_INTERACTOR = [
    {"button": 1, "action": "Rotate"},
    {"button": 2, "action": "Pan"},
    {"button": 3, "action": "Zoom", "scrollEnabled": True},
    {"button": 1, "action": "Pan", "shift": True},
    {"button": 1, "action": "Zoom", "alt": True},
    {"button": 1, "action": "Roll", "alt": True, "shift": True},
]


def main_segment(argv: list[str] | None = None) -> int:
    """``plantvr segment VOLUME_OR_SYNTH [--level L] [--port P] [--out DIR]`` (issue 14).

    Builds the isosurface of a volume (or opens a mesh, or a synthetic head with ``synth`` / ``synth:N``), then
    either serves the browser review page (until interrupted) or, with ``--out``, paints a scripted demo
    headless and writes ``DIR/segment.ply`` (per-vertex colours and labels), ``DIR/segment_session.npz`` and a
    proxy screenshot ``DIR/segment.png``. Returns the process exit code.
    """
    import argparse

    from plantvr.vine.app import open_source, paint_demo
    ap = argparse.ArgumentParser(prog="plantvr segment", description=main_segment.__doc__.split("\n")[0])
    ap.add_argument("source", help="volume file (.tif/.npy/.npz/.nrrd), mesh file (.ply/.obj/...), or synth[:N]")
    ap.add_argument("--level", type=float, default=None, help="iso-value (default: Otsu / the synthetic one)")
    ap.add_argument("--downsample", action="store_true", help="2x block-mean downsampling before meshing")
    ap.add_argument("--port", type=int, default=None, help="port of the review page (default: a free one)")
    ap.add_argument("--faces", type=int, default=1_500_000, help="display-proxy triangle budget")
    ap.add_argument("--mode", choices=("local", "remote"), default="local",
                    help="local: the browser draws the proxy (vtk.js); remote: the server renders")
    ap.add_argument("--out", type=str, default=None, help="headless: paint a demo and write PLY/session/PNG here")
    ap.add_argument("--stamps", type=int, default=24, help="demo brush stamps with --out")
    a = ap.parse_args(argv)
    try:
        src = open_source(a.source, level=a.level, downsample=a.downsample)
    except ValueError as exc:
        print(f"plantvr segment: {exc}")
        return 2
    seg = src.seg
    print(f"surface: {seg.n_vertices:,} vertices, {len(seg.faces):,} faces"
          + (f" (iso-value {src.level:g})" if src.level is not None else ""))
    if a.out:
        from pathlib import Path

        from plantvr.view.segmentation import SegmentationView
        out = Path(a.out)
        out.mkdir(parents=True, exist_ok=True)
        n = paint_demo(seg, truth=src.truth, stamps=a.stamps)
        seg.export_ply(out / "segment.ply")
        seg.save(out / "segment_session.npz", include_mesh=False)
        proxy = DisplayProxy(seg, target_faces=a.faces)
        view = SegmentationView(seg, proxy=proxy, window_size=(800, 600), background=(0.08, 0.08, 0.1))
        view.plotter.reset_camera()
        view.plotter.camera.elevation = -35
        view.screenshot(out / "segment.png")
        view.close()
        proxy.close()
        print(f"painted {n:,} vertices; wrote {out / 'segment.ply'}, {out / 'segment_session.npz'}, "
              f"{out / 'segment.png'}")
        return 0
    app = VineReviewApp(seg, target_faces=a.faces, mode=a.mode, volume=src.volume, level=src.level)
    print(f"display proxy: {app.proxy.n_vertices:,} vertices, {len(app.proxy.faces):,} faces")
    app.start(a.port, thread=False, open_browser=False)
    return 0

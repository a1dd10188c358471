"""The ViNE review page: its trame layout (toolbar, colour wheel, the vtk.js or remote view, status line and iso
slider) bound to a :class:`~plantvr.view.vine_app.VineReviewApp`'s commands and state (spec 000_vine §2.4–2.6).

In ``"local"`` mode the page hook ``vine_delta.js`` writes the colour deltas into the vtk.js actor and sends
clicks and paint drags to the server for picking; in ``"remote"`` mode the view is ``VtkRemoteView`` and clicks
are picked on the server.
"""
from __future__ import annotations

from pathlib import Path

from .._fileio import read_text
from ._render_lock import lock_trame_image_delivery
from .vine_svg import WHEEL_RADIUS, _level_slider, wheel_geometry

__all__ = ["build_page"]

_DELTA_JS = Path(__file__).with_name("vine_delta.js")
_VIEW_REF = "vine_view"


def build_page(app):
    """The page of ``app`` (a trame ``SinglePageLayout``), its buttons and triggers bound to ``app``'s commands."""
    lock_trame_image_delivery()         # remote mode: the server's renders take the view's lock
    from trame.ui.vuetify3 import SinglePageLayout
    from trame.widgets import client, html
    from trame.widgets import vtk as vtk_widgets
    from trame.widgets import vuetify3 as v3
    ctrl = app.ctrl
    ctrl.undo, ctrl.redo, ctrl.toggle_selected = app.undo, app.redo, app.toggle_selected
    ctrl.apply_level = app.apply_level
    app.server.trigger("vine_resync")(app.resync)
    app.server.trigger("vine_stroke")(app.stroke)
    ctrl.toggle_paint = app.toggle_paint
    app.state.change("label")(app._render_wheel)
    side = 2 * wheel_geometry(WHEEL_RADIUS)[1]
    # click position relative to the wheel's box (its SVG fills it exactly) and the shift key
    where = ("[$event.clientX - $event.currentTarget.getBoundingClientRect().left, "
             "$event.clientY - $event.currentTarget.getBoundingClientRect().top, $event.shiftKey]")
    with SinglePageLayout(app.server) as layout:
        layout.title.set_text("ViNE review")
        with layout.toolbar:
            v3.VSpacer()
            v3.VSlider(v_model=("radius",), min=0.0, max=("radius_max",), step=("radius_step",), label="radius",
                       hide_details=True, density="compact", style="max-width: 220px",
                       classes="vine-radius mx-2")
            if app.mode == "local":
                v3.VBtn("{{ paint_drag ? 'paint: drag' : 'paint: click' }}", click=ctrl.toggle_paint,
                        classes="vine-paint", variant=("paint_drag ? 'flat' : 'text'",))
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
                html.Div(v_html=("wheel",), classes="vine-wheel", click=(app.wheel_click, where),
                         style=f"width: {side:.0f}px; height: {side:.0f}px; cursor: pointer; user-select: none;")
                html.Div("label {{ label }}{{ hidden.includes(label) ? ' (hidden)' : '' }}",
                         classes="vine-label mt-1")
                html.Div("click: select, shift-click: hide/show", style="font-size: 11px; color: #999;")
                html.Div("{{ message }}", classes="vine-message", style="font-size: 11px; color: #f88; "
                         f"max-width: {side:.0f}px;")
            with html.Div(style="position: relative; flex: 1 1 0; min-width: 0; height: 100%; "
                                "overflow: hidden;"):
                kw = {"interactor_settings": ("interactor_settings", _INTERACTOR)}
                if app.mode == "local":
                    # clicks and paint drags are handled by the page hook (server-side picking), orbit
                    # drags by vtk.js; no hardware selector pass in the browser
                    view = vtk_widgets.VtkLocalView(app.view.plotter.ren_win, classes="vine-view",
                                                    ref=_VIEW_REF, **kw)
                    client.Script(read_text(_DELTA_JS, what="page script"))
                    client.ClientStateChange(value="vine_delta", trigger_on_create=True,
                                             change=f"trame.utils.vine && trame.utils.vine.apply('{_VIEW_REF}', "
                                                    "vine_delta)")
                else:
                    kw.update({"picking_modes": ("picking_modes", ["click"]), "click": (app.on_pick, "[$event]"),
                               # a DOM click also ends every orbit drag: press/release positions tell them apart
                               "interactor_events": ("interactor_events", ["LeftButtonPress", "LeftButtonRelease"]),
                               "LeftButtonPress": (app.on_press, "[$event.position]"),
                               "LeftButtonRelease": (app.on_release, "[$event.position]")})
                    view = vtk_widgets.VtkRemoteView(app.view.plotter.ren_win, classes="vine-view",
                                                     interactive_ratio=1, **kw)
                ctrl.view_update = view.update
                ctrl.view_reset_camera = view.reset_camera
                with html.Div(style="position: absolute; left: 8px; bottom: 8px; color: #ddd; "
                                    "font: 12px sans-serif;", classes="vine-status"):
                    html.Div("{{ n_full.toLocaleString() }} vertices, proxy {{ n_proxy.toLocaleString() }}; "
                             "painted {{ painted.toLocaleString() }}")
                    if app.volume is not None:
                        html.Div(v_html=("histogram",))
                        v3.VSlider(v_model=("level",), **_level_slider(app.volume),
                                   hide_details=True, density="compact", style="width: 260px",
                                   label="iso", classes="vine-level", end=ctrl.apply_level)
    return layout


#: Left drag rotates, middle/shift-left pans, right/wheel zooms (clicks without a drag pick and paint).
_INTERACTOR = [
    {"button": 1, "action": "Rotate"},
    {"button": 2, "action": "Pan"},
    {"button": 3, "action": "Zoom", "scrollEnabled": True},
    {"button": 1, "action": "Pan", "shift": True},
    {"button": 1, "action": "Zoom", "alt": True},
    {"button": 1, "action": "Roll", "alt": True, "shift": True},
]

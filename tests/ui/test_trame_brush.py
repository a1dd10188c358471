"""The brush in a trame (server-rendered) view: browser mouse events replayed on the plotter's VTK interactor.

First through trame-vtk's own server-side mouse handler (the code a remote view's websocket calls), then
end to end: a trame page from :func:`plantvr.view.interaction.trame_app` in a subprocess, dragged in
headless Chromium; the page's status line (synced from the document) shows the paint commands.
"""
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import CHROMIUM, launch_chromium
from plantvr.view.interaction import BrushInteractor, trame_app

from ._jupyter import free_port, repo_env, screenshot_dir, serve
from ._views import grown_model_view

trame_vtk_mouse = pytest.importorskip("trame_vtk.modules.vtk.protocols.mouse_handler")
pytest.importorskip("trame_pyvista")
from vtkmodules.vtkWebCore import vtkWebApplication


@pytest.fixture
def grown():
    m, v = grown_model_view()
    yield m, v
    v.close()


def _handler(render_window):
    app = vtkWebApplication()

    class Handler(trame_vtk_mouse.vtkWebMouseHandler):
        @property
        def app(self):
            return app

        def get_view(self, vid):
            return render_window

    return Handler()


def _mouse(h, action, x, y, left=False):
    return h.mouse_interaction({"view": "1", "action": action, "x": x, "y": y, "buttonLeft": left,
                                "buttonMiddle": False, "buttonRight": False, "shiftKey": False,
                                "ctrlKey": False, "altKey": False, "metaKey": False})


def test_trame_server_events_drive_the_brush(grown):
    m, v = grown
    b = BrushInteractor(v, spacing=0.5)
    b.attach()
    h = _handler(v.plotter.render_window)
    cam = tuple(v.plotter.camera.position)
    n_ev = len(m.log)
    _mouse(h, "move", 0.5, 0.7)  # hover (remote view with enable_picking)
    assert b.center is not None and v._brush_actor.GetVisibility()
    hover = b.center.copy()
    # the hover point is the brush's world point under that normalised pixel
    w, hgt = v.plotter.render_window.GetSize()
    np.testing.assert_allclose(hover, b.world_point(np.floor(0.5 * w + 0.5), np.floor(0.7 * hgt + 0.5)), atol=1e-6)
    assert not [e for e in m.log.events[n_ev:] if e.command == "paint_stroke"]
    _mouse(h, "down", 0.5, 0.7, left=True)
    for y in np.linspace(0.7, 0.98, 15):
        _mouse(h, "move", 0.5, y, left=True)
    _mouse(h, "up", 0.5, 0.98)
    stamps = [e for e in m.log.events[n_ev:] if e.command == "paint_stroke"]
    assert len(stamps) >= 2 and not b._pressed
    assert tuple(v.plotter.camera.position) == cam  # the camera did not rotate while painting
    # the wheel (trame's zoom RPC) is the radius gesture: one notch forward = x 2^(1/8)
    r0 = m.brush_radius
    h.update_zoomFromWheel({"view": "1", "type": "MouseWheel", "spinY": -1.0, "x": 0.5, "y": 0.5})
    assert m.brush_radius == pytest.approx(r0 * 2 ** (1 / 8))
    assert tuple(v.plotter.camera.position) == cam
    # prune mode through the same events
    b.toggle_prune()
    snap = m.snapshot
    kids = np.flatnonzero(snap.parent >= 0)
    node = kids[len(kids) // 2]
    x, y = b.world_to_display(0.5 * (snap.pos[node] + snap.pos[snap.parent[node]]))
    m.brush_radius = 0.3
    n_int = m.n_internodes
    _mouse(h, "move", x / w, y / hgt)
    assert len(b.preview) > 0  # the red preview follows the hover
    _mouse(h, "down", x / w, y / hgt, left=True)
    _mouse(h, "up", x / w, y / hgt)
    assert m.n_internodes < n_int
    b.close()


def test_trame_app_rejects_bad_input(grown):
    with pytest.raises(ValueError, match="brush must be a BrushInteractor"):
        trame_app(grown[1])


APP = """
import os, sys
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
import plantvr
from plantvr.view import View
from plantvr.view.interaction import BrushInteractor, trame_app
m = plantvr.Model(seed=0)
m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
m.step(15)
view = View(m, window_size=(480, 400), off_screen=True)
server, layout = trame_app(BrushInteractor(view), width=480, height=400)
server.start(port=int(sys.argv[1]), open_browser=False, show_connection_info=False)
"""


@pytest.mark.browser
@pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")
def test_drag_in_browser_paints_through_trame(tmp_path):
    playwright_api = pytest.importorskip("playwright.sync_api")
    shots = screenshot_dir(tmp_path)
    (tmp_path / "app.py").write_text(textwrap.dedent(APP))
    port = free_port()
    app = [sys.executable, str(tmp_path / "app.py"), str(port)]
    with (serve(app, f"http://127.0.0.1:{port}/", log=tmp_path / "app.log", what="trame app", timeout_s=60,
                env=repo_env()),
          playwright_api.sync_playwright() as p):
        browser = launch_chromium(p, timeout=30_000)
        try:
            page = browser.new_page(viewport={"width": 560, "height": 480})
            page.set_default_timeout(30_000)
            page.goto(f"http://127.0.0.1:{port}/", wait_until="domcontentloaded")
            status = page.locator("#plantvr-brush-status")
            page.wait_for_function("""() => { const s = document.querySelector('#plantvr-brush-status');
                return s && /brush commands 0/.test(s.innerText); }""")
            page.wait_for_selector("#plantvr-brush-view img, #plantvr-brush-view canvas")
            time.sleep(1.0)  # first image
            box = page.locator("#plantvr-brush-view").bounding_box()
            x0, y0 = box["x"] + 0.5 * box["width"], box["y"] + 0.3 * box["height"]
            page.mouse.move(x0, y0)
            page.mouse.down()
            for k in range(12):
                page.mouse.move(x0 + 3 * k, y0 - 7 * k)
                time.sleep(0.05)
            page.mouse.up()
            page.wait_for_function("""() => !/brush commands 0 /.test(
                document.querySelector('#plantvr-brush-status').innerText)""")
            time.sleep(1.0)
            page.screenshot(path=str(shots / "trame_brush.png"))
            text = status.inner_text()
            n_cmd = int(text.split("brush commands")[1].split("·")[0])
            n_markers = int(text.split("markers")[1].split("·")[0])
            assert n_cmd >= 2 and n_markers > 18, text
        finally:
            browser.close()

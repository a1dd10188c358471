"""Drive the anywidget front ends in headless Chromium (playwright) and feed their state back to Python.

The ESM of each widget is rendered in a minimal page with a stand-in for anywidget's model
(``get``/``set``/``on``/``save_changes``); the state the browser writes is applied to the Python widget
with ``set_state`` — what the Jupyter comm does — and the shared model is checked.
Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
import io
import json
from pathlib import Path

import numpy as np
import pytest

import plantvr
from plantvr._browser import CHROMIUM, launch_chromium
from plantvr.ui import ColorWheel, GrowthControl, InfluenceTriangle
from plantvr.ui._assets import asset

from ._jupyter import screenshot_dir

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
playwright_api = pytest.importorskip("playwright.sync_api")

HARNESS = """
<html><head><style>%(css)s</style></head><body style="margin:0;background:#fff">
<div id="host" style="padding:10px;display:inline-block"></div>
<script type="module">
const state = %(state)s;
const listeners = {};
const model = {
  get: (k) => state[k],
  set: (k, v) => { state[k] = v; (listeners["change:" + k] || []).forEach((f) => f()); },
  on: (e, f) => { (listeners[e] = listeners[e] || []).push(f); },
  off: (e, f) => { listeners[e] = (listeners[e] || []).filter((g) => g !== f); },
  save_changes: () => { window.saves = (window.saves || 0) + 1; },
};
window.widgetState = state;
window.widgetModel = model;
const src = %(esm)s;
const url = URL.createObjectURL(new Blob([src], { type: "text/javascript" }));
const mod = await import(url);
await mod.default.render({ model, el: document.getElementById("host") });
window.rendered = true;
</script></body></html>
"""


@pytest.fixture(scope="module")
def browser():
    with playwright_api.sync_playwright() as p:
        b = launch_chromium(p)
        yield b
        b.close()


@pytest.fixture
def shots(tmp_path):
    return screenshot_dir(tmp_path)


def _page(browser, widget, js: str, css: str | None = None):
    state = {k: v for k, v in widget.get_state().items() if not k.startswith("_")}
    html = HARNESS % {"css": asset(css).read_text() if css else "", "state": json.dumps(state),
                      "esm": json.dumps(asset(js).read_text())}
    page = browser.new_page(viewport={"width": 420, "height": 380})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.set_content(html)
    page.wait_for_function("window.rendered === true", timeout=10_000)
    assert not errors, errors
    return page


def _push(page, widget, *names):
    """Send the browser's values of ``names`` to the Python widget, as the comm would."""
    widget.set_state({n: page.evaluate(f"window.widgetState[{n!r}]") for n in names})


def test_drag_influence_triangle_sets_model_weights(browser, shots):
    model = plantvr.Model(seed=0)
    tri = InfluenceTriangle(model)
    page = _page(browser, tri, "influence_triangle.js", "influence_triangle.css")
    svg = page.locator("svg.tri-svg").bounding_box()
    handle = page.locator("circle.tri-handle").bounding_box()
    pad, size = 28, 240
    h = np.sqrt(3) / 2

    def screen(p):  # triangle units -> page pixels (the ESM's mapping)
        return svg["x"] + pad + p[0] * size, svg["y"] + pad + (h - p[1]) * size

    page.mouse.move(handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2)
    page.mouse.down()
    target = screen((0.5, 0.0))  # middle of the T–E edge: H = 0, T = E = 1/2
    page.mouse.move(*target, steps=8)
    page.mouse.up()
    _push(page, tri, "weights")
    assert model.influence == pytest.approx((0.0, 0.5, 0.5), abs=0.01)
    page.screenshot(path=str(shots / "triangle_edge.png"))

    page.mouse.move(*screen((0.5, 0.3)))
    page.mouse.down()
    page.mouse.move(*[c + 60 for c in screen((1.0, 0.0))], steps=8)  # far outside, past the E corner
    page.mouse.up()
    _push(page, tri, "weights")
    assert model.influence == pytest.approx((0.0, 0.0, 1.0), abs=0.01)  # clamped to the corner

    model.set_influence(0.6, 0.2, 0.2)  # model -> browser: the point moves
    page.evaluate(f"window.widgetModel.set('weights', {json.dumps(tri.weights)})")
    cx = float(page.locator("circle.tri-handle").get_attribute("cx"))
    cy = float(page.locator("circle.tri-handle").get_attribute("cy"))
    p = np.array([0.6 * 0.5 + 0.2 * 0.0 + 0.2 * 1.0, 0.6 * h])
    sx, sy = screen(p)
    assert (cx + svg["x"], cy + svg["y"]) == pytest.approx((sx, sy), abs=0.5)
    text = page.locator(".tri-readout").inner_text()
    assert "H 0.600" in text and "E 0.200" in text
    page.screenshot(path=str(shots / "triangle.png"))
    # the pixel at the centroid of each sub-triangle has that influence's colour (red H, blue T, green E)
    from PIL import Image  # noqa: PLC0415
    img = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)
    corners = np.array(tri.corners)
    for i, colour in enumerate(tri.colors):
        cen = (p + corners[(i + 1) % 3] + corners[(i + 2) % 3]) / 3
        x, y = screen(cen)
        want = np.array([int(colour[k:k + 2], 16) for k in (1, 3, 5)])
        got = img[int(round(y)), int(round(x))]
        # fill-opacity 0.8 over white
        assert np.abs(got - (0.8 * want + 0.2 * 255)).max() < 12, (i, got, want)
    page.close()


def test_click_color_wheel_selects_and_hides(browser, shots):
    from plantvr.documents.labels import Segmentation
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    seg = Segmentation(v, np.array([[0, 1, 2]]))
    wheel = ColorWheel(target=seg)
    page = _page(browser, wheel, "color_wheel.js", "color_wheel.css")
    box = page.locator("svg.wheel-svg").bounding_box()
    C, R = 110 + 14 + 18, 110
    K = len(wheel.colors)

    def slice_center(k, r=0.7):
        a = (k + 0.5) * 2 * np.pi / K
        return box["x"] + C + r * R * np.cos(a), box["y"] + C - r * R * np.sin(a)

    page.mouse.click(*slice_center(4))
    _push(page, wheel, "selected")
    assert wheel.selected == 4
    page.keyboard.down("Shift")
    page.mouse.click(*slice_center(2))
    page.keyboard.up("Shift")
    _push(page, wheel, "hidden")
    assert not seg.colors.visible[2] and seg.colors.visible[4]
    assert page.locator("g.wheel-slice.hidden line.wheel-hidden-line").count() == 5
    assert page.locator("g.wheel-slice.selected").get_attribute("data-index") == "4"
    page.mouse.click(*slice_center(2, r=0.05))  # dead zone: keeps the last slice
    _push(page, wheel, "selected")
    assert wheel.selected == 4
    page.screenshot(path=str(shots / "color_wheel.png"))
    page.close()


def test_growth_plot_draws(browser, shots):
    model = plantvr.Model(seed=0)
    model.paint_stroke([[0, y, 0] for y in range(2, 9)], radius=2.0)
    gc = GrowthControl(model)
    for _ in range(12):
        gc.step()
    page = _page(browser, gc.plot, "growth_plot.js")
    page.screenshot(path=str(shots / "growth_plot.png"))
    # some orange (ms) and green (internodes) pixels were drawn on the canvas
    counts = page.evaluate("""() => {
      const c = document.querySelector('canvas'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let o = 0, g = 0;
      for (let i = 0; i < d.length; i += 4) {
        if (d[i] > 200 && d[i+1] > 100 && d[i+1] < 150 && d[i+2] < 60) o++;
        if (d[i] < 80 && d[i+1] > 150 && d[i+2] < 120) g++;
      }
      return [o, g]; }""")
    assert counts[0] > 20 and counts[1] > 20
    page.close()

"""The trame review page in headless Chromium (issue 14): a click on the proxy drawn by vtk.js paints the
full-resolution labels exactly where a brute-force sphere test says; undo restores them; hiding a colour
removes it from the page; after the first scene only colour arrays travel, never the mesh again.

Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
import io
import os
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import CHROMIUM, launch_chromium

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
playwright_api = pytest.importorskip("playwright.sync_api")
pytest.importorskip("trame_vtk")

from plantvr.documents.labels import Segmentation
from plantvr.vine.index import ball_query_brute


def _img(page):
    """The 3D view's pixels (the toolbar's colour buttons are left out)."""
    from PIL import Image
    img = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)
    b = page.locator(".vine-view").bounding_box()
    return img[int(b["y"]):int(b["y"] + b["height"]), int(b["x"]):int(b["x"] + b["width"])]


def _yellow(img):
    # label 3 is (240, 200, 30): lit or shaded, red and green well above blue
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return int(((r > 90) & (g > 70) & (b < 0.45 * g) & (r > 1.6 * b + 30)).sum())


def _hue_match(px, rgb=(240, 200, 30)):
    """Cosine between pixel colours and a label colour: 1 for that colour under any shading."""
    px = np.asarray(px, float).reshape(-1, 3)
    c = np.asarray(rgb, float)
    return (px @ c) / np.maximum(np.linalg.norm(px, axis=1) * np.linalg.norm(c), 1e-9)


def _wait(page, cond, timeout=15.0):
    for _ in range(int(timeout / 0.1)):
        if cond():
            return True
        page.wait_for_timeout(100)                # lets playwright deliver websocket events meanwhile
    return cond()


def _shots(tmp_path) -> Path:
    d = Path(os.environ.get("PLANTVR_SCREENSHOTS", tmp_path))
    d.mkdir(parents=True, exist_ok=True)
    return d


def _open_page(browser, width: int, *, received: list | None = None, console: bool = False):
    """A page that collects page errors (and console errors bar trame's 405 probe when ``console``; a layout that
    makes vtk.js's ResizeObserver loop logs one) and the sizes of received websocket frames into ``received``."""
    page = browser.new_page(viewport={"width": width, "height": 640})
    if received is not None:
        page.on("websocket", lambda ws: ws.on("framereceived", lambda m: received.append(len(m))))
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    if console:
        page.on("console", lambda m: m.type == "error" and "Failed to load resource" not in m.text
                and errors.append(m.text))
    return page, errors


def test_click_paints_full_resolution_labels_through_the_proxy(surface, tmp_path):
    from plantvr.view.vine_app import VineReviewApp
    shots = _shots(tmp_path)
    seg = Segmentation(surface.vertices, surface.faces, normals=surface.normals)
    app = VineReviewApp(seg, target_faces=len(seg.faces) // 4, radius=5.0, window_size=(640, 480))
    assert app.proxy.n_vertices < seg.n_vertices // 3
    app.state.label = 3
    url = app.start()
    try:
        with playwright_api.sync_playwright() as p:
            browser = launch_chromium(p)
            received = []
            page, errors = _open_page(browser, 800, received=received)
            page.goto(url)
            page.wait_for_selector(".vine-view canvas", timeout=30_000)
            box = page.locator(".vine-view").bounding_box()
            cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            h, w = int(box["height"] / 2), int(box["width"] / 2)
            assert _wait(page, lambda: _img(page)[h, w].sum() > 150), "the mesh was not drawn"
            page.wait_for_timeout(500)
            scene_bytes = sum(received)
            before = _img(page)
            assert _yellow(before) == 0

            # one click on the surface: picked in the browser, painted on the full-resolution labels
            received.clear()
            page.mouse.click(cx, cy)
            assert _wait(page, lambda: np.any(seg.labels == 3)), "the click did not paint"
            pick = np.asarray(app.last_pick["worldPosition"], float)
            want = ball_query_brute(seg.vertices, pick, 5.0)
            assert np.array_equal(np.nonzero(seg.labels == 3)[0], want)
            assert np.count_nonzero(seg.labels) == len(want) > 20
            assert _wait(page, lambda: _yellow(_img(page)) > 30), "the painted colour did not reach the page"
            page.wait_for_timeout(300)
            stroke_bytes = sum(received)
            # the page hook recoloured the vtk.js actor in place from one delta, without a scene resync
            hook = page.evaluate("({...window.vineDelta})")
            assert app.deltas == 1 and app.resyncs == 0 and app.pushes == 1
            assert hook["applied"] == 1 and hook["resyncs"] == 0 and hook["vertices"] == app.delta_vertices > 0
            # the picked pixel itself now shows the label colour (240, 200, 30), lit or shaded
            centre = _img(page)[h - 1:h + 2, w - 1:w + 2]
            assert np.all(_hue_match(before[h - 1:h + 2, w - 1:w + 2]) < 0.95)
            assert np.all(_hue_match(centre) > 0.99) and centre.sum(axis=2).min() > 60, centre.tolist()
            # only (id, rgba) of the changed proxy vertices (8 B each) and small state travel: never the whole
            # colour array (4 B per proxy vertex), never the points
            assert stroke_bytes < 8 * app.delta_vertices + 2_000 < 4 * app.proxy.n_vertices < scene_bytes, \
                (stroke_bytes, app.delta_vertices, app.proxy.n_vertices)
            page.screenshot(path=str(shots / "vine_review_painted.png"))

            # an orbit drag ends with a DOM click too: it rotates the view and paints nothing
            n_painted = np.count_nonzero(seg.labels)
            page.mouse.move(cx - 120, cy + 40)
            page.mouse.down()
            page.mouse.move(cx + 60, cy - 20, steps=8)
            page.mouse.up()
            page.wait_for_timeout(1500)
            assert np.count_nonzero(seg.labels) == n_painted and len(seg.history.undo_stack) == 1

            # undo from the toolbar restores the full-resolution labels
            page.locator(".vine-undo").click()
            assert _wait(page, lambda: not np.any(seg.labels))
            assert _wait(page, lambda: _yellow(_img(page)) == 0)
            assert app.deltas == 2 and page.evaluate("window.vineDelta.applied") == 2    # undo: a delta too
            # ... written straight into the GPU colour buffer (no vertex-buffer rebuild): the paint is gone
            assert page.evaluate("window.vineDelta.fast") == 2

            # paint again, then hide the selected colour: gone from the page, kept in the labels
            page.mouse.click(cx, cy)
            assert _wait(page, lambda: np.any(seg.labels == 3))
            want = ball_query_brute(seg.vertices, np.asarray(app.last_pick["worldPosition"], float), 5.0)
            assert _wait(page, lambda: _yellow(_img(page)) > 30)
            page.locator(".vine-toggle").click()
            assert _wait(page, lambda: not seg.colors.visible[3])
            assert _wait(page, lambda: _yellow(_img(page)) == 0)
            assert np.array_equal(np.nonzero(seg.labels == 3)[0], want)
            page.screenshot(path=str(shots / "vine_review_hidden.png"))

            # show it again (scene resync), undo (a delta), hide and show once more: the page must not bring
            # back the undone paint from trame-vtk's array cache (the hook copies a cached array before writing)
            page.locator(".vine-toggle").click()
            assert _wait(page, lambda: _yellow(_img(page)) > 30)
            page.locator(".vine-undo").click()
            assert _wait(page, lambda: not np.any(seg.labels == 3))
            assert _wait(page, lambda: _yellow(_img(page)) == 0)
            for _ in range(2):
                page.locator(".vine-toggle").click()
                page.wait_for_timeout(1000)
                assert _yellow(_img(page)) == 0
            assert seg.colors.visible[3]

            # a page opened after strokes shows them (its hook sees a later delta and asks for a resync)
            page.mouse.click(cx, cy)
            assert _wait(page, lambda: np.any(seg.labels == 3))
            assert _wait(page, lambda: _yellow(_img(page)) > 30)
            # a page opened later shows the paint: checked after a stroke in the paint-drag test below
            assert not errors, errors
            browser.close()
    finally:
        app.stop()
    print(f"scene {scene_bytes:,} B, one stroke {stroke_bytes:,} B for {app.delta_vertices:,} changed of "
          f"{app.proxy.n_vertices:,} proxy vertices")


def _slice_xy(k, n, r_frac=0.6, radius=None):
    """CSS px, from the wheel's top-left corner, of a point inside slice ``k`` of ``n`` (y up, CCW from +x)."""
    from plantvr.view.vine_app import WHEEL_RADIUS, wheel_geometry
    radius = WHEEL_RADIUS if radius is None else radius
    cen = wheel_geometry(WHEEL_RADIUS)[1]
    a = (k + 0.5) * 2 * np.pi / n
    return {"x": cen + r_frac * radius * np.cos(a), "y": cen - r_frac * radius * np.sin(a)}


def _wheel_img(page):
    from PIL import Image
    img = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)
    b = page.locator(".vine-wheel").bounding_box()
    y0, x0 = round(b["y"]), round(b["x"])
    return img[y0:y0 + round(b["height"]), x0:x0 + round(b["width"])]


def test_colour_wheel_selects_paints_and_hides(surface, tmp_path):
    """Spec §2.4.1/§2.6 on the page: a click on a slice selects that colour (raised, outlined) and the next
    click on the mesh paints with it; a shift-click hides the colour (radial lines; gone from the mesh, painting
    with it refused) and shows it again."""
    from plantvr.view.vine_app import WHEEL_RADIUS, VineReviewApp, wheel_geometry
    shots = _shots(tmp_path)
    seg = Segmentation(surface.vertices, surface.faces, normals=surface.normals)
    n = len(seg.colors)
    app = VineReviewApp(seg, target_faces=len(seg.faces) // 4, radius=5.0, window_size=(640, 480))
    assert app.state.label == 1
    url = app.start()
    lift = wheel_geometry(WHEEL_RADIUS)[0]
    try:
        with playwright_api.sync_playwright() as p:
            browser = launch_chromium(p)
            page, errors = _open_page(browser, 900, console=True)
            page.goto(url)
            page.wait_for_selector(".vine-view canvas", timeout=30_000)
            page.wait_for_selector(".vine-wheel svg .wheel-slice", timeout=30_000)
            wheel = page.locator(".vine-wheel")
            box = page.locator(".vine-view").bounding_box()
            cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            h, w = int(box["height"] / 2), int(box["width"] / 2)
            assert _wait(page, lambda: _img(page)[h, w].sum() > 150), "the mesh was not drawn"
            assert page.locator(".vine-wheel .wheel-slice").count() == n
            assert page.locator(".vine-wheel .wheel-slice.selected").get_attribute("data-index") == "1"

            # a click on the yellow slice selects label 3: raised and outlined on the wheel
            wheel.click(position=_slice_xy(3, n))
            assert _wait(page, lambda: app.state.label == 3)
            assert _wait(page, lambda: page.locator(".vine-wheel .wheel-slice.selected")
                         .get_attribute("data-index") == "3")
            assert "label 3" in page.locator(".vine-label").inner_text()
            wimg = _wheel_img(page)
            rim = _slice_xy(3, n, r_frac=(WHEEL_RADIUS + lift / 2) / WHEEL_RADIUS)   # in the raised band
            rim4 = _slice_xy(4, n, r_frac=(WHEEL_RADIUS + lift / 2) / WHEEL_RADIUS)
            assert _hue_match(wimg[int(rim["y"]), int(rim["x"])])[0] > 0.99        # slice 3 reaches the band
            assert _hue_match(wimg[int(rim4["y"]), int(rim4["x"])], (60, 170, 60))[0] < 0.9   # slice 4 does not
            page.screenshot(path=str(shots / "vine_wheel_selected.png"))

            # the next click on the mesh paints with the wheel's colour, at full resolution
            page.mouse.click(cx, cy)
            assert _wait(page, lambda: np.any(seg.labels == 3)), "the click did not paint"
            want = ball_query_brute(seg.vertices, np.asarray(app.last_pick["worldPosition"], float), 5.0)
            assert np.array_equal(np.nonzero(seg.labels)[0], want) and set(np.unique(seg.labels)) == {0, 3}
            assert _wait(page, lambda: _yellow(_img(page)) > 30)

            # shift-click on slice 3 hides the colour: radial lines on the wheel, gone from the mesh
            wheel.click(position=_slice_xy(3, n), modifiers=["Shift"])
            assert _wait(page, lambda: not seg.colors.visible[3])
            assert app.state.label == 3 and app.state.hidden == [3]
            assert _wait(page, lambda: page.locator(".vine-wheel .wheel-slice.hidden").count() == 1)
            assert page.locator(".vine-wheel .wheel-slice.hidden").get_attribute("data-index") == "3"
            assert page.locator(".vine-wheel .wheel-slice.hidden .wheel-hidden-line").count() == 5
            assert "(hidden)" in page.locator(".vine-label").inner_text()
            assert _wait(page, lambda: _yellow(_img(page)) == 0)
            page.screenshot(path=str(shots / "vine_wheel_hidden.png"))
            # painting with a hidden colour is refused and says why
            page.mouse.click(cx + 15, cy)
            assert _wait(page, lambda: "hidden" in page.locator(".vine-message").inner_text())
            assert np.array_equal(np.nonzero(seg.labels)[0], want)

            # a click outside the wheel's disc (a corner of its box) changes nothing
            wheel.click(position={"x": 2, "y": 2})
            page.wait_for_timeout(500)
            assert app.state.label == 3 and not seg.colors.visible[3]

            # shift-click again shows it; select the blue slice and paint elsewhere with it
            wheel.click(position=_slice_xy(3, n), modifiers=["Shift"])
            assert _wait(page, lambda: seg.colors.visible[3])
            assert _wait(page, lambda: _yellow(_img(page)) > 30)
            assert _wait(page, lambda: page.locator(".vine-wheel .wheel-slice.hidden").count() == 0)
            wheel.click(position=_slice_xy(6, n))
            assert _wait(page, lambda: app.state.label == 6)
            page.mouse.click(cx + 40, cy - 10)
            assert _wait(page, lambda: np.any(seg.labels == 6)), "painting with the new selection failed"
            assert np.all(seg.labels[want] > 0)
            assert _wait(page, lambda: page.locator(".vine-message").inner_text() == "")   # refusal cleared
            page.wait_for_timeout(500)
            page.screenshot(path=str(shots / "vine_wheel_blue.png"))
            assert not errors, errors
            browser.close()
    finally:
        app.stop()


_CAMERA_JS = "window.trame.refs.vine_view.$.provides.view.renderer.getActiveCamera().getPosition()"


def test_paint_drag_stroke_on_the_lod_paints_full_resolution_and_undoes(surface, tmp_path):
    """A paint drag (toolbar "paint: drag"): every position is picked on the server against the drawn proxy and
    stamped on the full-resolution labels; the page draws the coarse level of detail while the stroke runs and
    the display proxy again after it; the stroke is one undo item; only colour deltas travel."""
    from plantvr.view.vine_app import VineReviewApp
    shots = _shots(tmp_path)
    seg = Segmentation(surface.vertices, surface.faces, normals=surface.normals)
    app = VineReviewApp(seg, target_faces=len(seg.faces) // 2, radius=4.0, window_size=(640, 480),
                        interactive_faces=len(seg.faces) // 8)
    assert app.lod is not None and app.lod.n_vertices < app.proxy.n_vertices
    app.state.label = 3
    url = app.start()
    try:
        with playwright_api.sync_playwright() as p:
            browser = launch_chromium(p)
            received = []
            page, errors = _open_page(browser, 800, received=received, console=True)
            page.goto(url)
            page.wait_for_selector(".vine-view canvas", timeout=30_000)
            box = page.locator(".vine-view").bounding_box()
            cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            h, w = int(box["height"] / 2), int(box["width"] / 2)
            assert _wait(page, lambda: _img(page)[h, w].sum() > 150), "the mesh was not drawn"
            # at rest the page hides the level of detail's actor (the server keeps it visible to send it)
            assert _wait(page, lambda: page.evaluate(
                "() => { const v = window.trame.refs.vine_view.$.provides.view; const a = v.renderer.getActors();"
                " return a.length === 2 && a.filter(x => x.getVisibility()).length === 1; }"))
            page.locator(".vine-paint").click()
            assert _wait(page, lambda: app.state.paint_drag)
            page.wait_for_timeout(500)
            received.clear()
            cam0 = page.evaluate(_CAMERA_JS)
            page.evaluate("() => { window.__lod = []; const v = window.vineDelta;"
                          " const f = () => { window.__lod.push(v.lodShown); if (window.__lod.length < 4000)"
                          " requestAnimationFrame(f); }; requestAnimationFrame(f); }")
            page.mouse.move(cx - 50, cy + 5)
            page.mouse.down()
            for k in range(1, 11):
                page.mouse.move(cx - 50 + 10 * k, cy + 5 - 2 * np.sin(k / 2))
            page.mouse.up()
            assert _wait(page, lambda: page.evaluate("window.vineDelta.strokes") == 1, timeout=60.0)
            assert _wait(page, lambda: _yellow(_img(page)) > 30), "the stroke did not reach the page"
            page.wait_for_timeout(500)
            stroke_bytes = sum(received)
            # full resolution: exactly the union of brute-force spheres around the stamps; one undo item
            centres = np.asarray(app.last_stroke)
            assert len(centres) >= 3, centres
            want = np.unique(np.concatenate([ball_query_brute(seg.vertices, c, 4.0) for c in centres]))
            assert np.array_equal(np.nonzero(seg.labels)[0], want) and np.all(seg.labels[want] == 3)
            assert len(seg.history.undo_stack) == 1 and not app._stroking
            # the stamps lie along the drag (left to right in the view): a stroke, not a single spot
            assert np.linalg.norm(centres[-1] - centres[0]) > 4.0
            hook = page.evaluate("({...window.vineDelta, log: window.vineDelta.log.map(e => e.phase)})")
            assert hook["log"][0] == "begin" and hook["log"][-1] == "end" and hook["resyncs"] == 0
            assert hook["applied"] == app.deltas and hook["vertices"] == app.delta_vertices > 0
            assert not hook["lodShown"] and True in page.evaluate("window.__lod")     # coarse while it ran
            assert hook["fast"] > 0                   # later deltas of the stroke: into the GPU colour buffer
            assert stroke_bytes < 8 * app.delta_vertices + 400 * len(hook["log"]) + 2_000, \
                (stroke_bytes, app.delta_vertices, len(hook["log"]))
            page.screenshot(path=str(shots / "vine_review_stroke.png"))
            # a page opened now (its scene predates the stroke, whose deltas went to the painting page only)
            # asks for a resync and shows the stroke
            assert app.state.vine_stale
            late = browser.new_page(viewport={"width": 800, "height": 640})
            late.goto(url)
            late.wait_for_selector(".vine-view canvas", timeout=30_000)
            assert _wait(late, lambda: _yellow(_img(late)) > 30, timeout=45.0), "a late page did not show the stroke"
            # it shows the stroke from its first scene or after one resync (which of the two depends on timing)
            assert late.evaluate("window.vineDelta.resyncs") <= 1
            late.close()
            # the drag painted instead of orbiting: the camera did not move
            assert np.allclose(page.evaluate(_CAMERA_JS), cam0)
            page.locator(".vine-undo").click()
            assert _wait(page, lambda: not np.any(seg.labels))
            assert _wait(page, lambda: _yellow(_img(page)) == 0)
            # with "paint: click" a left drag orbits (drawing the level of detail meanwhile) and paints nothing
            page.locator(".vine-paint").click()
            assert _wait(page, lambda: not app.state.paint_drag)
            page.wait_for_timeout(300)
            page.evaluate("() => { window.__lod = []; const v = window.vineDelta;"
                          " const f = () => { window.__lod.push(v.lodShown); if (window.__lod.length < 4000)"
                          " requestAnimationFrame(f); }; requestAnimationFrame(f); }")
            page.mouse.move(cx - 60, cy)
            page.mouse.down()
            page.mouse.move(cx + 40, cy - 20, steps=8)
            page.mouse.up()
            page.wait_for_timeout(1000)
            assert not np.allclose(page.evaluate(_CAMERA_JS), cam0)
            assert True in page.evaluate("window.__lod") and not page.evaluate("window.vineDelta.lodShown")
            assert not np.any(seg.labels) and len(seg.history.undo_stack) == 0
            assert not errors, errors
            browser.close()
    finally:
        app.stop()
    print(f"stroke: {len(centres)} stamps, {stroke_bytes:,} B received for {app.delta_vertices:,} proxy vertices")

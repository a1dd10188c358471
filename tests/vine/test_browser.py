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

CHROMIUM = "/usr/bin/chromium"
pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
playwright_api = pytest.importorskip("playwright.sync_api")
pytest.importorskip("trame_vtk")

from plantvr.vine.index import ball_query_brute
from plantvr.vine.segmentation import Segmentation

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync"]


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


def test_click_paints_full_resolution_labels_through_the_proxy(surface, tmp_path):
    from plantvr.view.vine_app import VineReviewApp
    shots = Path(os.environ.get("PLANTVR_SCREENSHOTS", tmp_path))
    shots.mkdir(parents=True, exist_ok=True)
    seg = Segmentation(surface.vertices, surface.faces, normals=surface.normals)
    app = VineReviewApp(seg, target_faces=len(seg.faces) // 4, radius=5.0, window_size=(640, 480))
    assert app.proxy.n_vertices < seg.n_vertices // 3
    app.state.label = 3
    url = app.start()
    try:
        with playwright_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 800, "height": 640})
            received = []
            page.on("websocket", lambda ws: ws.on("framereceived", lambda m: received.append(len(m))))
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
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
            late = browser.new_page(viewport={"width": 800, "height": 640})
            late.goto(url)
            late.wait_for_selector(".vine-view canvas", timeout=30_000)
            assert _wait(late, lambda: _yellow(_img(late)) > 30), "a late page did not show the paint"
            late.screenshot(path=str(shots / "vine_review_late_page.png"))
            assert not errors, errors
            browser.close()
    finally:
        app.stop()
    print(f"scene {scene_bytes:,} B, one stroke {stroke_bytes:,} B for {app.delta_vertices:,} changed of "
          f"{app.proxy.n_vertices:,} proxy vertices")

"""The influence triangle in a real JupyterLab: live kernel, real anywidget comm (spec 000_treewand §4.9, TW-V11).

A JupyterLab server is started on 127.0.0.1 in a subprocess with a temporary notebook that makes a
:class:`plantvr.Model` and an :class:`~plantvr.ui.InfluenceTriangle`. Headless Debian Chromium (playwright)
runs the cells, drags the triangle's handle, then re-runs a cell that prints ``model.influence`` in the
kernel; the printed weights are read back from the page. A cell then sets the weights in the kernel and
the handle moves in the page. In the same session a parameter slider of the generated panels is dragged
(the model's λ follows) and a colour-wheel slice is clicked (the selected label follows). The server is always killed.
The workbench tests (Tree Wand and ViNE brushes, the L-system step slider) run with the network blocked, as
test_jupyterlab_kinds does (issue 31): the server and kernels resolve no other host, the page reaches none.
Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
import time
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import CHROMIUM

from ._jupyter import (
    drag,
    drag_handle,
    jupyter_lab,
    live_view,
    notebook_page,
    pixels,
    poll,
    printed,
    run_cell,
    screenshot_dir,
    until_changed,
)

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
pytest.importorskip("playwright.sync_api")
pytest.importorskip("jupyterlab")
pytest.importorskip("anywidget")

CELLS = [
    ("import plantvr\nfrom plantvr.ui import InfluenceTriangle\n"
     "model = plantvr.Model(seed=0)\nmodel.set_influence(1, 1, 1)\ntri = InfluenceTriangle(model)\ntri"),
    "print('INFLUENCE', *[f'{w:.4f}' for w in model.influence])",
    "model.set_influence(0.6, 0.2, 0.2)  # kernel -> browser",
    ("from plantvr.ui import ParameterPanels\npanels = ParameterPanels(model)\n"
     "panels.controls['apical_dominance']"),
    "print('APICAL', f'{model.apical_dominance:.6f}', panels.controls['apical_dominance'].value)",
    ("import numpy as np\nfrom plantvr.ui import ColorWheel\nfrom plantvr.documents.labels import Segmentation\n"
     "seg = Segmentation(np.eye(3, dtype=np.float32), np.array([[0, 1, 2]]))\nwheel = ColorWheel(target=seg)\nwheel"),
    "print('SELECTED', wheel.selected, len(wheel.colors))",
]


@pytest.fixture
def shots(tmp_path):
    return screenshot_dir(tmp_path)


@pytest.fixture
def lab(tmp_path):
    """A JupyterLab server on a free port serving ``triangle.ipynb``; yields its base URL."""
    with jupyter_lab(tmp_path, {"triangle.ipynb": CELLS}) as url:
        yield url


def _influence(page) -> np.ndarray:
    """Read the last 'INFLUENCE h t e' line printed by the second cell."""
    return np.array([float(v) for v in printed(page, 1, r"INFLUENCE ([\d.]+) ([\d.]+) ([\d.]+)")])


def test_drag_triangle_in_jupyterlab_changes_kernel_model(lab, shots):
    with notebook_page(lab, "triangle.ipynb", len(CELLS), viewport=(1100, 800)) as (page, errors):
        run_cell(page, 0)
        handle = page.locator("circle.tri-handle")
        handle.wait_for(state="visible", timeout=45_000)
        run_cell(page, 1)
        before = _influence(page)
        np.testing.assert_allclose(before, [1 / 3] * 3, atol=1e-3)
        page.screenshot(path=str(shots / "jupyterlab_triangle_before.png"))

        svg = page.locator("svg.tri-svg").bounding_box()
        pad, size, h = 28, 240, np.sqrt(3) / 2
        hb = handle.bounding_box()
        page.mouse.move(hb["x"] + hb["width"] / 2, hb["y"] + hb["height"] / 2)
        page.mouse.down()
        # to the middle of the T–E edge: H = 0, T = E = 1/2
        page.mouse.move(svg["x"] + pad + 0.5 * size, svg["y"] + pad + h * size, steps=10)
        page.mouse.up()
        page.wait_for_function("() => document.querySelector('.tri-readout').innerText.includes('H 0.000')")

        # the drag's last comm message may still be queued behind the cell: re-run until it lands
        deadline = time.monotonic() + 20
        while True:
            run_cell(page, 1)
            after = _influence(page)
            if np.allclose(after, [0.0, 0.5, 0.5], atol=0.01) or time.monotonic() > deadline:
                break
            time.sleep(0.3)
        page.screenshot(path=str(shots / "jupyterlab_triangle.png"))
        np.testing.assert_allclose(after, [0.0, 0.5, 0.5], atol=0.01)

        run_cell(page, 2)  # the model moves the handle in the browser
        page.wait_for_function("() => document.querySelector('.tri-readout').innerText.includes('H 0.600')")
        cx = float(handle.get_attribute("cx"))
        assert cx == pytest.approx(pad + (0.6 * 0.5 + 0.2 * 1.0) * size, abs=0.5)

        # a parameter slider (ipywidgets, generated from the table) dragged: the model follows
        run_cell(page, 3)
        handle = page.locator(".jp-Cell").nth(3).locator(".noUi-handle").first
        handle.wait_for(state="visible", timeout=30_000)
        handle.scroll_into_view_if_needed()
        run_cell(page, 4)
        before_lam = float(printed(page, 4, r"APICAL ([\d.]+)")[0])
        assert before_lam == pytest.approx(0.55)
        drag_handle(page, handle, 60, steps=6)
        deadline, lam = time.monotonic() + 20, before_lam
        while lam == pytest.approx(before_lam) and time.monotonic() < deadline:
            run_cell(page, 4)
            lam, shown = (float(v) for v in printed(page, 4, r"APICAL ([\d.]+) ([\d.]+)"))
        assert lam > before_lam + 0.02 and lam == pytest.approx(shown, abs=1e-6) and lam <= 1.0
        page.screenshot(path=str(shots / "jupyterlab_slider.png"))

        # a colour-wheel slice clicked: the selected label changes in the kernel
        run_cell(page, 5)
        wheel_svg = page.locator(".jp-Cell").nth(5).locator("svg.wheel-svg")
        wheel_svg.wait_for(state="visible", timeout=30_000)
        wheel_svg.scroll_into_view_if_needed()
        run_cell(page, 6)
        n_colors = int(printed(page, 6, r"SELECTED (\d+) (\d+)")[1])
        box = wheel_svg.bounding_box()
        C, R, k = 110 + 14 + 18, 110, 4
        a = (k + 0.5) * 2 * np.pi / n_colors
        page.mouse.click(box["x"] + C + 0.7 * R * np.cos(a), box["y"] + C - 0.7 * R * np.sin(a))
        deadline, sel = time.monotonic() + 20, None
        while sel != k and time.monotonic() < deadline:
            run_cell(page, 6)
            sel = int(printed(page, 6, r"SELECTED (\d+)")[0])
        page.screenshot(path=str(shots / "jupyterlab_wheel.png"))
        assert sel == k
        assert not [e for e in errors if "plantvr" in e.lower() or "anywidget" in e.lower()], errors


# -- the live workbench: trame view (server rendered) beside the generated panel -----------------------------
WB_TREEWAND = [
    ("import plantvr\nfrom plantvr.ui import workbench\nmodel = plantvr.Model(seed=0)\n"
     "model.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)\nmodel.step(15)\n"
     "wb = workbench(model, window_size=(460, 420))\nwb"),
    ("print('TW', wb.live, model.n_internodes, model.n_markers, wb.regrows, model.steps_done,\n"
     "      sum(e.command == 'paint_stroke' for e in model.log.events), f'{model.tropism_angle:.4f}')"),
]
WB_VINE = [
    ("import numpy as np, trimesh\nfrom plantvr.documents.labels import Segmentation\nfrom plantvr.ui import workbench\n"
     "ico = trimesh.creation.icosphere(subdivisions=4, radius=1.0)\n"
     "seg = Segmentation(ico.vertices.astype(np.float32), ico.faces)\n"
     "wb = workbench(seg, window_size=(460, 420))\nwb"),
    ("print('VINE', wb.live, int((seg.labels > 0).sum()), wb.brush.label, wb.wheel.selected,\n"
     "      np.unique(seg.labels).tolist(), bool(seg.colors.visible[4]))"),
]


WB_LSYSTEM = [
    ("from plantvr.documents import LSystemDocument\nfrom plantvr.ui import LsystemWidget\n"
     "doc = LSystemDocument(step=2)\nwb = LsystemWidget(doc, window_size=(460, 420))\nwb"),
    "print('LS', wb.live, doc.step, doc.n_modules, f\"{doc.externs['angle']:.3f}\", len(doc.log.events))",
]


@pytest.fixture
def wb_lab(tmp_path):
    with jupyter_lab(tmp_path, {"treewand.ipynb": WB_TREEWAND, "vine.ipynb": WB_VINE,
                                "lsystem.ipynb": WB_LSYSTEM}, offline=True) as url:   # the network blocked
        yield url


TW = r"TW (\w+) (\d+) (\d+) (\d+) (\d+) (\d+) ([\d.]+)"


def test_workbench_treewand_slider_regrows_and_brush_paints_in_jupyterlab(wb_lab, shots):
    with notebook_page(wb_lab, "treewand.ipynb", len(WB_TREEWAND), viewport=(1280, 900), offline=True) as (page, errors):
        run_cell(page, 0)
        frame = live_view(page, 0)
        run_cell(page, 1)
        live, _, _, regrows, steps, strokes, trop = printed(page, 1, TW)
        assert live == "True" and regrows == "0" and steps == "15" and strokes == "1"
        before = pixels(frame)
        page.screenshot(path=str(shots / "workbench_treewand_before.png"))

        # drag the first slider of the Tree form window (tropism angle): the tree regrows and is redrawn
        handle = page.locator(".jp-Cell").nth(0).locator(".noUi-handle").first
        handle.scroll_into_view_if_needed()
        drag_handle(page, handle, 120, steps=6)
        got = poll(page, 1, TW, lambda g: g[3] == "1")
        assert got[3] == "1" and got[4] == "15" and float(got[6]) > float(trop) + 5, got  # same step count
        frame.scroll_into_view_if_needed()
        after = until_changed(frame, before)
        page.screenshot(path=str(shots / "workbench_treewand_regrown.png"))
        assert np.abs(after - before).max(axis=-1).mean() > 0.5, "the live view did not change"

        # paint in the view: markers added by the brush's paint_stroke commands, the status line follows
        status = page.locator(".jp-Cell").nth(0).locator(".plantvr-status")
        assert "brush commands 0" in status.inner_text()
        drag(page, frame.bounding_box(), [(0.5, 0.35), (0.55, 0.25), (0.6, 0.15), (0.62, 0.08)])
        page.wait_for_function("""() => { const s = document.querySelector('.plantvr-status');
            return s && !/brush commands 0 /.test(s.innerText); }""", timeout=20_000)
        got2 = poll(page, 1, TW, lambda g: int(g[5]) > 1)
        assert int(got2[5]) > 1 and int(got2[2]) > int(got[2]), (got, got2)
        time.sleep(1.0)
        painted = pixels(frame)
        page.screenshot(path=str(shots / "workbench_treewand_painted.png"))
        text = status.inner_text()
        assert f"markers {got2[2]}" in text, text
        assert np.abs(painted - after).max(axis=-1).mean() > 0.05, "the markers did not appear in the view"
        assert not [e for e in errors if "plantvr" in e.lower() or e.startswith("offline:")], errors


VINE = r"VINE (\w+) (\d+) (\d+) (\d+) (\[[\d, ]*\]) (\w+)"


def test_workbench_vine_wheel_and_label_brush_in_jupyterlab(wb_lab, shots):
    with notebook_page(wb_lab, "vine.ipynb", len(WB_VINE), viewport=(1280, 900), offline=True) as (page, errors):
        run_cell(page, 0)
        frame = live_view(page, 0)
        run_cell(page, 1)
        live, painted, label, selected, _, _ = printed(page, 1, VINE)
        assert live == "True" and painted == "0" and label == selected == "1"
        before = pixels(frame)

        # pick label 4 on the wheel: the brush follows, and the status line says so
        wheel_svg = page.locator(".jp-Cell").nth(0).locator("svg.wheel-svg")
        wheel_svg.scroll_into_view_if_needed()
        n_colors = len(page.locator(".jp-Cell").nth(0).locator("svg.wheel-svg g.wheel-slice").all())
        box = wheel_svg.bounding_box()
        C, R, k = 110 + 14 + 18, 110, 4
        a = (k + 0.5) * 2 * np.pi / n_colors
        page.mouse.click(box["x"] + C + 0.7 * R * np.cos(a), box["y"] + C - 0.7 * R * np.sin(a))
        status = page.locator(".jp-Cell").nth(0).locator(".plantvr-status")
        page.wait_for_function("() => /label 4 /.test(document.querySelector('.plantvr-status').innerText)",
                               timeout=20_000)

        # paint across the sphere: the labels change in the kernel, the view and the status line follow
        frame.scroll_into_view_if_needed()
        drag(page, frame.bounding_box(), [(0.35, 0.5), (0.45, 0.5), (0.55, 0.5), (0.65, 0.5)])
        got = poll(page, 1, VINE, lambda g: int(g[1]) > 0)
        assert int(got[1]) > 0 and got[2] == "4" and got[4] == "[0, 4]", got
        page.wait_for_function("() => !/painted vertices 0 /.test(document.querySelector('.plantvr-status')"
                               ".innerText)", timeout=20_000)
        after = until_changed(frame, before)
        page.screenshot(path=str(shots / "workbench_vine_painted.png"))
        assert f"painted vertices {got[1]}" in status.inner_text()
        assert np.abs(after - before).max(axis=-1).mean() > 0.05, "the painted label did not appear in the view"

        # shift-click the same slice: label 4 is hidden in the document, and its triangles leave the live view
        wheel_svg.scroll_into_view_if_needed()
        box = wheel_svg.bounding_box()
        page.keyboard.down("Shift")
        page.mouse.click(box["x"] + C + 0.7 * R * np.cos(a), box["y"] + C - 0.7 * R * np.sin(a))
        page.keyboard.up("Shift")
        hidden = poll(page, 1, VINE, lambda g: g[5] == "False")
        assert hidden[5] == "False", hidden
        frame.scroll_into_view_if_needed()
        gone = until_changed(frame, after)
        page.screenshot(path=str(shots / "workbench_vine_hidden.png"))
        assert np.abs(gone - after).max(axis=-1).mean() > 0.05, "hiding the label did not change the view"
        assert not [e for e in errors if "plantvr" in e.lower() or e.startswith("offline:")], errors


LS = r"LS (\w+) (\d+) (\d+) ([\d.]+) (\d+)"


def test_lsystem_widget_step_slider_derives_and_redraws_in_jupyterlab(wb_lab, shots):
    """Issue 23: dragging the widget's derivation-step slider in the page issues set_step in the kernel, and the
    live view shows the plant of the new step."""
    with notebook_page(wb_lab, "lsystem.ipynb", len(WB_LSYSTEM), viewport=(1280, 900), offline=True) as (page, errors):
        run_cell(page, 0)
        frame = live_view(page, 0)
        run_cell(page, 1)
        live, step, modules, _, _ = printed(page, 1, LS)
        assert live == "True" and step == "2"
        before = pixels(frame)
        page.screenshot(path=str(shots / "lsystem_widget_step2.png"))
        slider = page.locator(".jp-Cell").nth(0).locator(".widget-hslider", has_text="Step")
        handle = slider.locator(".noUi-handle").first
        handle.scroll_into_view_if_needed()
        drag_handle(page, handle, 400, steps=8)
        got = poll(page, 1, LS, lambda g: g[1] == "5")
        assert got[1] == "5" and int(got[2]) > int(modules), got
        frame.scroll_into_view_if_needed()
        after = until_changed(frame, before)
        page.screenshot(path=str(shots / "lsystem_widget_step5.png"))
        assert np.abs(after - before).max(axis=-1).mean() > 0.5, "the live view did not change"
        assert not [e for e in errors if "plantvr" in e.lower() or e.startswith("offline:")], errors

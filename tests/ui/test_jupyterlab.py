"""The influence triangle in a real JupyterLab: live kernel, real anywidget comm (spec 000_treewand §4.9, TW-V11).

A JupyterLab server is started on 127.0.0.1 in a subprocess with a temporary notebook that makes a
:class:`plantvr.Model` and an :class:`~plantvr.ui.InfluenceTriangle`. Headless Debian Chromium (playwright)
runs the cells, drags the triangle's handle, then re-runs a cell that prints ``model.influence`` in the
kernel; the printed weights are read back from the page. A cell then sets the weights in the kernel and
the handle moves in the page. In the same session a parameter slider of the generated panels is dragged
(the model's λ follows) and a colour-wheel slice is clicked (the selected label follows). The server is always killed.
Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
import time
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import CHROMIUM

from ._jupyter import jupyter_lab, notebook_page, printed, run_cell, screenshot_dir

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
    ("import numpy as np\nfrom plantvr.ui import ColorWheel\nfrom plantvr.vine.segmentation import Segmentation\n"
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
        hb = handle.bounding_box()
        page.mouse.move(hb["x"] + hb["width"] / 2, hb["y"] + hb["height"] / 2)
        page.mouse.down()
        page.mouse.move(hb["x"] + hb["width"] / 2 + 60, hb["y"] + hb["height"] / 2, steps=6)
        page.mouse.up()
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

"""The influence triangle in a real JupyterLab: live kernel, real anywidget comm (spec 000_treewand §4.9, TW-V11).

A JupyterLab server is started on 127.0.0.1 in a subprocess with a temporary notebook that makes a
:class:`plantvr.Model` and an :class:`~plantvr.ui.InfluenceTriangle`. Headless Debian Chromium (playwright)
runs the cells, drags the triangle's handle, then re-runs a cell that prints ``model.influence`` in the
kernel; the printed weights are read back from the page. A cell then sets the weights in the kernel and
the handle moves in the page. In the same session a parameter slider of the generated panels is dragged
(the model's λ follows) and a colour-wheel slice is clicked (the selected label follows). The server is always killed.
Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
import json
import os
import re
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import CHROMIUM, launch_chromium, stop_process_group

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
playwright_api = pytest.importorskip("playwright.sync_api")
pytest.importorskip("jupyterlab")
pytest.importorskip("anywidget")

TOKEN = "plantvr-test-token"
REPO = Path(__file__).resolve().parents[2]
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


def _notebook(cells: list[str]) -> dict:
    return {"cells": [{"cell_type": "code", "execution_count": None, "id": f"c{i}", "metadata": {},
                       "outputs": [], "source": src} for i, src in enumerate(cells)],
            "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"}},
            "nbformat": 4, "nbformat_minor": 5}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def shots(tmp_path):
    d = Path(os.environ.get("PLANTVR_SCREENSHOTS", tmp_path))
    d.mkdir(parents=True, exist_ok=True)
    return d


@pytest.fixture
def lab(tmp_path):
    """A JupyterLab server on a free port, serving ``tmp_path/root``; yields its base URL."""
    root = tmp_path / "root"
    root.mkdir()
    (root / "triangle.ipynb").write_text(json.dumps(_notebook(CELLS)))
    port = _free_port()
    env = {**os.environ, "JUPYTER_CONFIG_DIR": str(tmp_path / "cfg"), "JUPYTER_RUNTIME_DIR": str(tmp_path / "rt"),
           "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]),
           "VTK_DEFAULT_OPENGL_WINDOW": "vtkEGLRenderWindow"}
    # no announcements/news pop-up over the notebook
    settings = tmp_path / "cfg" / "lab" / "user-settings" / "@jupyterlab" / "apputils-extension"
    settings.mkdir(parents=True)
    (settings / "notification.jupyterlab-settings").write_text(
        json.dumps({"fetchNews": "false", "checkForUpdates": False, "doNotDisturbMode": True}))
    cmd = [sys.executable, "-m", "jupyterlab", "--no-browser", f"--port={port}", "--ip=127.0.0.1",
           f"--IdentityProvider.token={TOKEN}", f"--ServerApp.root_dir={root}", "--ServerApp.port_retries=0",
           "--LabApp.expose_app_in_browser=True", f"--LabApp.user_settings_dir={tmp_path / 'cfg' / 'lab' / 'user-settings'}",
           f"--LabApp.workspaces_dir={tmp_path / 'ws'}", "--ServerApp.disable_check_xsrf=True"]
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # CI containers run as root
        cmd.append("--allow-root")
    with open(tmp_path / "lab.log", "wb") as log:
        proc = subprocess.Popen(cmd, cwd=root, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        url = f"http://127.0.0.1:{port}"
        try:
            deadline = time.monotonic() + 40
            while True:
                if proc.poll() is not None:
                    pytest.fail(f"jupyter lab exited: {(tmp_path / 'lab.log').read_text()[-2000:]}")
                try:
                    with urllib.request.urlopen(f"{url}/api/status?token={TOKEN}", timeout=2) as r:
                        if r.status == 200:
                            break
                except OSError:
                    pass
                if time.monotonic() > deadline:
                    pytest.fail(f"jupyter lab did not start in 40 s: {(tmp_path / 'lab.log').read_text()[-2000:]}")
                time.sleep(0.3)
            yield url
        finally:
            stop_process_group(proc)  # server and its kernels


def _run_cell(page, index: int) -> None:
    page.evaluate("""async (i) => {
        const app = window.jupyterapp, nb = app.shell.currentWidget;
        nb.content.activeCellIndex = i;
        await app.commands.execute('notebook:run-cell');
    }""", index)


def _printed(page, cell: int, pattern: str, timeout_s: float = 20.0) -> tuple[str, ...]:
    """The groups of ``pattern`` in the output of ``cell`` (what the kernel printed)."""
    loc = page.locator(".jp-Cell").nth(cell).locator(".jp-OutputArea-output")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if loc.count():
            m = re.search(pattern, loc.last.inner_text())
            if m:
                return m.groups()
        time.sleep(0.2)
    raise AssertionError(f"cell {cell} printed nothing matching {pattern!r}")


def _influence(page) -> np.ndarray:
    """Read the last 'INFLUENCE h t e' line printed by the second cell."""
    return np.array([float(v) for v in _printed(page, 1, r"INFLUENCE ([\d.]+) ([\d.]+) ([\d.]+)")])


def test_drag_triangle_in_jupyterlab_changes_kernel_model(lab, shots):
    with playwright_api.sync_playwright() as p:
        browser = launch_chromium(p, timeout=30_000)
        try:
            page = browser.new_page(viewport={"width": 1100, "height": 800})
            page.set_default_timeout(30_000)
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(f"{lab}/lab/tree/triangle.ipynb?token={TOKEN}", wait_until="domcontentloaded")
            page.wait_for_function("""() => window.jupyterapp && window.jupyterapp.shell.currentWidget
                && window.jupyterapp.shell.currentWidget.sessionContext
                && window.jupyterapp.shell.currentWidget.sessionContext.session
                && window.jupyterapp.shell.currentWidget.sessionContext.session.kernel
                && window.jupyterapp.shell.currentWidget.sessionContext.session.kernel.connectionStatus === 'connected'
                && window.jupyterapp.shell.currentWidget.content.widgets.length === 7""", timeout=45_000)
            _run_cell(page, 0)
            handle = page.locator("circle.tri-handle")
            handle.wait_for(state="visible", timeout=45_000)
            _run_cell(page, 1)
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
                _run_cell(page, 1)
                after = _influence(page)
                if np.allclose(after, [0.0, 0.5, 0.5], atol=0.01) or time.monotonic() > deadline:
                    break
                time.sleep(0.3)
            page.screenshot(path=str(shots / "jupyterlab_triangle.png"))
            np.testing.assert_allclose(after, [0.0, 0.5, 0.5], atol=0.01)

            _run_cell(page, 2)  # the model moves the handle in the browser
            page.wait_for_function("() => document.querySelector('.tri-readout').innerText.includes('H 0.600')")
            cx = float(handle.get_attribute("cx"))
            assert cx == pytest.approx(pad + (0.6 * 0.5 + 0.2 * 1.0) * size, abs=0.5)

            # a parameter slider (ipywidgets, generated from the table) dragged: the model follows
            _run_cell(page, 3)
            handle = page.locator(".jp-Cell").nth(3).locator(".noUi-handle").first
            handle.wait_for(state="visible", timeout=30_000)
            handle.scroll_into_view_if_needed()
            _run_cell(page, 4)
            before_lam = float(_printed(page, 4, r"APICAL ([\d.]+)")[0])
            assert before_lam == pytest.approx(0.55)
            hb = handle.bounding_box()
            page.mouse.move(hb["x"] + hb["width"] / 2, hb["y"] + hb["height"] / 2)
            page.mouse.down()
            page.mouse.move(hb["x"] + hb["width"] / 2 + 60, hb["y"] + hb["height"] / 2, steps=6)
            page.mouse.up()
            deadline, lam = time.monotonic() + 20, before_lam
            while lam == pytest.approx(before_lam) and time.monotonic() < deadline:
                _run_cell(page, 4)
                lam, shown = (float(v) for v in _printed(page, 4, r"APICAL ([\d.]+) ([\d.]+)"))
            assert lam > before_lam + 0.02 and lam == pytest.approx(shown, abs=1e-6) and lam <= 1.0
            page.screenshot(path=str(shots / "jupyterlab_slider.png"))

            # a colour-wheel slice clicked: the selected label changes in the kernel
            _run_cell(page, 5)
            wheel_svg = page.locator(".jp-Cell").nth(5).locator("svg.wheel-svg")
            wheel_svg.wait_for(state="visible", timeout=30_000)
            wheel_svg.scroll_into_view_if_needed()
            _run_cell(page, 6)
            n_colors = int(_printed(page, 6, r"SELECTED (\d+) (\d+)")[1])
            box = wheel_svg.bounding_box()
            C, R, k = 110 + 14 + 18, 110, 4
            a = (k + 0.5) * 2 * np.pi / n_colors
            page.mouse.click(box["x"] + C + 0.7 * R * np.cos(a), box["y"] + C - 0.7 * R * np.sin(a))
            deadline, sel = time.monotonic() + 20, None
            while sel != k and time.monotonic() < deadline:
                _run_cell(page, 6)
                sel = int(_printed(page, 6, r"SELECTED (\d+)")[0])
            page.screenshot(path=str(shots / "jupyterlab_wheel.png"))
            assert sel == k
            assert not [e for e in errors if "plantvr" in e.lower() or "anywidget" in e.lower()], errors
        finally:
            browser.close()

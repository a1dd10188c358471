"""The influence triangle in a real JupyterLab: live kernel, real anywidget comm (spec 000_treewand §4.9, TW-V11).

A JupyterLab server is started on 127.0.0.1 in a subprocess with a temporary notebook that makes a
:class:`plantvr.Model` and an :class:`~plantvr.ui.InfluenceTriangle`. Headless Debian Chromium (playwright)
runs the cells, drags the triangle's handle, then re-runs a cell that prints ``model.influence`` in the
kernel; the printed weights are read back from the page. A last cell sets the weights in the kernel and
the handle moves in the page. The server is always killed.
Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = "/usr/bin/chromium"
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
            try:  # the whole process group: server and kernels
                os.killpg(proc.pid, signal.SIGTERM)
                proc.wait(10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                proc.wait(5)


def _run_cell(page, index: int) -> None:
    page.evaluate("""async (i) => {
        const app = window.jupyterapp, nb = app.shell.currentWidget;
        nb.content.activeCellIndex = i;
        await app.commands.execute('notebook:run-cell');
    }""", index)


def _influence(page, timeout_s: float = 20.0) -> np.ndarray:
    """Read the last 'INFLUENCE h t e' line printed by the second cell."""
    loc = page.locator(".jp-Cell").nth(1).locator(".jp-OutputArea-output")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if loc.count():
            m = re.search(r"INFLUENCE ([\d.]+) ([\d.]+) ([\d.]+)", loc.last.inner_text())
            if m:
                return np.array([float(v) for v in m.groups()])
        time.sleep(0.2)
    raise AssertionError("the kernel printed no INFLUENCE line")


def test_drag_triangle_in_jupyterlab_changes_kernel_model(lab, shots):
    with playwright_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, timeout=30_000, args=[
            "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--disable-component-update", "--disable-sync"])
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
                && window.jupyterapp.shell.currentWidget.content.widgets.length === 3""", timeout=45_000)
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

            _run_cell(page, 1)
            deadline = time.monotonic() + 20
            after = _influence(page)
            while np.allclose(after, before, atol=1e-3) and time.monotonic() < deadline:
                time.sleep(0.2)
                after = _influence(page)
            page.screenshot(path=str(shots / "jupyterlab_triangle.png"))
            np.testing.assert_allclose(after, [0.0, 0.5, 0.5], atol=0.01)

            _run_cell(page, 2)  # the model moves the handle in the browser
            page.wait_for_function("() => document.querySelector('.tri-readout').innerText.includes('H 0.600')")
            cx = float(handle.get_attribute("cx"))
            assert cx == pytest.approx(pad + (0.6 * 0.5 + 0.2 * 1.0) * size, abs=0.5)
            assert not [e for e in errors if "plantvr" in e.lower() or "anywidget" in e.lower()], errors
        finally:
            browser.close()

"""Shared helpers of the browser tests that start a server: a free port, a server subprocess waited for and always
killed, a JupyterLab server with its notebooks, and running / reading notebook cells from playwright.

Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir), see :func:`screenshot_dir`.
"""
from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import launch_chromium, stop_process_group

TOKEN = "plantvr-test-token"
REPO = Path(__file__).resolve().parents[2]

# the notebook is open, its kernel connected and all its ``n`` cells are rendered
_NOTEBOOK_READY = """(n) => { const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
    return !!(w && w.sessionContext && w.sessionContext.session && w.sessionContext.session.kernel
      && w.sessionContext.session.kernel.connectionStatus === 'connected' && w.content.widgets.length === n); }"""


#: ``sitecustomize`` of an offline process: resolving a host that is not loopback fails as it does without a
#: network (``socket.gaierror``), and each refused host is appended to ``$PLANTVR_REFUSED_LOG`` when set.
OFFLINE_SITE = """
import os, socket
_real = socket.getaddrinfo
def _offline(host, *args, **kwargs):
    h = host.decode() if isinstance(host, bytes) else str(host or "")
    if h not in ("localhost", "", "::1", "0.0.0.0") and not h.startswith("127."):
        log = os.environ.get("PLANTVR_REFUSED_LOG")
        if log:
            with open(log, "a") as f:
                f.write(h + "\\n")
        raise socket.gaierror(socket.EAI_NONAME, "Name or service not known (offline test)")
    return _real(host, *args, **kwargs)
socket.getaddrinfo = _offline
"""


def free_port() -> int:
    """A TCP port on 127.0.0.1 that is free now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def screenshot_dir(tmp_path: Path) -> Path:
    """``$PLANTVR_SCREENSHOTS`` (created) or ``tmp_path``."""
    d = Path(os.environ.get("PLANTVR_SCREENSHOTS", tmp_path))
    d.mkdir(parents=True, exist_ok=True)
    return d


def repo_env(**extra: str) -> dict[str, str]:
    """The environment with this checkout first on ``PYTHONPATH`` (for server subprocesses and their kernels)."""
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]), **extra}


@contextmanager
def serve(cmd: list[str], probe: str, *, log: Path, what: str, timeout_s: float = 40.0, **popen) -> Iterator[None]:
    """Run ``cmd`` in a new session (output to ``log``) until ``probe`` answers; kill it and its children on exit.

    The test fails, with the end of the log, if the server exits or ``probe`` does not answer in ``timeout_s``.
    """
    with open(log, "wb") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, start_new_session=True, **popen)
        try:
            deadline = time.monotonic() + timeout_s
            while True:
                if proc.poll() is not None:
                    pytest.fail(f"{what} exited: {log.read_text()[-2000:]}")
                try:
                    with urllib.request.urlopen(probe, timeout=2):
                        break
                except OSError:
                    pass
                if time.monotonic() > deadline:
                    pytest.fail(f"{what} did not start in {timeout_s:g} s: {log.read_text()[-2000:]}")
                time.sleep(0.3)
            yield
        finally:
            stop_process_group(proc)  # the server and everything it spawned (kernels)


def notebook(cells: list[str]) -> dict:
    """An nbformat 4 notebook of code cells, Python 3 kernel."""
    return {"cells": [{"cell_type": "code", "execution_count": None, "id": f"c{i}", "metadata": {},
                       "outputs": [], "source": src} for i, src in enumerate(cells)],
            "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"}},
            "nbformat": 4, "nbformat_minor": 5}


@contextmanager
def jupyter_lab(tmp_path: Path, notebooks: dict[str, list[str]], *, token: str = TOKEN,
                offline: bool = False) -> Iterator[str]:
    """A JupyterLab server on a free port serving ``tmp_path/root`` with ``notebooks`` (file name -> cells);
    yields its base URL. Kernels import this checkout; no news or update pop-up covers the notebook.
    ``offline``: the server and its kernels cannot resolve any host but loopback (:data:`OFFLINE_SITE`)."""
    root = tmp_path / "root"
    root.mkdir()
    for name, cells in notebooks.items():
        (root / name).write_text(json.dumps(notebook(cells)))
    user_settings = tmp_path / "cfg" / "lab" / "user-settings"
    settings = user_settings / "@jupyterlab" / "apputils-extension"
    settings.mkdir(parents=True)
    (settings / "notification.jupyterlab-settings").write_text(
        json.dumps({"fetchNews": "false", "checkForUpdates": False, "doNotDisturbMode": True}))
    port = free_port()
    env = repo_env(JUPYTER_CONFIG_DIR=str(tmp_path / "cfg"), JUPYTER_RUNTIME_DIR=str(tmp_path / "rt"),
                   VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow")
    if offline:
        site = tmp_path / "offline_site"
        site.mkdir()
        (site / "sitecustomize.py").write_text(OFFLINE_SITE)
        env["PYTHONPATH"] = os.pathsep.join([str(site), env["PYTHONPATH"]])
    cmd = [sys.executable, "-m", "jupyterlab", "--no-browser", f"--port={port}", "--ip=127.0.0.1",
           f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={root}", "--ServerApp.port_retries=0",
           "--LabApp.expose_app_in_browser=True", f"--LabApp.user_settings_dir={user_settings}",
           f"--LabApp.workspaces_dir={tmp_path / 'ws'}", "--ServerApp.disable_check_xsrf=True"]
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # CI containers run as root
        cmd.append("--allow-root")
    url = f"http://127.0.0.1:{port}"
    with serve(cmd, f"{url}/api/status?token={token}", log=tmp_path / "lab.log", what="jupyter lab",
               cwd=root, env=env):
        yield url


@contextmanager
def notebook_page(url: str, name: str, n_cells: int, *, viewport: tuple[int, int], token: str = TOKEN,
                  offline: bool = False, console: list[str] | None = None):
    """Open notebook ``name`` of the server at ``url`` in headless Chromium and wait for its kernel.

    The notebook opens in a workspace of its own, and its kernel is shut down on exit. ``offline``: every request
    of the page and its frames to a host that is not loopback is aborted, and noted in ``errors`` as
    ``"offline: refused URL"``. ``console``: filled with the text of the page's console errors.

    Yields
    ------
    page
        The playwright page (default timeout 30 s); the browser is closed on exit.
    errors : list of str
        Filled with the page's uncaught errors as they happen.
    """
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = launch_chromium(p, timeout=30_000)
        try:
            page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
            page.set_default_timeout(30_000)
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            if console is not None:
                page.on("console", lambda m: console.append(m.text) if m.type == "error" else None)
            if offline:
                def refuse(route):
                    parts = urllib.parse.urlsplit(route.request.url)
                    if parts.scheme not in ("http", "https") or parts.hostname in ("127.0.0.1", "localhost", "::1"):
                        route.continue_()
                    else:
                        errors.append(f"offline: refused {route.request.url}")
                        route.abort("internetdisconnected")
                page.context.route("**/*", refuse)
            workspace = re.sub(r"[^\w-]", "-", Path(name).stem)   # its own: no tab of another notebook restored
            page.goto(f"{url}/lab/workspaces/{workspace}/tree/{name}?token={token}", wait_until="domcontentloaded")
            page.wait_for_function(_NOTEBOOK_READY, arg=n_cells, timeout=45_000)
            yield page, errors
        finally:
            with suppress(Exception):      # the kernel (and its render windows) goes with the page
                page.evaluate("() => window.jupyterapp.shell.currentWidget.sessionContext.shutdown()")
            browser.close()


def run_cell(page, index: int) -> None:
    """Run cell ``index`` of the open notebook, and only it (the command JupyterLab's run button sends)."""
    page.evaluate("""async (i) => {
        const app = window.jupyterapp, nb = app.shell.currentWidget;
        nb.content.activeCellIndex = i;
        nb.content.deselectAll();  // a shift-click in an output extends the selection: run this cell only
        await app.commands.execute('notebook:run-cell');
    }""", index)


def printed(page, cell: int, pattern: str, timeout_s: float = 20.0) -> tuple[str, ...]:
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


# -- the live workbench in a page: its view, its sliders, the kernel's answers --------------------------------
def pixels(loc) -> np.ndarray:
    """The RGB pixels (int16, so differences do not wrap) of a playwright locator's screenshot."""
    from io import BytesIO

    from PIL import Image
    return np.asarray(Image.open(BytesIO(loc.screenshot())).convert("RGB"), np.int16)


def live_view(page, cell: int):
    """The trame iframe of the workbench in ``cell``, once its first picture is in."""
    frame = page.locator(".jp-Cell").nth(cell).locator(".plantvr-view iframe")
    frame.wait_for(state="visible", timeout=60_000)
    frame.scroll_into_view_if_needed()
    frame.content_frame.locator("img, canvas").first.wait_for(state="visible", timeout=30_000)
    time.sleep(1.5)
    return frame


def until_changed(loc, before: np.ndarray, timeout_s: float = 20.0) -> np.ndarray:
    """The pixels of ``loc`` once they differ from ``before`` (or after ``timeout_s``: the caller asserts)."""
    deadline = time.monotonic() + timeout_s
    while True:
        now = pixels(loc)
        if now.shape != before.shape or np.abs(now - before).max(axis=-1).mean() > 0 or time.monotonic() > deadline:
            return now
        time.sleep(0.3)


def drag(page, box, path, *, steps: int = 4) -> None:
    """A left-button drag along ``path``, points as fractions (x, y) of the bounding ``box``."""
    (x0, y0), rest = path[0], path[1:]
    page.mouse.move(box["x"] + x0 * box["width"], box["y"] + y0 * box["height"])
    page.mouse.down()
    for x, y in rest:
        page.mouse.move(box["x"] + x * box["width"], box["y"] + y * box["height"], steps=steps)
        time.sleep(0.05)
    page.mouse.up()


def drag_handle(page, handle, dx: float, *, steps: int = 6) -> None:
    """Drag a slider ``handle`` by ``dx`` px, once the layout has settled and the handle is on top.

    The live view's first pictures can still move the page after the handle is scrolled into view;
    a press on a stale box lands on the view and paints instead of sliding.
    """
    deadline, box = time.monotonic() + 20, None
    while True:
        handle.scroll_into_view_if_needed()
        prev, box = box, handle.bounding_box()
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        on_top = handle.evaluate("(h, [x, y]) => h.contains(document.elementFromPoint(x, y))", [x, y])
        if (on_top and prev == box) or time.monotonic() > deadline:
            break
        time.sleep(0.3)
    assert on_top, "the slider handle is covered"
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + dx, y, steps=steps)
    page.mouse.up()


def poll(page, cell: int, pattern: str, ok, timeout_s: float = 30.0):
    """Re-run ``cell`` until the groups of ``pattern`` in its output satisfy ``ok`` (or ``timeout_s``); returns
    the last groups (the caller asserts)."""
    deadline = time.monotonic() + timeout_s
    while True:
        run_cell(page, cell)
        got = printed(page, cell, pattern)
        if ok(got) or time.monotonic() > deadline:
            return got
        time.sleep(0.5)

"""A live notebook run offline in JupyterLab (issue 31): ``notebooks/07_inflorescences.ipynb`` (its code cells)
is run with *Run All* by a JupyterLab server whose kernel cannot resolve any host but loopback. Every cell runs
without an error or a traceback (the VTK.wasm download that failed here is not attempted), the live workbench
shows its picture, and it is still there after the last cell (notebooks close views only when headless).

Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from plantvr._browser import CHROMIUM

from ._jupyter import REPO, jupyter_lab, notebook_page, screenshot_dir

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
pytest.importorskip("playwright.sync_api")
pytest.importorskip("trame_pyvista")

NOTEBOOK = REPO / "notebooks" / "07_inflorescences.ipynb"

_STATE = """() => {
  const nb = window.jupyterapp.shell.currentWidget, cells = nb.content.widgets;
  const done = cells.filter((c) => c.model.type !== 'code' || c.model.executionCount !== null).length;
  const busy = nb.sessionContext.session.kernel.status !== 'idle';
  const errors = [...document.querySelectorAll('.jp-OutputArea-output')]
    .map((o) => o.innerText).filter((t) => /Traceback|Error:|ClientConnector|Downloaded WASM/.test(t));
  return {done, n: cells.length, busy, errors: errors.map((t) => t.slice(0, 400))};
}"""


def test_notebook_07_runs_all_offline_and_keeps_its_live_view(tmp_path, monkeypatch):
    shots = screenshot_dir(tmp_path)
    refused = tmp_path / "refused.txt"
    monkeypatch.setenv("PLANTVR_REFUSED_LOG", str(refused))
    cells = ["".join(c["source"]) for c in json.loads(NOTEBOOK.read_text())["cells"] if c["cell_type"] == "code"]
    with jupyter_lab(tmp_path, {"07.ipynb": cells}, offline=True) as url, \
            notebook_page(url, "07.ipynb", len(cells), viewport=(1280, 1000)) as (page, errors):
        page.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
        deadline = time.monotonic() + 240
        while True:
            state = page.evaluate(_STATE)
            if state["errors"] or (state["done"] == state["n"] and not state["busy"]) or time.monotonic() > deadline:
                break
            time.sleep(1.0)
        assert not state["errors"], state["errors"]
        assert state["done"] == state["n"] and not state["busy"], f"Run All did not finish: {state}"
        wb_cell = next(i for i, c in enumerate(cells) if "workbench(doc)" in c)
        view = page.locator(".jp-Cell").nth(wb_cell).locator(".plantvr-view iframe")
        view.wait_for(state="visible", timeout=30_000)         # still there after the last cell
        view.scroll_into_view_if_needed()
        view.content_frame.locator("img").first.wait_for(state="visible", timeout=30_000)
        time.sleep(1.5)
        page.locator(".jp-Cell").nth(wb_cell).screenshot(path=str(shots / "nb07_offline_after_run_all.png"))
        assert not [e for e in errors if "plantvr" in e.lower() or "anywidget" in e.lower()], errors
    names = set(refused.read_text().split()) if refused.exists() else set()
    assert "gitlab.kitware.com" not in names, "the kernel tried to download VTK.wasm"
    assert os.environ["PLANTVR_REFUSED_LOG"] == str(refused)

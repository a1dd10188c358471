"""The live workbench of each kind in JupyterLab at 1280 px (issue 31, "layout"): no slider label, button, tab
title or readout is clipped (the controls move below the view when the output is too narrow for both), the growth
plot draws its curves, and the inflorescence shows one panel for its floret.

Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir), one per workbench.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from plantvr._browser import CHROMIUM

from ._jupyter import jupyter_lab, notebook_page, run_cell, screenshot_dir

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
pytest.importorskip("playwright.sync_api")
pytest.importorskip("trame_pyvista")

CELLS = [
    ("import plantvr\nfrom plantvr.ui import workbench\nm = plantvr.Model(seed=0)\n"
     "m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)\nm.step(12)\n"
     "wb = workbench(m, window_size=(460, 400))\nwb"),
    ("from plantvr.documents import SketchDocument\nd = SketchDocument(activation_threshold=0.0)\n"
     "d.begin_stroke([0.0, 1.0, 0.0]); d.move_stroke([0.0, 6.0, 0.0], 0.0); d.end_stroke(); d.grow(4)\n"
     "workbench(d, window_size=(460, 400))"),
    ("from plantvr.documents.forest import ForestDocument\n"
     "f = ForestDocument(n_trees=2, width=20.0, depth=20.0, rounds=1, steps_per_round=3, n_darts=120,"
     " compete=False)\nf.grow()\nworkbench(f, window_size=(460, 400))"),
    ("from plantvr.documents import InflorescenceDocument\nworkbench(InflorescenceDocument(),"
     " window_size=(460, 400))"),
]
KINDS = ("treewand", "treesketch", "forest", "inflorescence")

# every label / button / readout inside the output whose text does not fit its box, and the growth plot's
# non-white pixels
_CLIPPED = """(cell) => {
  const out = document.querySelectorAll('.jp-Cell')[cell].querySelector('.jp-OutputArea');
  const bad = [];
  const texts = '.widget-label, .widget-readout, button, .widget-label-basic, .lm-TabBar-tabLabel';
  for (const el of out.querySelectorAll(texts)) {
    const r = el.getBoundingClientRect();
    if (r.width === 0 || el.closest('.lm-mod-hidden, .widget-tab-contents > .lm-mod-hidden')) continue;
    if (el.scrollWidth > el.clientWidth + 1) bad.push((el.textContent || el.title).trim().slice(0, 60));
  }
  const canvas = out.querySelector('canvas');
  let ink = -1;
  if (canvas && canvas.width) {
    const d = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    ink = 0;
    for (let i = 0; i < d.length; i += 4) if (d[i] < 200 || d[i + 1] < 200 || d[i + 2] < 200) ink++;
  }
  const panels = out.querySelectorAll('.widget-tab').length;
  return {bad, ink, panels};
}"""


def test_workbench_layout_at_1280_px(tmp_path):
    shots = screenshot_dir(tmp_path)
    with jupyter_lab(tmp_path, {"layout.ipynb": CELLS}) as url, \
            notebook_page(url, "layout.ipynb", len(CELLS), viewport=(1280, 1800)) as (page, errors):
        found = {}
        for i, kind in enumerate(KINDS):
            run_cell(page, i)
            view = page.locator(".jp-Cell").nth(i).locator(".plantvr-view iframe")
            view.wait_for(state="visible", timeout=90_000)
            view.content_frame.locator("img").first.wait_for(state="visible", timeout=30_000)
            out = page.locator(".jp-Cell").nth(i).locator(".jp-OutputArea")
            out.scroll_into_view_if_needed()
            page.wait_for_timeout(1500)
            out.screenshot(path=str(shots / f"layout_{kind}.png"))
            found[kind] = page.evaluate(_CLIPPED, i)
        assert not [e for e in errors if "plantvr" in e.lower() or "anywidget" in e.lower()], errors
    clipped = {k: v["bad"] for k, v in found.items() if v["bad"]}
    assert not clipped, f"clipped text: {clipped}"
    assert found["treewand"]["ink"] > 200, "the growth plot is an empty box"
    assert found["inflorescence"]["panels"] <= 1, "two panels for one floret"

"""Every document kind's workbench in a real JupyterLab with the network blocked (issue 31).

One JupyterLab server (offline: it and its kernels resolve no host but loopback; the page's requests to any
other host are aborted) serves one small notebook per document kind. For each kind, headless Chromium runs the
notebook's cells and checks that the live view (trame, rendered in the kernel) shows a picture; then, for each
tab of the generated panel (the part's own panel where it has no generated one), drags the tab's first slider
and checks, from what a kernel cell prints, that exactly that parameter of the document changed and that the
view's pixels followed; the workbench's *Undo* button then restores the document (its state bytes, hashed) and
the picture. No output area shows stderr text or a traceback, no widget shows ipywidgets' error box, the page
has no uncaught JavaScript error and no console error naming plantvr or anywidget or a widget it could not
render. The brushes (Tree Wand, ViNE) are tested in test_jupyterlab.py.

Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from plantvr._browser import CHROMIUM

from ._jupyter import (
    drag_handle,
    jupyter_lab,
    live_view,
    notebook_page,
    pixels,
    poll,
    run_cell,
    screenshot_dir,
    until_changed,
)

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
pytest.importorskip("playwright.sync_api")
pytest.importorskip("jupyterlab")
pytest.importorskip("trame_pyvista")

SIZE = "window_size=(380, 320)"
#: Cell 1 of every notebook: the document's values (cell 0 defines ``values()``) and a hash of its whole state.
STATE_CELL = ("import hashlib, json\nprint('STATE', json.dumps({'values': values(), 'state': "
              "hashlib.sha1(doc.state_bytes()).hexdigest()[:16]}, default=str))")
STATE = r"STATE (\{.*\})"
_PARAMS = ("values = lambda: {k: v for k, v in doc.params.items() if isinstance(v, (bool, int, float, str))}\n")


@dataclass(frozen=True)
class Slider:
    """Drag the first slider of panel tab ``tab`` (None: the first slider labelled ``label``) to ``to`` of its
    track (default: 0.7 from the left half, 0.25 from the right); ``param`` is the value that must change."""

    param: str
    tab: int | None = None
    label: str | None = None
    to: float | None = None


@dataclass(frozen=True)
class Button:
    """A panel without sliders (the implicit crown's): fill the first text box of tab ``tab`` with ``fill`` (when
    given), then click its button ``text``; ``param`` is the value that must change."""

    param: str
    tab: int
    text: str
    fill: str | None = None


@dataclass(frozen=True)
class Edit:
    """No panel control (ViNE, whose brush test_jupyterlab.py drags): run cell ``cell``, which changes
    ``param``."""

    param: str
    cell: int


@dataclass(frozen=True)
class Kind:
    cells: list[str]
    #: each changes the document; the workbench's Undo button takes it back
    steps: tuple[Slider | Button | Edit, ...]


KINDS = {
    "treewand": Kind(
        [("import plantvr\nfrom plantvr.ui import workbench\ndoc = plantvr.Model(seed=0)\n"
          "doc.paint_stroke([[0, y, 0] for y in range(2, 6)], radius=2.0)\ndoc.step(8)\n" + _PARAMS +
          f"wb = workbench(doc, {SIZE})\nwb"), STATE_CELL],
        (Slider("tropism_angle", 0), Slider("bark_rate", 1), Slider("shadow_intensity", 2))),
    "treesketch": Kind(
        [("from plantvr.documents import SketchDocument\nfrom plantvr.ui import workbench\n"
          "doc = SketchDocument(seed=1, tip_radius=0.03, n_max=3)\ndoc.begin_stroke([0.0, 1.0, 0.0])\n"
          "doc.move_stroke([0.0, 5.0, 0.0], radius=0.0)\ndoc.move_stroke([1.0, 7.0, 0.0], radius=0.0)\n"
          "doc.end_stroke()\ndoc.paint([0, 6, 0], radius=3.0)\ndoc.grow(8)\n" + _PARAMS +
          f"wb = workbench(doc, {SIZE})\nwb"), STATE_CELL],
        (Slider("tropism_angle", 0), Slider("bark_rate", 1), Slider("shadow_intensity", 2),
         Slider("n_max", 3, to=0.1))),
    "forest": Kind(
        [("from plantvr.documents import ForestDocument\nfrom plantvr.ui import workbench\n"
          "doc = ForestDocument(n_trees=3, width=20.0, depth=20.0, min_dist=6.0, rounds=1, steps_per_round=3,\n"
          "                     crown_height=5.0, crown_radius=3.0, seed=4)\n"
          "doc.grow(params={'tip_radius': 0.03, 'activation_threshold': 0.0, 'length_mode': 'constant'})\n"
          + _PARAMS + f"wb = workbench(doc, {SIZE})\nwb"), STATE_CELL],
        (Slider("n_trees", 0, to=0.02),)),
    "inflorescence": Kind(   # power growth at half time: the warp and the middle pose show in the picture
        [("from plantvr.documents import InflorescenceDocument\nfrom plantvr.ui import workbench\n"
          "doc = InflorescenceDocument(preset='disc floret', growth='power', time=0.5)\n" + _PARAMS +
          f"wb = workbench(doc, {SIZE})\nwb"), STATE_CELL],
        (Slider("nu", 0), Slider("n_fold", 1), Slider("n_poses", 2, to=0.9), Slider("warp", 3),
         Slider("lam", 4))),
    "lsystem": Kind(
        [("from plantvr.documents import LSystemDocument\nfrom plantvr.ui import workbench\n"
          "doc = LSystemDocument(step=2)\nvalues = lambda: {'step': doc.step, **doc.externs}\n"
          f"wb = workbench(doc, {SIZE})\nwb"), STATE_CELL],
        (Slider("step", label="Step"), Slider("angle", label="angle"))),
    "crown": Kind(   # the panel's tabs Scene, Points, Growth: text boxes and buttons
        [("from plantvr.documents import CrownDocument\nfrom plantvr.ui import workbench\n"
          "doc = CrownDocument(seed=0)\ndoc.run('sphere crown 6 0 6 0\\npoint_set_gen crown uniform num_points=300')\n"
          "values = lambda: {'box': str(doc.surface('crown').bbox.round(3).tolist()), 'points': len(doc.points),\n"
          "                  'trees': len(doc.trees)}\n"
          f"wb = workbench(doc, {SIZE})\nwb"), STATE_CELL],
        (Button("box", 0, "Translate", fill="3"), Button("points", 1, "Generate"), Button("trees", 2, "Grow"))),
    "vine": Kind(
        [("import numpy as np, trimesh\nfrom plantvr.documents.labels import Segmentation\n"
          "from plantvr.ui import workbench\nico = trimesh.creation.icosphere(subdivisions=3, radius=1.0)\n"
          "doc = Segmentation(ico.vertices.astype(np.float32), ico.faces)\n"
          "values = lambda: {'painted': int((doc.labels > 0).sum())}\n"
          f"wb = workbench(doc, {SIZE})\nwb"), STATE_CELL, "doc.paint([0.0, 0.0, 1.0], 0.6, 3)"],
        (Edit("painted", 2),)),
}

_STDERR = """() => [...document.querySelectorAll('.jp-OutputArea-output')].filter((o) =>
    o.dataset.mimeType === 'application/vnd.jupyter.stderr' || /Traceback|Error:/.test(o.innerText))
    .map((o) => o.innerText.slice(0, 400))"""


@pytest.fixture(scope="module")
def kinds_lab(tmp_path_factory):
    """One offline JupyterLab server with a notebook per kind; yields (URL, refused-hosts log, screenshot dir)."""
    tmp = tmp_path_factory.mktemp("kinds_lab")
    refused = tmp / "refused.txt"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PLANTVR_REFUSED_LOG", str(refused))
        with jupyter_lab(tmp, {f"{k}.ipynb": kind.cells for k, kind in KINDS.items()}, offline=True) as url:
            yield url, refused, screenshot_dir(tmp)


def _centered(frame):
    """``frame`` scrolled to the middle of the notebook (never partly under its sticky toolbar), for pictures."""
    frame.evaluate("(e) => e.scrollIntoView({block: 'center', inline: 'nearest'})")
    return frame


def _state(page) -> dict:
    return json.loads(poll(page, 1, STATE, lambda g: True)[0])


def _until_state(page, ok) -> dict:
    return json.loads(poll(page, 1, STATE, lambda g: ok(json.loads(g[0])))[0])


def _diff(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max(axis=-1).mean()) if a.shape == b.shape else np.inf


def _until_back(frame, ok, timeout_s: float = 20.0) -> np.ndarray:
    """The pixels of ``frame`` once ``ok(pixels)`` (or after ``timeout_s``: the caller asserts)."""
    deadline = time.monotonic() + timeout_s
    while True:
        now = pixels(frame)
        if ok(now) or time.monotonic() > deadline:
            return now
        time.sleep(0.3)


def _tab(cell, index: int):
    """The contents of the first tab bar's tab ``index`` in ``cell``, once its title is clicked."""
    tabs = cell.locator(".widget-tab").first
    title = tabs.locator(".lm-TabBar-tab").nth(index)
    title.scroll_into_view_if_needed()
    title.click()
    return tabs.locator(".widget-tab-contents > *").nth(index)


def _handle(cell, slider: Slider):
    """The first slider handle of the slider's panel tab, or of its labelled slider."""
    if slider.tab is None:
        return cell.locator(".widget-slider", has_text=slider.label).locator(".noUi-handle").first
    return _tab(cell, slider.tab).locator(".noUi-handle").first


def _press(cell, button: Button) -> None:
    tab = _tab(cell, button.tab)
    if button.fill is not None:
        box = tab.locator("input").first
        box.fill(button.fill)
        box.press("Enter")
    tab.locator("button", has_text=button.text).first.click()


def _drag_to(page, handle, to: float | None) -> None:
    track = handle.locator("xpath=ancestor::div[contains(@class, 'noUi-target')]").bounding_box()
    box = handle.bounding_box()
    x = box["x"] + box["width"] / 2
    f = (x - track["x"]) / track["width"]
    to = (0.7 if f < 0.5 else 0.25) if to is None else to
    drag_handle(page, handle, track["x"] + to * track["width"] - x, steps=8)


@pytest.mark.parametrize("kind", list(KINDS))
def test_workbench_of_every_kind_in_offline_jupyterlab(kinds_lab, kind):
    url, refused, shots = kinds_lab
    spec = KINDS[kind]
    console: list[str] = []
    with notebook_page(url, f"{kind}.ipynb", len(spec.cells), viewport=(1280, 1000), offline=True,
                       console=console) as (page, errors):
        run_cell(page, 0)
        frame = live_view(page, 0)
        cell = page.locator(".jp-Cell").nth(0)
        first = pixels(_centered(frame))
        bg = first[2, 2]
        assert (np.abs(first - bg).max(axis=-1) > 30).mean() > 0.01, "the live view is blank"
        page.screenshot(path=str(shots / f"kinds_{kind}_0.png"))
        undo = cell.locator("button", has_text="Undo").first
        for n, step in enumerate(spec.steps, 1):
            name = step.param
            start, before = _state(page), pixels(_centered(frame))
            if isinstance(step, Slider):
                _drag_to(page, _handle(cell, step), step.to)
            elif isinstance(step, Button):
                _press(cell, step)
            else:
                run_cell(page, step.cell)
            got = _until_state(page, lambda s, start=start: s["state"] != start["state"])
            changed = {k for k in got["values"] if got["values"][k] != start["values"].get(k)}
            assert changed == {name}, (kind, name, start["values"], got["values"])
            _centered(frame)
            after = until_changed(frame, before)
            assert _diff(after, before) > 0.01, f"{kind}: {name} changed, the live view did not"
            print(f"{kind}: {name} {start['values'][name]} -> {got['values'][name]}, "
                  f"view changed by {_diff(after, before):.3f}")
            page.screenshot(path=str(shots / f"kinds_{kind}_{n}_{name}.png"))
            undo.scroll_into_view_if_needed()
            undo.click()
            back = _until_state(page, lambda s, start=start: s["state"] == start["state"])
            assert back == start, f"{kind}: Undo did not restore the document after {name}"
            _centered(frame)
            # the picture before again (0.02: a few pixels; an undone regrow puts the camera back exactly)
            def back_again(px, before=before):
                return _diff(px, before) <= 0.02
            again = _until_back(frame, back_again)
            ok = back_again(again)
            print(f"{kind}: {name} undone, {_diff(again, before):.3f} from before, {_diff(again, after):.3f} from after")
            if not ok:
                for tag, img in (("before", before), ("undone", again)):
                    Image.fromarray(img.astype(np.uint8)).save(shots / f"kinds_{kind}_{n}_{name}_{tag}.png")
            assert ok, f"{kind}: Undo did not restore the picture after {name}"
        assert not page.evaluate(_STDERR), page.evaluate(_STDERR)
        assert not errors, errors
        assert not [c for c in console if "plantvr" in c.lower() or "anywidget" in c.lower()
                    or "could not create a view" in c.lower()], console
        assert page.locator(".jupyter-widgets-error-widget").count() == 0, f"{kind}: a widget failed to render"
    assert not (refused.exists() and refused.read_text().split()), refused.read_text()

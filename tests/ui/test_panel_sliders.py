"""Every parameter table declares slider-safe ranges, and every generated panel's sliders work (issue 31,
"sliders that do nothing or break").

* Each numeric row of every document's ``PARAMS`` has a finite range and a finite,
  increasing slider span inside it, logarithmic where it spans decades; a linear slider's pixel is a small step
  of the default value.
* Every generated panel (:class:`~plantvr.ui.ParameterPanels`, all windows) of every document kind has sliders,
  each with finite bounds and a state that serialises as strict JSON (what the Jupyter comm sends; an infinite
  bound is what gave "Out of range float values are not JSON compliant").
* A slider of each window of each kind's workbench changes the document; where the document regrows (Tree Wand,
  TreeSketch, forest) it regrows, and the view's picture changes.
"""
from __future__ import annotations

import io
import json
import math
import sys
from pathlib import Path

import ipywidgets as W
import numpy as np
import pytest
from PIL import Image

from plantvr.documents import InflorescenceDocument, Model, SketchDocument
from plantvr.documents.forest import ForestDocument
from plantvr.params import ParamTable
from plantvr.ui import ParameterPanels, workbench

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "view"))
from test_every_document import _forest, _inflorescence, _treesketch, _treewand  # noqa: E402

DOCUMENTS = (Model, SketchDocument, ForestDocument, InflorescenceDocument)
TABLES = {d.PARAMS.name: d.PARAMS for d in DOCUMENTS}
SLIDER_PX = 400        # a panel slider is 420 px wide, ~400 px of track
SLIDERS = (W.FloatSlider, W.IntSlider, W.FloatLogSlider)


def _numeric(table: ParamTable):
    return [p for p in table if not p.choices and p.kind is not bool]


@pytest.mark.parametrize("name", sorted(TABLES))
def test_every_table_declares_finite_slider_safe_ranges(name):
    for p in _numeric(TABLES[name]):
        lo, hi = p.slider_span()
        assert all(math.isfinite(v) for v in (*p.range, lo, hi)), p.name
        assert p.range[0] <= lo < hi <= p.range[1], p.name
        json.dumps({"range": p.range, "slider": (lo, hi), "default": p.default}, allow_nan=False)
        if p.log:
            assert lo > 0 and (p.range[0] > 0 or p.low_open), p.name
        elif p.kind is float and p.step is None and p.default:
            # one pixel of a linear slider is at most a quarter of the default: the default can be adjusted
            assert (hi - lo) / SLIDER_PX <= abs(p.default) / 4, f"{name}.{p.name}: {(lo, hi)} needs log=True"


def test_a_table_with_an_unbounded_range_is_refused():
    from plantvr.params import Param

    row = {"name": "d", "kind": float, "default": 1.0, "doc": "d", "ref": "-", "window": "w"}
    with pytest.raises(ValueError, match="'d' of table 't' needs a finite range"):
        ParamTable("t", [Param(**row, range=(0.0, math.inf))])
    with pytest.raises(ValueError, match="slider span"):
        ParamTable("t", [Param(**row, range=(0.0, 10.0), slider=(0.0, 20.0))])
    with pytest.raises(ValueError, match="logarithmic slider needs positive values"):
        ParamTable("t", [Param(**row, range=(0.0, 10.0), slider=(0.0, 5.0), log=True)])


@pytest.mark.parametrize("cls", DOCUMENTS, ids=lambda c: c.__name__)
def test_every_generated_panel_has_sliders_with_finite_json_bounds(cls):
    doc = cls(n_trees=2) if cls is ForestDocument else cls()
    panels = ParameterPanels(doc, include_hidden=True)
    try:
        table = cls.PARAMS
        for key in panels.windows:
            names = [p.name for p in table if p.window == key and p.name in panels.controls]
            assert any(isinstance(panels.controls[n], SLIDERS) for n in names), f"window {key} has no slider"
        for name, ctl in panels.controls.items():
            state = ctl.get_state()
            json.dumps({k: v for k, v in state.items() if not isinstance(v, (bytes, memoryview))}, allow_nan=False)
            if isinstance(ctl, SLIDERS):
                assert all(math.isfinite(v) for v in (ctl.min, ctl.max, ctl.value, ctl.step)), name
                assert ctl.min < ctl.max, name
                p = table[name]
                assert isinstance(ctl, W.FloatLogSlider) == p.log, name
                if p.log:           # a log slider's bounds are exponents
                    assert p.range[0] <= 10 ** ctl.min and 10 ** ctl.max <= p.range[1], name
                else:
                    assert p.range[0] <= ctl.min and ctl.max <= p.range[1], name
        assert ("min_dist" not in panels.controls
                or (panels.controls["min_dist"].max < 3) and isinstance(panels.controls["min_dist"], W.FloatLogSlider))
    finally:
        panels.close()


def test_log_slider_widens_to_a_value_set_from_code_and_round_trips():
    doc = ForestDocument(n_trees=2)
    panels = ParameterPanels(doc)
    s = panels.controls["min_dist"]
    assert isinstance(s, W.FloatLogSlider) and s.value == pytest.approx(8.0)
    doc.min_dist = 5000.0                                   # beyond the slider's span, inside the range
    assert s.value == pytest.approx(5000.0) and 10 ** s.max >= 5000.0
    s.value = 2.5
    assert doc.min_dist == pytest.approx(2.5)
    panels.close()


def _image(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.int16)


#: kind -> (document factory, {window: slider to move}, sliders whose move must change the picture). The
#: inflorescence workbench shows the floret editor only (it edits every row): its sliders are moved, the pose
#: slider editing the selected (open) pose.
CASES = {
    "treewand": (lambda: _treewand()[0], {"form": "max_len_mult", "appearance": "tip_radius",
                                          "light": "vigor_mult"}, ("max_len_mult", "tip_radius")),
    "treesketch": (lambda: _treesketch()[0], {"form": "main_branch_angle", "appearance": "tip_radius",
                                              "light": "vigor_mult", "sketch": "n_max"},
                   ("main_branch_angle", "tip_radius")),
    "forest": (lambda: _forest()[0], {"forest": "width"}, ("width",)),
    "inflorescence": (lambda: _inflorescence()[0], {"petal": "base_radius", "corolla": "n_fold",
                                                    "poses": "opening_deg", "growth": "time", "mesh": "lam"},
                      ("base_radius", "opening_deg", "time")),
}
ATTRIBUTE = {"opening_deg": "open_opening_deg"}


def _move(ctl) -> None:
    """Move a slider to another value inside its span (a third of the way from the end it is nearer)."""
    if isinstance(ctl, W.IntSlider):
        ctl.value = ctl.max if ctl.value - ctl.min < ctl.max - ctl.value else ctl.min
    elif isinstance(ctl, W.FloatLogSlider):
        e = math.log10(ctl.value)
        ctl.value = 10 ** (e + (ctl.max - e) * 0.5 if e - ctl.min < ctl.max - e else e - (e - ctl.min) * 0.5)
    else:
        ctl.value = ctl.value + (ctl.max - ctl.value) * 0.6 if ctl.value - ctl.min < ctl.max - ctl.value \
            else ctl.value - (ctl.value - ctl.min) * 0.6


@pytest.mark.parametrize("kind", sorted(CASES))
def test_every_panel_slider_regrows_and_redraws(kind):
    make, by_window, visible = CASES[kind]
    doc = make()
    wb = workbench(doc, live=False, window_size=(200, 160))
    try:
        if wb.panels is None:
            assert kind == "inflorescence" and wb.editor is not None
            controls = wb.editor.controls
            assert set(by_window) == {p.window for p in doc.PARAMS}, "one slider per window of the table"
        else:
            controls = wb.panels.controls
            assert set(by_window) == set(wb.panels.windows), "one slider per window of the generated panel"
        regrow_windows = {"treewand": ("form", "light"), "treesketch": ("form", "light", "sketch"),
                          "forest": ("forest",)}.get(kind, ())
        for window, name in by_window.items():
            ctl = controls[name]
            assert isinstance(ctl, SLIDERS), name
            before, png, regrows = doc.state_bytes(), wb.screen.value, wb.regrows
            _move(ctl)
            wb.flush()
            assert doc.state_bytes() != before, f"{kind}: the {name} slider did not change the document"
            assert getattr(doc, ATTRIBUTE.get(name, name)) == pytest.approx(ctl.value), name
            if window in regrow_windows:
                assert wb.regrows == regrows + 1, f"{kind}: the {name} slider did not regrow"
            if name in visible:
                diff = np.abs(_image(wb.screen.value) - _image(png)).max(axis=-1)
                assert (diff > 8).mean() > 0.002, f"{kind}: the {name} slider did not redraw"
                assert wb.view.drawn_version == doc.version
    finally:
        wb.close()


def _outside(view, pts: np.ndarray) -> float:
    """Share of ``pts`` the view's camera projects outside its picture."""
    ren = view.plotter.renderer
    w, h = view.plotter.window_size
    out = 0
    for p in pts:
        ren.SetWorldPoint(*p, 1.0)
        ren.WorldToDisplay()
        x, y, _ = ren.GetDisplayPoint()
        out += not (0 <= x <= w and 0 <= y <= h)
    return out / max(len(pts), 1)


def test_the_camera_is_refitted_after_a_regrow():
    doc = _treewand()[0]
    wb = workbench(doc, live=False, window_size=(200, 160))
    try:
        direction = np.subtract(*wb.view.plotter.camera_position[:2])
        old = wb.view.plotter.camera_position
        assert _outside(wb.view, doc.tree.pos[doc.tree.alive]) == 0
        wb.panels.controls["max_len_mult"].value = 10.0          # internodes up to 10 base lengths: a taller tree
        wb.flush()
        pts = doc.tree.pos[doc.tree.alive]
        assert wb.regrows == 1 and np.ptp(pts[:, 1]) > 0
        assert _outside(wb.view, pts) == 0, "the regrown tree left the frame"
        new = np.subtract(*wb.view.plotter.camera_position[:2])
        assert np.allclose(new / np.linalg.norm(new), direction / np.linalg.norm(direction))   # same direction
        wb.view.plotter.camera_position = old                      # the camera before: the tree went out of it
        assert _outside(wb.view, pts) > 0
    finally:
        wb.close()


def _widgets(w):
    """``w`` and every widget under it."""
    yield w
    for c in getattr(w, "children", ()):
        yield from _widgets(c)


def test_every_part_panel_has_finite_json_sliders(tmp_path):
    """The parts' own panels beside the generated one (floret editor, TreeSketch architecture, implicit crown,
    L-system externs) send finite, strict-JSON slider bounds too."""
    from plantvr.documents import CrownDocument, LSystemDocument
    from plantvr.ui.workbench import EDITORS

    docs = {"inflorescence": InflorescenceDocument(), "treesketch": SketchDocument(),
            "crown": CrownDocument(base_dir=tmp_path, seed=0), "lsystem": LSystemDocument()}
    assert set(docs) == set(EDITORS)
    for kind, doc in docs.items():
        panel = EDITORS[kind](doc)
        try:
            sliders = [w for w in _widgets(panel) if isinstance(w, SLIDERS)]
            assert sliders or kind == "crown", f"{kind}: no slider found"   # the crown panel types its values
            for s in sliders:
                assert all(math.isfinite(v) for v in (s.min, s.max, s.value, s.step)) and s.min < s.max, kind
                json.dumps({k: v for k, v in s.get_state().items() if not isinstance(v, (bytes, memoryview))},
                           allow_nan=False)
        finally:
            panel.close()

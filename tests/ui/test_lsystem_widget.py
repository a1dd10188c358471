"""The L-system widget headless (issue 23, "A notebook widget"): its step slider, parameter editors and grammar
box issue the document's commands and follow its changes, an engine error is shown with line and column, and the
offscreen view redraws (the pixels change) after a step change."""
import io
import os

import ipywidgets as W
import numpy as np
import pytest
from PIL import Image

from plantvr.documents.lsystem import LSystemDocument
from plantvr.ui.lsystem import LsystemPanel, LsystemWidget, extern_param
from plantvr.ui.workbench import Workbench

GRAMMAR = """\
extern(delta=22.5, n=3, shrink=0.8)
Axiom: X
derivation length: 5
production:
X --> F(1)[+(delta)X][-(delta)X]F(shrink)X
endlsystem
"""
PNG_DIR = os.environ.get("PLANTVR_TEST_PNG_DIR", "/tmp")


def _image(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.int16)


@pytest.fixture
def widget():
    doc = LSystemDocument(GRAMMAR, step=2)
    w = LsystemWidget(doc, live=False, window_size=(260, 220))
    yield doc, w
    w.close()


def test_layout_is_a_workbench_with_the_lsystem_panel(widget):
    doc, w = widget
    assert isinstance(w, Workbench) and isinstance(w.panel, LsystemPanel) and w.editor is w.panel
    assert isinstance(w.screen, W.Image) and _image(w.screen.value).shape == (220, 260, 3)
    assert isinstance(w.step_slider, W.IntSlider) and (w.step_slider.min, w.step_slider.max) == (0, 5)
    assert w.step_slider.value == 2 and w.grammar.value == GRAMMAR
    assert set(w.controls) == {"delta", "n", "shrink"}
    assert isinstance(w.controls["delta"], W.FloatSlider) and w.controls["delta"].max == pytest.approx(67.5)
    assert "step 2 / 5" in w.status.value and f"segments {doc.tree.n_internodes}" in w.status.value


def test_sliders_command_the_document_and_follow_it(widget):
    doc, w = widget
    n = len(doc.log)
    w.step_slider.value = 4
    assert doc.step == 4 and doc.log.events[-1].command == "set_step" and doc.log.events[-1].kwargs == {"step": 4}
    w.controls["delta"].value = 40.0
    assert doc.overrides == {"delta": 40.0} and doc.log.events[-1].command == "set_externs"
    assert [e.command for e in doc.log.events[n:]] == ["set_step", "set_externs"]   # commands only
    doc.undo()                                                   # the document changed: the widgets follow
    assert w.controls["delta"].value == pytest.approx(22.5)
    doc.undo()
    assert w.step_slider.value == 2
    doc.set_step(5)
    assert w.step_slider.value == 5 and "step 5 / 5" in w.panel.status.value


def test_apply_shows_the_engines_line_and_column_and_changes_nothing(widget):
    doc, w = widget
    before = doc.state_bytes()
    w.grammar.value = GRAMMAR.replace("F(1)[", "F(1)(")
    assert w.apply() is False
    assert "Not applied: line 5, column" in w.panel.status.value and doc.state_bytes() == before
    assert w.grammar.value != doc.text                           # the text stays for the user to fix
    w.grammar.value = GRAMMAR.replace("extern(delta=22.5, n=3, shrink=0.8)", "extern(delta=30.0)").replace(
        "F(shrink)", "F(0.8)")
    w.apply_button.click()
    assert doc.log.events[-1].command == "set_grammar" and doc.text == w.grammar.value
    assert set(w.panel.controls) == {"delta"} and "Not applied" not in w.panel.status.value
    assert w.controls["delta"].value == pytest.approx(30.0)      # the new grammar's default


def test_the_view_redraws_after_a_step_change(widget):
    _, w = widget
    before = _image(w.screen.value)
    w.step_slider.value = 5
    after = _image(w.screen.value)
    assert np.abs(after - before).max(axis=-1).mean() > 1.0     # the picture followed the slider
    Image.fromarray(before.astype(np.uint8)).save(os.path.join(PNG_DIR, "lsystem_widget_step2.png"))
    Image.fromarray(after.astype(np.uint8)).save(os.path.join(PNG_DIR, "lsystem_widget_step5.png"))
    bark = (np.abs(after - [96, 66, 40]).sum(-1) < 120).mean()   # brownish pixels: the plant is in the picture
    assert bark > 0.002


def test_extern_ranges_come_from_the_default():
    assert extern_param("a", 20.0).range == (0.0, 60.0) and extern_param("a", 20.0).kind is float
    assert extern_param("a", -2.0).range == (-6.0, 0.0) and extern_param("z", 0.0).range == (-1.0, 1.0)
    p = extern_param("n", 3)
    assert p.kind is int and p.range == (0, 10)
    with pytest.raises(ValueError, match="doc must be an LSystemDocument"):
        LsystemPanel(object())
    w = LsystemWidget(GRAMMAR, live=False, window_size=(96, 96))   # a grammar text makes its document
    assert isinstance(w.doc, LSystemDocument) and w.doc.step == 5
    w.close()
    w.close()


def test_the_trust_box_is_passed_to_set_grammar_and_follows_the_document(widget):
    doc, w = widget
    code = "def f(x):\n    return x * 2\nAxiom: F(f(1))\nderivation length: 1\nproduction:\nendlsystem\n"
    panel = w.panel
    assert isinstance(panel.trust_box, W.Checkbox) and panel.trust_box.value is False
    assert "Trust this grammar (runs its Python code)" in panel.trust_box.description
    before = doc.state_bytes()
    w.grammar.value = code
    assert w.apply() is False and doc.state_bytes() == before
    assert "line 1, column 1" in panel.status.value and "trusted=True" in panel.status.value
    panel.trust_box.value = True
    assert w.apply() is True and doc.trusted and doc.log.events[-1].kwargs["trusted"] is True
    doc.undo()                                                   # back to the untrusted grammar: the box follows
    assert panel.trust_box.value is False and not doc.trusted


def test_a_widget_of_a_grammar_str_takes_trusted():
    code = "def f(x):\n    return x * 2\nAxiom: F(f(1))\n"
    with pytest.raises(ValueError, match="trusted=True"):
        LsystemWidget(code, live=False, window_size=(120, 100))
    w = LsystemWidget(code, live=False, window_size=(120, 100), trusted=True)
    try:
        assert w.doc.trusted and w.trust_box.value is True
    finally:
        w.close()


def test_one_drag_of_the_step_slider_is_one_undo_item(widget, monkeypatch):
    """Issue 31: values of one drag (less than DRAG_GAP apart, no other command between) make one undo item;
    undo takes the whole drag back, and the log replays to the same state."""
    import plantvr.ui.lsystem_panel as P
    doc, w = widget
    clock = [100.0]
    monkeypatch.setattr(P.time, "monotonic", lambda: clock[0])
    for v in (3, 4, 5):                          # one drag
        w.step_slider.value = v
        clock[0] += 0.05
    assert doc.step == 5
    clock[0] += 2 * P.DRAG_GAP
    w.step_slider.value = 1                      # a new drag
    doc.undo()
    assert doc.step == 5 and w.step_slider.value == 5
    doc.undo()
    assert doc.step == 2 and w.step_slider.value == 2 and not doc.can_undo
    fresh = LSystemDocument(GRAMMAR, step=2)
    doc.redo()
    doc.redo()
    fresh.replay(doc.log)
    assert fresh.state_bytes() == doc.state_bytes() and fresh.step == 1

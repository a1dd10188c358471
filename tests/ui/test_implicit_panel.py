"""Implicit command-language panel, a view of a crown document, driven from code: run, rejected lines, preview,
save and replay of the command log (issues 10, 21)."""
import io

import numpy as np
import pytest
from PIL import Image

from plantvr.commandlog import CommandLog
from plantvr.documents.crown import CrownDocument
from plantvr.ui.implicit_panel import ImplicitPanel, preview_png

SCRIPT = """sphere crown 10 0 8 0
scale crown 1 1.2 1
point_set_gen crown uniform num_points=300
"""


def _img(png):
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def test_run_updates_session_and_preview():
    panel = ImplicitPanel(script=SCRIPT)
    empty = _img(panel.preview.value)
    assert panel.run() is True
    s = panel.doc
    assert list(s.surfaces) == ["crown"] and len(s.points) == 300
    assert panel.surface.options == ("crown",) and panel.surface.value == "crown"
    assert panel.history.value.splitlines() == [ln for ln in SCRIPT.splitlines() if ln] == panel.doc.lines
    assert "300 points" in panel.status.value and panel.error.value == "" and panel.error_line == 0
    img = _img(panel.preview.value)
    assert panel.preview.value[:4] == b"\x89PNG" and img.shape == empty.shape
    im = img.astype(int)
    green = (im[..., 1] > im[..., 0] + 6) & (im[..., 1] > im[..., 2] + 6)        # the envelope is drawn
    assert green.mean() > 0.02
    assert np.abs(img.astype(int) - empty).mean() > 1.0


def test_rejected_line_names_line_and_token_and_leaves_session_unchanged():
    panel = ImplicitPanel(script=SCRIPT)
    assert panel.run()
    before = (dict(panel.doc.surfaces), len(panel.doc.points), list(panel.doc.lines))
    png = panel.preview.value
    assert panel.run("sphere extra 4\nscale crown 1 oops 1\nsphere never 3\n") is False
    assert panel.error_line == 2 and panel.error_token == "oops"
    assert "line 2" in panel.error.value and "oops" in panel.error.value
    assert "&#9654;   2: scale crown 1 <u><b>oops</b></u> 1" in panel.error.value
    assert (dict(panel.doc.surfaces), len(panel.doc.points), list(panel.doc.lines)) == before
    assert panel.preview.value == png
    assert panel.run("bogus 1 2") is False and panel.error_line == 1 and panel.error_token == "bogus"
    assert panel.run("sphere ok 3") is True and panel.error_line == 0 and panel.error.value == ""


def test_button_runs_the_script_box():
    panel = ImplicitPanel(script="sphere a 4\n")
    panel.run_button.click()
    assert "a" in panel.doc.surfaces
    panel.clear_button.click()
    assert panel.script.value == ""


def test_empty_envelope_is_reported_not_raised():
    panel = ImplicitPanel(script="sphere a 4\ndiff a a hole\n")
    assert panel.run()
    assert panel.surface.value == "hole"
    assert "empty envelope" in panel.error.value
    assert panel.preview.value[:4] == b"\x89PNG"
    panel.surface.value = "a"                                   # choosing a surface redraws it
    assert panel.error.value == ""


def test_save_and_replay(tmp_path):
    panel = ImplicitPanel(CrownDocument(base_dir=tmp_path, seed=3), script=SCRIPT)
    assert panel.run()
    path = panel.save(tmp_path / "s.txt")
    pts = panel.doc.points.points.copy()
    other = ImplicitPanel(CrownDocument(seed=3), script="")
    other.path.value = str(path)
    other.load_button.click()
    assert other.error_line == 0 and list(other.doc.surfaces) == ["crown"]
    np.testing.assert_array_equal(other.doc.points.points, pts)      # same seed, identical output
    bad = tmp_path / "bad.txt"
    bad.write_text("sphere a 3\nline\n")
    assert other.replay(bad) is False and "not a PlantVR event log" in other.error.value     # a script, not a log
    assert other.run_file(bad) is False and other.error_line == 2                              # scripts run as input
    np.testing.assert_array_equal(other.doc.points.points, pts)      # current document kept
    assert other.replay(tmp_path / "missing.txt") is False and "does not exist" in other.error.value
    assert other.run_file(tmp_path / "missing.txt") is False and "does not exist" in other.error.value


def test_preview_draws_trees_and_validates():
    s = CrownDocument(seed=1).run(SCRIPT + "grow step=0.8 kill=1.6\n")
    assert len(s.trees) == 1
    with_tree = _img(preview_png(s, "crown", resolution=24))
    brown = (with_tree[..., 0] > with_tree[..., 2] + 30) & (with_tree[..., 1] < 120)
    assert brown.sum() > 50
    with pytest.raises(ValueError, match="resolution"):
        preview_png(s, "crown", resolution=2)
    with pytest.raises(ValueError, match="not a surface"):
        preview_png(s, "nope")


def test_v30_widget_pipeline_crown_points_tree(tmp_path):
    """Spec 003 V30: the panel built headless runs crown -> points -> tree through its callbacks; every widget
    action is a command line, so the saved command log replays to the identical document."""
    from plantvr.ui.implicit_panel import BOOLEAN_OPS

    panel = ImplicitPanel(CrownDocument(seed=4), script="sphere a 10 0 8 0\nsphere b 6 4 10 0\n")
    assert panel.transform("scale") is False and "no surface" in panel.error.value
    panel.run_button.click()
    assert (panel.operand_a.value, panel.operand_b.value) == ("b", "a")
    panel.swap_button.click()
    assert (panel.operand_a.value, panel.operand_b.value) == ("a", "b")
    panel.boolean.value, panel.result_name.value = "Blend", "crown"
    panel.boolean_button.click()
    assert panel.doc.lines[-1] == "blend a b crown" and panel.surface.value == "crown"
    for w, v in zip(panel.offset, (1.0, 1.2, 1.0)):
        w.value = v
    panel.scale_button.click()
    assert panel.doc.lines[-1] == "scale crown 1 1.2 1"
    panel.num_points.value = 400
    panel.generate_button.click()
    assert len(panel.doc.points) == 400
    panel.step_size.value, panel.kill_radius.value = 0.8, 1.6
    panel.grow_button.click()
    assert panel.doc.lines[-1] == "grow step=0.8 kill=1.6 influence=inf max_steps=500"
    assert len(panel.doc.trees) == 1 and len(panel.doc.trees[0].nodes) > 50
    assert panel.error.value == ""
    panel.result_name.value = "two words"
    assert panel.apply_boolean() is False and "one word" in panel.error.value
    assert set(BOOLEAN_OPS.values()) <= {"union", "diff", "diff2", "inter", "blend"}
    path = panel.save(tmp_path / "widgets.log")
    again = CrownDocument(seed=4)
    again.replay(CommandLog.load(path, CrownDocument.COMMANDS, document="crown"))
    assert again.state_bytes() == panel.doc.state_bytes()
    np.testing.assert_array_equal(again.points.points, panel.doc.points.points)
    np.testing.assert_array_equal(again.trees[0].nodes, panel.doc.trees[0].nodes)


def test_widget_thin_densify_and_rejection():
    panel = ImplicitPanel(CrownDocument(seed=2), script="sphere crown 10 0 8 0\nsphere hole 5 0 8 0\n"
                                                         "point_set_gen crown uniform num_points=500\n")
    assert panel.run()
    panel.surface.value = "crown"
    panel.operand_b.value = "hole"
    panel.thin_percent.value = 100
    panel.thin_button.click()
    assert len(panel.doc.points) < 500
    n = len(panel.doc.points)
    panel.num_points.value, panel.min_distance.value = 50, 0.5
    panel.densify_button.click()
    assert len(panel.doc.points) == n + 50
    panel.root.value = "0, x, 0"                                   # a bad widget value: the line is rejected
    assert panel.grow() is False and panel.error_token in ("x", "grow") and "root" in panel.error.value
    panel.clear_points_button.click()
    assert len(panel.doc.points) == 0


def test_panel_follows_undo_and_redo_of_its_document():
    panel = ImplicitPanel(script=SCRIPT)
    assert panel.run() and panel.run("sphere extra 3")
    assert panel.surface.options == ("crown", "extra")
    panel.doc.undo()
    assert panel.surface.options == ("crown",) and panel.history.value.splitlines()[-1].startswith("point_set_gen")
    panel.doc.undo()
    assert panel.surface.options == () and "0 points" in panel.status.value
    panel.doc.redo()
    assert panel.surface.options == ("crown",) and "300 points" in panel.status.value

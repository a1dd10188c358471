"""Issue 20 for the floret editor and its inflorescence document: every setting, command and export path checks
its input at the door with a ValueError naming it (never a bare TraitError or an error from inside pyvista/numpy),
a rejected command leaves the document unchanged, and the OBJ export is atomic."""
from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr.documents.inflorescence import PRESETS
from plantvr.flowers.floret import FLORET, POSE_KEYS, read_obj_sequence
from plantvr.ui.floret_editor import FloretEditor, preview_png

BAD = [np.nan, np.inf, -np.inf, 1e300, 1e19, 10**12, -5, 0, 1e-20, 0.5, "x", None, [], True, {"a": 1}]
FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
TRAITS = FLORET.names


@pytest.fixture(scope="module")
def editor():
    ed = FloretEditor(live_preview=False)
    yield ed
    ed.close()


def _state(ed) -> tuple:
    return (ed.doc.state_bytes(), ed.pose_index)


def test_wrong_types_raise_value_errors_naming_the_setting(editor):
    """``editor.nu = "x"`` raised traitlets' TraitError; ``weld = "no"`` and ``poses = None`` too."""
    before = _state(editor)
    for name, value in (("nu", "x"), ("nu", 1.5), ("weld", "no"), ("growth", 3), ("open_length", None)):
        with pytest.raises(ValueError, match=name):
            setattr(editor.doc, name, value)
    with pytest.raises(ValueError, match="pose_index"):
        editor.pose_index = "open"
    assert _state(editor) == before


@FUZZ
@given(st.sampled_from(TRAITS), st.sampled_from(BAD))
def test_fuzz_every_setting(fuzz, editor, name, bad):
    before = _state(editor)
    out = fuzz.call(f"InflorescenceDocument.{name}", setattr, editor.doc, name, bad, param=name)
    if isinstance(out, Exception):
        assert _state(editor) == before
    else:                                        # accepted: the floret is still a valid mesh
        fm = editor.doc.floret
        assert len(fm.faces) and np.all(np.isfinite(fm.frames)) and fm.faces.max() < fm.frames.shape[1]
        editor.doc.load_preset("disc floret")    # back to a known state for the next example
        editor.doc.time = 1.0
    out = fuzz.call("FloretEditor.pose_index", setattr, editor, "pose_index", bad, param="pose_index")
    if not isinstance(out, Exception):
        editor.pose_index = 2


@FUZZ
@given(st.sampled_from(BAD + [3, 1, "bud"]), st.sampled_from(list(POSE_KEYS) + ["nu", "bogus"]),
       st.sampled_from(BAD))
def test_fuzz_commands(fuzz, editor, index, key, value):
    before = _state(editor)
    out = fuzz.call("InflorescenceDocument.set_pose", editor.doc.set_pose, index, **{key: value},
                    param=("index", key, "pose"))
    if isinstance(out, Exception):
        assert _state(editor) == before
    else:
        editor.doc.load_preset("disc floret")
    before = _state(editor)
    assert isinstance(fuzz.call("InflorescenceDocument.load_preset", editor.doc.load_preset, value,
                                param="preset"), Exception)
    assert _state(editor) == before
    fuzz.call("FloretMesh.frame_at", editor.doc.floret.frame_at, value, param="t")


@settings(FUZZ, max_examples=12)
@given(st.sampled_from(["size", "color", "camera", "show_edges", "t"]), st.sampled_from(BAD + ["notacolour"]))
def test_fuzz_preview(fuzz, editor, which, bad):
    kw = {which: bad}
    t = kw.pop("t", 0.5)
    kw.setdefault("size", (64, 64))
    out = fuzz.call("preview_png", preview_png, editor.doc.floret, t, param=which, **kw)
    if not isinstance(out, Exception):
        assert out[:4] == b"\x89PNG"


def test_presets_all_build(editor):
    for name in PRESETS:
        editor.doc.load_preset(name)
        assert editor.doc.message == "" and len(editor.doc.floret.faces)
    editor.doc.load_preset("disc floret")


def test_export_is_atomic_and_bad_folders_are_reported(editor, tmp_path, monkeypatch):
    paths = editor.export_obj(tmp_path / "obj")
    faces, frames, fixed = read_obj_sequence(str(tmp_path / "obj"))
    assert len(paths) == frames.shape[0] and np.array_equal(faces, editor.doc.floret.faces)
    old = {p: open(p, "rb").read() for p in paths}
    with pytest.raises(ValueError, match="prefix"):
        editor.export_obj(tmp_path / "obj", prefix="../x")
    with pytest.raises(ValueError, match="folder"):
        editor.export_obj("")
    with pytest.raises(ValueError, match="folder"):
        editor.export_obj(None)

    def boom(*a, **k):
        raise OSError("disk full")

    editor.doc.nu = 7                                 # a different floret: the save would change the files
    monkeypatch.setattr(os, "fsync", boom)
    with pytest.raises(OSError):
        editor.export_obj(tmp_path / "obj")
    monkeypatch.undo()
    assert {p: open(p, "rb").read() for p in paths} == old
    assert not [f for _, _, fs in os.walk(tmp_path) for f in fs if f.endswith(".tmp")]
    # the browser's Export button reports a bad folder in the panel instead of raising in the callback
    (tmp_path / "file").write_text("x")
    editor.folder.value = str(tmp_path / "file" / "sub")
    editor._export_clicked()
    assert "Not exported" in editor.export_status.value
    editor.folder.value = ""
    editor._export_clicked()
    assert "Not exported" in editor.export_status.value
    editor.folder.value = str(tmp_path / "ok")
    editor._export_clicked()
    assert "wrote" in editor.export_status.value
    editor.doc.load_preset("disc floret")


def test_slider_values_from_the_browser_stay_in_range(editor):
    """The browser sets the linked sliders; out-of-range values are clamped by the slider and checked by the
    trait, so the editor never holds a value outside its range."""
    s = editor.controls["nu"]
    s.value = 15
    assert editor.doc.nu == 15
    for p in FLORET:
        if p.range is not None and p.kind is not bool:
            assert p.range[0] <= getattr(editor.doc, p.name) <= p.range[1]
    for k in POSE_KEYS:                                 # the pose sliders have the table's ranges
        lo, hi = FLORET[f"open_{k}"].range
        assert (editor.controls[k].min, editor.controls[k].max) == (lo, hi)
    editor.doc.load_preset("disc floret")

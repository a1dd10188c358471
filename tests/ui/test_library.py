"""Tree library panel: save / reload (lossless; a failed load changes nothing), thumbnails, delete, and parameters of
saved trees as growth or rendering presets (spec 004 Fig. E.8, §2.4, §4.6)."""
import json

import numpy as np
import pytest

import plantvr
from plantvr.documents.treesketch import SketchDocument
from plantvr.params import PARAM_BY_NAME
from plantvr.ui.architecture import ArchitecturePanel
from plantvr.ui.library import LibraryPanel, apply_preset_values, preset_from_tree, tree_svg


def _grown(seed=0, steps=6, **params):
    doc = SketchDocument(seed=seed, activation_threshold=0.0, leaf_size=0.3, **params)
    doc.begin_stroke([0.0, 2.0, 0.0])
    doc.move_stroke([0.0, 8.0, 0.0], 1.5, dt=1.0)
    doc.end_stroke()
    doc.grow(steps)
    return doc


def _live(e):
    a = e.tree.arrays()
    return {k: v[a["alive"]] for k, v in a.items() if k not in ("parent", "child")}


def test_save_reload_lossless_and_bound_to_the_panel(tmp_path):
    src = _grown(deflection=10.0, ellipse_sv=0.9, ellipse_sp=1.2, ellipse_ev=0.1)
    e = src.engine
    panel = ArchitecturePanel(SketchDocument(seed=5), schematic_iterations=4)
    panel.bind(src)
    lib = LibraryPanel(tmp_path / "lib", panel)
    lib.save("oak")
    assert lib.trees.options == ("oak",) and "<line" in lib.thumb.value and "saved 'oak'" in lib.message.value
    other = SketchDocument(seed=9, deflection=40.0)
    panel.bind(other)                                    # the library follows the panel's document
    seen = []
    other.observe(lambda ch: seen.append(ch["new"]), names="change")
    f = lib.load("oak")
    assert [c.command for c in seen] == ["restore"] and panel.engine is f and lib.engine is f and lib.doc is other
    assert panel.branching.angles[1] == 10.0 and panel.ellipse.ellipse == [0.9, 1.2, 0.1]  # widgets follow
    for k, v in _live(e).items():
        np.testing.assert_array_equal(_live(f)[k], v, err_msg=k)
    np.testing.assert_array_equal(f.markers, e.markers)
    # lossless: saving the reloaded tree writes the same files
    lib.save("oak2")
    d = tmp_path / "lib"
    assert (d / "oak.tree").read_text() == (d / "oak2.tree").read_text()
    assert json.loads((d / "oak.json").read_text()) == json.loads((d / "oak2.json").read_text())
    src.grow(2)  # and it continues exactly as the original
    other.grow(2)
    for k, v in _live(e).items():
        np.testing.assert_array_equal(_live(f)[k], v, err_msg=k)


@pytest.mark.parametrize("corrupt", [
    lambda d: (d / "t.json").write_text("{not json"),
    lambda d: (d / "t.json").write_text('{"format": "plantvr-treesketch 1", "options": {}}'),
    lambda d: (d / "t.tree").write_text("# plantvr-tree 1\ntree=N(0,0,0"),
    lambda d: (d / "t.json").write_text(json.dumps({**json.loads((d / "t.json").read_text()), "rng": "x"})),
    lambda d: (d / "t.json").write_text(json.dumps({**json.loads((d / "t.json").read_text()), "born": [1, 2]})),
])
def test_failed_load_leaves_state_unchanged(tmp_path, corrupt):
    doc = _grown(steps=3)
    e = doc.engine
    lib = LibraryPanel(tmp_path, doc)
    lib.save("t")
    corrupt(tmp_path)
    before = (_live(e), dict(e.params), dict(e.sketch), doc.params, doc.version)
    with pytest.raises(ValueError, match="'t'|t.json|.tree"):
        lib.load("t")
    lib.load_button.click()  # through the button: the message names the problem, nothing raises
    assert lib.message.value.startswith("<span style='color:#c0392b'>")
    assert doc.engine is e and lib.engine is e
    after = (_live(e), dict(e.params), dict(e.sketch), doc.params, doc.version)
    for k, v in before[0].items():
        np.testing.assert_array_equal(after[0][k], v)
    assert after[1:] == before[1:]


def test_delete_missing_and_bad_names(tmp_path):
    lib = LibraryPanel(tmp_path, _grown(steps=2))
    lib.save("a")
    lib.save("b")
    lib.delete("a")
    assert lib.library.trees() == ["b"] and not (tmp_path / "a.thumb.svg").exists()
    with pytest.raises(ValueError, match="no saved tree 'a'"):
        lib.delete("a")
    with pytest.raises(ValueError, match=r"cannot read library tree '.*zz\.tree': no such file"):
        lib.load("zz")
    with pytest.raises(ValueError, match="name must be"):
        lib.save("../x")
    with pytest.raises(TypeError, match="SketchDocument"):
        LibraryPanel(tmp_path, plantvr.Model(seed=0))


def test_saved_tree_parameters_as_growth_or_rendering_presets(tmp_path):
    src = _grown(steps=2, n_max=5, deflection=20.0)
    src.set_params(branch_angle=70.0, leaf_size=1.2, tip_radius=0.05)
    lib = LibraryPanel(tmp_path, src)
    lib.save("willow")
    growth = preset_from_tree(lib.library, "willow", kind="growth")
    rendering = preset_from_tree(lib.library, "willow", kind="rendering")
    assert growth["branch_angle"] == 70.0 and "leaf_size" not in growth
    assert growth["n_max"] == 5 and "branching" not in growth
    assert set(rendering) == {k for k, p in PARAM_BY_NAME.items() if p.window == "appearance"}
    assert "n_max" not in rendering and rendering["leaf_size"] == 1.2

    doc = SketchDocument(seed=1)
    e = doc.engine
    lib2 = LibraryPanel(tmp_path, doc)
    lib2.use_tree_parameters("willow", kind="rendering")                 # appearance only
    assert e.params["leaf_size"] == 1.2 and e.params["branch_angle"] == 45.0 and e.sketch["n_max"] == 3
    lib2.trees.value, lib2.preset_kind.value = "willow", "growth"
    lib2.tree_preset_button.click()                                      # growth: parameters + options
    assert e.params["branch_angle"] == 70.0 and e.sketch["n_max"] == 5 and doc.deflection == 20.0
    m = plantvr.Model(seed=0)
    apply_preset_values(m, rendering)                                    # a Model takes the parameters
    assert m.tip_radius == 0.05
    apply_preset_values(m, growth)                                       # ... the Tree Wand rows only
    assert m.branch_angle == 70.0 and not hasattr(m, "n_max")


def test_presets_checked_before_writing(tmp_path):
    doc = SketchDocument(seed=1)
    e = doc.engine
    lib = LibraryPanel(tmp_path, doc)
    lib.apply_preset("weeping")
    assert e.sketch["n_max"] == 6 and doc.n_max == 6 and doc.tropism_angle == 160.0
    before = (dict(e.params), dict(e.sketch), doc.version)
    with pytest.raises(ValueError, match="deflection"):
        apply_preset_values(doc, {"branch_angle": 10.0, "deflection": 300.0})
    with pytest.raises(ValueError, match="branch_angle"):
        apply_preset_values(doc, {"branch_angle": 100.0, "n_max": 2})
    with pytest.raises(ValueError, match="preset must be"):
        apply_preset_values(doc, [1])
    with pytest.raises(ValueError, match="'params'"):
        apply_preset_values(doc, {"params": [1]})
    with pytest.raises(ValueError, match="branch_angle"):
        apply_preset_values(plantvr.Model(seed=0), {"branch_angle": 100.0, "n_max": 2})
    assert (dict(e.params), dict(e.sketch), doc.version) == before
    lib.save_preset("mine")
    assert "mine" in lib.presets.options


def test_tree_svg_draws_every_live_internode():
    t = _grown(steps=3).tree
    svg = tree_svg(t.pos[: t.n], t.parent[: t.n], alive=t.alive[: t.n], radius=t.radius[: t.n], size=120)
    assert svg.startswith("<svg") and svg.count("<line") == t.n_internodes
    with pytest.raises(ValueError, match="size"):
        tree_svg(t.pos[: t.n], t.parent[: t.n], size=4)


def test_failed_save_leaves_no_half_entry(tmp_path, monkeypatch):
    lib = LibraryPanel(tmp_path, _grown(steps=2))
    import os

    def failing(fd):  # saves are atomic (plantvr._fileio): the disk fills while the files are synced
        raise OSError("disk full")
    monkeypatch.setattr(os, "fsync", failing)
    with pytest.raises(ValueError, match="cannot save 'x'.*disk full"):
        lib.save("x")
    monkeypatch.undo()
    assert lib.library.trees() == [] and not list(tmp_path.glob("x.*"))


# -- issue 20: validated inputs, safe thumbnails ---------------------------------------------------------------------
def test_fuzz_tree_svg(fuzz):
    pos = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.0]])
    for kw, param in (({"parent": [-1, 0, 10 ** 9]}, "parent"), ({"parent": [-1, 0]}, "parent"),
                      ({"pos": [[0, np.nan, 0]] * 3}, "pos"), ({"alive": [True]}, "alive"),
                      ({"radius": [np.inf] * 3}, "radius"), ({"size": 10 ** 9}, "size")):
        args = {"pos": pos, "parent": [-1, 0, 1], **kw}
        assert isinstance(fuzz.call("tree_svg", tree_svg, args.pop("pos"), args.pop("parent"), **args, param=param),
                          ValueError)


def test_foreign_thumbnail_is_not_injected(tmp_path):
    lib = LibraryPanel(tmp_path, _grown(steps=2))
    lib.save("x")
    (tmp_path / "x.thumb.svg").write_text('<svg onload="alert(1)"><script>alert(1)</script></svg>')
    lib._show("x")
    assert "script" not in lib.thumb.value and "onload" not in lib.thumb.value
    lib.save("x")
    lib._show("x")
    assert lib.thumb.value.startswith("<svg")


def test_apply_preset_values_checks_everything_first(fuzz):
    doc = _grown(steps=2)
    e = doc.engine
    before = (dict(e.params), dict(e.sketch), doc.state_bytes(), doc.version)
    for preset in ({"base_length": 1e-20, "n_max": 4}, {"w_env": 0.3, "n_max": 0},
                   {"tropism_angle": float("nan")}, "preset", {"params": [1]}):
        assert isinstance(fuzz.call("apply_preset_values", apply_preset_values, doc, preset), ValueError)
    assert (e.params, e.sketch, doc.state_bytes(), doc.version) == before

"""Parameter windows generated from trait metadata, both-way sync, bad values, icon selectors, presets."""
import json

import ipywidgets as W
import pytest

import plantvr
from plantvr.document import Document
from plantvr.params import PARAM_BY_NAME, PARAMS, TREEWAND, WINDOWS, Param, ParamTable
from plantvr.ui import IconSelector, ParameterPanels, param_traits
from plantvr.ui.panels import HIGHLIGHT, INFLUENCE, push_param, show_value


@pytest.fixture
def model():
    return plantvr.Model(seed=0)


def test_controls_are_generated_from_trait_metadata(model):
    panels = ParameterPanels(model)
    expected = {p.name for p in PARAMS if p.window in ("form", "appearance", "light")} - set(INFLUENCE)
    assert set(panels.controls) == expected
    assert set(panels.windows) == {"form", "appearance", "light"}
    # the checklist item 27 count: 10 + 10 + 6 parameters (the triangle carries H, T, E)
    assert [len(param_traits(model, k)) for k in ("form", "appearance", "light")] == [12, 10, 6]
    for key, box in panels.windows.items():
        title, colour = WINDOWS[key]
        assert title in box.children[0].value and colour in box.children[0].value
        assert colour in box.layout.border
    assert [panels.tabs.get_title(i) for i in range(3)] == [WINDOWS[k][0] for k in ("form", "appearance", "light")]
    assert panels.triangle in panels.windows["form"].children[1].children


def test_slider_bounds_default_and_tooltip_from_table(model):
    panels = ParameterPanels(model, include_hidden=True)
    for p in PARAMS:
        if p.name in INFLUENCE:
            continue
        ctl = panels.controls[p.name]
        assert ctl.value == p.default
        assert p.doc in ctl.tooltip
        if isinstance(ctl, (W.FloatSlider, W.IntSlider)):
            lo, hi = p.range
            assert lo <= ctl.min and ctl.max <= hi
            assert not (p.low_open and ctl.min == lo) and not (p.high_open and ctl.max == hi)
        elif isinstance(ctl, W.FloatLogSlider):
            assert p.log and p.range[0] <= 10 ** ctl.min < 10 ** ctl.max <= p.range[1]


def test_sync_both_ways(model):
    panels = ParameterPanels(model)
    panels.controls["apical_dominance"].value = 0.7
    assert model.apical_dominance == pytest.approx(0.7)
    model.tropism_angle = 90.0
    assert panels.controls["tropism_angle"].value == 90.0
    leaf = PARAM_BY_NAME["leaf_texture"].choices[-1]
    panels.controls["leaf_texture"].value = leaf
    assert model.leaf_texture == leaf
    model.shadow_depth = 12
    assert panels.controls["shadow_depth"].value == 12


def test_slider_can_never_set_out_of_range_value(model):
    panels = ParameterPanels(model)
    s = panels.controls["shadow_falloff"]   # β in (0, 1): open both ends
    s.value = 5.0
    assert 0 < model.shadow_falloff < 1 and s.value == s.max
    s.value = -3.0
    assert 0 < model.shadow_falloff < 1 and s.value == s.min


def test_typed_value_out_of_range_rejected_with_message():
    from plantvr.documents.forest import ForestDocument

    doc = ForestDocument(n_trees=2, seed=3)
    panels = ParameterPanels(doc)
    box = panels.controls["seed"]  # a wide integer range without a slider span gets a typed box
    assert isinstance(box, W.IntText)
    box.value = -5
    assert doc.seed == 3
    assert "seed must be an integer in [0, 9223372036854775807], got -5" in panels.message.value
    assert box.value == 3  # the box shows the document's value again
    box.value = 70
    assert doc.seed == 70 and panels.message.value == ""


def test_icon_selector_yellow_highlight(model):
    panels = ParameterPanels(model)
    sel = panels.controls["bark_texture"]
    assert isinstance(sel, IconSelector)
    first, last = PARAM_BY_NAME["bark_texture"].choices[0], PARAM_BY_NAME["bark_texture"].choices[-1]
    assert sel.buttons[first].style.button_color == HIGHLIGHT
    sel.buttons[last].click()
    assert model.bark_texture == last
    assert HIGHLIGHT in sel.images[last].layout.border
    assert HIGHLIGHT not in sel.images[first].layout.border
    assert sel.images[last].value[:8] == b"\x89PNG\r\n\x1a\n"
    model.bark_texture = first  # model -> selector
    assert sel.value == first and HIGHLIGHT in sel.images[first].layout.border


def test_presets_round_trip(model, tmp_path):
    model.set_params(apical_dominance=0.62, leaf_texture=PARAM_BY_NAME["leaf_texture"].choices[-1], shadow_depth=9)
    path = model.save_preset(tmp_path / "oak.json")
    other = plantvr.Model(seed=1)
    other.load_preset(path)
    assert other.params == model.params


def test_preset_errors_are_clear_and_leave_model_unchanged(model, tmp_path):
    before = model.params
    with pytest.raises(ValueError, match="does not exist"):
        model.load_preset(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="is not valid JSON"):
        model.load_preset(bad)
    bad.write_text(json.dumps({"params": {}}))
    with pytest.raises(ValueError, match="is not a PlantVR preset"):
        model.load_preset(bad)
    bad.write_text(json.dumps({"plantvr_preset": 1, "params": {"apical_dominance": 0.3, "view_radius": -1}}))
    with pytest.raises(ValueError, match=r"bad.json: view_radius must be in \(0.0, 100.0\]"):
        model.load_preset(bad)
    bad.write_text(json.dumps({"plantvr_preset": 1, "params": {"nope": 1}}))
    with pytest.raises(ValueError, match="unknown parameter 'nope'"):
        TREEWAND.read_preset(bad)
    with pytest.raises(ValueError, match="preset path must end in .json"):
        model.save_preset(tmp_path / "x.txt")
    assert model.params == before


def test_panel_preset_buttons_report_errors(model, tmp_path):
    panels = ParameterPanels(model)
    panels.preset_path.value = str(tmp_path / "p.json")
    model.apical_dominance = 0.8
    panels.children[1].children[1].click()  # Save
    model.apical_dominance = 0.5
    panels.children[1].children[2].click()  # Load
    assert model.apical_dominance == 0.8 and panels.controls["apical_dominance"].value == 0.8
    panels.preset_path.value = str(tmp_path / "none.json")
    panels.children[1].children[2].click()
    assert "does not exist" in panels.message.value


class _Lamp(Document):
    """A document with a table of its own and no influence weights."""

    KIND = "lamp"
    COMMANDS = ("set_params",)
    PARAMS = ParamTable("lamp", (
        Param("power", float, 2.0, "Power.", "-", "light", unit="W", range=(0.0, 10.0)),
        Param("shade", str, "round", "Shade.", "-", "look", choices=("round", "square")),
        Param("glow", bool, False, "Glow.", "-", "look", range=(0, 1)),
        Param("secret", int, 3, "Not in a window.", "-", "hidden", range=(0, 9)),
    ), {"light": ("Light", "#2e6fd0"), "look": ("Look", "#c0392b"), "hidden": ("Settings", "#777777")})


def test_panels_are_generated_for_any_document(tmp_path):
    lamp = _Lamp()
    panels = ParameterPanels(lamp)
    assert set(panels.windows) == {"light", "look"} and set(panels.controls) == {"power", "shade", "glow"}
    assert panels.triangle is None and [panels.tabs.get_title(i) for i in range(2)] == ["Light", "Look"]
    assert isinstance(panels.controls["power"], W.FloatSlider) and panels.controls["power"].max == 10.0
    panels.controls["power"].value = 4.0
    assert lamp.power == 4.0 and lamp.log.events[-1].command == "set_params"
    lamp.shade = "square"
    assert panels.controls["shade"].value == "square"
    panels.save(tmp_path / "lamp.json")
    lamp.power = 1.0
    panels.load(tmp_path / "lamp.json")
    assert lamp.power == 4.0 and panels.controls["power"].value == 4.0
    assert "secret" in ParameterPanels(lamp, include_hidden=True).controls
    panels.close()
    with pytest.raises(ValueError, match="doc must be a document with a parameter table"):
        ParameterPanels(object())


def test_push_param_and_show_value_shared_by_the_panels(model):
    msg = W.HTML("old")
    assert push_param(model, "branch_angle", 40.0, msg) and msg.value == "" and model.branch_angle == 40.0
    assert not push_param(model, "branch_angle", 1e9, msg) and "branch_angle" in msg.value
    assert model.branch_angle == 40.0
    s = W.IntSlider(value=2, min=0, max=5)
    show_value(s, 9)
    assert (s.min, s.max, s.value) == (0, 9, 9)
    t = W.Text(value="a")
    show_value(t, "b")
    assert t.value == "b"

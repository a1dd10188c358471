"""Fuzzing the widgets' and the view's entry points: a result or a clear error, never a crash (issue 20)."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import plantvr
from plantvr.ui import ColorWheel, InfluenceTriangle
from plantvr.ui.triangle import barycentric, clamp_to_triangle, point_from_weights, sub_triangle_areas
from plantvr.ui.wheel import hex_to_rgb, rgb_to_hex, slice_at

BAD = [math.nan, math.inf, -math.inf, 1e300, -1e300, 1e19, 1e-20, -5, 0, 10**12, "x", None, [], [1, 2]]
number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**15, 10**15),
                   st.sampled_from(BAD))
fuzz_settings = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@fuzz_settings
@given(p=st.lists(number, min_size=0, max_size=4), w=st.lists(number, min_size=0, max_size=4))
def test_triangle_geometry(fuzz, p, w):
    for name, fn, arg, param in (("barycentric", barycentric, p, "p"),
                                 ("clamp_to_triangle", clamp_to_triangle, p, "p"),
                                 ("sub_triangle_areas", sub_triangle_areas, p, "p"),
                                 ("point_from_weights", point_from_weights, w, "weights")):
        out = fuzz.call(name, fn, arg, param=param)
        if not isinstance(out, Exception):
            assert np.all(np.isfinite(out)) or name == "barycentric", (name, arg, out)


@fuzz_settings
@given(x=number, y=number, n=number, last=number)
def test_wheel_helpers(fuzz, x, y, n, last):
    out = fuzz.call("slice_at", slice_at, x, y, n, last, param=("x", "y", "n_slices", "last"))
    if not isinstance(out, Exception):
        assert 0 <= out < n
    out = fuzz.call("rgb_to_hex", rgb_to_hex, [x, y, n], param="rgb")
    if not isinstance(out, Exception):
        assert hex_to_rgb(out) == tuple(int(round(float(v))) for v in (x, y, n))
    fuzz.call("hex_to_rgb", hex_to_rgb, str(x), param="color")


@pytest.fixture(scope="module")
def model():
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 6)], radius=1.5)
    m.step(3)
    return m


@fuzz_settings
@given(h=number, t=number, e=number)
def test_influence_triangle_keeps_the_model(fuzz, model, h, t, e):
    tri = InfluenceTriangle(model)
    try:
        before = model.influence
        fuzz.call("InfluenceTriangle.set_weights", tri.set_weights, h, t, e, param=("H", "T", "E"))
        w = model.influence
        assert all(math.isfinite(v) and v >= 0 for v in w) and math.isclose(sum(w), 1.0)
        if tri.error:  # rejected in the browser path: the model kept its weights, the widget snapped back
            assert w == before and tri.weights == list(before)
    finally:
        tri.close()


@fuzz_settings
@given(label=number, color=st.one_of(st.text(max_size=8), st.sampled_from(["#00ff00", "#GGGGGG", "#fff"])))
def test_color_wheel_commands(fuzz, label, color):
    wheel = ColorWheel(["#ff0000", "#00ff00", "#0000ff"])
    try:
        before = (list(wheel.colors), list(wheel.hidden), wheel.selected)
        if isinstance(fuzz.call("ColorWheel.select", wheel.select, label, param="label"), Exception):
            assert wheel.selected == before[2]
        if isinstance(fuzz.call("ColorWheel.set_color", wheel.set_color, label, color, param=("label", "color")),
                      Exception):
            assert list(wheel.colors) == before[0]
        if isinstance(fuzz.call("ColorWheel.toggle_hidden", wheel.toggle_hidden, label, param="label"), Exception):
            assert list(wheel.hidden) == before[1]
    finally:
        wheel.close()


@pytest.fixture(scope="module")
def view(model):
    v = plantvr.View(model, off_screen=True, window_size=(64, 64))
    yield v
    v.close()


@fuzz_settings
@given(c=st.lists(number, min_size=0, max_size=4), r=number, visible=st.sampled_from([True, False, "no", 1, None]))
def test_view_brush(fuzz, view, c, r, visible):
    before = (view.brush_center.copy(), view.brush_radius)
    out = fuzz.call("View.set_brush", view.set_brush, c, r, visible, param=("center", "radius", "visible"))
    if isinstance(out, Exception):
        assert np.array_equal(view.brush_center, before[0]) and view.brush_radius == before[1]
    else:
        assert np.all(np.isfinite(view.brush_center)) and 0 < view.brush_radius <= 1e6


@pytest.mark.parametrize("size", [(0, 10), (10**6, 10), (10,), "big", (12.5, 30), None])
def test_view_window_size(fuzz, model, size):
    assert isinstance(fuzz.call("View", plantvr.View, model, off_screen=True, window_size=size,
                                param="window_size"), ValueError)


def test_view_needs_a_document(fuzz):
    assert isinstance(fuzz.call("View", plantvr.View, object(), param="doc"), TypeError)


def test_screenshot_is_atomic_and_png_only(fuzz, view, tmp_path, monkeypatch):
    p = tmp_path / "v.png"
    view.screenshot(p)
    before = p.read_bytes()
    assert before[:4] == b"\x89PNG"
    assert isinstance(fuzz.call("View.screenshot", view.screenshot, tmp_path / "v.jpg", param="path"), ValueError)
    from PIL import Image

    def boom(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(Image.Image, "save", boom)
    with pytest.raises(OSError, match="No space"):
        view.screenshot(p)
    assert p.read_bytes() == before and sorted(x.name for x in tmp_path.iterdir()) == ["v.png"]

"""Fuzzing sweeps, thumbnails and the growth control: clear errors before any task runs (issue 20)."""
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import plantvr
from plantvr.ui import GrowthControl
from plantvr.documents.sweep import MAX_POINTS, grow_variant, sweep
from plantvr.view.thumbnails import thumbnail, thumbnail_grid

BAD = [math.nan, math.inf, -1, 1e300, 10**12, -(10**19), "x", None, 0.5]
fuzz_settings = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@fuzz_settings
@given(seed=st.sampled_from(BAD), value=st.sampled_from(BAD + [[], {}, "fast"]))
def test_sweep_rejects_bad_input_before_growing(fuzz, seed, value):
    fuzz.call("sweep", sweep, "fig12_1", {"apical_dominance": [value]}, seed=seed,
              param=("seed", "apical_dominance", "grid"))
    fuzz.call("grow_variant", grow_variant, "fig12_1", {"apical_dominance": value}, seed=seed,
              param=("seed", "apical_dominance"))


@pytest.mark.parametrize("grid, match", [
    ({}, "grid"), ([1], "grid"), ({"nope": [1]}, "grid parameter"), ({"apical_dominance": []}, "grid"),
    ({"apical_dominance": "0.5"}, "grid"),
    ({"apical_dominance": [0.5] * 1000, "tropism_angle": [0.0] * 1000}, f"at most {MAX_POINTS}"),
])
def test_sweep_grid(fuzz, grid, match):
    exc = fuzz.call("sweep", sweep, "fig12_1", grid, param="grid")
    assert isinstance(exc, ValueError) and match in str(exc)


@pytest.mark.parametrize("size", [(0, 10), (10**6, 10), (10,), "big", None, (math.nan, 30)])
def test_thumbnail_size(fuzz, size):
    assert isinstance(fuzz.call("thumbnail", thumbnail, b"PK\x03\x04", size=size, param="size"), ValueError)
    assert isinstance(fuzz.call("thumbnail_grid", thumbnail_grid, None, "a", "b", size=size, param="size"),
                      ValueError)


@pytest.mark.parametrize("state", [b"", "text", b"not a zip", b"PK\x03\x04" + b"\0" * 40, None])
def test_thumbnail_state(fuzz, state):
    assert isinstance(fuzz.call("thumbnail", thumbnail, state, param=("state", "tree")), ValueError)


@pytest.mark.parametrize("kw, param", [({"max_points": 0}, "max_points"), ({"max_points": "x"}, "max_points"),
                                       ({"max_points": 10**9}, "max_points"),
                                       ({"steps_per_second": math.nan}, "steps_per_second"),
                                       ({"steps_per_second": 0}, "steps_per_second")])
def test_growth_control_options(fuzz, kw, param):
    assert isinstance(fuzz.call("GrowthControl", GrowthControl, plantvr.Model(seed=0), param=param, **kw),
                      ValueError)


def test_growth_control_needs_a_model(fuzz):
    assert isinstance(fuzz.call("GrowthControl", GrowthControl, object(), param="model"), TypeError)


@pytest.mark.parametrize("n", [-1, 1e300, "x", None, 10**12])
def test_growth_control_step(fuzz, n):
    m = plantvr.Model(seed=0)
    gc = GrowthControl(m)
    try:
        assert isinstance(fuzz.call("GrowthControl.step", gc.step, n, param="steps"), ValueError)
        assert m.steps_done == 0
    finally:
        gc.close()

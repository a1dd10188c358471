"""Tests for spec 002 §4.3: dynamic phyllotaxis with fractionation and segregation (V28–V31)."""
import itertools

import numpy as np
import pytest

from plantvr.flowers import (
    GOLDEN_ANGLE_DEG,
    centripetal_fractionation,
    cone_receptacle,
    disc_receptacle,
    dome_receptacle,
    parastichy_numbers,
)
from plantvr.flowers.dynamic import FRONT_IN, FRONT_OUT, DynamicPhyllotaxis
from plantvr.flowers.phyllotaxis import _band_integral


def _growing(mode):
    """One growing meristem per mode: region growth, primordium growth and two key profiles."""
    if mode == "centripetal":
        return DynamicPhyllotaxis([(0.0, disc_receptacle()), (30.0, dome_receptacle(1.0, 0.6))],
                                  mode="centripetal", inner_area=2.0,
                                  inner_rate=lambda t: 0.02 * np.exp(-0.05 * t),
                                  primordium_area=lambda a: 0.02 * (1 + 0.05 * a), dt_prod=0.5)
    if mode == "divergent":
        return DynamicPhyllotaxis(cone_receptacle(1.0, 0.4), mode="divergent", inner_area=1.0, outer_area=0.6,
                                  inner_rate=0.01, outer_rate=lambda t: 0.03 * (1 + t / 10),
                                  primordium_area=lambda a: 0.015 * np.exp(0.02 * a), dt_prod=0.7)
    return DynamicPhyllotaxis([(0.0, dome_receptacle(1.0, 0.2)), (40.0, dome_receptacle(1.0, 1.0))],
                              mode="segregation", inner_area=0.03, inner_rate=lambda t: 0.01 * (1 + 0.1 * t),
                              primordium_area=lambda a: 0.02 * (1 + 0.2 * a), threshold=0.04)


def _band_areas(fr):
    """Area between the apex and each primordium's s on the frame's scaled receptacle."""
    s, g, F = _band_integral(fr.receptacle, 1.0, 1)
    j = np.clip(np.searchsorted(s, fr.s, side="right") - 1, 0, s.size - 2)
    x = fr.s - s[j]
    return F[j] + g[j] * x + 0.5 * (g[j + 1] - g[j]) / (s[j + 1] - s[j]) * x * x     # exact: g linear in s


@pytest.mark.parametrize("mode", ["centripetal", "divergent", "segregation"])
def test_v30_area_bookkeeping(mode):
    dyn = _growing(mode)
    frames = dyn.run(60, 0.5)
    assert frames[-1].n >= 20
    for fr in frames:
        total = fr.inner_area + fr.area.sum() + fr.outer_area
        assert abs(fr.receptacle.area - total) <= 1e-9 * total
        assert fr.inner_area >= 0 and fr.outer_area >= 0
    # the layout is Eq. 5.1 on the scaled surface: bands between consecutive same-front primordia have the
    # area of the primordia they hold, and the inner region sits between the apex and the inner front
    fr = frames[-1]
    a_s = _band_areas(fr)
    inner = np.flatnonzero(fr.front == FRONT_IN)
    youngest_first = inner[::-1]
    expect = fr.inner_area + np.cumsum(fr.area[youngest_first])
    assert np.allclose(a_s[youngest_first], expect, rtol=1e-9, atol=1e-12 * fr.total_area)


def test_v30_surface_grows_with_regions_and_keeps_angles():
    dyn = _growing("segregation")
    frames = dyn.run(40, 0.5)
    assert all(b.receptacle.area > a.receptacle.area for a, b in itertools.pairwise(frames))
    a_first = frames[10].alpha
    assert np.array_equal(frames[-1].alpha[:a_first.size], a_first)          # no popping: angles kept


def test_v31_segregation_period():
    g, a_new = 0.013, 0.05
    dyn = DynamicPhyllotaxis(dome_receptacle(1.0, 0.5), mode="segregation", inner_area=0.01, inner_rate=g,
                             primordium_area=lambda a: a_new * (1 + 0.3 * a), threshold=0.07)
    fr = dyn.run(300, 0.37)[-1]                    # step length unrelated to the period
    period = np.diff(fr.birth)
    assert fr.n > 20
    assert np.allclose(period[-10:], a_new / g, rtol=1e-9)
    # the first production happens when the inner area first exceeds the threshold
    assert fr.birth[0] == pytest.approx((0.07 - 0.01) / g, rel=1e-9)


def test_v31_period_follows_growth_rate():
    for g in (0.005, 0.02):
        dyn = DynamicPhyllotaxis(mode="segregation", inner_area=0.01, inner_rate=g, primordium_area=0.04)
        fr = dyn.run(200, 0.5)[-1]
        assert np.mean(np.diff(fr.birth)[-5:]) == pytest.approx(0.04 / g, rel=1e-9)


def test_v29_dynamic_centripetal_fractionation_matches_static():
    A = 0.05
    fr = DynamicPhyllotaxis(mode="centripetal", inner_area=np.pi, primordium_area=A).run(100, 1.0)[-1]
    assert abs(fr.n - np.floor(np.pi / A)) <= 1                               # V29
    assert 0 <= fr.inner_area < A                                  # stops only below one primordium
    assert fr.receptacle.r[-1] == pytest.approx(1.0, rel=1e-12)              # no growth: disc of radius 1
    s_static, a_static, _ = centripetal_fractionation(disc_receptacle(1.0), area=A)
    assert np.max(np.abs(fr.s - s_static[:fr.n])) <= 1e-12
    assert np.allclose(fr.alpha, a_static[:fr.n], atol=1e-12)
    assert np.all(np.diff(fr.birth) == 1.0) and np.all(np.diff(fr.s) < 0)   # outer = older (phase effect)


def test_v28_divergence_per_front():
    fr = _growing("divergent").run(40, 0.5)[-1]
    for f in (FRONT_IN, FRONT_OUT):
        a = fr.alpha[fr.front == f]
        assert a.size > 5
        assert np.allclose(np.rad2deg(np.diff(a)) % 360.0, GOLDEN_ANGLE_DEG, atol=1e-9)


def test_divergent_fronts_move_apart_from_the_boundary():
    fr = _growing("divergent").run(40, 0.5)[-1]
    sin, sout = fr.s[fr.front == FRONT_IN], fr.s[fr.front == FRONT_OUT]
    assert np.all(np.diff(sin) <= 1e-12) and np.all(np.diff(sout) >= -1e-12)   # inward and outward
    assert sin.max() <= sout.min() + 1e-12
    # the outer region stays outside every primordium
    assert _band_areas(fr).max() <= fr.total_area - fr.outer_area + 1e-9


def test_placement_fields_are_a_frame():
    fr = _growing("centripetal").run(30, 0.5)[-1]
    assert np.allclose(np.linalg.norm(fr.up, axis=1), 1.0)
    assert np.allclose(np.einsum("ij,ij->i", fr.up, fr.right), 0.0, atol=1e-12)
    assert np.all(fr.age >= 0)


def test_centre_anchor_sits_mid_band():
    dyn = DynamicPhyllotaxis(mode="centripetal", inner_area=1.0, primordium_area=0.1, anchor="centre")
    fr = dyn.run(5, 1)[-1]
    a_s = _band_areas(fr)
    assert np.allclose(a_s, 1.0 - 0.1 * (np.arange(fr.n) + 0.5), atol=1e-12)


@pytest.mark.parametrize("kwargs, match", [
    ({"mode": "spiral"}, "mode must be one of"),
    ({"inner_area": 0.0}, "inner_area must be in"),
    ({"mode": "divergent"}, "outer region"),
    ({"profiles": [(1.0, disc_receptacle()), (0.0, disc_receptacle())]}, "strictly increasing"),
    ({"profiles": [(0.0, "disc")]}, r"profiles\[0\]"),
])
def test_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        DynamicPhyllotaxis(**kwargs)


def test_rejected_step_leaves_the_meristem_unchanged():
    dyn = DynamicPhyllotaxis(mode="segregation", inner_area=0.01, inner_rate=lambda t: -1.0)
    before = dyn.frame
    with pytest.raises(ValueError, match="inner_rate"):
        dyn.step(1.0)
    with pytest.raises(ValueError, match="dt must be in"):
        dyn.step(-1.0)
    assert dyn.frame is before and dyn.t == 0.0
    dyn = DynamicPhyllotaxis(mode="segregation", inner_area=0.01, inner_rate=0.01, threshold=0.02,
                             primordium_area=lambda a: 0.01 * (2.0 - a))          # negative after age 2
    dyn.run(2, 1.0)
    assert dyn.n == 1
    state = (dyn.t, dyn.n, dyn.inner_area, dyn.frame)
    with pytest.raises(ValueError, match="primordium_area"):
        dyn.run(5, 1.0)
    assert (dyn.t, dyn.n, dyn.inner_area, dyn.frame) == state                # a failed step changes nothing


FIB = {1, 2, 3, 5, 8, 13, 21, 34, 55, 89, 144}


@pytest.mark.parametrize("mode", ["centripetal", "segregation", "divergent"])
def test_dynamic_patterns_have_fibonacci_parastichies(mode):
    if mode == "segregation":
        dyn = DynamicPhyllotaxis(dome_receptacle(1.0, 0.5), mode="segregation", inner_area=0.02,
                                 inner_rate=0.02, threshold=0.03,
                                 primordium_area=lambda a: 0.01 * np.exp(0.002 * a))
        fr = dyn.run(300, 1.0)[-1]
    elif mode == "centripetal":
        dyn = DynamicPhyllotaxis(mode="centripetal", inner_area=np.pi, inner_rate=0.002, dt_prod=0.5,
                                 primordium_area=lambda a: 0.005 * (1 + 0.01 * a))
        fr = dyn.run(300, 1.0)[-1]
    else:
        dyn = DynamicPhyllotaxis(mode="divergent", inner_area=1.5, outer_area=1.5, primordium_area=0.005)
        fr = dyn.run(400, 1.0)[-1]
    checked = 0
    for f in (FRONT_IN, FRONT_OUT):
        idx = np.flatnonzero(fr.front == f)
        if idx.size < 250:
            continue
        par = parastichy_numbers(fr.position[idx], select=np.arange(100, 250))
        assert set(par) <= FIB and par[1] > par[0] >= 13
        checked += 1
    assert checked == (2 if mode == "divergent" else 1)


def test_used_up_meristem_stops_growing():
    dyn = DynamicPhyllotaxis(mode="segregation", inner_area=0.01, inner_rate=0.01, primordium_area=0.02,
                             threshold=0.03, max_primordia=5)
    frames = dyn.run(40, 1.0)
    assert frames[-1].n == 5
    full = next(k for k, f in enumerate(frames) if f.n == 5)
    assert frames[-1].inner_area == frames[full + 1].inner_area <= 0.03    # no naked disc growing forever
    assert frames[-1].total_area == pytest.approx(frames[full + 1].total_area)

"""Influence triangle: barycentric helpers (TW-V11) and two-way sync with the model."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import plantvr
from plantvr.ui import (InfluenceTriangle, barycentric, clamp_to_triangle, point_from_weights,
                        sub_triangle_areas)
from plantvr.ui.triangle import CORNERS

coord = st.floats(-2.0, 2.0, allow_nan=False)


def test_tw_v11_corners_give_pure_weights():
    np.testing.assert_allclose(barycentric(CORNERS), np.eye(3), atol=1e-12)
    for i in range(3):
        np.testing.assert_allclose(point_from_weights(np.eye(3)[i]), CORNERS[i], atol=1e-12)


def test_tw_v11_centre_is_equal_weights():
    np.testing.assert_allclose(barycentric(CORNERS.mean(0)), [1 / 3] * 3, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3).filter(lambda w: sum(w) > 1e-6))
def test_tw_v11_round_trip_and_sub_areas(w):
    w = np.array(w) / sum(w)
    p = point_from_weights(w)
    np.testing.assert_allclose(barycentric(p), w, atol=1e-9)
    areas = sub_triangle_areas(p)
    (ax, ay), (bx, by) = CORNERS[1] - CORNERS[0], CORNERS[2] - CORNERS[0]
    total = 0.5 * abs(ax * by - ay * bx)
    np.testing.assert_allclose(areas / total, w, atol=1e-9)
    assert barycentric(p).sum() == pytest.approx(1.0)


@settings(max_examples=200, deadline=None)
@given(coord, coord)
def test_tw_v11_clamping_outside_is_nearest_point_on_triangle(x, y):
    p = np.array([x, y])
    q = clamp_to_triangle(p)
    w = barycentric(q)
    assert np.all(w >= -1e-9)
    if np.all(barycentric(p) >= 0):
        np.testing.assert_array_equal(q, p)
    else:  # no point of a dense sample of the triangle is nearer than q
        g = np.linspace(0, 1, 41)
        a, b = np.meshgrid(g, g)
        keep = a + b <= 1
        samples = point_from_weights(np.column_stack([a[keep], b[keep], np.clip(1 - a[keep] - b[keep], 0, 1)]))
        assert np.linalg.norm(q - p) <= np.linalg.norm(samples - p, axis=1).min() + 1e-9


def test_helpers_reject_bad_input():
    with pytest.raises(ValueError, match="p must have shape"):
        barycentric([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="weights must be >= 0"):
        point_from_weights([-1, 1, 1])
    with pytest.raises(ValueError, match="weights must not all be 0"):
        point_from_weights([0, 0, 0])
    with pytest.raises(ValueError, match="non-zero area"):
        barycentric([0, 0], corners=[[0, 0], [1, 1], [2, 2]])


def test_widget_two_way_sync_with_model():
    m = plantvr.Model(seed=0)
    tri = InfluenceTriangle(m)
    assert tri.weights == pytest.approx(list(m.influence))
    tri.weights = [2.0, 1.0, 1.0]  # what the browser sends; the model normalises
    assert m.influence == pytest.approx((0.5, 0.25, 0.25))
    assert tri.weights == pytest.approx([0.5, 0.25, 0.25])
    m.set_influence(0.0, 0.0, 1.0)
    assert tri.weights == pytest.approx([0.0, 0.0, 1.0])
    np.testing.assert_allclose(tri.point, CORNERS[2], atol=1e-12)
    m.w_tropism = 0.3  # a single trait set from code is mirrored too
    assert tri.weights[1] == pytest.approx(0.3)


def test_widget_bad_weights_rejected_with_message_model_unchanged():
    m = plantvr.Model(seed=0)
    tri = InfluenceTriangle(m)
    before = m.influence
    tri.weights = [-1.0, 1.0, 1.0]
    assert m.influence == before
    assert "H must be in" in tri.error
    assert tri.weights == pytest.approx(list(before))
    tri.weights = [0.0, 0.0, 0.0]
    assert "must not all be 0" in tri.error and m.influence == before


def test_widget_has_no_state_beyond_synced_traits():
    tri = InfluenceTriangle()
    synced = set(tri.keys)
    assert {"weights", "corners", "colors", "labels", "error"} <= synced
    tri.set_weights(1, 0, 0)
    assert tri.weights == [1, 0, 0]
    tri.close()

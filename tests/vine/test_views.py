"""Saved views (spec §2.3, V10) and model-space transforms."""
import numpy as np
import pytest

from plantvr.vine.views import (
    SavedView,
    load_view,
    quat_from_axis_angle,
    quat_to_matrix,
    save_view,
    world_to_model,
)


def _head_dir(yaw, pitch, rng):
    # forward -z rotated by yaw about +y, then pitched; roll does not change the forward vector
    f = np.array([np.sin(yaw) * np.cos(pitch), np.sin(pitch), -np.cos(yaw) * np.cos(pitch)])
    return f


def _yaw_frame(V, d):
    h = np.array([d[0], 0, d[2]]) / np.linalg.norm([d[0], d[2]])
    right = np.cross(h, [0, 1, 0])
    return V, np.stack([right, [0, 1, 0], -h])                 # rows: x right, y up, z back


def test_tw_v10_view_is_invariant_to_head_pitch_and_relative_to_yaw():
    rng = np.random.default_rng(0)
    P = np.array([0.3, 1.2, -1.5])
    Rm = quat_to_matrix(quat_from_axis_angle([0.2, 1, 0.4], 0.9))
    V1, d1 = np.array([0.1, 1.7, 0.2]), _head_dir(0.4, 0.5, rng)
    view = save_view(P, Rm, 1.8, viewer_position=V1, view_dir=d1)
    V2, d2 = np.array([-2.0, 1.5, 3.0]), _head_dir(-1.9, -0.6, rng)
    P2, R2, s2 = load_view(view, viewer_position=V2, view_dir=d2)
    o1, F1 = _yaw_frame(V1, d1)
    o2, F2 = _yaw_frame(V2, d2)
    assert np.allclose(F1 @ (P - o1), F2 @ (P2 - o2))           # same placement in each yaw-only frame
    assert np.allclose(F1 @ Rm, F2 @ R2)
    assert s2 == 1.8
    # the corrected R_view maps the horizontal facing to -z (ERRATUM A.7)
    assert np.allclose(view.position, save_view(P, Rm, 1.8, viewer_position=V1,
                                                view_dir=d1 * [1, 0, 1]).position)


def test_view_array_round_trip_and_validation():
    v = save_view([1, 2, 3], [1, 0, 0, 0], 2.0, viewer_position=[0, 0, 0], view_dir=[0, 0, -1])
    assert np.allclose(v.position, [1, 2, 3])            # facing -z already: identity frame
    w = SavedView.from_array(v.to_array())
    assert np.array_equal(w.to_array(), v.to_array())
    with pytest.raises(ValueError, match="vertical"):
        save_view([0, 0, 0], [1, 0, 0, 0], 1.0, viewer_position=[0, 0, 0], view_dir=[0, 1, 0])
    with pytest.raises(ValueError, match="model_scale"):
        save_view([0, 0, 0], [1, 0, 0, 0], 0.0, viewer_position=[0, 0, 0], view_dir=[0, 0, 1])
    with pytest.raises(ValueError, match="orthonormal"):
        SavedView.from_array(np.r_[0, 0, 0, np.ones(9), 1.0])


def test_world_to_model_inverts_model_transform():
    q = quat_from_axis_angle([0, 1, 1], 1.1)
    P, s = np.array([1.0, 2.0, 3.0]), 0.5
    x = np.array([4.0, -1.0, 2.0])
    w = P + s * quat_to_matrix(q) @ x
    c, r = world_to_model(w, 1.0, position=P, rotation=q, scale=s)
    assert np.allclose(c, x) and r == 2.0
    with pytest.raises(ValueError, match="rotation"):
        world_to_model(w, 1.0, position=P, rotation=[0, 0, 0, 0], scale=s)

"""Neighbourhood asymmetry (V23) and the fading landscape tropism (V24), spec 004 §3.6."""
import numpy as np
import pytest

from plantvr.landscape.asymmetry import cell_geometry, landscape_tropism, neighbour_asymmetry


def test_ts_v23_symmetric_ring_cancels_single_neighbour_pushes_away():
    ang = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    ring = np.vstack([[0.0, 0.0], 3.0 * np.column_stack([np.cos(ang), np.sin(ang)])])
    V = neighbour_asymmetry(ring, np.ones(7), 5.0)
    assert np.linalg.norm(V[0]) < 1e-12
    V = neighbour_asymmetry(np.array([[0.0, 0.0], [2.0, 0.0]]), np.ones(2), 4.0)
    assert V[0, 0] < 0 and abs(V[0, 1]) < 1e-15 and V[1, 0] > 0  # away from the neighbour
    np.testing.assert_allclose(-V[0, 0], 1.0 * 1 + 2.0 * (1 - 2 / 4))  # Eq. 6.3 weight


def test_ts_v23_size_weight_and_centroid_ratio():
    T = np.array([[0.0, 0.0], [2.0, 0.0]])
    a = neighbour_asymmetry(T, np.array([1.0, 1.0]), 4.0)
    b = neighbour_asymmetry(T, np.array([1.0, 2.0]), 4.0)  # doubling A_j adds alpha_a A_j / A_i
    np.testing.assert_allclose(np.linalg.norm(b[0]) - np.linalg.norm(a[0]), 1.0 * 1.0 / 1.0)
    c = neighbour_asymmetry(T, np.ones(2), 4.0, centroids=T.copy(), bounding=np.ones(2))
    np.testing.assert_array_equal(c, 0.0)  # a tree at its region centroid does not lean
    C, B = cell_geometry(T + 5.0, (12.0, 10.0))
    assert C[0, 0] < 6.0 < C[1, 0] and np.all(B > 0)
    with pytest.raises(ValueError, match="areas"):
        neighbour_asymmetry(T, np.array([1.0, 0.0]), 4.0)


def test_ts_v24_fade():
    V, S = np.array([1.0, 0.0, 0.0]), np.array([[0.0, 1.0, 0.0]])
    np.testing.assert_allclose(landscape_tropism(V, S, 0.0, 10.0), V + S)
    np.testing.assert_allclose(landscape_tropism(V, S, 10.0, 10.0), S)
    xs = [landscape_tropism(V, S, h, 10.0)[0, 0] for h in np.linspace(0, 10, 11)]
    assert np.all(np.diff(xs) < 0)  # monotone fade

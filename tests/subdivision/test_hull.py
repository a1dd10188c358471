"""Spec 001 §2.4.3 / C7: the batched numba incremental hull (Alg. 3) against its Qhull twin; V6 up to k = 200."""
import numpy as np
import pytest

from plantvr.subdivision import build_control_mesh, graph_from_arrays
from plantvr.subdivision.graph import random_tree
from plantvr.subdivision.hull import joint_hulls

from ._helpers import star_graph


def _canon(F):
    r = np.argmin(F, axis=1)
    F = np.stack([np.take_along_axis(F, ((r + i) % 3)[:, None], 1)[:, 0] for i in range(3)], 1)
    return np.unique(F, axis=0)


def test_incremental_equals_qhull_on_random_sphere_sets():
    rng = np.random.default_rng(0)
    sizes = rng.integers(4, 60, 40)
    ptr = np.r_[0, np.cumsum(sizes)]
    P = rng.normal(size=(ptr[-1], 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    P = P * np.repeat(rng.uniform(0.5, 3, len(sizes)), sizes)[:, None] + np.repeat(rng.normal(size=(len(sizes), 3)) * 10, sizes, 0)
    F1, n1, v1 = joint_hulls(P, ptr)
    F2, n2, v2 = joint_hulls(P, ptr, method="qhull")
    np.testing.assert_array_equal(n1, 2 * sizes - 4)
    np.testing.assert_array_equal(v1, sizes)
    np.testing.assert_array_equal(n1, n2)
    np.testing.assert_array_equal(v1, v2)
    np.testing.assert_array_equal(_canon(F1), _canon(F2))          # same oriented triangles
    # outward: every face normal points away from its joint's centroid
    j = np.repeat(np.arange(len(sizes)), n1)
    c = np.add.reduceat(P, ptr[:-1], axis=0) / sizes[:, None]
    a, b, cc = P[F1[:, 0]], P[F1[:, 1]], P[F1[:, 2]]
    assert np.all(np.einsum("ij,ij->i", np.cross(b - a, cc - a), a - c[j]) > 0)


def test_interior_points_are_not_hull_vertices_and_flat_sets_fail():
    rng = np.random.default_rng(1)
    P = np.vstack([rng.normal(size=(20, 3)), np.zeros((1, 3))])
    P[:20] /= np.linalg.norm(P[:20], axis=1, keepdims=True)
    F, nf, nv = joint_hulls(P, np.array([0, 21]))
    assert nv[0] == 20 and 20 not in F
    flat = np.c_[rng.normal(size=(10, 2)), np.zeros(10)]
    F, nf, nv = joint_hulls(flat, np.array([0, 10]))
    assert nf[0] == 0 and nv[0] == 0
    with pytest.raises(ValueError, match="method must be one of"):
        joint_hulls(P, np.array([0, 21]), method="gift")


@pytest.mark.filterwarnings("ignore:.*overlapping loop caps")     # thin children crowd the trunk's cap at k >= 50
@pytest.mark.parametrize("k", [2, 3, 10, 50, 200])
def test_v6_hull_counts_to_degree_200(k):
    cm = build_control_mesh(star_graph(k, radius=0.004), compensate_radius=False)
    assert cm.hull_faces.tolist() == [8 * k - 4] and cm.joint_faces.tolist() == [6 * k - 4]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_control_mesh_same_with_either_hull(seed):
    g = graph_from_arrays(*random_tree(400, rng=seed))
    a = build_control_mesh(g)
    b = build_control_mesh(g, hull="qhull")
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.hull_faces, b.hull_faces)
    np.testing.assert_array_equal(_canon(a.faces), _canon(b.faces))

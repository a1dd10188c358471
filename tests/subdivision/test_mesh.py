"""Spec 001 §2.3–§2.4: tubes, convex-hull joints, one manifold control mesh (V6, V8–V12)."""
import time
import warnings

import numpy as np
import pytest
import trimesh

from plantvr.subdivision import BranchGraph, build_control_mesh, graph_from_arrays, parse_lsystem
from plantvr.subdivision.graph import random_tree

from ._helpers import SAMPLE_LST, mesh_invariants, star_graph


def test_v9_single_tube_counts_and_valence():
    g = BranchGraph(np.zeros((1, 3)), np.array([[0, 10.0, 0]]), np.ones(1), np.ones(1), np.array([-1]))
    cm = build_control_mesh(g, compensate_radius=False)
    N = cm.n_segments[0]
    assert N == 3                                            # round(10 / pi) (spec V9)
    assert len(cm.vertices) == 4 * (N + 1) and len(cm.faces) == 8 * N
    val = np.bincount(trimesh.Trimesh(cm.vertices, cm.faces, process=False).edges_unique.ravel())
    inner = np.arange(4, 4 * N)
    assert np.all(val[inner] == 6)
    # loops planar, orthogonal to the axis, equidistant from it
    for loop in np.arange(4 * (N + 1)).reshape(-1, 4):
        p = cm.vertices[loop]
        assert np.ptp(p[:, 1]) < 1e-12
        np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 2]), 1.0)
    g5 = BranchGraph(np.zeros((1, 3)), np.array([[0, 5.0, 0]]), np.ones(1), np.ones(1), np.array([-1]))
    assert build_control_mesh(g5, compensate_radius=False).n_segments[0] == 2


@pytest.mark.parametrize("k", [2, 3, 4, 5, 6, 8, 12, 20])
def test_v6_v8_hull_and_joint_face_counts(k):
    cm = build_control_mesh(star_graph(k), compensate_radius=False)
    assert cm.joint_sizes.tolist() == [k]
    assert cm.hull_faces.tolist() == [8 * k - 4]             # V6
    assert cm.joint_faces.tolist() == [6 * k - 4]            # V8
    inv = mesh_invariants(cm.vertices, cm.faces)
    assert inv["max_edge_faces"] == 2 and inv["duplicate_directed"] == 0
    assert inv["euler"] == 2 - k                               # one open loop per branch end


@pytest.mark.parametrize("sides", [3, 4, 6, 8])
def test_hull_counts_for_any_sides(sides):
    k = 4
    cm = build_control_mesh(star_graph(k), sides=sides, compensate_radius=False)
    assert cm.hull_faces.tolist() == [2 * k * sides - 4]
    assert cm.joint_faces.tolist() == [k * sides + 2 * k - 4]
    m = cm.to_trimesh()
    assert m.is_winding_consistent
    assert cm.first_loop.shape[1] == sides


def _check_tree(cm, S=4):
    V, F = cm.vertices, cm.faces
    inv = mesh_invariants(V, F)
    b = cm.n_boundary_loops
    assert inv["max_edge_faces"] == 2, "non-manifold edge"
    assert inv["duplicate_directed"] == 0, "inconsistent winding"
    assert inv["degenerate"] == 0 and inv["unused_vertices"] == 0
    assert inv["boundary_edges"] == S * b                    # V11: 1 + #leaves loops of S edges
    assert inv["euler"] == 2 - b
    N = cm.n_segments                                        # V12
    assert len(V) == S * (N + 1).sum()
    k = cm.joint_sizes
    assert len(F) == 2 * S * N.sum() + (k * S + 2 * k - 4).sum()


def test_v10_v12_sample_lst():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        g = parse_lsystem(SAMPLE_LST, angle_unit="radians")
    cm = build_control_mesh(g, compensate_radius=False)
    _check_tree(cm)
    assert cm.n_boundary_loops == 1 + 3
    m = cm.to_trimesh()
    assert m.is_winding_consistent
    capped = build_control_mesh(g, compensate_radius=False, cap=True).to_trimesh()
    assert capped.is_watertight and capped.is_winding_consistent and capped.euler_number == 2
    assert capped.volume > 0                                  # outward orientation


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("sides", [4, 6])
def test_random_trees_watertight_manifold(seed, sides):
    pos, par, rad = random_tree(200, rng=seed)
    cm = build_control_mesh(graph_from_arrays(pos, par, rad), sides=sides)
    _check_tree(cm, sides)
    capped = build_control_mesh(graph_from_arrays(pos, par, rad), sides=sides, cap=True).to_trimesh()
    assert capped.is_watertight and capped.is_winding_consistent
    assert capped.euler_number == 2 and capped.volume > 0


def test_forked_root_node_closes_base():
    pos = np.array([[0, 0, 0], [1, 1, 0], [-1, 1, 0], [0, 1, 1.5]])
    g = graph_from_arrays(pos, [-1, 0, 0, 0], [0.1, 0.1, 0.1, 0.1])
    cm = build_control_mesh(g)
    assert cm.joint_sizes.tolist() == [3] and cm.n_boundary_loops == 3
    _check_tree(cm)


def test_10k_branch_tree_fast_and_manifold():
    pos, par, rad = random_tree(10_001, rng=7)
    g = graph_from_arrays(pos, par, rad)
    t = time.perf_counter()
    cm = build_control_mesh(g)
    dt = time.perf_counter() - t
    assert len(cm.graph) > 9000
    _check_tree(cm)
    assert dt < 30.0      # ~0.3 s (numba hulls) on the 2-core box; timing proper lives in benchmarks/subdivision.py


def test_bad_mesh_parameters():
    g = star_graph(3)
    with pytest.raises(ValueError, match=r"sides must be an integer in \[3, 64\], got 2"):
        build_control_mesh(g, sides=2)
    with pytest.raises(ValueError, match="rounding must be one of"):
        build_control_mesh(g, rounding="up")
    with pytest.raises(ValueError, match="min_offset must be in"):
        build_control_mesh(g, min_offset=-1)
    with pytest.raises(ValueError, match="graph must be a BranchGraph"):
        build_control_mesh("F")


def test_v7_overlapping_caps_fail_loudly():
    J = np.array([0, 3.0, 0])
    a = np.deg2rad(4)
    d1, d2 = np.array([np.sin(a), np.cos(a), 0]), np.array([-np.sin(a), np.cos(a), 0])
    g = BranchGraph(np.array([[0, 0, 0], J, J]), np.array([J, J + 4 * d1, J + 4 * d2]), np.full(3, 0.4),
                    np.full(3, 0.4), np.array([-1, 0, 0]))
    with pytest.raises(ValueError, match=r"joint \d+ of branches 1 and 2: their loops overlap .*spec V7"):
        build_control_mesh(g, overlap="raise")
    with pytest.warns(UserWarning, match="overlapping loop caps"):
        cm = build_control_mesh(g)
    _check_tree(cm)


@pytest.mark.filterwarnings("ignore:.*too short")
@pytest.mark.parametrize("seed", range(3))
def test_crowded_grown_tree_stays_manifold_with_warning(seed):
    # narrow branching + thick branches: overlapping caps (V7), leaf crossovers (§2.2 edge case)
    pos, par, rad = random_tree(300, rng=seed, branch_angle=20, radius=0.25, p_lateral=0.6)
    g = graph_from_arrays(pos, par, rad)
    with pytest.warns(UserWarning, match="overlapping loop caps"):
        cm = build_control_mesh(g)
    _check_tree(cm)
    with pytest.warns(UserWarning, match="too short"):
        with pytest.raises(ValueError, match="overlap on the joint sphere"):
            build_control_mesh(g, overlap="raise")


def test_control_mesh_is_the_shared_trimesh():
    """Issue 21: ControlMesh is a plantvr.types.TriMesh; its cached derived data agree with trimesh."""
    from plantvr.types import TriMesh

    cm = build_control_mesh(star_graph(4), compensate_radius=False, cap=True)
    assert isinstance(cm, TriMesh)
    tm = cm.to_trimesh()
    assert np.array_equal(tm.vertices, cm.vertices) and np.array_equal(tm.faces, cm.faces)  # ids kept
    assert cm.is_watertight == tm.is_watertight and cm.is_watertight
    np.testing.assert_allclose(cm.area, tm.area)
    np.testing.assert_allclose(cm.face_normals, tm.face_normals, atol=1e-12)
    ref = np.sort(tm.edges_unique, axis=1)
    assert np.array_equal(cm.edges, ref[np.lexsort(ref.T[::-1])])

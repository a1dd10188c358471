"""Spec 001 §3: Loop subdivision (V14–V17, V20), oracles trimesh (exact) and VTK (float32), export."""
import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from plantvr.io.mesh import export_mesh
from plantvr.subdivision import (
    BranchGraph,
    build_control_mesh,
    cap_boundaries,
    loop_weight,
    radius_factor,
    subdivide_loop,
    tree_mesh,
)
from plantvr.subdivision.graph import random_tree

from ._helpers import mesh_invariants, star_graph


def _match(A, B, tol):
    """Index map A -> B (bijective, within tol)."""
    d, idx = cKDTree(B).query(A)
    assert d.max() <= tol, d.max()
    assert len(np.unique(idx)) == len(A)
    return idx


def _same_faces(F1, F2, m):
    def canon(F):
        r = np.argmin(F, axis=1)
        F = np.stack([np.take_along_axis(F, ((r + i) % 3)[:, None], 1)[:, 0] for i in range(3)], 1)
        return np.unique(F, axis=0)
    np.testing.assert_array_equal(canon(m[F1]), canon(F2))


def _capped_tree(n=60, seed=0):
    pos, par, rad = random_tree(n, rng=seed)
    from plantvr.subdivision import graph_from_arrays
    cm = build_control_mesh(graph_from_arrays(pos, par, rad), cap=True)
    return cm.vertices, cm.faces


def test_v15_weights_cos_erratum():
    assert loop_weight(np.array([3]))[0] == 3 / 16
    assert loop_weight(np.array([6]))[0] == pytest.approx(1 / 16, abs=1e-15)
    assert loop_weight(np.array([6]), weight_rule="as_printed_sin")[0] == pytest.approx(0.045853, abs=1e-6)
    np.testing.assert_allclose(loop_weight(np.arange(3, 9)),
                               [0.1875, 0.121094, 0.084093, 0.0625, 0.049025, 0.040068], atol=1e-6)


@pytest.mark.parametrize("levels", [1, 2, 3])
def test_v17_exact_oracle_trimesh_icosphere(levels):
    s = trimesh.creation.icosphere(subdivisions=1)
    V, F = subdivide_loop(s.vertices, s.faces, levels)
    Vt, Ft = trimesh.remesh.subdivide_loop(s.vertices, s.faces, iterations=levels)
    m = _match(V, Vt, 1e-13)
    _same_faces(F, Ft, m)


@pytest.mark.parametrize("levels", [1, 2])
def test_exact_oracle_trimesh_closed_tree(levels):
    V0, F0 = _capped_tree()
    V, F = subdivide_loop(V0, F0, levels)
    Vt, Ft = trimesh.remesh.subdivide_loop(V0, F0, iterations=levels)
    m = _match(V, Vt, 1e-12 * np.ptp(V0))
    _same_faces(F, Ft, m)


def test_oracle_trimesh_open_mesh_with_standard_boundary_rule():
    cm = build_control_mesh(star_graph(4))
    V, F = subdivide_loop(cm.vertices, cm.faces, 2, boundary_rule="loop_cubic")
    Vt, Ft = trimesh.remesh.subdivide_loop(cm.vertices, cm.faces, iterations=2)
    _same_faces(F, Ft, _match(V, Vt, 1e-12))


def test_oracle_vtk_float32_tolerance():
    pv = pytest.importorskip("pyvista")
    V0, F0 = _capped_tree(40, seed=2)
    poly = pv.PolyData(V0, np.c_[np.full(len(F0), 3), F0].ravel())
    out = poly.subdivide(2, subfilter="loop")
    V, F = subdivide_loop(V0, F0, 2)
    assert out.n_points == len(V) and out.n_cells == len(F)
    _match(V, np.asarray(out.points, float), 1e-6 * np.ptp(V0))


def test_v14_counts_and_euler_invariant():
    cm = build_control_mesh(star_graph(4))
    V, F = cm.vertices, cm.faces
    inv0 = mesh_invariants(V, F)
    E = len(trimesh.Trimesh(V, F, process=False).edges_unique)
    B = inv0["boundary_edges"]
    for lv in range(1, 4):
        V2, F2 = subdivide_loop(V, F, 1)
        inv = mesh_invariants(V2, F2)
        E2 = len(trimesh.Trimesh(V2, F2, process=False).edges_unique)
        assert len(V2) == len(V) + E and len(F2) == 4 * len(F) and E2 == 2 * E + 3 * len(F)
        assert inv["boundary_edges"] == 2 * B and inv["euler"] == inv0["euler"]
        assert inv["max_edge_faces"] == 2 and inv["duplicate_directed"] == 0
        V, F, E, B = V2, F2, E2, 2 * B
    V3, F3 = subdivide_loop(cm.vertices, cm.faces, 3)          # derived-topology path == repeated single levels
    _same_faces(F3, F, _match(V3, V, 1e-14))


def test_v16_boundary_fixed_and_midpoints():
    cm = build_control_mesh(star_graph(3))
    V0, F0 = cm.vertices, cm.faces
    b0 = np.unique(np.concatenate([cm.first_loop[0], cm.last_loop[1:].ravel()]))
    V1, _ = subdivide_loop(V0, F0, 1)
    np.testing.assert_array_equal(V1[b0], V0[b0])
    V5, F5 = subdivide_loop(V0, F0, 5)
    np.testing.assert_array_equal(V5[b0], V0[b0])
    tip = V0[cm.last_loop[1]]                                  # tip square stays a planar square
    n = np.cross(tip[1] - tip[0], tip[2] - tip[0])
    m5 = trimesh.Trimesh(V5, F5, process=False)
    bnd = np.unique(m5.edges_sorted[trimesh.grouping.group_rows(m5.edges_sorted, require_count=1)])
    near = bnd[np.linalg.norm(V5[bnd] - tip.mean(0), axis=1) < 1.01 * np.linalg.norm(tip[0] - tip.mean(0))]
    assert len(near) == 4 * 2 ** 5
    np.testing.assert_allclose((V5[near] - tip[0]) @ n, 0, atol=1e-12)


def test_v18_convergence_and_v20_shrinkage_radius_compensation():
    g = BranchGraph(np.zeros((1, 3)), np.array([[0, 20.0, 0]]), np.ones(1), np.ones(1), np.array([-1]))
    radii = {}
    for S in (4, 8):
        cm = build_control_mesh(g, sides=S, compensate_radius=False)
        V, _ = subdivide_loop(cm.vertices, cm.faces, 4)
        mid = np.abs(V[:, 1] - 10) < 2
        radii[S] = np.hypot(V[mid, 0], V[mid, 2]).mean()
        assert V[:, 1].min() == 0 and V[:, 1].max() == 20       # branch keeps its length
    assert radii[4] < radii[8]
    assert radii[4] == pytest.approx(0.657, abs=0.01) and radii[8] == pytest.approx(0.902, abs=0.01)
    for S in (3, 4, 6, 8):
        cm = build_control_mesh(g, sides=S, compensate_radius=True)
        V, _ = subdivide_loop(cm.vertices, cm.faces, 4)
        mid = np.abs(V[:, 1] - 10) < 2
        r = np.hypot(V[mid, 0], V[mid, 2])
        assert abs(r.mean() - 1.0) < 0.05, (S, r.mean())       # issue 5: within 5 % of requested
        assert radius_factor(S) == pytest.approx(radii.get(S, radius_factor(S)), abs=0.015)


def test_v18_displacement_shrinks_geometrically():
    cm = build_control_mesh(star_graph(4))
    V, F = cm.vertices, cm.faces
    prev = None
    for _ in range(4):
        V2, F2 = subdivide_loop(V, F, 1)
        disp = np.linalg.norm(V2[:len(V)] - V, axis=1).max()
        if prev is not None:
            assert disp < 0.5 * prev
        prev, V, F = disp, V2, F2


def test_tree_mesh_watertight_and_exports(tmp_path):
    m = tree_mesh("F(2,0.2)[+F(1,0.1)][-F(1,0.1)]F(1,0.15)", levels=2)
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    for ext in ("ply", "obj", "glb", "gltf"):
        p = export_mesh(m, tmp_path / f"tree.{ext}")
        back = trimesh.load(p, force="mesh", process=False)
        assert len(back.faces) == len(m.faces)
        if ext in ("ply",):
            np.testing.assert_allclose(back.vertices, m.vertices, atol=1e-6)
            np.testing.assert_array_equal(back.faces, m.faces)


def test_cap_boundaries_closes_every_loop():
    cm = build_control_mesh(star_graph(5))
    V, F = cap_boundaries(*subdivide_loop(cm.vertices, cm.faces, 2))
    inv = mesh_invariants(V, F)
    assert inv["boundary_edges"] == 0 and inv["euler"] == 2 and inv["duplicate_directed"] == 0


def test_bad_subdivision_input():
    s = trimesh.creation.icosphere(0)
    with pytest.raises(ValueError, match=r"levels must be an integer in \[0, 8\], got 9"):
        subdivide_loop(s.vertices, s.faces, 9)
    with pytest.raises(ValueError, match="weight_rule must be one of"):
        subdivide_loop(s.vertices, s.faces, 1, weight_rule="sin")
    with pytest.raises(ValueError, match="boundary_rule must be one of"):
        subdivide_loop(s.vertices, s.faces, 1, boundary_rule="free")
    with pytest.raises(ValueError, match=r"faces must index vertices in \[0, 11\]"):
        subdivide_loop(s.vertices, s.faces + 1, 1)
    with pytest.raises(ValueError, match=r"vertices must have shape \(N, 3\)"):
        subdivide_loop(s.vertices[:, :2], s.faces, 1)
    F = np.vstack([s.faces, s.faces[:1]])
    with pytest.raises(ValueError, match="shared by 3 faces"):
        subdivide_loop(s.vertices, F, 1)
    with pytest.raises(ValueError, match="file_type must be one of"):
        export_mesh(trimesh.Trimesh(s.vertices, s.faces, process=False), "x.stl")
    with pytest.raises(ValueError, match=r"levels must be an integer in \[0, 6\]"):
        tree_mesh("F", levels=7)
    with pytest.raises(ValueError, match="tree must be an L-system str"):
        tree_mesh(42)


@pytest.mark.parametrize("weight_rule", ["loop_cos", "as_printed_sin"])
def test_v15_affine_invariance_rows_sum_to_one(weight_rule):
    V0, F0 = _capped_tree(30, seed=4)
    t = np.array([3.0, -7.0, 11.0])
    A, _ = subdivide_loop(V0, F0, 2, weight_rule=weight_rule)
    B, _ = subdivide_loop(V0 + t, F0, 2, weight_rule=weight_rule)
    np.testing.assert_allclose(B - t, A, atol=1e-12)
    if weight_rule == "as_printed_sin":
        C, _ = subdivide_loop(V0, F0, 2)
        assert np.abs(C - A).max() > 1e-3                          # the erratum matters


def test_report_offset_mode_still_builds_manifold_mesh():
    cm = build_control_mesh(star_graph(4), offset_mode="report")
    inv = mesh_invariants(cm.vertices, cm.faces)
    assert inv["max_edge_faces"] == 2 and inv["duplicate_directed"] == 0 and inv["euler"] == 2 - 4


def test_edge_table_numba_twin_equals_numpy():
    from plantvr.subdivision import loop as L
    for V0, F0 in [_capped_tree(50, seed=9), (lambda cm: (cm.vertices, cm.faces))(build_control_mesh(star_graph(6)))]:
        F0 = np.random.default_rng(0).permutation(F0)
        a = L._edge_table_numpy(F0, len(V0))
        b = L._edge_table_numba(F0, len(V0))
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])

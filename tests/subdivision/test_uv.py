"""Spec 001 §2.6, §2.7, §3.3: per-corner UVs (V21), OBJ round trip (V22), extraordinary vertices (V19)."""
import numpy as np
import pytest
import trimesh

from plantvr.io.obj import write_obj
from plantvr.subdivision import (
    BranchGraph,
    build_control_mesh,
    graph_from_arrays,
    parse_lsystem,
    subdivide_loop,
)
from plantvr.subdivision.graph import random_tree
from plantvr.subdivision.uv import (
    branch_uvs,
    control_uvs,
    propagate_uvs,
    read_obj,
    subdivide_uvs,
    vertex_normals,
)

from ._helpers import star_graph

TREE = "F(3,0.25)[+F(2,0.15)[-F(1.2,0.08)][+F(1.2,0.08)]][-F(2,0.15)[&F(1.2,0.08)]]/F(2,0.2)[+F(1.5,0.1)]F(1.5,0.12)"


def _uv_area(uv):
    d, e = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    return 0.5 * (d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0])


def _seam_vertices(F, uv):
    """Vertices carrying more than one distinct corner UV."""
    keys = np.c_[F.reshape(-1), uv.reshape(-1, 2)]
    u = np.unique(keys, axis=0)
    return set(np.flatnonzero(np.bincount(u[:, 0].astype(np.int64)) > 1).tolist())


def test_v21_tube_strips_cylindrical():
    L, r = 10.0, 1.0
    g = BranchGraph(np.zeros((1, 3)), np.array([[0, L, 0]]), np.full(1, r), np.full(1, r), np.array([-1]))
    cm = build_control_mesh(g, compensate_radius=False)
    uv, known = branch_uvs(cm)
    assert known.all()
    assert uv[..., 0].min() == 0.0 and uv[..., 0].max() == 1.0                # u in [0, 1], last column ends at 1
    assert set(np.unique(uv[..., 1]).tolist()) <= {0.0, 0.5, 1.0}              # v repeats every two segments
    N = cm.n_segments[0]
    assert abs(2 * (L / N) / (2 * np.pi * r) - 1) <= np.pi * r / L + 1e-12     # two segments ~ one square tile
    assert np.all(_uv_area(uv) > 0)                                            # same sense as the 3D winding
    # the u seam: the first loop vertex carries u = 0 and u = 1
    F = cm.faces
    assert 0 in _seam_vertices(F, uv)


@pytest.mark.parametrize("wrap", ["triangle", "coordinate", "none"])
def test_v21_every_face_gets_uvs(wrap):
    cm = build_control_mesh(parse_lsystem(TREE, angle=40))
    uv = control_uvs(cm, wrap=wrap)
    assert uv.shape == (len(cm.faces), 3, 2) and np.isfinite(uv).all()
    if wrap == "triangle":
        c = uv.mean(axis=1)
        assert np.all((c >= 0) & (c < 1))
        assert np.all(_uv_area(uv) > 0)                 # propagation keeps the orientation (no flipped charts)
    if wrap == "coordinate":
        assert uv.min() >= 0 and uv.max() <= 1          # ERRATUM A8: wrap each coordinate into [0, 1]


def test_v21_propagation_is_isometric_on_a_developable_strip():
    # an unrolled cylinder: propagating from one face reproduces the exact planar (u, v) of the rest
    rng = np.random.default_rng(0)
    cm = build_control_mesh(BranchGraph(np.zeros((1, 3)), np.array([[0, 6.0, 0]]), np.ones(1), np.ones(1),
                                        np.array([-1])), sides=8, compensate_radius=False)
    V, F = cm.vertices, cm.faces
    # a flat copy of the tube (developable): x = arc length, y = height, z = 0 with no seam (cut the last column)
    S = 8
    keep = np.flatnonzero((F % S).max(axis=1) - (F % S).min(axis=1) < S - 1)
    Fk = F[keep]
    flat = np.c_[(np.arange(len(V)) % S) * 0.3, V[:, 1], np.zeros(len(V))]
    truth = flat[Fk][..., :2] * 0.7 + [0.1, 0.2]
    known = np.zeros(len(Fk), bool)
    known[rng.integers(len(Fk))] = True
    uv = np.where(known[:, None, None], truth, np.nan)
    out = propagate_uvs(flat, Fk, uv, known, wrap="none")
    np.testing.assert_allclose(out, truth, atol=1e-12)


def test_v21_linear_subdivision_keeps_parents_midpoints_and_seams():
    cm = build_control_mesh(star_graph(4))
    uv = control_uvs(cm)
    _, F1 = subdivide_loop(cm.vertices, cm.faces, 1)
    uv1 = subdivide_uvs(uv, 1)
    assert uv1.shape == (4 * len(uv), 3, 2)
    c = uv1.reshape(-1, 4, 3, 2)
    np.testing.assert_array_equal(c[:, 0, 0], uv[:, 0])                 # parent corners kept
    np.testing.assert_array_equal(c[:, 1, 1], uv[:, 1])
    np.testing.assert_array_equal(c[:, 2, 2], uv[:, 2])
    np.testing.assert_array_equal(c[:, 0, 1], 0.5 * (uv[:, 0] + uv[:, 1]))   # exact midpoints
    np.testing.assert_array_equal(c[:, 3], c[:, [0, 1, 2], [1, 2, 0]])        # centre child = the three midpoints
    # child corners sit on the right vertices: a child corner's UV is the UV of that vertex in its parent
    seams0 = _seam_vertices(cm.faces, uv)
    seams1 = _seam_vertices(F1, uv1)
    assert seams0 and seams0 <= seams1                                       # seams preserved as seams
    uv3 = subdivide_uvs(uv, 3)
    _, F3 = subdivide_loop(cm.vertices, cm.faces, 3)
    assert len(uv3) == len(F3) and seams0 <= _seam_vertices(F3, uv3)


def test_v22_obj_round_trip_control_and_subdivided(tmp_path):
    cm = build_control_mesh(parse_lsystem(TREE, angle=40))
    uv = control_uvs(cm)
    V2, F2 = subdivide_loop(cm.vertices, cm.faces, 2)
    uv2 = subdivide_uvs(uv, 2)
    for name, (V, F, T) in {"control": (cm.vertices, cm.faces, uv), "subdivided": (V2, F2, uv2)}.items():
        p = write_obj(tmp_path / f"{name}.obj", V, F, T)
        text = p.read_text().splitlines()
        f_lines = [ln for ln in text if ln.startswith("f ")]
        assert len(f_lines) == len(F) and all(c.count("/") == 2 for c in f_lines[0].split()[1:])   # v/vt/vn
        first = [int(c.split("/")[0]) for c in f_lines[0].split()[1:]]
        assert first == (F[0] + 1).tolist()                                   # 1-based
        assert sum(ln.startswith("vn ") for ln in text) == len(V)
        Vr, Fr, Tr = read_obj(p)
        np.testing.assert_array_equal(Vr, V)
        np.testing.assert_array_equal(Fr, F)
        np.testing.assert_array_equal(Tr, T)
        back = trimesh.load(p, process=False)                                 # a third-party reader agrees
        assert len(back.faces) == len(F)
    p = write_obj(tmp_path / "plain.obj", V2, F2, normals=False)
    Vr, Fr, Tr = read_obj(p)
    assert Tr is None and np.array_equal(Fr, F2)


def test_vertex_normals_point_outward():
    s = trimesh.creation.icosphere(2)
    n = vertex_normals(s.vertices, s.faces)
    np.testing.assert_allclose(np.einsum("ij,ij->i", n, s.vertices / np.linalg.norm(s.vertices, axis=1)[:, None]),
                               1.0, atol=5e-3)


def test_uv_and_obj_bad_input(tmp_path):
    cm = build_control_mesh(star_graph(3))
    with pytest.raises(ValueError, match=r"wrap must be one of"):
        control_uvs(cm, wrap="smear")
    with pytest.raises(ValueError, match=r"uv must have shape \(N, 3, 2\)"):
        subdivide_uvs(np.zeros((4, 3)), 1)
    with pytest.raises(ValueError, match=r"levels must be an integer in \[0, 8\]"):
        subdivide_uvs(np.zeros((4, 3, 2)), 9)
    with pytest.raises(ValueError, match=r"uv must have shape"):
        write_obj(tmp_path / "x.obj", cm.vertices, cm.faces, np.zeros((1, 3, 2)))
    with pytest.raises(ValueError, match="OBJ file .* does not exist"):
        read_obj(tmp_path / "missing.obj")
    (tmp_path / "quad.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    with pytest.raises(ValueError, match="line 5 is a face with 4 corners"):
        read_obj(tmp_path / "quad.obj")


# ------------------------------------------------------------------------------------------------
# V19: extraordinary vertices
# ------------------------------------------------------------------------------------------------
def _extraordinary(V, F):
    m = trimesh.Trimesh(V, F, process=False)
    e = m.edges_sorted
    from trimesh.grouping import group_rows
    bnd = np.unique(e[group_rows(e, require_count=1)])
    val = np.bincount(m.edges_unique.ravel(), minlength=len(V))
    interior = np.ones(len(V), bool)
    interior[bnd] = False
    return np.flatnonzero(interior & (val != 6))


@pytest.mark.parametrize("seed", [0, 1])
def test_v19_extraordinary_vertices_invariant_and_on_joint_rings(seed):
    cm = build_control_mesh(graph_from_arrays(*random_tree(80, rng=seed)))
    V, F = cm.vertices, cm.faces
    ex0 = _extraordinary(V, F)
    g = cm.graph
    has_joint_end = ~g.is_leaf
    has_joint_start = g.parent >= 0
    rings = np.concatenate([cm.last_loop[has_joint_end].ravel(), cm.first_loop[has_joint_start].ravel()])
    assert len(ex0) > 0 and np.isin(ex0, rings).all()                 # only on joint rings
    for lv in (1, 2, 3):
        V2, F2 = subdivide_loop(V, F, lv)
        ex = _extraordinary(V2, F2)
        np.testing.assert_array_equal(ex, ex0)                         # same vertices, even ids kept


def test_two_gltf_files_in_one_folder_keep_their_own_buffers(tmp_path):
    from plantvr.io.mesh import export_mesh

    a, b = trimesh.creation.box(), trimesh.creation.icosphere(1)
    export_mesh(a, tmp_path / "a.gltf")
    export_mesh(b, tmp_path / "b.gltf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.bin", "a.gltf", "b.bin", "b.gltf"]
    assert len(trimesh.load(tmp_path / "a.gltf", force="mesh").faces) == 12
    assert len(trimesh.load(tmp_path / "b.gltf", force="mesh").faces) == 80

"""Issue 20 for Yggdrasil: every public entry point checks its input at the door (fuzzed), OBJ files are
written atomically, read back byte-identically and refused clearly when corrupt."""
import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr.io.obj import write_obj
from plantvr.subdivision import (
    BranchGraph,
    build_control_mesh,
    cap_boundaries,
    graph_from_arrays,
    loop_weight,
    parse_lsystem,
    propagate_uvs,
    read_obj,
    self_intersections,
    subdivide_loop,
    subdivide_uvs,
    tree_mesh,
    tree_mesh_uv,
    vertex_normals,
)
from plantvr.subdivision.hull import joint_hulls
from plantvr.subdivision.loop import boundary_loops, edge_table

BAD_FLOATS = [np.nan, np.inf, -np.inf, 1e300, -1e300, 1e19, -9.3e18, 1e-20, -1.0, 0.0, 1e7]
BAD_VALUES = [None, "x", [], [[1, 2]], {"a": 1}, 10**12, -5, 0.5, True, np.zeros((2, 2, 2))]
FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

POS = np.array([[0, 0, 0], [0, 1, 0], [0.5, 1.8, 0], [-0.5, 1.8, 0.1]], float)
PAR = np.array([-1, 0, 1, 1])
RAD = np.array([0.1, 0.08, 0.05, 0.05])
TRI_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
TRI_F = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]])


def _quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **kw)


# -- item 9: the reported cases --------------------------------------------------------------------------------
@pytest.mark.parametrize("text", ["F(1e300,0.1)", "F(1,1e300)", "F(1,1e-300)", "MovRel3f(1e300,0,0)F",
                                  "F(2e6)", "f(9e5)f(9e5)F", "Cylinder(1,1,1e300)", "RotRel3f(1e300,0,0,1)F"])
def test_parse_lsystem_refuses_values_that_fail_later(text):
    with pytest.raises(ValueError, match="text|graph"):
        g = parse_lsystem(text)
        tree_mesh(g, levels=1)            # F(1,1e-300): accepted radius, refused mesh size (a clear error)


@pytest.mark.parametrize("pos, parent, radius, param", [
    ([[0, 0, 0], [0, 1e300, 0]], [-1, 0], [0.1, 0.1], "pos"),
    ([[0, 0, 0], [0, 1e19, 0]], [-1, 0], [0.1, 0.1], "pos"),
    ([[0, 0, 0], [0, np.nan, 0]], [-1, 0], [0.1, 0.1], "pos"),
    ([[0, 0, 0], [0, 1, 0]], [-1, 0.5], [0.1, 0.1], "parent"),
    ([[0, 0, 0], [0, 1, 0]], [-1, 2**70], [0.1, 0.1], "parent"),
    ([[0, 0, 0], [0, 1, 0]], [-1, 10**9], [0.1, 0.1], "parent"),
    ([[0, 0, 0], [0, 1, 0]], [-1, -7], [0.1, 0.1], "parent"),
    ([[0, 0, 0], [0, 1, 0]], [-1, np.nan], [0.1, 0.1], "parent"),
    ([[0, 0, 0], [0, 1, 0]], [-1, 1], [0.1, 0.1], "parent"),           # a cycle (self parent)
    ([[0, 0, 0], [0, 1, 0]], [-1, 0], [0.1, 1e300], "radius"),
    ([[0, 0, 0], [0, 1, 0]], [-1, 0], [0.1, np.inf], "radius"),
    ([[0, 0, 0], [0, 1, 0]], [-1, 0], [[0.1], [0.1]], "radius"),
    ([[0, 0, 0], [0, 1, 0]], ["a", "b"], [0.1, 0.1], "parent"),
])
def test_graph_from_arrays_refuses_at_the_door(pos, parent, radius, param):
    with pytest.raises(ValueError, match=param):
        graph_from_arrays(pos, parent, radius)


def test_branch_graph_validate_checks_dtypes_and_bounds():
    g = graph_from_arrays(POS, PAR, RAD)
    bad = BranchGraph(g.start, g.end, g.r0, g.r1, g.parent.astype(float) + 0.5)
    with pytest.raises(ValueError, match="parent"):
        build_control_mesh(bad)
    with pytest.raises(ValueError, match="start"):
        BranchGraph(g.start * 1e10, g.end * 1e10, g.r0, g.r1, g.parent).validate()
    with pytest.raises(ValueError, match="branches"):
        BranchGraph(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0, int)).validate()
    ok = BranchGraph(g.start.tolist(), g.end, g.r0, g.r1, g.parent.astype(np.int32)).validate()
    assert ok.parent.dtype == np.int64 and isinstance(ok.start, np.ndarray)
    assert len(build_control_mesh(ok).faces) == len(build_control_mesh(g).faces)


def test_huge_joint_and_huge_mesh_refused_before_allocating():
    k = 2000                                                    # 2000 children at one joint
    ang = np.linspace(0, 2 * np.pi, k, endpoint=False)
    pos = np.vstack([[0, 0, 0], [0, 1, 0], np.c_[np.cos(ang), np.full(k, 1.5), np.sin(ang)]])
    parent = np.r_[-1, 0, np.ones(k, int)]
    g = graph_from_arrays(pos, parent, np.full(k + 2, 1e-3))
    with pytest.raises(ValueError, match="joint"):
        build_control_mesh(g)
    g = graph_from_arrays([[0, 0, 0], [0, 9e5, 0]], [-1, 0], [1e-9, 1e-9])
    with pytest.raises(ValueError, match="vertices"):
        build_control_mesh(g)
    with pytest.raises(ValueError, match="levels"):
        subdivide_loop(np.zeros((3 * 10**5, 3)), np.arange(3 * 10**5).reshape(-1, 3), 8)


@pytest.mark.parametrize("fn", [subdivide_loop, cap_boundaries, vertex_normals, self_intersections])
@pytest.mark.parametrize("faces", [[[0, 1, 5]], [[0, 1, -1]], [[0, 1, 0.5]], [[0, 1, 2**70]], [[0, 1, np.nan]],
                                   [[0, 1]], "abc", None])
def test_mesh_functions_refuse_faces_outside_the_table(fn, faces):
    with pytest.raises(ValueError, match="faces"):
        fn(TRI_V[:3], faces)


def test_kernel_entry_points_check_indices():
    with pytest.raises(ValueError, match="faces"):
        edge_table(np.array([[0, 1, 7]]), 3)
    with pytest.raises(ValueError, match="n_vertices"):
        edge_table(np.array([[0, 1, 2]]), -3)
    with pytest.raises(ValueError, match="faces"):
        boundary_loops(np.array([[0, 1, 7]]), 3)
    with pytest.raises(ValueError, match="ptr"):
        joint_hulls(np.random.default_rng(0).normal(size=(8, 3)), np.array([0, 90]))
    with pytest.raises(ValueError, match="ptr"):
        joint_hulls(np.random.default_rng(0).normal(size=(8, 3)), np.array([0, 2, 8]))
    with pytest.raises(ValueError, match="P"):
        joint_hulls(np.zeros((4, 3)), np.array([0, 4]), method="qhull")
    with pytest.raises(ValueError, match="uv"):
        propagate_uvs(TRI_V, TRI_F, np.full((4, 3, 2), np.inf), np.ones(4, bool))
    with pytest.raises(ValueError, match="known"):
        propagate_uvs(TRI_V, TRI_F, np.zeros((4, 3, 2)), np.ones(4))
    with pytest.raises(ValueError, match="n"):
        loop_weight(np.array([3.5]))


# -- fuzz: every public entry point -------------------------------------------------------------------------------
floats = st.one_of(st.sampled_from(BAD_FLOATS), st.floats(-1e3, 1e3, allow_nan=False))
anything = st.one_of(floats, st.sampled_from(BAD_VALUES))


@FUZZ
@given(i=st.integers(0, 3), j=st.integers(0, 2), v=floats)
def test_fuzz_graph_from_arrays(fuzz, i, j, v):
    pos, rad = POS.copy(), RAD.copy()
    pos[i, j] = v
    rad[i] = abs(v) if j == 0 else rad[i]
    r = fuzz.call("graph_from_arrays", graph_from_arrays, pos, PAR, rad, param=("pos", "radius"))
    if isinstance(r, BranchGraph) and abs(v) <= 1e3:         # far larger trees are valid, only slow to mesh
        m = fuzz.call("tree_mesh", _quiet, tree_mesh, r, levels=1, param=("graph", "joint", "branch"))
        if not isinstance(m, Exception):
            assert np.isfinite(m.vertices).all() and len(m.faces) > 0


@FUZZ
@given(i=st.integers(0, 3), v=anything)
def test_fuzz_graph_from_arrays_parent(fuzz, i, v):
    par = PAR.astype(object)
    par[i] = v
    try:
        par = np.array(par.tolist())
    except ValueError:
        par = par.tolist()
    r = fuzz.call("graph_from_arrays", graph_from_arrays, POS, par, RAD, param="parent")
    if isinstance(r, BranchGraph):
        assert ((r.parent >= -1) & (r.parent < np.arange(len(r)))).all()


@FUZZ
@given(a=floats, b=floats, sym=st.sampled_from(["F({a},{b})", "Cylinder({a},{b},1)", "MovRel3f({a},0,{b})F",
                                                "RotRel3f({a},0,0,{b})F", "f({a})F({b})", "F[+F({a})]F({b})"]))
def test_fuzz_parse_lsystem(fuzz, a, b, sym):
    text = sym.format(a=repr(float(a)), b=repr(float(b)))
    g = fuzz.call("parse_lsystem", _quiet, parse_lsystem, text, param="text")
    if isinstance(g, BranchGraph):
        cm = fuzz.call("build_control_mesh", _quiet, build_control_mesh, g, param=("graph", "joint", "branch"))
        if not isinstance(cm, Exception):
            assert np.isfinite(cm.vertices).all()


@FUZZ
@given(kw=st.sampled_from(["angle", "step", "radius", "angle_unit", "strict"]), v=anything)
def test_fuzz_parse_lsystem_options(fuzz, kw, v):
    g = fuzz.call("parse_lsystem", _quiet, parse_lsystem, "F[+F]F", **{kw: v}, param=kw)
    if isinstance(g, BranchGraph):
        assert np.isfinite(g.end).all()


@FUZZ
@given(kw=st.sampled_from(["sides", "min_offset", "offset_margin", "max_offset_factor", "offset_mode", "rounding",
                           "overlap", "hull", "levels", "weight_rule", "boundary_rule", "wrap"]), v=anything)
def test_fuzz_tree_mesh_options(fuzz, kw, v):
    g = graph_from_arrays(POS, PAR, RAD)
    r = fuzz.call("tree_mesh_uv", _quiet, tree_mesh_uv, g, **{kw: v}, param=kw)
    if not isinstance(r, Exception):
        mesh, uv = r
        assert np.isfinite(mesh.vertices).all() and np.isfinite(uv).all()


MESH_FNS = {"subdivide_loop": subdivide_loop, "cap_boundaries": cap_boundaries, "vertex_normals": vertex_normals,
            "self_intersections": self_intersections}


@FUZZ
@given(name=st.sampled_from(sorted(MESH_FNS)), i=st.integers(0, 3), j=st.integers(0, 2), v=anything,
       which=st.sampled_from(["vertices", "faces"]))
def test_fuzz_mesh_functions(fuzz, name, i, j, v, which):
    V, F = TRI_V.astype(object), TRI_F.astype(object)
    (V if which == "vertices" else F)[i, j] = v
    V, F = V.tolist(), F.tolist()
    r = fuzz.call(name, MESH_FNS[name], V, F, param=which)
    if not isinstance(r, Exception) and name == "subdivide_loop":
        assert np.isfinite(r[0]).all() and r[1].max() < len(r[0])


@FUZZ
@given(levels=anything, v=floats)
def test_fuzz_subdivide_uvs_and_levels(fuzz, levels, v):
    uv = np.zeros((2, 3, 2))
    uv[0, 0, 0] = v
    r = fuzz.call("subdivide_uvs", subdivide_uvs, uv, levels if not isinstance(levels, float) else 1,
                  param=("uv", "levels"))
    if not isinstance(r, Exception):
        assert np.isfinite(r).all()
    r = fuzz.call("subdivide_loop", subdivide_loop, TRI_V, TRI_F, levels, param="levels")
    if not isinstance(r, Exception):
        assert len(r[1]) == len(TRI_F) * 4 ** int(levels)


@FUZZ
@given(n=anything)
def test_fuzz_kernels(fuzz, n):
    fuzz.call("edge_table", edge_table, TRI_F, n, param=("n_vertices", "faces"))
    fuzz.call("boundary_loops", boundary_loops, TRI_F, n, param=("n_vertices", "faces"))
    fuzz.call("loop_weight", loop_weight, n, param="n")
    P = np.random.default_rng(0).normal(size=(8, 3))
    fuzz.call("joint_hulls", joint_hulls, P, [0, n] if not isinstance(n, (list, np.ndarray)) else n,
              param="ptr")
    fuzz.call("joint_hulls", joint_hulls, P, [0, 8], eps=n, param="eps")


# -- OBJ: atomic save, byte-identical round trip, corrupt-file suite ---------------------------------------------
@pytest.fixture(scope="module")
def obj_mesh():
    mesh, uv = _quiet(tree_mesh_uv, graph_from_arrays(POS, PAR, RAD), levels=1)
    return mesh.vertices, mesh.faces, uv


def test_obj_round_trip_is_byte_identical(tmp_path, obj_mesh):
    V, F, uv = obj_mesh
    a = write_obj(tmp_path / "a.obj", V, F, uv)
    V2, F2, uv2 = read_obj(a)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)
    b = write_obj(tmp_path / "b.obj", V2, F2, uv2)
    assert a.read_bytes() == b.read_bytes()


def test_obj_failed_save_keeps_old_file(tmp_path, obj_mesh, monkeypatch):
    V, F, uv = obj_mesh
    p = write_obj(tmp_path / "a.obj", V, F, uv)
    old = p.read_bytes()
    import plantvr.io.obj as U

    def boom(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(U, "_fmt_rows", lambda line, A, chunk=0: boom() if line.startswith("f") else "")
    with pytest.raises(OSError):
        write_obj(p, V, F, uv)
    assert p.read_bytes() == old and os.listdir(tmp_path) == ["a.obj"]
    with pytest.raises(ValueError, match="faces"):
        write_obj(p, V, F + len(V), uv)
    assert p.read_bytes() == old and os.listdir(tmp_path) == ["a.obj"]


def _corrupt_objs(good: bytes):
    lines = good.decode().splitlines(keepends=True)
    first_f = next(i for i, ln in enumerate(lines) if ln.startswith("f "))
    yield "truncated face", good[:good.index(b"\nf ") + 6]
    yield "vertex index out of range", "".join(lines[:first_f] + ["f 1/1/1 2/2/2 99999/3/3\n"]).encode()
    yield "texture index out of range", "".join(lines[:first_f] + ["f 1/1/1 2/2/2 3/99999/3\n"]).encode()
    yield "index 0", "".join(lines[:first_f] + ["f 0 1 2\n"]).encode()
    yield "non-numeric vertex", b"v 1 2 x\nv 0 0 0\nv 1 1 1\nf 1 2 3\n"
    yield "short vertex", b"v 1 2\nf 1 1 1\n"
    yield "huge vertex", b"v 1e300 0 0\nv 0 0 0\nv 1 1 1\nf 1 2 3\n"
    yield "nan vertex", b"v nan 0 0\nv 0 0 0\nv 1 1 1\nf 1 2 3\n"
    yield "quad", b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    yield "bad corner", b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1/a 2 3\n"
    yield "bad corner slashes", b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1/1/1/1 2 3\n"
    yield "binary", bytes(range(256)) * 4
    flip = bytearray(good)
    flip[good.index(b"\nf ") + 3] ^= 0x40                                 # '1'.. -> 'q'..: not an integer
    yield "bit flip", bytes(flip)


def test_read_obj_rejects_corrupt_files(tmp_path, obj_mesh):
    V, F, uv = obj_mesh
    good = write_obj(tmp_path / "good.obj", V, F, uv).read_bytes()
    n = 0
    for what, data in _corrupt_objs(good):
        p = tmp_path / "bad.obj"
        p.write_bytes(data)
        try:
            r = read_obj(p)
        except ValueError as exc:
            assert "path" in str(exc), what
            n += 1
            continue
        # a truncation that happens to end on a whole line is a smaller, consistent mesh
        assert what == "truncated face" and r[1].max() < len(r[0]), what
    assert n >= 12
    with pytest.raises(ValueError, match="OBJ file .*missing.obj. does not exist"):
        read_obj(tmp_path / "missing.obj")

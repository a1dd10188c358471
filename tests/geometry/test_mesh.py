"""Skeleton, generalized cylinders, LOD, bark UVs and incremental update (spec 000_treewand §3.1–§3.5)."""
import numpy as np
import pytest
import trimesh

from plantvr.geometry import (build_branch_mesh, length_estimate, lod_level, rational_bezier,
                              rational_bezier_tangent, transport_frame, tree_segments, update_branch_mesh)
from plantvr.geometry import _kernels as K

from ._trees import random_tree


@pytest.fixture(scope="module")
def tree():
    return random_tree(250, seed=7, tip_radius=0.01)


@pytest.fixture(scope="module")
def mesh(tree):
    pos, parent, radius, mc = tree
    return build_branch_mesh(pos, parent, radius, main_child=mc)


def _ring(m, s, which):
    cnt = m.counts[s]
    start = m.v_off[s] if which == 0 else m.v_off[s] + int((cnt[:-1] + 1).sum())
    n = cnt[0] if which == 0 else cnt[-1]
    return slice(start, start + n + 1), n


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# ---- TW-V17 skeleton ------------------------------------------------------------------------------
def test_tw_v17_segment_ends_at_midpoints_and_g1_along_paths(tree):
    pos, parent, radius, mc = tree
    seg = tree_segments(pos, parent, radius, main_child=mc)
    r = seg.records
    ends = rational_bezier(r[:, 0:3], r[:, 3:6], r[:, 6:9], [0.0, 1.0], w=3.0)
    np.testing.assert_allclose(ends[:, 0], r[:, 0:3], atol=1e-14)
    np.testing.assert_allclose(ends[:, 1], r[:, 6:9], atol=1e-14)
    incoming = seg.keys % 2 == 0
    c = seg.keys[incoming] // 2
    nonroot = parent[parent[c]] >= 0
    np.testing.assert_allclose(r[incoming][nonroot, 0:3], 0.5 * (pos[parent[parent[c]]] + pos[parent[c]])[nonroot])
    np.testing.assert_allclose(r[incoming, 6:9], 0.5 * (pos[c] + pos[parent[c]]))
    key_to_seg = {k: i for i, k in enumerate(seg.keys)}
    checked = 0
    for s in np.flatnonzero(incoming):
        ci = seg.keys[s] // 2
        nxt = key_to_seg.get(2 * mc[ci]) if mc[ci] > 0 else key_to_seg.get(2 * ci + 1)
        t1 = _unit(rational_bezier_tangent(*(r[s, k:k + 3] for k in (0, 3, 6)), 1.0)[0])
        t0 = _unit(rational_bezier_tangent(*(r[nxt, k:k + 3] for k in (0, 3, 6)), 0.0)[0])
        np.testing.assert_allclose(t1, t0, atol=1e-12)
        checked += 1
    assert checked == incoming.sum()


def test_tw_v17_larger_weight_pulls_curve_to_node():
    p0, p1, p2 = np.zeros(3), np.array([0.0, 1, 0]), np.array([1.0, 1, 0])
    d = [np.linalg.norm(rational_bezier(p0, p1, p2, 0.5, w=w)[0] - p1) for w in (0.5, 1, 3, 10)]
    assert np.all(np.diff(d) < 0)


# ---- TW-V18 frames and joins ----------------------------------------------------------------------
def test_tw_v18_closed_form_matches_stepped_transport():
    rng = np.random.default_rng(3)
    for _ in range(3):
        p0, p1, p2 = rng.normal(size=(3, 3))
        steps = 10_000
        u = np.linspace(0, 1, steps + 1)
        tg = _unit(rational_bezier_tangent(p0, p1, p2, u, 3.0))
        bx0 = K._perp(tg[0])
        bx = bx0.copy()
        stepped = [bx]
        for k in range(steps):
            bx = K._rotate_between(bx, tg[k], tg[k + 1])
            stepped.append(bx)
        stepped = np.array(stepped)
        probe = np.arange(0, steps + 1, 1000)
        closed, by = transport_frame(p0, p1, p2, bx0, u[probe], 3.0)
        np.testing.assert_allclose(closed, stepped[probe], atol=1e-6)
        np.testing.assert_allclose(np.sum(closed * tg[probe], 1), 0, atol=1e-12)
        np.testing.assert_allclose(by, np.cross(closed, tg[probe]), atol=1e-15)


def test_tw_v18_v20_rings_coincide_at_shared_midpoints(mesh, tree):
    pos, parent, radius, mc = tree
    m, seg = mesh, mesh.segments
    start_at = {}
    for s, rec in enumerate(seg.records):
        start_at.setdefault(rec[0:3].tobytes(), []).append(s)
    pairs = 0
    for s in range(len(seg)):
        if seg.keys[s] % 2:
            continue
        end, n_end = _ring(m, s, 1)
        for o in start_at.get(seg.records[s, 6:9].tobytes(), []):
            beg, n_beg = _ring(m, o, 0)
            assert n_end == n_beg                                          # TW-V20 equal counts
            np.testing.assert_allclose(m.vertices[beg], m.vertices[end], atol=1e-12)   # TW-V18 no gaps
            np.testing.assert_allclose(m.uv[beg], m.uv[end], atol=1e-6)                # TW-V19 continuity
            pairs += 1
    assert pairs >= len(seg) - 2


def test_mesh_per_axis_closed_outward_no_nan(mesh):
    m, seg = mesh, mesh.segments
    assert np.isfinite(m.vertices).all() and np.isfinite(m.normals).all() and np.isfinite(m.uv).all()
    assert m.faces.min() >= 0 and m.faces.max() < len(m.vertices)
    np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1, atol=1e-5)
    axes = np.unique(seg.axis)
    assert len(axes) > 10
    for a in axes[:40]:
        s = np.flatnonzero(seg.axis == a)
        f = np.concatenate([m.faces[m.f_off[i]:m.f_off[i + 1]] for i in s])
        tm = trimesh.Trimesh(m.vertices, f, process=False)
        tm.merge_vertices(digits_vertex=9)
        tm.remove_unreferenced_vertices()
        assert tm.is_watertight and tm.is_winding_consistent
        assert tm.volume > 0                                               # outward orientation
    # analytic normals agree with face normals
    fn = trimesh.Trimesh(m.vertices, m.faces, process=False).face_normals
    vn = m.normals[m.faces].mean(axis=1)
    assert np.median(np.sum(fn * vn, axis=1)) > 0.95


def test_volume_matches_cylinders_for_straight_tree():
    n = 6
    pos = np.zeros((n, 3))
    pos[:, 1] = np.arange(n)
    parent = np.arange(-1, n - 1)
    radius = np.full(n, 0.1)
    m = build_branch_mesh(pos, parent, radius, lod=(64, 64))
    tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
    tm.merge_vertices(digits_vertex=9)
    polygon = 0.5 * 64 * np.sin(2 * np.pi / 64) * 0.01
    assert tm.is_watertight
    np.testing.assert_allclose(tm.volume, polygon * (n - 1), rtol=1e-9)
    np.testing.assert_allclose(np.ptp(m.uv[:, 1]), n - 1, rtol=1e-12)  # bark rate 1: t = length


# ---- TW-V19 bark coordinates ----------------------------------------------------------------------
def test_tw_v19_length_estimate_exact_for_collinear_and_monotone():
    p0, p1, p2 = np.zeros(3), np.array([0.3, 0, 0]), np.array([1.3, 0, 0])
    u = np.linspace(0, 1, 101)
    for w in (0.5, 1.0, 3.0):
        pts = rational_bezier(p0, p1, p2, u, w)
        np.testing.assert_allclose(length_estimate(p0, p1, p2, u, w), pts[:, 0], atol=1e-14)
    p2b = np.array([0.3, 0.7, 0.2])
    assert np.all(np.diff(length_estimate(p0, p1, p2b, u, 3.0)) > 0)


def test_tw_v19_weighted_estimate_stretches_less_than_raw_u():
    p0, p1, p2 = np.array([-1.0, 0, 0]), np.zeros(3), np.array([0, 1.0, 0])
    u = np.linspace(0, 1, 2001)
    pts = rational_bezier(p0, p1, p2, u, 3.0)
    ds = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    dd = np.diff(length_estimate(p0, p1, p2, u, 3.0))
    du = np.diff(u)

    def cv(x):
        r = x / ds
        return np.std(r) / np.mean(r)
    assert cv(dd) < 0.5 * cv(du)


# ---- TW-V20 LOD -----------------------------------------------------------------------------------
def test_tw_v20_lod_levels():
    assert lod_level(0.01, tip_radius=0.01) == 10
    assert lod_level(0.5, tip_radius=0.01) == 64
    np.testing.assert_array_equal(lod_level([0.001, 10.0], tip_radius=0.01), [10, 64])
    np.testing.assert_array_equal(lod_level([0.01, 0.5], tip_radius=0.01, lod=(6, 32)), [6, 32])
    assert 10 < lod_level(0.25, tip_radius=0.01) < 64


def test_lod_option_reduces_triangles(tree):
    pos, parent, radius, mc = tree
    full = build_branch_mesh(pos, parent, radius, main_child=mc)
    fast = build_branch_mesh(pos, parent, radius, main_child=mc, lod=(6, 32))
    assert len(fast.faces) < 0.7 * len(full.faces)
    assert full.counts.min() == 10 and fast.counts.min() == 6


# ---- twins ----------------------------------------------------------------------------------------
def test_kernel_twins_agree(tree):
    pos, parent, radius, mc = tree
    alive = np.ones(len(pos), bool)
    alive[np.random.default_rng(1).choice(np.arange(5, len(pos)), 10)] = False
    for main in (mc, np.zeros(0, np.int64)):
        a = K._unfold_numba(pos, parent, alive, main, 1.3)
        b = K._unfold_numpy(pos, parent, alive, main, 1.3)
        for x, y in zip(a, b):
            np.testing.assert_allclose(x, y, atol=1e-13)
    m1 = build_branch_mesh(pos, parent, radius, alive=alive, main_child=mc, kernel="numba")
    m2 = build_branch_mesh(pos, parent, radius, alive=alive, main_child=mc, kernel="numpy")
    np.testing.assert_allclose(m1.vertices, m2.vertices, atol=1e-12)
    np.testing.assert_allclose(m1.normals, m2.normals, atol=1e-6)
    np.testing.assert_allclose(m1.uv, m2.uv, atol=1e-6)
    np.testing.assert_array_equal(m1.faces, m2.faces)
    np.testing.assert_array_equal(m1.node_id, m2.node_id)


def test_dead_subtrees_are_skipped(tree):
    pos, parent, radius, mc = tree
    alive = np.ones(len(pos), bool)
    alive[3] = False
    m = build_branch_mesh(pos, parent, radius, alive=alive, main_child=mc)
    sub = np.zeros(len(pos), bool)
    sub[3] = True
    for i in range(4, len(pos)):
        sub[i] = sub[parent[i]]
    assert not np.isin(m.node_id, np.flatnonzero(sub)).any()


# ---- incremental ----------------------------------------------------------------------------------
def _assert_same(a, b):
    for k in ("vertices", "normals", "uv", "node_id", "faces"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)


def test_incremental_update_equals_full_build(tree):
    pos, parent, radius, mc = tree
    m = build_branch_mesh(pos, parent, radius, main_child=mc, tip_radius=0.01)
    # 1) small radius change, same layout: in place, few segments
    r2 = radius.copy()
    r2[200] *= 1.001
    m1, changed = update_branch_mesh(m, pos, parent, r2, main_child=mc)
    full = build_branch_mesh(pos, parent, r2, main_child=mc, tip_radius=0.01)
    _assert_same(m1, full)
    assert 0 < len(changed) <= 4
    # 2) growth: append two internodes at a tip and thicken its parent chain, new layout
    tip = int(np.flatnonzero(np.bincount(parent[1:], minlength=len(pos)) == 0)[-1])
    pos3 = np.vstack([pos, pos[tip] + [0, 0.3, 0], pos[tip] + [0.2, 0.4, 0]])
    parent3 = np.concatenate([parent, [tip, len(pos)]])
    radius3 = np.concatenate([r2, [0.01, 0.01]])
    radius3[tip] = 0.013
    mc3 = np.concatenate([mc, [len(pos) + 1, -1]])
    mc3[tip] = len(pos)
    m2, changed2 = update_branch_mesh(m1, pos3, parent3, radius3, main_child=mc3)
    _assert_same(m2, build_branch_mesh(pos3, parent3, radius3, main_child=mc3, tip_radius=0.01))
    assert len(changed2) < 0.1 * len(m2.segments)
    # 3) pruning a subtree
    alive = np.ones(len(pos3), bool)
    alive[5] = False
    m3, _ = update_branch_mesh(m2, pos3, parent3, radius3, alive=alive, main_child=mc3)
    _assert_same(m3, build_branch_mesh(pos3, parent3, radius3, alive=alive, main_child=mc3, tip_radius=0.01))


# ---- validation -----------------------------------------------------------------------------------
def test_invalid_inputs_are_rejected(tree):
    pos, parent, radius, mc = tree
    bad_parent = parent.copy()
    bad_parent[10] = 20
    with pytest.raises(ValueError, match="parent must"):
        build_branch_mesh(pos, bad_parent, radius)
    with pytest.raises(ValueError, match="radius must be > 0"):
        build_branch_mesh(pos, parent, -radius)
    with pytest.raises(ValueError, match=r"u_steps must be an integer in \[1, 64\]"):
        build_branch_mesh(pos, parent, radius, u_steps=0)
    with pytest.raises(ValueError, match="lod must be a pair"):
        build_branch_mesh(pos, parent, radius, lod=10)
    with pytest.raises(ValueError, match=r"lod\[1\] must be an integer in \[10, 64\]"):
        build_branch_mesh(pos, parent, radius, lod=(10, 8))
    with pytest.raises(ValueError, match="bezier_w must be in"):
        build_branch_mesh(pos, parent, radius, bezier_w=0)
    with pytest.raises(ValueError, match="pos must have shape"):
        build_branch_mesh(pos[:, :2], parent, radius)
    with pytest.raises(ValueError, match="kernel must be one of"):
        build_branch_mesh(pos, parent, radius, kernel="cuda")


def test_record_kernel_twins_agree(tree):
    pos, parent, radius, mc = tree
    alive = np.ones(len(pos), bool)
    alive[[7, 30, 31]] = False
    un = K._unfold_numba(pos, parent, alive, mc, 0.7)
    a = K._records_numba(pos, parent, radius, *un[:4][:1], *un[1:], 3.0, 0.7)
    b = K._records_numpy(pos, parent, radius, *un[:4][:1], *un[1:], 3.0, 0.7)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


# ---- forests: a turtle move before F starts a second tree (parent -1 at a node > 0) ----------------------
def test_forest_meshes_as_its_trees_meshed_one_by_one():
    """A forest's branch mesh is the union of its trees' meshes: each tree meshed alone is the oracle."""
    a = random_tree(40, seed=3, tip_radius=0.01)
    b = random_tree(30, seed=5, tip_radius=0.01)
    shift = np.array([5.0, 0.0, 0.0])
    n = len(a[0])
    pos = np.vstack([a[0], b[0] + shift])
    parent = np.concatenate([a[1], np.where(b[1] < 0, -1, b[1] + n)])
    radius = np.concatenate([a[2], b[2]])
    mc = np.concatenate([a[3], np.where(b[3] < 0, -1, b[3] + n)])
    forest = build_branch_mesh(pos, parent, radius, main_child=mc)
    ma = build_branch_mesh(*a[:3], main_child=a[3])
    mb = build_branch_mesh(*b[:3], main_child=b[3])
    assert len(forest.vertices) == len(ma.vertices) + len(mb.vertices)
    assert len(forest.faces) == len(ma.faces) + len(mb.faces)
    first = forest.node_id < n
    np.testing.assert_allclose(forest.vertices[first], ma.vertices, atol=1e-12)
    np.testing.assert_allclose(forest.vertices[~first], mb.vertices + shift, atol=1e-12)
    assert trimesh.Trimesh(forest.vertices, forest.faces, process=False).is_winding_consistent


def test_forest_root_without_children_draws_nothing():
    pos = [[0, 0, 0], [0, 1, 0], [3, 0, 0]]        # the last node: a root (parent -1) with no internode
    m = build_branch_mesh(pos, [-1, 0, -1], [0.1, 0.1, 0.0])
    assert set(np.unique(m.node_id)) == {1} and np.isfinite(m.vertices).all()   # the one internode 0 → 1

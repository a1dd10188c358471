"""Tests for plantvr.growth.colonize (issue 13; spec 003_implicit_sca §1.3–1.4 V22–V24, 000_treewand §2.3 TW-V5/V6)."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from plantvr.growth import _colonize_kernels as K
from plantvr.growth.colonize import (
    SpaceColonizer,
    TreeWandAssigner,
    assign_treewand,
    assign_treewand_reference,
    space_colonization,
    space_colonization_reference,
)


def _ball(n, rng, radius=10.0, centre=(0.0, 0.0, 10.0)):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    return v * radius * rng.random(n)[:, None] ** (1 / 3) + np.asarray(centre)


def _scene(seed, n, kind):
    rng = np.random.default_rng(seed)
    if kind == "ball":
        return _ball(n, rng, 3.0, (0, 0, 3.0))
    if kind == "box":
        return rng.uniform(-2, 2, size=(n, 3)) + [0, 0, 2.5]
    if kind == "lattice":  # integer/half-integer coordinates: many exact distance ties
        return rng.integers(-4, 5, size=(n, 3)).astype(np.float64) * 0.5 + [0, 0, 2.0]
    return np.concatenate([rng.normal(size=(n // 2 + 1, 3)) * 0.3 + c for c in ([1, 0, 2], [-1, 0.5, 3])])[:n]


def _assert_same(a, b):
    assert a.steps == b.steps and a.growth_steps == b.growth_steps
    np.testing.assert_array_equal(a.parent, b.parent)
    np.testing.assert_array_equal(a.nodes, b.nodes)  # bit-identical, not just close
    np.testing.assert_array_equal(a.markers_left, b.markers_left)


# ---------------------------------------------------------------------------------------------- classic mode
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(1, 250),
       kind=st.sampled_from(["ball", "box", "lattice", "clusters"]),
       di=st.floats(0.4, 4.0), kf=st.floats(0.05, 0.95), step=st.floats(0.05, 1.0),
       limit=st.one_of(st.none(), st.integers(1, 3)), nroots=st.integers(1, 3))
def test_kernel_equals_ckdtree_reference(seed, n, kind, di, kf, step, limit, nroots):
    markers = _scene(seed, n, kind)
    roots = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-1.0, 0.5, 0.0]])[:nroots]
    kw = dict(influence_radius=di, kill_radius=kf * di, step_size=step, max_steps=40, children_limit=limit)
    _assert_same(space_colonization(markers, roots, **kw), space_colonization_reference(markers, roots, **kw))


@pytest.mark.parametrize("limit", [None, 2])
def test_kernel_equals_reference_ball_3000(limit):
    markers = _ball(3000, np.random.default_rng(1))
    kw = dict(influence_radius=3.0, kill_radius=0.5, step_size=0.25, children_limit=limit)
    a = space_colonization(markers, [0, 0, 0], **kw)
    _assert_same(a, space_colonization_reference(markers, [0, 0, 0], **kw))
    assert a.steps > 50 and len(a.nodes) > 3000


def test_v22_step_invariants():
    markers = _ball(2000, np.random.default_rng(2))
    di, dk, d = 3.0, 0.6, 0.3
    res = space_colonization(markers, [0, 0, 0], influence_radius=di, kill_radius=dk, step_size=d)
    nodes, parent = res.nodes, res.parent
    assert parent[0] == -1 and np.all(parent[1:] >= 0) and np.all(parent[1:] < np.arange(1, len(parent)))
    np.testing.assert_allclose(np.linalg.norm(nodes[1:] - nodes[parent[1:]], axis=1), d, rtol=1e-12)
    dist, _ = cKDTree(nodes).query(res.markers_left)
    assert np.all(dist >= dk)
    # no node repeats a sibling (duplicate guard)
    for v in np.unique(parent[1:]):
        kids = nodes[parent == v]
        if len(kids) > 1:
            assert cKDTree(kids).query(kids, k=2)[0][:, 1].min() >= K.DUP_FRACTION * d
    assert len(res.step_ms) == res.steps and np.all(res.step_ms >= 0)


def test_v22_first_step_direction_is_normalized_sum():
    rng = np.random.default_rng(3)
    markers = rng.uniform(-1, 1, size=(40, 3)) + [0, 0, 1.5]
    di, dk, d = 2.0, 0.2, 0.1
    sc = SpaceColonizer(markers, [0, 0, 0], influence_radius=di, kill_radius=dk, step_size=d)
    inside = markers[np.linalg.norm(markers, axis=1) < di]
    u = (inside / np.linalg.norm(inside, axis=1)[:, None]).sum(axis=0)
    sc.step()
    np.testing.assert_allclose(sc.nodes[1], d * u / np.linalg.norm(u), atol=1e-10)


def test_v23_toy_first_iteration():
    # one root, three markers (Fig. 2.1 style, 2D in the z = 0 plane)
    markers = np.array([[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.4, 0.0]])
    sc = SpaceColonizer(markers, [0, 0, 0], influence_radius=5.0, kill_radius=0.35, step_size=0.1)
    added, killed = sc.step()
    assert added == 1
    np.testing.assert_allclose(sc.nodes[1], [0.0, 0.1, 0.0], atol=1e-10)  # x pulls cancel; all point up
    assert killed == 1 and len(sc.markers_left) == 2  # (0, 0.4) is within 0.35 of the new node
    np.testing.assert_array_equal(sc.markers_left, markers[:2])


def test_v24_termination_ball_and_trap():
    markers = _ball(3000, np.random.default_rng(4))
    res = space_colonization(markers, [0, 0, 0], influence_radius=4.0, kill_radius=1.0, step_size=0.5,
                             max_steps=1000)
    assert res.steps < 200 and len(res.markers_left) <= 0.01 * 3000
    # symmetric two-marker trap: the root's pull never reaches the markers; the guard stops repetition
    trap = np.array([[1.0, 0.0, 0.05], [-1.0, 0.0, 0.05]])
    res = space_colonization(trap, [0, 0, 0], influence_radius=3.0, kill_radius=0.5, step_size=0.5, max_steps=1000)
    assert len(res.nodes) == 2 and res.steps == 1 and len(res.markers_left) == 2
    # exact cancellation: no growth at all
    res = space_colonization(np.array([[1.0, 0, 0], [-1.0, 0, 0]]), [0, 0, 0], influence_radius=3.0,
                             kill_radius=0.5, step_size=0.5)
    assert len(res.nodes) == 1 and res.steps == 0


def test_children_limit_and_stall_and_max_steps():
    markers = _ball(1500, np.random.default_rng(5))
    kw = dict(influence_radius=3.0, kill_radius=0.5, step_size=0.25)
    res = space_colonization(markers, [0, 0, 0], children_limit=1, **kw)
    assert np.bincount(res.parent[1:]).max() == 1  # an unbranched chain
    res = space_colonization(markers, [0, 0, 0], max_steps=7, **kw)
    assert res.steps == 7
    full = space_colonization(markers, [0, 0, 0], **kw)
    stalled = space_colonization(markers, [0, 0, 0], stall_steps=1, **kw)
    assert stalled.steps <= full.steps
    assert full.growth_steps <= full.steps


def test_multiple_roots_and_single_root_vector():
    markers = _ball(500, np.random.default_rng(6), 3.0, (0, 0, 4.0))
    a = space_colonization(markers, [0, 0, 0], influence_radius=3.0, kill_radius=0.5, step_size=0.25)
    b = space_colonization(markers, [[0, 0, 0]], influence_radius=3.0, kill_radius=0.5, step_size=0.25)
    _assert_same(a, b)
    c = space_colonization(markers, [[0, 0, 0], [0, 0, 8.0]], influence_radius=3.0, kill_radius=0.5, step_size=0.25)
    assert np.sum(c.parent == -1) == 2


def test_markers_killed_at_setup_and_far_markers_stay():
    markers = np.array([[0.0, 0.0, 0.1], [50.0, 0.0, 0.0]])
    res = space_colonization(markers, [0, 0, 0], influence_radius=2.0, kill_radius=0.5, step_size=0.25)
    assert res.steps == 0 and len(res.nodes) == 1
    np.testing.assert_array_equal(res.markers_left, markers[1:])


def test_per_marker_state_bytes():
    markers = _ball(20000, np.random.default_rng(7))
    sc = SpaceColonizer(markers, [0, 0, 0], influence_radius=3.0, kill_radius=0.5, step_size=0.25)
    state = (sc.orig.nbytes + sc.owner.nbytes + sc.best.nbytes + sc.cell_start.nbytes + sc.cell_live.nbytes
             + sc.cell_maxbest.nbytes)
    assert state / len(markers) <= 32


# ---------------------------------------------------------------------------------------------- numpy twins
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_add_nodes_kernel_matches_numpy_twin(seed):
    rng = np.random.default_rng(seed)
    markers = rng.uniform(-3, 3, size=(800, 3))
    nodes = np.zeros((64, 3))
    nodes[:20] = rng.uniform(-3, 3, size=(20, 3))
    di2, dk2 = 1.2 ** 2, 0.3 ** 2
    sc = SpaceColonizer(markers, nodes[:1], influence_radius=1.2, kill_radius=0.3, step_size=0.1)
    sc._nodes[:20] = nodes[:20]
    sc.n = 20
    killed_k, n_dirty = K.add_nodes_kernel(sc._nodes, 1, 20, sc.origin, sc.h, sc.dims, sc.reach, sc.cell_start,
                                           sc.cell_live, sc.cell_maxbest, sc.pos_s, sc.orig, sc.owner, sc.best,
                                           sc._acc, sc._dirty_flag, sc._dirty_list, sc.n_dirty, di2, dk2)
    # twin, from the same state after the root was offered
    alive = np.ones(800, bool)
    owner = np.full(800, -1, np.int64)
    best = np.full(800, np.inf)
    acc = np.zeros((64, 3), np.int64)
    K.add_nodes_numpy(nodes, 0, 1, markers, alive, owner, best, acc, di2, dk2)
    killed_n, dirty = K.add_nodes_numpy(nodes, 1, 20, markers, alive, owner, best, acc, di2, dk2)
    assert killed_k == killed_n
    live = sc.live_index
    np.testing.assert_array_equal(live, np.flatnonzero(alive))
    inv = np.empty(800, np.int64)
    inv[sc.orig] = np.arange(800)
    np.testing.assert_array_equal(sc.owner[inv[live]], owner[live])
    np.testing.assert_array_equal(sc.best[inv[live]], best[live])
    np.testing.assert_array_equal(sc._acc[:20], acc[:20])
    assert set(dirty.tolist()) <= set(sc._dirty_list[:n_dirty].tolist())


def test_grow_kernel_matches_numpy_twin():
    rng = np.random.default_rng(8)
    n, cap = 30, 100
    nodes = np.zeros((cap, 3))
    nodes[:n] = rng.normal(size=(n, 3))
    parent = np.full(cap, -1, np.int64)
    first, nxt, nch = np.full(cap, -1, np.int32), np.full(cap, -1, np.int32), np.zeros(cap, np.int32)
    acc = np.zeros((cap, 3), np.int64)
    acc[:n] = rng.integers(-2 ** 40, 2 ** 40, size=(n, 3))
    acc[5] = 0  # cancelling pull
    dirty = np.zeros(cap, np.int64)
    cand = rng.permutation(n)[:20]
    dirty[:20] = cand
    flag = np.zeros(cap, np.uint8)
    flag[cand] = 1
    children = [[] for _ in range(n)]
    for lim in (-1, 1):
        m = K.grow_kernel(nodes, parent, first, nxt, nch, n, acc, dirty, 20, flag, lim, 0.3, 1e-6)
        ref_nodes, ref_parent = K.grow_numpy(nodes[:n], parent[:n], children, acc, cand, lim, 0.3, 1e-6)
        np.testing.assert_array_equal(nodes[:m], ref_nodes)
        np.testing.assert_array_equal(parent[:m], ref_parent)
        assert not flag.any()
        n = m
        dirty[:20] = cand
        flag[cand] = 1
    assert m > 30


# ---------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("kwargs, match", [
    (dict(markers=np.zeros((0, 3))), "markers must have at least 1 rows"),
    (dict(markers=np.array([[np.nan, 0, 0]])), "markers must contain only finite"),
    (dict(markers=np.zeros((4, 2))), r"markers must have shape \(N, 3\)"),
    (dict(roots=np.zeros((1, 2))), r"roots must have shape \(N, 3\)"),
    (dict(roots=np.zeros((0, 3))), "roots must have at least 1 rows"),
    (dict(influence_radius=0.0), r"influence_radius must be in \(0.0, inf\)"),
    (dict(influence_radius=-1.0), r"influence_radius must be in \(0.0, inf\)"),
    (dict(influence_radius=np.inf), r"influence_radius must be in \(0.0, inf\)"),
    (dict(kill_radius=0.0), r"kill_radius must be in \(0.0, 3.0\)"),
    (dict(kill_radius=3.0), r"kill_radius must be in \(0.0, 3.0\)"),
    (dict(kill_radius=5.0), r"kill_radius must be in \(0.0, 3.0\)"),
    (dict(step_size=0.0), r"step_size must be in \(0.0, inf\)"),
    (dict(max_steps=-1), r"max_steps must be an integer in \[0, "),
    (dict(children_limit=0), r"children_limit must be an integer in \[1, "),
    (dict(stall_steps=0), r"stall_steps must be an integer in \[1, "),
])
@pytest.mark.parametrize("fn", [space_colonization, space_colonization_reference])
def test_bad_input(fn, kwargs, match):
    args = dict(markers=np.ones((5, 3)), roots=[0, 0, 0], influence_radius=3.0, kill_radius=0.5, step_size=0.25)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        fn(**args)


def test_bad_treewand_input():
    m, p, d, ln = np.ones((3, 3)), np.zeros((2, 3)), np.tile([0, 0, 1.0], (2, 1)), np.ones(2)
    with pytest.raises(ValueError, match=r"view_radius must be in \(0.0, inf\)"):
        assign_treewand(m, p, d, ln, view_radius=0.0, view_angle=1.0)
    with pytest.raises(ValueError, match=r"view_angle must be in \[0.0, 6.28"):
        assign_treewand(m, p, d, ln, view_radius=1.0, view_angle=7.0)
    with pytest.raises(ValueError, match=r"bud_dir must have shape \(2, 3\)"):
        assign_treewand(m, p, d[:1], ln, view_radius=1.0, view_angle=1.0)
    with pytest.raises(ValueError, match=r"bud_len must be in \(0, inf\)"):
        assign_treewand(m, p, d, [1.0, 0.0], view_radius=1.0, view_angle=1.0)
    with pytest.raises(ValueError, match="bud_dir must be non-zero"):
        assign_treewand(m, p, np.zeros((2, 3)), ln, view_radius=1.0, view_angle=1.0)
    with pytest.raises(ValueError, match="markers must contain only finite"):
        assign_treewand([[np.nan, 0, 0]], p, d, ln, view_radius=1.0, view_angle=1.0)


# ---------------------------------------------------------------------------------------------- Tree Wand
@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), m=st.integers(0, 300), b=st.integers(0, 40),
       lattice=st.booleans(), vr=st.floats(0.2, 3.0),
       angle=st.one_of(st.sampled_from([0.0, math.pi / 2, math.pi, 2 * math.pi]), st.floats(0.0, 2 * math.pi)))
def test_tw_v5_assignment_equals_brute_force(seed, m, b, lattice, vr, angle):
    rng = np.random.default_rng(seed)
    if lattice:  # exact ties in d and d/l; duplicated buds
        markers = rng.integers(-3, 4, size=(m, 3)).astype(np.float64)
        pos = rng.integers(-3, 4, size=(b, 3)).astype(np.float64)
        if b > 1:
            pos[-1] = pos[0]
        dirs = rng.integers(-1, 2, size=(b, 3)).astype(np.float64)
        dirs[np.all(dirs == 0, axis=1)] = [0, 0, 1]
        lens = rng.choice([0.5, 1.0, 2.0], size=b)
    else:
        markers = rng.uniform(-3, 3, size=(m, 3))
        pos = rng.uniform(-3, 3, size=(b, 3))
        dirs = rng.normal(size=(b, 3)) + 1e-3
        lens = rng.uniform(0.1, 2.0, size=b)
    kw = dict(view_radius=vr, view_angle=angle)
    np.testing.assert_array_equal(assign_treewand(markers, pos, dirs, lens, **kw),
                                  assign_treewand_reference(markers, pos, dirs, lens, **kw))


def test_tw_v6_perception_and_d_over_l():
    rng = np.random.default_rng(9)
    markers = rng.uniform(-2, 2, size=(3000, 3))
    pos = np.zeros((1, 3))
    owner = assign_treewand(markers, pos, [[0, 0, 1.0]], [1.0], view_radius=1.5, view_angle=math.pi / 2)
    v = markers - pos
    d = np.linalg.norm(v, axis=1)
    inside = (d <= 1.5) & (v[:, 2] >= d * math.cos(math.pi / 4)) & (d > 0)
    np.testing.assert_array_equal(owner == 0, inside)  # nothing outside radius or cone, everything inside
    # equal distance: the longer-internode bud wins; equal d/l: the lower index wins
    mk = np.array([[0.0, 0.0, 1.0]])
    two = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
    dirs = np.array([[0, 0, 1.0], [0, 0, -1.0]])
    assert assign_treewand(mk, two, dirs, [1.0, 2.0], view_radius=2, view_angle=1.0)[0] == 1
    assert assign_treewand(mk, two, dirs, [2.0, 1.0], view_radius=2, view_angle=1.0)[0] == 0
    assert assign_treewand(mk, two, dirs, [1.0, 1.0], view_radius=2, view_angle=1.0)[0] == 0


def test_treewand_assigner_kill_within_and_reuse():
    rng = np.random.default_rng(10)
    markers = rng.uniform(-3, 3, size=(5000, 3))
    ta = TreeWandAssigner(markers, view_radius=1.0, view_angle=math.pi)
    nodes = rng.uniform(-3, 3, size=(50, 3))
    killed = ta.kill_within(nodes, 0.4)
    near = cKDTree(nodes).query(markers)[0] < 0.4
    assert killed == near.sum()
    np.testing.assert_array_equal(ta.alive, ~near)
    pos, dirs, lens = rng.uniform(-3, 3, size=(80, 3)), rng.normal(size=(80, 3)), rng.uniform(0.2, 1, 80)
    owner = ta.assign(pos, dirs, lens)
    ref = assign_treewand_reference(markers[~near], pos, dirs, lens, view_radius=1.0, view_angle=math.pi)
    np.testing.assert_array_equal(owner[~near], ref)
    assert np.all(owner[near] == -1)


@pytest.mark.parametrize("seed", range(8))
def test_tw_v5_incremental_update_equals_brute_force(seed):
    rng = np.random.default_rng(seed)
    lattice = seed % 2 == 1
    m = int(rng.integers(1, 1500))
    markers = rng.integers(-4, 5, size=(m, 3)).astype(float) if lattice else rng.uniform(-4, 4, size=(m, 3))
    vr, ang = float(rng.uniform(0.5, 3)), float(rng.choice([math.pi / 2, math.pi, 2 * math.pi]))
    ta = TreeWandAssigner(markers, view_radius=vr, view_angle=ang)

    def buds(k):
        if lattice:
            d = rng.integers(-1, 2, size=(k, 3)).astype(float)
            d[np.all(d == 0, axis=1)] = [0, 0, 1]
            return rng.integers(-5, 6, size=(k, 3)).astype(float), d, rng.choice([0.5, 1.0, 2.0], size=k)
        return rng.uniform(-5, 5, size=(k, 3)), rng.normal(size=(k, 3)) + 1e-3, rng.uniform(0.1, 2, size=k)

    pos, dirs, lens = buds(int(rng.integers(1, 40)))
    alive = rng.random(len(pos)) < 0.8
    ta.update(pos, dirs, lens, None, alive=alive)
    killed = np.zeros(m, bool)
    for _ in range(6):
        ch = rng.choice(len(pos), size=int(rng.integers(0, len(pos) + 1)), replace=False)
        p2, d2, l2 = buds(len(ch))
        sel = rng.random(len(ch)) < 0.5
        pos[ch[sel]], dirs[ch[sel]], lens[ch[sel]] = p2[sel], d2[sel], l2[sel]
        alive[ch[~sel]] = ~alive[ch[~sel]]
        k = int(rng.integers(0, 5))
        pa, da, la = buds(k)
        new = np.arange(len(pos), len(pos) + k)
        pos, dirs = np.vstack([pos, pa]), np.vstack([dirs, da])
        lens, alive = np.concatenate([lens, la]), np.concatenate([alive, rng.random(k) < 0.8])
        pts = rng.uniform(-4, 4, size=(3, 3))
        ta.kill_within(pts, min(0.5, vr))
        killed |= cKDTree(pts).query(markers)[0] < min(0.5, vr)
        owner = ta.update(pos, dirs, lens, np.concatenate([ch, new]), alive=alive)
        ids = np.flatnonzero(alive)
        ref = assign_treewand_reference(markers, pos[ids], dirs[ids], lens[ids], view_radius=vr, view_angle=ang)
        ref = np.where(ref >= 0, ids[np.maximum(ref, 0)], -1)
        ref[killed] = -1
        np.testing.assert_array_equal(owner, ref)


@pytest.mark.parametrize("angle", [0.05, math.pi / 3, math.pi / 2 - 1e-9, math.pi / 2, 1.5 * math.pi])
def test_tw_v5_cone_cell_culling_is_conservative(angle):
    """Dense markers (many per grid cell) around buds whose cones graze cell corners: culling loses nothing."""
    rng = np.random.default_rng(11)
    markers = rng.uniform(-3, 3, size=(40_000, 3))
    pos = rng.uniform(-2, 2, size=(60, 3))
    dirs = rng.normal(size=(60, 3))
    dirs[:6] = np.concatenate([np.eye(3), -np.eye(3)])  # axis-aligned headings hit cell faces exactly
    lens = rng.uniform(0.5, 1.5, 60)
    kw = dict(view_radius=2.0, view_angle=angle)
    owner = assign_treewand(markers, pos, dirs, lens, **kw)
    np.testing.assert_array_equal(owner, assign_treewand_reference(markers, pos, dirs, lens, **kw))
    assert (owner >= 0).sum() > 0


def test_marker_state_is_at_most_32_bytes_per_marker():
    """Issue 13: per-marker state beyond the position (grid included) stays within 32 bytes."""
    markers = np.random.default_rng(12).uniform(-10, 10, size=(50_000, 3))
    sc = SpaceColonizer(markers, np.zeros(3), influence_radius=3.0, kill_radius=0.5, step_size=0.25)
    ta = TreeWandAssigner(markers, view_radius=3.0, view_angle=math.pi / 2)
    assert sc.state_bytes_per_marker <= 32 and ta.state_bytes_per_marker <= 32

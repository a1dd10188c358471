"""Incremental branch mesh: slot layout with slack, update == full rebuild (spec 000_treewand §3.5, item 20)."""
import numpy as np
import pytest

from plantvr.geometry import IncrementalBranchMesh, build_branch_mesh
from plantvr.geometry import _kernels as K

from ._trees import random_tree

TIP = 0.01


@pytest.fixture(scope="module")
def big():
    return random_tree(300, seed=11, tip_radius=TIP)


def _history(tree, n):
    """The tree after its first ``n`` nodes grew (nodes are appended in index order), pipe radii recomputed."""
    pos, parent, _, mc = tree
    p, pa = pos[:n], parent[:n]
    m = np.where(mc[:n] < n, mc[:n], -1)
    acc = np.zeros(n)
    r = np.zeros(n)
    for i in range(n - 1, 0, -1):
        acc[i] = acc[i] or TIP ** 2.5
        r[i] = acc[i] ** (1 / 2.5)
        if pa[i] > 0:
            acc[pa[i]] += acc[i]
    r[0] = r[1]
    return p, pa, r, m


def _assert_same(a, b):
    for k in ("vertices", "normals", "uv", "node_id", "faces", "counts", "v_off", "f_off"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    for k in ("records", "nodes", "keys", "axis", "caps"):
        np.testing.assert_array_equal(getattr(a.segments, k), getattr(b.segments, k), err_msg=k)


def _visible(v, f):
    """Sorted rows of the corner coordinates of every non-degenerate triangle."""
    f = f[(f[:, 0] != f[:, 1]) | (f[:, 1] != f[:, 2])]
    tri = v[f].reshape(len(f), 9)
    return tri[np.lexsort(tri.T[::-1])]


def test_growth_updates_equal_full_rebuild(big):
    inc = IncrementalBranchMesh(*_history(big, 40)[:3], main_child=_history(big, 40)[3], tip_radius=TIP)
    n_changed = []
    for n in range(43, 302, 13):
        p, pa, r, m = _history(big, n)
        upd = inc.update(p, pa, r, main_child=m)
        full = build_branch_mesh(p, pa, r, main_child=m, tip_radius=TIP)
        _assert_same(inc.to_branch_mesh(), full)
        # what a view shows (live buffers with free blocks and slack) is exactly the tree
        np.testing.assert_array_equal(_visible(inc.vertices, inc.faces), _visible(full.vertices, full.faces))
        assert upd.n_vertices == len(inc.vertices) and upd.n_faces == len(inc.faces)
        assert np.isfinite(inc.vertices).all() and np.isfinite(inc.normals).all()
        n_changed.append(len(upd.changed) / len(full.segments))
    assert np.median(n_changed) < 0.5                 # growth steps touch a part of the tree, not all of it


def test_radius_change_rewrites_only_its_blocks(big):
    p, pa, r, m = _history(big, 200)
    inc = IncrementalBranchMesh(p, pa, r, main_child=m, tip_radius=TIP)
    before = [a.copy() for a in (inc.vertices, inc.normals, inc.uv, inc.node_id, inc.faces)]
    r2 = r.copy()
    r2[150] *= 1.2
    upd = inc.update(p, pa, r2, main_child=m)
    assert not upd.relayout and 1 <= len(upd.changed) <= 4 and len(upd.removed) == 0
    assert set(upd.changed.tolist()) <= {300, 301} | {2 * c for c in np.flatnonzero(pa == 150)}
    vmask = np.zeros(len(inc.vertices), bool)
    for a, b in upd.vertex_ranges:
        vmask[a:b] = True
    fmask = np.zeros(len(inc.faces), bool)
    for a, b in upd.face_ranges:
        fmask[a:b] = True
    after = (inc.vertices, inc.normals, inc.uv, inc.node_id, inc.faces)
    for x, y in zip(before[:4], after[:4]):
        np.testing.assert_array_equal(x[~vmask], y[~vmask])
    np.testing.assert_array_equal(before[4][~fmask], after[4][~fmask])
    assert not np.array_equal(before[0][vmask], after[0][vmask])
    _assert_same(inc.to_branch_mesh(), build_branch_mesh(p, pa, r2, main_child=m, tip_radius=TIP))


def test_ring_count_growth_moves_block_then_compacts(big):
    p, pa, r, m = _history(big, 200)
    inc = IncrementalBranchMesh(p, pa, r, main_child=m, tip_radius=TIP, slack=0.0, max_waste=0.05)
    v0 = inc.buffer_version
    r2 = r.copy()
    r2[1:] *= 1.5                                      # every ring count grows: nothing fits without slack
    upd = inc.update(p, pa, r2, main_child=m)
    assert upd.relayout and inc.buffer_version > v0    # re-laid out in full (everything moved)
    _assert_same(inc.to_branch_mesh(), build_branch_mesh(p, pa, r2, main_child=m, tip_radius=TIP))
    r3 = r2.copy()
    r3[[20, 60, 100]] *= 3.0                           # a few blocks outgrow their slots and move to the end
    upd = inc.update(p, pa, r3, main_child=m)
    assert len(upd.changed) < 12
    full = build_branch_mesh(p, pa, r3, main_child=m, tip_radius=TIP)
    _assert_same(inc.to_branch_mesh(), full)
    np.testing.assert_array_equal(_visible(inc.vertices, inc.faces), _visible(full.vertices, full.faces))
    inc.compact()
    assert inc.waste == 0.0
    _assert_same(inc.to_branch_mesh(), full)


def test_pruning_and_renumbering(big):
    p, pa, r, m = _history(big, 250)
    inc = IncrementalBranchMesh(p, pa, r, main_child=m, tip_radius=TIP)
    alive = np.ones(len(p), bool)
    alive[[9, 40]] = False
    upd = inc.update(p, pa, r, alive=alive, main_child=m)
    assert len(upd.removed) > 0 and not upd.relayout
    full = build_branch_mesh(p, pa, r, alive=alive, main_child=m, tip_radius=TIP)
    _assert_same(inc.to_branch_mesh(), full)
    np.testing.assert_array_equal(_visible(inc.vertices, inc.faces), _visible(full.vertices, full.faces))
    assert (inc.node_id[inc.faces[:, 0]][inc.faces[:, 0] != inc.faces[:, 1]] >= 0).all()
    # a snapshot after pruning: live nodes compacted, so most keys move -> full re-layout
    eff = alive.copy()
    for i in range(1, len(p)):
        eff[i] = eff[i] and eff[pa[i]]
    live = np.flatnonzero(eff)
    remap = np.full(len(p), -1)
    remap[live] = np.arange(len(live))
    pa2 = np.where(pa[live] >= 0, remap[np.maximum(pa[live], 0)], -1)
    m2 = np.where(m[live] >= 0, remap[np.maximum(m[live], 0)], -1)
    upd = inc.update(p[live], pa2, r[live], main_child=m2)
    _assert_same(inc.to_branch_mesh(), build_branch_mesh(p[live], pa2, r[live], main_child=m2, tip_radius=TIP))


def test_buffers_grow_and_slots_are_reused(big):
    p, pa, r, m = _history(big, 30)
    inc = IncrementalBranchMesh(p, pa, r, main_child=m, tip_radius=TIP, max_waste=1.0)
    cap0, ver0 = len(inc._V), inc.buffer_version
    relayouts = 0
    for n in range(31, 301):
        upd = inc.update(*_history(big, n)[:3], main_child=_history(big, n)[3])
        relayouts += upd.relayout
    assert len(inc._V) > cap0 and inc.buffer_version > ver0 and relayouts >= 1
    assert inc.waste < 0.2                             # freed tip halves were taken by new tip halves
    full = build_branch_mesh(*_history(big, 300)[:3], main_child=_history(big, 300)[3], tip_radius=TIP)
    _assert_same(inc.to_branch_mesh(), full)


def test_diff_kernel_twins_agree(big):
    p, pa, r, m = _history(big, 200)
    inc = IncrementalBranchMesh(p, pa, r, main_child=m, tip_radius=TIP)
    p2, pa2, r2, m2 = _history(big, 230)
    from plantvr.geometry.mesh import tree_segments
    seg = tree_segments(p2, pa2, r2, main_child=m2)
    cnt, nv, nf = inc._counts(seg)
    args = (seg.keys, seg.records, cnt, seg.nodes, seg.caps, nv, nf, inc._slot_of_key, inc._rec, inc._cnt,
            inc._nodes, inc._caps, inc._vcap, inc._fcap)
    a, b = K._diff_numba(*args), K._diff_numpy(*args)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert set(np.unique(a[1]).tolist()) >= {0, 1, 3}
    # ring counts and block sizes: the numba pass equals lod_level / ring_counts / the build layout
    from plantvr.geometry.mesh import _layout
    c2, v_off, f_off = _layout(seg, 4, TIP, (10, 64))
    np.testing.assert_array_equal(cnt, c2)
    np.testing.assert_array_equal(nv, np.diff(v_off))
    np.testing.assert_array_equal(nf, np.diff(f_off))


def test_invalid_options_rejected(big):
    p, pa, r, m = _history(big, 20)
    with pytest.raises(ValueError, match=r"slack must be in \[0.0, 4.0\]"):
        IncrementalBranchMesh(p, pa, r, slack=-1)
    with pytest.raises(ValueError, match="max_waste must be in"):
        IncrementalBranchMesh(p, pa, r, max_waste=0)
    inc = IncrementalBranchMesh(p, pa, r, tip_radius=TIP)
    before = inc.vertices.copy()
    with pytest.raises(ValueError, match="radius must be > 0"):
        inc.update(p, pa, -r)
    np.testing.assert_array_equal(inc.vertices, before)

"""Tests for spec 002 §5: extended Rodkaew branching, pipe widths, tubes, compound umbels (V36–V40)."""
import time

import numpy as np
import pytest

from plantvr.flowers.branching import (
    compound_umbel,
    corymb,
    linear_wb,
    pipe_widths,
    rodkaew,
    scale_tree,
    tube_mesh,
)


@pytest.fixture(scope="module")
def trees():
    out = {}
    for interval in (0.0, 0.5, 5.0):
        t0 = time.perf_counter()
        out[interval] = corymb(120, emergence_interval=interval, delta=0.01, merge_dist=0.012, search_radius=0.08,
                               w_b=linear_wb(0.08))
        out[interval].seconds = time.perf_counter() - t0
    return out


def _check_tree(tree):
    depth = tree.depth_to_root()                       # raises on cycles / dangling nodes
    roots = np.flatnonzero(tree.parent < 0)
    assert roots.tolist() == [0]                       # exactly one root: the base A0
    n_edges = int(np.sum(tree.parent >= 0))
    assert n_edges == tree.n_nodes - len(roots)
    assert np.all(depth[tree.tips] > 0)
    return depth


@pytest.mark.parametrize("interval", [0.0, 0.5, 5.0])
def test_v36_v37_every_floret_reaches_one_root_tips_on_canopy(trees, interval):
    tree = trees[interval]
    _check_tree(tree)
    F = tree.pos[tree.tips]
    assert np.std(F[:, 2]) == 0.0 and np.all(F[:, 2] == 1.0)        # planar canopy, tips = florets exactly
    assert np.all(tree.branch_id == 0)                               # every tree carries the base's ID
    assert len(np.unique(tree.tips)) == len(tree.tips)


def test_v38_id_rules(trees):
    for tree in trees.values():
        for child, host, new_id, old_id in tree.grafts:
            assert new_id != old_id or host == 0                     # never grafts onto its own tree
    # graft propagation on a constructed case: two florets side by side, the second grafts onto the first
    t = rodkaew(np.array([[0.0, 0, 1], [0.02, 0, 1]]), [0, 0, 0], emergence=np.array([0.0, 30.0]), delta=0.01,
                merge_dist=0.03, search_radius=0.1)
    _check_tree(t)
    assert any(host != 0 for _, host, _, _ in t.grafts)


def test_v39_umbel_limit_straight_rays_and_architecture(trees):
    F = np.column_stack([np.cos(np.linspace(0, 6, 30)) * 0.5, np.sin(np.linspace(0, 6, 30)) * 0.5, np.ones(30)])
    t = rodkaew(F, [0, 0, 0], w_b=lambda d: 0.0, merge=False, w_h=0.0, delta=0.01)
    _check_tree(t)
    for k, tip in enumerate(t.tips):
        chain = [tip]
        while t.parent[chain[-1]] >= 0:
            chain.append(t.parent[chain[-1]])
        P = t.pos[chain]
        d = P[-1] - P[0]
        resid = np.linalg.norm(np.cross(P - P[0], d / np.linalg.norm(d)), axis=1)
        assert resid.max() <= 1e-9
    # monopodial (slow emergence) vs sympodial (quick): longer mean segment between branch points
    def mean_internode(tree):
        kids = np.bincount(tree.parent[tree.parent >= 0], minlength=tree.n_nodes)
        special = (kids != 1) | (np.arange(tree.n_nodes) == 0)
        return tree.n_nodes / max(special.sum(), 1)
    assert mean_internode(trees[5.0]) > mean_internode(trees[0.0])


def test_v40_pipe_model_and_ffd(trees):
    tree = trees[0.5]
    p = 2.5
    d = pipe_widths(tree, tip_diameter=0.01, p=p)
    kids = [[] for _ in range(tree.n_nodes)]
    for v in np.flatnonzero(tree.parent >= 0):
        kids[tree.parent[v]].append(v)
    for v in range(tree.n_nodes):
        if kids[v]:
            expect = sum(d[c] ** p for c in kids[v]) + (0.01 ** p if v in set(tree.tips.tolist()) else 0.0)
            assert abs(d[v] ** p - expect) <= 1e-12 * max(expect, 1e-30)
    assert np.allclose(d[tree.tips][np.array([len(kids[t]) == 0 for t in tree.tips])], 0.01)
    child = np.flatnonzero(tree.parent >= 0)
    seg = tree.pos[child] - tree.pos[tree.parent[child]]
    big = scale_tree(tree, 1.7)
    seg2 = big.pos[child] - big.pos[big.parent[child]]
    assert np.allclose(np.linalg.norm(seg2, axis=1), 1.7 * np.linalg.norm(seg, axis=1), rtol=1e-12)
    assert np.allclose(seg2 / np.linalg.norm(seg2, axis=1, keepdims=True),
                       seg / np.linalg.norm(seg, axis=1, keepdims=True), atol=1e-12)      # angles kept
    assert np.array_equal(pipe_widths(big, tip_diameter=0.01, p=p), d)                     # widths unchanged
    allo = scale_tree(tree, [1.0, 1.0, 2.0])
    seg3 = allo.pos[child] - allo.pos[allo.parent[child]]
    cos = lambda s: np.einsum("ij,ij->i", s, [[0, 0, 1.0]] * len(s)) / np.linalg.norm(s, axis=1)
    assert np.max(np.abs(cos(seg3) - cos(seg))) > 1e-3                                       # angles change


def test_tube_mesh_and_compound_umbel():
    tree, level = compound_umbel(5, 8, delta=0.02)
    _check_tree(tree)
    assert len(tree.tips) == 40 and set(np.unique(level)) == {1, 2}
    assert np.allclose(np.std(tree.pos[tree.tips][:, 2]), 0.0)
    d = pipe_widths(tree, tip_diameter=0.004, p=3.0)
    v, f = tube_mesh(tree, d, sides=5)
    n_seg = int(np.sum(tree.parent >= 0))
    assert v.shape == (n_seg * 10, 3) and f.shape == (n_seg * 10, 3)
    assert f.min() == 0 and f.max() == len(v) - 1


def test_branching_bad_input():
    with pytest.raises(ValueError, match="delta"):
        rodkaew(np.zeros((2, 3)) + [0, 0, 1], [0, 0, 0], delta=0.0)
    with pytest.raises(ValueError, match="w_a \\+ w_h"):
        rodkaew(np.zeros((2, 3)) + [0, 0, 1], [0, 0, 0], w_a=0.0, w_h=0.0)
    with pytest.raises(ValueError, match="initial_direction"):
        rodkaew(np.zeros((2, 3)) + [0, 0, 1], [0, 0, 0], initial_direction="up")

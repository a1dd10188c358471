"""Issue 22: leaves too short for their joint offsets (spec §2.2 edge case) at crowded joints: tube or stub."""
import warnings

import numpy as np
import pytest

from plantvr.subdivision import build_control_mesh, graph_from_arrays, self_intersections, tree_mesh
from plantvr.subdivision.graph import random_tree

from ._helpers import star_graph
from .test_selfintersect import FIXTURES, qsm_tree


def _quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **k)


def test_joints_without_short_leaves_are_identical_in_every_mode():
    from plantvr.subdivision import parse_lsystem

    graphs = [star_graph(k) for k in (3, 6)] + [parse_lsystem(FIXTURES["tree"], angle=40),
                                                  graph_from_arrays(*random_tree(400, rng=2))]
    for g in graphs:
        ref = build_control_mesh(g, short_leaves="tube")
        for mode in ("auto", "stub"):
            cm = build_control_mesh(g, short_leaves=mode)
            np.testing.assert_array_equal(cm.vertices, ref.vertices)
            np.testing.assert_array_equal(cm.faces, ref.faces)


def test_auto_keeps_the_tube_of_every_short_leaf_that_does_not_fold():
    g = qsm_tree(6)
    tube, auto = _quiet(build_control_mesh, g, short_leaves="tube"), _quiet(build_control_mesh, g)
    stubbed = np.flatnonzero(auto.n_segments == 0)
    assert stubbed.tolist() == [2]                         # only the folding leaf lost its tube
    same = np.ones(len(tube.graph), bool)
    same[stubbed] = False
    np.testing.assert_array_equal(auto.n_segments[same], tube.n_segments[same])
    ids = _quiet(build_control_mesh, g, short_leaves=[2])
    np.testing.assert_array_equal(ids.vertices, auto.vertices)
    np.testing.assert_array_equal(ids.faces, auto.faces)


@pytest.mark.parametrize("seed", [6, 19])
def test_stub_counts_watertight_and_tip_fixed(seed):
    # spec V9/V12 with N = 0 for a stub: V = sum 4 (N + 1), F = sum 8 N + sum (6 k - 4); the tip loop is fixed
    g = qsm_tree(seed)
    cm = _quiet(build_control_mesh, g, short_leaves="stub")
    N, k = cm.n_segments, cm.joint_sizes
    assert (N == 0).sum() > 3
    assert len(cm.vertices) == 4 * (N + 1).sum()
    assert len(cm.faces) == 8 * N.sum() + (6 * k - 4).sum()
    st = np.flatnonzero(N == 0)
    assert np.array_equal(cm.first_loop[st], cm.last_loop[st])
    tip = cm.vertices[cm.last_loop[st]].mean(axis=1)
    np.testing.assert_allclose(tip, cm.graph.end[st], atol=1e-12)
    m = _quiet(tree_mesh, g, levels=2, short_leaves="stub")
    assert m.is_watertight and m.volume > 0


def test_crowded_qsm_levels_1_and_3_do_not_fold():
    for seed in (6, 25, 42):
        for lv in (1, 3):
            m = _quiet(tree_mesh, qsm_tree(seed), levels=lv, fold_level=lv)
            assert len(self_intersections(m.vertices, m.faces)) == 0, (seed, lv)


def test_folds_that_remain_are_named():
    # narrow, thick grown trees fold with and without tubes: the warning names each branch and joint
    g = graph_from_arrays(*random_tree(300, rng=2, branch_angle=20, radius=0.25, p_lateral=0.6))
    with pytest.warns(UserWarning, match=r"still self-intersect at subdivision level 2 \(branch \d+ at joint \d+"):
        build_control_mesh(g, fold_level=2)


def test_short_leaves_bad_input():
    g = qsm_tree(6)
    with pytest.raises(ValueError, match="short_leaves must be one of"):
        build_control_mesh(g, short_leaves="none")
    with pytest.raises(ValueError, match=r"short_leaves must name leaves too short .* got branch 0"):
        _quiet(build_control_mesh, g, short_leaves=[0])
    with pytest.raises(ValueError, match=r"short_leaves"):
        _quiet(build_control_mesh, g, short_leaves=[10_000])
    with pytest.raises(ValueError, match=r"fold_level must be"):
        build_control_mesh(g, fold_level=0)

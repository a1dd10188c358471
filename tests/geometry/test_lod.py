"""LOD chain: decreasing triangle counts, budgets met, bounds kept (spec 000_treewand §3.5; issue 16)."""
import numpy as np
import pytest

from plantvr.geometry import build_branch_mesh
from plantvr.geometry.lod import LOD_RATIOS, axis_start, lod_chain, triangle_count

from ._trees import random_tree


@pytest.fixture(scope="module")
def tree():
    return random_tree(400, seed=3)


@pytest.fixture(scope="module")
def chain(tree):
    pos, parent, radius, mc = tree
    return lod_chain(pos, parent, radius, main_child=mc)


def test_triangle_count_matches_build(tree):
    pos, parent, radius, mc = tree
    for lod, u in [((10, 64), 4), ((4, 12), 2)]:
        m = build_branch_mesh(pos, parent, radius, main_child=mc, lod=lod, u_steps=u)
        assert triangle_count(pos, parent, radius, main_child=mc, lod=lod, u_steps=u) == len(m.faces)


def test_level0_is_full_mesh(tree, chain):
    pos, parent, radius, mc = tree
    full = build_branch_mesh(pos, parent, radius, main_child=mc)
    assert len(chain) == 4
    np.testing.assert_array_equal(chain[0].mesh.faces, full.faces)
    np.testing.assert_allclose(chain[0].mesh.vertices, full.vertices)
    assert chain[0].cut_radius == 0.0


def test_triangles_decrease_and_budgets_met(chain):
    tris = [lv.triangles for lv in chain]
    assert all(a > b for a, b in zip(tris, tris[1:])), tris
    assert all(lv.met for lv in chain)
    for lv, r in zip(chain, LOD_RATIOS):
        assert lv.budget == max(1, int(tris[0] * r))
    cuts = [lv.cut_radius for lv in chain]
    assert cuts == sorted(cuts)


def test_bounds_kept(chain):
    lo0, hi0 = chain[0].mesh.vertices.min(0), chain[0].mesh.vertices.max(0)
    ext0 = hi0 - lo0
    for lv in chain[1:3]:
        lo, hi = lv.mesh.vertices.min(0), lv.mesh.vertices.max(0)
        assert np.all(lo >= lo0 - 1e-9) and np.all(hi <= hi0 + 1e-9)
        assert np.all(hi - lo >= 0.7 * ext0), (hi - lo) / ext0


def test_explicit_budgets_and_pruned_twigs(tree):
    pos, parent, radius, mc = tree
    ch = lod_chain(pos, parent, radius, main_child=mc, levels=3, budgets=[10**9, 20000, 3000])
    assert [lv.met for lv in ch] == [True, True, True]
    assert ch[2].triangles <= 3000
    # pruned nodes are exactly those on axes whose base is thinner than the cut
    lv = ch[2]
    st = axis_start(parent, mc)
    np.testing.assert_array_equal(lv.alive[2:], radius[st[2:]] >= lv.cut_radius)
    assert np.isin(lv.mesh.node_id, np.flatnonzero(lv.alive)).all()


def test_unreachable_budget_keeps_trunk(tree):
    pos, parent, radius, mc = tree
    ch = lod_chain(pos, parent, radius, main_child=mc, levels=2, budgets=[10**9, 1])
    assert not ch[1].met and ch[1].triangles > 0


def test_validation(tree):
    pos, parent, radius, mc = tree
    with pytest.raises(ValueError, match="levels"):
        lod_chain(pos, parent, radius, levels=9)
    with pytest.raises(ValueError, match="budgets"):
        lod_chain(pos, parent, radius, levels=2, budgets=[10, 0])
    with pytest.raises(ValueError, match="budgets"):
        lod_chain(pos, parent, radius, levels=2, budgets=[10])


def test_axis_start_follows_main_children():
    parent = np.array([-1, 0, 1, 1, 2, 3, 4])
    mc = np.array([1, 2, 4, 5, -1, -1, -1])
    np.testing.assert_array_equal(axis_start(parent, mc), [0, 1, 1, 3, 1, 3, 6])
    np.testing.assert_array_equal(axis_start(parent), [0, 1, 1, 3, 1, 3, 1])

"""LOD chain: decreasing triangle counts, budgets met, bounds kept (spec 000_treewand §3.5; issue 16)."""
import numpy as np
import pytest

from plantvr.geometry import build_branch_mesh
from plantvr.geometry.lod import LOD_RATIOS, axis_start, lod_chain, silhouette_radius_scale, triangle_count

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
    assert tris[0] > tris[1] > tris[2] and tris[2] >= tris[3], tris
    assert all(lv.met for lv in chain)
    for lv, r in zip(chain, LOD_RATIOS):
        assert lv.budget == max(1, int(tris[0] * r))
    cuts = [lv.cut_radius for lv in chain]
    assert cuts == sorted(cuts)


def test_bounds_kept(tree, chain):
    lo0, hi0 = chain[0].mesh.vertices.min(0), chain[0].mesh.vertices.max(0)
    ext0 = hi0 - lo0
    for lv in chain[1:3]:
        lo, hi = lv.mesh.vertices.min(0), lv.mesh.vertices.max(0)
        slack = 0.25 * tree[2].max()            # widened rings (silhouette_radius_scale) may stick out a little
        assert np.all(lo >= lo0 - slack) and np.all(hi <= hi0 + slack)
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
    pos, parent, radius, _ = tree
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


def test_silhouette_radius_scale():
    """A regular n-gon scaled by the factor has the circle's mean width 2r (perimeter / pi, Cauchy)."""
    for n in (3, 4, 8, 64):
        f = silhouette_radius_scale(n)
        perim = 2 * n * f * np.sin(np.pi / n)
        assert perim / np.pi == pytest.approx(2.0)
    assert silhouette_radius_scale([3])[0] == pytest.approx(1.2092, abs=1e-4)
    with pytest.raises(ValueError, match="sides"):
        silhouette_radius_scale(2)


def test_widen_scales_radii_of_coarse_levels(tree):
    pos, parent, radius, mc = tree
    wide = lod_chain(pos, parent, radius, main_child=mc, levels=2)
    thin = lod_chain(pos, parent, radius, main_child=mc, levels=2, widen=False)
    np.testing.assert_array_equal(wide[0].mesh.vertices, thin[0].mesh.vertices)
    ext = lambda m: np.ptp(m.vertices[:, [0, 2]], axis=0).sum()
    assert ext(wide[1].mesh) > ext(thin[1].mesh)


def test_prune_by_projected_size(tree):
    """prune_px: axes whose base radius is below prune_px pixels at the level's screen size go."""
    pos, parent, radius, mc = tree
    size = np.ptp(pos[1:], axis=0).max()
    ch = lod_chain(pos, parent, radius, main_child=mc, levels=3, budgets=[10**9] * 3, prune_px=0.5,
                   screen_px=(np.inf, 400.0, 100.0))
    assert ch[0].cut_radius == 0.0
    assert ch[1].cut_radius == pytest.approx(0.5 * size / 400.0)
    assert ch[2].cut_radius == pytest.approx(0.5 * size / 100.0)
    assert ch[2].alive.sum() < ch[1].alive.sum() <= ch[0].alive.sum()
    with pytest.raises(ValueError, match="screen_px"):
        lod_chain(pos, parent, radius, levels=2, prune_px=1.0)

"""Canonical space colonization (issue 22): Runions et al. 2007 as public implementations grow it.

The oracle here is a plain numpy + cKDTree implementation written for this test (float sums of unit vectors, no
quantisation, no guards): node counts must be identical to ``space_colonization(..., canonical=True)``.
"""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantvr.growth.colonize import SpaceColonizer, space_colonization, space_colonization_reference


def plain_sca(markers, root, di, dk, D, max_steps):
    """Runions et al. 2007, Fig. 3, step by step: nearest node of every marker (ties to the lowest index),
    kill within d_k, attract within d_i, every attracted node grows D along the normalised sum of the
    normalised pulls; stop when no marker is left or nothing grew. Returns (nodes, parent, steps)."""
    nodes = np.asarray(root, float).reshape(1, 3)
    parent = [-1]
    live = np.ones(len(markers), bool)
    steps = 0
    for _ in range(max_steps + 1):
        uniq, first = np.unique(nodes, axis=0, return_index=True)  # coincident nodes: the lowest index
        d, i = cKDTree(uniq).query(markers)
        i = first[i]
        live &= ~(d < dk)
        att = live & (d < di)
        if not live.any() or steps == max_steps or not att.any():
            break
        pull = markers[att] - nodes[i[att]]
        pull /= np.linalg.norm(pull, axis=1)[:, None]
        acc = np.zeros((len(nodes), 3))
        np.add.at(acc, i[att], pull)  # in marker order: the same set always sums to the same bits
        grow = np.flatnonzero(np.linalg.norm(acc, axis=1) > 0)
        new = nodes[grow] + D * acc[grow] / np.linalg.norm(acc[grow], axis=1)[:, None]
        nodes = np.concatenate([nodes, new])
        parent += grow.tolist()
        steps += 1
    return nodes, np.asarray(parent), steps


def _ball(n, seed, radius=3.0, centre=(0.0, 0.0, 3.5)):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    return v * radius * rng.random(n)[:, None] ** (1 / 3) + np.asarray(centre)


@pytest.mark.parametrize("seed, n, di, dk, D", [(0, 300, 2.0, 0.3, 0.2), (1, 1000, 1.5, 0.25, 0.15),
                                                 (2, 2000, 3.0, 0.5, 0.25), (3, 500, 0.8, 0.2, 0.3)])
def test_canonical_node_counts_equal_plain_numpy_ckdtree(seed, n, di, dk, D):
    markers = _ball(n, seed)
    steps = 60
    res = space_colonization(markers, [0, 0, 0], influence_radius=di, kill_radius=dk, step_size=D,
                             max_steps=steps, canonical=True)
    nodes, parent, k = plain_sca(markers, [0, 0, 0], di, dk, D, steps)
    assert res.steps == k
    assert len(res.nodes) == len(nodes)
    np.testing.assert_array_equal(res.parent, parent)
    np.testing.assert_allclose(res.nodes, nodes, atol=1e-9)  # quantised vs float sums: equal to ~1e-11


def test_canonical_kernel_equals_its_reference_bit_for_bit():
    markers = _ball(1500, 4)
    kw = dict(influence_radius=2.0, kill_radius=0.3, step_size=0.2, max_steps=80, canonical=True)
    a = space_colonization(markers, [0, 0, 0], **kw)
    b = space_colonization_reference(markers, [0, 0, 0], **kw)
    assert a.steps == b.steps
    np.testing.assert_array_equal(a.parent, b.parent)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.markers_left, b.markers_left)


def test_canonical_grows_without_the_two_guards():
    # two markers pulling sideways from a root out of kill range: canonical grows the same child every step
    trap = np.array([[1.0, 0.0, 0.05], [-1.0, 0.0, 0.05]])
    kw = dict(influence_radius=3.0, kill_radius=0.5, step_size=0.5, max_steps=10)
    guarded = space_colonization(trap, [0, 0, 0], **kw)
    canon = space_colonization(trap, [0, 0, 0], canonical=True, **kw)
    assert len(guarded.nodes) == 2 and guarded.steps == 1
    assert canon.steps == 10 and len(canon.nodes) == 11
    np.testing.assert_allclose(canon.nodes[1:], np.broadcast_to(canon.nodes[1], (10, 3)))  # all on top of one
    nodes, _, k = plain_sca(trap, [0, 0, 0], 3.0, 0.5, 0.5, 10)
    assert len(nodes) == len(canon.nodes) and k == canon.steps
    # near-cancelling pulls (|sum| ~ 1e-10, under the guard's 1e-9) still grow in canonical mode
    eps = 1e-10  # 27 quanta of 2**-38: above the exact zero, under the guard
    pair = np.array([[1.0, eps, 0.0], [-1.0, 0.0, 0.0]])
    assert space_colonization(pair, [0, 0, 0], **kw).steps == 0
    assert space_colonization(pair, [0, 0, 0], canonical=True, **kw).steps > 0
    # an exactly zero sum has no direction: no growth in either mode
    sym = np.array([[1.0, 0, 0], [-1.0, 0, 0]])
    assert space_colonization(sym, [0, 0, 0], canonical=True, **kw).steps == 0


def test_canonical_is_checked():
    with pytest.raises(ValueError, match="canonical must be a bool"):
        space_colonization(_ball(10, 0), [0, 0, 0], influence_radius=1.0, kill_radius=0.1, step_size=0.1,
                           canonical=1)
    with pytest.raises(ValueError, match="canonical must be a bool"):
        SpaceColonizer(_ball(10, 0), [0, 0, 0], influence_radius=1.0, kill_radius=0.1, step_size=0.1,
                       canonical="yes")


def test_guarded_and_canonical_agree_until_a_node_repeats():
    # the guards only drop repeated (coincident) children: with every repeat removed, canonical == guarded
    markers = _ball(800, 5)
    kw = dict(influence_radius=2.0, kill_radius=0.3, step_size=0.2, max_steps=200)
    g = space_colonization(markers, [0, 0, 0], **kw)
    c = space_colonization(markers, [0, 0, 0], canonical=True, **kw)
    assert len(c.nodes) >= len(g.nodes)
    uniq_c = np.unique(np.round(c.nodes, 9), axis=0)
    assert len(uniq_c) <= len(c.nodes)
    assert len(np.unique(np.round(g.nodes, 9), axis=0)) == len(g.nodes)  # guarded: no coincident nodes

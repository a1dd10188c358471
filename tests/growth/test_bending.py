"""Branch bending (spec 004 §2.9, Eq. A.3; test V14)."""
import numpy as np
import pytest

from plantvr.growth.bending import bend_path, rotation_matrix, stiffness


def _chain(m=10, radii=None, side=True):
    """A vertical chain 0..m with a side branch of two nodes at every other path node."""
    pos = [[0.0, float(k), 0.0] for k in range(m + 1)]
    parent = [-1] + list(range(m))
    radius = list(np.linspace(0.3, 0.05, m + 1)) if radii is None else list(radii)
    if side:
        for k in range(2, m, 2):
            pos.append([0.7, k + 0.7, 0.0])
            parent.append(k)
            radius.append(0.03)
            pos.append([1.2, k + 1.5, 0.3])
            parent.append(len(pos) - 2)
            radius.append(0.02)
    return np.array(pos), np.array(parent), np.array(radius), np.arange(m + 1)


def _lengths(pos, parent):
    i = np.flatnonzero(parent >= 0)
    return np.linalg.norm(pos[i] - pos[parent[i]], axis=1)


def test_ts_v14_rest_state_without_displacement():
    pos, par, rad, path = _chain()
    r = bend_path(pos, par, rad, path, pos[path[-1]])
    assert r.iterations == 0 and r.residual == 0.0
    np.testing.assert_array_equal(r.pos, pos)
    np.testing.assert_array_equal(r.phi, 0.0)


def test_ts_v14_reaches_target_and_preserves_lengths():
    pos, par, rad, path = _chain()
    target = np.array([4.0, 8.0, 1.0])
    r = bend_path(pos, par, rad, path, target)
    assert r.residual < 1e-3  # spec §8.3: bending residual < 1e-3
    np.testing.assert_allclose(r.pos[path[-1]], target, atol=1e-6)
    np.testing.assert_allclose(_lengths(r.pos, par), _lengths(pos, par), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(r.pos[0], pos[0])  # the base stays


def test_ts_v14_circular_editing():
    pos, par, rad, path = _chain()
    bent = bend_path(pos, par, rad, path, np.array([5.0, 7.0, -2.0]))
    back = bend_path(pos, par, rad, path, pos[path[-1]])  # solved from rest: the same state returns
    np.testing.assert_array_equal(back.pos, pos)
    assert not np.allclose(bent.pos, pos)


def test_ts_v14_side_branches_rigid():
    pos, par, rad, path = _chain()
    r = bend_path(pos, par, rad, path, np.array([4.0, 8.0, 1.0]))
    onpath = set(path.tolist())
    for s in range(len(pos)):
        q = par[s]
        if s in onpath or q < 0:
            continue
        sup = q  # the supporting internode ends at the attachment node
        a = par[sup]
        # transform of the side node relative to its supporting internode (a -> sup) is unchanged
        R = r.rot[s]
        np.testing.assert_allclose(r.pos[s] - r.pos[q], R @ (pos[s] - pos[q]), atol=1e-9)
        np.testing.assert_allclose(r.pos[sup] - r.pos[a], R @ (pos[sup] - pos[a]), atol=1e-9)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)


def test_ts_v14_thicker_deforms_less():
    m = 10
    thin = np.full(m + 1, 0.1)
    thick = thin.copy()
    thick[1:6] = 0.2  # proximal half 2x thicker → 16x stiffer
    target = np.array([3.0, 8.5, 0.0])
    pt, par, rt, path = _chain(m, thin, side=False)
    a = bend_path(pt, par, rt, path, target)
    b = bend_path(pt, par, thick, path, target)
    ang_a, ang_b = np.linalg.norm(a.phi, axis=1), np.linalg.norm(b.phi, axis=1)
    assert ang_b[:5].sum() < 0.5 * ang_a[:5].sum()  # the thick half bends less
    assert ang_b[5:].sum() > ang_a[5:].sum()  # and the thin half takes the bend


def test_ts_stiffness_eq_a3():
    np.testing.assert_allclose(stiffness([0.2, 0.1], [1.0, 2.0]), [0.2 ** 4, 0.1 ** 4 / 2])


def test_ts_rotation_matrix():
    R = rotation_matrix(np.array([0.0, 0.0, np.pi / 2]))
    np.testing.assert_allclose(R @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-15)


def test_ts_bend_validation():
    pos, par, rad, path = _chain()
    with pytest.raises(ValueError, match="reach"):
        bend_path(pos, par, rad, path, np.array([0.0, 30.0, 0.0]))
    with pytest.raises(ValueError, match="path must follow"):
        bend_path(pos, par, rad, [0, 2, 3], pos[3])
    with pytest.raises(ValueError, match="target"):
        bend_path(pos, par, rad, path, [1.0, 2.0])
    with pytest.raises(ValueError, match="parent"):
        bend_path(pos, par[:-1], rad, path, pos[3])


# -- pipe-model widths with constraints (spec 004 §2.10, V13) --------------------------------------------------
from plantvr.growth.bending import (
    _pipe_fold,
    _pipe_fold_numpy,
    _segments,
    _segments_numpy,
    pipe_widths,
    solve_exponent,
)


def _fan(m_tips, chain=3):
    """Trunk of ``chain`` internodes, then ``m_tips`` single-internode tips at its top."""
    par = [-1] + list(range(chain))
    top = chain
    par += [top] * m_tips
    return np.array(par)


def test_ts_v13_single_chain_constant_width():
    par = np.array([-1, 0, 1, 2, 3, 4])
    r = pipe_widths(par, np.ones(6, bool), tip_diameter=0.04, exponent=2.5)
    np.testing.assert_allclose(r.diameter, 0.04, rtol=1e-15)


@pytest.mark.parametrize("m", [1, 2, 5, 17])
def test_ts_v13_equal_tips_exact_exponent(m):
    """M + 1 equal tips under a base constraint: n = log(M+1) / (log d_b - log d_e) (ERRATUM E2)."""
    par = _fan(m + 1)
    d_b, d_e = 0.15, 0.05
    r = pipe_widths(par, np.ones(len(par), bool), tip_diameter=d_e, constraints={1: d_b})
    expect = np.log(m + 1) / (np.log(d_b) - np.log(d_e))
    assert abs(r.exponent[1] - expect) < 1e-9
    assert r.infeasible == ()
    np.testing.assert_allclose(r.diameter[1:4], d_b, rtol=1e-12)


def test_ts_v13_multi_constraint_eq52_at_each():
    rng = np.random.default_rng(3)
    n = 300
    par = np.array([-1] + [int(rng.integers(max(0, i - 6), i)) for i in range(1, n)])
    par[1] = 0
    alive = np.ones(n, bool)
    cons = {1: 2.0, 40: 0.9, 90: 0.6, 150: 0.5}
    r = pipe_widths(par, alive, tip_diameter=0.05, constraints=cons)
    d = r.diameter
    for c, dc in cons.items():
        assert d[c] == dc
    # Eq. 5.1 at every node with children, with the exponent of its subtree
    seg = np.full(n, -1)
    for i in range(n):
        seg[i] = i if i in cons else seg[par[i]]
    for i in range(n):
        ch = np.flatnonzero(par == i)
        if len(ch) and i > 0:
            k = r.exponent[seg[i]]
            np.testing.assert_allclose(d[i] ** k, np.sum(d[ch] ** k), rtol=1e-9)
    assert not r.infeasible


def test_ts_v13_infeasible_and_validation():
    par = _fan(3)
    r = pipe_widths(par, np.ones(len(par), bool), tip_diameter=0.5, constraints={1: 0.4})
    assert r.infeasible == (1,) and r.exponent[1] == 10.0
    assert solve_exponent(1.0, np.array([0.5, 0.5]))[1]
    with pytest.raises(ValueError, match="d_k"):
        solve_exponent(1.0, np.array([0.5]))
    with pytest.raises(ValueError, match="parent"):
        pipe_widths(np.array([-1, 2, 0]), np.ones(3, bool), tip_diameter=0.1)
    with pytest.raises(ValueError, match="constraint diameter"):
        pipe_widths(par, np.ones(len(par), bool), tip_diameter=0.1, constraints={1: -1.0})


def test_ts_pipe_fold_twin():
    rng = np.random.default_rng(5)
    n = 500
    par = np.array([-1] + [int(rng.integers(max(0, i - 8), i)) for i in range(1, n)])
    alive = rng.random(n) > 0.05
    alive[0] = True
    for i in range(1, n):  # closed under descendants
        alive[i] &= alive[par[i]]
    fixed = rng.random(n) < 0.05
    fixed_d = rng.uniform(0.1, 1.0, n)
    node_n = rng.uniform(1.5, 3.0, n)
    out = np.zeros(n)
    _pipe_fold(par, alive, fixed, fixed_d, node_n, 0.03, out)
    np.testing.assert_allclose(out, _pipe_fold_numpy(par, alive, fixed, fixed_d, node_n, 0.03), rtol=1e-13)


def test_ts_width_solve_speed():
    """Spec §8.2 [INFERRED] target: 10^4 internodes and 20 constraints in interactive time."""
    import time

    rng = np.random.default_rng(1)
    n = 10_000
    par = np.array([-1] + [int(rng.integers(max(0, i - 20), i)) for i in range(1, n)])
    cons = {1: 5.0}
    cons.update({int(k): 0.3 for k in rng.choice(np.arange(2, n), 19, replace=False)})
    pipe_widths(par, np.ones(n, bool), tip_diameter=0.02, constraints=cons)
    t = time.perf_counter()
    pipe_widths(par, np.ones(n, bool), tip_diameter=0.02, constraints=cons)
    assert time.perf_counter() - t < 0.5  # generous for CI; the benchmark reports the figure


def test_ts_segments_twin():
    rng = np.random.default_rng(8)
    n = 2000
    par = np.array([-1] + [int(rng.integers(max(0, i - 30), i)) for i in range(1, n)])
    fixed = rng.random(n) < 0.02
    ref = np.full(n, -1)
    for i in range(n):  # the definition, as a plain loop
        ref[i] = i if fixed[i] else (ref[par[i]] if par[i] >= 0 else -1)
    np.testing.assert_array_equal(_segments(par, fixed), ref)
    np.testing.assert_array_equal(_segments_numpy(par, fixed), ref)

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

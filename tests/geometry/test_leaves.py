"""Leaves: placement, elastic reorientation, petioles (spec 000_treewand §3.4, TW-V21)."""
import numpy as np
import pytest

from plantvr.geometry.leaves import build_leaves, initial_leaf_frames, orient_leaves, select_leaf_buds

Y = np.array([0.0, 1.0, 0.0])


@pytest.fixture(scope="module")
def buds():
    rng = np.random.default_rng(11)
    n = 200
    pos = rng.normal(size=(n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    r = rng.uniform(0.01, 0.05, n)
    return pos, d, r


def _angle_to_y(u):
    return np.arccos(np.clip(u @ Y, -1, 1))


def test_tw_v21_leaf_count_and_size_zero(buds):
    pos, d, r = buds
    thr = 0.03
    lv = build_leaves(pos, d, r, radius_threshold=thr, leaf_size=0.2, rng=0)
    assert len(lv.frames) == np.sum(r < thr)
    assert set(np.unique(lv.bud_id)) == set(np.flatnonzero(r < thr))
    none = build_leaves(pos, d, r, radius_threshold=thr, leaf_size=0.0, rng=0)
    assert len(none.faces) == 0 and len(none.vertices) == 0
    assert len(select_leaf_buds(r, radius_threshold=thr, leaf_size=0)) == 0


def test_tw_v21_zero_elasticity_keeps_frames(buds):
    _, d, _ = buds
    h, r, u = initial_leaf_frames(d, rng=1)
    h2, r2, u2 = orient_leaves(h, r, u, e_twist=0, e_up=0, e_right=0, iterations=15)
    np.testing.assert_allclose(np.stack([h2, r2, u2]), np.stack([h, r, u]), atol=1e-12)
    np.testing.assert_allclose(r, np.cross(h, u), atol=1e-12)


@pytest.mark.parametrize("increment", ["per_iteration", "split"])
def test_tw_v21_elasticity_turns_normal_up_monotonically(buds, increment):
    _, d, _ = buds
    h, r, u = initial_leaf_frames(d, rng=2)
    prev = _angle_to_y(u)
    for it in range(1, 16):
        _, _, uk = orient_leaves(h, r, u, e_twist=0.1, e_up=0.1, e_right=0.1, iterations=it, increment="per_iteration")
        ang = _angle_to_y(uk)
        assert np.all(ang <= prev + 1e-9)
        prev = ang
    finals = [_angle_to_y(orient_leaves(h, r, u, e_twist=e, e_up=e, e_right=e, increment=increment)[2]).mean()
              for e in (0.0, 0.05, 0.1)]
    assert finals[0] > finals[1] > finals[2]


def test_tw_v21_iterations_converge(buds):
    _, d, _ = buds
    h, r, u = initial_leaf_frames(d, rng=3)
    # at the suggested default elasticity 0.05 (B.2); at 0.1 the change is ~3e-3 rad (first-order splitting)
    a = orient_leaves(h, r, u, e_twist=0.05, e_up=0.05, e_right=0.05, iterations=15, increment="split")
    b = orient_leaves(h, r, u, e_twist=0.05, e_up=0.05, e_right=0.05, iterations=20, increment="split")
    ang = np.arccos(np.clip(np.sum(a[2] * b[2], 1), -1, 1))
    assert ang.max() < 1e-3


def test_leaf_mesh_geometry(buds):
    pos, d, r = buds
    for shape in ("ovate", "lobed"):
        lv = build_leaves(pos, d, r, radius_threshold=0.03, leaf_size=0.2, petiole_length=0.05, leaf_shape=shape,
                          e_up=0.05, rng=0)
        assert np.isfinite(lv.vertices).all() and lv.faces.max() < len(lv.vertices)
        # petiole starts at the bud and the blade sits at p2 = p0 + l h_init + l h_final
        sel = np.flatnonzero(r < 0.03)
        near = np.linalg.norm(lv.vertices[:, None] - pos[sel][None], axis=2).min(axis=0)
        np.testing.assert_allclose(near, 0.3 * r.min(), rtol=1e-9)   # the petiole ring around the bud
        assert (lv.uv >= 0).all() and (lv.uv <= 1).all()


def test_leaf_inputs_rejected(buds):
    pos, d, r = buds
    with pytest.raises(ValueError, match="leaf_shape must be one of"):
        build_leaves(pos, d, r, leaf_shape="needle")
    with pytest.raises(ValueError, match="leaf_size must be in"):
        build_leaves(pos, d, r, leaf_size=-1)
    with pytest.raises(ValueError, match="bud_radius must have shape"):
        build_leaves(pos, d, r[:-1])
    with pytest.raises(ValueError, match=r"iterations must be an integer in \[1, 1000\]"):
        orient_leaves(d, d, d, iterations=0)
    with pytest.raises(ValueError, match="increment must be one of"):
        orient_leaves(d, d, d, increment="total")


def test_orient_twins_agree(buds):
    _, d, _ = buds
    h, r, u = initial_leaf_frames(d, rng=4)
    for inc in ("per_iteration", "split"):
        a = orient_leaves(h, r, u, e_twist=0.08, e_up=0.05, e_right=0.1, increment=inc, kernel="numba")
        b = orient_leaves(h, r, u, e_twist=0.08, e_up=0.05, e_right=0.1, increment=inc, kernel="numpy")
        np.testing.assert_allclose(np.stack(a), np.stack(b), atol=1e-10)


def test_parallel_and_serial_orient_agree():
    from plantvr.geometry import leaves as LV
    rng = np.random.default_rng(5)
    h, r, u = initial_leaf_frames(rng.normal(size=(3000, 3)), rng=6)
    e = np.array([0.1, 0.05, 0.08])
    a = LV._orient_numba(h, r, u, e, 15, Y, 1.0)
    b = LV._orient_serial(h, r, u, e, 15, Y, 1.0)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


# ---- incremental leaves -----------------------------------------------------------------------------
def _bud_rows(rng, n):
    pos = rng.normal(size=(n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return pos, d, rng.uniform(0.01, 0.05, n), rng.normal(size=(n, 3))


def test_incremental_leaves_equal_build_leaves():
    from plantvr.geometry.leaves import IncrementalLeafMesh
    kw = dict(radius_threshold=0.03, petiole_radius=0.004, leaf_size=0.4, petiole_length=0.08, e_twist=0.07,
              leaf_shape="lobed")
    rng = np.random.default_rng(2)
    pos, d, r, up = _bud_rows(rng, 150)
    inc = IncrementalLeafMesh(**kw)
    for step in range(6):
        # buds are consumed (rows vanish, later rows shift), new ones appear, some radii cross the threshold
        keep = rng.random(len(pos)) > 0.15
        p2, d2, r2, u2 = _bud_rows(rng, 40)
        pos, d, r, up = (np.concatenate([a[keep], b]) for a, b in ((pos, p2), (d, d2), (r, r2), (up, u2)))
        r = r * np.where(rng.random(len(r)) < 0.05, 1.5, 1.0)
        if step == 3:
            pos, d, r, up = (np.concatenate([a, a[:5]]) for a in (pos, d, r, up))     # duplicate buds
        res = inc.update(pos, d, r, up)
        ref = build_leaves(pos, d, r, bud_up=up, **kw)
        got = inc.to_leaf_mesh()
        for k in ("vertices", "normals", "uv", "bud_id", "faces", "frames"):
            np.testing.assert_array_equal(getattr(got, k), getattr(ref, k), err_msg=k)
        assert inc.n_leaves == len(ref.frames)
        if step:
            assert res["added"] < 0.5 * len(ref.frames)          # only new buds were oriented and meshed
        # the live buffers show exactly these leaves (free blocks are degenerate)
        f = inc.faces[(inc.faces[:, 0] != inc.faces[:, 1]) | (inc.faces[:, 1] != inc.faces[:, 2])]
        assert len(f) == len(ref.faces)
        np.testing.assert_allclose(np.sort(inc.vertices[f].reshape(-1, 9), axis=0),
                                   np.sort(ref.vertices[ref.faces].reshape(-1, 9), axis=0))
    with pytest.raises(ValueError, match="bud_up must have shape"):
        inc.update(pos, d, r, up[:3])
    assert inc.n_leaves == len(build_leaves(pos, d, r, bud_up=up, **kw).frames)   # unchanged by the rejection


def test_ts_v29_petiole_twist_sign_and_convergence():
    """TreeSketch V29: T = up and a tilted blade → U converges toward T; the first twist is Ω_H = −e_H L·T
    (L = U × H); all elasticities 0 → no reorientation."""
    tilt = np.radians(30)
    h = np.array([[1.0, 0.0, 0.0]])
    u = np.array([[0.0, np.cos(tilt), np.sin(tilt)]])
    L = np.cross(u, h)
    e_h = 0.1
    _, _, u1 = orient_leaves(h, L, u, e_twist=e_h, e_up=0, e_right=0, iterations=1)
    omega_h = np.arctan2(np.cross(u[0], u1[0]) @ h[0], u[0] @ u1[0])
    assert np.isclose(omega_h, -e_h * (L[0] @ [0.0, 1.0, 0.0]), rtol=1e-12)
    _, _, u_end = orient_leaves(h, L, u, e_twist=e_h, e_up=0, e_right=0, iterations=200)
    assert u_end[0] @ [0.0, 1.0, 0.0] > 1 - 1e-9
    h0, r0, u0 = orient_leaves(h, L, u, e_twist=0, e_up=0, e_right=0, iterations=15)
    np.testing.assert_allclose(u0, u, atol=1e-15)

"""V9-V11, V32: implicit skinning projection, frames, association contract and the errata guard (spec 003 §2.7)."""
import numpy as np
import pytest

from plantvr.implicit.skinning import Circle2D, Polygon2D, Revolution, Skin, SkinPath, sweep

SQUARE = Polygon2D([[-0.4, -0.4], [0.4, -0.4], [0.4, 0.4], [-0.4, 0.4]])


def _helix():
    t = np.linspace(0, 4 * np.pi, 40)
    return SkinPath(np.column_stack([np.cos(t), np.sin(t), 0.3 * t]))


def test_v9_newton_projection_and_rmf():
    path = _helix()
    rng = np.random.default_rng(9)
    u = rng.uniform(0.1, 0.9, 500)
    c, t, n, b, _ = path.frames(u)
    p = c + 0.15 * rng.normal(size=(500, 3))
    up = path.project(p)
    cp, tp, npp, bp, _ = path.frames(up)
    assert np.max(np.abs(np.einsum("ij,ij->i", tp, cp - p))) < 1e-9
    for x, y in ((tp, npp), (npp, bp), (tp, bp)):
        assert np.max(np.abs(np.einsum("ij,ij->i", x, y))) < 1e-12
    for x in (tp, npp, bp):
        assert np.max(np.abs(np.linalg.norm(x, axis=1) - 1)) < 1e-12


def test_v9_rmf_minimal_twist_on_planar_path():
    t = np.linspace(0, np.pi, 12)
    path = SkinPath(np.column_stack([np.cos(t), np.sin(t) * 2, np.zeros(12)]))
    _, _, n, b, _ = path.frames(np.linspace(0, 1, 200))
    # planar path: one frame vector stays the plane normal, so consecutive frames do not rotate about T
    v = n if abs(n[0, 2]) > 0.5 else b
    assert np.max(np.abs(np.abs(v[:, 2]) - 1)) < 1e-6


def _contract_residual(sk, s_value, curve):
    path = sk.path
    u = np.interp(s_value, path.s, path.u)
    c, t, n, b, _ = path.frames(np.array([u]))
    if isinstance(curve, Circle2D):
        a = np.linspace(0, 2 * np.pi, 60, endpoint=False)
        uv = curve.center + curve.r * np.column_stack([np.cos(a), np.sin(a)])
    else:
        v = curve.vertices
        w = np.roll(v, -1, axis=0)
        f = np.linspace(0, 1, 15, endpoint=False)[:, None, None]
        uv = (v[None] * (1 - f) + w[None] * f).reshape(-1, 2)
    p = c + uv[:, :1] * n + uv[:, 1:] * b
    return np.max(np.abs(sk.field(p) - 0.5))


def _curved_path():
    return SkinPath([[0, 0, 0], [0.2, 0, 1], [0.8, 0.1, 2], [1.0, 0.3, 3]])


def test_v10_linear_association_contract():
    sk = Skin(_curved_path(), [(0.0, SQUARE), (0.5, Circle2D(0.3)), (1.0, SQUARE)], radius=0.6)
    for s_value, curve in ((0.0, SQUARE), (0.5, Circle2D(0.3)), (1.0, SQUARE)):
        assert _contract_residual(sk, s_value, curve) < 1e-3


def test_v10_cubic_passes_through_triple_repeats():
    secs = [(0.0, SQUARE)] * 3 + [(0.5, Circle2D(0.3))] * 3 + [(1.0, SQUARE)] * 3
    sk = Skin(_curved_path(), secs, radius=0.6, interpolation="cubic")
    assert _contract_residual(sk, 0.5, Circle2D(0.3)) < 1e-3
    assert _contract_residual(sk, 0.0, SQUARE) < 1e-3
    # a single (unrepeated) cubic control is approximated, not interpolated
    single = Skin(_curved_path(), [(0.0, SQUARE), (0.25, SQUARE), (0.5, Circle2D(0.3)), (0.75, SQUARE),
                                   (1.0, SQUARE)], radius=0.6, interpolation="cubic")
    assert _contract_residual(single, 0.5, Circle2D(0.3)) > 1e-2


def test_v32_errata_guard_literal_tn_plane_breaks_the_contract():
    sk = Skin(_curved_path(), [(0.0, SQUARE), (0.5, Circle2D(0.3)), (1.0, SQUARE)], radius=0.6)
    assert _contract_residual(sk, 0.5, Circle2D(0.3)) < 1e-3
    sk._plane = "TN"   # ERRATUM A.3: the literal wording of §4.2.3
    assert _contract_residual(sk, 0.5, Circle2D(0.3)) > 0.05
    # ERRATUM A.2: linear g blends d_i with d_{i+1}: halfway the distance is the mean of neighbours
    lin = Skin(_curved_path(), [(0.0, Circle2D(0.2)), (1.0, Circle2D(0.4))], radius=0.6)
    assert _contract_residual(lin, 0.5, Circle2D(0.3)) < 1e-3


def test_v11_bounded_continuous_and_extrusion():
    sk = Skin(_curved_path(), [(0.0, SQUARE), (0.5, Circle2D(0.3)), (1.0, SQUARE)], radius=0.6)
    lo, hi = sk.bbox
    n = 32
    axes = [np.linspace(lo[i], hi[i], n) for i in range(3)]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    f = sk.field(g).reshape(n, n, n)
    assert f.min() >= 0.0 and f.max() <= 1.0
    h = np.max((hi - lo) / (n - 1))
    lip = 1.6 / 0.6 * 3.0
    for ax in range(3):
        assert np.max(np.abs(np.diff(f, axis=ax))) <= lip * h
    ex = sweep(Circle2D(0.3), [[0, 0, 0], [0, 0, 2]], radius=0.6)
    phi = np.linspace(0, 2 * np.pi, 9)
    vals = [ex.field(np.column_stack([0.25 * np.cos(phi), 0.25 * np.sin(phi), np.full(9, z)])) for z in
            (0.3, 1.0, 1.7)]
    assert np.allclose(vals[0], vals[1], atol=1e-9) and np.allclose(vals[1], vals[2], atol=1e-9)


def test_revolution_profile_is_the_surface():
    rev = Revolution([[0, 0], [1.0, 0], [1.0, 2.0], [0, 2.0]], radius=0.5)
    phi = np.linspace(0, 2 * np.pi, 7)
    p = np.column_stack([np.cos(phi), np.sin(phi), np.full(7, 1.0)])
    assert np.allclose(rev.field(p), 0.5, atol=1e-12)


def test_skinning_bad_input():
    with pytest.raises(ValueError, match="sections needs at least 4"):
        Skin(_curved_path(), [(0.0, SQUARE), (1.0, SQUARE)], interpolation="cubic")
    with pytest.raises(ValueError, match="s must be in"):
        Skin(_curved_path(), [(0.0, SQUARE), (1.5, SQUARE)])
    with pytest.raises(ValueError, match="points must be distinct"):
        SkinPath([[0, 0, 0], [0, 0, 0], [1, 0, 0]])
    with pytest.raises(ValueError, match="rho >= 0"):
        Revolution([[-1, 0], [1, 0], [0, 1]])


def test_variational_surface_interpolates_constraints():
    from plantvr.implicit.variational import Variational
    rng = np.random.default_rng(5)
    d = rng.normal(size=(60, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    b = d * [2.0, 1.0, 1.0]
    v = Variational(b, [[0, 0, 0]], interior_value=1.0)
    assert np.allclose(v.field(b), 0.5, atol=1e-6)
    assert v.inside([[0, 0, 0], [1.5, 0, 0]]).all() and not v.inside([[0, 0, 1.3], [2.4, 0, 0]]).any()
    with pytest.raises(ValueError, match="interior"):
        Variational(b, np.empty((0, 3)))

"""V3-V5, V8 and kernel twins: blending, CSG truth tables, boxes, transforms (spec 003 §2.2, §2.4)."""
import numpy as np
import pytest

from plantvr.implicit import _kernels
from plantvr.implicit.blobtree import (Blend, Difference, Difference2, Intersection, Union, polyline, segment,
                                       sphere, torus)
from plantvr.implicit.skinning import Circle2D, Revolution, sweep
from plantvr.implicit.warps import bend, taper, twist


def test_v3_summation_blend_bulges_union_does_not():
    R = 1.0
    far = Blend(sphere((0, 0, 0), R), sphere((3 * R, 0, 0), R))
    assert far.field([[1.5 * R, 0, 0]])[0] == 0.0           # disjoint spheres
    assert far.field([[0.5 * R, 0, 0]])[0] == pytest.approx(0.5, abs=1e-12)
    near_b = Blend(sphere((0, 0, 0), R), sphere((1.2 * R, 0, 0), R))
    near_u = Union(sphere((0, 0, 0), R), sphere((1.2 * R, 0, 0), R))
    mid = [[0.6 * R, 0, 0]]
    assert near_b.field(mid)[0] == pytest.approx(0.688, abs=1e-3)
    assert near_b.inside(mid)[0] and not near_u.inside(mid)[0]


def test_v4_csg_membership_1e5_points():
    rng = np.random.default_rng(4)
    p = rng.uniform(-2, 2, (100_000, 3))
    a = sphere((-0.4, 0, 0), 2.0)
    b = segment((0.2, -1, 0), (0.6, 1, 0.3), 1.6)
    A, B = a.inside(p), b.inside(p)
    assert np.array_equal(Union(a, b).inside(p), A | B)
    assert np.array_equal(Intersection(a, b).inside(p), A & B)
    assert np.array_equal(Difference(a, b).inside(p), A & ~B)
    assert np.array_equal(Difference2(a, b).inside(p), B & ~A)
    assert (A & B).mean() > 0.01 and (A & ~B).mean() > 0.01 and (B & ~A).mean() > 0.005


def _zoo():
    s = sphere((0.3, 0, 0), 1.5)
    c = segment((0, 0, -1), (0, 0.5, 1), 1.0)
    t = torus((0, 0, 0), (0.3, 1, 0), 1.0, 0.8)
    return [
        s, c, t, polyline([[0, 0, 0], [1, 0, 0], [1, 1, 0]], 0.7),
        Blend(s, c, t), Union(s, t), Intersection(s, c), Difference(t, s), Difference2(t, s),
        Blend(s, c).scaled(2, 0.5, 1).rotated((1, 1, 0), 30).translated((1, 2, 3)),
        twist(segment((0.3, 0, 0), (0.3, 0, 2), 0.8), 1.2), taper(c, 0.3), bend(segment((0, 0, 0), (0, 0, 2), 0.6), 0.8, length=2.0),
        Revolution([[0, 0], [0.8, 0], [0.5, 1], [0, 1.2]], radius=0.5),
        sweep(Circle2D(0.3), [[0, 0, 0], [0, 0.5, 1], [0.5, 1, 2]], radius=0.4),
    ]


def test_v5_aabb_soundness():
    rng = np.random.default_rng(5)
    for node in _zoo():
        lo, hi = node.bbox
        span = hi - lo
        p = rng.uniform(lo - span, hi + span, (20_000, 3))
        f = node.field(p)
        pos = f > 0
        assert pos.any()
        assert np.all((p[pos] >= lo - 1e-12) & (p[pos] <= hi + 1e-12))
        # culling by box does not change values inside the box
        m = np.all((p >= lo) & (p <= hi), axis=1)
        assert np.array_equal(node._eval_inside(p[m], "numba"), f[m])


def test_v8_scale_gives_ellipsoid():
    s = sphere(radius=1.0).scaled(50, 80, 50)
    for axis, semi in zip(np.eye(3), (25.0, 40.0, 25.0)):
        f_in, f_out = s.field([axis * semi * 0.99, axis * semi * 1.01])
        assert f_in > 0.5 > f_out


def test_c2_sphere_surface_radius():
    s = sphere((1, 2, 3), 3.0)
    d = np.random.default_rng(0).normal(size=(100, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    assert np.allclose(s.field(np.array([1, 2, 3]) + 1.5 * d), 0.5, atol=1e-12)


def test_torus_surface():
    t = torus((0, 0, 0), (0, 0, 1), rho=2.0, radius=1.0)
    phi = np.linspace(0, 2 * np.pi, 50)
    p = np.column_stack([2.5 * np.cos(phi), 2.5 * np.sin(phi), np.zeros(50)])
    assert np.allclose(t.field(p), 0.5, atol=1e-12)


def test_kernel_twins_equal_on_seeded_input():
    rng = np.random.default_rng(7)
    k = 40
    a = rng.uniform(-3, 3, (k, 3))
    b = a + rng.normal(size=(k, 3)) * (rng.random((k, 1)) < 0.5)
    radius = rng.uniform(0.5, 2.0, k)
    minv = np.ascontiguousarray(np.tile(np.eye(4)[:3], (k, 1, 1)) + rng.normal(scale=0.1, size=(k, 3, 4)))
    lo, hi = np.minimum(a, b) - 3, np.maximum(a, b) + 3
    p = rng.uniform(-5, 5, (5000, 3))
    f1 = _kernels.segment_blend_numba(p, a, b, radius, minv, lo, hi)
    f2 = _kernels.segment_blend_numpy(p, a, b, radius, minv, lo, hi)
    assert np.allclose(f1, f2, atol=1e-12, rtol=0)
    assert f1.max() > 1.0


def test_blend_backends_agree_and_match_plain_sum():
    rng = np.random.default_rng(1)
    prims = [sphere(c, 2.0).scaled(1, 1.5, 1) for c in rng.uniform(-3, 3, (30, 3))] + [torus(rho=1.0)]
    b = Blend(*prims)
    p = rng.uniform(-6, 6, (4000, 3))
    ref = sum(pr.field(p, backend="numpy") for pr in prims)
    assert np.allclose(b.field(p), ref, atol=1e-12)
    assert np.allclose(b.field(p, backend="numpy"), ref, atol=1e-12)


def test_bad_input_names_parameter():
    s = sphere()
    with pytest.raises(ValueError, match="points"):
        s.field(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="backend"):
        s.field(np.zeros((3, 3)), backend="cuda")
    with pytest.raises(ValueError, match="radius"):
        sphere(radius=-1)
    with pytest.raises(ValueError, match="sx"):
        s.scaled(0, 1, 1)
    with pytest.raises(ValueError, match="Difference operand 1"):
        Difference(s, "x")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="axis"):
        s.rotated((0, 0, 0), 10)

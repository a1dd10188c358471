"""V7: warps are invertible and keep their defining properties (spec 003 §2.5)."""
import numpy as np
import pytest

from plantvr.implicit.blobtree import segment
from plantvr.implicit.warps import (Warp, bend, bend_forward, bend_inverse, taper, taper_forward, taper_inverse,
                                    twist, twist_forward, twist_inverse)


def test_v7_round_trips():
    rng = np.random.default_rng(7)
    p = rng.uniform(-1, 1, (2000, 3)) + [0, 0, 1]
    assert np.allclose(twist_forward(twist_inverse(p, 1.3), 1.3), p, atol=1e-9)
    assert np.allclose(taper_forward(taper_inverse(p, 0.2, 0.0), 0.2, 0.0), p, atol=1e-9)
    # bend: valid region x < rho, all three z regions (below 0, on the arc, beyond L)
    k, L = 0.5, 2.0
    q = np.column_stack([rng.uniform(-1, 1, 3000), rng.uniform(-1, 1, 3000), rng.uniform(-1, 4, 3000)])
    assert np.allclose(bend_inverse(bend_forward(q, k, L), k, L), q, atol=1e-9)
    assert np.allclose(bend_inverse(bend_forward(q, -k, L), -k, L), q, atol=1e-9)


def test_v7_twisted_cylinder_keeps_radius():
    c = segment((0, 0, 0), (0, 0, 4), 1.0)
    w = twist(c, 2.0)
    rng = np.random.default_rng(0)
    phi, z = rng.uniform(0, 2 * np.pi, 500), rng.uniform(0.5, 3.5, 500)
    p = np.column_stack([0.5 * np.cos(phi), 0.5 * np.sin(phi), z])
    assert np.allclose(w.field(p), 0.5, atol=1e-9)


def test_v7_taper_scales_cross_section():
    c = segment((0, 0, 0), (0, 0, 4), 1.0)
    k = 0.25
    w = taper(c, k)
    z = np.linspace(0.5, 3.5, 20)
    s = 1 + k * z
    # surface radius is 0.5 s(z), so the cross-section area scales by s(z)^2
    p = np.column_stack([0.5 * s, np.zeros(20), z])
    assert np.allclose(w.field(p), 0.5, atol=1e-9)


def test_bend_moves_the_tip():
    c = segment((0, 0, 0), (0, 0, 2), 0.4)
    w = bend(c, np.pi / 4, length=2.0)            # 90 degrees over the length
    tip = bend_forward(np.array([[0, 0, 2.0]]), np.pi / 4, 2.0)[0]
    assert w.field([tip])[0] == pytest.approx(1.0, abs=1e-9)
    assert np.allclose(tip, [4 / np.pi, 0, 4 / np.pi], atol=1e-9)


def test_warp_bad_input():
    with pytest.raises(ValueError, match="kind"):
        Warp(segment((0, 0, 0), (0, 0, 1)), "shear", 1.0)
    with pytest.raises(ValueError, match="k gives a non-positive taper"):
        taper(segment((0, 0, 0), (0, 0, 4)), -1.0)

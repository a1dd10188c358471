"""Spec 001 §2.1–§2.2: trimming offsets (V3, V5) and graph simplification (V4)."""
import numpy as np
import pytest

from plantvr.subdivision import BranchGraph, joint_offsets, pair_offset, simplify


def test_v3_orthogonal_offset_is_other_radius():
    assert pair_offset(np.array([0.0]), np.array([1.0]), np.array([2.0]))[0] == pytest.approx(2.0)
    assert pair_offset(np.array([0.0]), np.array([1.0]), np.array([2.0]), offset_mode="report")[0] == pytest.approx(2.0)


@pytest.mark.parametrize("alpha_deg", [30, 60, 90, 120, 150, 170])
def test_v3_equal_radii_cot_half_angle(alpha_deg):
    a = np.deg2rad(alpha_deg)
    off = pair_offset(np.array([np.cos(a)]), np.array([0.7]), np.array([0.7]))[0]
    assert off == pytest.approx(min(0.7 / np.tan(a / 2), 4 * 0.7), rel=1e-12)


def test_v3_continuation_zero_and_pythagoras_identity():
    assert pair_offset(np.array([-1.0]), np.array([1.0]), np.array([1.0]))[0] == 0.0
    rng = np.random.default_rng(1)
    c = rng.uniform(-0.3, 0.9, 50)
    ra, rb = rng.uniform(0.5, 1.0, 50), rng.uniform(0.5, 1.0, 50)
    oa = pair_offset(c, ra, rb, max_offset_factor=100)
    ob = pair_offset(c, rb, ra, max_offset_factor=100)
    ok = (oa > 0) & (ob > 0)
    np.testing.assert_allclose((ob ** 2 + rb ** 2)[ok], (oa ** 2 + ra ** 2)[ok], rtol=1e-12)   # ERRATUM A4


def test_v3_report_mode_is_discontinuous_at_90_degrees():
    eps = 1e-6
    lo = pair_offset(np.array([eps]), np.array([1.0]), np.array([1.0]), offset_mode="report")[0]
    hi = pair_offset(np.array([-eps]), np.array([1.0]), np.array([1.0]), offset_mode="report")[0]
    assert lo == pytest.approx(1.0, abs=1e-5) and hi == pytest.approx(0.0, abs=1e-5)   # ERRATUM A5
    geo = pair_offset(np.array([-eps, eps]), np.array([1.0, 1.0]), np.array([1.0, 1.0]))
    assert abs(geo[0] - geo[1]) < 1e-5


def test_v3_same_direction_is_bad_input():
    g = BranchGraph(np.array([[0, 0, 0], [0, 1, 0], [0, 1, 0.]]), np.array([[0, 1, 0], [1, 2, 0], [2, 3, 0.]]),
                    np.full(3, 0.1), np.full(3, 0.1), np.array([-1, 0, 0]))
    with pytest.raises(ValueError, match="branches 1 and 2 leave joint 0 in the same direction"):
        joint_offsets(g)
    with pytest.raises(ValueError, match="offset_mode must be one of"):
        pair_offset(np.array([0.0]), 1.0, 1.0, offset_mode="x")


def test_v5_trimmed_discs_do_not_overlap():
    # bifurcation: trimmed end discs lie outside the other member's cylinder
    rng = np.random.default_rng(3)
    for _ in range(20):
        d = rng.normal(size=(2, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        if d[0] @ d[1] > 0.95 or d[:, 1].min() < 0.2:
            continue
        J = np.array([0, 5.0, 0])
        g = BranchGraph(np.array([[0, 0, 0], J, J]), np.array([J, J + 5 * d[0], J + 5 * d[1]]),
                        np.full(3, 0.3), np.full(3, 0.3), np.array([-1, 0, 0]))
        s, _, _ = joint_offsets(g, min_offset=0)
        ax = g.axis
        for a, b in [(1, 2), (2, 1)]:
            th = np.linspace(0, 2 * np.pi, 64)
            u = np.cross(ax[a], [1, 0, 0.]); u /= np.linalg.norm(u)
            w = np.cross(ax[a], u)
            ring = J + s[a] * ax[a] + 0.3 * (np.cos(th)[:, None] * u + np.sin(th)[:, None] * w)
            rel = ring - J
            along = rel @ ax[b]
            dist = np.linalg.norm(rel - along[:, None] * ax[b], axis=1)
            assert not np.any((along > s[b] + 1e-9) & (dist < 0.3 - 1e-9))


def test_v4_simplification_collapses_keeps_tips():
    # trunk 0 -> short internode 1 (0.2 long) -> two children; short branch must collapse
    J1, J2 = np.array([0, 3.0, 0]), np.array([0, 3.2, 0])
    start = np.array([[0, 0, 0], J1, J1, J2, J2])
    end = np.array([J1, J2, J1 + [2, 1, 0], J2 + [-2, 1.5, 0], J2 + [0, 2, 2]])
    g = BranchGraph(start, end, np.full(5, 0.2), np.full(5, 0.2), np.array([-1, 0, 0, 1, 1]))
    g2, s, e, _ = simplify(g)
    assert len(g2) == 4                                          # exactly one collapse
    assert g2.parent.tolist() == [-1, 0, 0, 0]                   # re-parented to the grandparent
    np.testing.assert_array_equal(g2.start[1:], np.repeat(J1[None], 3, 0))
    leaves = g.end[[2, 3, 4]]
    np.testing.assert_array_equal(np.sort(g2.end[g2.is_leaf], 0), np.sort(leaves, 0))   # tips bit-identical
    assert np.all(s + e <= g2.length)


def test_v4_leaf_crossover_is_clamped_with_warning():
    J = np.array([0, 3.0, 0])
    g = BranchGraph(np.array([[0, 0, 0], J, J]), np.array([J, J + [0.05, 0.1, 0], J + [-1, 1, 0]]),
                    np.full(3, 0.2), np.full(3, 0.2), np.array([-1, 0, 0]))
    with pytest.warns(UserWarning, match="too short"):
        g2, s, e, _ = simplify(g)
    assert len(g2) == 3 and np.all(s + e <= 0.9 * g2.length + 1e-12)

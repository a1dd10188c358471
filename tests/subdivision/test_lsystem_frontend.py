"""Issue 30: parse_lsystem is read and drawn by plantvr.lsystem; branch starts, ends and radii derived by hand."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from plantvr.lsystem import ModuleString, turtle
from plantvr.subdivision import parse_lsystem

S3 = math.sqrt(3) / 2


def _check(g, start, end, r0, r1, parent):
    np.testing.assert_allclose(g.start, start, atol=1e-12)
    np.testing.assert_allclose(g.end, end, atol=1e-12)
    np.testing.assert_array_equal(g.r0, r0)
    np.testing.assert_array_equal(g.r1, r1)
    assert g.parent.tolist() == parent


def test_f_is_a_gap_and_the_next_F_a_new_root():
    # spec §1.4 gaps are MovRel3f's; an f ends the branch (L-Py's turtle), so no snap and no warning
    g = parse_lsystem("Ff(1)F", strict=True)
    _check(g, [[0, 0, 0], [0, 2, 0]], [[0, 1, 0], [0, 3, 0]], [0.1, 0.1], [0.1, 0.1], [-1, -1])
    g = parse_lsystem("F(2) f(0.5) [+(90)F] F(1, 0.3)", radius=0.2, strict=True)   # a root in and after a [
    _check(g, [[0, 0, 0], [0, 2.5, 0], [0, 2.5, 0]], [[0, 2, 0], [-1, 2.5, 0], [0, 3.5, 0]],
           [0.2, 0.2, 0.3], [0.2, 0.2, 0.3], [-1, -1, -1])


def test_bracketed_branches_turn_left_and_right():
    # + turns the heading (+Y) about the up axis (+Z) toward -X, - toward +X (Rz(+-90) e_y)
    g = parse_lsystem("F(2,0.3)[+F(1,0.2)][-(90)F(1,0.1)]F(1.5)", angle=90, radius=0.05)
    _check(g, [[0, 0, 0], [0, 2, 0], [0, 2, 0], [0, 2, 0]], [[0, 2, 0], [-1, 2, 0], [1, 2, 0], [0, 3.5, 0]],
           [0.3, 0.2, 0.1, 0.05], [0.3, 0.2, 0.1, 0.05], [-1, 0, 0, 0])
    g = parse_lsystem("F[+(30)F]-(60)F", strict=True)
    _check(g, [[0, 0, 0], [0, 1, 0], [0, 1, 0]], [[0, 1, 0], [-0.5, 1 + S3, 0], [S3, 1.5, 0]],
           [0.1] * 3, [0.1] * 3, [-1, 0, 0])


def test_pitch_and_roll_are_l_pys():
    # & pitches down: the heading +Y toward -U = -Z; / rolls the up axis +Z about the heading onto +X, so a
    # second & pitches toward -X
    g = parse_lsystem("F[&(90)F]/(90)&(90)F", strict=True)
    _check(g, [[0, 0, 0], [0, 1, 0], [0, 1, 0]], [[0, 1, 0], [0, 1, -1], [-1, 1, 0]], [0.1] * 3, [0.1] * 3,
           [-1, 0, 0])
    g = parse_lsystem("F|F(2)", strict=True)              # | turns the heading around
    np.testing.assert_allclose(g.end[1], [0, -1, 0], atol=1e-12)


def test_lst_in_radians_cones_and_moves():
    text = (f"RotRel3f({math.pi / 2!r}, 0, 0, 1) Cylinder(0.2, 0.1, 2) MovRel3f(0, 2, 0) "
            f"RotRel3f({-math.pi / 6!r}, 0, 0, 1) Cylinder(0.1, 0.05, 1)")
    g = parse_lsystem(text, angle_unit="radians", strict=True)    # headings Rz(90) e_y, then Rz(60) e_y
    _check(g, [[0, 0, 0], [-2, 0, 0]], [[-2, 0, 0], [-2 - S3, 0.5, 0]], [0.2, 0.1], [0.1, 0.05], [-1, 0])
    deg = parse_lsystem("RotRel3f(90, 0, 0, 1) Cylinder(0.2, 0.1, 2) MovRel3f(0, 2, 0) "
                        "RotRel3f(-30, 0, 0, 1) Cylinder(0.1, 0.05, 1)", strict=True)
    np.testing.assert_allclose(deg.end, g.end, atol=1e-12)


def test_rotrel3f_about_any_axis_and_moves_in_the_local_frame():
    # 120 degrees about (1, 1, 1) maps y onto z
    g = parse_lsystem("RotRel3f(120, 1, 1, 1) Cylinder(1, 1, 2)")
    np.testing.assert_allclose(g.end[0], [0, 0, 2], atol=1e-12)
    # after Rz(90) the local x is +Y and the heading -X: MovRel3f(1, 0, 3) lands on (0, 1, 3)
    g = parse_lsystem("RotRel3f(90, 0, 0, 1) MovRel3f(0, 0, 3) MovRel3f(1, 0, 0) Cylinder(1, 1, 1)")
    _check(g, [[0, 1, 3]], [[-1, 1, 3]], [1], [1], [-1])


def test_lst_gaps_are_snapped_or_raised_at_their_position():
    text = "Cylinder(1,1,2) MovRel3f(1,2,0) Cylinder(0.5,0.5,1)"
    with pytest.warns(UserWarning, match=r"position 32 starts 1 away"):
        g = parse_lsystem(text)
    _check(g, [[0, 0, 0], [0, 2, 0]], [[0, 2, 0], [1, 3, 0]], [1, 0.5], [1, 0.5], [-1, 0])   # tip kept
    with pytest.raises(ValueError, match=r"position 32 starts 1 away"):
        parse_lsystem(text, strict=True)
    with pytest.warns(UserWarning, match=r"position 16 starts 2 away"):   # a Cylinder does not move the turtle
        g = parse_lsystem("Cylinder(1,1,2) Cylinder(1,1,1)")
    _check(g, [[0, 0, 0], [0, 2, 0]], [[0, 2, 0], [0, 1, 0]], [1, 1], [1, 1], [-1, 0])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.sampled_from(["F", "F(0.5)", "+", "-", "&", "^", "/", "\\", "|", "[", "]", "+(17)"]),
                min_size=1, max_size=30))
def test_bracket_strings_draw_l_pys_turtle_in_the_y_up_frame(syms):
    # the same skeleton as plantvr.lsystem.turtle (heading +Z, up +X) seen from the frame heading +Y, up +Z
    depth = 0
    for i, s in enumerate(syms):
        if s == "]" and depth == 0:
            syms[i] = "F"
        depth += (syms[i] == "[") - (syms[i] == "]")
    syms += ["]"] * depth + ["F"]
    g = parse_lsystem("".join(syms), angle=33, strict=True)
    mods = [(s[0], (float(s[2:-1]),)) if "(" in s else s for s in syms]
    t = turtle(ModuleString.from_modules(mods), angle=33)
    node = np.flatnonzero(t.parent >= 0)
    lpy = t.pos[:, [1, 2, 0]]                       # (y, z, x): +Z heading -> +Y, +X up -> +Z
    np.testing.assert_allclose(g.end, lpy[node], atol=1e-9)
    np.testing.assert_allclose(g.start, lpy[t.parent[node]], atol=1e-9)


def _axis_angle(axis, a):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def test_long_lst_chain_follows_the_spec_frame_oracle():
    # spec §1.4 [INFERRED] 2-4 written out with matrices: R <- R @ axis_angle, p <- p + R @ (0, L, 0); 3000
    # turns about changing axes keep every branch on the oracle (the turtle's frame stays orthonormal)
    rng = np.random.default_rng(1)
    ops = [(float(rng.uniform(-1, 1)), rng.normal(size=3).tolist(), float(rng.uniform(0.5, 2))) for _ in range(3000)]
    text = " ".join(f"RotRel3f({a!r}, {x[0]!r}, {x[1]!r}, {x[2]!r}) Cylinder(1, 1, {L!r}) MovRel3f(0, {L!r}, 0)"
                    for a, x, L in ops)
    g = parse_lsystem(text, angle_unit="radians", strict=True)
    R, p, ends = np.eye(3), np.zeros(3), []
    for a, x, L in ops:
        R = R @ _axis_angle(x, a)
        p = p + R @ [0, L, 0]
        ends.append(p)
    np.testing.assert_allclose(g.end, ends, atol=1e-9)
    assert g.parent.tolist() == list(range(-1, 2999))

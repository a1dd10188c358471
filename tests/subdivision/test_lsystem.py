"""Spec 001 §1.4–§1.5: LST / turtle parsing and grown-tree arrays (V1, V2)."""

import re
import warnings

import numpy as np
import pytest

from plantvr.subdivision import BranchGraph, graph_from_arrays, parse_lsystem

from ._helpers import SAMPLE_LST


def test_v1_sample_lst_six_branches_depth_first():
    with pytest.warns(UserWarning, match="starts 5 away"):
        g = parse_lsystem(SAMPLE_LST, angle_unit="radians")
    assert len(g) == 6
    assert g.parent.tolist() == [-1, 0, 1, 0, 3, 0]            # depth-first order
    np.testing.assert_allclose(g.length[:5], [10, 5, 5, 5, 5])
    np.testing.assert_allclose(g.start[5], g.end[0])              # gap snapped, tip kept:
    tip = g.end[0] + 15 * g.axis[0]                               # 5 up + a 10-long cylinder
    assert np.linalg.norm(g.end[5] - g.end[0]) > 10 and np.linalg.norm(tip - g.end[0]) == pytest.approx(15)
    assert np.flatnonzero(g.parent == 0).tolist() == [1, 3, 5]  # root has 3 children
    g.validate()


def test_v1_strict_mode_reports_gap_position():
    with pytest.raises(ValueError, match=r"position 3\d\d starts 5"):
        parse_lsystem(SAMPLE_LST, angle_unit="radians", strict=True)


def test_v1_one_op_per_line_and_empty_lines_equal_many_per_line():
    text = "Cylinder(1, 1, 2)\n\nMovRel3f(0, 2, 0)\nSB()\nRotRel3f(0.5, 0, 0, 1)\nCylinder(1, 0.5, 3)\nEB()\n"
    g1 = parse_lsystem(text)
    g2 = parse_lsystem(" ".join(text.split("\n")))
    np.testing.assert_array_equal(g1.end, g2.end)
    assert g1.parent.tolist() == [-1, 0]


def test_v2_turtle_frame_move_reaches_cylinder_end():
    rng = np.random.default_rng(0)
    for _ in range(5):
        a, x, y, z = rng.uniform(-2, 2, 4)
        text = f"RotRel3f({a}, {x}, {y}, {z}) Cylinder(1, 1, 3) MovRel3f(0, 3, 0) Cylinder(1, 1, 2)"
        g = parse_lsystem(text, strict=True)             # no gap: the move landed on the end
        np.testing.assert_allclose(g.start[1], g.end[0], atol=1e-12)


def test_v2_brackets_restore_state():
    g = parse_lsystem("F(2)[+F(1)&F(1)]F(1)", angle=30, strict=True)
    assert g.parent.tolist() == [-1, 0, 1, 0]
    np.testing.assert_allclose(g.start[3], g.end[0])
    np.testing.assert_allclose(g.axis[3], g.axis[0])


def test_turtle_symbols_rotate_by_angle():
    g = parse_lsystem("F[+F][-F]", angle=90, step=1)
    np.testing.assert_allclose(g.end[1], [-1, 1, 0], atol=1e-12)
    np.testing.assert_allclose(g.end[2], [1, 1, 0], atol=1e-12)


@pytest.mark.parametrize("text, match", [
    ("F[+F", r"'\[' / SB\(\) at position 1 is never closed"),
    ("F]F", r"position 1 has no matching"),
    ("F X F", r"unknown symbol 'X F' at position 2"),
    ("Cylinder(1,1,2) Foo(1)", r"unknown symbol 'oo\(1\)' at position 17"),   # L-Py's lexer: F, o, o(1)
    ("Cylinder(1,1,0)", r"zero-length branch at position 0"),
    ("Cylinder(1,1)", r"Cylinder takes 3 arguments, got 2 at position 0"),
    ("Cylinder(0,1,1)", r"non-positive radius"),
    ("MovRel3f(0,1,0)", r"no branch"),
])
def test_bad_strings_name_position(text, match):
    with pytest.raises(ValueError, match=match):
        parse_lsystem(text)


def test_bad_parser_options():
    with pytest.raises(ValueError, match="angle_unit must be one of"):
        parse_lsystem("F", angle_unit="grad")
    with pytest.raises(ValueError, match="step must be in"):
        parse_lsystem("F", step=0)
    with pytest.raises(ValueError, match="text must be a str"):
        parse_lsystem(b"F")


def test_graph_from_arrays_internodes():
    pos = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0], [1, 2, 0]], float)
    par = np.array([-1, 0, 1, 1])
    rad = np.array([0.3, 0.2, 0.1, 0.05])
    g = graph_from_arrays(pos, par, rad)
    assert isinstance(g, BranchGraph) and len(g) == 3
    assert g.parent.tolist() == [-1, 0, 0]
    np.testing.assert_array_equal(g.r0, [0.3, 0.2, 0.2])
    np.testing.assert_array_equal(g.r1, [0.2, 0.1, 0.05])
    g.validate()


@pytest.mark.parametrize("pos, par, rad, match", [
    (np.zeros((3, 2)), [-1, 0, 1], [1, 1, 1], r"pos must have shape \(N, 3\)"),
    ([[0, 0, 0], [0, 1, 0], [0, 2, 0]], [-1, 2, 1], [1, 1, 1], r"parent must satisfy .*cycles.*parent\[1\] = 2"),
    ([[0, 0, 0], [0, 1, 0], [0, 2, 0]], [1, 0, 1], [1, 1, 1], r"parent\[0\] must be -1"),
    ([[0, 0, 0], [0, 1, 0], [0, 2, 0]], [-1, 0, 1], [1, 0, 1], r"radius must be > 0 .* at node 1"),
    ([[0, 0, 0], [0, 1, 0], [0, 1, 0]], [-1, 0, 1], [1, 1, 1], r"pos: internode ending at node 2 has zero"),
    ([[0, 0, 0], [0, 1, 0], [0, 2, 0]], [-1, 0], [1, 1, 1], r"parent must have shape"),
    ([[0, 0, 0], [0, np.nan, 0]], [-1, 0], [1, 1], r"pos must contain only finite"),
])
def test_graph_from_arrays_rejects_bad_input(pos, par, rad, match):
    with pytest.raises(ValueError, match=match):
        graph_from_arrays(pos, par, rad)


def test_branch_graph_validate_rejects_gap_and_cycle():
    g = BranchGraph(np.array([[0, 0, 0], [0, 2, 0.]]), np.array([[0, 1, 0], [0, 3, 0.]]), np.ones(2), np.ones(2),
                    np.array([-1, 0]))
    with pytest.raises(ValueError, match="branch 1 starts 1 away"):
        g.validate()
    g = BranchGraph(np.array([[0, 0, 0], [0, 1, 0.]]), np.array([[0, 1, 0], [0, 3, 0.]]), np.ones(2), np.ones(2),
                    np.array([1, -1]))
    with pytest.raises(ValueError, match="no cycles"):
        g.validate()


from hypothesis import given, settings
from hypothesis import strategies as st


@settings(max_examples=60, deadline=None)
@given(st.text(alphabet="F+-&^/[]", min_size=1, max_size=40))
def test_random_turtle_strings_parse_or_name_position(text):
    depth, ok = 0, True
    for ch in text:
        depth += (ch == "[") - (ch == "]")
        ok &= depth >= 0
    ok &= depth == 0 and "F" in text
    if ok:
        g = parse_lsystem(text, angle=30, strict=True)
        g.validate()
        assert len(g) == text.count("F")
    else:
        with pytest.raises(ValueError, match=r"text: (unbalanced brackets|the string contains no branch)"):
            parse_lsystem(text, angle=30)


def test_module_name_followed_by_paren_is_that_module():
    # issue 22: "FF(0.5)" is F then F(0.5), as "F F(0.5)"; glued F/f before a named module split the same way
    for glued, spaced in (("FF(0.5)", "F F(0.5)"), ("FFF(2,0.2)[+fF(1)]", "F F F(2,0.2)[+f F(1)]"),
                          ("FCylinder(1,1,2)", "F Cylinder(1,1,2)"), ("Ff(0.5)F", "F f(0.5) F")):
        a, b = parse_lsystem(glued), parse_lsystem(spaced)
        np.testing.assert_array_equal(a.parent, b.parent)
        np.testing.assert_allclose(a.end, b.end)
        np.testing.assert_allclose(a.r0, b.r0)
    assert len(parse_lsystem("FF(0.5)")) == 2
    for bad, at in (("FFoo(1)", 2), ("FX(1)", 1)):      # L-Py's reading (issue 30): an unknown name is its letters
        with pytest.raises(ValueError, match=rf"unknown symbol '{re.escape(bad[at:])}' at position {at}"):
            parse_lsystem(bad)


def test_turn_symbols_take_degrees_and_rotrel3f_defaults_to_degrees():
    # issue 23: "+(30)F" parses as L-Py (a turn symbol followed by (args) takes its angle in degrees) and
    # RotRel3f is in degrees by default, like every other angle; the report's radians stay one option away
    for with_arg, plain in (("F+(30)F", "F+F"), ("F[&(30)F]-(30)F", "F[&F]-F"), ("F/ (30)+(30)F", "F/+F")):
        a, b = parse_lsystem(with_arg, angle=45), parse_lsystem(plain, angle=30)
        np.testing.assert_allclose(a.end, b.end, atol=1e-12)
    np.testing.assert_allclose(parse_lsystem("F+()F", angle=30).end, parse_lsystem("F+F", angle=30).end)
    deg = parse_lsystem("RotRel3f(30, 0, 0, 1) Cylinder(1, 1, 1)")
    rad = parse_lsystem(f"RotRel3f({np.pi / 6!r}, 0, 0, 1) Cylinder(1, 1, 1)", angle_unit="radians")
    np.testing.assert_allclose(deg.end, rad.end, atol=1e-12)
    np.testing.assert_allclose(deg.end[0], [-0.5, np.sqrt(3) / 2, 0], atol=1e-12)
    with pytest.raises(ValueError, match=r"\+ takes 0-1 arguments \(angle in degrees\), got 2 at position 1"):
        parse_lsystem("F+(30,2)F")
    with pytest.raises(ValueError, match=r"non-finite argument in '-\(nan\)' at position 1"):
        parse_lsystem("F-(nan)F")


def test_f_moves_without_drawing_and_the_next_F_is_a_root():
    # issue 33: ``f`` was read as a gap to snap, merging the move into the next branch (``Ff(1)F`` gave lengths
    # [1, 2] and a warning); as L-Py's turtle, the F after an f starts a new root where the move ended
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g = parse_lsystem("Ff(1)F", strict=True)
        np.testing.assert_allclose(np.linalg.norm(g.end - g.start, axis=1), [1, 1])
        assert g.parent.tolist() == [-1, -1]
        np.testing.assert_allclose(g.start[1], [0, 2, 0])
        g = parse_lsystem("F[+fF]F", angle=90, strict=True)      # in a branch too; the axis goes on from F
        assert g.parent.tolist() == [-1, -1, 0]

"""Request modules ``?P``, ``?H``, ``?U``, ``?L``, ``?R``, ``?F`` (issue 33, L-Py's query pass): before a step
whose productions match one, the string is interpreted and each request module's parameters are set to the
turtle's frame there (L-Py ``ParamModule::_setValues``)."""
from __future__ import annotations

import re

import numpy as np
import pytest

from plantvr.lsystem import LSystem, LSystemError, ModuleString
from plantvr.lsystem.plantgl import Vector3
from plantvr.lsystem.turtle import query_frames


def _close(got, want):
    """Modules ``got`` equal ``want``, numbers and Vector3s to 1e-12."""
    assert [n for n, _ in got] == [n for n, _ in want]
    for (name, a), (_, b) in zip(got, want):
        assert len(a) == len(b), name
        for x, y in zip(a, b):
            assert type(x) is type(y), (name, x, y)
            np.testing.assert_allclose(np.asarray(x, float), np.asarray(y, float), atol=1e-12, err_msg=name)


def test_every_request_module_gets_the_frame_by_hand():
    # H = +Z, L = -Y, U = +X. F(2): at (0, 0, 2). +(90) turns H toward L: H = -Y, L = -Z, U = +X.
    # F(1): (0, -1, 2). &(90) pitches H down toward -U: H = -X. F(3): (-3, -1, 2).
    ls = LSystem("Axiom: F(2) ?P(0, 0, 0) +(90) F(1) ?P ?H(0) ?U(5, 5) ?L(1, 2, 3, 4) ?R GetPos(7) ?F "
                 "[ &(90) F(3) ?P(0, 0, 0) ] [ % ?P(9, 9, 9) ]\n"
                 "production:\n?P(x, y, z) --> ?P(x, y, z)\nendlsystem\n")
    got = ls.derive(1).modules()
    v = Vector3
    want = [("F", (2.0,)), ("?P", (0.0, 0.0, 2.0)), ("+", (90.0,)), ("F", (1.0,)),
            ("?P", (v(0, -1, 2),)), ("?H", (0.0,)), ("?U", (1.0, 0.0)), ("?L", (0.0, 0.0, -1.0, 4.0)),
            ("?R", (v(0, 0, 1),)), ("GetPos", (0.0,)), ("?F", (v(0, -1, 2), v(0, -1, 0), v(1, 0, 0), v(0, 0, -1))),
            ("[", ()), ("&", (90.0,)), ("F", (3.0,)), ("?P", (-3.0, -1.0, 2.0)), ("]", ()),
            ("[", ()), ("]", ())]                               # the step drops what % cuts
    _close(got, want)
    assert ls.derive(0).count("?P") == 4                      # the axiom is not answered: no step ran


def test_grow_until_a_height():
    """The classic open L-system: the apex grows while the position after it is below a height."""
    ls = LSystem("Axiom: A ?P(0, 0, 0)\nderivation length: 10\nproduction:\n"
                 "A > ?P(x, y, z) : z < 3.5 --> F(1) A\nendlsystem\n")
    got = ls.derive().modules()
    _close(got, [("F", (1.0,))] * 4 + [("A", ()), ("?P", (0.0, 0.0, 4.0))])
    assert len(ls.tree().pos) == 5


def test_vector_parameter_and_homomorphism_before_the_query():
    """``?P(p)`` gets a Vector3; the turtle reads the interpreted string (here ``I --> F(2)``)."""
    ls = LSystem("Axiom: I ?P I ?H\nproduction:\n?P(p) --> Z(p.z, p[1])\n?H(h) --> W(h.z)\n"
                 "homomorphism:\nI --> F(2) +(90)\nendlsystem\n")
    _close(ls.derive(1).modules(), [("I", ()), ("Z", (2.0, 0.0)), ("I", ()), ("W", (-1.0,))])  # H: +Z, -Y, -Z


def test_no_query_pass_without_a_request_pattern():
    ls = LSystem("Axiom: F ?P(0, 0, 0) A\nproduction:\nA --> A\nendlsystem\n")
    assert ls.derive(3).modules()[1] == ("?P", (0.0, 0.0, 0.0))


def test_query_frames_and_drawing_ignores_request_modules():
    s = ModuleString.from_modules(["F", "[", ("+", (90.0,)), "F", "?U", "]", "?P", ("?L", ("text",))])
    idx, fr = query_frames(s)
    assert idx.tolist() == [4, 6, 7]
    np.testing.assert_allclose(fr[:, 0], [[0, -1, 1], [0, 0, 1], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(fr[0, 3], [1, 0, 0], atol=1e-12)
    ls = LSystem("Axiom: F ?P(1, 2, 3) F\n")
    assert len(ls.tree().pos) == 3 and ls.draw(ls.axiom, shapes=True).shapes.kind.size == 0


@pytest.mark.parametrize("text, line, match", [
    ("Axiom: F ?P\nproduction:\n?P(p) --> F\nhomomorphism:\n?P(p) --> F\n", 5, "interpretation rule's pattern"),
    ("Axiom: F A ?P\nproduction:\n?P(p) --> F\nhomomorphism:\nA --> F ?P\n", 5, "produce request modules"),
    ("Axiom: F ?P @2D\nproduction:\n?P(p) --> F\n", 1, "unsupported module @2D"),
    ("Axiom: F\nproduction:\n?I(it) < F --> F\n", 3, "iterator request"),
])
def test_refused_with_line(text, line, match):
    with pytest.raises(LSystemError, match=match) as err:
        LSystem(text).derive(1)
    assert err.value.line == line


def _ex_lsystem2(n: int) -> list:
    """L-Py's ``share/examples/ex_lsystem2.lpy`` derived by hand: each step, the position of every ``?P`` from a
    turtle that only turns about U (``+``/``-``, H = (0, -sin a, cos a)), then the rules, skipping what a ``%``
    cuts (up to the ``]`` closing its branch), as L-Py's ``Lsystem::__step``."""
    s = [("A", ())]
    for _ in range(n):
        at, stack, p, a = {}, [], np.zeros(3), 0.0
        out, i = [], 0
        while i < len(s):
            name, v = s[i]
            if name == "%":                                   # the turtle and the step skip the rest of the branch
                depth = 0
                while i < len(s) and (depth or s[i][0] != "]"):
                    depth += (s[i][0] == "[") - (s[i][0] == "]")
                    i += 1
                continue
            if name == "F":
                p = p + np.array([0.0, -np.sin(np.radians(a)), np.cos(np.radians(a))])
            elif name in "+-":
                a += v[0] if name == "+" else -v[0]
            elif name == "[":
                stack.append((p, a))
            elif name == "]":
                p, a = stack.pop()
            elif name == "?P":
                at[i] = p
            if name == "A":
                out += [("[", ()), ("+", (60.0,)), ("B", ()), ("]", ()), ("[", ()), ("-", (60.0,)), ("B", ()),
                        ("]", ()), ("F", ()), ("?P", (0.0, 0.0, 0.0)), ("A", ())]
            elif name == "B":
                out += [("F", ()), ("?P", (0.0, 0.0, 0.0)), ("@O", (0.2,)), ("B", ())]
            elif name == "?P":
                _, y, z = at[i].tolist()
                if 4 * y * y + (z - 10) ** 2 > 100:
                    out += [("[", ()), ("+", (2 * z,)), ("F", ()), ("]", ()), ("[", ()), ("-", (2 * z,)), ("F", ()),
                            ("]", ()), ("%", ())]
            else:
                out.append((name, v))
            i += 1
        s = out
    return s


def test_lpy_distribution_grammar_ex_lsystem2():
    """An open L-system of L-Py's distribution (``share/examples``): branches grow until their ``?P`` leaves an
    ellipsoid, then end in a fork and a cut."""
    from pathlib import Path
    ls = LSystem.from_file(Path(__file__).parent / "data" / "ex_lsystem2.lpy", trusted=True)
    for n in (1, 2, 5, 12, ls.derivation_length):
        got, want = ls.derive(n).modules(), _ex_lsystem2(n)
        assert len(got) == len(want), n
        _close(got, want)
    assert ls.derive(20).count("B") == 16 and ls.derive().count("A") + ls.derive().count("B") == 0  # all cut
    assert ls.tree().pos[:, 2].max() > 20                     # the main axis forked above the ellipsoid


def test_cut_removes_the_rest_of_the_branch_in_a_step():
    """L-Py's steps skip a ``%`` and its branch up to the closing ``]`` (kept); at the top level, to the end."""
    ls = LSystem("Axiom: F [ A % B [ C ] D ] E % G\nproduction:\nA --> A\nendlsystem\n")
    assert str(ls.derive(1)) == "F[A]E"


def test_static_rule_successor_is_made_once():
    """L-Py's ``-static->`` (``LsysRule::setStatic``): the successor is computed once, its pattern's variables
    unbound, and every match gets that same successor."""
    text = "Axiom: A A A\nproduction:\nA {} B(uniform(0, 1))\nendlsystem\n"
    static = [v for _, (v,) in LSystem(text.format("-static->"), seed=1).derive(1).modules()]
    plain = [v for _, (v,) in LSystem(text.format("-->"), seed=1).derive(1).modules()]
    assert len(set(static)) == 1 and len(set(plain)) == 3
    grow = "Axiom: F(1) A(2)\nproduction:\nA(n) {} F(1) [+F(0.5)] A(0)\nendlsystem\n"   # numba's constant path
    assert str(LSystem(grow.format("-static->")).derive(3)) == str(LSystem(grow.format("-->")).derive(3))
    with pytest.raises(LSystemError, match=r"line 3, column 1: .*NameError: name 'x' is not defined"):
        LSystem("Axiom: A(1)\nproduction:\nA(x) -static-> B(x)\n")
    block = "Axiom: A A A\nproduction:\nA : @static\n    x = uniform(0, 1)\n    nproduce [F]\n    produce B(x)\n"
    static = LSystem(block, seed=1, trusted=True).derive(1)  # ``pred : @static`` + block (lpy_parser.cpp)
    (x,), = {vals for name, vals in static.modules() if name == "B"}
    assert re.sub(r"B\([^)]*\)", "B(x)", str(static)) == "[F]B(x)[F]B(x)[F]B(x)"


@pytest.mark.parametrize("text, col, match", [
    ("Axiom: A\nproduction:\nx(A, 2) --> B\n", 1, "repetition pattern x.* in a predecessor"),
    ("Axiom: A\nproduction:\nA > x(B, 1, n) --> B\n", 13, "repetition count 'n'"),
    ("Axiom: A\nproduction:\nA > or(B, C(y if y)) --> B\n", 11, "value constraints inside an alternative"),
])
def test_pattern_modules_are_refused_with_line_and_column(text, col, match):
    with pytest.raises(LSystemError, match=match) as err:
        LSystem(text)
    assert (err.value.line, err.value.column) == (3, col)


def test_query_turtle_has_plantgl_defaults_as_lpy_envturtle():
    """L-Py answers queries with ``LsysContext::envturtle``, a default PlantGL turtle (60 degrees), not the drawing
    turtle whose options the grammar sets."""
    ls = LSystem("context().turtle.setAngleIncrement(90)\nAxiom: + F ?P(0, 0, 0)\nproduction:\n"
                 "?P(x, y, z) --> ?P(x, y, z)\nendlsystem\n")
    _close(ls.derive(1).modules()[-1:], [("?P", (0.0, -3 ** 0.5 / 2, 0.5))])
    np.testing.assert_allclose(ls.tree().pos[-1], [0, -1, 0], atol=1e-12)      # drawn at 90 degrees

"""ABOP §1.8 signal propagation with context-sensitive rules: the signal reaches the tip (or the root) in the
predicted number of steps; ``ignore:`` skips turtle symbols and contexts follow the axial tree."""
from __future__ import annotations

import pytest

from plantvr.lsystem.engine import LSystem


def axis(k: int, lateral: bool) -> str:
    return "b" + "".join(("[+a]" if lateral else "") + "a" for _ in range(k))


@pytest.mark.parametrize("lateral", [False, True])
def test_acropetal_signal_reaches_tip(lateral):
    k = 12
    text = f"Axiom: {axis(k, lateral)}\nignore: +\nproduction:\nb < a --> b\nendlsystem\n"
    ls = LSystem(text)
    for step, s in enumerate(ls.iterate(k + 2)):
        main = [m[0] for m in s.modules()]
        depth, axis_mods = 0, []
        for name in main:
            depth += (name == "[") - (name == "]")
            if depth == 0 and name in "ab":
                axis_mods.append(name)
        # main-axis module j (0 = the root b) carries the signal after j steps
        assert axis_mods == ["b"] * min(step + 1, k + 1) + ["a"] * max(k - step, 0)
        if lateral:                                          # a lateral a sees its bearing module as left context
            assert s.count("b") == min(2 * step + 1, 2 * k + 1)
    assert str(s).endswith("b")


def test_basipetal_signal_reaches_root():
    k = 9
    text = f"Axiom: {'a[-a]' * k}b\nignore: -\nproduction:\na > b --> b\nendlsystem\n"
    s = LSystem(text).derive(k)
    assert str(s) == "b[-a]" * k + "b"                       # laterals never see b on their right
    assert str(LSystem(text).derive(k - 1)).startswith("a[-a]b")


def test_consider_and_right_context_with_branch():
    text = "Axiom: A[B]C\nproduction:\nA > [B]C --> X\nC --> C\nendlsystem\n"
    assert str(LSystem(text).derive(1)) == "X[B]C"
    text = "Axiom: A+B\nconsider: AB\nproduction:\nA < B --> Y\nendlsystem\n"
    assert str(LSystem(text).derive(1)) == "A+Y"
    text = "Axiom: A+B\nproduction:\nA < B --> Y\nendlsystem\n"
    assert str(LSystem(text).derive(1)) == "A+B"             # '+' is a module unless ignored


def test_parametric_context():
    text = ("Axiom: A(1)B(2)B(3)\nproduction:\nA(x) < B(y) --> B(x+y)\nB(x) < B(y) --> B(x*y)\nendlsystem\n")
    assert str(LSystem(text).derive(1)) == "A(1)B(3)B(6)"

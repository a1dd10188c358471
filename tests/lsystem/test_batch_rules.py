"""Rules that call grammar functions run as one generated loop per rule over the parameter columns (issue 33,
speed: the batch plan of ``_Rules._batch``): the strings are those of a plain Python loop of the same rules,
module for module; values that are not numbers are kept as the module path keeps them; errors keep the rule's
grammar line; the time budget and the module cap hold inside a step; the guards still refuse a memory bomb."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plantvr.lsystem.engine import LSystem, LSystemError

FUNCS = Path(__file__).parent / "grammars" / "functions.lpy"


def by_hand(n: int) -> list:
    """``functions.lpy`` derived by a plain Python loop (its two functions, one branch per rule)."""
    s = [("A", (1, 0))]
    for _ in range(n):
        out = []
        for name, p in s:
            if name == "A":
                l, k = p
                out += [("I", (l * 1.01,)), ("[", ()), ("+", (30 + 5 * k,)), ("B", (l, k + 1)), ("]", ()),
                        ("A", (l * 1.01, k + 1))]
            elif name == "B" and p[1] < 1000:
                out += [("I", (p[0] * 1.01,)), ("B", (p[0] * 1.01, p[1]))]
            elif name == "I":
                out.append(("I", (p[0] * 1.01,)))
            else:
                out.append((name, p))
        s = out
    return s


def test_rules_calling_functions_use_the_batch_plan_and_equal_a_python_loop():
    ls = LSystem.from_file(FUNCS, trusted=True)
    assert all(c.batch is not None and c.vec is None for c in ls._rules["production"])
    for n in (0, 1, 2, 7, 40):
        got = ls.derive(n).modules()
        want = by_hand(n)
        assert [m for m, _ in got] == [m for m, _ in want], n
        assert np.array_equal(np.concatenate([np.asarray(v, float) for _, v in got] or [[]]),
                              np.concatenate([np.asarray(v, float) for _, v in want] or [[]])), n


def test_batch_sees_ints_and_keeps_objects_as_the_module_path():
    g = """
def kind(x):
    return type(x).__name__

def half(n):
    return n // 2 if isinstance(n, int) else -1.0

Axiom: A(4) A(2.5) A(7)
derivation length: 1
production:
A(n) --> B(half(n), kind(n)) C(n > 3) D((n, n))
endlsystem
"""
    got = LSystem(g, trusted=True).derive(1).modules()
    assert got == [("B", (2.0, "int")), ("C", (True,)), ("D", ((4, 4),)),
                   ("B", (-1.0, "float")), ("C", (False,)), ("D", ((2.5, 2.5),)),
                   ("B", (3.0, "int")), ("C", (True,)), ("D", ((7, 7),))]


def test_batch_condition_and_later_rules_and_turtle_vectors():
    g = """
def big(x):
    return x > 2

def up(x):
    return (0, 0, x)

Axiom: A(1) A(3) A(5)
derivation length: 1
production:
A(x) : big(x) --> SetHead(up(x)) F(x)
A(x) --> G(x + 10)
endlsystem
"""
    got = LSystem(g, trusted=True).derive(1).modules()
    assert got == [("G", (11.0,)), ("SetHead", (0.0, 0.0, 3.0)), ("F", (3.0,)),
                   ("SetHead", (0.0, 0.0, 5.0)), ("F", (5.0,))]


def test_batch_errors_name_the_line():
    g = "def f(x):\n    return 1 / (x - 2)\n\nAxiom: A(1) A(2)\nderivation length: 1\nproduction:\nA(x) --> A(f(x))\nendlsystem\n"
    with pytest.raises(LSystemError, match=r"line 2.*ZeroDivisionError"):
        LSystem(g, trusted=True).derive(1)
    g2 = g.replace("return 1 / (x - 2)", "return x").replace("A(f(x))", "A(f(x) + undefined_name)")
    with pytest.raises(LSystemError, match=r"line 7.*NameError"):
        LSystem(g2, trusted=True).derive(1)


def test_batch_module_cap_and_time_budget_hold_inside_a_step():
    g = "def f(x):\n    return x\n\nAxiom: A(1)\nderivation length: 30\nproduction:\n" \
        "A(x) --> A(f(x)) A(f(x)) A(f(x))\nendlsystem\n"
    with pytest.raises(LSystemError, match=r"line 7.*more than max_modules = 1,000"):
        LSystem(g, trusted=True, max_modules=1000).derive(30)
    slow = "import time\ndef f(x):\n    time.sleep(0.01)\n    return x\n\nAxiom: A(1)\nderivation length: 30\n" \
           "production:\nA(x) --> A(f(x)) A(f(x))\nendlsystem\n"
    with pytest.raises(LSystemError, match=r"time budget of 0.5 s exceeded"):
        LSystem(slow, trusted=True, time_budget=0.5).derive(30)


def test_float_literals_are_unguarded_but_bombs_are_still_refused():
    g = "def f(x):\n    return [0] * x\n\nAxiom: A(10000000000)\nderivation length: 1\nproduction:\n" \
        "A(x) --> B(len(f(x)))\nendlsystem\n"
    with pytest.raises(LSystemError, match="too long|too large|longer"):
        LSystem(g, trusted=True).derive(1)
    g2 = "def f(x):\n    return [0] * 1.5\n\nAxiom: A(1)\nderivation length: 1\nproduction:\nA(x) --> B(f(x))\nendlsystem\n"
    with pytest.raises(LSystemError, match=r"line 2.*TypeError"):
        LSystem(g2, trusted=True).derive(1)
    g3 = "def f(x):\n    y = x\n    y *= -0.5\n    return y * 1.01\n\nAxiom: A(2)\nderivation length: 1\n" \
         "production:\nA(x) --> B(f(x))\nendlsystem\n"
    assert LSystem(g3, trusted=True).derive(1).modules() == [("B", (2 * -0.5 * 1.01,))]

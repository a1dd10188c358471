"""L-Py's Fibonacci test (test/fibonacci.lpy, test_backward in L-Py's suite), ported: decomposition with a
maximum depth, backward() and a new right context ``>>`` compute the Fibonacci numbers in one step."""
from __future__ import annotations

from pathlib import Path

from plantvr.lsystem.engine import LSystem

HERE = Path(__file__).parent / "grammars"


def test_backward():
    """Computation of the Fibonacci series using fast transfer in backward direction (L-Py's test_backward)."""
    ls = LSystem.from_file(HERE / "fibonacci.lpy", trusted=True)
    a = ls.derive()
    assert a.module(2)[1][0] == 6765
    assert a.module(3)[1][0] == 4181
    assert a.module(21)[1][0] == 1
    fib = [1, 1]
    while len(fib) < 20:
        fib.append(fib[-1] + fib[-2])
    assert [m[1][0] for m in a.modules()[2:]] == fib[::-1]


def test_fibonacci_extern_and_steps():
    ls = LSystem.from_file(HERE / "fibonacci.lpy", trusted=True)
    steps = list(ls.iterate())
    assert len(steps) == 3 and str(steps[0]) == "+(90);(3)A(20)"
    assert steps[1].count("I") == 20 and steps[1].count("A") == 0      # decomposed, max depth 100
    assert ls.derive().module(2)[1][0] == 6765                          # derive again: same result


def test_fibonacci_label_keeps_its_text():
    """``@L(str(i))`` holds the str (issue 33: module parameters of any Python value, as L-Py's)."""
    ls = LSystem.from_file(HERE / "fibonacci.lpy", trusted=True)
    h = ls.interpret(ls.derive())
    labels = [m[1][0] for m in h.modules() if m[0] == "@L"]
    fib = [1, 1]
    while len(fib) < 20:
        fib.append(fib[-1] + fib[-2])
    assert labels == [str(v) for v in fib[::-1]]

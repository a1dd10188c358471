"""ABOP ch. 1 figures derived by the engine (issue 23): exact module counts against growth matrices written by
hand from each grammar's successors (segment count = count of F, branch points = count of '[')."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plantvr.lsystem.engine import LSystem

HERE = Path(__file__).parent / "grammars"


def grown(symbols, axiom, successors, n):
    """Counts of ``symbols`` after ``n`` steps: row vector axiom @ M^n, M[a, b] = count of b in a's successor
    (identity for symbols without a rule)."""
    k = len(symbols)
    M = np.eye(k, dtype=object)
    for a, row in successors.items():
        M[symbols.index(a)] = [row.get(b, 0) for b in symbols]
    v = np.array([axiom.get(s, 0) for s in symbols], dtype=object)
    for _ in range(n):
        v = v.dot(M)
    return dict(zip(symbols, v.tolist()))


CASES = {
    "abop_1_24a": (["F", "[", "]", "+", "-"], {"F": 1},
                   {"F": {"F": 5, "[": 2, "]": 2, "+": 1, "-": 1}}, 5),
    "abop_1_24b": (["F", "[", "]", "+", "-"], {"F": 1},
                   {"F": {"F": 5, "[": 3, "]": 3, "+": 1, "-": 1}}, 5),
    "abop_1_24c": (["F", "[", "]", "+", "-"], {"F": 1},
                   {"F": {"F": 8, "[": 2, "]": 2, "+": 4, "-": 4}}, 4),
    "abop_1_24d": (["X", "F", "[", "]", "+", "-"], {"X": 1},
                   {"X": {"X": 3, "F": 2, "[": 2, "]": 2, "+": 2, "-": 1}, "F": {"F": 2}}, 7),
    "abop_1_24e": (["X", "F", "[", "]", "+", "-"], {"X": 1},
                   {"X": {"X": 3, "F": 2, "[": 2, "]": 2, "+": 1, "-": 1}, "F": {"F": 2}}, 7),
    "abop_1_24f": (["X", "F", "[", "]", "+", "-"], {"X": 1},
                   {"X": {"X": 4, "F": 3, "[": 3, "]": 3, "+": 3, "-": 2}, "F": {"F": 2}}, 5),
    "abop_1_25": (["A", "F", "S", "L", "[", "/", ";"], {"A": 1},
                  {"A": {"A": 3, "F": 3, "L": 3, "[": 3, "/": 12, ";": 2}, "F": {"S": 1, "/": 5, "F": 1},
                   "S": {"F": 1, "L": 1}}, 7),
    "abop_1_26": (["plant", "internode", "seg", "leaf", "flower", "pedicel", "wedge", "F", "["], {"plant": 1},
                  {"plant": {"internode": 2, "plant": 3, "flower": 3, "leaf": 2, "[": 4},
                   "internode": {"F": 2, "seg": 2, "leaf": 2, "[": 2}, "seg": {"seg": 2, "F": 1},
                   "leaf": {"[": 1}, "flower": {"[": 1, "pedicel": 1, "wedge": 5}, "pedicel": {"F": 2},
                   "wedge": {"[": 2, "F": 1}}, 5),
    "koch_island": (["F", "+", "-"], {"F": 4, "-": 3}, {"F": {"F": 8, "+": 3, "-": 3}}, 3),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_abop_counts(name):
    symbols, axiom, succ, n = CASES[name]
    ls = LSystem.from_file(HERE / f"{name}.lpy")
    assert ls.derivation_length == n
    s = ls.derive()
    want = grown(symbols, axiom, succ, n)
    for sym in symbols:
        assert s.count(sym) == want[sym], (name, sym)
    assert s.count("[") == s.count("]")
    t = ls.tree(width_increment=0.01)                       # ABOP's '!' narrows, never below zero here
    assert len(t.parent) == want["F"] + 1                    # one node per F plus the root


def test_abop_1_24a_closed_form():
    s = LSystem.from_file(HERE / "abop_1_24a.lpy").derive()
    assert s.count("F") == 5 ** 5 and s.count("[") == 2 * (5 ** 5 - 1) // 4
    assert s.module(1) == ("[", ())
    assert s.module(2) == ("+", (25.7,))                     # degrees kept as written


def test_sierpinski_homomorphism_to_F():
    ls = LSystem.from_file(HERE / "sierpinski.lpy")
    s = ls.derive()
    assert s.count("F") == 0 and s.count("L") + s.count("R") == 3 ** 6
    drawn = ls.interpret(s)
    assert drawn.count("F") == 3 ** 6 and drawn.count("L") == drawn.count("R") == 0
    assert drawn.count("+") + drawn.count("-") == 3 ** 6 - 1
    assert len(ls.tree(angle=60).parent) == 3 ** 6 + 1


def test_koch_island_is_closed():
    ls = LSystem.from_file(HERE / "koch_island.lpy")
    assert ls.turtle_options == {"angle": 90.0}
    t = ls.tree()
    assert np.allclose(t.pos[-1], t.pos[0], atol=1e-9)       # the island closes on its start
    assert np.ptp(t.pos, axis=0).min() < 1e-9                # planar

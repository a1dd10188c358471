"""Named module parameters (issue 33): ``module A(x, t)`` names A's last two values; ``**kwds`` in a pattern binds
them as a dict, ``A(**p)`` in a successor places them by name (L-Py's ``matching.cpp`` and ``module.cpp``). The
expected bindings are L-Py's own, from its test_kwd.lpy / test_kwd2.lpy asserts."""
from __future__ import annotations

import pytest

from plantvr.lsystem import LSystem, LSystemError


def _bound(pattern: str, axiom: str):
    """What ``pattern`` binds on the axiom's module (``None``: no match), ``module A(x,t)`` declared."""
    names = [a.strip().lstrip("*") for a in pattern[pattern.index("(") + 1:-1].split(",")]
    g = (f"got = []\nmodule A(x,t)\nAxiom: {axiom}\nderivation length: 1\nproduction:\n{pattern} :\n"
         f"  got.append(({', '.join(names)},))\nendlsystem\n")
    ls = LSystem(g, trusted=True)
    ls.derive()
    return ls._ns["got"][0] if ls._ns["got"] else None


@pytest.mark.parametrize("pattern, two, three", [
    ("*(*args)", (["A", 1, 2],), (["A", 1, 2, 3],)),
    ("*(**kwds)", ({"x": 1, "name": "A", "t": 2},), None),
    ("*(*args,**kwds)", ([], {"x": 1, "name": "A", "t": 2}), ([1], {"x": 2, "name": "A", "t": 3})),
    ("*(name,*args,**kwds)", ("A", [], {"x": 1, "t": 2}), ("A", [1], {"x": 2, "t": 3})),
    ("*(name,x,*args,**kwds)", ("A", 1, [], {"t": 2}), ("A", 1, [], {"x": 2, "t": 3})),
    ("*(name,x,y,*args,**kwds)", ("A", 1, 2, [], {}), ("A", 1, 2, [], {"t": 3})),
    ("*(name,x,y,z,*args,**kwds)", None, ("A", 1, 2, 3, [], {})),
    ("*(name,**kwds)", ("A", {"x": 1, "t": 2}), None),
    ("*(name,x,**kwds)", ("A", 1, {"t": 2}), ("A", 1, {"x": 2, "t": 3})),
    ("A(**kwds)", ({"x": 1, "t": 2},), None),
    ("A(*args,**kwds)", ([], {"x": 1, "t": 2}), ([1], {"x": 2, "t": 3})),
    ("A(x,*args,**kwds)", (1, [], {"t": 2}), (1, [], {"x": 2, "t": 3})),
    ("A(x,**kwds)", (1, {"t": 2}), (1, {"x": 2, "t": 3})),
    ("A(x,y,**kwds)", (1, 2, {}), (1, 2, {"t": 3})),
    ("A(x,y,z,**kwds)", None, (1, 2, 3, {})),
])
def test_kwds_bind_as_l_py_does(pattern, two, three):
    assert _bound(pattern, "A(1,2)") == two
    assert _bound(pattern, "A(1,2,3)") == three


def test_successor_places_parameters_by_name():
    """L-Py's test_deflatekwd.lpy: ``A(**p)`` after ``p['y'] += 1`` gives A(0,1); keywords after positional
    values fill the rest of the declaration."""
    g = "module A(x,y)\nAxiom: A(0,0)\nderivation length: 1\nproduction:\nA(**p) :\n  p['y'] += 1\n" \
        "  produce A(**p) B(7, **{'y': 2})\nendlsystem\nmodule B(x, y)\n"
    assert str(LSystem(g, trusted=True).derive()) == "A(0,1)B(7,2)"
    assert str(LSystem("module A(x,y)\nAxiom: A(0,0)\nderivation length: 1\nproduction:\n"
                       "A(**p) --> A(**p) F\nendlsystem\n").derive()) == "A(0,0)F"          # untrusted too


@pytest.mark.parametrize("succ, what", [
    ("A(**{'x': 1})", r"line 5, column 1: A takes exactly 2 parameters \(1 given\)"),
    ("A(**{'x': 1, 'z': 2})", r"invalid parameter name 'z' for module 'A' \(declared: x, y\)"),
    ("A(1, **{'x': 1, 'y': 2})", r"A got multiple values for parameter 'x'"),
])
def test_bad_keywords_are_refused(succ, what):
    with pytest.raises(LSystemError, match=what):
        LSystem(f"module A(x,y)\nAxiom: A(0,0)\nderivation length: 1\nproduction:\nA(x, y) :\n  produce {succ}\n"
                "endlsystem\n", trusted=True).derive()


def test_node_module_reads_named_parameters_from_the_end():
    """``module A(x, t)`` on A(1, 2, 3): ``a.x`` is the second value and ``a.t`` the third (named parameters
    are the last ones, L-Py's ``getParameterPosition``)."""
    g = "got = []\nmodule A(x,t)\nAxiom: A(1,2,3)\nderivation length: 1\nproduction:\n$A(a) :\n" \
        "  got.append((a.x, a.t))\nendlsystem\n"
    ls = LSystem(g, trusted=True)
    ls.derive()
    assert ls._ns["got"] == [(2, 3)]

"""L-Py's ``$`` (issue 33): ``$A(a)`` patterns bind the module matched as a ``NodeModule`` (its parameters, by
position and declared name, and the axial tree around it, ``axialtree_manip.h``), ``$a`` puts it in a successor;
``new(name, *args)`` names a module at run time. Expected values are derived by hand in each test."""
from __future__ import annotations

import pytest

from plantvr.lsystem import LSystem, LSystemError


def test_l_py_test_getmod():
    """L-Py's test_getmod.lpy: with module inheritance, ``$A(a)`` matches A and its derived B; ``a.sons()`` is
    the list of children (None for none), ``a.position()`` the index in the string."""
    g = """result = {}
module A
module B: base = A

Axiom: AB

derivation length: 1
production:

$A(a) :
    assert a.name in 'AB'
    result[a.name] = (a.position(), str(a.sons()))
    produce A $a

endlsystem
###### INITIALISATION ######

def __initialiseContext__(context):
	context.options.setSelection('Module inheritance',1)
"""
    ls = LSystem(g, trusted=True)
    assert str(ls.derive()) == "AAAB"
    assert ls._ns["result"] == {"A": (0, "[B]"), "B": (1, "None")}


def test_l_py_test_getmod_sons():
    """L-Py's test_getmod_sons.lpy, whose End hook holds L-Py's string after two steps."""
    g = """module A
module B : base = A

Axiom: A[+B]B

derivation length: 2
production:

$A(a)  :
    produce new('A' if a.name == 'B' else 'B')[+$a]$a

endlsystem
###### INITIALISATION ######

def __initialiseContext__(context):
	context.options.setSelection('Module inheritance',1)
"""
    assert str(LSystem(g, trusted=True).derive()) == \
        "A[+B]B[+B[+A]A]B[+A]A[+B[+A]A[+A[+B]B]A[+B]B]B[+A]A[+A[+B]B]A[+B]B"


def _walk(axiom: str, rule: str, decl: str = "module A, B, C, D, E, F") -> dict:
    g = f"out = {{}}\n{decl}\nAxiom: {axiom}\nderivation length: 1\nproduction:\n{rule}\nendlsystem\n"
    ls = LSystem(g, trusted=True)
    ls.derive()
    return ls._ns["out"]


def test_node_module_walks_the_axial_tree():
    """``A [ B C ] [ D ] E [ F ]``: A's children are B, D (lateral, in string order) then E (direct); E's parent
    skips both branches back to A, C's parent is B, F's is E; A is the root and has no parent."""
    rules = """$A(a) :
  out['A'] = (str(a.children()), str(a.lateral_children()), str(a.direct_child()), a.parent(), a.isRoot())
$E(e) :
  out['E'] = (str(e.parent()), e.parent().position(), str(e.children()), e.direct_child())
$C(c) :
  out['C'] = (str(c.parent()), c.children(), c.isRoot(), c.isValid())
$F(f) :
  out['F'] = str(f.parent())
"""
    out = _walk("A [ B C ] [ D ] E [ F ]", rules)
    assert out["A"] == ("[B, D, E]", "[B, D]", "E", None, True)
    assert out["E"] == ("A", 0, "[F]", None)
    assert out["C"] == ("B", None, False, True)
    assert out["F"] == "E"


def test_ignored_modules_are_skipped_in_walks():
    """With ``ignore: +``, ``A + + B``: B's parent is A and A's direct child B (axialtree_manip's isIgnored)."""
    out = _walk("A + + B", "ignore: +\n$B(b) :\n  out['B'] = (str(b.parent()), str(b.parent().direct_child()))")
    assert out["B"] == ("A", "B")


def test_l_py_test_components():
    """L-Py's test_components.lpy: ``A(3) B [ B A(1) B ] B A(2) B B`` with A at scale 1 and B at 2; each A's
    components are the B's up to the next A (A(3): B@1, B@3, B@7 breadth first), as many as its parameter, by the
    name its declaration gives it."""
    rules = "$A(a) :\n  out[a.position()] = (a.nbcomponents, [c.position() for c in a.components()], " \
            "len(a.components_at_scale(2)), a.components_at_scale(1))"
    out = _walk("A(3) B [ B A(1) B ] B A(2) B B", rules,
                "module A(nbcomponents) : scale = 1\nmodule B : scale = 2")
    assert out == {0: (3, [1, 3, 7], 3, None), 4: (1, [5], 1, None), 8: (2, [9, 10], 2, None)}


def test_complex_is_the_first_parent_at_the_scale():
    """``P Q Q`` with P at scale 3, Q at 1: ``complex(3)`` of the last Q is P; ``complex()`` asks scale 1 + 1 = 2,
    which no module has (L-Py's NodeModule::complex)."""
    out = _walk("P Q Q", "$Q(q) :\n  out[q.position()] = (str(q.complex(3)), q.complex())",
                "module P : scale = 3\nmodule Q : scale = 1")
    assert out == {1: ("P", None), 2: ("P", None)}


def test_a_bound_module_is_changed_and_produced():
    """``a.age += 1`` (the declaration's name) and ``a[1] *= 2`` change the copy ``$a`` produces: after two steps
    A(0, 1) is A(2, 4), each step adding an F."""
    g = """module A(age, size)
Axiom: A(0, 1)
derivation length: 2
production:
$A(a) :
  a.age += 1
  a[1] *= 2
  produce $a F
endlsystem
"""
    assert str(LSystem(g, trusted=True).derive()) == "A(2,4)FF"
    assert str(LSystem("Axiom: F A(1)\nderivation length: 2\nproduction:\n$A(a) --> F $a\nendlsystem\n").derive()) \
        == "FFFA(1)"                                          # a one-line rule, untrusted


def test_repetitions_bind_lists_of_nodes():
    """L-Py's multiscalexmatching.lpy, as an axial tree: ``A > x($B(b))`` sees BBB then BB, ``x($B(b)) < A``
    nothing then BBB."""
    g = """right, left = [], []
Axiom: A BBB A BB
derivation length: 1
production:
A > x($B(b)):
  right.append([x.position() for x in b])
x($B(b)) < A:
  left.append(len(b))
endlsystem
"""
    ls = LSystem(g, trusted=True)
    ls.derive()
    assert ls._ns["right"] == [[1, 2, 3], [5, 6]] and ls._ns["left"] == [0, 3]   # no produce: the next rule


def test_dollar_with_parameters_in_a_successor_is_abop_roll():
    """ABOP's ``$C(l, w)`` (roll to vertical, then C), which L-Py cannot read (its ``$`` takes a variable name
    only), stays a roll and a module; ``$a`` without parameters is L-Py's bound module."""
    ls = LSystem("Axiom: A(1)\nderivation length: 1\nproduction:\nA(x) --> F[$C(x, 2)]\nendlsystem\n")
    assert ls.derive().modules() == [("F", ()), ("[", ()), ("$", ()), ("C", (1.0, 2.0)), ("]", ())]


def test_new_names_the_module_at_run_time():
    ls = LSystem("Axiom: A(1)\nderivation length: 1\nproduction:\nA(x) --> new('B', x + 1) newmodule('C') "
                 "new('F', 2)\nendlsystem\n")
    s = ls.derive()
    assert s.modules() == [("B", (2.0,)), ("C", ()), ("F", (2.0,))]
    assert ls.draw(s).pos.shape[0] == 2                # the F made by new is drawn


@pytest.mark.parametrize("rule, what", [
    ("A(x) --> new(3)", r"line 4, column 1: new\(name, \*args\) needs a module name \(a str\) first, got 3"),
    ("A(x) --> new('B C')", r"needs a module name"),
    ("A(x) :\n  a = 3\n  produce $a", r"line 4, column 1: \$a in a successor needs a module .* got int"),
    ("$A(a) :\n  print(a.size)", r"line 5, column 1: .*AttributeError: module A has no parameter 'size'"),
    ("$A(a) << A(x) --> B", r"line 4, column 1: \$A\(a\) in a new context"),
])
def test_bad_uses_are_refused_with_their_line(rule, what):
    with pytest.raises(LSystemError, match=what):
        ls = LSystem(f"module A(x)\nAxiom: A(1)\nproduction:\n{rule}\nendlsystem\n", trusted=True)
        ls.derive(1)


def test_string_matching_option_names_its_value():
    """``options.find('String matching').currentValue()`` (L-Py's multiscalexmatching2.lpy asks it)."""
    g = """seen = []
def StartEach():
  context().options.setSelection('String matching', 3)
  seen.append(context().options.find('String matching').currentValue())
  context().options.find('String matching').activateSelection()
Axiom: A
derivation length: 1
endlsystem
"""
    ls = LSystem(g, trusted=True)
    ls.derive()
    assert ls._ns["seen"] == ["As Multiscale AxialTree"]

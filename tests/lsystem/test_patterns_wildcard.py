"""Issue 33, L-Py's pattern constructs: the wildcard module ``*``, ``*args`` star parameters and the repetition
``x(pattern)`` in contexts.

Every expected string is written out by hand from L-Py's sources (``matching.cpp``:
``module_matching_with_star_and_valueconstraints``; ``matching_tmpl.h``: ``TreeLeftMatcher``,
``TreeRightMatcher``, ``RegExpMatcher``; ``lsysrule.cpp``: ``RulePtrMap`` gives a star rule to every module
class, brackets included) and L-Py's own tests (``test_starmatching.py``, ``test_regexpmatching.py``,
``test/lpytest/test_repexp.lpy``) for small axioms; no derivation code is shared with the engine."""
from __future__ import annotations

import pytest

from plantvr.lsystem.engine import LSystem, LSystemError


def derive(rules: str, axiom: str, n: int = 1, head: str = "", **kw):
    return LSystem(f"{head}Axiom: {axiom}\nproduction:\n{rules}\nendlsystem\n", **kw).derive(n)


# -- 1. the wildcard module ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("rules, expected", [
    # '*' matches any module, brackets included (a star rule is in every class's rule set)
    ("* --> F", "FFFFFF"),
    # rules are tried in file order: a rule before the star one wins, one after it never applies
    ("B --> X\n* --> F", "FXFFFF"),
    ("* --> F\nB --> X", "FFFFFF"),
    # *(n): a module without parameters, n its name
    ("*(n) --> E(n)", "A(1)E('B')E('[')E('C')E(']')D(2,3)"),
    # *(n, x): a module with one parameter; *(n, x, y): two
    ("*(n, x) --> E(n, x)", "E('A',1)B[C]D(2,3)"),
    ("*(n, x, y) --> E(n, x + y)", "A(1)B[C]E('D',5)"),
    # *(n, x, *r): at least one parameter, r the list of the others
    ("*(n, x, *r) --> E(n, x, r)", "E('A',1,[])B[C]E('D',2,[3])"),
    # *(n, *r): any module, its name and all its parameters as a list
    ("*(n, *r) --> E(n, len(r))", "E('A',1)E('B',0)E('[',0)E('C',0)E(']',0)E('D',2)"),
    # a constant: the module's parameter must equal it
    ("*(n, 1) --> E(n)", "E('A')B[C]D(2,3)"),
])
def test_star_predecessor(rules, expected):
    assert str(derive(rules, "A(1)B[C]D(2,3)")) == expected


def test_star_args_binds_name_and_parameters_as_one_list():
    """``*(*args)``: args is ``[name, *parameters]`` (L-Py's test_match_mod_with_starmod_stararg)."""
    s = derive("*(*a) --> E(a)", "A(2,3)B")
    assert s.modules() == [("E", (["A", 2, 3],)), ("E", (["B"],))]


@pytest.mark.parametrize("rules, expected", [
    ("D(x, *r) --> E(x, r)", "A(1)E(2,[3])E(4,[])"),
    ("D(*r) --> E(r)", "A(1)E([2, 3])E([4])"),
    ("D(x, y, *r) --> E(r)", "A(1)E([])D(4)"),
    ("D(2, *r) --> E(r)", "A(1)E([3])D(4)"),
])
def test_star_parameters(rules, expected):
    """``A(x, *rest)``: the parameters after the fixed ones as a list (empty when there are none; fewer
    parameters than the fixed ones do not match)."""
    assert str(derive(rules, "A(1)D(2,3)D(4)")) == expected


def test_star_parameters_unpacked_in_a_successor():
    """L-Py's test_deflateargs.lpy: ``A(*p)`` binds the list, ``produce A(*p)`` unpacks it again."""
    s = derive("A(*p) :\n    p[1] += 1\n    produce A(*p)", "A(0,0)", trusted=True)
    assert str(s) == "A(0,1)"


@pytest.mark.parametrize("rules, axiom, expected", [
    # a left context '*' is the parent module (lateral branches and brackets skipped)
    ("* < B --> X", "AB", "AX"),
    ("* < B --> X", "B", "B"),
    ("*(n) < X --> Y(n)", "A[B]X", "A[B]Y('A')"),
    # L-Py's test_match_left_context_with_param / test_match_right_context_with_params
    ("C(x) *(n, y) < A(z) --> R(x, n, y, z)", "C(1)B(2)A(3)", "C(1)B(2)R(1,'B',2,3)"),
    ("A(x) > *(n, y) C(z) --> R(x, n, y, z)", "A(1)B(2)C(3)", "R(1,'B',2,3)B(2)C(3)"),
    # a right context '*' is the next module, whatever it is: a lateral branch's '[' too
    ("A > * --> X", "A[B]C", "X[B]C"),
    ("A > *(n) --> X(n)", "A[B]C", "X('[')[B]C"),
    ("A > * --> X", "A", "A"),
    # a multi-module predecessor: consecutive modules
    ("A * --> X", "ABAC", "XX"),
])
def test_star_in_contexts(rules, axiom, expected):
    assert str(derive(rules, axiom)) == expected


def test_star_in_interpretation_rules():
    """Homomorphism ``*`` rules: a module with one parameter k drawn as F(k), one without as f."""
    ls = LSystem("Axiom: A(2)B\nproduction:\ninterpretation:\n*(n, k) --> F(k)\n*(n) --> f\nendlsystem\n")
    assert str(ls.interpret(ls.derive(1))) == "F(2)f"


def test_nested_repetition():
    """``x(I(a) x(J(b)))``: each I with its run of J; a and b lists per I, b a list of lists."""
    s = derive("A > x(I(a) x(J(b))) --> R(a, b)", "AI(1)J(2)J(3)I(4)I(5)J(6)")
    assert s.modules()[0] == ("R", ([1, 4, 5], [[2, 3], [], [6]]))


def test_star_new_left_context():
    """L-Py's test_match_new_left_context: ``* << A`` sees the new string (B already rewritten to C)."""
    assert str(derive("B --> C\n*(n) << A --> M(n)", "BA")) == "CM('C')"


# -- 2. repetitions --------------------------------------------------------------------------------------------
def test_repetition_left_context_lpy_test_repexp():
    """L-Py's test/lpytest/test_repexp.lpy: ``x(I(t)) < A`` on ``I(0)I(1)A`` binds t = [0, 1]."""
    assert derive("x(I(t)) < A --> B(t)", "I(0)I(1)A").modules()[-1] == ("B", ([0, 1],))


@pytest.mark.parametrize("rules, axiom, expected", [
    # no context at all: zero repetitions match (test_match_left/right_regexp_to_none)
    ("x(I) < A --> B", "A", "B"),
    ("A > x(I) --> B", "A", "B"),
    # fewer than the least count: no match
    ("x(I, 1, 3) < A --> B", "A", "A"),
])
def test_repetition_of_nothing(rules, axiom, expected):
    assert str(derive(rules, axiom)) == expected


def test_repetition_new_left_context_along_the_tree():
    """L-Py's test_match_regexp_including_start: ``x(I(x)) << I(y)`` binds the ancestors' values, root first
    ({0: [], 1: [0], 2: [0, 1], 3: [0, 1, 2], 4: [0, 1]}); each successor adds its J in a lateral branch, which
    the later left contexts skip."""
    s = derive("x(I(a)) << I(y) --> I(y)[J(a)]", "I(0) [ I(1) [ I(2) I(3) ] I(4) ]")
    assert [p[0] for name, p in s.modules() if name == "J"] == [[], [0], [0, 1], [0, 1, 2], [0, 1]]


@pytest.mark.parametrize("rules, expected", [
    # greedy along the axis, lateral branches skipped; inside the branch the ']' ends it
    ("I(a) > x(I(t)) --> J(a, t)", "J(0,[2, 3])[J(1,[])]J(2,[3])J(3,[])A"),
    # lo to hi times, then the rest of the context
    ("I(a) > x(I(t), 1, 2) A --> J(a, t)", "J(0,[2, 3])[I(1)]J(2,[3])I(3)A"),
    # x(pattern, n): n times exactly
    ("I(a) > x(I(t), 1) --> J(a, t)", "J(0,[2])[I(1)]J(2,[3])I(3)A"),
    # greedy, no backtracking: x(I) takes every I, none is left for the I after it
    ("I(a) > x(I(t)) I(u) --> J(a, t, u)", "I(0)[I(1)]I(2)I(3)A"),
    # a constant inside the repetition ends it
    ("I(a) > x(I(2)) --> J(a)", "J(0)[J(1)]J(2)J(3)A"),
    ("I(a) > x(I(2), 1) --> J(a)", "J(0)[I(1)]I(2)I(3)A"),
])
def test_repetition_right_context(rules, expected):
    assert str(derive(rules, "I(0)[I(1)]I(2)I(3)A")) == expected


def test_repetition_of_lateral_branches():
    """``x([I(b)])`` (L-Py's spacecolonization.lpy): the first module of each lateral branch in a row, the rest of a
    branch skipped by its ']'; at the string's end, none."""
    s = derive("I(a) > x([I(b)]) --> K(a, b)", "I(0)[I(1)F][I(2)]I(3)")
    assert str(s) == "K(0,[1, 2])[K(1,[])F][K(2,[])]K(3,[])"


def test_repetition_new_right_context_backward():
    """Backward, ``>>`` reads the new string: I(1) becomes I(1 + 5) before I(0) sums its branches' I (6 + 2)."""
    s = derive("I(a) >> x([I(b)]) --> I(a + sum(b))", "I(0)[I(1)[I(5)]][I(2)]", head="def Start(): backward()\n",
               trusted=True)
    assert str(s) == "I(8)[I(6)[I(5)]][I(2)]"


def test_repetition_at_the_string_end_after_other_modules_fails_as_lpy():
    """L-Py's ``TreeRightMatcher`` stops at the string's end with pattern modules left: ``A > B x(C)`` fails on
    ``AB`` (and matches when something follows, or when the context starts at the end)."""
    assert str(derive("A > B x(C) --> X", "AB")) == "AB"
    assert str(derive("A > B x(C) --> X", "[AB]")) == "[XB]"
    assert str(derive("A > x(C) --> X", "A")) == "X"


# -- 3. brackets first in a predecessor ---------------------------------------------------------------------------
@pytest.mark.parametrize("rules, axiom, expected", [
    # walnut4.lpy's '[] -->': empty branches dropped (the rule is L-Py's rule of class '[')
    ("[] -->", "A[]B[[]C]", "AB[C]"),
    ("[] --> F", "A[]B[[]C]", "AFB[FC]"),
    ("[ B ] --> D", "A[B]C[B]", "ADCD"),
    ("[ *(n) ] --> E(n)", "A[B]C[D(1)]", "AE('B')C[D(1)]"),
])
def test_bracket_first_predecessor(rules, axiom, expected):
    assert str(derive(rules, axiom)) == expected


def test_bracket_first_predecessor_backward():
    """L-Py's test/lpytest/test_backward_multimatch.lpy: backward, '[]' is found by its ']'."""
    assert str(derive("[] --> F", "[]", head="def Start(): backward()\n", trusted=True)) == "F"


# -- 4. '[' in a left context ----------------------------------------------------------------------------------
@pytest.mark.parametrize("rules, axiom, head, expected", [
    # L-Py's test_match_bracket_right_context: only the A right after the '[' (a '[' is the module just before,
    # the pattern module left of it that '['s parent)
    ("I [ < A --> B", "I [ A ] A", "", "I[B]A"),
    # test_match_multiple_brackets_right_context
    ("I(x) [ I(y) [ < A --> B(x, y)", "I(0) [ I(1) [ A ] ]", "", "I(0)[I(1)[B(0,1)]]"),
    # test_consider_per_rule.lpy: an ignored module between the '[' and the module is skipped
    ("F [ < A --> B", "F[+A]F[-A]A", "ignore: +-\n", "F[+B]F[-B]A"),
    ("F [ < A --> B", "F[+A]F[-A]A", "", "F[+A]F[-A]A"),
    # a '[' in a new left context: the new string's module before (B, rewritten to C, opened it)
    ("B --> C\nC [ << A --> D", "B[A]", "", "C[D]"),
])
def test_bracket_in_left_context(rules, axiom, head, expected):
    assert str(derive(rules, axiom, head=head)) == expected


# -- 5. what stays refused ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("rules, col, match", [
    ("x(A) B --> C", 1, r"repetition pattern x\(\.\.\.\) in a predecessor"),
    ("or(B, C) --> B", 1, r"alternative pattern or\(...\) in a predecessor"),
    ("A > or() --> B", 5, r"alternative pattern or\(\) has no patterns"),
    ("A(**1) --> B", 1, r"keyword pattern parameter '\*\*1' of A must be '\*\*name'"),
    ("A(*r, x) --> B", 1, r"star parameter '\*r' of A must be the last"),
    ("A > x(B, 1, n) --> B", 13, r"repetition count 'n'"),
    ("A > x(B, 1, 2, 3) --> B", 5, r"at most two counts"),
    ("?I(it) < A --> B", 1, r"iterator request \?I"),
    ("A > all --> B", 5, r"repetition pattern all has no pattern"),
    ("A > None --> B", 5, r"the empty pattern None outside or"),
    ("F=] < A --> B", 2, r"the exact closing bracket =\] is supported in right contexts only"),
    ("A > " + "x(" * 40 + "B" + ")" * 40 + " --> B", 5 + 2 * 16, r"nested more than 16 deep"),
    ("A ] < B --> C", 3, r"'\]' in a left context is not supported"),
    ("A > x(I(y)) --> B(y)\nI(y) > x(I(y)) --> B", 10, r"parameter 'y' defined twice"),
])
def test_unsupported_patterns_are_refused_with_line_and_column(rules, col, match):
    with pytest.raises(LSystemError, match=match) as err:
        LSystem(f"Axiom: A\nproduction:\n{rules}\nendlsystem\n")
    line = 3 + rules.count("\n")
    assert (err.value.line, err.value.column) == (line, col)


def test_or_alternatives_bind_the_first_that_matches():
    """``or(p1, p2, ...)`` (L-Py's ``RegExpMatcher``): the first alternative that matches binds its variables, the
    others' are None; ``None`` matches nothing."""
    rules = "A > or(B(x), C(y) D(z)) :\n  produce Z(x, y, z)"
    assert str(derive(rules, "AB(1) AC(2)D(3) AC(4) A", trusted=True)) == \
        "Z(1,None,None)B(1)Z(None,2,3)C(2)D(3)AC(4)A"
    assert str(derive("A > or(B(x), None) :\n  produce Z(x)", "AB(1) A", trusted=True)) == "Z(1)B(1)Z(None)"
    assert str(derive("or(B(x), C(y)) < A --> Z", "B(1)A C(1)A D A")) == "B(1)ZC(1)ZDA"   # left contexts too


def test_l_py_test_consider_bracket():
    """L-Py's test_consider_bracket.lpy: backward, with ``x([M(l)])`` and ``or(M(a), None)`` in a new right
    context: each N becomes M(1 + its lateral M values + its following M), giving L-Py's M(4) [M(1)] M(2) M(1)."""
    rules = "N(r) >> x([M(lnbelem)]) or( M(anbelem), None ) :\n  v = 1\n  if lnbelem : v += sum(lnbelem)\n" \
            "  if anbelem : v += anbelem\n  produce M(v)"
    s = derive(rules, "N(0) [ N(0) ] N(0) N(0)", head="backward()\nconsider: NM\n", trusted=True)
    assert str(s) == "M(4)[M(1)]M(2)M(1)"

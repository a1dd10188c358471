"""Issue 33, L-Py constructs once refused: module parameters of any Python value, constants in pattern
parameters, multi-module predecessors, rule groups and context-sensitive decomposition / homomorphism rules.

Every expected string is written out by hand from L-Py's semantics for a small axiom (no derivation code shared
with the engine)."""
from __future__ import annotations

import numpy as np
import pytest

from plantvr.lsystem.engine import LSystem, LSystemError
from plantvr.lsystem.modules import ModuleString


def mods(s: ModuleString) -> list:
    return s.modules()


# -- 1. parameters of any Python value ---------------------------------------------------------------------------
OBJECTS = """\
Axiom: A(1, "text") @L("label") B((1, 2), [3, 4], None, True)
derivation length: 2
production:
A(n, s) --> A(n + 1, s + "!") C(s)
B(t, l, z, b) --> B(t, l, z, not b)
C(s) --> C(s * 2)
endlsystem
"""


def test_object_parameters_untrusted_literals():
    """Strings, tuples, lists, None and booleans stay Python values in the string and reach rules as such
    (L-Py's modules hold any Python object: ``ParamModule`` arguments are ``boost::python::object`` s)."""
    ls = LSystem(OBJECTS)                                     # untrusted: literals only
    s1, s2 = ls.derive(1), ls.derive(2)
    assert mods(s1) == [("A", (2.0, "text!")), ("C", ("text",)), ("@L", ("label",)),
                        ("B", ((1, 2), [3, 4], None, False))]
    assert mods(s2) == [("A", (3.0, "text!!")), ("C", ("text!",)), ("C", ("texttext",)), ("@L", ("label",)),
                        ("B", ((1, 2), [3, 4], None, True))]
    assert str(s1) == "A(2,'text!')C('text')@L('label')B((1, 2),[3, 4],None,False)"
    assert np.isnan(s2.args[list(s2.objects)]).all() and s2.args[0] == 3.0


def test_object_parameters_numeric_strings_stay_on_the_fast_path():
    ls = LSystem("Axiom: A(1)\nproduction:\nA(x) --> A(x + 1)B\nendlsystem\n")
    s = ls.derive(3)
    assert not s.objects and str(s) == "A(4)BBB"


def test_object_parameters_copied_and_matched_in_context():
    """Modules holding objects are copied with their values; a context binds them."""
    ls = LSystem('Axiom: X("a") Y(1) X(2)\nproduction:\nX(s) < Y(n) --> Y(s)\nendlsystem\n')
    assert mods(ls.derive(1)) == [("X", ("a",)), ("Y", ("a",)), ("X", (2.0,))]
    assert mods(ls.derive(2)) == [("X", ("a",)), ("Y", ("a",)), ("X", (2.0,))]


def test_object_parameters_from_trusted_python():
    ls = LSystem("def lab(i):\n    return {'n': i}\nAxiom: A(0)\nproduction:\nA(i) :\n    produce A(i + 1) "
                 "B(lab(i))\nendlsystem\n", trusted=True)
    assert mods(ls.derive(2)) == [("A", (2.0,)), ("B", ({"n": 1},)), ("B", ({"n": 0},))]


def test_object_parameters_module_string_round_trip():
    s = ModuleString.from_modules([("F", (1,)), ("@L", ("hi",)), ("A", (None, 2.5))])
    assert s.modules() == [("F", (1.0,)), ("@L", ("hi",)), ("A", (None, 2.5))]
    assert dict(s.objects) == {1: "hi", 2: None}
    with pytest.raises(ValueError, match="NaN where objects"):
        ModuleString(s.names, s.ids, s.arg_ptr, np.zeros(4), {1: "x"})
    with pytest.raises(ValueError, match="objects keys"):
        ModuleString(s.names, s.ids, s.arg_ptr, s.args, {9: "x"})


def test_bool_comparison_parameter_stays_bool():
    """``A(x > 1)`` holds a bool, vectorised or not."""
    ls = LSystem("Axiom: A(0) A(2)\nproduction:\nA(x) --> B(x > 1)\nendlsystem\n")
    assert mods(ls.derive(1)) == [("B", (False,)), ("B", (True,))]


# -- 2. constants in pattern parameters --------------------------------------------------------------------------
def test_pattern_constants_match_only_their_value():
    """L-Py compares a predecessor's non-variable arguments with the module's (``M(0)`` matches M(0) only);
    the first rule that matches wins, so ``M(x)`` below takes the others."""
    text = ("Axiom: M(0) M(1) M(2) A(1, 5) A(2, 5) L('a') L('b')\nproduction:\nM(0) --> X\nM(x) --> M(x - 1)\n"
            "A(1, x) --> B(x)\nL('a') --> Y\nendlsystem\n")
    for ls in (LSystem(text), LSystem(text, trusted=True)):
        assert mods(ls.derive(1)) == [("X", ()), ("M", (0.0,)), ("M", (1.0,)), ("B", (5.0,)), ("A", (2.0, 5.0)),
                                      ("Y", ()), ("L", ("b",))]
        assert str(ls.derive(3)) == "XXXB(5)A(2,5)YL('b')"


def test_pattern_constants_vectorised_equal_python():
    """Many modules: the vectorised path (constants compared on the parameter column) gives Python's string."""
    axiom = " ".join(f"M({k % 3})" for k in range(300))
    text = f"Axiom: {axiom}\nproduction:\nM(1) --> N(2)\nM(x) --> M(x + 10)\nendlsystem\n"
    ls = LSystem(text)
    got = mods(ls.derive(1))
    assert got == [("N", (2.0,)) if k % 3 == 1 else ("M", (k % 3 + 10.0,)) for k in range(300)]
    assert ls._rules["production"][0].vec is not None and ls._rules["production"][0].const is None


def test_pattern_constants_in_contexts():
    ls = LSystem("Axiom: A(0) B A(1) B\nproduction:\nA(1) < B --> C\nB > A(1) --> D\nendlsystem\n")
    assert str(ls.derive(1)) == "A(0)DA(1)C"


def test_pattern_expression_is_a_value_constraint():
    """L-Py's ``parse_variable``: ``F(x + 1)`` binds ``x`` and the whole text is the condition (truthy)."""
    assert str(LSystem("Axiom: F(1) F(-1)\nproduction:\nF(x + 1) --> G(x)\n").derive(1)) == "G(1)F(-1)"
    with pytest.raises(LSystemError, match=r"line 3, column 1: .*'1 \+' of F must be a variable name, a constant"):
        LSystem("Axiom: F\nproduction:\nF(1 +) --> F\n")


# -- 3. multi-module predecessors --------------------------------------------------------------------------------
def test_multi_module_predecessor_replaces_consecutive_modules():
    """``A B --> C`` replaces an A immediately followed by a B (L-Py's ``LsysRule::match``: the predecessor's
    modules at consecutive positions), scanning left to right: in ``ABB`` the first B goes with the A, the second
    is rewritten by its own rule; ``AAB``: the first A has no B after it."""
    ls = LSystem("Axiom: A B B A A B\nproduction:\nA B --> C\nB --> D\nendlsystem\n")
    assert str(ls.derive(1)) == "CDAC"


def test_multi_module_predecessor_parameters_and_contexts():
    text = ("Axiom: X(0) A(1) B(2) A(3) [B(5)] Y\nproduction:\nA(x) B(y) --> S(x + y)\n"
            "X(w) < A(x) B(y) > A(z) --> T(w, x, y, z)\nA(z) > Y --> U(z)\nendlsystem\n")
    for ls in (LSystem(text), LSystem(text, trusted=True)):
        # the first rule in file order takes A(1) B(2); A(3) sees Y past the lateral branch [B(5)]
        assert str(ls.derive(1)) == "X(0)S(3)U(3)[B(5)]Y"
    ls = LSystem("Axiom: X(0) A(1) B(2) A(3)\nproduction:\nX(w) < A(x) B(y) > A(z) --> T(w, x, y, z)\n"
                 "endlsystem\n")
    assert str(ls.derive(1)) == "X(0)T(0,1,2,3)A(3)"
    ls = LSystem("Axiom: A(1) B(2) [F] A(7)\nproduction:\nA(x) B(y) > A(z) --> T(x, y, z)\nendlsystem\n")
    assert str(ls.derive(1)) == "T(1,2,7)[F]A(7)"             # the right context skips the lateral branch


def test_multi_module_predecessor_with_constants_and_objects():
    ls = LSystem("Axiom: A(0) B A(1) B A('s') B\nproduction:\nA(1) B --> Z\nA(x) B --> W(x)\nendlsystem\n")
    assert mods(ls.derive(1)) == [("W", (0.0,)), ("Z", ()), ("W", ("s",))]


def test_multi_module_predecessor_with_brackets():
    """L-Py's ``StringMatcher`` matches a predecessor's brackets as modules, one after another."""
    ls = LSystem("Axiom: A [ B ] C A [ B ] A B\nproduction:\nA [ B ] C --> D\nA [ B ] --> E\nendlsystem\n")
    assert str(ls.derive(1)) == "DEAB"
    # brackets need not balance (L-Py checks none; its walnut.lpy draws with '[S(p, d) --> [ _(d/2) OLineTo(..)')
    ls = LSystem("Axiom: A[TC]T[T]C\nproduction:\n[T --> [X\nT] --> Y]\nT --> Z\nA ] T --> Q\nendlsystem\n")
    assert str(ls.derive(1)) == "A[XC]Z[X]C"
    ls = LSystem("Axiom: [A]T[B]\nproduction:\nA ] T [ --> C\nendlsystem\n")
    assert str(ls.derive(1)) == "[CB]"


# -- 4. rule groups ----------------------------------------------------------------------------------------------
GROUPS = """\
def EndEach():
    useGroup(1 if getIterationNb() % 2 == 0 else 2)
Axiom: A
derivation length: 4
production:
A --> A B
group 1:
B --> C
A --> X A
group 2:
C --> D
endgroup
D --> E
endlsystem
"""


def test_groups_switched_by_use_group_in_end_each():
    """L-Py's ``Lsystem::__getRules``: the active group's rules (file order) come first, then group 0's; the
    group is read at the start of each step, so ``useGroup`` in EndEach switches the next step's rules.
    Step 1 (group 0): A -> AB.  Step 2 (group 1: B->C, A->XA, then A->AB, D->E): AB -> XAC.
    Step 3 (group 2: C->D, then A->AB, D->E): XAC -> XABD.  Step 4 (group 1): XABD -> XXACE."""
    ls = LSystem(GROUPS, trusted=True)
    assert [str(s) for s in ls.iterate()] == ["A", "AB", "XAC", "XABD", "XXACE"]
    assert str(ls.derive()) == "XXACE"                         # again: the derivation starts in group 0


def test_groups_untrusted_top_level_use_group():
    text = "useGroup(1)\nAxiom: A\nproduction:\nA --> B\ngroup 1:\nA --> C\nB --> D\nendgroup\nendlsystem\n"
    ls = LSystem(text)
    assert str(ls.derive(1)) == "C" and str(ls.derive(2)) == "C"
    ls = LSystem(text.replace("useGroup(1)\n", ""))          # group 0 only: B has no rule there
    assert str(ls.derive(2)) == "B"
    ls = LSystem(text.replace("useGroup(1)", "useGroup(7)"))  # a group without rules: group 0's
    assert str(ls.derive(1)) == "B"


def test_groups_bad_values_refused():
    with pytest.raises(LSystemError, match=r"line 3, .*group must be an integer in \[0"):
        LSystem("Axiom: F\nproduction:\ngroup -1:\nF --> FF\n")
    with pytest.raises(LSystemError, match=r"line 1, .*useGroup needs an integer group"):
        LSystem("useGroup('a')\nAxiom: F\n")


# -- 5. context-sensitive decomposition and homomorphism ---------------------------------------------------------
def test_context_sensitive_decomposition_recursive_as_lpy():
    """L-Py's ``Lsystem::__recursiveSteps``: level 1 matches contexts in the whole string, each successor is then
    decomposed on its own (its contexts within it), up to ``maximum depth``.
    A B A C: B (left A) -> X Y, A (right C) -> W; level 2 in "X Y": X -> Z A; "W": nothing -> A Z A Y W C."""
    text = ("Axiom: A B A C\nproduction:\ndecomposition:\nmaximum depth: {d}\nA < B --> X Y\nX --> Z A\n"
            "A > C --> W\nendlsystem\n")
    assert str(LSystem(text.format(d=1)).derive(1)) == "AXYWC"
    assert str(LSystem(text.format(d=2)).derive(1)) == "AZAYWC"
    # level 2 sees only the successor: Y's right context C lies outside "Y", so Y stays
    ls = LSystem("Axiom: B C\nproduction:\ndecomposition:\nmaximum depth: 3\nB --> Y\nY > C --> V\n"
                 "endlsystem\n")
    assert str(ls.derive(1)) == "YC"
    ls = LSystem("Axiom: B C\nproduction:\ndecomposition:\nmaximum depth: 3\nB --> Y C\nY > C --> V\n"
                 "endlsystem\n")
    assert str(ls.derive(1)) == "VCC"


def test_context_sensitive_decomposition_after_production():
    ls = LSystem("Axiom: A(1) B\nproduction:\nA(x) --> A(x + 1)\ndecomposition:\nA(x) < B --> C(x)\nendlsystem\n")
    assert str(ls.derive(1)) == "A(2)C(2)" and str(ls.derive(2)) == "A(3)C(2)"


def test_context_sensitive_homomorphism():
    ls = LSystem("Axiom: A B B [A] B\nhomomorphism:\nA < B --> F(1)\nB > [A] --> F(2)\nendlsystem\n")
    assert str(ls.interpret(ls.axiom)) == "AF(1)F(2)[A]B"


def test_new_contexts_in_homomorphism_refused():
    with pytest.raises(LSystemError, match=r"line 3, column 1: new contexts .* homomorphism rules"):
        LSystem("Axiom: A\nhomomorphism:\nA << B --> F\nendlsystem\n")


def test_object_parameters_of_non_turtle_modules_do_not_change_the_skeleton():
    with pytest.warns(UserWarning, match="@g at module 6: .* got str"):
        a = LSystem('Axiom: F(1) B("x", None) [+F(2) @L("t") @g("x") @g] F(1)\n').tree(unsupported="warn")
    b = LSystem("Axiom: F(1) B [+F(2)] F(1)\n").tree()
    assert np.array_equal(a.pos, b.pos) and np.array_equal(a.parent, b.parent)


def test_object_parameters_beside_constant_rules():
    """A string holding objects leaves the numba tables (they copy floats only): the grouped path moves the
    objects of copied modules, step-wise and all at once alike."""
    ls = LSystem("Axiom: A B('x') A(2) C(None, 3)\nproduction:\nA --> A A\nA(x) --> D(x, 'y')\nendlsystem\n")
    want = [("A", ()), ("A", ()), ("A", ()), ("A", ()), ("B", ("x",)), ("D", (2.0, "y")), ("C", (None, 3.0))]
    assert mods(ls.derive(2)) == want
    assert [mods(s) for s in ls.iterate(2)][-1] == want


def test_multi_module_predecessor_backward():
    """After ``backward()`` the string is rewritten right to left and a predecessor ends at the module reached
    (L-Py's ``reverse_match``): ``A A --> C`` on A A A gives C A forward, A C backward."""
    rules = "production:\nA A --> C\nendlsystem\n"
    assert str(LSystem("Axiom: A A A\n" + rules).derive(1)) == "CA"
    ls = LSystem("def StartEach():\n    backward()\nAxiom: A A A\n" + rules, trusted=True)
    assert str(ls.derive(1)) == "AC"
    ls = LSystem("def StartEach():\n    backward()\nAxiom: X(1) A(2) B(3) A(4) B(5)\nproduction:\n"
                 "X(w) < A(x) B(y) --> S(w + x + y)\nA(x) B(y) > A(z) --> T(x, y, z)\nA(x) B(y) --> U(x, y)\n"
                 "endlsystem\n", trusted=True)
    assert str(ls.derive(1)) == "X(1)S(6)U(4,5)"

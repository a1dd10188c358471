"""L-Py's ``String matching`` option (issue 33): contexts read as a string, an axial tree (the default), a
multi-level or a multiscale axial tree, with module scales declared ``module A : scale = n``.

The grammars are after L-Py's test/lpytest multiscale tests (test_multiscale_leftcontext, test_complex_match,
test_msmatch, test_axial_msmatch, test_lateral_msmatch); expected matches are worked by hand from
``predecessor_at_scale`` / ``next_module_at_scale`` (``axialtree_manip.h``): in ``U I I I`` with U coarser,
U is the complex of each I, so ``U < I`` holds at every I.
"""
import pytest

from plantvr.lsystem import LSystem, LSystemError


def _grammar(decl: str, axiom: str, rules: str, mode: int | None, head: str = "") -> str:
    init = ("" if mode is None else
            f"###### INITIALISATION ######\n\ndef __initialiseContext__(context):\n"
            f"\tcontext.options.setSelection('String matching',{mode})\n")
    return f"{head}{decl}\nAxiom: {axiom}\n\nderivation length: 1\nproduction:\n\n{rules}\nendlsystem\n{init}"


def _derive(*args, **kw) -> str:
    return str(LSystem(_grammar(*args, **kw), trusted=True).derive())


SCALES = "module U : scale = 1\nmodule I : scale = 2\n"


@pytest.mark.parametrize("mode, expected", [
    (None, "UXIIUXII"),          # an axial tree: the I right after each U only
    (1, "UXIIUXII"),
    (0, "UXIIUXII"),             # a string: the same here (no branches)
    (3, "UXXXUXXX"),             # multiscale: U is the complex of every I
    (2, "UXXXUXXX"),             # multi-level: the I's (another level) are skipped
])
def test_left_context_at_a_coarser_scale(mode, expected):
    assert _derive(SCALES, "U I I I U I I I", "U < I --> X\n", mode) == expected


def test_new_left_context_at_a_coarser_scale():
    assert _derive(SCALES, "U I I I U I I I", "U << I --> X\n", 3) == "UXXXUXXX"
    assert _derive(SCALES, "U I I I U I I I", "U << I --> X\n", 1) == "UXIIUXII"


def test_right_context_at_a_coarser_scale():
    axiom = "U I I I U I I I U"
    assert _derive(SCALES, axiom, "I > U --> X\n", 3) == "UXXXUXXXU"
    assert _derive(SCALES, axiom, "I > U --> X\n", 1) == "UIIXUIIXU"


def test_complex_two_scales_up():
    """test_complex_match: P is N's complex through B (scales 1, 2, 3): ``P < N(x)`` holds at both N."""
    decl = "module P : scale = 1\nmodule B : scale = 2\nmodule N : scale = 3\n"
    assert _derive(decl, "PBN(0)BN(1)", "P < N(x) --> M(x)\n", 3) == "PBM(0)BM(1)"
    assert _derive(decl, "PBN(0)BN(1)", "P < N(x) --> M(x)\n", 1) == "PBN(0)BN(1)"


def test_predecessor_at_the_same_scale_through_branches():
    """test_msmatch: from C (scale 2) in the branch, ``TA(x)B < C``: B is C's complex (B(8)); from B, the
    predecessor at scale 2 is the tree parent A(2) (``predecessor_at_scale`` goes up complexes only when the
    pattern is coarser); from A(2), T is A(1)'s complex, the lateral branch [BA(4)] skipped."""
    decl = "module A,C : scale = 2\nmodule T,B : scale = 1\n"
    out = _derive(decl, "TA(1)[BA(4)]A(2)[BA(3)C]", "TA(x)B < C --> D(x)\n", 3)
    assert out == "TA(1)[BA(4)]A(2)[BA(3)D(2)]"
    assert _derive(decl, "TA(1)[BA(4)]A(2)[BA(3)C]", "TA(x)B < C --> D(x)\n", 1) == "TA(1)[BA(4)]A(2)[BA(3)C]"


@pytest.mark.parametrize("mode, expected", [(3, "B(8)"), (None, "B(2)")])
def test_right_context_skips_finer_modules(mode, expected):
    """test_axial_msmatch: at scale 1, ``[C(c)]D(d)`` right of B(2) skips the finer A(3) in the branch and A(5)
    after it (c = 0, d = 5); as an axial tree, A(3) is not C and nothing matches."""
    decl = "module A : scale = 2\nmodule C, B,D : scale = 1\n"
    axiom = "A(1)[A(2)C(0)]B(2)[A(3)C(0)[D(1)C(1)]]A(5)D(5)"
    out = _derive(decl, axiom, "A(a) < B(b) > [C(c)]D(d) --> B(a + b + c + d)\n", mode, head="ignore: +-\n")
    assert out == f"A(1)[A(2)C(0)]{expected}[A(3)C(0)[D(1)C(1)]]A(5)D(5)"


def test_lateral_branch_at_a_finer_scale():
    """test_lateral_msmatch: ``A(x) > [[A(y)]]`` from A(0) across the coarser B's to A(1)."""
    decl = "module A : scale = 3\nmodule B : scale = 2\n"
    assert _derive(decl, "A(0)B[B[BA(1)]]BA(2)", "A(x) > [[A(y)]] --> Z(x, y)\n", 3) == "Z(0,1)B[B[BA(1)]]BA(2)"


INHERIT = """module A(t)
module B : base = A, scale = 2
module C(x) : base = (A,B) # both
assert ModuleClass.get('C').issubclass(ModuleClass.get('A')) and not ModuleClass.get('A').issubclass(ModuleClass.get('B'))
assert ModuleClass.get('B').scale == 2 and ModuleClass.get('C').bases == ('A', 'B')
Axiom: C(1) B(2) A(3) D(4)

derivation length: 1
production:
{rules}
endlsystem
###### INITIALISATION ######
def __initialiseContext__(context):
\tcontext.options.setSelection('Module inheritance',{on})
"""


@pytest.mark.parametrize("on, rules, expected", [
    # test_inheritance / test_inheritance_simple: a pattern module matches the classes derived from it,
    # the first rule in file order applies
    (1, "A(x) --> X(x)\nB(x) --> Y(x)", "X(1)X(2)X(3)D(4)"),
    (1, "B(x) --> Y(x)\nA(x) --> X(x)", "Y(1)Y(2)X(3)D(4)"),
    (0, "A(x) --> X(x)\nB(x) --> Y(x)", "C(1)Y(2)X(3)D(4)"),
    # in contexts too
    (1, "A(x) < D(y) --> D(x + y)", "C(1)B(2)A(3)D(7)"),
    (1, "B(x) > B(y) --> E(x, y)", "E(1,2)B(2)A(3)D(4)"),
])
def test_module_inheritance_in_matching(on, rules, expected):
    assert str(LSystem(INHERIT.format(rules=rules, on=on), trusted=True).derive()) == expected


def test_repetitions_and_option_values_are_checked():
    with pytest.raises(LSystemError, match="Multiscale context and Regular Expression not compatible"):
        _derive(SCALES, "U I I", "U > x(I) --> X\n", 3)
    with pytest.raises(LSystemError, match=r"option 'String matching' takes an index in \[0, 3\]"):
        LSystem(_grammar(SCALES, "U", "", 7), trusted=True)
    with pytest.raises(LSystemError, match="ModuleClass.issubclass needs a ModuleClass"):
        LSystem("assert ModuleClass.get('A').issubclass('B')\nAxiom: A\n", trusted=True)

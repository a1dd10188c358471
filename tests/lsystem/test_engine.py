"""Engine behaviour (issue 23): parametric rules with conditions, vectorised plans equal to Python, stochastic
seeding, externs, decomposition, the module cap, numba kernels equal to their twins, and bad grammars."""
from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from plantvr.lsystem import _derive_kernels as K
from plantvr.lsystem import engine as E
from plantvr.lsystem.engine import MAX_MODULES, LSystem, LSystemError
from plantvr.lsystem.modules import ModuleString

HERE = Path(__file__).parent / "grammars"


def python_only(ls: LSystem) -> LSystem:
    for rules in ls._rules.values():
        for r in rules:
            r.vec = r.const = None
    ls._tables.clear()
    return ls


def same(a: ModuleString, b: ModuleString) -> bool:
    return (a.names == b.names and np.array_equal(a.ids, b.ids) and np.array_equal(a.arg_ptr, b.arg_ptr)
            and np.array_equal(a.args, b.args))


def test_parametric_conditions_vectorised_equal_python():
    fast = LSystem.from_file(HERE / "parametric.lpy", trusted=True)
    kinds = [(r.rule.header, r.vec is not None) for r in fast._rules["production"]]
    assert kinds == [("A(l, n)", True), ("A(l, n)", True), ("I(l)", True), ("L(l)", False)]
    slow = python_only(LSystem.from_file(HERE / "parametric.lpy", trusted=True))
    for n in range(8):
        assert same(fast.derive(n), slow.derive(n))
    s = fast.derive(2)
    assert str(s).startswith("I(1.02)[+(30)I(0.8)[+(30)A(0.64,4)]")
    assert fast.externs == {"ratio": 0.8, "depth": 6.0}
    other = LSystem.from_file(HERE / "parametric.lpy", ratio=0.5, depth=2, trusted=True)
    assert other.externs == {"ratio": 0.5, "depth": 2.0}
    assert other.derive(4).count("A") == 0


def test_constant_rules_use_kernel_and_keep_parameters():
    text = "Axiom: F(2)X\nderivation length: 3\nproduction:\nX --> F[+(30)X]-(2)X\nF --> FF\nendlsystem\n"
    ls = LSystem(text)
    assert ls._constant_table("production") is not None
    slow = python_only(LSystem(text))
    for n in range(4):
        assert same(ls.derive(n), slow.derive(n))
    assert ls.derive(1).module(0) == ("F", (2.0,))           # F(2) does not match the pattern F


def test_kernels_equal_twins():
    rng = np.random.default_rng(0)
    S = 6
    for _ in range(20):
        n = int(rng.integers(0, 60))
        ids = rng.integers(0, S, n).astype(np.int32)
        counts = rng.integers(0, 3, n)
        ptr = np.zeros(n + 1, np.int64)
        np.cumsum(counts, out=ptr[1:])
        args = rng.normal(size=int(ptr[-1]))
        arity = rng.integers(-1, 3, S).astype(np.int64)
        lens = rng.integers(0, 4, S)
        sptr = np.zeros(S + 1, np.int64)
        np.cumsum(lens, out=sptr[1:])
        sids = rng.integers(0, S, int(sptr[-1])).astype(np.int32)
        sc = rng.integers(0, 3, int(sptr[-1]))
        saptr = np.zeros(len(sids) + 1, np.int64)
        np.cumsum(sc, out=saptr[1:])
        sargs = rng.normal(size=int(saptr[-1]))
        n_out, m_out, hits = K.count_constant(ids, ptr, arity, sptr, saptr, True)
        assert (n_out, m_out, hits) == K.count_constant_py(ids, ptr, arity, sptr, saptr)
        oi, op, oa = np.empty(n_out, np.int32), np.empty(n_out + 1, np.int64), np.empty(m_out)
        K.fill_constant(ids, ptr, args, arity, sptr, sids, saptr, sargs, oi, op, oa, True)
        ti, tp, ta = K.fill_constant_py(ids, ptr, args, arity, sptr, sids, saptr, sargs)
        assert np.array_equal(oi, ti) and np.array_equal(op, tp) and np.array_equal(oa, ta)
        # no parameters anywhere: arg_ptr is neither read nor written (stays the zeros it was allocated as)
        z, zs = np.zeros(n + 1, np.int64), np.zeros(len(sids) + 1, np.int64)
        n0, m0, h0 = K.count_constant(ids, z, arity, sptr, zs, False)
        assert (n0, m0, h0) == K.count_constant_py(ids, z, arity, sptr, zs)
        oi, op = np.empty(n0, np.int32), np.zeros(n0 + 1, np.int64)
        K.fill_constant(ids, z, np.zeros(0), arity, sptr, sids, zs, np.zeros(0), oi, op, np.zeros(0), False)
        ti, tp, _ = K.fill_constant_py(ids, z, np.zeros(0), arity, sptr, sids, zs, np.zeros(0))
        assert np.array_equal(oi, ti) and np.array_equal(op, tp)
        b = rng.choice(np.array([0, 1, 2], np.int32), n)
        assert np.array_equal(K.match_brackets(b, 0, 1), K.match_brackets_py(b, 0, 1))


def test_stochastic_seeded_reproducible():
    a = LSystem.from_file(HERE / "stochastic.lpy", seed=1, trusted=True).derive()
    b = LSystem.from_file(HERE / "stochastic.lpy", seed=1, trusted=True).derive()
    c = LSystem.from_file(HERE / "stochastic.lpy", seed=2, trusted=True).derive()
    assert same(a, b) and not same(a, c)
    ls = LSystem.from_file(HERE / "stochastic.lpy", seed=1, trusted=True)
    assert same(ls.derive(), ls.derive())                    # reseeded at every derivation
    text = "from random import *\nAxiom: A\nproduction:\nA :\n    produce B(uniform(0, 1))\nendlsystem\n"
    x = LSystem(text, seed=5, trusted=True).derive(1).args[0]
    assert x == LSystem(text, seed=5, trusted=True).derive(1).args[0] == random.Random(5).uniform(0, 1)


def test_block_rules_nproduce_and_hooks():
    text = """
count = 0
def StartEach():
    global count
    count += 1
def side(n):
    nproduce [+F]
module Apex
Axiom: Apex(3)
derivation length: 5
production:
Apex(n) :
    if n > 0:
        side(n)
        nproduce F
        produce Apex(n - 1)
    # produces nothing at n = 0: the rule fails and the module stays
endlsystem
"""
    ls = LSystem(text, trusted=True)
    s = ls.derive()
    assert str(s) == "[+F]F[+F]F[+F]FApex(0)"
    assert ls._ns["count"] == 5


def test_decomposition_and_stop():
    text = ("Axiom: A(3)\nderivation length: 4\nproduction:\nA(n) --> A(n+1)\ndecomposition:\n"
            "maximum depth: 10\nA(n) :\n    if n > 1:\n        produce B A(n-1)\n")
    s = LSystem(text, trusted=True).derive(1)
    assert str(s) == "BBBA(1)"
    text2 = "def EndEach():\n    if getIterationNb() == 1: Stop()\nAxiom: F\nderivation length: 9\n" \
            "production:\nF --> FF\nendlsystem\n"
    assert len(list(LSystem(text2, trusted=True).iterate())) == 3


def test_module_cap_before_allocating():
    text = "Axiom: F\nproduction:\nF --> " + "F" * 1000 + "\nendlsystem\n"
    with pytest.raises(LSystemError, match="MAX_MODULES"):
        LSystem(text).derive(3)
    assert MAX_MODULES == 50_000_000
    text = "Axiom: A(0)\nproduction:\nA(x) --> " + "A(x+1)" * 400 + "\nendlsystem\n"
    with pytest.raises(LSystemError, match="MAX_MODULES"):
        LSystem(text).derive(3)


def test_lexer_names_and_degrees():
    ls = LSystem("module Apex\nAxiom: FF(0.5)+(30)F@Tp(0,0,-1)Apex(2)X\nproduction:\nendlsystem\n")
    assert ls.axiom.modules() == [("F", ()), ("F", (0.5,)), ("+", (30.0,)), ("F", ()), ("@Tp", (0.0, 0.0, -1.0)),
                                  ("Apex", (2.0,)), ("X", ())]


def test_undeclared_names_are_read_one_character_at_a_time_as_lpy():
    """L-Py reads the longest declared (or predefined) module name, else one character (issue 33)."""
    ls = LSystem("Axiom: A(1)\nderivation length: 1\nproduction:\nA(x) --> IB(x)Apex(2)SetColor(3)\nendlsystem\n")
    assert ls.derive().modules() == [("I", ()), ("B", (1.0,)), ("A", ()), ("p", ()), ("e", ()), ("x", (2.0,)),
                                     ("SetColor", (3.0,))]
    decl = LSystem("module IB, Ap\nAxiom: IB(1)Apex(2)\n")
    assert decl.axiom.modules() == [("IB", (1.0,)), ("Ap", ()), ("e", ()), ("x", (2.0,))]


BAD = [
    ("Axiom: F\nproduction:\nF --> F(1\n", 3, "unclosed"),
    ("Axiom: F\nproduction:\ngroup -1:\nF --> FF\n", 3, "group must be an integer"),
    ("Axiom: F\nproduction:\nF :\n    if True\n        produce F\n", 4, "syntax error"),
    ("Axiom: F(0)\nproduction:\nF(x) :\n    y = 1 / x\n    produce F(y)\n", 4, "ZeroDivisionError"),
    ("Axiom: F\nderivation length: foo\nproduction:\n", 2, "NameError"),
    ("Axiom: F\nproduction:\n    F --> F\n", 3, "unexpected indent"),
    ("Axiom: F\nproduction:\nF(**kw, x) --> F\n", 3, "keyword parameter '\\*\\*kw' of F must be the last"),
    ("Axiom: F\nproduction:\nF(1 +) --> F\n", 3, "a value constraint"),
    ("Axiom: F\nproduction:\nF --> F\n?I(x) < F --> F\n", 4, "iterator request"),
    ("Axiom: F\nx = 1 +\nproduction:\n", 2, "syntax error"),
    ("Axiom: F(nope)\nproduction:\n", 1, "NameError"),
]


@pytest.mark.parametrize("text, line, match", BAD)
def test_bad_grammar_line_and_column(text, line, match):
    with pytest.raises(LSystemError, match=match) as err:
        LSystem(text, trusted=True).derive(1)
    assert err.value.line == line and err.value.column >= 0
    assert str(err.value).startswith(f"line {line}, column {err.value.column}: ")


def test_unsupported_module_named_at_tree():
    ls = LSystem("Axiom: F@2D\nproduction:\nendlsystem\n")
    with pytest.raises(LSystemError, match=r"line 1, column 9: unsupported module @2D"):
        ls.tree()
    with pytest.raises(LSystemError, match=r"line 1, column 9: @g: PlantVR draws a PlantGL geometry, .* got float"):
        LSystem("Axiom: F@g(1)\nproduction:\nendlsystem\n").tree()


def test_unsupported_modules_can_be_left_out_of_the_picture():
    """A grammar in the style of L-Py's training models (stochastic block rules, a homomorphism with
    ``f``/``;``/``@O`` flowers, here colour interpolations, which the turtle does not draw; its spheres are
    drawn, see test_shapes.py): they are left out with a warning and never change the skeleton."""
    text = (HERE / "continuous_growth.lpy").read_text().replace("@O(FLOWER", "InterpolateColors(1, 2, FLOWER")
    ls = LSystem(text, seed=2, trusted=True)
    with pytest.raises(LSystemError, match="unsupported module InterpolateColors"):
        ls.tree()
    with pytest.warns(UserWarning, match=r"not drawn .*InterpolateColors \(line \d+\)"):
        tree = ls.tree(unsupported="warn")
    bare = LSystem(text.replace(";(4)InterpolateColors(1, 2, FLOWER * WIDTH * k)", ""), seed=2, trusted=True)
    ref = bare.tree()
    assert np.array_equal(tree.pos, ref.pos) and np.array_equal(tree.parent, ref.parent)
    assert tree.n_internodes == ls.derive().count("I") > 10
    with pytest.raises(ValueError, match="unsupported"):
        ls.tree(unsupported="skip")


def test_fuzzed_grammars_fail_cleanly():
    base = (HERE / "parametric.lpy").read_text()
    rng = np.random.default_rng(3)
    for _ in range(40):
        k = int(rng.integers(0, len(base)))
        text = base[:k] + base[k + 1:] if rng.random() < 0.5 else base[:k] + "([:>-"[rng.integers(5)] + base[k:]
        try:
            LSystem(text, trusted=True).derive(3)
        except LSystemError as e:
            assert e.line >= 0 and str(e).startswith("line ")
        except ValueError as e:                              # an unknown extern after a mutated name
            assert "extern" in str(e)


def test_door_validation():
    with pytest.raises(ValueError, match="text must be a str"):
        LSystem(3)
    with pytest.raises(ValueError, match="extern ratio must be a finite number"):
        LSystem.from_file(HERE / "parametric.lpy", ratio=float("nan"), trusted=True)
    with pytest.raises(ValueError, match="unknown extern 'ratoi'"):
        LSystem.from_file(HERE / "parametric.lpy", ratoi=1, trusted=True)
    ls = LSystem.from_file(HERE / "parametric.lpy", trusted=True)
    with pytest.raises(ValueError, match="n must be an integer"):
        ls.derive(-1)
    with pytest.raises(ValueError, match="string must be a ModuleString"):
        ls.derive(1, string="A(1,2)")
    s = ls.derive(1, string=ModuleString.from_modules([("A", (1.0, 1.0)), "Q"]))
    assert str(s).endswith("I(0.5)A(0.9,0)Q")


def test_turtle_modules_read_their_first_parameters_as_lpy():
    """Extra parameters of turtle modules are left out, as L-Py's turtle reads the first ones (issue 33)."""
    for extra, plain in [("F(1,2,3)", "F(1,2)"), ("-(30, 2)F", "-(30)F"), ("+(40,1)F&(20,3)F", "+(40)F&(20)F"),
                         ("_(0.3,2)F(1)", "_(0.3)F(1)"), ("@Tp(0,0,1,5)F", "@Tp(0,0,1)F")]:
        a, b = LSystem(f"Axiom: {extra}\n").tree(), LSystem(f"Axiom: {plain}\n").tree()
        assert np.array_equal(a.pos, b.pos) and np.array_equal(a.radius, b.radius), extra
    ls = LSystem("Axiom: F\nproduction:\nF --> F[-(a, t)F]\nendlsystem\n".replace("a, t", "25, 0.5"))
    plain = LSystem("Axiom: F\nproduction:\nF --> F[-(25)F]\nendlsystem\n")
    assert np.array_equal(ls.tree(2).pos, plain.tree(2).pos)
    assert str(ls.derive(1)) == "F[-(25,0.5)F]"                # the string keeps them
    with pytest.raises(LSystemError, match=r"line 1, column 9: .*parameter 0 = inf") as err:
        LSystem("Axiom: F-(1e999)\n").tree()
    assert err.value.line == 1


SEEDED = """\
import random
import random as rd
import numpy
from random import uniform
Axiom: A(0)
derivation length: 6
production:
A(k) :
    a = random.random()
    b = rd.randint(0, 1000)
    c = float(numpy.random.random())
    produce B(a, b, c, uniform(0, 1))A(k + 1)
endlsystem
"""


def test_one_seed_drives_every_generator_a_trusted_grammar_uses():
    """``seed=`` seeds ``random``, ``random.random``, ``rd.randint`` (``import random as rd``) and
    ``numpy.random`` inside the grammar, during derivation only: the program's generators are left as they were
    (issue 33)."""
    random.seed(99)
    np.random.seed(99)
    outside = (random.getstate(), np.random.get_state()[1].copy())
    a = LSystem(SEEDED, seed=4, trusted=True).derive()
    steps = list(LSystem(SEEDED, seed=4, trusted=True).iterate())
    b = LSystem(SEEDED, seed=4, trusted=True).derive()
    c = LSystem(SEEDED, seed=5, trusted=True).derive()
    assert same(a, b) and same(a, steps[-1]) and not same(a, c)
    params = np.array([m[1] for m in a.modules() if m[0] == "B"])
    assert len(params) == 6 and len(set(params[:, 0].tolist())) == 6 and len(set(params[:, 2].tolist())) == 6
    assert random.getstate() == outside[0] and np.array_equal(np.random.get_state()[1], outside[1])
    ls = LSystem(SEEDED, seed=4, trusted=True)
    it = ls.iterate()
    first = [next(it) for _ in range(3)]
    random.random()                                           # the caller's draws between steps change nothing
    np.random.random()
    assert same(list(it)[-1], a) and same(first[2], steps[2])


def test_every_error_has_a_line_and_column(tmp_path, monkeypatch):
    """Issue 33: cap errors, context() and useGroup misuse (a negative group), bad bytes: all located in the grammar."""
    monkeypatch.setattr(E, "MAX_MODULES", 100)
    cases = [("Axiom: F\nproduction:\nF --> FFF\nendlsystem\n", 5, 3),
             ("Axiom: F\nproduction:\nB --> B\nF --> FFF\nendlsystem\n", 5, 4),
             ("x = context().bogus\nAxiom: F\n", None, 1),
             ("def StartEach():\n    useGroup(-1)\nAxiom: F\nproduction:\nF --> F\nendlsystem\n", 2, 2),
             ("Axiom: F\nderivation length: context().frame\n", None, 2),
             ("Axiom: F\x00\n", None, 1)]
    for text, n, line in cases:
        with pytest.raises(LSystemError) as err:
            ls = LSystem(text, trusted=True)
            ls.derive(n) if n is not None else ls.derive()
        assert err.value.line == line and err.value.column >= 1, (text, str(err.value))
    p = tmp_path / "bad.lpy"
    p.write_bytes(b"Axiom: F\xff\n")
    with pytest.raises(LSystemError, match=r"line 1, column 9: grammar '.*bad.lpy' is not UTF-8"):
        LSystem.from_file(p)


def test_top_level_code_draws_from_the_seeded_generators_too():
    text = "import random\nimport numpy as np\nX = random.random()\nY = float(np.random.random())\nAxiom: F(X, Y)\n"
    state = random.getstate()
    a = LSystem(text, seed=8, trusted=True).axiom.args
    assert np.array_equal(a, LSystem(text, seed=8, trusted=True).axiom.args)
    assert a[0] == random.Random(8).random() and random.getstate() == state
    plain = "Axiom: F\nproduction:\nF :\n    produce F\nendlsystem\n"
    assert not LSystem(plain, seed=1, trusted=True)._global_random      # nothing to swap: no cost per step


# -- L-Py's axiom blocks and hooks that take the lstring ----------------------------------------------------------
def test_axiom_written_as_an_nproduce_block_as_lpy_reads_it():
    """``Axiom:`` with nothing after it and an indented block below: the block's ``nproduce`` statements make the
    axiom (L-Py's tutorials, e.g. ``05 - signals/01 - fibonacci.lpy``); a trusted grammar only."""
    text = ("n = 3\nAxiom:\n  nproduce -(90)\n  for i in range(n):  # one I per value\n    nproduce I(i)\n\n"
            "derivation length: 1\nproduction:\nI(x) --> I(x + 1)\nendlsystem\n")
    ls = LSystem(text, trusted=True)
    assert str(ls.axiom) == "-(90)I(0)I(1)I(2)" and str(ls.derive()) == "-(90)I(1)I(2)I(3)"
    with pytest.raises(LSystemError, match=r"line 2.*the axiom is a Python block.*trusted=True"):
        LSystem(text)
    with pytest.raises(LSystemError, match=r"line 5.*NameError"):
        LSystem(text.replace("I(i)", "I(j)"), trusted=True)
    empty = LSystem("Axiom:\n\nproduction:\nendlsystem\n", trusted=True)   # L-Py: the empty L-string
    assert str(empty.axiom) == str(empty.derive()) == "" and empty.tree().n_internodes == 0


def test_hooks_take_the_lstring_and_may_return_a_new_one():
    """``LsysContext::controlMethod``: ``StartEach(lstring)`` / ``EndEach(lstring[, scene])`` / ``End(lstring)``;
    an lstring returned replaces the string, None keeps it."""
    seen = []
    text = ("def StartEach(lstring):\n  seen.append(str(lstring))\n"
            "def EndEach(lstring, scene):\n  if len(lstring) > 4:\n    return lstring_of_a\n"
            "def End(lstring):\n  seen.append('end ' + str(lstring))\n"
            "Axiom: A\nderivation length: 3\nproduction:\nA --> AA\nendlsystem\n")
    ls = LSystem(text, trusted=True)
    ls._ns.update(seen=seen, lstring_of_a=ls.axiom)
    assert str(ls.derive()) == "A"                          # step 3's AAAAAAAA replaced by what EndEach returned
    assert seen == ["A", "AA", "AAAA", "end A"]
    ls = LSystem("seen = []\n" + text.replace("return lstring_of_a", "return None"), trusted=True)
    assert str(ls.derive()) == "AAAAAAAA" and ls._ns["seen"] == ["A", "AA", "AAAA", "end AAAAAAAA"]
    with pytest.raises(LSystemError, match=r"line 1.*EndEach\(\) must return None or an lstring"):
        LSystem("def EndEach(lstring):\n  return 3\nAxiom: A\nproduction:\nA --> AA\nendlsystem\n",
                trusted=True).derive(1)
    with pytest.raises(LSystemError, match=r"line 1.*StartEach\(\) takes the lstring at most"):
        LSystem("def StartEach(a, b):\n  pass\nAxiom: A\nendlsystem\n", trusted=True)


def test_lstring_and_getgroup_in_grammar_code():
    """L-Py's ``Lstring(text)`` (a hook returns it: ``02 - fractals/ifs.lpy``) and ``getGroup()``."""
    text = ("def EndEach(lstring):\n  if getGroup() == 0 and len(lstring) > 2:\n    return Lstring('B(1 + 1) [A]')\n"
            "Axiom: A\nderivation length: 3\nproduction:\nA --> AA\nendlsystem\n")
    assert str(LSystem(text, trusted=True).derive()) == "B(2)[A]"
    with pytest.raises(LSystemError, match="Lstring needs a str"):
        LSystem(text.replace("Lstring('B(1 + 1) [A]')", "Lstring(3)"), trusted=True).derive()

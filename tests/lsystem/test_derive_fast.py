"""All-at-once derivation of constant rules (issue 23, speed): ``LSystem.derive`` builds each expansion E(s, k) once
and copies it as a block; its result must be the step-wise one (``iterate``) array for array, on every grammar
fixture and on seeded random constant grammars; its kernels equal their Python twins."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plantvr.lsystem import _derive_kernels as K
from plantvr.lsystem import engine as E
from plantvr.lsystem.engine import LSystem, LSystemError
from plantvr.lsystem.modules import ModuleString

HERE = Path(__file__).parent / "grammars"
FIXTURES = sorted(p.stem for p in HERE.glob("*.lpy"))
CONSTANT = {"abop_1_24a", "abop_1_24b", "abop_1_24c", "abop_1_24d", "abop_1_24e", "abop_1_24f", "abop_1_25",
            "abop_1_26", "koch_island", "sierpinski"}
#: Fixtures with Python code (imports, functions, rule bodies): they run only trusted (issue 34).
CODE = {"continuous_growth", "fibonacci", "functions", "parametric", "stochastic"}


def same(a: ModuleString, b: ModuleString) -> bool:
    return (a.names == b.names and all(x.dtype == y.dtype and np.array_equal(x, y)
                                       for x, y in ((a.ids, b.ids), (a.arg_ptr, b.arg_ptr), (a.args, b.args))))


def stepwise(ls: LSystem, n: int, string: ModuleString | None = None) -> ModuleString:
    return list(ls.iterate(n, string=string))[-1]


@pytest.mark.parametrize("name", FIXTURES)
def test_fixture_all_at_once_equals_stepwise(name):
    ls = LSystem.from_file(HERE / f"{name}.lpy", seed=1, trusted=name in CODE)
    assert (ls._expand(ls.derivation_length, ls.axiom) is not None) == (name in CONSTANT)
    for n in range(ls.derivation_length + 2):
        assert same(ls.derive(n), stepwise(ls, n)), n
    assert ls.derive(0) is ls.axiom


def random_table(rng, S: int, params: bool):
    arity = rng.integers(-1, 2 if params else 1, S).astype(np.int64)
    lens = rng.integers(0, 5, S) * (arity >= 0)
    sptr = np.zeros(S + 1, np.int64)
    np.cumsum(lens, out=sptr[1:])
    sids = rng.integers(0, S, int(sptr[-1])).astype(np.int32)
    sc = rng.integers(0, 2, len(sids)) if params else np.zeros(len(sids), np.int64)
    saptr = np.zeros(len(sids) + 1, np.int64)
    np.cumsum(sc, out=saptr[1:])
    return arity, sptr, sids, saptr, rng.normal(size=int(saptr[-1]))


def random_string(rng, S: int, n: int, params: bool):
    ids = rng.integers(0, S, n).astype(np.int32)
    ptr = np.zeros(n + 1, np.int64)
    np.cumsum(rng.integers(0, 2, n) if params else np.zeros(n, np.int64), out=ptr[1:])
    return ids, ptr, rng.normal(size=int(ptr[-1]))


@pytest.mark.parametrize("params", [False, True])
def test_expand_kernels_equal_twins_and_steps(params):
    rng = np.random.default_rng(7 + params)
    for _ in range(40):
        S = int(rng.integers(1, 6))
        arity, sptr, sids, saptr, sargs = random_table(rng, S, params)
        ids, ptr, args = random_string(rng, S, int(rng.integers(0, 6)), params)
        n = int(rng.integers(1, 6))
        lm, la = K.expand_lengths(n, arity, sptr, sids, saptr, 2 ** 52)
        tm, ta = K.expand_lengths_py(n, arity, sptr, sids, saptr, 2 ** 52)
        assert np.array_equal(lm, tm) and np.array_equal(la, ta)
        want = (ids, ptr, args)                               # n steps of the one-step twin
        for _ in range(n):
            want = K.fill_constant_py(*want, arity, sptr, sids, saptr, sargs)
        twin = K.expand_constant_py(ids, ptr, args, n, arity, sptr, sids, saptr, sargs)
        rw = arity[ids] == np.diff(ptr)
        n_out = int((~rw).sum() + lm[n, ids[rw]].sum())
        m_out = int(np.diff(ptr)[~rw].sum() + la[n, ids[rw]].sum())
        with_ptr = m_out > 0
        oi = np.empty(n_out, np.int32)
        op = np.empty(n_out + 1, np.int64) if with_ptr else np.zeros(n_out + 1, np.int64)
        oa = np.empty(m_out)
        K.expand_constant(ids, ptr, args, n, arity, sptr, sids, saptr, sargs, lm, la, oi, op, oa, with_ptr)
        for got, t, w in zip((oi, op, oa), twin, want):
            assert np.array_equal(got, t) and np.array_equal(got, w)


def test_lengths_saturate():
    arity = np.array([0], np.int64)
    sptr = np.array([0, 3], np.int64)
    lm, _ = K.expand_lengths(60, arity, sptr, np.zeros(3, np.int32), np.zeros(4, np.int64), 10 ** 6)
    tm, _ = K.expand_lengths_py(60, arity, sptr, np.zeros(3, np.int32), np.zeros(4, np.int64), 10 ** 6)
    assert lm[12, 0] == 3 ** 12 and lm[13, 0] == lm[60, 0] == 10 ** 6 and np.array_equal(lm, tm)


def random_grammar(rng) -> tuple[str, bool]:
    """A constant grammar text; with parameters in the axiom and successors half of the time."""
    names = ["A", "B", "C", "F", "+", "-", "X"][: int(rng.integers(2, 8))]
    params = bool(rng.random() < 0.5)

    def module(k):
        name = names[k]
        if params and rng.random() < 0.3:
            return f"{name}({float(rng.integers(0, 90))})"
        return name

    def word(lo, hi):
        return "".join(module(int(rng.integers(len(names)))) if rng.random() > 0.15 else
                       "[" + module(int(rng.integers(len(names)))) + "]" for _ in range(int(rng.integers(lo, hi))))

    rules = [f"{nm} --> {word(0, 5)}" for nm in names if rng.random() < 0.6]
    return f"Axiom: {word(1, 4)}\nproduction:\n" + "\n".join(rules) + "\nendlsystem\n", params


def test_random_constant_grammars_all_at_once_equals_stepwise():
    rng = np.random.default_rng(11)
    used = 0
    for _ in range(60):
        text, _ = random_grammar(rng)
        ls = LSystem(text)
        for n in (1, 2, 3, 5, 7):
            fast = ls.derive(n)
            used += ls._expand(n, ls.axiom) is not None
            assert same(fast, stepwise(ls, n)), (text, n)
    assert used > 100
    ls = LSystem("Axiom: X\nproduction:\nX --> F[+X]F[-X]+X\nF --> FF\nendlsystem\n")
    start = ModuleString.from_modules(["F", ("X", (1.0,)), "X", ("+", (25.0,)), "[", "X", "]"])
    for n in range(6):                                        # from a given string: X(1) does not match X
        assert same(ls.derive(n, string=start), stepwise(ls, n, start))


def test_stepwise_paths_used_where_needed():
    hooks = "def StartEach():\n    pass\nAxiom: F\nproduction:\nF --> FF\nendlsystem\n"
    decomp = "Axiom: A\nproduction:\nA --> AB\ndecomposition:\nB --> C\nendlsystem\n"
    cond = "Axiom: A(1)\nproduction:\nA(x) : x > 0 --> A(x-1)B\nendlsystem\n"
    for text in (hooks, decomp, cond):
        ls = LSystem(text, trusted=text is hooks)
        assert ls._expand(3, ls.axiom) is None
    ls = LSystem("Axiom: F\nproduction:\nF --> FF\nendlsystem\n")
    assert ls._expand(3, ls.axiom) is not None and str(ls.derive(3)) == "F" * 8
    assert ls._ns["getIterationNb"]() == 2                    # the state the step-wise derivation leaves


def test_module_cap_same_error_as_stepwise(monkeypatch):
    monkeypatch.setattr(E, "MAX_MODULES", 100)
    grows = LSystem("Axiom: F\nproduction:\nF --> FFF\nendlsystem\n")
    assert len(grows.derive(4)) == 81
    # the string shrinks after step 1: the step-wise derivation stops at step 1, so must the all-at-once one
    shrinks = LSystem("Axiom: AA\nproduction:\nA --> " + "B" * 60 + "\nB -->\nendlsystem\n")
    for ls, n in ((grows, 5), (shrinks, 2)):
        with pytest.raises(LSystemError, match="MAX_MODULES") as fast:
            ls.derive(n)
        with pytest.raises(LSystemError, match="MAX_MODULES") as slow:
            stepwise(ls, n)
        assert str(fast.value) == str(slow.value)


def test_trusted_string_equals_checked():
    ls = LSystem.from_file(HERE / "abop_1_24a.lpy")
    s = ls.derive()
    checked = ModuleString(s.names, s.ids, s.arg_ptr, s.args)
    assert same(s, checked) and not s.ids.flags.writeable and not s.arg_ptr.flags.writeable
    with pytest.raises(ValueError, match="ids must lie in"):
        ModuleString(("F",), np.array([1], np.int32), np.zeros(2, np.int64), np.zeros(0))

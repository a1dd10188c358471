"""Grammars are code (issue 34): the restricted evaluator of untrusted grammars, trust, the integer and
sequence guards, and the time and module budgets of every derivation."""
from __future__ import annotations

import time

import pytest

from plantvr.lsystem import sandbox as SB
from plantvr.lsystem.engine import MAX_DERIVATION, LSystem, LSystemError

TRUST = "pass trusted=True"


def refused(text: str, line: int, match: str = TRUST, **kw) -> LSystemError:
    with pytest.raises(LSystemError, match=match) as err:
        LSystem(text, **kw).derive()
    assert err.value.line == line and err.value.column >= 1, str(err.value)
    return err.value


def test_one_line_grammars_run_untrusted():
    text = ("extern(angle=20.0)\nn = 2 * 3\nexecContext().turtle.setAngleIncrement(angle)\nAxiom: A(1, n)\n"
            "derivation length: n - 3\nproduction:\nA(l, k) : k > 0 and l > 0.1 --> F(l)[+(angle)A(l*0.5, k-1)]"
            "A(max(l, 0.2) ** 2, k-1)\nA(l, k) --> F(sqrt(l) if k % 2 == 0 else round(l, 2))\nendlsystem\n")
    ls = LSystem(text)
    assert not ls.trusted and ls.derivation_length == 3 and ls.turtle_options == {"angle": 20.0}
    assert str(ls.derive()) == str(LSystem(text, trusted=True).derive())
    assert ls.derive().count("F") > 3


CODE = [
    ("import math\nAxiom: F\n", 1, "import runs Python code"),
    ("Axiom: F\nproduction:\nF :\n    produce FF\nendlsystem\n", 3, "has a Python body"),
    ("def f(x):\n    return x\nAxiom: F(f(1))\n", 1, "a function definition"),
    ("for i in range(3):\n    pass\nAxiom: F\n", 1, "a 'for' loop"),
    ("Axiom: F\nproduction:\nF : produce F\n    x = 1\nendlsystem\n", 3, "has a Python body"),
    ("x = [i for i in range(9)]\nAxiom: F\n", 1, "a comprehension"),
    ("f = lambda: 1\nAxiom: F\n", 1, "a lambda"),
    ("x = f'{1}'\nAxiom: F\n", 1, "an f-string"),
]


@pytest.mark.parametrize("text, line, match", CODE)
def test_untrusted_code_is_refused_with_its_line(text, line, match):
    err = refused(text, line, match)
    assert TRUST in str(err)


HOSTILE = [
    ("x = open('{path}').read()\nAxiom: F\n", 1, 5, "'open' is not available"),
    ("import os\nAxiom: F\n", 1, 1, "import runs Python code"),
    ("x = __import__('os')\nAxiom: F\n", 1, 5, "names starting with '_'"),
    ("x = ().__class__.__bases__[0].__subclasses__()\nAxiom: F\n", 1, 5, "'__subclasses__'"),
    ("Axiom: F\nproduction:\nF --> F(len(().__class__.__subclasses__()))\nendlsystem\n", 3, 0, "'__subclasses__'"),
    ("Axiom: F(getattr(1, 'real'))\n", 1, 10, "'getattr' is not available"),
    ("Axiom: F\nproduction:\nF : eval('1') > 0 --> FF\nendlsystem\n", 3, 5, "'eval' is not available"),
    ("x = globals()\nAxiom: F\n", 1, 5, "'globals' is not available"),
    ("x = type(1)\nAxiom: F\n", 1, 5, "'type' is not available"),
]


@pytest.mark.parametrize("template, line, col, match", HOSTILE)
def test_hostile_grammar_refused_untrusted_runs_trusted(template, line, col, match, tmp_path):
    secret = tmp_path / "harmless.txt"
    secret.write_text("hello")
    text = template.format(path=secret)
    err = refused(text, line, match)
    if col:
        assert err.column == col
    LSystem(text, trusted=True).derive()                     # the same grammar runs when trusted


def test_attribute_reads_only_on_the_context_stubs():
    refused("x = (1).real\nAxiom: F\n", 1, "attribute .real of a int")
    refused("x = 'a'.upper\nAxiom: F\n", 1, "attribute .upper of a str")
    refused("x = sqrt.__doc__\nAxiom: F\n", 1, "'__doc__'")
    refused("x = 'a%s' % 3\nAxiom: F\n", 1, "'%' string formatting")
    ls = LSystem("context().turtle.setWidth(0.2)\ncontext().options.setSelection('x')\nAxiom: F\n")
    assert ls.turtle_options == {"width": 0.2}


def test_huge_integers_refused_before_computing():
    t0 = time.perf_counter()
    refused("Axiom: F\nderivation length: 9**9**9\n", 2, "too large")
    refused("Axiom: F(10**10**10)\n", 1, "too large")
    refused("y = 10**10**10\nAxiom: F\n", 1, "too large")
    refused("y = 1 << 10**9\nAxiom: F\n", 1, "too large")
    refused("y = 'ab' * 10**9\nAxiom: F\n", 1, "longer than")
    refused("y = max(range(10**12))\nAxiom: F\n", 1, "range of more than")
    refused("y = sum([[1]] * 10**6, [])\nAxiom: F\n", 1, "adds numbers only")
    refused("a = 'x' * 10**6\nb = a + a\nAxiom: F\n", 2, "longer than")
    refused("a = (1,) * 10**6\na += a\nAxiom: F\n", 2, "longer than")
    refused("Axiom: F(1)\nproduction:\nF(x) --> F(x * 9**9**9)\nendlsystem\n", 3, "too large")
    refused("Axiom: F(1)\nproduction:\nF(x) : x ** 9**9**9 > 0 --> F\nendlsystem\n", 3, "too large")
    refused("Axiom: A\nproduction:\nA :\n    y = 10**10**10\n    produce A\nendlsystem\n", 4, "too large",
            trusted=True)
    refused(f"Axiom: F\nderivation length: {MAX_DERIVATION + 1}\n", 2, "derivation length must be")
    assert time.perf_counter() - t0 < 5
    assert SB.safe_pow(2, 10) == 1024 and SB.safe_pow(2.0, 0.5) == 2 ** 0.5 and SB.safe_mul("ab", 3) == "ababab"
    assert SB.safe_pow(1, 10 ** 30) == 1 and SB.safe_pow(-1, 10 ** 30 + 1) == -1


def test_while_true_in_trusted_code_stops_at_the_budget():
    for text, line in [("Axiom: A\nproduction:\nA :\n    while True: pass\n    produce A\nendlsystem\n", 4),
                       ("def f():\n    x = 0\n    while True:\n        x += 1\nAxiom: A\nproduction:\n"
                        "A :\n    f()\n    produce A\nendlsystem\n", 4),
                       ("Axiom: A\nproduction:\nA :\n    while True:\n        try:\n            pass\n"
                        "        except Exception:\n            pass\n    produce A\nendlsystem\n", 5)]:
        t0 = time.perf_counter()
        with pytest.raises(LSystemError, match="time budget of 1 s exceeded") as err:
            LSystem(text, trusted=True, time_budget=1.0).derive()
        assert time.perf_counter() - t0 < 1.0 + 2.5
        assert err.value.line in (line, line - 1), str(err.value)
    t0 = time.perf_counter()
    with pytest.raises(LSystemError, match="time budget") as err:
        LSystem("while True:\n    pass\nAxiom: F\n", trusted=True, time_budget=1.0)
    assert err.value.line in (1, 2) and time.perf_counter() - t0 < 3.5


def test_budgets_checked_while_a_step_is_built():
    # a Python rule multiplying the string by ten: stopped inside a step, at the rule's line
    text = "Axiom: A\nderivation length: 100\nproduction:\nA :\n    produce AAAAAAAAAA\nendlsystem\n"
    t0 = time.perf_counter()
    with pytest.raises(LSystemError, match="time budget|max_modules") as err:
        LSystem(text, trusted=True, time_budget=1.0).derive()
    assert err.value.line == 4 and time.perf_counter() - t0 < 3.5
    with pytest.raises(LSystemError, match="more than max_modules = 5,000") as err:
        LSystem(text, trusted=True, max_modules=5000).derive()
    assert err.value.line == 4
    nprod = "def grow():\n    while True:\n        nproduce F\nAxiom: A\nproduction:\nA :\n    grow()\n" \
            "    produce A\nendlsystem\n"
    with pytest.raises(LSystemError, match="nproduce built|time budget") as err:
        LSystem(nprod, trusted=True, time_budget=1.0, max_modules=100_000).derive()
    assert err.value.line in (3, 7)
    # one-line rules: the cap (kernel and vectorised paths) names the growing rule's line
    for succ in ("AAAAAAAAAA", "A(x+1)A(x)A(x)A(x)A(x)"):
        arg = "(0)" if "x" in succ else ""
        pred = "A(x)" if "x" in succ else "A"
        with pytest.raises(LSystemError, match="max_modules") as err:
            LSystem(f"Axiom: A{arg}\nderivation length: 30\nproduction:\nB --> B\n{pred} --> {succ}\nendlsystem\n",
                    max_modules=10_000).derive()
        assert err.value.line == 5
    with pytest.raises(LSystemError, match="time budget") as err:
        LSystem("Axiom: A(0)\nderivation length: 100000\nproduction:\nA(x) : x >= 0 --> A(x + 1)\nendlsystem\n",
                time_budget=0.5).derive()
    assert err.value.line == 4


def test_iterate_has_a_budget_per_step_and_options_are_checked():
    ls = LSystem("Axiom: F\nderivation length: 3\nproduction:\nF --> FF\nendlsystem\n", time_budget=0.5)
    steps = ls.iterate()
    next(steps)
    time.sleep(0.6)                                           # time between steps is the caller's
    assert [len(s) for s in steps] == [2, 4, 8]
    with pytest.raises(ValueError, match="trusted must be True or False"):
        LSystem("Axiom: F\n", trusted="yes")
    with pytest.raises(ValueError, match="time_budget must be"):
        LSystem("Axiom: F\n", time_budget=0)
    with pytest.raises(ValueError, match="max_modules must be"):
        LSystem("Axiom: F\n", max_modules=0)


def test_from_file_trust_and_bad_bytes(tmp_path):
    p = tmp_path / "g.lpy"
    p.write_text("import math\nAxiom: F(math.pi)\n")
    with pytest.raises(LSystemError, match="import runs Python code"):
        LSystem.from_file(p)
    assert LSystem.from_file(p, trusted=True).axiom.args[0] == pytest.approx(3.14159265)
    bad = tmp_path / "bad.lpy"
    bad.write_bytes(b"Axiom: F\n# caf\xe9\n")
    with pytest.raises(LSystemError, match="bad.lpy' is not UTF-8") as err:
        LSystem.from_file(bad)
    assert (err.value.line, err.value.column) == (2, 6)

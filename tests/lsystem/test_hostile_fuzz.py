"""Hostile-grammar fuzz (issue 34): seeded hostile grammars (exponential growth, deep nesting, huge exponents,
long strings, bad bytes, forbidden code, runaway trusted code) run in a child process under a 2 GB address-space
limit through ``LSystem(...).derive()`` and ``LSystemDocument.set_grammar``: no crash (the child never dies), no
hang (each run within its time budget and a margin), every failure an LSystemError with a line, and a refused
grammar leaves the document unchanged."""
from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

CHILD = Path(__file__).with_name("_hostile_child.py")
ROOT = Path(__file__).resolve().parents[2]
BUDGET = 0.5            # seconds, each derivation's time budget in the child
MARGIN = 4.0            # seconds over the budget a run may take (a step's last chunk, drawing the tree)
MEMORY = 2 * 2 ** 30    # RLIMIT_AS of the child, after its imports

BASE = "Axiom: A(1)\nderivation length: 4\nproduction:\nA(x) : x > 0 --> F(x)[+(30)A(x*0.5)]A(x*0.7)\nendlsystem\n"


def _growth(rng: random.Random) -> tuple[str, bool]:
    k, n = rng.randint(2, 16), rng.randint(10, 200)
    kind = rng.randrange(4)
    if kind == 0:
        return f"Axiom: A\nderivation length: {n}\nproduction:\nA --> {'A' * k}\nendlsystem\n", False
    if kind == 1:
        succ = "".join(f"A(x+{j})" for j in range(k))
        return f"Axiom: A(0)\nderivation length: {n}\nproduction:\nA(x) : x >= 0 --> {succ}\nendlsystem\n", False
    if kind == 2:
        return (f"Axiom: A\nderivation length: {n}\nproduction:\nA :\n    produce {'A' * k}\nendlsystem\n", True)
    return (f"Axiom: A\nderivation length: {n}\nproduction:\nA < A --> {'[A]' * k}\nA --> AA\nendlsystem\n", False)


def _nesting(rng: random.Random) -> tuple[str, bool]:
    d = rng.choice([50, 300, 3000, 30000])
    kind = rng.randrange(5)
    if kind == 0:
        return f"Axiom: F({'(' * d}1{')' * d})\n", False
    if kind == 1:
        return f"Axiom: {'[' * d}F{']' * d}\nderivation length: 2\nproduction:\nF --> F[F]\nendlsystem\n", False
    if kind == 2:
        return f"Axiom: F({'-' * d}1)\n", False
    if kind == 3:
        return f"x = {'[' * d}{']' * d}\nAxiom: F\n", rng.random() < 0.5
    return f"Axiom: A(1)\nproduction:\nA(x) --> A({'+'.join(['x'] * d)})\nendlsystem\n", False


def _exponent(rng: random.Random) -> tuple[str, bool]:
    big = ["9**9**9", "10**10**10", "2**2**2**2**2**2", "1 << 10**10", "'a' * 10**10", "[0] * 10**10",
           "round(1, -10**9)", "pow(10, 10**10)", "10**400 * 10**400"]
    trusted = rng.random() < 0.3
    # one C call that never returns cannot be stopped in trusted code (sandbox docstring): untrusted only
    big = rng.choice(big if trusted else big + ["max(range(10**15))", "sum(range(10**15))",
                                                 "sum([[1]] * 10**6, [])"])
    where = rng.randrange(5)
    if where == 0:
        return f"Axiom: F\nderivation length: {big}\n", trusted
    if where == 1:
        return f"Axiom: F({big})\n", trusted
    if where == 2:
        return f"y = {big}\nAxiom: F\n", trusted
    if where == 3:
        return f"Axiom: F(1)\nproduction:\nF(x) : x < {big} --> F(x)\nendlsystem\n", trusted
    return f"Axiom: A\nproduction:\nA :\n    y = {big}\n    produce A\nendlsystem\n", "range" not in big


def _long(rng: random.Random) -> tuple[str, bool]:
    n = rng.choice([10 ** 4, 10 ** 5, 10 ** 6])
    kind = rng.randrange(4)
    if kind == 0:
        return f"Axiom: {'F' * n}\nderivation length: 3\nproduction:\nF --> FF\nendlsystem\n", False
    if kind == 1:
        return f"module {'A' * n}\nAxiom: {'A' * n}\n", False
    if kind == 2:
        return f"s = '{'x' * n}'\nAxiom: F(len(s))\n", False
    return "Axiom: F\nproduction:\n" + "F --> F\n" * (n // 100) + "endlsystem\n", False


def _bytes(rng: random.Random) -> tuple[str, bool]:
    text = list(BASE)
    for _ in range(rng.randint(1, 12)):
        k = rng.randrange(len(text) + 1)
        c = rng.choice(["\x00", "\ud800", "\udfff", "\x1b", "\ufeff", "\u202e", "\x7f", "\t", "\r", "\x0c", "(",
                        ")", "[", "]", ":", "-->", "'", '"', "\\", "#", "\n    ", chr(rng.randrange(0x20, 0x3000))])
        text.insert(k, c)
    return "".join(text), rng.random() < 0.3


def _code(rng: random.Random) -> tuple[str, bool]:
    return rng.choice([
        ("x = open('/etc/hostname').read()\nAxiom: F\n", False),
        ("import os\nos.getcwd()\nAxiom: F\n", False),
        ("x = __import__('os')\nAxiom: F\n", False),
        ("x = ().__class__.__bases__[0].__subclasses__()\nAxiom: F\n", False),
        ("Axiom: F\nproduction:\nF : ().__class__ --> F\nendlsystem\n", False),
        ("x = (lambda: 1)()\nAxiom: F\n", False),
        ("Axiom: A\nproduction:\nA :\n    while True: pass\n    produce A\nendlsystem\n", True),
        ("def grow():\n    while True:\n        nproduce F\nAxiom: A\nproduction:\nA :\n    grow()\n    produce A\n"
         "endlsystem\n", True),
        ("def f(n):\n    return f(n + 1)\nAxiom: F(f(0))\n", True),
        ("x = [0]\nwhile True:\n    x = x + x\nAxiom: F\n", True),
        ("def StartEach():\n    while True:\n        pass\nAxiom: F\nderivation length: 2\nproduction:\nF --> FF\n"
         "endlsystem\n", True),
    ])


FAMILIES = {"growth": _growth, "nesting": _nesting, "exponent": _exponent, "long": _long, "bytes": _bytes,
            "code": _code}


def hostile_grammars(seed: int, per_family: int) -> list[dict]:
    rng = random.Random(seed)
    cases = []
    for family, make in FAMILIES.items():
        for _ in range(per_family):
            text, trusted = make(rng)
            cases.append({"i": len(cases), "family": family, "text": text, "trusted": trusted})
    return cases


def test_hostile_grammars_never_crash_or_hang_and_fail_with_a_line():
    cases = hostile_grammars(seed=34, per_family=12)
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    stdin = "".join(json.dumps(c) + "\n" for c in cases)
    proc = subprocess.run([sys.executable, str(CHILD), str(MEMORY), str(BUDGET)], input=stdin, text=True,
                          capture_output=True, env=env, timeout=170)
    records = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    started = [r for r in records if "start" in r]
    done = [r for r in records if "outcome" in r]
    last = started[-1] if started else None
    assert proc.returncode == 0, (f"child died (rc {proc.returncode}) on case {last}: "
                                  f"{cases[last['start']] if last else ''!r:.300}\n{proc.stderr[-2000:]}")
    assert len(done) == 2 * len(cases)
    counts = Counter((r["outcome"]) for r in done)
    by_family = Counter((cases[r["i"]]["family"], r["outcome"]) for r in done)
    slowest = max(done, key=lambda r: r["t"])
    print(f"\nhostile fuzz: {len(cases)} grammars x 2 paths = {len(done)} runs: {dict(counts)}; 0 crashes; slowest "
          f"{slowest['t']:.2f} s (budget {BUDGET} s); by family {dict(sorted(by_family.items()))}")
    bad = [r for r in done if r["outcome"] not in ("ok", "LSystemError") or (r["outcome"] == "LSystemError"
                                                                             and not r["line"])]
    assert not bad, [(r, cases[r["i"]]["text"][:120]) for r in bad[:5]]
    hangs = [r for r in done if r["t"] > BUDGET + MARGIN]
    assert not hangs, [(r, cases[r["i"]]["text"][:120]) for r in hangs[:5]]
    changed = [r for r in done if r.get("unchanged") is False]
    assert not changed, changed[:5]
    assert counts["LSystemError"] > len(done) // 2


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_the_generator_is_seeded(family):
    a = [c for c in hostile_grammars(1, 3) if c["family"] == family]
    assert a == [c for c in hostile_grammars(1, 3) if c["family"] == family] and len(a) == 3

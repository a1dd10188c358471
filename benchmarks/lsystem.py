"""L-system derivation and interpretation speed (issue 23), in modules per second, beside straightforward Python
baselines measured in the same run.

(a) a non-parametric bush (ABOP 1.24d, ``X -> F[+X]F[-X]+X``, ``F -> FF``) grown to about 10^6 modules, against
    ``"".join(rules.get(c, c) for c in s)`` string rewriting (goal >= 20x);
(b) a parametric grammar with conditions (``tests/lsystem/grammars/parametric.lpy``) grown to about 10^5 modules,
    against a Python loop over ``(name, params)`` tuples calling one function per rule (goal >= 5x);
(c) the turtle interpretation of 10^6 modules into tree arrays (goal <= 1 s);
(d) rules that call grammar functions (``tests/lsystem/grammars/functions.lpy``: numpy cannot evaluate them) grown
    to about 10^4 modules (10^6 rewritten in all), against a plain Python loop over ``(name, params)`` tuples with
    the same rules and functions (goal >= 1x).

Throughput = modules produced over all steps / best wall time of the whole derivation (the same numerator for ours
and the baseline, so the speedup is the ratio of wall times for the same work: same grammar, same steps, from the
axiom, same final string). For (a) ``LSystem.derive`` does the steps at once (each module of the result written
once, repeated blocks copied); the step-wise path (``LSystem.iterate``, which keeps every step) is timed beside it.
The benchmark checks that the derived string, as text, equals the baseline's (small n and the benchmark size) and
that both paths give the same arrays. CPU time (``time.process_time``) is printed beside the wall time.
``--quick`` uses smaller strings (< 30 s).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from plantvr.lsystem.engine import LSystem

BUSH = "Axiom: X\nproduction:\nX --> F[+X]F[-X]+X\nF --> FF\nendlsystem\n"
#: Branching depth of the parametric benchmark: deep enough that the string keeps growing.
DEPTH = 40
PARAM = Path(__file__).resolve().parent.parent / "tests" / "lsystem" / "grammars" / "parametric.lpy"
FUNCS = PARAM.with_name("functions.lpy")


def _timed(fn, repeat: int):
    best_wall, best_cpu, out = float("inf"), float("inf"), None
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        out = fn()
        best_wall = min(best_wall, time.perf_counter() - w)
        best_cpu = min(best_cpu, time.process_time() - c)
    return best_wall, best_cpu, out


def _steps_for(ls: LSystem, target: int) -> int:
    s, n = ls.axiom, 0
    while len(s) < target:
        if n > 60:
            raise RuntimeError("the benchmark grammar stopped growing")
        s = ls.derive(1, string=s)
        n += 1
    return n


def bush_baseline(n: int) -> tuple[int, str]:
    rules = {"X": "F[+X]F[-X]+X", "F": "FF"}
    s, total = "X", 0
    for _ in range(n):
        s = "".join(rules.get(c, c) for c in s)
        total += len(s)
    return total, s


def _text(s) -> str:
    """A parameter-free module string as text (one character per module name here)."""
    assert s.args.shape[0] == 0
    return "".join(np.array(s.names, dtype=object)[s.ids].tolist())


def _same(a, b) -> bool:
    return (a.names == b.names and np.array_equal(a.ids, b.ids) and np.array_equal(a.arg_ptr, b.arg_ptr)
            and np.array_equal(a.args, b.args))


def param_baseline(n: int, ratio: float = 0.8, depth: int = 6) -> int:
    def rule_a(l, k):
        if k > 0:
            return [("I", (l,)), ("[", ()), ("+", (30,)), ("A", (l * ratio, k - 1)), ("]", ()), ("[", ()),
                    ("-", (30,)), ("A", (l * ratio, k - 1)), ("]", ()), ("I", (l * 0.5,)), ("A", (l * 0.9, k - 1))]
        return [("L", (l,))]

    def rule_i(l):
        return [("I", (l * 1.02,))]

    def rule_l(l):
        return [("L", (l * ratio,))] if l > 0.1 else None

    rules = {("A", 2): rule_a, ("I", 1): rule_i, ("L", 1): rule_l}
    s, total = [("A", (1.0, depth))], 0
    for _ in range(n):
        out = []
        for name, params in s:
            f = rules.get((name, len(params)))
            res = f(*params) if f is not None else None
            if res is None:
                out.append((name, params))
            else:
                out.extend(res)
        s = out
        total += len(s)
    return total


def functions_baseline(n: int) -> tuple[int, list]:
    """The rules of ``functions.lpy`` as a plain Python loop (the grammar's two functions, one branch per rule)."""
    def grow(l):
        return l * 1.01

    def branch_angle(k):
        return 30 + 5 * k

    s, total = [("A", (1, 0))], 0
    for _ in range(n):
        out = []
        for name, p in s:
            if name == "A":
                l, k = p
                out += [("I", (grow(l),)), ("[", ()), ("+", (branch_angle(k),)), ("B", (l, k + 1)), ("]", ()),
                        ("A", (grow(l), k + 1))]
            elif name == "B" and p[1] < 1000:
                l, k = p
                out += [("I", (grow(l),)), ("B", (grow(l), k))]
            elif name == "I":
                out.append(("I", (grow(p[0]),)))
            else:
                out.append((name, p))
        s = out
        total += len(s)
    return total, s


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller strings (< 30 s)")
    a = ap.parse_args(argv)
    bush_n, param_n, turtle_n, rep = (10 ** 5, 10 ** 4, 10 ** 5, 2) if a.quick else (10 ** 6, 10 ** 5, 10 ** 6, 3)
    func_steps = 100 if a.quick else 250
    res: dict = {}

    bush = LSystem(BUSH)
    steps = _steps_for(bush, bush_n)
    for k in range(7):                                        # also compiles the kernels
        assert str(bush.derive(k)) == bush_baseline(k)[1], k
    brep = 5 * rep                                            # both sides: best of the same number of runs
    w, c, s = _timed(lambda: bush.derive(steps), brep)
    sw, sc, stepwise = _timed(lambda: list(bush.iterate(steps)), brep)
    total = sum(len(x) for x in stepwise[1:])
    assert _same(s, stepwise[-1])
    bw, bc, (btotal, bstring) = _timed(lambda: bush_baseline(steps), brep)
    assert btotal == total and _text(s) == bstring
    res["bush"] = dict(modules=len(s), steps=steps, wall_s=w, cpu_s=c, rate=total / w, baseline_rate=btotal / bw,
                       baseline_wall_s=bw, baseline_cpu_s=bc, speedup=bw / w, stepwise_wall_s=sw,
                       stepwise_cpu_s=sc, stepwise_speedup=bw / sw)
    print(f"(a) bush to {len(s):,} modules in {steps} steps: {total / w:,.0f} modules/s (wall {w * 1e3:.2f} ms, "
          f"cpu {c * 1e3:.2f} ms; final string {len(s) / w:,.0f} modules/s) vs Python string rewriting "
          f"{btotal / bw:,.0f} modules/s (wall {bw * 1e3:.2f} ms, cpu {bc * 1e3:.2f} ms): {bw / w:.1f}x (goal >= 20x);"
          f" step-wise iterate {sw * 1e3:.2f} ms wall, {sc * 1e3:.2f} ms cpu: {bw / sw:.1f}x")

    par = LSystem.from_file(PARAM, depth=DEPTH, trusted=True)           # our own fixture: its Python runs
    steps = _steps_for(par, param_n)
    w, c, s = _timed(lambda: par.derive(steps), rep)
    total = sum(len(x) for x in list(par.iterate(steps))[1:])
    bw, bc, btotal = _timed(lambda: param_baseline(steps, depth=DEPTH), rep)
    assert btotal == total
    res["parametric"] = dict(modules=len(s), steps=steps, wall_s=w, cpu_s=c, rate=total / w,
                             baseline_rate=btotal / bw, baseline_wall_s=bw, baseline_cpu_s=bc, speedup=bw / w)
    print(f"(b) parametric to {len(s):,} modules in {steps} steps: {total / w:,.0f} modules/s (wall {w:.3f} s, "
          f"cpu {c:.3f} s) vs Python rule functions {btotal / bw:,.0f} modules/s (wall {bw:.3f} s, "
          f"cpu {bc:.3f} s): {bw / w:.1f}x (goal >= 5x)")

    fun = LSystem.from_file(FUNCS, trusted=True)                       # our own fixture: its Python runs
    fun.derive(3)                                                       # the rule plans, made once
    w, c, s = _timed(lambda: fun.derive(func_steps), rep)
    bw, bc, (btotal, bs) = _timed(lambda: functions_baseline(func_steps), rep)
    assert len(s) == len(bs) and s.ids.tolist() == [fun._index[nm] for nm, _ in bs]
    assert np.allclose(s.args, [v for _, p in bs for v in p])
    total = btotal                                                      # the same modules on both sides
    res["functions"] = dict(modules=len(s), steps=func_steps, wall_s=w, cpu_s=c, rate=total / w,
                            baseline_rate=btotal / bw, baseline_wall_s=bw, baseline_cpu_s=bc, speedup=bw / w)
    print(f"(d) grammar functions to {len(s):,} modules in {func_steps} steps: {total / w:,.0f} modules/s (wall "
          f"{w:.3f} s, cpu {c:.3f} s) vs a plain Python loop of the same rules {btotal / bw:,.0f} modules/s "
          f"(wall {bw:.3f} s, cpu {bc:.3f} s): {bw / w:.2f}x (goal >= 1x)")

    try:
        from plantvr.lsystem.turtle import bush_string, turtle
    except ImportError:                                       # pragma: no cover - turtle built in parallel
        print("(c) turtle not available")
        return res
    string = bush_string(turtle_n)
    turtle(bush_string(1000))
    w, c, t = _timed(lambda: turtle(string), rep)
    res["turtle"] = dict(modules=len(string), nodes=len(t.parent), wall_s=w, cpu_s=c, rate=len(string) / w)
    print(f"(c) turtle: {len(string):,} modules -> {len(t.parent):,} nodes in {w:.3f} s wall, {c:.3f} s cpu "
          f"({len(string) / w:,.0f} modules/s; goal <= 1 s at 10^6)")
    return res


if __name__ == "__main__":
    main()

"""Cold start benchmark (issue 24): first-call seconds of each numba-backed feature with an empty numba cache
(cold: every kernel compiles) and with the cache filled (warm: kernels load from the cache).

Each measure runs in a fresh ``python`` subprocess with ``NUMBA_CACHE_DIR`` set to a temporary folder (so the
``cache=True`` kernels neither read nor write the ``__pycache__`` next to the sources): the first run of a feature
in an empty folder is cold, the second in the same folder is warm. The child times its imports and the first call
of the feature and reports its own CPU time (``resource.getrusage``) beside the wall time, since compiling is
CPU-bound and the wall time on a shared machine depends on the neighbours. It also counts the compiled signatures
of every numba dispatcher in ``plantvr`` (``dispatcher.signatures``): a kernel compiled for several dtypes or
layouts costs one compile per signature.

Features: Loop subdivision, tree meshing (``build_branch_mesh``), colonization (a ``GrowthEngine`` step),
isosurface (``plantvr.vine``), painting (the ViNE brush), the demo's first growth step (a ``Model``, the demo's
strokes, one step), and the whole demo (``plantvr demo --no-install``: grow, mesh, export, render).

Targets: warm <= 1 s per feature; cold <= 10 s for the whole demo.

Baseline: the cold figures are the cost of today's fresh environment; ``plantvr warmup`` (issue 24) moves it to
install time, and the last line of the whole-demo block is the demo after it. First run (2 cores, load ~6, so
wall ~3x CPU; first call of the feature after its imports and inputs, wall s (CPU s)):

    feature                      cold first call   warm first call
    Loop subdivision             12.7 (4.6)        0.76 (0.26)
    tree meshing                 34.4 (12.1)       1.09 (0.42)
    colonization                 21.3 (9.1)        0.26 (0.08)   (+ GrowthEngine() 10.1 (~4.8) cold: shadow kernels)
    isosurface                   12.6 (3.9)        1.53 (0.70)
    painting                     11.7 (3.9)        0.04 (0.02)
    demo's first growth step     24.1 (9.7)        1.23 (0.79)   (+ Model() 20.7 cold)
    whole demo, process          38.0 (35.1) cold on a quieter machine (32 s of it compiling); 5.3 (6.6) warm

Every kernel has one signature per feature (the doors normalise dtypes), except ``grid.axis_range`` (3), an
inline-sized helper typed once per calling kernel. Warm, ~1 s of the demo is numba compiling the
``numba.typed.Dict`` methods that ``growth/shadow.py`` calls from Python (never cached).

Run: ``python benchmarks/cold_start.py [--quick] [--features NAME ...] [--demo-steps N]``. ``--quick`` (CI,
< 30 s) measures every feature warm and one small feature (Loop subdivision) cold.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from plantvr._warmup import WORKLOADS

ROOT = Path(__file__).resolve().parent.parent

#: The issue-24 targets (s).
WARM_TARGET_S = 1.0
DEMO_COLD_TARGET_S = 10.0


FEATURES = {k: v for k, v in WORKLOADS.items() if k != "demo"}   # the whole demo runs as `plantvr demo`


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _signatures() -> dict[str, int]:
    """Compiled signatures of every numba dispatcher in the loaded ``plantvr`` modules (those with any)."""
    from numba.core.registry import CPUDispatcher
    out = {}
    for name, mod in list(sys.modules.items()):
        if not name.startswith("plantvr") or mod is None:
            continue
        for attr, obj in list(vars(mod).items()):
            if isinstance(obj, CPUDispatcher) and obj.__module__ == name and obj.signatures:
                out[f"{name}.{attr}"] = len(obj.signatures)
    return out


def _compile_listener():
    """A numba ``numba:compile`` event listener: wall seconds spent compiling, per dispatcher (outermost only)."""
    from numba.core import event

    class CompileTimes(event.Listener):
        def __init__(self):
            self.seconds: dict[str, float] = {}
            self._stack: list[tuple[str, float]] = []

        def on_start(self, ev) -> None:
            d = ev.data["dispatcher"]
            self._stack.append((f"{d.py_func.__module__}.{d.py_func.__name__}", time.perf_counter()))

        def on_end(self, ev) -> None:
            key, t = self._stack.pop()
            if not self._stack:                   # nested compiles (callees) count in their caller
                self.seconds[key] = self.seconds.get(key, 0.0) + time.perf_counter() - t

    times = CompileTimes()
    event.register("numba:compile", times)
    return times


def _child(name: str) -> None:
    """Run one feature in this (fresh) process and print one JSON line of timings."""
    times = _compile_listener()
    w0, c0 = time.perf_counter(), _cpu()
    fn = FEATURES[name][1]()
    w1, c1 = time.perf_counter(), _cpu()
    setup_compile = dict(times.seconds)
    fn()
    w2, c2 = time.perf_counter(), _cpu()
    fn()
    w3 = time.perf_counter()
    print(json.dumps({"setup_wall": w1 - w0, "setup_cpu": c1 - c0, "first_wall": w2 - w1, "first_cpu": c2 - c1,
                      "second_wall": w3 - w2, "signatures": _signatures(),
                      "compile_s": dict(sorted(times.seconds.items(), key=lambda kv: -kv[1])),
                      "setup_compile_s": setup_compile}))


# -- the parent ---------------------------------------------------------------------------------------------------
def _env(cache: str | None) -> dict:
    """The child's environment: numba's cache in ``cache`` (None: numba's default, ``__pycache__``)."""
    env = dict(os.environ)
    env.pop("NUMBA_DISABLE_JIT", None)
    env.pop("NUMBA_CACHE_DIR", None)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    return env


def measure(name: str, cache: str | None) -> dict:
    """One fresh child running feature ``name`` with the numba cache in ``cache``: its timings (s)."""
    t = time.perf_counter()
    res = subprocess.run([sys.executable, __file__, "--child", name], env=_env(cache), cwd=ROOT,
                         check=False, capture_output=True, text=True, timeout=900)
    wall = time.perf_counter() - t
    if res.returncode != 0:
        raise RuntimeError(f"{name}: child failed\n{res.stderr[-3000:]}")
    out = json.loads(res.stdout.strip().splitlines()[-1])
    out["process_wall"] = wall
    return out


def _timed_child(args: list[str], cache: str) -> dict:
    """Wall and CPU time (s, ``getrusage`` of the children: includes the child's own subprocesses) of a command."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    res = subprocess.run(args, env=_env(cache), cwd=ROOT, check=False, capture_output=True, text=True, timeout=1800)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed\n{res.stderr[-3000:]}")
    return {"wall": wall, "cpu": (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)}


def measure_demo(cache: str, steps: int) -> dict:
    """``plantvr demo --no-install --steps N`` in a fresh child: wall and CPU time of the whole process (s)."""
    with tempfile.TemporaryDirectory() as out:
        return _timed_child([sys.executable, "-m", "plantvr.cli", "demo", "--no-install", "--out", out,
                             "--steps", str(steps)], cache)


def measure_warmup(cache: str, jobs: int) -> dict:
    """``python -m plantvr._warmup --jobs N`` (what ``plantvr warmup`` runs) into an empty cache."""
    return _timed_child([sys.executable, "-m", "plantvr._warmup", "--jobs", str(jobs)], cache)


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="warm for every feature, cold for Loop subdivision only")
    ap.add_argument("--features", nargs="*", choices=sorted(FEATURES), default=None)
    ap.add_argument("--demo-steps", type=int, default=80, help="steps of the whole-demo run (plantvr demo default)")
    ap.add_argument("--no-demo", action="store_true", help="skip the whole-demo run")
    ap.add_argument("--jobs", type=int, default=2, help="plantvr warmup --jobs (subprocesses at once)")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        _child(a.child)
        return {}
    names = a.features or list(FEATURES)
    out: dict = {}
    if a.quick:
        # CI: one small feature cold; every feature warm from the user's own cache (``__pycache__`` next to the
        # sources, filled by earlier runs and tests; a run that still compiled something is repeated once)
        with tempfile.TemporaryDirectory(prefix="plantvr-numba-") as cache:
            out["loop"] = {"cold": measure("loop", cache)}
    print(f"{'feature':36s} {'cold first call':>22s} {'warm first call':>22s}  import+setup (cold/warm)  "
          "signatures")
    for n in names:
        row = out.setdefault(n, {})
        if a.quick:
            w = measure(n, None)
            compiled = [k for k in w["compile_s"] if k.startswith("plantvr")]
            row["warm"] = w if not compiled else measure(n, None)
        else:
            with tempfile.TemporaryDirectory(prefix="plantvr-numba-") as cache:
                row["cold"] = measure(n, cache)
                row["warm"] = measure(n, cache)
        c, w = row.get("cold"), row["warm"]
        sigs = (c or w)["signatures"]
        multi = {k.rsplit(".", 1)[-1]: v for k, v in sigs.items() if v > 1}
        cold_s = f"{c['first_wall']:6.2f} s ({c['first_cpu']:5.2f} CPU)" if c else f"{'-':>22s}"
        setup_s = f"{c['setup_wall']:5.2f}/{w['setup_wall']:5.2f} s" if c else f"  -  /{w['setup_wall']:5.2f} s"
        print(f"{WORKLOADS[n][0]:36s} {cold_s} {w['first_wall']:6.2f} s ({w['first_cpu']:5.2f} CPU)  "
              f"{setup_s:>22s}  {sum(sigs.values())} in {len(sigs)} kernels" + (f"; >1: {multi}" if multi else ""))
        if c and c["compile_s"]:
            top = list(c["compile_s"].items())[:3]
            print(f"{'':36s}   compiling {sum(c['compile_s'].values()):.1f} s, most: "
                  + ", ".join(f"{k.rsplit('.', 1)[-1]} {v:.1f} s" for k, v in top))
        row["warm_ok"] = w["first_wall"] <= WARM_TARGET_S
    if not a.quick and not a.no_demo:
        with tempfile.TemporaryDirectory(prefix="plantvr-numba-") as cache:
            cold, warm = measure_demo(cache, a.demo_steps), measure_demo(cache, a.demo_steps)
        with tempfile.TemporaryDirectory(prefix="plantvr-numba-") as cache:
            wu = measure_warmup(cache, a.jobs)
            after = measure_demo(cache, a.demo_steps)
        out["demo"] = {"cold": cold, "warm": warm, "warmup": wu, "after_warmup": after,
                       "compile_wall": cold["wall"] - warm["wall"], "compile_cpu": cold["cpu"] - warm["cpu"]}
        print(f"whole demo (plantvr demo --no-install --steps {a.demo_steps}, whole process incl. render):")
        print(f"  empty cache {cold['wall']:6.1f} s ({cold['cpu']:5.1f} CPU)   <- baseline: cold start today")
        print(f"  filled cache {warm['wall']:5.1f} s ({warm['cpu']:5.1f} CPU)   (compiling = {out['demo']['compile_wall']:.1f} s,"
              f" {out['demo']['compile_cpu']:.1f} CPU)")
        print(f"  after `plantvr warmup --jobs {a.jobs}` ({wu['wall']:.1f} s, {wu['cpu']:.1f} CPU, at install): "
              f"{after['wall']:.1f} s ({after['cpu']:.1f} CPU)  [target <= {DEMO_COLD_TARGET_S:g} s: "
              f"{'met' if after['wall'] <= DEMO_COLD_TARGET_S else 'NOT met'}]")
    print(f"targets: warm first call <= {WARM_TARGET_S:g} s per feature; baseline: see the module docstring")
    return out


if __name__ == "__main__":
    main()

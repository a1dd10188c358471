"""``plantvr warmup``: compile every numba kernel the features use into numba's on-disk cache, once, at install time
(issue 24, cold start).

Every kernel is ``@numba.njit(cache=True)``: the first process that calls it compiles it (0.2–7 s each, about 30 s
of CPU for the whole demo on the 2-core machine) and writes the machine code next to the source in
``__pycache__`` (or under ``NUMBA_CACHE_DIR``); every later process loads it in milliseconds. The door of each
public function already normalises dtypes and layouts, so each kernel has exactly one signature per feature and
the cache written here is the one the features read (``tests/test_cold_start.py`` guards both).

:data:`WORKLOADS` are small runs of each feature (the same ones ``benchmarks/cold_start.py`` times). ``warmup``
runs them in ``jobs`` fresh subprocesses at once, so the compiles share the cores; each subprocess writes its
kernels to the cache (numba's cache writes are atomic file replacements, so two processes compiling the same
helper kernel both succeed).

Run: ``plantvr warmup [--jobs N] [--features NAME ...]`` or ``python -m plantvr._warmup``.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from plantvr._validation import check_choice, check_int

__all__ = ["FEATURE_NAMES", "WORKLOADS", "warmup"]


def _loop() -> Callable[[], object]:
    import numpy as np

    from plantvr.subdivision.loop import subdivide_loop
    # an octahedron: closed, every vertex valence 4; two levels reach every branch of the step
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return lambda: subdivide_loop(v, f, 2)


def _tree_mesh() -> Callable[[], object]:
    from plantvr.geometry.mesh import build_branch_mesh
    from plantvr.geometry.synthetic import random_tree
    pos, parent, radius, main_child = random_tree(300, seed=0)
    return lambda: build_branch_mesh(pos, parent, radius, main_child=main_child)


def _colonize() -> Callable[[], object]:
    import numpy as np

    from plantvr.growth.engine import GrowthEngine
    from plantvr.params import defaults
    eng = GrowthEngine(defaults(), rng=0)

    def run():
        eng.paint(np.array([0.0, 2.5, 0.0]), 2.5, 150)
        eng.step()
    return run


def _isosurface() -> Callable[[], object]:
    from plantvr.documents.labels import Segmentation
    from plantvr.vine.proxy import DisplayProxy
    from plantvr.vine.synth import synth_flowerhead
    head = synth_flowerhead(40, rng=0)

    def run():
        seg = Segmentation.from_volume(head.volume, head.level)
        DisplayProxy(seg, target_faces=2000)       # the display proxy the review app draws
    return run


def _paint() -> Callable[[], object]:
    import numpy as np

    from plantvr.documents.labels import Segmentation
    from plantvr.vine.synth import synth_flowerhead
    head = synth_flowerhead(40, rng=0)
    seg = Segmentation.from_volume(head.volume, head.level)
    c = seg.vertices[len(seg.vertices) // 2].astype(np.float64)
    k = [0]

    def run():
        k[0] += 1
        seg.paint(c, 3.0, k[0])
        seg.undo()
    return run


def _demo_step() -> Callable[[], object]:
    from plantvr import Model
    from plantvr.growth.scenarios import demo_session
    model, session = Model(seed=0), demo_session()
    s = [0]

    def run():
        session(model, s[0])
        model.step()
        s[0] += 1
    return run


def _demo() -> Callable[[], object]:
    """What ``plantvr demo`` computes, without the render: grow past the crown strokes (marker compaction
    included), keep the view's incremental meshes up to date, mesh for export, export."""
    from plantvr import Model
    from plantvr.growth.scenarios import demo_session, run
    from plantvr.io.tree import IncrementalTreeGeometry, export_model, tree_geometry

    def go():
        model, session, geom = Model(seed=0), demo_session(), IncrementalTreeGeometry()
        for s in range(0, 48, 8):           # the view re-meshes incrementally as snapshots arrive
            run(model, lambda target, k, s=s: session(target, s + k), 8)
            geom.update(model.snapshot, model.params)
        tree_geometry(model.snapshot, model.params)
        with tempfile.TemporaryDirectory(prefix="plantvr-warmup-") as out:
            for name in ("tree.ply", "tree.glb"):
                export_model(model, os.path.join(out, name))
            model.save(os.path.join(out, "tree.tree"))
    return go


#: Feature name -> (description, setup returning the call to time). Setup imports and builds the inputs.
WORKLOADS: dict[str, tuple[str, Callable[[], Callable[[], object]]]] = {
    "loop": ("Loop subdivision", _loop),
    "tree_mesh": ("tree meshing (build_branch_mesh)", _tree_mesh),
    "colonize": ("colonization (a GrowthEngine step)", _colonize),
    "isosurface": ("isosurface (plantvr.vine)", _isosurface),
    "paint": ("painting (the ViNE brush)", _paint),
    "demo_step": ("the demo's first growth step", _demo_step),
    "demo": ("the demo (grow, mesh, export)", _demo),
}
FEATURE_NAMES = tuple(WORKLOADS)
#: What ``plantvr warmup`` compiles by default: the demo first (its kernels are the slowest), then the rest.
DEFAULT_FEATURES = ("demo", "loop", "isosurface", "paint")


def run_feature(name: str) -> None:
    """Run feature ``name`` once in this process (compiling, or loading from the cache, what it calls)."""
    check_choice("feature", name, FEATURE_NAMES)
    WORKLOADS[name][1]()()


def _one(name: str) -> tuple[str, float, str]:
    t = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "plantvr._warmup", "--child", name], check=False, capture_output=True,
                         text=True, timeout=1800)
    return name, time.perf_counter() - t, "" if res.returncode == 0 else res.stderr[-2000:]


def warmup(features: tuple[str, ...] | list[str] | None = None, *, jobs: int = 2, verbose: bool = True) -> dict:
    """Compile and cache the numba kernels of ``features`` (default :data:`DEFAULT_FEATURES`).

    Parameters
    ----------
    features : sequence of str, optional
        Names from :data:`FEATURE_NAMES`.
    jobs : int
        Subprocesses at once, in [1, 64] (compiling is CPU-bound: the core count).
    verbose : bool
        Print one line per feature.

    Returns
    -------
    dict
        ``{"seconds": wall s of the whole warmup, "features": {name: wall s}}``.

    Raises
    ------
    RuntimeError
        A feature's subprocess failed (its stderr tail is in the message).
    """
    names = list(DEFAULT_FEATURES if features is None else features)
    for n in names:
        check_choice("features", n, FEATURE_NAMES)
    jobs = check_int("jobs", jobs, 1, 64)
    t = time.perf_counter()
    out: dict[str, float] = {}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for name, s, err in pool.map(_one, names):
            if err:
                raise RuntimeError(f"warmup of {name} failed:\n{err}")
            out[name] = s
            if verbose:
                print(f"compiled {WORKLOADS[name][0]} in {s:.1f} s", flush=True)
    total = time.perf_counter() - t
    if verbose:
        where = os.environ.get("NUMBA_CACHE_DIR") or "__pycache__ next to the sources"
        print(f"numba kernels cached in {total:.1f} s ({where})")
    return {"seconds": total, "features": out}


def main(argv: list[str] | None = None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="plantvr warmup", description=__doc__.split("\n\n")[0])
    ap.add_argument("--features", nargs="*", choices=FEATURE_NAMES, default=None)
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        run_feature(a.child)
        return 0
    warmup(a.features, jobs=a.jobs)
    return 0


if __name__ == "__main__":
    sys.exit(main())

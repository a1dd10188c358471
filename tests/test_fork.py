"""Fork safety of the parallel kernels (issue 34): a process that grew a tree can fork (or spawn) children that
grow the same tree, and parallel kernels called from two threads at once do not abort (plantvr._threading)."""
import ast
import multiprocessing as mp
import os
import subprocess
import sys
import textwrap
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

sys.path.insert(0, os.path.dirname(__file__))
import _fork_work as W

from plantvr import _threading

STEPS = 40
PLANTVR = Path(__file__).resolve().parent.parent / "plantvr"
USER_LAYER = bool(os.environ.get("NUMBA_THREADING_LAYER"))


@pytest.fixture(scope="module")
def parent_digest():
    """The parent grows first, so numba's worker threads are running when it forks."""
    return W.grow_digest(STEPS)


def _child(method: str) -> tuple[int, str | None]:
    ctx = mp.get_context(method)
    recv, send = ctx.Pipe(duplex=False)
    p = ctx.Process(target=W.grow_into, args=(send, STEPS))
    p.start()
    send.close()
    got = recv.recv() if recv.poll(240) else None
    p.join(60)
    return p.exitcode, got


@pytest.mark.skipif(USER_LAYER, reason="NUMBA_THREADING_LAYER set by the user")
def test_default_layer_is_workqueue(parent_digest):
    assert W.layer() == _threading.DEFAULT_LAYER == "workqueue"


@pytest.mark.skipif(sys.platform == "win32", reason="no fork")
def test_forked_child_grows_the_parents_tree(parent_digest):
    code, got = _child("fork")
    assert code == 0, f"forked child died with exit code {code}"
    assert got == parent_digest


def test_spawned_child_grows_the_parents_tree(parent_digest):
    code, got = _child("spawn")
    assert code == 0 and got == parent_digest


@pytest.mark.skipif(sys.platform == "win32", reason="no fork")
def test_process_pool_with_fork(parent_digest):
    with ProcessPoolExecutor(2, mp_context=mp.get_context("fork")) as pool:
        got = list(pool.map(W.grow_digest, [STEPS, STEPS], timeout=240))
    assert got == [parent_digest, parent_digest]


@pytest.mark.skipif(sys.platform == "win32", reason="no fork")
def test_dask_forked_worker_grows_after_the_client_grew(parent_digest):
    dask = pytest.importorskip("dask")
    pytest.importorskip("distributed")
    from plantvr.scaleout import connect
    with dask.config.set({"distributed.worker.multiprocessing-method": "fork"}), \
            connect(None, n_workers=1, processes=True) as client:
        got = client.submit(W.grow_digest, STEPS, pure=False).result(timeout=240)
        layers = set(client.run(W.layer).values())
    assert got == parent_digest
    if not USER_LAYER:
        assert layers == {"workqueue"}


_TWO_THREADS = textwrap.dedent("""
    import threading
    import numpy as np
    import plantvr
    from plantvr.geometry.leaves import orient_leaves
    from plantvr.geometry.mesh import build_branch_mesh
    from plantvr.geometry.synthetic import random_tree

    pos, parent, radius, mc = random_tree(6000, seed=0)      # >= 4096 segments: the parallel mesh kernel
    rng = np.random.default_rng(0)
    h = rng.normal(size=(4096, 3)); u = rng.normal(size=(4096, 3))   # >= 2048 leaves: the parallel kernel
    errors = []

    def grow():
        try:
            m = plantvr.Model(seed=0)
            m.paint_stroke([[0, y, 0] for y in range(2, 10)], radius=2.5)
            m.step(30)
        except BaseException as e:
            errors.append(e)

    def render():
        try:
            for _ in range(15):
                build_branch_mesh(pos, parent, radius, main_child=mc)
                orient_leaves(h, np.cross(h, u), u, iterations=4)
        except BaseException as e:
            errors.append(e)

    ts = [threading.Thread(target=grow), threading.Thread(target=render), threading.Thread(target=render)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert not errors, errors
    print("ok", plantvr._threading.threading_layer())
""")


def test_parallel_kernels_from_several_threads_do_not_abort():
    res = subprocess.run([sys.executable, "-c", _TWO_THREADS], check=False, capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PYTHONPATH": str(PLANTVR.parent)})
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.split()[0] == "ok"


def _sources() -> list[tuple[Path, str]]:
    return [(p, p.read_text()) for p in sorted(PLANTVR.rglob("*.py"))]


def _parallel_kernels() -> dict[str, set[str]]:
    """module path -> names of its ``parallel=True`` numba kernels."""
    out: dict[str, set[str]] = {}
    for path, text in _sources():
        if "parallel=True" not in text:
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef) and any(
                    isinstance(d, ast.Call) and any(k.arg == "parallel" and getattr(k.value, "value", None) is True
                                                    for k in d.keywords) for d in node.decorator_list):
                out.setdefault(str(path), set()).add(node.name)
    return out


def test_every_parallel_kernel_call_is_inside_a_parallel_region():
    kernels = set().union(*_parallel_kernels().values())
    assert {"treewand_assign_parallel", "_eval_segments_numba", "_orient_numba", "_propagate_layers"} <= kernels
    bare = []
    for path, text in _sources():
        if not any(k in text for k in kernels):
            continue
        tree = ast.parse(text)

        def visit(node, guarded, path=path):
            if isinstance(node, ast.With) and any(
                    isinstance(i.context_expr, ast.Call) and getattr(i.context_expr.func, "id", None) ==
                    "parallel_region" for i in node.items):
                guarded = True
            if isinstance(node, ast.Call):
                f = node.func
                name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
                if name in kernels and not guarded:
                    bare.append(f"{path.relative_to(PLANTVR.parent)}:{node.lineno} {name}")
            for child in ast.iter_child_nodes(node):
                visit(child, guarded, path)
        visit(tree, False)
    # ``fn = _orient_numba if ... else _orient_serial`` names the kernel without calling it: only calls count
    assert not bare, f"parallel kernels called outside plantvr._threading.parallel_region: {bare}"


def test_user_layer_is_respected():
    code = "import plantvr._threading as t, numba; print(t.configure(), numba.config.THREADING_LAYER)"
    res = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120,
                         env={**os.environ, "NUMBA_THREADING_LAYER": "omp", "PYTHONPATH": str(PLANTVR.parent)})
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["omp", "omp"]

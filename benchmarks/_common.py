"""Helpers shared by the benchmark scripts (``python benchmarks/<name>.py``): best-of-N wall times, memory and
CPU readings, a measurement in a forked child, and the brush radius that catches a given number of vertices.

Imported as ``from _common import best_of`` (the script's folder is on ``sys.path`` when a benchmark runs as a
script); not a benchmark itself, so ``tests/test_benchmarks.py`` skips it.
"""
from __future__ import annotations

import multiprocessing
import resource
import time
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["best_of", "best_time", "cpu_capacity", "cpu_seconds", "current_rss_gib", "in_forked_child", "peak_rss_gib",
           "radius_for"]


def best_of(fn: Callable[[], Any], repeat: int = 3) -> tuple[float, Any]:
    """Best wall time (s, ``time.perf_counter``) of ``repeat`` calls of ``fn()``, and the last call's result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def best_time(fn: Callable[[], Any], repeat: int = 3) -> float:
    """Best wall time (s) of ``repeat`` calls of ``fn()`` (the result is dropped)."""
    return best_of(fn, repeat)[0]


def current_rss_gib() -> float:
    """Resident set size of this process now (GiB, ``VmRSS`` of ``/proc/self/status``; NaN where absent)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 2 ** 20
    return float("nan")


def peak_rss_gib() -> float:
    """Peak resident set size of this process so far (GiB, ``ru_maxrss``)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20


def cpu_seconds() -> float:
    """User + system CPU time of this process so far (s)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _child(fn, args, conn) -> None:
    conn.send(fn(*args))
    conn.close()


def in_forked_child(fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` run in a forked child of this process (it sees all the parent holds, and its peak RSS is its
    own); returns what it returns (keep it small: it is pickled back), or None if the child died (out of
    memory)."""
    ctx = multiprocessing.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    p = ctx.Process(target=_child, args=(fn, args, send))
    p.start()
    send.close()
    try:
        res = recv.recv()
    except EOFError:                                          # killed (out of memory)
        res = None
    p.join()
    return res


def radius_for(index: Any, center, hits: int, steps: int = 40) -> float:
    """Smallest radius (bisection, ``steps`` halvings) at which ``index.query(center, r)`` returns ``hits`` ids."""
    lo, hi = 0.0, 1.0
    while len(index.query(center, hi)) < hits:
        hi *= 2
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if len(index.query(center, mid)) < hits:
            lo = mid
        else:
            hi = mid
    return hi


def _burn(n: int) -> float:
    t = time.perf_counter()
    s = 0
    for i in range(n):
        s += i
    return time.perf_counter() - t


def cpu_capacity(n: int = 3_000_000) -> float:
    """Throughput of 2 processes over 1 on a pure-Python loop (2.0 on two free cores)."""
    from concurrent.futures import ProcessPoolExecutor

    one = _burn(n)
    with ProcessPoolExecutor(2) as ex:
        _ = list(ex.map(_burn, [1000, 1000]))
        t = time.perf_counter()
        list(ex.map(_burn, [n, n]))
        two = time.perf_counter() - t
    return 2 * one / two

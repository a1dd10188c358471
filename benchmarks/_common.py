"""Helpers shared by the benchmark scripts (``python benchmarks/<name>.py``): best-of-N wall times.

Imported as ``from _common import best_of`` (the script's folder is on ``sys.path`` when a benchmark runs as a
script); not a benchmark itself, so ``tests/test_benchmarks.py`` skips it.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["best_of", "best_time"]


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

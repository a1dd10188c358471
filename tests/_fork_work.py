"""Work run in child processes by tests/test_fork.py (importable by name, so spawned children find it)."""
from __future__ import annotations

import hashlib


def grow_digest(steps: int = 40) -> str:
    """SHA-256 of the state of the README's tree (seed 0, one wand stroke) after ``steps`` growth steps."""
    import plantvr
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 10)], radius=2.5)
    m.step(steps)
    return hashlib.sha256(m.state_bytes()).hexdigest()


def grow_into(conn, steps: int = 40) -> None:
    """:func:`grow_digest` sent down a pipe (a ``multiprocessing.Process`` target)."""
    conn.send(grow_digest(steps))
    conn.close()


def layer() -> str:
    """numba's threading layer in this process (after a parallel kernel has run)."""
    from plantvr._threading import threading_layer
    return threading_layer()

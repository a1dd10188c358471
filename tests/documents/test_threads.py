"""Snapshots are published atomically and in order, and commands from any thread are ordered through the
document's lock, so replay of the recorded log is exact with background growth (issue 34).

The 30 s version is ``python benchmarks/document_threads.py`` (run at ``--quick`` size by tests/test_benchmarks.py).
"""
import importlib.util
import threading
from pathlib import Path

import numpy as np
import pytest

from plantvr.documents.treewand import Model

_spec = importlib.util.spec_from_file_location(
    "document_threads", Path(__file__).resolve().parents[2] / "benchmarks" / "document_threads.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


@pytest.mark.parametrize("seed", range(10))
def test_background_growth_with_commands_replays_exactly_and_reads_consistently(seed):
    r = bench.session(seed, 0.4, n_markers=1500)
    assert r["commands"] > 0 and r["polls"] > 0
    assert r["backwards"] == 0 and r["inconsistent"] == 0
    assert r["replay_identical"]


def test_changes_published_from_two_threads_never_go_back():
    m = Model(seed=0)
    m.add_markers(np.random.default_rng(1).uniform([-3, 1, -3], [3, 8, 3], (400, 3)))
    seen = []
    m.observe(lambda ch: seen.append(ch["new"]), names="version")

    def paint(k):
        for i in range(30):
            m.paint([0.1 * k, 2 + 0.1 * i, 0], 0.5, 5)

    threads = [threading.Thread(target=paint, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    m.grow(5)
    for t in threads:
        t.join()
    m.flush()
    assert seen == sorted(seen) and m.version == m._seq
    assert m.snapshot is m.latest and m.snapshot.version == max(seen, default=0) or m.snapshot is m.latest
    fresh = Model(seed=0)
    fresh.replay(m.log)
    assert fresh.state_bytes() == m.state_bytes()

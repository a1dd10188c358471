"""Triple buffer (V6) and render-thread liveness while painting on the worker (V7)."""
import threading
import time

import numpy as np
import pytest

from plantvr.documents.labels import Segmentation
from plantvr.vine.buffers import PaintWorker, TripleBuffer


def test_tw_v6_reader_never_sees_a_buffer_being_written():
    n = 50_000
    tb = TripleBuffer(np.zeros(n, np.uint8))
    stop = threading.Event()
    bad, seen = [], []

    def reader():
        while not stop.is_set():
            b, v = tb.acquire()
            # every publish writes the whole content as (version % 251): a torn buffer is not constant
            first, last = int(b[0]), int(b[-1])
            if first != last or first != v % 251 or not np.all(b[::997] == first):
                bad.append((v, first, last))
            seen.append(v)
            tb.release()

    t = threading.Thread(target=reader)
    t.start()
    perm = np.random.default_rng(0).permutation(n)
    for k in range(1, 150):
        if k % 10 == 0:
            tb.publish(None, np.full(n, k % 251, np.uint8))          # large edit: 100 % of vertices
        else:
            tb.publish(perm, np.full(n, k % 251, np.uint8))
    stop.set()
    t.join()
    assert not bad
    b, v = tb.acquire()
    assert v == 149 and np.all(b == 149 % 251)
    assert tb.nbytes == 3 * n


def test_triple_buffer_catches_up_by_sparse_deltas():
    tb = TripleBuffer(np.zeros(10, np.uint8))
    ref = np.zeros(10, np.uint8)
    rng = np.random.default_rng(1)
    for k in range(30):
        idx = rng.choice(10, 3, replace=False)
        val = rng.integers(0, 255, 3).astype(np.uint8)
        ref[idx] = val
        tb.publish(idx, val)
        if k % 3 == 0:
            tb.acquire()                      # hold a buffer sometimes
        if k % 5 == 0:
            tb.release()
        b, _ = tb.acquire()
        assert np.array_equal(b, ref)
        tb.release()


def test_tw_v7_render_loop_keeps_cadence_during_long_paint():
    rng = np.random.default_rng(2)
    pts = rng.uniform(0, 100, (600_000, 3)).astype(np.float32)
    seg = Segmentation(pts, np.zeros((1, 3), np.int64))
    _ = seg.index
    worker = PaintWorker(seg)
    gaps = []
    stop = threading.Event()

    def render_loop():
        last = time.perf_counter()
        while not stop.is_set():
            b, _ = worker.buffer.acquire()
            int(b[::4096].sum())              # "draw" a little
            worker.buffer.release()
            time.sleep(0.002)
            now = time.perf_counter()
            gaps.append(now - last)
            last = now

    t = threading.Thread(target=render_loop)
    t.start()
    t0 = time.perf_counter()
    worker.submit("begin_stroke")
    for k in range(12):                      # whole-mesh repaints, alternating colours
        worker.submit("paint", [50.0, 50.0, 50.0], 90.0, 1 + k % 2)
    worker.submit("end_stroke")
    worker.join()
    busy = time.perf_counter() - t0
    stop.set()
    t.join()
    worker.close()
    assert not worker.errors
    assert busy > 0.2
    b, _ = worker.buffer.acquire()
    assert np.array_equal(b, seg.labels)
    # the loop kept running: many frames, and no stall anywhere near the repaint time
    assert len(gaps) > 20 and max(gaps) < 0.5 * busy, (max(gaps), busy)


def test_worker_reports_invalid_commands():
    seg = Segmentation(np.zeros((4, 3), np.float32) + np.arange(4)[:, None], np.array([[0, 1, 2]]))
    w = PaintWorker(seg)
    w.submit("paint", [0, 0, 0], -1.0, 1)
    w.join()
    w.close()
    assert len(w.errors) == 1 and "radius" in str(w.errors[0])
    with pytest.raises(ValueError, match="op must be one of"):
        w.submit("explode")

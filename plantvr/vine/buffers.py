"""Triple-buffered label publication and the painting worker thread (spec 000_vine §4.2–4.3, checklist items
18–19; thesis §5.7.1–5.7.2).

The worker owns ``Segmentation.labels``; after each change (the document's ``change`` trait) the changed
entries are published into a :class:`TripleBuffer`. The writer always fills the oldest buffer not being read and the reader always takes
the latest completed one, so neither waits for the other beyond an index swap under a short lock. A buffer
that is one or two versions stale is caught up by replaying the sparse deltas it missed (the "catch-up
step" the spec adds), or by one full copy when the deltas are gone.
"""
from __future__ import annotations

import queue
import threading
from collections import deque

import numpy as np

from plantvr._validation import check_choice

__all__ = ["PaintWorker", "TripleBuffer"]


class TripleBuffer:
    """Three copies of a per-vertex uint8 array with lock-free-ish hand-off between one writer and one reader.

    Parameters
    ----------
    initial : (V,) uint8 ndarray
        Initial content (copied three times: 3 bytes per vertex, 54 MB for the gerbera).
    """

    def __init__(self, initial: np.ndarray):
        a = np.asarray(initial)
        if a.ndim != 1 or a.dtype != np.uint8:
            raise ValueError(f"initial must be a 1-D uint8 array, got {a.dtype} {a.shape}")
        self.bufs = [a.copy() for _ in range(3)]
        self.version = [0, 0, 0]
        self.latest = 0
        self.reading: int | None = None
        self._lock = threading.Lock()
        self._deltas: deque = deque(maxlen=4)        # (version_after, idx, values)

    @property
    def nbytes(self) -> int:
        """Memory of the three buffers."""
        return sum(b.nbytes for b in self.bufs)

    # -- reader (render thread) --
    def acquire(self) -> tuple[np.ndarray, int]:
        """Take the latest completed buffer for reading; returns a read-only view and its version."""
        with self._lock:
            self.reading = self.latest
            b = self.bufs[self.reading].view()
            v = self.version[self.reading]
        b.flags.writeable = False
        return b, v

    def release(self) -> None:
        """Finish reading (the writer may then reuse that buffer)."""
        with self._lock:
            self.reading = None

    # -- writer (worker thread) --
    def publish(self, idx: np.ndarray | None, values: np.ndarray | None) -> int:
        """Write a sparse update (``idx``, ``values``) or, with ``idx=None``, a full array ``values``.

        Returns the new version.
        """
        with self._lock:
            latest, reading = self.latest, self.reading
            w = next(i for i in sorted(range(3), key=lambda i: self.version[i])
                     if i != latest and i != reading)
            target_v = self.version[latest]
        buf = self.bufs[w]
        have = self.version[w]
        if have != target_v:
            need = [d for d in self._deltas if have < d[0] <= target_v]
            if len(need) == target_v - have and all(d[1] is not None for d in need):
                for _, di, dv in need:
                    buf[di] = dv
            else:
                np.copyto(buf, self.bufs[latest])
        if idx is None:
            np.copyto(buf, values)
        else:
            buf[idx] = values
        new_v = target_v + 1
        self._deltas.append((new_v, None if idx is None else np.array(idx), np.array(values)))
        with self._lock:
            self.version[w] = new_v
            self.latest = w
        return new_v


class PaintWorker:
    """Run painting, undo and redo of a :class:`~plantvr.documents.labels.Segmentation` on a worker thread.

    Commands are queued by name with their keyword arguments, as the document's command log holds them
    (``paint``, ``begin_stroke``, ``end_stroke``, ``undo``, ``redo``, ``set_visible``, ...), and validated by
    the segmentation when they run; errors are collected in ``errors``. Changes are published
    into ``buffer`` (a :class:`TripleBuffer`), which the render thread reads.

    Parameters
    ----------
    seg : Segmentation
    """

    _OPS = ("paint", "begin_stroke", "end_stroke", "abort_stroke", "undo", "redo", "set_visible", "set_color",
            "add_color")

    def __init__(self, seg):
        self.seg = seg
        self.buffer = TripleBuffer(seg.labels)
        self.errors: list[Exception] = []
        self._q: queue.Queue = queue.Queue()
        self._thread = threading.Thread(target=self._run, name="vine-paint-worker", daemon=True)
        seg.observe(self._on_change, names="change")
        self._thread.start()

    def _on_change(self, event):
        c = event["new"]
        if c.kind == "labels" and c.ids is not None:
            if c.ids.size:
                self.buffer.publish(c.ids, self.seg.labels[c.ids])
        elif c.kind == "all":
            self.buffer.publish(None, self.seg.labels)

    def submit(self, op: str, *args, **kwargs) -> None:
        """Queue a command, e.g. ``submit("paint", center, radius, label)`` or, from a command log,
        ``submit(event.command, **event.kwargs)``."""
        check_choice("op", op, self._OPS)
        self._q.put((op, args, kwargs))

    def join(self) -> None:
        """Wait until every queued command has run."""
        self._q.join()

    def close(self) -> None:
        """Finish queued work and stop the thread."""
        self._q.put(None)
        self._thread.join()
        self.seg.unobserve(self._on_change, names="change")

    def _run(self):
        while True:
            item = self._q.get()
            try:
                if item is None:
                    return
                op, args, kwargs = item
                getattr(self.seg, op)(*args, **kwargs)
            except Exception as exc:  # noqa: BLE001 - reported to the caller through .errors
                self.errors.append(exc)
            finally:
                self._q.task_done()

"""numba's threading layer, and fork safety of PlantVR's parallel kernels (issue 34).

PlantVR's ``parallel=True`` kernels (the Tree Wand assignment, branch meshing, leaf orientation, crown layers)
run on numba's threading layer. numba picks ``tbb`` when the ``tbb`` package can be loaded, else ``omp``, else
``workqueue``. On Linux ``omp`` is GNU OpenMP, and numba ends any process that forks after it has used it
(``Terminating: fork() called from a process already using GNU OpenMP``): a notebook that grew a tree could not
``multiprocessing``-fork a child (``ProcessPoolExecutor``, dask's nanny with the fork method) that grows again.

PlantVR therefore runs its kernels on ``workqueue``, numba's own pool, which is fork-safe (the child restarts its
workers on the first kernel). ``workqueue`` is not thread-safe: two threads entering parallel kernels at once
abort the process (``Concurrent access has been detected``), and PlantVR calls kernels from the growth thread
and from render threads. So every parallel kernel is entered under :func:`parallel_region`, one process-wide
lock: parallel kernels run one at a time (each already uses every numba thread), the others' callers wait. The
lock is also taken around ``os.fork``, so a fork never copies a pool in the middle of a kernel, and the child
gets a fresh lock.

Measured on the 2-core development machine, shared with other jobs (load 3-6), three interleaved rounds per
layer, best of 6 growth steps at 5,600 internodes with 50,000 markers (``benchmarks/interactive.py``'s
engine), each beside the serial step (``GrowthEngine._fast = False``) in the same process so the load cancels:
parallel / serial step time ``omp`` 0.29-1.27 (median 0.81; 8.6-110 ms), ``workqueue`` 0.24-0.48 (0.47;
17.7-31.8 ms), ``tbb`` 0.33-0.46 (0.43; 21.5-29.2 ms); a 20,000-internode ``build_branch_mesh`` best-of-8
64-87 / 37-76 / 54-83 ms. So ``workqueue`` is no slower here; on a busy machine ``omp``'s spinning workers
cost the most. ``tbb`` is fork- and thread-safe too, but it is an extra dependency (a 4.5 MB library), and numba does not load the ``libtbb.so.12`` that ``pip install tbb`` puts in a virtual
environment's ``lib/`` unless ``LD_LIBRARY_PATH`` names it (numba's ``tbbpool`` extension has no rpath). The
price of ``workqueue``: parallel kernels called from two threads at once run one after the other (each uses
every core anyway), and a nested parallel kernel (none in PlantVR) would abort.

A user's choice wins: ``NUMBA_THREADING_LAYER`` in the environment, or ``numba.config.THREADING_LAYER`` set
before PlantVR first runs a kernel (``omp`` brings back the fork abort; ``tbb`` is safe). The choice is made by
:func:`configure` when this module is imported (every module defining a parallel kernel imports it) and again
before the first :func:`parallel_region`.
"""
from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator

__all__ = ["DEFAULT_LAYER", "configure", "parallel_region", "threading_layer"]

#: The layer PlantVR asks numba for when the user has not chosen one.
DEFAULT_LAYER = "workqueue"

_lock = threading.RLock()
_configured = False


def configure() -> str:
    """Ask numba for :data:`DEFAULT_LAYER` unless the user chose a layer, or numba's threads already started.

    Returns
    -------
    str
        The layer numba is configured with (``numba.config.THREADING_LAYER``).
    """
    global _configured
    import numba
    from numba.np.ufunc import parallel as _parallel

    started = getattr(_parallel, "_is_initialized", False)
    if not started and not os.environ.get("NUMBA_THREADING_LAYER") and numba.config.THREADING_LAYER == "default":
        numba.config.THREADING_LAYER = DEFAULT_LAYER
    _configured = True
    return numba.config.THREADING_LAYER


def threading_layer() -> str:
    """The layer numba's threads run on (after the first parallel kernel), else the configured one."""
    import numba
    try:
        return numba.threading_layer()
    except ValueError:                       # no parallel kernel has run yet
        return configure()


@contextlib.contextmanager
def parallel_region() -> Iterator[None]:
    """Enter a ``parallel=True`` kernel: one thread at a time in the process (``workqueue`` is not thread-safe).

    Re-entrant in one thread. Every Python call of a parallel kernel in ``plantvr`` is inside one
    (``tests/test_fork.py`` checks the sources).
    """
    if not _configured:
        configure()
    with _lock:
        yield


def _before_fork() -> None:
    _lock.acquire()                          # wait until no parallel kernel runs: the pool is idle when copied


def _after_fork_parent() -> None:
    _lock.release()


def _after_fork_child() -> None:
    global _lock
    _lock = threading.RLock()                # the copy is held by the forking thread's parent


os.register_at_fork(before=_before_fork, after_in_parent=_after_fork_parent, after_in_child=_after_fork_child)
configure()                                  # on import: every module defining a parallel kernel imports this one

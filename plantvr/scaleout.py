"""Scale-out plumbing on dask.distributed shared by the forest and the parameter sweep (DESIGN: scale-out work is
a set of independent tasks on a dask client; issue 24).

One task is a module-level function of small parameter records that returns compact arrays; tasks are batched
so every worker gets a few (:func:`chunks`); every task is run through :func:`timed`, so the time spent inside
task bodies is known beside the wall time of the wave (:class:`TaskStats`: the per-task overhead of scheduling,
serialisation, transfers and idle workers). ``client`` is ``"sync"`` (this thread), a scheduler address
(``"tcp://host:port"``, connected and closed here), a dask ``Client``, or None (a :class:`LocalCluster` started
and closed here, see :func:`connect`). Results never depend on where tasks run.
"""
from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._validation import check_int

__all__ = ["SCHEMES", "TaskStats", "check_client", "check_progress", "chunks", "connect", "run_tasks", "timed",
           "track", "warm_workers"]

#: Scheduler address schemes accepted as ``client`` strings.
SCHEMES = ("tcp://", "tls://", "inproc://", "ucx://", "ws://", "wss://")


def check_client(client: Any) -> Any:
    """``client`` if it is None, ``"sync"``, a scheduler address (``"tcp://host:port"``) or a dask ``Client``
    (anything with ``submit``), else a ValueError naming the parameter."""
    if client is None or hasattr(client, "submit"):
        return client
    if isinstance(client, str) and (client == "sync" or (client.startswith(SCHEMES) and len(client) > 6
                                                         and client.split("://", 1)[1].strip())):
        return client
    raise ValueError(f"client must be None, 'sync' or a dask Client (or a scheduler address "
                     f"'tcp://host:port'), got {client!r:.80}")


def check_progress(progress: Any) -> bool:
    """``progress`` as a bool (True / False only)."""
    if not isinstance(progress, (bool, np.bool_)):
        raise ValueError(f"progress must be True or False, got {progress!r:.80}")
    return bool(progress)


@contextlib.contextmanager
def connect(client: Any, *, n_workers: int = 2, processes: bool = True, threads_per_worker: int = 1
            ) -> Iterator[Any]:
    """The runner for ``client`` (checked by :func:`check_client`): ``"sync"`` as is (also when dask is missing
    and ``client`` is None), a given ``Client`` as is, a ``Client`` connected to an address string, or a
    ``Client`` on a new ``LocalCluster(n_workers, processes=, threads_per_worker=)`` for None; what is opened
    here is closed on exit."""
    client = check_client(client)
    if client == "sync" or hasattr(client, "submit"):
        yield client
        return
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        if client is not None:
            raise ValueError(f"client {client!r} needs dask.distributed (pip install 'dask[distributed]')") from None
        yield "sync"
        return
    if client is None:
        with LocalCluster(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=processes,
                          dashboard_address=None) as cluster, Client(cluster) as own:
            yield own
    else:
        with Client(client) as own:
            yield own


def n_workers_of(runner: Any) -> int:
    """Workers of a runner (1 for ``"sync"``)."""
    return 1 if runner == "sync" else max(len(runner.scheduler_info()["workers"]), 1)


def chunks(n: int, n_workers: int, *, per_worker: int = 3, tasks: int | None = None) -> list[np.ndarray]:
    """Indices 0..n-1 in contiguous batches: ``tasks`` of them, default ``per_worker`` per worker (a few per
    worker balance uneven tasks; fewer, larger tasks amortise the per-task overhead)."""
    n = check_int("n", n, 0, 10**9)
    k = tasks if tasks is not None else per_worker * check_int("n_workers", n_workers, 1, 100_000)
    k = check_int("tasks", k, 1, 10**9)
    return [c for c in np.array_split(np.arange(n), max(min(n, k), 1)) if len(c)]


def timed(fn: Callable, *args: Any, **kwargs: Any) -> tuple[Any, float, float]:
    """``(fn(*args, **kwargs), wall seconds, CPU seconds)`` of the call, measured inside the task."""
    t, c = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t, time.process_time() - c


@dataclass
class TaskStats:
    """Timing of the task waves of one run: ``wall_s`` the caller's wall time over the waves, ``body_s`` / ``cpu_s``
    the wall / CPU seconds spent inside task bodies (summed), ``n_tasks`` and ``n_workers``.

    ``overhead`` = 1 - body / (workers x wall): the share of the workers' time not spent in task bodies
    (scheduling, serialisation, transfers, the caller's own work between waves, idle workers at barriers); an
    upper bound of the per-task overhead. ``task_s`` is the mean body time, ``overhead_per_task_s`` the lost
    worker time per task."""

    n_workers: int = 1
    n_tasks: int = 0
    wall_s: float = 0.0
    body_s: float = 0.0
    cpu_s: float = 0.0
    waves: list[float] = field(default_factory=list)

    def add(self, wall: float, parts: Sequence[tuple[float, float]]) -> None:
        self.waves.append(wall)
        self.wall_s += wall
        self.n_tasks += len(parts)
        self.body_s += sum(p[0] for p in parts)
        self.cpu_s += sum(p[1] for p in parts)

    @property
    def overhead(self) -> float:
        cap = self.n_workers * self.wall_s
        return max(0.0, 1.0 - self.body_s / cap) if cap > 0 else 0.0

    @property
    def task_s(self) -> float:
        return self.body_s / self.n_tasks if self.n_tasks else 0.0

    @property
    def overhead_per_task_s(self) -> float:
        return max(0.0, self.n_workers * self.wall_s - self.body_s) / self.n_tasks if self.n_tasks else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"n_workers": self.n_workers, "n_tasks": self.n_tasks, "wall_s": self.wall_s, "body_s": self.body_s,
                "cpu_s": self.cpu_s, "task_s": self.task_s, "overhead": self.overhead,
                "overhead_per_task_s": self.overhead_per_task_s, "waves": list(self.waves)}

    def __str__(self) -> str:
        return (f"{self.n_tasks} tasks on {self.n_workers} worker(s): wall {self.wall_s:.2f} s, in tasks "
                f"{self.body_s:.2f} s ({self.cpu_s:.2f} s CPU), mean task {1e3 * self.task_s:.1f} ms, overhead "
                f"{1e3 * self.overhead_per_task_s:.1f} ms/task = {100 * self.overhead:.1f} % of worker time")


def _in_notebook() -> bool:
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    ip = get_ipython()
    return ip is not None and hasattr(ip, "kernel")


def track(futures: list, *, progress: bool, desc: str = "tasks") -> None:
    """Show tasks completing: dask's progress bar in a notebook, tqdm in scripts; returns once all are done
    (with ``progress=False`` returns at once)."""
    if not progress or not futures:
        return
    from dask.distributed import as_completed
    if _in_notebook():
        from dask.distributed import progress as dask_progress
        dask_progress(futures, notebook=True, multi=False)
        return
    from tqdm import tqdm
    for _ in tqdm(as_completed(futures), total=len(futures), desc=desc):
        pass


def run_tasks(runner: Any, fn: Callable, arg_lists: Sequence[tuple], *, stats: TaskStats | None = None,
              progress: bool = False, desc: str = "tasks") -> list:
    """``[fn(*args) for args in arg_lists]`` as one wave of tasks on ``runner`` (``"sync"`` or a Client), in
    order; every call is :func:`timed` and added to ``stats``."""
    t0 = time.perf_counter()
    if runner == "sync":
        it = arg_lists
        if progress:
            from tqdm.auto import tqdm
            it = tqdm(arg_lists, desc=desc)
        got = [timed(fn, *a) for a in it]
    else:
        futs = [runner.submit(timed, fn, *a, pure=False) for a in arg_lists]
        track(futs, progress=progress, desc=desc)
        got = runner.gather(futs)
    if stats is not None:
        stats.add(time.perf_counter() - t0, [(w, c) for _, w, c in got])
    return [r for r, _, _ in got]


def warm_workers(runner: Any, fn: Callable) -> dict[str, float]:
    """Run ``fn`` (a warm-up returning seconds) once on every worker (``client.run``) or here for ``"sync"``;
    worker -> seconds. Worker start-up (imports, loading compiled kernels) is then out of the timed waves."""
    if runner == "sync":
        return {"sync": float(fn())}
    return {k: float(v) for k, v in runner.run(fn).items()}

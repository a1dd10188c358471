"""Scale-out plumbing (issue 24): client and option checks, batching, task timing, the same results serially, on
a client and through a scheduler address."""
import numpy as np
import pytest

from plantvr.scaleout import TaskStats, check_client, check_progress, chunks, connect, run_tasks, timed


def _square(x):
    return x * x


def test_check_client_accepts_addresses_and_names_the_parameter():
    assert check_client(None) is None and check_client("sync") == "sync"
    assert check_client("tcp://127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    for bad in ("threads", "tcp://", "tcp:// ", 3, ["sync"]):
        with pytest.raises(ValueError, match="client must be None, 'sync' or a dask Client"):
            check_client(bad)
    assert check_progress(True) is True and check_progress(np.bool_(False)) is False
    for bad in ("yes", 1, None):
        with pytest.raises(ValueError, match="progress must be True or False"):
            check_progress(bad)


def test_chunks_cover_every_index_once_in_order():
    for n, w, k in ((300, 2, 6), (5, 2, 6), (1, 4, 3), (0, 2, 3)):
        c = chunks(n, w, per_worker=k)
        assert len(c) == min(n, w * k) or n == 0
        np.testing.assert_array_equal(np.concatenate(c) if c else np.zeros(0, int), np.arange(n))
    assert len(chunks(10, 2, tasks=3)) == 3
    with pytest.raises(ValueError, match="n_workers"):
        chunks(10, 0)
    with pytest.raises(ValueError, match="tasks"):
        chunks(10, 2, tasks=0)


def test_task_stats_overhead():
    s = TaskStats(2)
    s.add(1.0, [(0.45, 0.4), (0.5, 0.5)])
    assert s.n_tasks == 2 and s.body_s == pytest.approx(0.95) and s.cpu_s == pytest.approx(0.9)
    assert s.overhead == pytest.approx(1 - 0.95 / 2.0) and s.overhead_per_task_s == pytest.approx(1.05 / 2)
    assert "2 tasks on 2 worker(s)" in str(s) and s.as_dict()["waves"] == [1.0]
    out, wall, cpu = timed(_square, 3)
    assert out == 9 and wall >= 0 and cpu >= 0


def test_run_tasks_same_results_sync_client_and_address():
    distributed = pytest.importorskip("dask.distributed")
    args = [(i,) for i in range(7)]
    st = TaskStats(1)
    ref = run_tasks("sync", _square, args, stats=st, progress=True)
    assert ref == [i * i for i in range(7)] and st.n_tasks == 7
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        with connect(cluster.scheduler_address) as client:  # connected here, closed on exit
            assert hasattr(client, "submit")
            s2 = TaskStats(2)
            assert run_tasks(client, _square, args, stats=s2, progress=True) == ref
            assert s2.n_tasks == 7 and s2.wall_s > 0
        assert client.status == "closed"
        with distributed.Client(cluster) as given, connect(given) as same:
            assert same is given
        assert given.status == "closed"
    with connect("sync") as r:
        assert r == "sync"

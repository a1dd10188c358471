"""Scale-out on dask.distributed (issue 24): throughput of a LocalCluster with 2 worker processes against 1 worker
(the baseline, measured in the same run) on a forest with geometry (meshes built on the workers) and a Tree Wand
parameter sweep, with byte-identical results (SHA-256 of every result array) and the per-task overhead.

Target: 2 workers >= 1.7x the throughput of 1 worker on 2 cores, overhead < 5 % of task time. Worker start-up
(process start, imports, loading compiled numba kernels) is a warm-up task per worker, timed and printed apart
from the throughput. The machine's parallel capacity (the same pure-Python loop in 1 and 2 processes) is printed
first: a speed-up above it is impossible (on a loaded machine it is well below 2).

Overhead = 1 - (seconds inside task bodies) / (workers x wall seconds of the waves): scheduling, (de)serialisation,
transfers, the caller's competition between rounds and workers idle at barriers, all counted. dask's task stream
splits it: *dispatch* is the gaps between a worker's consecutive tasks while the run is going on (the scheduler
and (de)serialisation: the per-task overhead proper), *barrier* the time no worker computes (the client between
rounds, result transfer), *imbalance* a worker waiting for the others at the end of a wave.

    python benchmarks/scaleout.py            # 300 trees (competing and independent), 64-point sweep
    python benchmarks/scaleout.py --quick    # 40 trees, 8 points (< 30 s)
"""
from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np
from _common import cpu_capacity

from plantvr.landscape import grow_forest
from plantvr.landscape.forest import warm_up
from plantvr.documents.sweep import sweep, warm_up_sweep


def forest_hash(f) -> str:
    h = hashlib.sha256()
    for t in f.trees:
        for k in sorted(t):
            h.update(k.encode() + t[k].tobytes())
    for v, fa in f.meshes or ():
        h.update(v.tobytes() + fa.tobytes() + fa.dtype.str.encode())
    return h.hexdigest()[:16]


def sweep_hash(table) -> str:
    h = hashlib.sha256()
    for s in table["state"]:
        h.update(s)
    h.update(table.drop(columns=["state", "seconds", "ms_per_step"]).to_numpy().tobytes())
    return h.hexdigest()[:16]


def _warm() -> float:
    return warm_up() + warm_up_sweep()


def stream_split(records: list[dict]) -> dict[str, float]:
    """Worker-seconds of a run's task stream (``client.get_task_stream()`` records): ``compute`` (the tasks'
    compute intervals), ``dispatch`` (a worker's gaps between its consecutive tasks, where some worker is
    computing throughout the gap), ``barrier`` (no worker computes: times the number of workers), ``imbalance``
    (the rest of the span: a worker idle while another finishes its wave)."""
    iv: dict[str, list] = {}
    for r in records:
        for ss in r.get("startstops", ()):
            if ss["action"] == "compute":
                iv.setdefault(r["worker"], []).append((ss["start"], ss["stop"]))
    if not iv:
        return {"compute": 0.0, "dispatch": 0.0, "barrier": 0.0, "imbalance": 0.0, "span": 0.0}
    allv = sorted(x for v in iv.values() for x in v)
    t0, t1 = allv[0][0], max(b for _, b in allv)
    busy, cur = [], list(allv[0])                     # union of all compute intervals
    for a, b in allv[1:]:
        if a <= cur[1]:
            cur[1] = max(cur[1], b)
        else:
            busy.append(tuple(cur))
            cur = [a, b]
    busy.append(tuple(cur))
    covered = lambda a, b: any(x <= a and b <= y for x, y in busy)  # noqa: E731
    workers = len(iv)
    compute = sum(b - a for v in iv.values() for a, b in v)
    dispatch = 0.0
    for v in iv.values():
        v.sort()
        dispatch += sum(c - b for (_, b), (c, _) in zip(v, v[1:]) if c > b and covered(b, c))
    barrier = ((t1 - t0) - sum(b - a for a, b in busy)) * workers
    imbalance = max(0.0, workers * (t1 - t0) - compute - dispatch - barrier)
    return {"compute": compute, "dispatch": dispatch, "barrier": barrier, "imbalance": imbalance, "span": t1 - t0}


def _worker_cpu(client) -> float:
    return float(sum(client.run(time.process_time).values()))


def run_on(n_workers: int, jobs: dict) -> dict:
    """Start a LocalCluster of ``n_workers`` processes, warm every worker, run every job; timings per job."""
    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    out = {}
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.wait_for_workers(n_workers)
        out["start_s"] = time.perf_counter() - t0
        t = time.perf_counter()
        out["warm"] = client.run(_warm)
        out["warm_s"] = time.perf_counter() - t
        for name, job in jobs.items():
            cpu, pc = _worker_cpu(client), time.process_time()
            from dask.distributed import get_task_stream
            t = time.perf_counter()
            with get_task_stream(client) as ts:
                res = job(client)
            wall = time.perf_counter() - t
            stats = res.stats if hasattr(res, "trees") else res.attrs["scaleout"]
            out[name] = {"wall_s": wall, "worker_cpu_s": _worker_cpu(client) - cpu,
                         "client_cpu_s": time.process_time() - pc, "stats": stats,
                         "hash": forest_hash(res) if hasattr(res, "trees") else sweep_hash(res),
                         "units": len(res.trees) if hasattr(res, "trees") else len(res),
                         "stream": stream_split(ts.data)}
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="40 trees, 8 sweep points (< 30 s)")
    ap.add_argument("--trees", type=int, help="forest size (default 300; 40 with --quick)")
    ap.add_argument("--points", type=int, choices=(8, 16, 64), help="sweep points (default 64; 8 with --quick)")
    args = ap.parse_args(argv)
    n = args.trees or (40 if args.quick else 300)
    n_points = args.points or (8 if args.quick else 64)
    side = 9.0 * np.sqrt(n)
    common = {"size": (side, side), "min_dist": 7.0, "geometry": True, "rounds": 2 if args.quick else 4,
              "steps_per_round": 3 if args.quick else 5, "n_darts": 150 if args.quick else 300, "seed": 1}
    values = {8: (2, 4), 16: (4, 4), 64: (8, 8)}[n_points]
    grid = {"apical_dominance": list(np.round(np.linspace(0.3, 0.8, values[0]), 3)),
            "tropism_angle": list(np.round(np.linspace(0.0, 90.0, values[1]), 1))}
    jobs = {"forest (competing)": lambda c: grow_forest(n, client=c, **common)}
    if not args.quick:
        jobs["forest (independent)"] = lambda c: grow_forest(n, client=c, compete=False, **common)
    jobs["sweep"] = lambda c: sweep("fig12_1", grid, client=c)

    cap = cpu_capacity(1_000_000 if args.quick else 3_000_000)
    print(f"parallel capacity of this machine (2 processes / 1, pure-Python loop): {cap:.2f}x")
    runs = {w: run_on(w, jobs) for w in (1, 2)}
    for w, r in runs.items():
        warm = ", ".join(f"{v:.2f}" for v in r["warm"].values())
        print(f"{w} worker(s): cluster start {r['start_s']:.2f} s, warm-up per worker (imports + kernels) "
              f"{warm} s -- not in the throughput below")
    out = {"capacity": cap, "runs": runs, "rows": {}}
    for name in jobs:
        one, two = runs[1][name], runs[2][name]
        unit = "trees" if name.startswith("forest") else "points"
        speed = one["wall_s"] / two["wall_s"]
        same = one["hash"] == two["hash"]
        s1, s2 = one["stats"], two["stats"]
        out["rows"][name] = {"speedup": speed, "identical": same, "overhead_1": s1["overhead"],
                             "overhead_2": s2["overhead"]}
        print(f"{name}: {one['units']} {unit}, {s2['n_tasks']} tasks | 1 worker {one['wall_s']:6.2f} s "
              f"({one['units'] / one['wall_s']:6.1f} {unit}/s, worker CPU {one['worker_cpu_s']:.2f} s) (baseline) | "
              f"2 workers {two['wall_s']:6.2f} s ({two['units'] / two['wall_s']:6.1f} {unit}/s, worker CPU "
              f"{two['worker_cpu_s']:.2f} s) | speed-up {speed:4.2f}x (target >= 1.7x) | identical: {same} "
              f"({two['hash']})")
        print(f"    per-task overhead: 1 worker {1e3 * s1['overhead_per_task_s']:.1f} ms/task = "
              f"{100 * s1['overhead']:.1f} %, 2 workers {1e3 * s2['overhead_per_task_s']:.1f} ms/task of "
              f"{1e3 * s2['task_s']:.0f} ms = {100 * s2['overhead']:.1f} % (target < 5 %); client CPU "
              f"{two['client_cpu_s']:.2f} s")
        st = two["stream"]
        if st["compute"] > 0:
            print(f"    task stream, 2 workers: compute {st['compute']:.2f} worker-s; dispatch (scheduler + "
                  f"serialisation between a worker's tasks) {st['dispatch']:.3f} = "
                  f"{100 * st['dispatch'] / st['compute']:.2f} % of task time (target < 5 %); barrier (no worker "
                  f"computing) {st['barrier']:.2f}; imbalance at wave ends {st['imbalance']:.2f}")
            out["rows"][name]["dispatch_2"] = st["dispatch"] / st["compute"]
    return out


if __name__ == "__main__":
    main()

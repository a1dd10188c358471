"""Forest growth on dask.distributed vs serial (spec 004_treesketch §3.7, §6.2; issue 11 speed targets).

Grows the same seeded forest serially (``client="sync"``) and on a 2-worker LocalCluster of processes in the
same run, checks the results are byte-identical, and prints seconds per forest and the speed-up. Cluster start
is timed separately (it is paid once per session), and every worker loads the compiled kernels first. Geometry
(branch meshes) is built per tree in the same tasks. Target (issue 11): 300 trees <= 30 s on 2 cores (thesis
33.9 s on 4 threads). The machine's real parallel capacity is measured first (the same pure-Python loop in 1
and in 2 processes), because a speed-up above it is impossible.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from plantvr.landscape import grow_forest
from plantvr.landscape.forest import warm_up


def _same(f, g) -> bool:
    return len(f.trees) == len(g.trees) and all(
        a[k].tobytes() == b[k].tobytes() for a, b in zip(f.trees, g.trees) for k in a)


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


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="reduced size for CI (< 30 s)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    sizes = [6] if args.quick else [10, 30, 100, 300]
    kw = {"rounds": 2 if args.quick else 4, "steps_per_round": 3 if args.quick else 5, "n_darts": 150 if args.quick else 300,
              "seed": 1}
    from dask.distributed import Client, LocalCluster

    cap = cpu_capacity(1_000_000 if args.quick else 3_000_000)
    print(f"parallel capacity of this machine (2 processes / 1): {cap:.2f}x")

    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(cluster)
    client.run(warm_up)  # every worker loads the compiled kernels before timing
    warm_up()
    start = time.perf_counter() - t0
    print(f"LocalCluster({args.workers} processes) start + warm-up: {start:.2f} s")
    out = {"cluster_start_s": start, "capacity": cap, "rows": []}
    try:
        for n in sizes:
            side = 9.0 * np.sqrt(n)
            common = dict(size=(side, side), min_dist=7.0, geometry=True, **kw)
            t = time.perf_counter()
            f = grow_forest(n, client="sync", **common)
            ts = time.perf_counter() - t
            t = time.perf_counter()
            g = grow_forest(n, client=client, **common)
            td = time.perf_counter() - t
            same = _same(f, g) and all(a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()
                                       for a, b in zip(f.meshes, g.meshes))
            row = {"trees": len(f.trees), "internodes": f.n_internodes, "serial_s": ts, "dask_s": td, "speedup": ts / td,
                       "identical": same}
            out["rows"].append(row)
            print(f"{len(f.trees):4d} trees, {f.n_internodes:7d} internodes: serial {ts:7.2f} s (baseline) | "
                  f"dask {args.workers} procs {td:7.2f} s | speed-up {ts / td:4.2f}x | identical: {same}")
    finally:
        client.close()
        cluster.close()
    return out


if __name__ == "__main__":
    main()

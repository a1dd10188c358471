"""Forest growth on dask.distributed vs serial (spec 004_treesketch §3.7, §6.2; issue 11 speed targets).

Grows the same seeded forest serially (``client="sync"``) and on a 2-worker LocalCluster of processes in the
same run, checks the results are byte-identical, and prints seconds per forest and the speed-up. Cluster start
is timed separately (it is paid once per session). Target (issue 11): 300 trees <= 30 s on 2 cores (thesis
33.9 s on 4 threads); here geometry is not included.
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


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="reduced size for CI (< 30 s)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    sizes = [6] if args.quick else [10, 30, 100]
    kw = dict(rounds=2 if args.quick else 4, steps_per_round=3 if args.quick else 5, n_darts=150 if args.quick else 300,
              seed=1)
    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(cluster)
    client.run(warm_up)  # every worker loads the compiled kernels before timing
    warm_up()
    start = time.perf_counter() - t0
    print(f"LocalCluster({args.workers} processes) start + warm-up: {start:.2f} s")
    out = {"cluster_start_s": start, "rows": []}
    try:
        for n in sizes:
            side = 9.0 * np.sqrt(n)
            common = dict(size=(side, side), min_dist=7.0, **kw)
            t = time.perf_counter()
            f = grow_forest(n, client="sync", **common)
            ts = time.perf_counter() - t
            t = time.perf_counter()
            g = grow_forest(n, client=client, **common)
            td = time.perf_counter() - t
            same = _same(f, g)
            row = dict(trees=len(f.trees), internodes=f.n_internodes, serial_s=ts, dask_s=td, speedup=ts / td,
                       identical=same)
            out["rows"].append(row)
            print(f"{len(f.trees):4d} trees, {f.n_internodes:7d} internodes: serial {ts:7.2f} s (baseline) | "
                  f"dask {args.workers} workers {td:7.2f} s | speed-up {ts / td:4.2f}x | identical: {same}")
    finally:
        client.close()
        cluster.close()
    return out


if __name__ == "__main__":
    main()

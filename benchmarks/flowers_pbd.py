"""Benchmark: PBD growth of a sunflower-like head with collisions (spec 002 §3.5, §8.2).

Prints, per step, the solver / broad-phase / narrow-phase split for the numba path, beside the numpy
twins measured in the same run (internal solver on one floret, narrow phase on the same step).
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def _head(n_florets: int, detail: float):
    from plantvr.flowers import centripetal_fractionation, disc_receptacle, floret_stage, place_on_receptacle
    from plantvr.flowers.composer import Canopy, FloretType
    from plantvr.flowers.floret import Corolla, build_floret, petal_net
    bud = Corolla(petal_net(opening_deg=10, length=0.3, width=0.05), n_fold=5, fused_rows=4)
    opn = Corolla(petal_net(opening_deg=80, curl_deg=20, length=1.0, width=0.35), n_fold=5, fused_rows=4)
    fm = build_floret([bud, opn], n_frames=8, lam=0.2 / detail, eta=lambda v: 3 + 2 * detail * v)
    T = FloretType(fm.faces, fm.frames, fm.fixed)
    rec = disc_receptacle(1.0)
    s, a, birth = centripetal_fractionation(rec, area=np.pi / n_florets)
    pos, up, right = place_on_receptacle(rec, s, a)
    n = len(s)
    scale = 0.9 * np.sqrt(1.0 / n)
    can = Canopy([T], np.zeros(n, int), pos, up, right, np.full(n, scale))
    return can, birth, floret_stage


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small head, few steps (< 30 s)")
    ap.add_argument("--florets", type=int, nargs="*", default=None)
    ap.add_argument("--steps", type=int, default=None)
    args = ap.parse_args(argv)
    from plantvr.flowers import ccd, pbd
    from plantvr.flowers.composer import SolverParams, step
    sizes = args.florets or ([6] if args.quick else [60, 150, 300])
    steps = args.steps or (1 if args.quick else 10)
    params = SolverParams()
    results = {}
    for nf in sizes:
        can, birth, floret_stage = _head(nf, 1.0)
        S = np.array([floret_stage(t * 2.0 - birth, opening_duration=2.0 * steps) for t in range(steps + 1)])
        x = can.initial_positions(S[0])
        step(can, x, S[1], SolverParams(solver_iterations=1))          # JIT warm-up
        tot = {"solver": 0.0, "broad": 0.0, "narrow": 0.0, "constraints": 0}
        t0 = time.perf_counter()
        x_prev = x
        for t in range(1, steps + 1):
            x_prev = x
            x, st = step(can, x, S[t], params)
            for k in tot:
                tot[k] += st[k]
        wall = time.perf_counter() - t0
        inter = ccd.count_static_intersections(x, can.faces, edges=can.edges)
        # numpy twins on the same data, same run
        p = x_prev.copy()
        rl, rp, _ = can.targets(S[-1])
        T = can.types[0]
        ne, nq = len(T.edges), len(T.quads)
        t1 = time.perf_counter()
        pbd.solve_internal(p, can.w, can.edges[:ne], rl[:ne], can.quads[:nq], rp[:nq], iterations=1,
                           backend="numpy")
        np_iter_floret = time.perf_counter() - t1
        t1 = time.perf_counter()
        pbd.solve_internal(p, can.w, can.edges[:ne], rl[:ne], can.quads[:nq], rp[:nq], iterations=1)
        nb_iter_floret = time.perf_counter() - t1
        tn = {}
        ccd.detect_collisions_numpy(x_prev, x, can.faces, edges=can.edges, timings=tn)
        tb = {}
        ccd.detect_collisions(x_prev, x, can.faces, edges=can.edges, timings=tb)
        r = {"florets": can.n_instances, "triangles": len(can.faces), "steps": steps,
             "wall_per_step_s": wall / steps, "solver_per_step_s": tot["solver"] / steps,
             "broad_per_step_s": tot["broad"] / steps, "narrow_per_step_s": tot["narrow"] / steps,
             "collision_constraints": tot["constraints"], "static_intersections": inter,
             "solver_numpy_twin_est_per_step_s": np_iter_floret * params.solver_iterations * can.n_instances,
             "solver_iter_floret_numba_s": nb_iter_floret, "solver_iter_floret_numpy_s": np_iter_floret,
             "narrow_numba_s": tb["narrow"], "narrow_numpy_twin_s": tn["narrow"]}
        results[nf] = r
        print(f"florets={r['florets']:4d} tris={r['triangles']:7d}  step {r['wall_per_step_s']*1e3:8.1f} ms "
              f"(solver {r['solver_per_step_s']*1e3:7.1f}, broad {r['broad_per_step_s']*1e3:7.1f}, "
              f"narrow {r['narrow_per_step_s']*1e3:7.1f})  constraints={r['collision_constraints']} "
              f"intersections={inter}")
        print(f"   solver numba {r['solver_per_step_s']*1e3:8.1f} ms/step vs numpy twin "
              f"~{r['solver_numpy_twin_est_per_step_s']*1e3:9.1f} ms/step (1 floret x 1 iteration measured: "
              f"{nb_iter_floret*1e6:.0f} us vs {np_iter_floret*1e6:.0f} us)")
        print(f"   narrow phase numba {tb['narrow']*1e3:8.2f} ms vs numpy twin {tn['narrow']*1e3:8.2f} ms")
    return results


if __name__ == "__main__":
    main()

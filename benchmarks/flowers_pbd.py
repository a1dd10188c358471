"""Benchmark: a sunflower-like head grown through its whole animation with PBD + CCD (spec 002 §3.5, §8.2).

For each head size it prints the time per step split into solver, broad phase and narrow phase, the
collision passes and constraints, the static intersections after the last step (must be 0), and two
baselines measured in the same run on the same data: the numpy twin of the narrow phase (one full
detection pass on the busiest step) and the numpy twin of the internal solver (one floret, one iteration,
extrapolated). The issue's target: 34 rays, >= 100,000 triangles, whole animation <= 2 minutes on 2 cores.
"""
from __future__ import annotations

import argparse
import time


def _run(n_florets: int, detail: float, steps: int) -> dict:
    from plantvr.flowers import ccd, pbd
    from plantvr.flowers.composer import SolverParams, step
    from plantvr.flowers.models import sunflower_head
    t0 = time.perf_counter()
    head = sunflower_head(n_florets, detail=detail)
    can = head.canopy
    S = head.schedule(steps)
    build = time.perf_counter() - t0
    params = SolverParams()
    x = can.initial_positions(S[0])
    step(can, x, S[1], SolverParams(solver_iterations=1), prev_stages=S[0])      # JIT warm-up
    tot = {"solver": 0.0, "broad": 0.0, "narrow": 0.0, "constraints": 0, "passes": 0, "rolled_back": 0}
    busiest, most = None, -1
    t0 = time.perf_counter()
    for t in range(1, steps + 1):
        x_prev = x
        x, st = step(can, x, S[t], params, prev_stages=S[t - 1])
        for k in tot:
            tot[k] += st[k]
        if st["candidates"] > most:
            most, busiest = st["candidates"], (x_prev, t)
    wall = time.perf_counter() - t0
    inter = ccd.count_static_intersections(x, can.faces, edges=can.edges)
    # baselines on the busiest step: the kinematic prediction after the internal solve
    xb, tb_ = busiest
    pb, _ = step(can, xb, S[tb_], params, prev_stages=S[tb_ - 1], collisions=False)
    tn, tj = {}, {}
    cn = ccd.detect_collisions_numpy(xb, pb, can.faces, h=params.spacing, edges=can.edges, timings=tn)
    det = ccd.CollisionDetector(can.faces, len(xb), h=params.spacing, edges=can.edges)
    cj = det.detect(xb, pb, timings=tj)
    assert len(cn[0]) == len(cj[0])
    T = can.types[0]
    ne, nq = len(T.edges), len(T.quads)
    rl, rp, _ = can.targets(S[-1])
    p = x.copy()
    t1 = time.perf_counter()
    pbd.solve_internal(p, can.w, can.edges[:ne], rl[:ne], can.quads[:nq], rp[:nq], iterations=1, backend="numpy")
    np_floret_iter = time.perf_counter() - t1
    return {"florets": can.n_instances, "rays": head.n_rays, "triangles": len(can.faces), "steps": steps,
            "build_s": build, "total_s": wall, "per_step_s": wall / steps,
            "solver_per_step_s": tot["solver"] / steps, "broad_per_step_s": tot["broad"] / steps,
            "narrow_per_step_s": tot["narrow"] / steps, "passes": tot["passes"],
            "collision_constraints": tot["constraints"], "rolled_back": tot["rolled_back"],
            "static_intersections": inter,
            "pass_candidates": int(tj["candidates"]),
            "narrow_pass_numba_s": tj["narrow"], "narrow_pass_numpy_twin_s": tn["narrow"],
            "broad_pass_s": tj["broad"],
            "solver_numpy_twin_est_per_step_s": np_floret_iter * params.solver_iterations * can.n_instances}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small heads, few steps (< 30 s)")
    ap.add_argument("--florets", type=int, nargs="*", default=None)
    ap.add_argument("--detail", type=float, default=None)
    ap.add_argument("--steps", type=int, default=None)
    args = ap.parse_args(argv)
    sizes = args.florets or ([21, 60] if args.quick else [60, 150, 280])
    detail = args.detail or (1.0 if args.quick else 1.8)
    steps = args.steps or (6 if args.quick else 16)
    results = {}
    for nf in sizes:
        r = _run(nf, detail, steps)
        results[nf] = r
        print(f"florets={r['florets']:4d} rays={r['rays']:3d} tris={r['triangles']:7d} steps={steps}: whole animation "
              f"{r['total_s']:6.1f} s, per step {r['per_step_s'] * 1e3:7.1f} ms (solver "
              f"{r['solver_per_step_s'] * 1e3:6.1f}, broad {r['broad_per_step_s'] * 1e3:6.1f}, narrow "
              f"{r['narrow_per_step_s'] * 1e3:6.1f}); passes={r['passes']} constraints="
              f"{r['collision_constraints']} rolled_back={r['rolled_back']} "
              f"intersections={r['static_intersections']}")
        print(f"   one full CCD pass ({r['pass_candidates']} candidates): broad {r['broad_pass_s'] * 1e3:7.1f} ms, "
              f"narrow numba {r['narrow_pass_numba_s'] * 1e3:7.2f} ms vs numpy twin "
              f"{r['narrow_pass_numpy_twin_s'] * 1e3:8.2f} ms "
              f"({r['narrow_pass_numpy_twin_s'] / max(r['narrow_pass_numba_s'], 1e-9):.0f}x)")
        print(f"   solver numba {r['solver_per_step_s'] * 1e3:7.1f} ms/step vs numpy twin "
              f"~{r['solver_numpy_twin_est_per_step_s'] * 1e3:9.1f} ms/step (extrapolated from 1 floret x 1 iteration)")
    return results


if __name__ == "__main__":
    main()

"""Snapshots and command order under threads (issue 34): a Tree Wand model grows in the background while the main
thread (and a second command thread) set parameters, undo and redo, and a reader thread polls the published
snapshots. Counts the snapshots a reader saw go back in version or read inconsistent, and checks that replaying the
recorded log into a fresh model gives identical state bytes.

Baseline beside each figure: the same session without the command threads (growth and reader only).

Run: ``python benchmarks/document_threads.py [--quick] [--seconds S] [--runs N]``.
"""
from __future__ import annotations

import argparse
import threading
import time

import numpy as np

from plantvr.documents.treewand import Model

#: Parameters the command threads set (each a valid value range).
_PARAMS = {"apical_dominance": (0.2, 0.9), "tip_radius": (0.01, 0.05), "branch_angle": (20.0, 60.0)}


def _consistent(snap) -> bool:
    t = snap.tree
    n = len(t.pos)
    if not (len(t.parent) == len(t.radius) == len(t.order) == len(t.main_child) == n):
        return False
    if n and (t.parent[0] != -1 or np.any(t.parent[1:] >= np.arange(1, n)) or np.any(t.parent[1:] < 0)):
        return False
    buds = {len(v) for v in snap.buds.values()}
    return len(buds) <= 1 and snap.n_internodes == max(n - 1, 0)


def session(seed: int, seconds: float, *, commands: bool = True, n_markers: int = 3000,
            replay: bool = True) -> dict:
    """One threaded session; returns its counts (polls, backwards, inconsistent, commands, steps, replay)."""
    rng = np.random.default_rng(seed)
    m = Model(seed=seed, max_undo=50)
    m.add_markers(rng.uniform([-4, 1, -4], [4, 12, 4], (n_markers, 3)))
    stop = threading.Event()
    out = {"polls": 0, "backwards": 0, "inconsistent": 0, "commands": 0}

    def read() -> None:
        last = (-1, -1, -1)
        while not stop.is_set():
            s, latest, v = m.snapshot, m.latest, m.version      # in the order they are published, reversed
            out["polls"] += 1
            if s.version < last[0] or latest.version < last[1] or v < last[2]:
                out["backwards"] += 1
            if latest.version < s.version or not _consistent(s) or not _consistent(latest):
                out["inconsistent"] += 1
            last = (s.version, latest.version, v)

    def command(r: np.random.Generator) -> None:
        names = sorted(_PARAMS)
        while not stop.is_set():
            x = r.random()
            if x < 0.4:
                name = names[int(r.integers(len(names)))]
                m.set_params(**{name: float(r.uniform(*_PARAMS[name]))})
            elif x < 0.75:
                m.undo()
            else:
                m.redo()
            out["commands"] += 1
            time.sleep(float(r.uniform(0.0, 0.004)))

    reader = threading.Thread(target=read, daemon=True)
    other = threading.Thread(target=command, args=(np.random.default_rng([seed, 1]),), daemon=True)
    m.grow(1_000_000, background=True)
    reader.start()
    if commands:
        other.start()
    t_end = time.perf_counter() + seconds
    mine = np.random.default_rng([seed, 2])
    while time.perf_counter() < t_end:
        if commands:
            x = mine.random()
            if x < 0.3:
                m.set_params(apical_dominance=float(mine.uniform(0.2, 0.9)))
            elif x < 0.7:
                m.undo()
            else:
                m.redo()
            out["commands"] += 1
        time.sleep(float(mine.uniform(0.0, 0.01)))
    m.stop()
    stop.set()
    reader.join()
    if commands:
        other.join()
    m.flush()
    out["steps"] = sum(e.kwargs.get("steps", 0) for e in m.log if e.command in ("grow", "step"))
    if replay:
        fresh = Model(seed=seed, max_undo=50)
        fresh.replay(m.log)
        out["replay_identical"] = fresh.state_bytes() == m.state_bytes()
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 runs of 2 s")
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--runs", type=int, default=1)
    args = ap.parse_args(argv)
    seconds, runs = (2.0, 2) if args.quick else (args.seconds, args.runs)
    base = session(0, min(seconds, 2.0), commands=False, replay=False)
    print(f"baseline (growth + reader, no commands, {min(seconds, 2.0):.0f} s): {base['polls']} polls, "
          f"{base['backwards']} backwards, {base['inconsistent']} inconsistent")
    total = {"polls": 0, "backwards": 0, "inconsistent": 0, "commands": 0, "steps": 0, "replays_identical": 0}
    for seed in range(runs):
        r = session(seed, seconds)
        for k in ("polls", "backwards", "inconsistent", "commands", "steps"):
            total[k] += r[k]
        total["replays_identical"] += bool(r["replay_identical"])
        print(f"run {seed}: {seconds:.0f} s, {r['steps']} steps, {r['commands']} commands, {r['polls']} polls, "
              f"{r['backwards']} backwards, {r['inconsistent']} inconsistent, replay identical "
              f"{r['replay_identical']}")
    print(f"total over {runs} runs: {total['backwards']} backwards + {total['inconsistent']} inconsistent "
          f"snapshots in {total['polls']} polls; {total['replays_identical']}/{runs} replays identical")
    return {"baseline": base, **total, "runs": runs}


if __name__ == "__main__":
    main()

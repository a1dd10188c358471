"""Parameter sweeps over a replayed scenario, with growth metrics (spec 000_treewand §4.11, §6.1; DESIGN: scale-out
work is a set of independent tasks on a dask client, :mod:`plantvr.scaleout`).

Each grid point is one variant: a fresh model is re-seeded, the scenario's strokes are replayed with the grid
point's parameters over the scenario's own, and the variant returns its metrics and the lossless ``.npz`` state
(bytes), so thumbnails (:mod:`plantvr.view.thumbnails`) are rendered afterwards in the calling process from
exactly the grown trees. On a dask
client the points are batched into a few tasks per worker (:mod:`plantvr.scaleout`); a task's input is the
scenario's name (or the small scenario record), the points' parameter dicts and the seed, never a model.
Variants are deterministic: the same grid gives the same trees on any client (process workers for a speed-up:
the replay is Python-heavy and thread workers share the GIL) or serially.
"""
from __future__ import annotations

import dataclasses
import itertools
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import check_int
from ..params import PARAM_BY_NAME, validate
from ..scaleout import TaskStats, check_client, check_progress, chunks, connect, n_workers_of, run_tasks
from .scenarios import Scenario, load_scenario, replay_scenario
from .treewand import Model

__all__ = ["grow_variant", "sweep", "sweep_task", "tree_metrics", "warm_up_sweep"]

#: Most grid points one :func:`sweep` call may grow.
MAX_POINTS = 100_000


def _seed(seed) -> int | None:
    return None if seed is None else check_int("seed", seed, 0, 2**63 - 1)


def tree_metrics(model) -> dict[str, float]:
    """Growth metrics of a model's current tree.

    Returns
    -------
    dict
        ``internodes``, ``markers``, ``height`` (m), ``crown_width`` (m, mean of the x and z extents),
        ``crown_ratio`` (width / height), ``lateral_share`` (fraction of internodes of order >= 1),
        ``trunk_fraction`` (height reached by the order-0 axis / tree height) and ``ms_per_step`` (mean).
    """
    s = model.snapshot
    pos, order = np.asarray(s.pos), np.asarray(s.order)
    height = float(np.ptp(pos[:, 1])) if len(pos) else 0.0
    width = float(0.5 * (np.ptp(pos[:, 0]) + np.ptp(pos[:, 2]))) if len(pos) else 0.0
    n = max(len(pos) - 1, 1)
    trunk = pos[order == 0, 1]
    hist = model.step_stats
    return {"internodes": int(s.n_internodes), "markers": len(s.markers), "height": height,
            "crown_width": width, "crown_ratio": width / height if height > 0 else 0.0,
            "lateral_share": float(np.sum(order >= 1) / n),
            "trunk_fraction": float((trunk.max() - pos[:, 1].min()) / height) if height > 0 and len(trunk) else 0.0,
            "ms_per_step": float(np.mean([h.ms for h in hist])) if hist else 0.0}


def grow_variant(scenario: str | Scenario, params: dict[str, Any], *, seed: int | None = None) -> dict[str, Any]:
    """Replay ``scenario`` with ``params`` set over the scenario's parameters; one sweep task.

    Parameters
    ----------
    scenario : str or Scenario
        A shipped stroke file name (e.g. ``"fig12_1"``) or a loaded scenario.
    params : dict
        Parameters of this grid point (checked against the table).
    seed : int, optional
        Seed of the replay (default: the scenario's).

    Returns
    -------
    dict
        The grid point's ``params``, :func:`tree_metrics`, ``seconds`` (wall time) and ``state`` (the
        model's ``.npz`` bytes, for :func:`plantvr.view.thumbnails.thumbnail`).
    """
    seed = _seed(seed)
    if not isinstance(params, dict):
        raise ValueError(f"params must be a dict of parameter -> value, got {type(params).__name__}")
    sc = load_scenario(scenario) if isinstance(scenario, str) else scenario
    checked = validate(params)
    sc = dataclasses.replace(sc, params={**sc.params, **checked}, seed=sc.seed if seed is None else seed)
    t0 = time.perf_counter()
    model = Model(seed=sc.seed)
    replay_scenario(model, sc)
    model.wait()  # apply the latest snapshot here (a dask worker thread has no kernel loop to do it)
    out = {**checked, **tree_metrics(model), "seconds": time.perf_counter() - t0}
    with tempfile.TemporaryDirectory() as d:
        out["state"] = Path(model.save(Path(d) / "tree.npz")).read_bytes()
    return out


def sweep_task(scenario: str | Scenario, points: list[dict[str, Any]], seed: int | None) -> list[dict[str, Any]]:
    """A batch of :func:`grow_variant` calls in one task (the scenario loaded once)."""
    sc = load_scenario(scenario) if isinstance(scenario, str) else scenario
    return [grow_variant(sc, p, seed=seed) for p in points]


def warm_up_sweep() -> float:
    """Replay a small scenario once so this process has imported the model and loaded its compiled kernels;
    seconds. Run it on every worker (``client.run(warm_up_sweep)``) before timing a sweep."""
    t = time.perf_counter()
    grow_variant("fig12_1", {})
    return time.perf_counter() - t


def sweep(scenario: str | Scenario, grid: dict[str, list], *, client=None, seed: int | None = None,
          progress: bool = False, tasks: int | None = None):
    """Grow ``scenario`` at every point of the product of ``grid``'s value lists.

    Parameters
    ----------
    scenario : str or Scenario
    grid : dict of str -> list
        Parameter name -> values, e.g. ``{"apical_dominance": [0.4, 0.6], "tropism_angle": [0, 90]}``;
        every value is checked against the parameter table before any task starts.
    client : None, "sync", a scheduler address or a dask.distributed.Client
        Where the variants grow: serially in this thread for None or ``"sync"``; on the client (or on a client
        connected for this call to an address ``"tcp://host:port"``) in a few batches per worker.
    seed : int, optional
        Replay seed (default: the scenario's).
    progress : bool
        Show tasks completing: dask's progress bar in a notebook, tqdm in scripts.
    tasks : int, optional
        Number of batches on a client (default: 4 per worker); the table does not depend on it.

    Returns
    -------
    pandas.DataFrame
        One row per grid point in product order (last name varies fastest): its parameters, metrics,
        ``seconds`` and ``state``; ``table.attrs["scaleout"]`` holds the task timing
        (:class:`plantvr.scaleout.TaskStats` as a dict: time in tasks, wall, per-task overhead).
    """
    import pandas as pd
    seed = _seed(seed)
    client = check_client(client)
    progress = check_progress(progress)
    if tasks is not None:
        tasks = check_int("tasks", tasks, 1, MAX_POINTS)
    if not isinstance(grid, dict) or not grid:
        raise ValueError(f"grid must be a non-empty dict of parameter -> list of values, got {grid!r:.80}")
    for name, values in grid.items():
        if name not in PARAM_BY_NAME:
            raise ValueError(f"grid parameter must be one of the parameter table's names, got {name!r}")
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__") or len(list(values)) == 0:
            raise ValueError(f"grid[{name!r}] must be a non-empty list of values, got {values!r:.80}")
    n_points = int(np.prod([len(list(v)) for v in grid.values()], dtype=object))
    if n_points > MAX_POINTS:
        raise ValueError(f"grid must have at most {MAX_POINTS} points, got {n_points}")
    points = [dict(zip(grid, combo)) for combo in itertools.product(*(list(v) for v in grid.values()))]
    for p in points:
        validate(p)
    sc = load_scenario(scenario) if isinstance(scenario, str) else scenario
    ref = scenario if isinstance(scenario, str) else sc  # a shipped scenario travels by name
    with connect("sync" if client is None else client) as runner:
        stats = TaskStats(n_workers_of(runner))
        if runner == "sync":
            parts = [[i] for i in range(len(points))]
        else:   # every k-th point in a task: neighbouring points cost alike, so strides balance the workers
            k = len(chunks(len(points), stats.n_workers, per_worker=8, tasks=tasks))
            parts = [list(range(i, len(points), k)) for i in range(k)]
        got = run_tasks(runner, sweep_task, [(ref, [points[i] for i in c], seed) for c in parts], stats=stats,
                        progress=progress, desc="sweep")
    rows: list = [None] * len(points)
    for part, c in zip(got, parts):
        for i, row in zip(c, part):
            rows[i] = row
    table = pd.DataFrame(rows)
    table.attrs["scaleout"] = stats.as_dict()
    return table

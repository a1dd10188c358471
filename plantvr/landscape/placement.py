"""Tree placement by Poisson-disc sampling (Bridson 2007) on a rectangle (spec 004_treesketch §3.4, [EXT])."""
from __future__ import annotations

import math

import numpy as np

from .._validation import check_int, check_range
from .terrain import MAX_CELLS, pair

__all__ = ["poisson_disc"]


def poisson_disc(size: tuple[float, float], min_dist: float, *, max_points: int | None = None, k: int = 30,
                 rng: int | np.random.Generator | None = None) -> np.ndarray:
    """Return (N, 2) points in [0, size[0]) x [0, size[1]) with pairwise distance >= ``min_dist``.

    Bridson's algorithm: active list, ``k`` candidates per point in the annulus [r, 2r), background grid of
    cell r/sqrt(2). Stops at ``max_points`` when given. Deterministic for a seed.
    """
    w, h = pair("size", size)
    r = check_range("min_dist", min_dist, 0.0, np.inf, low_open=True)
    if math.ceil(w * math.sqrt(2.0) / r) * math.ceil(h * math.sqrt(2.0) / r) > MAX_CELLS:
        raise ValueError(f"min_dist must be at least {math.sqrt(2.0 * w * h / MAX_CELLS):.3g} for a {w} x {h} plot "
                         f"(the background grid may hold {MAX_CELLS} cells), got {min_dist!r}")
    k = check_int("k", k, 1, 1000)
    cap = None if max_points is None else check_int("max_points", max_points, 0, 10_000_000)
    rng = np.random.default_rng(rng)
    cell = r / math.sqrt(2.0)
    gw, gh = math.ceil(w / cell), math.ceil(h / cell)
    grid = -np.ones((gh, gw), np.int64)
    pts: list[tuple[float, float]] = []
    if cap == 0:
        return np.zeros((0, 2))

    def add(p):
        grid[min(int(p[1] / cell), gh - 1), min(int(p[0] / cell), gw - 1)] = len(pts)
        pts.append(p)

    def ok(p):
        if not (0 <= p[0] < w and 0 <= p[1] < h):
            return False
        gx, gy = int(p[0] / cell), int(p[1] / cell)
        for j in range(max(gy - 2, 0), min(gy + 3, gh)):
            for i in range(max(gx - 2, 0), min(gx + 3, gw)):
                q = grid[j, i]
                if q >= 0 and (pts[q][0] - p[0]) ** 2 + (pts[q][1] - p[1]) ** 2 < r * r:
                    return False
        return True

    add((rng.uniform(0, w), rng.uniform(0, h)))
    active = [0]
    while active and (cap is None or len(pts) < cap):
        a = active[int(rng.integers(len(active)))]
        base = pts[a]
        ang = rng.uniform(0, 2 * math.pi, k)
        rad = r * np.sqrt(rng.uniform(1.0, 4.0, k))
        for c in zip(base[0] + rad * np.cos(ang), base[1] + rad * np.sin(ang)):
            if ok(c):
                active.append(len(pts))
                add((float(c[0]), float(c[1])))
                break
        else:
            active.remove(a)
    return np.array(pts, float).reshape(-1, 2)

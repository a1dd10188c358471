"""Markers painted by the wand: Poisson darts in the brush sphere (spec 000_treewand §2.2, §4.3)."""
from __future__ import annotations

import numpy as np

__all__ = ["uniform_in_ball", "poisson_darts"]


def uniform_in_ball(n: int, rng: np.random.Generator) -> np.ndarray:
    """Return ``n`` points uniformly distributed in the unit ball."""
    v = rng.normal(size=(n, 3))
    v /= np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    return v * rng.random((n, 1)) ** (1.0 / 3.0)


def poisson_darts(center: np.ndarray, radius: float, n_darts: int, existing: np.ndarray, rejection: float,
                  rng: np.random.Generator) -> np.ndarray:
    """Throw ``n_darts`` candidates in the sphere; keep those farther than ``rejection`` from every marker.

    Only the existing markers within ``radius + rejection`` of ``center`` are compared, so the cost grows
    with the brush, not with all markers (§2.2: rejection radius = occupation radius).
    """
    cand = center + radius * uniform_in_ball(n_darts, rng)
    near = existing[np.sum((existing - center) ** 2, axis=1) <= (radius + rejection) ** 2] if len(existing) else existing
    kept = []
    r2 = rejection * rejection
    pool = near
    for c in cand:
        if len(pool) and np.min(np.sum((pool - c) ** 2, axis=1)) < r2:
            continue
        kept.append(c)
        pool = np.vstack([pool, c[None]]) if len(pool) else c[None].copy()
    return np.array(kept).reshape(-1, 3)

"""Internode lengths: constant, branch order (Eq. 9.16) and vigor (Eq. 9.17) (spec 000_treewand §2.9)."""
from __future__ import annotations

import numpy as np

__all__ = ["internode_lengths"]


def internode_lengths(mode: str, *, base: float, mult: float, order: np.ndarray | None = None,
                      vigor: np.ndarray | None = None, vmax: float | None = None) -> np.ndarray:
    """Length of the internode each bud would produce.

    ``constant``: l = l_b. ``order`` (Eq. 9.16): l = l_b + (α−1) l_b / 2^k. ``vigor`` (Eq. 9.17):
    l = (1 − v/v_max) l_b + (v/v_max) α l_b, with v_max the largest bud vigor on the tree.
    """
    if mode == "constant":
        n = len(order) if order is not None else len(vigor)
        return np.full(n, base)
    if mode == "order":
        return base + (mult - 1.0) * base / 2.0 ** np.asarray(order, float)
    if mode == "vigor":
        v = np.asarray(vigor, float)
        frac = v / vmax if vmax and vmax > 0 else np.zeros_like(v)
        return (1.0 - frac) * base + frac * mult * base
    raise ValueError(f"length_mode must be one of ['vigor', 'order', 'constant'], got {mode!r}")

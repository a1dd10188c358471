"""Internode lengths: constant, branch order (Eq. 9.16) and vigor (Eq. 9.17) (spec 000_treewand §2.9)."""
from __future__ import annotations

import numpy as np

from plantvr._validation import check_choice, check_range

__all__ = ["internode_lengths"]


def internode_lengths(mode: str, *, base: float, mult: float, order: np.ndarray | None = None,
                      vigor: np.ndarray | None = None, vmax: float | None = None) -> np.ndarray:
    """Length of the internode each bud would produce.

    ``constant``: l = l_b. ``order`` (Eq. 9.16): l = l_b + (α−1) l_b / 2^k. ``vigor`` (Eq. 9.17):
    l = (1 − v/v_max) l_b + (v/v_max) α l_b, with v_max the largest bud vigor on the tree.
    ``base`` in (0, inf), ``mult`` in [1, inf).
    """
    check_choice("length_mode", mode, ("vigor", "order", "constant"))
    base = check_range("base", base, 0.0, np.inf, low_open=True, high_open=True)
    mult = check_range("mult", mult, 1.0, np.inf, high_open=True)
    if mode == "constant" and order is None and vigor is None:
        raise ValueError("internode_lengths needs order or vigor (their length is the bud count)")
    if mode == "order" and order is None:
        raise ValueError("order (bud branch orders) is required in mode 'order'")
    if mode == "vigor":
        if vigor is None:
            raise ValueError("vigor (bud vigors) is required in mode 'vigor'")
        if vmax is not None:
            vmax = check_range("vmax", vmax, -np.inf, np.inf)
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

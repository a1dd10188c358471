"""One stable counting sort shared by the uniform grids of the growth and ViNE cores (numba, O(n + k))."""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["counting_sort"]


@numba.njit(cache=True, nogil=True)
def counting_sort(keys, nkeys, index_dtype):  # pragma: no cover - numba kernel, twin: np.argsort(kind="stable")
    """Stable counting sort of integer ``keys`` in ``[0, nkeys)``.

    Returns ``(order, start)`` of dtype ``index_dtype``: ``order`` equals ``np.argsort(keys, kind="stable")`` and
    the items with key ``k`` are ``order[start[k]:start[k + 1]]`` (``start`` has ``nkeys + 1`` entries).
    ``index_dtype`` is ``np.int32`` where memory matters (18 M mesh vertices) and ``np.int64`` otherwise.
    """
    start = np.zeros(nkeys + 1, index_dtype)
    for i in range(keys.shape[0]):
        start[keys[i] + 1] += 1
    for k in range(nkeys):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    order = np.empty(keys.shape[0], index_dtype)
    for i in range(keys.shape[0]):
        k = keys[i]
        order[fill[k]] = i
        fill[k] += 1
    return order, start

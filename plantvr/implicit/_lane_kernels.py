"""Lane's distribution method on a 3D step pdf: numba kernels and numpy twins (spec 003_implicit_sca §3.4, C-10).

State: pdf ``G[nx, ny, nz] >= 0`` over cells of the box, row sums ``Y[i, j] = sum_k G`` and slab sums
``Z[i] = sum_j Y``. A draw picks a slab, a row and a cell by the marginal and the conditionals (inverse CDF, thesis
§5.2.2) and a uniform position inside the cell; the kernel then multiplies the pdf around the new point and only the
touched rows and slabs are re-summed. Kernels take pre-drawn uniforms so both twins consume the same stream.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["lane_run_numba", "lane_run_numpy", "recompute_sums", "set_cell", "apply_kernel_numba", "PDF_CAP"]

#: Kernel products are clamped here, so repeated boosts (cluster kernels) never overflow to inf, whose
#: product with a zero kernel value would be NaN and make the cell picks fail (issue 20).
PDF_CAP = 1e300


@numba.njit(cache=True, nogil=True)
def _pick(arr, target):  # pragma: no cover - covered through the numpy twin
    acc = 0.0
    last = -1
    for i in range(arr.shape[0]):
        if arr[i] > 0.0:
            last = i
            acc += arr[i]
            if acc > target:
                return i
    return last


@numba.njit(cache=True, nogil=True)
def _kernel_value(d, kr, kv, linear):  # pragma: no cover
    m = kr.shape[0]
    if linear:
        if d <= kr[0]:
            return kv[0]
        for q in range(1, m):
            if d < kr[q]:
                w = (d - kr[q - 1]) / (kr[q] - kr[q - 1])
                return kv[q - 1] * (1.0 - w) + kv[q] * w
        return 1.0
    for q in range(m):
        if d < kr[q]:
            return kv[q]
    return 1.0


@numba.njit(cache=True, nogil=True)
def apply_kernel_numba(G, Y, Z, lo, h, x, kr, kv, linear):  # pragma: no cover
    nx, ny, nz = G.shape
    sup = kr[kr.shape[0] - 1]
    i0 = max(0, int(np.floor((x[0] - sup - lo[0]) / h[0] - 0.5)))
    i1 = min(nx - 1, int(np.ceil((x[0] + sup - lo[0]) / h[0] - 0.5)))
    j0 = max(0, int(np.floor((x[1] - sup - lo[1]) / h[1] - 0.5)))
    j1 = min(ny - 1, int(np.ceil((x[1] + sup - lo[1]) / h[1] - 0.5)))
    k0 = max(0, int(np.floor((x[2] - sup - lo[2]) / h[2] - 0.5)))
    k1 = min(nz - 1, int(np.ceil((x[2] + sup - lo[2]) / h[2] - 0.5)))
    for i in range(i0, i1 + 1):
        dx = lo[0] + (i + 0.5) * h[0] - x[0]
        for j in range(j0, j1 + 1):
            dy = lo[1] + (j + 0.5) * h[1] - x[1]
            for k in range(k0, k1 + 1):
                dz = lo[2] + (k + 0.5) * h[2] - x[2]
                d = np.sqrt(dx * dx + dy * dy + dz * dz)
                if d < sup:
                    g = G[i, j, k] * _kernel_value(d, kr, kv, linear)
                    G[i, j, k] = g if g < PDF_CAP else PDF_CAP
            s = 0.0
            for k in range(nz):
                s += G[i, j, k]
            Y[i, j] = s
        s = 0.0
        for j in range(ny):
            s += Y[i, j]
        Z[i] = s


@numba.njit(cache=True, nogil=True)
def lane_run_numba(G, Y, Z, lo, h, kr, kv, linear, U, n_target, out, n_have):  # pragma: no cover
    """Draw until ``n_target`` points, the uniforms ``U (M, 6)`` run out, or the pdf is all zero.

    Returns ``(n_have, used, saturated)``.
    """
    used = 0
    x = np.empty(3)
    while n_have < n_target and used < U.shape[0]:
        total = 0.0
        for i in range(Z.shape[0]):
            total += Z[i]
        if total <= 0.0:
            return n_have, used, True
        u = U[used]
        used += 1
        i = _pick(Z, u[0] * total)
        if i < 0:                          # no positive slab (cannot happen with a finite pdf): stop
            return n_have, used, True
        j = _pick(Y[i], u[1] * Z[i])
        if j < 0:
            return n_have, used, True
        k = _pick(G[i, j], u[2] * Y[i, j])
        if k < 0:
            return n_have, used, True
        x[0] = lo[0] + (i + u[3]) * h[0]
        x[1] = lo[1] + (j + u[4]) * h[1]
        x[2] = lo[2] + (k + u[5]) * h[2]
        out[n_have, 0] = x[0]
        out[n_have, 1] = x[1]
        out[n_have, 2] = x[2]
        n_have += 1
        apply_kernel_numba(G, Y, Z, lo, h, x, kr, kv, linear)
    total = 0.0
    for i in range(Z.shape[0]):
        total += Z[i]
    return n_have, used, total <= 0.0


# ------------------------------------------------------------------------------------------ numpy twins
def _pick_numpy(arr, target):
    pos = np.flatnonzero(arr > 0)
    c = np.cumsum(arr[pos])
    idx = np.searchsorted(c, target, side="right")
    return int(pos[min(idx, len(pos) - 1)])


def _kernel_value_numpy(d, kr, kv, linear):
    if linear:
        return np.where(d < kr[-1], np.interp(d, kr, kv), 1.0)
    idx = np.searchsorted(kr, d, side="right")
    return np.where(idx < len(kr), kv[np.minimum(idx, len(kv) - 1)], 1.0)


def apply_kernel_numpy(G, Y, Z, lo, h, x, kr, kv, linear):
    """numpy twin of :func:`apply_kernel_numba`."""
    sup = kr[-1]
    lo_idx = np.maximum(0, np.floor((x - sup - lo) / h - 0.5).astype(int))
    hi_idx = np.minimum(np.array(G.shape) - 1, np.ceil((x + sup - lo) / h - 0.5).astype(int))
    sl = tuple(slice(a, b + 1) for a, b in zip(lo_idx, hi_idx))
    if any(s.start >= s.stop for s in sl):
        return
    axes = [lo[a] + (np.arange(sl[a].start, sl[a].stop) + 0.5) * h[a] - x[a] for a in range(3)]
    dx, dy, dz = np.meshgrid(*axes, indexing="ij")
    d = np.sqrt(dx * dx + dy * dy + dz * dz)
    G[sl] = np.minimum(G[sl] * np.where(d < sup, _kernel_value_numpy(d, kr, kv, linear), 1.0), PDF_CAP)
    Y[sl[0], sl[1]] = G[sl[0], sl[1], :].sum(axis=2)
    Z[sl[0]] = Y[sl[0], :].sum(axis=1)


def lane_run_numpy(G, Y, Z, lo, h, kr, kv, linear, U, n_target, out, n_have):
    """Readable numpy twin of :func:`lane_run_numba` (same uniforms, same points)."""
    used = 0
    while n_have < n_target and used < U.shape[0]:
        total = Z.sum()
        if total <= 0.0:
            return n_have, used, True
        u = U[used]
        used += 1
        i = _pick_numpy(Z, u[0] * total)
        j = _pick_numpy(Y[i], u[1] * Z[i])
        k = _pick_numpy(G[i, j], u[2] * Y[i, j])
        x = lo + (np.array([i, j, k]) + u[3:6]) * h
        out[n_have] = x
        n_have += 1
        apply_kernel_numpy(G, Y, Z, lo, h, x, kr, kv, linear)
    return n_have, used, bool(Z.sum() <= 0.0)


def recompute_sums(G):
    """Row sums Y and slab sums Z of a pdf grid."""
    Y = G.sum(axis=2)
    return Y, Y.sum(axis=1)


def set_cell(G, Y, Z, i, j, k, value):
    """Set one cell and refresh its row and slab sums."""
    G[i, j, k] = value
    Y[i, j] = G[i, j, :].sum()
    Z[i] = Y[i, :].sum()

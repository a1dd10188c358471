"""Distance-based shadow pyramids on a two-tier hashed sparse grid (spec 000_treewand §2.6–§2.7, Alg. 9.1).

Cells are ``l_b × 3 l_b × l_b`` (§2.6), their coordinates those of plantvr.grid (:func:`plantvr.grid.cell_coords`,
one cell size per axis). Fine grids of ``F³`` cells are created lazily under a coarse hash
keyed by the corrected Szudzik pairing (Eqs. 9.11–9.14, ERRATUM A.7) of zig-zag mapped coarse indices.

Bounds (issue 20): the nested pairing is quartic in the coarse index, so coarse indices are kept within
±:data:`COARSE_LIMIT`, where the key is exact in int64; fine-cell indices are clipped to the grid's ``limit``
(points farther out share the border cells; NaN maps to cell 0), so no float → int conversion overflows and
no kernel indexes outside its block table. A grid allocates at most ``max_cells`` fine cells
(:data:`MAX_CELLS`); an :meth:`ShadowGrid.add` that would need more raises :class:`ShadowGridFull` and leaves
the grid unchanged (the engine then rebuilds with a coarser cell).
"""
from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.typed import Dict

from plantvr import grid
from plantvr._validation import check_array, check_int, check_range

__all__ = ["szudzik", "zigzag", "coarse_key", "shadow_lut", "ShadowGrid", "ShadowGridFull", "cells_of_numpy",
           "COARSE_LIMIT", "MAX_OFFSET", "MAX_CELLS", "FINE_RANGE"]

#: Largest |coarse index|: zig-zag ≤ 2^15, inner S < 2^31, outer S < 2^62, so Eq. 9.14 never overflows int64.
COARSE_LIMIT = 2 ** 14
#: Largest |offset| per axis of a pyramid (shadow_depth ≤ 32 needs 32).
MAX_OFFSET = 64
#: Most fine cells one grid allocates (2^25 float64 cells = 256 MB); far above any grown tree's need.
MAX_CELLS = 2 ** 25
#: Fine cells per coarse-cell edge a grid accepts (the ``fine_cells`` parameter's range).
FINE_RANGE = (2, 64)


class ShadowGridFull(ValueError):
    """Raised by :meth:`ShadowGrid.add` when the pyramids would need more than ``max_cells`` fine cells."""


@numba.njit(cache=True, nogil=True)
def zigzag(a):
    """Eq. 9.13: map an integer to a natural number (0, -1, 1, -2, 2 → 0, 1, 2, 3, 4)."""
    return 2 * a if a >= 0 else -2 * a - 1


@numba.njit(cache=True, nogil=True)
def szudzik(a, b):
    """Eq. 9.12 with ERRATUM A.7: ``a² + a + b`` if ``a >= b`` else ``a + b²`` (the printed a·a + a·b + b collides)."""
    return a * a + a + b if a >= b else a + b * b


@numba.njit(cache=True, nogil=True)
def coarse_key(i, j, k):
    """Eq. 9.14: H(i, j, k) = S(S(N(i), N(j)), N(k))."""
    return szudzik(szudzik(zigzag(i), zigzag(j)), zigzag(k))


def shadow_lut(alpha: float, beta: float, q_max: int, inclusive: bool = False):
    """Return the pyramid as (offsets (K, 3) int64, values (K,) float64), Eq. 9.10.

    Level q (1 .. q_max-1 as printed in Alg. 9.1, or .. q_max if ``inclusive``) covers offsets
    ``(i, -q, j)`` with |i|, |j| <= q and value ``alpha * beta ** sqrt(q² + i² + j²)`` (ERRATUM A.5).
    The node's own cell (q = 0) is never shadowed. ``alpha`` in [0, inf), ``beta`` in [0, 1], ``q_max`` in
    [0, MAX_OFFSET − 1].
    """
    alpha = check_range("alpha", alpha, 0.0, np.inf, high_open=True)
    beta = check_range("beta", beta, 0.0, 1.0)
    q_max = check_int("q_max", q_max, 0, MAX_OFFSET - 1)
    if not isinstance(inclusive, (bool, np.bool_, int, np.integer)) or inclusive not in (0, 1):
        raise ValueError(f"inclusive must be True or False, got {inclusive!r}")
    offs, vals = [], []
    for q in range(1, q_max + (1 if inclusive else 0)):
        r = np.arange(-q, q + 1)
        i, j = np.meshgrid(r, r, indexing="ij")
        offs.append(np.stack([i.ravel(), np.full(i.size, -q), j.ravel()], 1))
        vals.append(alpha * beta ** np.sqrt(q * q + i.ravel() ** 2 + j.ravel() ** 2))
    if not offs:
        return np.zeros((0, 3), np.int64), np.zeros(0)
    return np.concatenate(offs).astype(np.int64), np.concatenate(vals)


@numba.njit(cache=True, nogil=True)
def _new_keys():
    """An empty block table (made in a cached kernel: typed-Dict methods called from Python compile anew in every
    process and are never cached)."""
    return Dict.empty(key_type=types.int64, value_type=types.int64)


@numba.njit(cache=True, nogil=True)
def _clear_keys(keys) -> None:
    keys.clear()


@numba.njit(cache=True, nogil=True)
def keys_to_array(keys) -> np.ndarray:
    """The block table as (K, 2) int64 ``[coarse key, block]`` rows, in the table's order."""
    out = np.empty((len(keys), 2), np.int64)
    n = 0
    for k, v in keys.items():
        out[n, 0] = k
        out[n, 1] = v
        n += 1
    return out


@numba.njit(cache=True, nogil=True)
def keys_from_array(keys, kv) -> None:
    """Insert the (K, 2) rows of :func:`keys_to_array` into ``keys``, in order."""
    for i in range(kv.shape[0]):
        keys[kv[i, 0]] = kv[i, 1]


@numba.njit(cache=True, nogil=True)
def _ensure_blocks(keys, centres, lo, hi, F, nblocks, max_blocks):
    """Create the fine blocks overlapped by the box [centre + lo, centre + hi] of each centre (lazily, §2.7).

    Stops as soon as the count would pass ``max_blocks`` and returns ``max_blocks + 1`` (the caller rolls back).
    """
    for c in range(centres.shape[0]):
        for i in range((centres[c, 0] + lo[0]) // F, (centres[c, 0] + hi[0]) // F + 1):
            for j in range((centres[c, 1] + lo[1]) // F, (centres[c, 1] + hi[1]) // F + 1):
                for k in range((centres[c, 2] + lo[2]) // F, (centres[c, 2] + hi[2]) // F + 1):
                    key = coarse_key(i, j, k)
                    if key not in keys:
                        if nblocks >= max_blocks:
                            return max_blocks + 1
                        keys[key] = nblocks
                        nblocks += 1
    return nblocks


@numba.njit(cache=True, nogil=True)
def _drop_blocks(keys, first):
    """Remove every key whose block id is ``>= first`` (roll back a refused :func:`_ensure_blocks`)."""
    gone = np.empty(len(keys), np.int64)
    n = 0
    for k, v in keys.items():
        if v >= first:
            gone[n] = k
            n += 1
    for t in range(n):
        keys.pop(gone[t])


# fine-cell coordinates: plantvr.grid's per-axis cell coordinates (twin: cells_of_numpy)
_cells_of = grid.cell_coords
cells_of_numpy = grid.cell_coords_numpy


@numba.njit(cache=True, nogil=True)
def _log2(F):
    """log2(F) when F is a power of two, else -1."""
    if F <= 0 or F & (F - 1):
        return -1
    s = 0
    while (1 << s) < F:
        s += 1
    return s


@numba.njit(cache=True, nogil=True)
def _splat(keys, blocks, F, centres, offsets, values, sign):
    # the block ids a pyramid touches are looked up once per node, not once per cell
    lo0, lo1, lo2 = offsets[:, 0].min(), offsets[:, 1].min(), offsets[:, 2].min()
    hi0, hi1, hi2 = offsets[:, 0].max(), offsets[:, 1].max(), offsets[:, 2].max()
    span = max(hi0 - lo0, hi1 - lo1, hi2 - lo2) // F + 2
    ids = np.empty((span, span, span), np.int64)
    shift = _log2(F)
    mask = F - 1
    for n in range(centres.shape[0]):
        c0, c1, c2 = centres[n, 0], centres[n, 1], centres[n, 2]
        b0, b1, b2 = (c0 + lo0) // F, (c1 + lo1) // F, (c2 + lo2) // F
        for i in range((c0 + hi0) // F - b0 + 1):
            for j in range((c1 + hi1) // F - b1 + 1):
                for k in range((c2 + hi2) // F - b2 + 1):
                    ids[i, j, k] = keys[coarse_key(b0 + i, b1 + j, b2 + k)]
        if shift >= 0:  # F a power of two: arithmetic shift and mask are floor-div and floor-mod, same cells
            for o in range(offsets.shape[0]):
                x = c0 + offsets[o, 0]
                y = c1 + offsets[o, 1]
                z = c2 + offsets[o, 2]
                b = ids[(x >> shift) - b0, (y >> shift) - b1, (z >> shift) - b2]
                blocks[b, x & mask, y & mask, z & mask] += sign * values[o]
            continue
        for o in range(offsets.shape[0]):
            x = c0 + offsets[o, 0]
            y = c1 + offsets[o, 1]
            z = c2 + offsets[o, 2]
            b = ids[x // F - b0, y // F - b1, z // F - b2]
            blocks[b, x % F, y % F, z % F] += sign * values[o]  # floor-mod: negative coords work (§2.7)


@numba.njit(cache=True, nogil=True)
def _read(keys, blocks, F, cells, out):
    shift = _log2(F)
    mask = F - 1
    for c in range(cells.shape[0]):
        x, y, z = cells[c, 0], cells[c, 1], cells[c, 2]
        if shift >= 0:
            key = coarse_key(x >> shift, y >> shift, z >> shift)
            x, y, z = x & mask, y & mask, z & mask
        else:
            key = coarse_key(x // F, y // F, z // F)
            x, y, z = x % F, y % F, z % F
        if key in keys:
            out[c] = blocks[keys[key], x, y, z]
        else:
            out[c] = 0.0


def _check_cells(name: str, value, limit: int, rows: int | None = None) -> np.ndarray:
    """``value`` as a C-contiguous (N, 3) int64 array of integers within ±limit, or ``ValueError`` naming it."""
    kind = getattr(value, "dtype", None)
    if kind is not None and kind.kind in "iu":
        return check_array(name, value, shape=(rows, 3), dtype=np.int64, max_abs=limit)
    arr = check_array(name, value, shape=(rows, 3), dtype=np.float64, max_abs=limit)
    if not np.array_equal(arr, np.floor(arr)):
        raise ValueError(f"{name} must hold integer cell indices, got non-integer values")
    return arr.astype(np.int64)


class ShadowGrid:
    """Sparse accumulated-shadow grid: a coarse hash → pooled ``F³`` fine blocks (§2.7).

    Parameters
    ----------
    cell : float
        d, the cell size in metres (cells are d × 3d × d, §2.6), in (0, inf).
    fine : int
        F, fine cells per coarse-cell edge, in :data:`FINE_RANGE`.
    max_cells : int
        Most fine cells the grid allocates (default :data:`MAX_CELLS`), at least one block (F³).

    Fine-cell indices live within ±``limit`` = (COARSE_LIMIT − 2)·F − MAX_OFFSET (:meth:`cells_of` clips to it).
    """

    def __init__(self, cell: float, fine: int = 16, *, max_cells: int = MAX_CELLS):
        cell = check_range("cell", cell, 0.0, np.inf, low_open=True, high_open=True)
        self.F = check_int("fine", fine, *FINE_RANGE)
        self.max_blocks = check_int("max_cells", max_cells, self.F ** 3, 2 ** 40) // self.F ** 3
        self.cell = np.array([cell, 3.0 * cell, cell])  # d × 3d × d (§2.6)
        self.limit = (COARSE_LIMIT - 2) * self.F - MAX_OFFSET
        self.keys = _new_keys()
        self.blocks = np.zeros((min(8, self.max_blocks), self.F, self.F, self.F))
        self.nblocks = 0

    def cells_of(self, points: np.ndarray) -> np.ndarray:
        """Return the integer fine-cell index (N, 3) of each point (Eq. 9.11 at fine resolution).

        Indices are clipped to ±``limit`` and NaN coordinates give 0, so every result can be added or read.
        """
        try:
            pts = np.asarray(points, np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"points must be an (N, 3) array of numbers, got {type(points).__name__}") from None
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
        out = np.empty(pts.shape, np.int64)
        if len(pts):
            _cells_of(np.ascontiguousarray(pts), self.cell, float(self.limit), out)
        return out

    def add(self, cells: np.ndarray, offsets: np.ndarray, values: np.ndarray, sign: float = 1.0) -> None:
        """Add (``sign`` = +1) or subtract (−1) the pyramid ``offsets/values`` under each cell of ``cells``.

        ``cells`` (N, 3) int within ±``limit``, ``offsets`` (K, 3) int within ±MAX_OFFSET, ``values`` (K,) finite.
        Raises :class:`ShadowGridFull` (grid unchanged) when the blocks would exceed ``max_cells``.
        """
        cells = _check_cells("cells", cells, self.limit)
        offsets = _check_cells("offsets", offsets, MAX_OFFSET)
        values = check_array("values", values, shape=(len(offsets),))
        sign = check_range("sign", sign, -1.0, 1.0)
        self._add_cells(cells, offsets, values, sign)

    def _add_cells(self, cells, offsets, values, sign=1.0) -> None:
        """:meth:`add` without the door checks (the engine's path: cells from :meth:`cells_of`, its own LUT)."""
        if len(cells) == 0 or len(offsets) == 0:
            return
        cells = np.ascontiguousarray(cells, np.int64)
        n = _ensure_blocks(self.keys, cells, offsets.min(0), offsets.max(0), self.F, self.nblocks, self.max_blocks)
        if n > self.max_blocks:
            _drop_blocks(self.keys, self.nblocks)
            raise ShadowGridFull(f"shadow grid would need more than max_cells = {self.max_blocks * self.F ** 3} "
                                 f"fine cells (cell {self.cell[0]:g} m, fine {self.F}); use a larger cell")
        self.nblocks = n
        if self.nblocks > len(self.blocks):
            size = min(max(2 * len(self.blocks), self.nblocks), self.max_blocks)
            grown = np.zeros((size, *self.blocks.shape[1:]))
            grown[: len(self.blocks)] = self.blocks
            self.blocks = grown
        _splat(self.keys, self.blocks, self.F, cells, offsets, values, float(sign))

    def read(self, cells: np.ndarray) -> np.ndarray:
        """Return the accumulated shadow at each integer cell (N, 3) within ±``limit`` (0 where no block exists)."""
        return self._read_cells(_check_cells("cells", cells, self.limit))

    def _read_cells(self, cells) -> np.ndarray:
        """:meth:`read` without the door checks (cells from :meth:`cells_of`)."""
        out = np.empty(len(cells))
        if len(cells):
            _read(self.keys, self.blocks, self.F, np.ascontiguousarray(cells, np.int64), out)
        return out

    def clear(self) -> None:
        """Drop every block."""
        _clear_keys(self.keys)
        self.blocks[:] = 0.0
        self.nblocks = 0

"""Distance-based shadow pyramids on a two-tier hashed sparse grid (spec 000_treewand §2.6–§2.7, Alg. 9.1).

Cells are ``l_b × 3 l_b × l_b`` (§2.6). Fine grids of ``F³`` cells are created lazily under a coarse hash
keyed by the corrected Szudzik pairing (Eqs. 9.11–9.14, ERRATUM A.7) of zig-zag mapped coarse indices.
"""
from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.typed import Dict

__all__ = ["szudzik", "zigzag", "coarse_key", "shadow_lut", "ShadowGrid"]


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
    The node's own cell (q = 0) is never shadowed.
    """
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
def _ensure_blocks(keys, centres, lo, hi, F, nblocks):
    """Create the fine blocks overlapped by the box [centre + lo, centre + hi] of each centre (lazily, §2.7)."""
    for c in range(centres.shape[0]):
        for i in range((centres[c, 0] + lo[0]) // F, (centres[c, 0] + hi[0]) // F + 1):
            for j in range((centres[c, 1] + lo[1]) // F, (centres[c, 1] + hi[1]) // F + 1):
                for k in range((centres[c, 2] + lo[2]) // F, (centres[c, 2] + hi[2]) // F + 1):
                    key = coarse_key(i, j, k)
                    if key not in keys:
                        keys[key] = nblocks
                        nblocks += 1
    return nblocks


@numba.njit(cache=True, nogil=True)
def _splat(keys, blocks, F, centres, offsets, values, sign):
    # the block ids a pyramid touches are looked up once per node, not once per cell
    lo0, lo1, lo2 = offsets[:, 0].min(), offsets[:, 1].min(), offsets[:, 2].min()
    hi0, hi1, hi2 = offsets[:, 0].max(), offsets[:, 1].max(), offsets[:, 2].max()
    span = max(hi0 - lo0, hi1 - lo1, hi2 - lo2) // F + 2
    ids = np.empty((span, span, span), np.int64)
    for n in range(centres.shape[0]):
        c0, c1, c2 = centres[n, 0], centres[n, 1], centres[n, 2]
        b0, b1, b2 = (c0 + lo0) // F, (c1 + lo1) // F, (c2 + lo2) // F
        for i in range((c0 + hi0) // F - b0 + 1):
            for j in range((c1 + hi1) // F - b1 + 1):
                for k in range((c2 + hi2) // F - b2 + 1):
                    ids[i, j, k] = keys[coarse_key(b0 + i, b1 + j, b2 + k)]
        for o in range(offsets.shape[0]):
            x = c0 + offsets[o, 0]
            y = c1 + offsets[o, 1]
            z = c2 + offsets[o, 2]
            b = ids[x // F - b0, y // F - b1, z // F - b2]
            blocks[b, x % F, y % F, z % F] += sign * values[o]  # floor-mod: negative coords work (§2.7)


@numba.njit(cache=True, nogil=True)
def _read(keys, blocks, F, cells, out):
    for c in range(cells.shape[0]):
        key = coarse_key(cells[c, 0] // F, cells[c, 1] // F, cells[c, 2] // F)
        if key in keys:
            out[c] = blocks[keys[key], cells[c, 0] % F, cells[c, 1] % F, cells[c, 2] % F]
        else:
            out[c] = 0.0


class ShadowGrid:
    """Sparse accumulated-shadow grid: a coarse hash → pooled ``F³`` fine blocks (§2.7)."""

    def __init__(self, cell: float, fine: int = 16):
        self.cell = np.array([cell, 3.0 * cell, cell])  # d × 3d × d (§2.6)
        self.F = int(fine)
        self.keys = Dict.empty(key_type=types.int64, value_type=types.int64)
        self.blocks = np.zeros((8, self.F, self.F, self.F))
        self.nblocks = 0

    def cells_of(self, points: np.ndarray) -> np.ndarray:
        """Return the integer fine-cell index (N, 3) of each point (Eq. 9.11 at fine resolution)."""
        return np.floor(np.asarray(points, np.float64) / self.cell).astype(np.int64)

    def add(self, cells: np.ndarray, offsets: np.ndarray, values: np.ndarray, sign: float = 1.0) -> None:
        """Add (``sign`` = +1) or subtract (−1) the pyramid ``offsets/values`` under each cell of ``cells``."""
        if len(cells) == 0 or len(offsets) == 0:
            return
        cells = np.ascontiguousarray(cells, np.int64)
        self.nblocks = _ensure_blocks(self.keys, cells, offsets.min(0), offsets.max(0), self.F, self.nblocks)
        if self.nblocks > len(self.blocks):
            grown = np.zeros((max(2 * len(self.blocks), self.nblocks), *self.blocks.shape[1:]))
            grown[: len(self.blocks)] = self.blocks
            self.blocks = grown
        _splat(self.keys, self.blocks, self.F, cells, offsets, values, float(sign))

    def read(self, cells: np.ndarray) -> np.ndarray:
        """Return the accumulated shadow at each integer cell (0 where no block exists)."""
        out = np.empty(len(cells))
        if len(cells):
            _read(self.keys, self.blocks, self.F, np.ascontiguousarray(cells, np.int64), out)
        return out

    def clear(self) -> None:
        """Drop every block."""
        self.keys.clear()
        self.blocks[:] = 0.0
        self.nblocks = 0

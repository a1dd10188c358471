"""Marker → bud assignment by the smallest d/l inside the perception cone (spec 000_treewand §2.3, Eq. 9.4).

A marker is perceived by a bud when 0 < d <= view radius and the angle between (m − p) and the bud heading
is at most half the view angle (ambiguity A.19: full apex angle). Among perceiving buds the marker goes to
the smallest d/l, with l the length of the internode the bud would produce; ties go to the lowest bud index.
"""
from __future__ import annotations

import numba
import numpy as np

from .spatial import _bucket, build_grid

__all__ = ["assign_markers", "assign_markers_bruteforce", "assign_markers_numpy"]


@numba.njit(cache=True, nogil=True, inline="always")
def _consider(markers, i, bp, bd, bl, j, r2, cosh, best, owner):
    dx = markers[i, 0] - bp[0]
    dy = markers[i, 1] - bp[1]
    dz = markers[i, 2] - bp[2]
    dd = dx * dx + dy * dy + dz * dz
    if dd == 0.0 or dd > r2:
        return
    d = np.sqrt(dd)
    if dx * bd[0] + dy * bd[1] + dz * bd[2] < d * cosh:
        return
    v = d / bl
    if v < best[i]:
        best[i] = v
        owner[i] = j


@numba.njit(cache=True, nogil=True)
def _assign_grid(markers, order, start, mask, h, bud_pos, bud_dir, bud_len, r, cosh, owner):
    best = np.full(markers.shape[0], np.inf)
    r2 = r * r
    reach = np.int64(np.ceil(r / h))
    for j in range(bud_pos.shape[0]):
        bp, bd, bl = bud_pos[j], bud_dir[j], bud_len[j]
        cx = np.int64(np.floor(bp[0] / h))
        cy = np.int64(np.floor(bp[1] / h))
        cz = np.int64(np.floor(bp[2] / h))
        for ix in range(cx - reach, cx + reach + 1):
            for iy in range(cy - reach, cy + reach + 1):
                for iz in range(cz - reach, cz + reach + 1):
                    b = _bucket(ix, iy, iz, mask)
                    for k in range(start[b], start[b + 1]):
                        _consider(markers, order[k], bp, bd, bl, j, r2, cosh, best, owner)


@numba.njit(cache=True, nogil=True)
def _assign_brute(markers, bud_pos, bud_dir, bud_len, r, cosh, owner):
    best = np.full(markers.shape[0], np.inf)
    r2 = r * r
    for j in range(bud_pos.shape[0]):
        for i in range(markers.shape[0]):
            _consider(markers, i, bud_pos[j], bud_dir[j], bud_len[j], j, r2, cosh, best, owner)


def _prep(markers, bud_pos, bud_dir, bud_len):
    owner = np.full(len(markers), -1, np.int64)
    return (np.ascontiguousarray(markers, np.float64), np.ascontiguousarray(bud_pos, np.float64),
            np.ascontiguousarray(bud_dir, np.float64), np.ascontiguousarray(bud_len, np.float64), owner)


def assign_markers(markers: np.ndarray, bud_pos: np.ndarray, bud_dir: np.ndarray, bud_len: np.ndarray, *,
                   view_radius: float, view_angle: float) -> np.ndarray:
    """Return ``owner`` (M,) int64: the bud index each marker is assigned to, or −1 (Eq. 9.4).

    Parameters
    ----------
    markers : (M, 3) float64 ndarray
        Marker positions.
    bud_pos, bud_dir : (B, 3) float64 ndarray
        Bud positions and unit headings.
    bud_len : (B,) float64 ndarray
        Length of the internode each bud would produce (§2.9), > 0.
    view_radius : float
        Perception radius.
    view_angle : float
        Full apex angle of the perception cone, radians (ambiguity A.19).

    Notes
    -----
    Uses a hashed uniform grid over the markers with cell = view radius, so the cost is the number of
    (bud, marker) pairs within reach rather than b·m (thesis §12.2). Equal to
    :func:`assign_markers_bruteforce` (TW-V5).
    """
    m, bp, bd, bl, owner = _prep(markers, bud_pos, bud_dir, bud_len)
    if len(m) and len(bp):
        g = build_grid(m, view_radius)
        _assign_grid(m, g.order, g.start, g.mask, g.h, bp, bd, bl, float(view_radius),
                     float(np.cos(view_angle / 2)), owner)
    return owner


def assign_markers_bruteforce(markers, bud_pos, bud_dir, bud_len, *, view_radius, view_angle) -> np.ndarray:
    """O(b·m) reference of :func:`assign_markers`, as in the thesis's C++ (§12.2)."""
    m, bp, bd, bl, owner = _prep(markers, bud_pos, bud_dir, bud_len)
    _assign_brute(m, bp, bd, bl, float(view_radius), float(np.cos(view_angle / 2)), owner)
    return owner


def assign_markers_numpy(markers, bud_pos, bud_dir, bud_len, *, view_radius, view_angle) -> np.ndarray:
    """Readable numpy twin of the kernels (O(b·m) memory: for tests on small inputs)."""
    v = markers[None, :, :] - bud_pos[:, None, :]
    d = np.linalg.norm(v, axis=2)
    ok = (d > 0) & (d <= view_radius) & (np.einsum("bmk,bk->bm", v, bud_dir) >= d * np.cos(view_angle / 2))
    score = np.where(ok, d / bud_len[:, None], np.inf)
    owner = np.argmin(score, axis=0)  # first minimum = lowest bud index
    return np.where(np.isfinite(score.min(axis=0, initial=np.inf)), owner, -1).astype(np.int64)

"""Colonization kernels (spec 003_implicit_sca §1.3–1.4, 000_treewand §2.3): numba ``nogil`` hot loops + numpy twins.

Data layout shared by every mode
--------------------------------
Markers live in a *uniform grid* built once (the dense layout of :mod:`plantvr.grid`): they are sorted by cell,
so cell ``c`` holds the
sorted slots ``[cell_start[c], cell_start[c] + cell_live[c])``.  Killing a marker swaps it with the
last live marker of its cell and shrinks ``cell_live[c]``, so scans only ever touch live markers.
Per-marker state (in sorted order) is ``orig`` (int32, input row), ``owner`` (int32, nearest node or
best bud, -1 = none) and ``best`` (float64, squared distance or d/l): 16 bytes beyond the position.

Growth directions are accumulated as **exact int64 sums of quantised unit vectors**
(``floor(u * 2**38 + 0.5)``).  Integer sums do not depend on summation order and can be updated
incrementally (a marker leaving a node subtracts exactly what it added), so a node whose marker set
did not change produces bit-for-bit the same candidate position as before.  This is what lets a step
look only at nodes whose assignment changed ("dirty" nodes) and still equal a full recompute.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from plantvr._threading import parallel_region  # noqa: F401 (sets numba's threading layer first)
from plantvr.grid import axis_range, ball_cells, bounds, box_gap2, cell_buffers, chain_within, sort_by_cell

#: Quantisation of unit vectors: 2**38 units per 1.0 (resolution 3.6e-12; sums exact up to 2**25 markers/node).
QSCALE = float(2.0 ** 38)
#: Opposite pulls cancel when the (unquantised) direction sum is shorter than this (spec 003 §1.4).
CANCEL = 1e-9 * QSCALE
#: Duplicate guard: a child closer than DUP_FRACTION * D to the candidate blocks it (spec 003 §1.4).
DUP_FRACTION = 1e-3
#: Canonical mode (Runions et al. 2007 as published): only an exactly zero sum (no direction) does not grow; a
#: non-zero int64 sum has norm >= 1 quantum.
CANONICAL_CANCEL = 1.0


# ----------------------------------------------------------------------------------------------------------------
# grid (numpy, built once)
# ----------------------------------------------------------------------------------------------------------------
def build_grid(points: np.ndarray, radius: float, cells_per_radius: int = 3, max_cells: int | None = None):
    """Sort ``points`` into a dense uniform grid of cell size ``radius / cells_per_radius``.

    The cell is enlarged when the grid would exceed ``max_cells`` (default ``max(4096, len(points) // 2)``), so
    the grid costs at most 10 bytes per point.  Returns ``(origin, h, dims, reach, pos_s, orig, cell_start,
    cell_live)``: ``pos_s`` are the points sorted by cell (stably), ``orig`` (int32) their input rows, and
    ``reach`` the cells to scan either side of a query cell to cover ``radius``.
    """
    m = len(points)
    if max_cells is None:
        max_cells = max(4096, m // 2)
    h = float(radius) / cells_per_radius
    if m == 0 or not (math.isfinite(h) and radius > 0):
        raise ValueError(f"build_grid needs M >= 1 points and radius in (0, inf), got M = {m}, radius = {radius!r}")
    lo, hi = bounds(points)
    origin, extent = lo, hi - lo
    if not np.all(np.isfinite(extent)):
        raise ValueError("build_grid needs finite points (no NaN or inf)")
    h = max(h, float(np.finfo(np.float64).tiny))  # a denormal radius / 3 rounds to 0
    lb = 0.5 * float(extent.max()) / max_cells  # any h below this gives more than 2 max_cells cells: skip them
    while h < lb:  # the same sequence of products as the loop below, without its numpy calls
        h *= 1.5
    while True:  # cell counts in float64: a tiny radius (issue 20: 1e-20) must not overflow the int64 cast
        dims_f = np.floor(extent / h) + 1.0
        if np.prod(dims_f) <= max_cells:
            break
        h *= 1.5
    dims = dims_f.astype(np.int64)
    reach = int(math.ceil(float(radius) / h - 1e-12))
    pos_s, orig, cell_start = _sort_into_cells(points, origin, h, dims)
    cell_live = np.diff(cell_start).astype(np.int32)
    return origin, h, dims, reach, pos_s, orig, cell_start, cell_live


@numba.njit(cache=True, nogil=True)
def _sort_into_cells(points, origin, h, dims):
    """Points sorted stably by grid cell (== ``points[np.argsort(cell, kind="stable")]``), in two O(m) passes."""
    m = points.shape[0]
    order, cell_start = sort_by_cell(points, origin, h, dims, np.int64)
    pos_s = np.empty((m, 3), np.float64)
    orig = np.empty(m, np.int32)
    for t in range(m):
        i = order[t]
        orig[t] = i
        for a in range(3):
            pos_s[t, a] = points[i, a]
    return pos_s, orig, cell_start


@numba.njit(cache=True, nogil=True, inline="always")
def _swap_out(s, end, pos_s, orig, owner, best):
    """Swap marker slot ``s`` with slot ``end`` (the last live slot of its cell, about to become dead)."""
    for a in range(3):
        t = pos_s[s, a]
        pos_s[s, a] = pos_s[end, a]
        pos_s[end, a] = t
    t2 = orig[s]
    orig[s] = orig[end]
    orig[end] = t2
    t3 = owner[s]
    owner[s] = owner[end]
    owner[end] = t3
    t4 = best[s]
    best[s] = best[end]
    best[end] = t4


# ----------------------------------------------------------------------------------------------------------------
# classic space colonization: incremental nearest-node update
# ----------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, inline="always")
def _q(dx, dy, dz):
    n = math.sqrt(dx * dx + dy * dy + dz * dz)
    return (np.int64(math.floor(dx / n * QSCALE + 0.5)),
            np.int64(math.floor(dy / n * QSCALE + 0.5)),
            np.int64(math.floor(dz / n * QSCALE + 0.5)))


@numba.njit(cache=True, nogil=True, inline="always")
def _mark(v, dirty_flag, dirty_list, n_dirty):
    if dirty_flag[v] == 0:
        dirty_flag[v] = 1
        dirty_list[n_dirty] = v
        n_dirty += 1
    return n_dirty


@numba.njit(cache=True, nogil=True)
def add_nodes_kernel(nodes, n_old, n_new, origin, h, dims, reach, cell_start, cell_live, cell_maxbest,
                     pos_s, orig, owner, best, acc, dirty_flag, dirty_list, n_dirty, di2, dk2):
    """Offer nodes ``n_old .. n_new-1`` to the live markers within ``sqrt(di2)`` of them.

    A marker moves to a new node whose squared distance is strictly smaller (ties keep the lower
    index, because new nodes have higher indices and are offered in increasing order); a distance
    below ``sqrt(dk2)`` kills it.  Owners that gain or lose a marker have its quantised unit vector
    added to / subtracted from ``acc`` and are appended to ``dirty_list``.
    ``cell_maxbest[c]`` bounds ``best`` over cell ``c``'s live markers (inf while one is unassigned): a
    cell farther than that from the new node cannot change and is skipped; scans make the bound exact.
    Returns ``(killed, n_dirty)``.
    """
    killed = 0
    cells, gaps = cell_buffers(reach)
    for j in range(n_old, n_new):
        px = nodes[j, 0]
        py = nodes[j, 1]
        pz = nodes[j, 2]
        for q in range(ball_cells(px, py, pz, di2, origin, h, dims, reach, cells, gaps)):
            c = cells[q]
            start = cell_start[c]
            end = start + cell_live[c]
            if end == start or gaps[q] >= di2 or gaps[q] >= cell_maxbest[c]:
                continue
            mx = 0.0
            s = start
            while s < end:
                dx = pos_s[s, 0] - px
                dy = pos_s[s, 1] - py
                dz = pos_s[s, 2] - pz
                d2 = dx * dx + dy * dy + dz * dz
                if d2 < di2 and d2 < best[s]:
                    old = owner[s]
                    if old >= 0:
                        qx, qy, qz = _q(pos_s[s, 0] - nodes[old, 0], pos_s[s, 1] - nodes[old, 1],
                                        pos_s[s, 2] - nodes[old, 2])
                        acc[old, 0] -= qx
                        acc[old, 1] -= qy
                        acc[old, 2] -= qz
                        n_dirty = _mark(old, dirty_flag, dirty_list, n_dirty)
                    if d2 < dk2:
                        end -= 1
                        _swap_out(s, end, pos_s, orig, owner, best)
                        owner[end] = -1
                        best[end] = 0.0
                        killed += 1
                        continue  # re-examine the marker swapped into slot s
                    owner[s] = j
                    best[s] = d2
                    qx, qy, qz = _q(dx, dy, dz)
                    acc[j, 0] += qx
                    acc[j, 1] += qy
                    acc[j, 2] += qz
                    n_dirty = _mark(j, dirty_flag, dirty_list, n_dirty)
                mx = max(mx, best[s])
                s += 1
            cell_live[c] = end - start
            cell_maxbest[c] = mx
    return killed, n_dirty


@numba.njit(cache=True, nogil=True)
def grow_kernel(nodes, parent, first_child, next_sibling, n_children, n, acc, dirty_list, n_dirty, dirty_flag,
                children_limit, step, dup2, cancel=CANCEL):
    """One synchronous growth step over the listed nodes (ascending index); returns the new node count.

    Each node with a direction sum of norm >= ``cancel`` (quantised units), fewer than ``children_limit``
    children (-1 = no limit) and no child within ``sqrt(dup2)`` of the candidate gets one child at
    ``p + step * a / |a|`` (spec 003 §1.4 with its guards). Canonical mode passes ``dup2 < 0`` (no duplicate
    guard) and ``cancel = CANONICAL_CANCEL`` (only an exactly zero sum does not grow).
    """
    lst = np.sort(dirty_list[:n_dirty])
    for t in range(n_dirty):
        v = lst[t]
        dirty_flag[v] = 0
        if children_limit >= 0 and n_children[v] >= children_limit:
            continue
        ax = np.float64(acc[v, 0])
        ay = np.float64(acc[v, 1])
        az = np.float64(acc[v, 2])
        nrm = math.sqrt(ax * ax + ay * ay + az * az)
        if nrm < cancel:
            continue
        cx = nodes[v, 0] + step * (ax / nrm)
        cy = nodes[v, 1] + step * (ay / nrm)
        cz = nodes[v, 2] + step * (az / nrm)
        if dup2 > 0.0 and chain_within(first_child[v], next_sibling, nodes, cx, cy, cz, dup2):
            continue
        nodes[n, 0] = cx
        nodes[n, 1] = cy
        nodes[n, 2] = cz
        parent[n] = v
        first_child[n] = -1
        n_children[n] = 0
        next_sibling[n] = first_child[v]
        first_child[v] = n
        n_children[v] += 1
        n += 1
    return n


@numba.njit(cache=True, nogil=True)
def live_orig_kernel(cell_start, cell_live, orig):
    """Input rows of the live markers, ascending."""
    total = 0
    for c in range(cell_live.shape[0]):
        total += cell_live[c]
    out = np.empty(total, np.int64)
    t = 0
    for c in range(cell_live.shape[0]):
        for s in range(cell_start[c], cell_start[c] + cell_live[c]):
            out[t] = orig[s]
            t += 1
    return np.sort(out)


# ---- numpy twins (readable; used by tests to check the kernels on seeded input) -------------------------------
def quantize_numpy(d: np.ndarray) -> np.ndarray:
    """Quantised unit vectors of the rows of ``d`` (numpy twin of ``_q``)."""
    d2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
    n = np.sqrt(d2)
    return np.floor(d / n[:, None] * QSCALE + 0.5).astype(np.int64)


def add_nodes_numpy(nodes, n_old, n_new, markers, alive, owner, best, acc, di2, dk2):
    """numpy twin of :func:`add_nodes_kernel` on markers in input order.

    ``alive`` (bool), ``owner`` and ``best`` are indexed by input row and updated in place with
    ``acc``.  Returns ``(killed, dirty)`` with ``dirty`` the sorted array of touched owners.
    """
    killed = 0
    dirty = set()
    for j in range(n_old, n_new):
        d = markers - nodes[j]
        d2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
        hit = np.flatnonzero(alive & (d2 < di2) & (d2 < best))
        if hit.size == 0:
            continue
        old = owner[hit]
        had = old >= 0
        if had.any():
            np.subtract.at(acc, old[had], quantize_numpy(markers[hit[had]] - nodes[old[had]]))
            dirty.update(old[had].tolist())
        kill = d2[hit] < dk2
        alive[hit[kill]] = False
        owner[hit[kill]] = -1
        killed += int(kill.sum())
        keep = hit[~kill]
        if keep.size:
            owner[keep] = j
            best[keep] = d2[keep]
            acc[j] += quantize_numpy(d[keep]).sum(axis=0)
            dirty.add(j)
    return killed, np.array(sorted(dirty), dtype=np.int64)


def grow_numpy(nodes, parent, children, acc, candidates, children_limit, step, dup2, cancel=CANCEL):
    """numpy twin of :func:`grow_kernel`; ``children`` is a list of child lists, extended in place.

    Returns the new node and parent arrays.
    """
    new_nodes, new_parent = [], []
    n = len(nodes)
    for v in sorted(int(c) for c in candidates):
        if children_limit >= 0 and len(children[v]) >= children_limit:
            continue
        ax, ay, az = (float(a) for a in acc[v])
        nrm = math.sqrt(ax * ax + ay * ay + az * az)
        if nrm < cancel:
            continue
        cand = np.array([nodes[v, 0] + step * (ax / nrm), nodes[v, 1] + step * (ay / nrm),
                         nodes[v, 2] + step * (az / nrm)])
        allpos = np.concatenate([nodes] + [np.asarray(new_nodes).reshape(-1, 3)])
        if children[v] and dup2 > 0:
            e = allpos[children[v]] - cand
            if np.any(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1] + e[:, 2] * e[:, 2] < dup2):
                continue
        children[v].append(n)
        children.append([])
        new_nodes.append(cand)
        new_parent.append(v)
        n += 1
    if new_nodes:
        nodes = np.concatenate([nodes, np.asarray(new_nodes)])
        parent = np.concatenate([parent, np.asarray(new_parent, dtype=np.int64)])
    return nodes, parent


# ----------------------------------------------------------------------------------------------------------------
# Tree Wand assignment (Eq. 9.4): smallest d / l among perceiving buds
# ----------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, inline="always")
def _cell_in_cone(px, py, pz, bx, by, bz, origin, h, dims, c, rc, cos_half, sin_half):
    """Whether cell ``c`` may hold points of the cone (apex p, unit axis b, half-angle θ): conservative.

    The cell's bounding sphere (radius ``rc``) seen from p subtends δ = asin(rc / dist); the sphere meets the
    cone iff the axis angle of its centre is ≤ θ + δ, i.e. b·v ≥ dist·cos(θ + δ) (with a small margin).
    """
    k = c % dims[2]
    j = (c // dims[2]) % dims[1]
    i = c // (dims[1] * dims[2])
    vx = origin[0] + (i + 0.5) * h - px
    vy = origin[1] + (j + 0.5) * h - py
    vz = origin[2] + (k + 0.5) * h - pz
    dist2 = vx * vx + vy * vy + vz * vz
    if dist2 <= rc * rc:
        return True
    dist = math.sqrt(dist2)
    sd = rc / dist
    cd = math.sqrt(1.0 - sd * sd)
    cos_sum = cos_half * cd - sin_half * sd  # cos(θ + δ), valid while θ + δ ≤ π, i.e. for θ ≤ π/2
    return cos_half < 0.0 or vx * bx + vy * by + vz * bz >= dist * cos_sum - 1e-9 * dist

@numba.njit(cache=True, nogil=True, inline="always")
def _offer_cell(c, px, py, pz, bx, by, bz, ln, bid, origin, h, dims, cell_start, cell_live, pos_s, orig, owner,
                best, owner_in, view_radius, cos_half, sin_half, vr2m, c2, wide, rc, cand):
    """Offer one bud to the live markers of grid cell ``c``: a branch-free pass keeps the markers that may be in
    the cone (no square roots), the exact test of the brute-force twin runs on those. Returns the (possibly
    grown) candidate buffer and the number of markers whose owner changed."""
    start = cell_start[c]
    end = start + cell_live[c]
    if end == start or not _cell_in_cone(px, py, pz, bx, by, bz, origin, h, dims, c, rc, cos_half, sin_half):
        return cand, 0
    if end - start > cand.shape[0]:
        cand = np.empty(2 * (end - start), np.int64)
    nc = 0
    for s in range(start, end):  # branch-free candidate pass
        vx = pos_s[s, 0] - px
        vy = pos_s[s, 1] - py
        vz = pos_s[s, 2] - pz
        d2 = vx * vx + vy * vy + vz * vz
        dot = vx * bx + vy * by + vz * bz
        cand[nc] = s
        nc += (d2 <= vr2m) & (d2 != 0.0) & (wide | ((dot > 0.0) & (dot * dot >= d2 * c2)))
    changed = 0
    for t in range(nc):  # exact test, the same arithmetic as treewand_assign_numpy
        s = cand[t]
        vx = pos_s[s, 0] - px
        vy = pos_s[s, 1] - py
        vz = pos_s[s, 2] - pz
        d = math.sqrt(vx * vx + vy * vy + vz * vz)
        if d > view_radius:
            continue
        if vx * bx + vy * by + vz * bz < d * cos_half:
            continue
        key = d / ln
        o = owner[s]
        if key < best[s] or (key == best[s] and o >= 0 and bid < o):
            best[s] = key
            owner[s] = bid
            owner_in[orig[s]] = bid
            changed += 1
    return cand, changed


# ----------------------------------------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True)
def treewand_assign_kernel(bud_pos, bud_dir, bud_len, bud_ids, origin, h, dims, reach, cell_start, cell_live,
                           pos_s, orig, owner, best, owner_in, view_radius, cos_half):
    """Offer buds to the markers in their perception cones; keeps the smallest d/l, ties to the lower bud id.

    ``owner``/``best`` are in sorted-marker order, ``owner_in`` is the owner by input row (``orig``); all are
    updated in place.  The result does not depend on the order of the buds.  Cells outside a bud's view
    sphere or cone are skipped; within a cell a branch-free pass keeps the markers that may be in the cone
    (a conservative test without square roots) and the exact test of the brute-force twin runs on those only.
    Returns the number of updates.
    """
    vr2 = view_radius * view_radius
    vr2m = vr2 * 1.0000001
    c2 = cos_half * cos_half * (1.0 - 1e-9)
    wide = cos_half <= 0.0
    sin_half = math.sqrt(max(0.0, 1.0 - cos_half * cos_half))
    rc = 0.5 * math.sqrt(3.0) * h  # radius of a cell's bounding sphere
    cand = np.empty(1024, np.int64)
    cells, gaps = cell_buffers(reach)
    changed = 0
    for b in range(bud_pos.shape[0]):
        px = bud_pos[b, 0]
        py = bud_pos[b, 1]
        pz = bud_pos[b, 2]
        bx = bud_dir[b, 0]
        by = bud_dir[b, 1]
        bz = bud_dir[b, 2]
        ln = bud_len[b]
        bid = bud_ids[b]
        for q in range(ball_cells(px, py, pz, vr2m, origin, h, dims, reach, cells, gaps)):
            cand, n = _offer_cell(cells[q], px, py, pz, bx, by, bz, ln, bid, origin, h, dims, cell_start,
                                  cell_live, pos_s, orig, owner, best, owner_in, view_radius, cos_half, sin_half,
                                  vr2m, c2, wide, rc, cand)
            changed += n
    return changed



@numba.njit(cache=True, nogil=True, inline="always")
def _offer_bud_slab(px, py, pz, bx, by, bz, ln, bid, i0, i1, origin, h, dims, reach, cell_start, cell_live, pos_s,
                    orig, owner, best, owner_in, view_radius, cos_half, cand):
    """One bud of :func:`treewand_assign_kernel`, restricted to the cells of grid slab ``i0 <= i < i1``."""
    vr2m = view_radius * view_radius * 1.0000001
    c2 = cos_half * cos_half * (1.0 - 1e-9)
    wide = cos_half <= 0.0
    sin_half = math.sqrt(max(0.0, 1.0 - cos_half * cos_half))
    rc = 0.5 * math.sqrt(3.0) * h
    ilo, ihi = axis_range(px, origin, h, dims, reach, 0)
    ilo, ihi = max(ilo, i0), min(ihi, i1 - 1)
    if ilo > ihi:
        return cand
    jlo, jhi = axis_range(py, origin, h, dims, reach, 1)
    klo, khi = axis_range(pz, origin, h, dims, reach, 2)
    for ci in range(ilo, ihi + 1):
        for cj in range(jlo, jhi + 1):
            for ck in range(klo, khi + 1):
                if box_gap2(px, py, pz, origin, h, ci, cj, ck) > vr2m:
                    continue
                cand, _ = _offer_cell((ci * dims[1] + cj) * dims[2] + ck, px, py, pz, bx, by, bz, ln, bid, origin,
                                      h, dims, cell_start, cell_live, pos_s, orig, owner, best, owner_in,
                                      view_radius, cos_half, sin_half, vr2m, c2, wide, rc, cand)
    return cand


@numba.njit(cache=True, nogil=True, parallel=True)
def treewand_assign_parallel(bud_pos, bud_dir, bud_len, bud_ids, origin, h, dims, reach, cell_start, cell_live,
                             pos_s, orig, owner, best, owner_in, view_radius, cos_half, n_slabs):
    """:func:`treewand_assign_kernel` with the marker grid cut into ``n_slabs`` slabs along its first axis, one
    ``prange`` task each: every marker slot belongs to one slab, so no two threads write the same marker, and the
    result (smallest d/l, ties to the lower bud id) does not depend on the order the buds are offered in, so it
    equals the serial kernel's bit for bit (tested). Each task runs every bud, restricted to its slab's cells."""
    n_slabs = max(1, min(n_slabs, dims[0]))
    for t in numba.prange(n_slabs):
        i0 = (dims[0] * t) // n_slabs
        i1 = (dims[0] * (t + 1)) // n_slabs
        cand = np.empty(1024, np.int64)
        for b in range(bud_pos.shape[0]):
            cand = _offer_bud_slab(bud_pos[b, 0], bud_pos[b, 1], bud_pos[b, 2], bud_dir[b, 0], bud_dir[b, 1],
                                   bud_dir[b, 2], bud_len[b], bud_ids[b], i0, i1, origin, h, dims, reach,
                                   cell_start, cell_live, pos_s, orig, owner, best, owner_in, view_radius,
                                   cos_half, cand)



@numba.njit(cache=True, nogil=True)
def keep_rows_kernel(keep, cell_start, cell_live, pos_s, orig):
    """Drop the markers of input rows where ``keep`` is False from a grid, in place: each cell's live slots are
    compacted (order kept) and ``orig`` renumbered to the rows of ``markers[keep]``. Returns the count kept.

    One pass over the live slots and ``keep`` (no sort), so a grid follows the engine's marker array across steps
    (occupation kills, expiry) instead of being rebuilt; twin: a fresh :func:`build_grid` of ``markers[keep]``
    (the same live markers per cell; assignments equal, tested)."""
    m = keep.shape[0]
    remap = np.empty(m, np.int64)
    k = 0
    for i in range(m):
        remap[i] = k
        if keep[i]:
            k += 1
    for c in range(cell_live.shape[0]):
        start = cell_start[c]
        w = start
        for s in range(start, start + cell_live[c]):
            r = orig[s]
            if keep[r]:
                if w != s:
                    pos_s[w, 0] = pos_s[s, 0]
                    pos_s[w, 1] = pos_s[s, 1]
                    pos_s[w, 2] = pos_s[s, 2]
                orig[w] = remap[r]
                w += 1
        cell_live[c] = w - start
    return k


@numba.njit(cache=True, nogil=True)
def rows_within_kernel(points, r, origin, h, dims, reach, cell_start, cell_live, pos_s, orig, out):
    """Set ``out[row]`` for the live markers within distance ``r`` (<= ``reach`` cells) of any of ``points``, by
    the squared-distance test of :func:`plantvr.grid.mark_within` (twin: ``within_any_numpy``)."""
    r2 = r * r
    cells, gaps = cell_buffers(reach)
    for j in range(points.shape[0]):
        px = points[j, 0]
        py = points[j, 1]
        pz = points[j, 2]
        for q in range(ball_cells(px, py, pz, r2 * 1.0000001, origin, h, dims, reach, cells, gaps)):
            c = cells[q]
            for s in range(cell_start[c], cell_start[c] + cell_live[c]):
                dx = pos_s[s, 0] - px
                dy = pos_s[s, 1] - py
                dz = pos_s[s, 2] - pz
                if dx * dx + dy * dy + dz * dz <= r2:
                    out[orig[s]] = True

@numba.njit(cache=True, nogil=True)
def owner_sums_kernel(owner, markers, n_buds):
    """``(count (B,) int64, sums (B, 3))`` of the markers of each bud: the engine's ``np.bincount`` pair
    (:func:`plantvr.growth.engine.marker_counts`, :func:`~plantvr.growth.engine.sum_per_bud`) in one pass,
    adding in marker order as ``bincount`` does, so the sums are bit for bit the same (tested)."""
    count = np.zeros(n_buds, np.int64)
    sums = np.zeros((n_buds, 3))
    for i in range(owner.shape[0]):
        o = owner[i]
        if o >= 0 and o < n_buds:
            count[o] += 1
            sums[o, 0] += markers[i, 0]
            sums[o, 1] += markers[i, 1]
            sums[o, 2] += markers[i, 2]
    return count, sums

def treewand_assign_numpy(markers, bud_pos, bud_dir, bud_len, view_radius, cos_half):
    """Brute-force O(b*m) twin of :func:`treewand_assign_kernel` (spec 000_treewand §2.3 pseudo-code).

    Returns ``(owner (M,) int64, best (M,) float64)``.
    """
    m = len(markers)
    owner = np.full(m, -1, np.int64)
    best = np.full(m, np.inf)
    for j in range(len(bud_pos)):
        v = markers - bud_pos[j]
        d2 = v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2]
        d = np.sqrt(d2)
        dot = v[:, 0] * bud_dir[j, 0] + v[:, 1] * bud_dir[j, 1] + v[:, 2] * bud_dir[j, 2]
        ok = (d2 != 0.0) & (d <= view_radius) & (dot >= d * cos_half)
        key = d / bud_len[j]
        better = ok & (key < best)
        best[better] = key[better]
        owner[better] = j
    return owner, best


# ---- incremental Tree Wand update ------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True)
def treewand_release_kernel(old_pos, ids, origin, h, dims, reach, cell_start, cell_live, orig, owner, best,
                            owner_in, view_radius, affected, n_aff):
    """Unassign the markers owned by buds ``ids`` (scanned around their previous positions ``old_pos``).

    Released sorted slots are appended to ``affected``; returns the new count.
    """
    vr2m = view_radius * view_radius * 1.0000001
    cells, gaps = cell_buffers(reach)
    for b in range(ids.shape[0]):
        bid = ids[b]
        for q in range(ball_cells(old_pos[b, 0], old_pos[b, 1], old_pos[b, 2], vr2m, origin, h, dims, reach,
                                   cells, gaps)):
            c = cells[q]
            for s in range(cell_start[c], cell_start[c] + cell_live[c]):
                if owner[s] == bid:
                    owner[s] = -1
                    owner_in[orig[s]] = -1
                    best[s] = np.inf
                    affected[n_aff] = s
                    n_aff += 1
    return n_aff


@numba.njit(cache=True, nogil=True)
def treewand_reassign_kernel(slots, pos_s, orig, owner, best, owner_in, bud_pos, bud_dir, bud_len, bud_order,
                             bud_cell_start, origin, h, dims, reach, view_radius, cos_half):
    """Give each marker slot in ``slots`` its best bud among all buds (bud grid: ``bud_order`` by cell).

    Buds outside the grid are clamped into its border cells, so every cell within reach is scanned (no gap test).
    """
    vr2 = view_radius * view_radius
    cells, gaps = cell_buffers(reach)
    for t in range(slots.shape[0]):
        s = slots[t]
        mx = pos_s[s, 0]
        my = pos_s[s, 1]
        mz = pos_s[s, 2]
        for q in range(ball_cells(mx, my, mz, np.inf, origin, h, dims, reach, cells, gaps)):
            c = cells[q]
            for u in range(bud_cell_start[c], bud_cell_start[c + 1]):
                b = bud_order[u]
                vx = mx - bud_pos[b, 0]
                vy = my - bud_pos[b, 1]
                vz = mz - bud_pos[b, 2]
                d2 = vx * vx + vy * vy + vz * vz
                if d2 > vr2 * 1.0000001 or d2 == 0.0:
                    continue
                d = math.sqrt(d2)
                if d > view_radius:
                    continue
                if vx * bud_dir[b, 0] + vy * bud_dir[b, 1] + vz * bud_dir[b, 2] < d * cos_half:
                    continue
                key = d / bud_len[b]
                o = owner[s]
                if key < best[s] or (key == best[s] and o >= 0 and b < o):
                    best[s] = key
                    owner[s] = b
                    owner_in[orig[s]] = b


@numba.njit(cache=True, nogil=True)
def kill_within_kernel(points, r2, origin, h, dims, reach, cell_start, cell_live, pos_s, orig, owner, best, owner_in):
    """Swap-remove live markers with squared distance < ``r2`` to any of ``points``; returns the count."""
    killed = 0
    cells, gaps = cell_buffers(reach)
    for j in range(points.shape[0]):
        px = points[j, 0]
        py = points[j, 1]
        pz = points[j, 2]
        for q in range(ball_cells(px, py, pz, r2, origin, h, dims, reach, cells, gaps)):
            c = cells[q]
            start = cell_start[c]
            end = start + cell_live[c]
            s = start
            while s < end:
                dx = pos_s[s, 0] - px
                dy = pos_s[s, 1] - py
                dz = pos_s[s, 2] - pz
                if dx * dx + dy * dy + dz * dz < r2:
                    owner_in[orig[s]] = -1
                    end -= 1
                    _swap_out(s, end, pos_s, orig, owner, best)
                    killed += 1
                    continue
                s += 1
            cell_live[c] = end - start
    return killed

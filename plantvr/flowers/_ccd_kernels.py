"""Numba kernels of continuous collision detection (spec 002 §3.6; thesis Eqs. 4.2–4.7, App. B).

Broad phase: padded swept AABBs and the query of the time-stamped spatial hash of :mod:`plantvr.grid`.
Narrow phase, scalar and allocation-free per pair: Provot's coplanarity cubic (Eq. B.2 vector form, ERRATUM A.6),
coefficient culling, Newton/bisection roots in [0, 1], the barycentric vertex-triangle test (Eq. B.7), the
segment distance of the edge-edge test (Eqs. B.8–B.11) and the parity rule (ERRATUM A.15). Then the projection of
the unilateral collision constraints (Eqs. 4.6–4.7) and the edge-triangle count of the static intersection
check (V23). The checked wrappers are in :mod:`plantvr.flowers.ccd`.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._barycentric import barycentric_nb
from plantvr.grid import box_cell_range, cell_key, hash_cell

# ---------------------------------------------------------------------------------------------------------
# Broad phase (Teschner et al. 2003, thesis [43])


@numba.njit(cache=True, nogil=True)
def _swept_boxes_kernel(x0, x1, elems, ids, pad, lo, hi):
    """Padded AABBs of the elements' start and end positions, written in place for ``ids``."""
    for k in range(ids.size):
        e = ids[k]
        for a in range(3):
            mn = np.inf
            mx = -np.inf
            for j in range(elems.shape[1]):
                v = elems[e, j]
                s = x0[v, a]
                t = x1[v, a]
                mn = min(mn, s)
                mn = min(mn, t)
                mx = max(mx, s)
                mx = max(mx, t)
            lo[e, a] = mn - pad
            hi[e, a] = mx + pad


@numba.njit(cache=True, nogil=True)
def _hash_query(qids, qlo, qhi, qverts, tlo, thi, tverts, tmode, inv, head, stamp, cur, nxt, elem, key,
                seen, token, out, m, swap):
    """Append (query, target) pairs whose padded swept boxes overlap; skip pairs sharing a vertex.

    ``tmode[e]``: 0 keep, 1 keep only if e > q (same element set), 2 skip. ``swap`` writes (target, query).
    """
    mask = head.size - 1
    nq = qverts.shape[1]
    nt = tverts.shape[1]
    for k in range(qids.size):
        q = qids[k]
        token += 1
        x0, x1, y0, y1, z0, z1 = box_cell_range(qlo, qhi, q, inv)
        for iz in range(z0, z1 + 1):
            for iy in range(y0, y1 + 1):
                for ix in range(x0, x1 + 1):
                    h = hash_cell(ix, iy, iz, mask)
                    if stamp[h] != cur:
                        continue
                    ck = cell_key(ix, iy, iz)
                    j = head[h]
                    while j >= 0:
                        if key[j] == ck:
                            e = elem[j]
                            if seen[e] != token:
                                seen[e] = token
                                md = tmode[e]
                                if md == 2 or (md == 1 and e <= q):
                                    pass
                                elif (qhi[q, 0] < tlo[e, 0] or qlo[q, 0] > thi[e, 0] or qhi[q, 1] < tlo[e, 1]
                                      or qlo[q, 1] > thi[e, 1] or qhi[q, 2] < tlo[e, 2] or qlo[q, 2] > thi[e, 2]):
                                    pass                                   # exact swept-box test
                                else:
                                    shared = False
                                    for a in range(nq):
                                        for b in range(nt):
                                            if qverts[q, a] == tverts[e, b]:
                                                shared = True
                                    if not shared:
                                        if m == out.shape[0]:
                                            new = np.empty((2 * out.shape[0] + 16, 2), np.int64)
                                            new[:m] = out[:m]
                                            out = new
                                        out[m, 0], out[m, 1] = (e, q) if swap else (q, e)
                                        m += 1
                        j = nxt[j]
    return out, m, token



# ---------------------------------------------------------------------------------------------------------
# Narrow phase: scalar numba kernels (no per-pair allocation)


@numba.njit(cache=True, nogil=True)
def _cubic_s(x0, x1, x2, u0, u1, u2, y0, y1, y2, v0, v1, v2, z0, z1, z2, w0, w1, w2):
    """Coefficients of (y + t v) x (z + t w) . (x + t u) (spec 002 §3.6.2, Eq. B.2 vector form)."""
    Q0, Q1, Q2 = v1 * w2 - v2 * w1, v2 * w0 - v0 * w2, v0 * w1 - v1 * w0
    R0 = (v1 * z2 - v2 * z1) + (y1 * w2 - y2 * w1)
    R1 = (v2 * z0 - v0 * z2) + (y2 * w0 - y0 * w2)
    R2 = (v0 * z1 - v1 * z0) + (y0 * w1 - y1 * w0)
    S0, S1, S2 = y1 * z2 - y2 * z1, y2 * z0 - y0 * z2, y0 * z1 - y1 * z0
    return (Q0 * u0 + Q1 * u1 + Q2 * u2,
            Q0 * x0 + Q1 * x1 + Q2 * x2 + R0 * u0 + R1 * u1 + R2 * u2,
            R0 * x0 + R1 * x1 + R2 * x2 + S0 * u0 + S1 * u1 + S2 * u2,
            S0 * x0 + S1 * x1 + S2 * x2)


@numba.njit(cache=True, nogil=True)
def _horner(a, b, c, d, t):
    return ((a * t + b) * t + c) * t + d


@numba.njit(cache=True, nogil=True)
def _culled(a3, a2, a1, a0):
    """Coefficient culling [50]: True when the cubic certainly has no root in [0, 1]."""
    if (a0 > 0 and a1 > 0 and a2 > 0 and a3 > 0) or (a0 < 0 and a1 < 0 and a2 < 0 and a3 < 0):
        return True
    if a0 > 0 and a1 > 0 and a0 + a1 > abs(a2) + abs(a3):
        return True
    if a0 < 0 and a1 < 0 and a0 + a1 < -abs(a2) - abs(a3):
        return True
    return abs(a0) > abs(a1) + abs(a2) + abs(a3)


@numba.njit(cache=True, nogil=True)
def _rtsafe(a, b, c, d, lo, hi, flo):
    """Hybrid Newton/bisection on a bracket with f(lo) f(hi) < 0 (Numerical Recipes rtsafe)."""
    t = 0.5 * (lo + hi)
    for _ in range(100):
        f = _horner(a, b, c, d, t)
        if f == 0.0:
            return t
        if (f < 0) == (flo < 0):
            lo = t
        else:
            hi = t
        df = (3 * a * t + 2 * b) * t + c
        tn = t - f / df if df != 0.0 else 0.5 * (lo + hi)
        if not (lo < tn < hi):
            tn = 0.5 * (lo + hi)
        if abs(tn - t) < 1e-15 or hi - lo < 1e-15:
            return tn
        t = tn
    return t


@numba.njit(cache=True, nogil=True)
def _roots01(a, b, c, d, out, pts):
    """All roots of the cubic in [0, 1], ascending, into ``out``; returns the count (spec §3.6.3).

    ``pts`` is a scratch array of 4 floats (the interval ends split at the critical points).
    """
    scale = abs(a) + abs(b) + abs(c) + abs(d)
    if scale == 0.0 or _culled(a, b, c, d):
        return 0
    eps = 1e-13 * scale
    npts = 1
    pts[0] = 0.0
    qa, qb, qc = 3 * a, 2 * b, c
    if abs(qa) > 1e-300:
        disc = qb * qb - 4 * qa * qc
        if disc >= 0:
            sq = np.sqrt(disc)
            qq = -0.5 * (qb + (sq if qb >= 0 else -sq))
            r1 = qq / qa
            r2 = qc / qq if qq != 0 else r1
            if r1 > r2:
                r1, r2 = r2, r1
            if 0 < r1 < 1:
                pts[npts] = r1
                npts += 1
            if 0 < r2 < 1 and r2 != r1:
                pts[npts] = r2
                npts += 1
    elif abs(qb) > 1e-300:
        r1 = -qc / qb
        if 0 < r1 < 1:
            pts[npts] = r1
            npts += 1
    pts[npts] = 1.0
    npts += 1
    m = 0
    for i in range(npts):
        t = pts[i]
        if abs(_horner(a, b, c, d, t)) <= eps and (m == 0 or t - out[m - 1] > 1e-10):
            out[m] = t
            m += 1
        if i + 1 < npts:
            lo, hi = pts[i], pts[i + 1]
            flo, fhi = _horner(a, b, c, d, lo), _horner(a, b, c, d, hi)
            if abs(flo) > eps and abs(fhi) > eps and (flo < 0) != (fhi < 0):
                r = _rtsafe(a, b, c, d, lo, hi, flo)
                if m == 0 or r - out[m - 1] > 1e-10:
                    out[m] = r
                    m += 1
    return m


@numba.njit(cache=True, nogil=True)
def _vt_inside_s(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz, tol):
    """Barycentric inside test of p in triangle abc (Eq. B.7)."""
    r_num, s_num, den = barycentric_nb(bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az,
                                       px - ax, py - ay, pz - az)
    if den <= 1e-300:
        return False
    r = r_num / den
    s = s_num / den
    return r >= -tol and s >= -tol and r + s <= 1 + tol


@numba.njit(cache=True, nogil=True)
def _seg_dist_s(p0x, p0y, p0z, p1x, p1y, p1z, q0x, q0y, q0z, q1x, q1y, q1z):
    """Minimum distance between segments p0p1 and q0q1 (App. B.3, robust clamped form)."""
    d1x, d1y, d1z = p1x - p0x, p1y - p0y, p1z - p0z
    d2x, d2y, d2z = q1x - q0x, q1y - q0y, q1z - q0z
    rx, ry, rz = p0x - q0x, p0y - q0y, p0z - q0z
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    if a <= 1e-300 and e <= 1e-300:
        return np.sqrt(rx * rx + ry * ry + rz * rz)
    if a <= 1e-300:
        s = 0.0
        t = min(max(f / e, 0.0), 1.0)
    else:
        c = d1x * rx + d1y * ry + d1z * rz
        if e <= 1e-300:
            t = 0.0
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = d1x * d2x + d1y * d2y + d1z * d2z
            den = a * e - b * b
            s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 1e-300 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    dx = rx + d1x * s - d2x * t
    dy = ry + d1y * s - d2y * t
    dz = rz + d1z * s - d2z * t
    return np.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True, nogil=True)
def _side_s(q, a, b, c):
    """(q - a) . ((b - a) x (c - a)) for rows q, a, b, c of a (., 3) array view."""
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    return ((q[0] - a[0]) * (uy * vz - uz * vy) + (q[1] - a[1]) * (uz * vx - ux * vz)
            + (q[2] - a[2]) * (ux * vy - uy * vx))


@numba.njit(cache=True, nogil=True)
def _narrow_kernel(x0, x1, pairs, m, qel, tel, kind, bary_tol, dist_tol, cons, sides, tfirst):
    """Narrow phase over ``pairs[:m]``; kind 0: VT (qel (Q,1) vertices, tel triangles), 1: EE.

    Writes odd-parity pairs as [free, t0, t1, t2] rows into ``cons`` and returns their count.
    """
    roots = np.empty(4)
    pts = np.empty(4)
    out = 0
    for k in range(m):
        if kind == 0:
            i0 = qel[pairs[k, 0], 0]
            i1, i2, i3 = tel[pairs[k, 1], 0], tel[pairs[k, 1], 1], tel[pairs[k, 1], 2]
        else:
            i0, i1 = qel[pairs[k, 0], 0], qel[pairs[k, 0], 1]
            i2, i3 = tel[pairs[k, 1], 0], tel[pairs[k, 1], 1]
        # start (s) and end (e) coordinates of the four points
        s0x, s0y, s0z = x0[i0, 0], x0[i0, 1], x0[i0, 2]
        s1x, s1y, s1z = x0[i1, 0], x0[i1, 1], x0[i1, 2]
        s2x, s2y, s2z = x0[i2, 0], x0[i2, 1], x0[i2, 2]
        s3x, s3y, s3z = x0[i3, 0], x0[i3, 1], x0[i3, 2]
        d0x, d0y, d0z = x1[i0, 0] - s0x, x1[i0, 1] - s0y, x1[i0, 2] - s0z
        d1x, d1y, d1z = x1[i1, 0] - s1x, x1[i1, 1] - s1y, x1[i1, 2] - s1z
        d2x, d2y, d2z = x1[i2, 0] - s2x, x1[i2, 1] - s2y, x1[i2, 2] - s2z
        d3x, d3y, d3z = x1[i3, 0] - s3x, x1[i3, 1] - s3y, x1[i3, 2] - s3z
        if kind == 0:
            # VT: x = p - a, y = b - a, z = c - a  (p = 0, a = 1, b = 2, c = 3)
            a3, a2, a1, a0 = _cubic_s(s0x - s1x, s0y - s1y, s0z - s1z, d0x - d1x, d0y - d1y, d0z - d1z,
                                      s2x - s1x, s2y - s1y, s2z - s1z, d2x - d1x, d2y - d1y, d2z - d1z,
                                      s3x - s1x, s3y - s1y, s3z - s1z, d3x - d1x, d3y - d1y, d3z - d1z)
        else:
            # EE (Eq. 4.5): edges (a, b) = (0, 1), (c, d) = (2, 3); x = c - a, y = d - a, z = b - a
            a3, a2, a1, a0 = _cubic_s(s2x - s0x, s2y - s0y, s2z - s0z, d2x - d0x, d2y - d0y, d2z - d0z,
                                      s3x - s0x, s3y - s0y, s3z - s0z, d3x - d0x, d3y - d0y, d3z - d0z,
                                      s1x - s0x, s1y - s0y, s1z - s0z, d1x - d0x, d1y - d0y, d1z - d0z)
        nr = _roots01(a3, a2, a1, a0, roots, pts)
        hits = 0
        first = 2.0
        for r in range(nr):
            t = roots[r]
            px, py, pz = s0x + t * d0x, s0y + t * d0y, s0z + t * d0z
            ax, ay, az = s1x + t * d1x, s1y + t * d1y, s1z + t * d1z
            bx, by, bz = s2x + t * d2x, s2y + t * d2y, s2z + t * d2z
            cx, cy, cz = s3x + t * d3x, s3y + t * d3y, s3z + t * d3z
            if kind == 0:
                ok = _vt_inside_s(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz, bary_tol)
            else:
                ok = _seg_dist_s(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz) <= dist_tol
            if ok:
                hits += 1
                first = min(first, t)
        if hits % 2 == 1:            # parity rule (ERRATUM A.15)
            cons[out, 0], cons[out, 1], cons[out, 2], cons[out, 3] = i0, i1, i2, i3
            sd = _side_s(x0[i0], x0[i1], x0[i2], x0[i3])
            if sd == 0.0:
                sd = -_side_s(x1[i0], x1[i1], x1[i2], x1[i3])
            sides[out] = 1.0 if sd >= 0 else -1.0
            tfirst[out] = first
            out += 1
    return out


# ---------------------------------------------------------------------------------------------------------
# Collision constraints


@numba.njit(cache=True, nogil=True, inline="always")
def _correct(p, i, lam_w, gx, gy, gz):
    """Move vertex ``i`` by ``-lam_w * grad`` (``lam_w``: the multiplier times the vertex's inverse mass)."""
    p[i, 0] -= lam_w * gx
    p[i, 1] -= lam_w * gy
    p[i, 2] -= lam_w * gz


@numba.njit(cache=True, nogil=True)
def _project_collision(p, w, cons, sides, h, k, iterations):
    for _ in range(iterations):
        for c in range(cons.shape[0]):
            iq, ia, ib, ic = cons[c, 0], cons[c, 1], cons[c, 2], cons[c, 3]
            s = sides[c]
            ax, ay, az = p[ia, 0], p[ia, 1], p[ia, 2]
            ux, uy, uz = p[ib, 0] - ax, p[ib, 1] - ay, p[ib, 2] - az          # b - a
            vx, vy, vz = p[ic, 0] - ax, p[ic, 1] - ay, p[ic, 2] - az          # c - a
            Nx, Ny, Nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            nN = np.sqrt(Nx * Nx + Ny * Ny + Nz * Nz)
            if nN < 1e-300:
                continue
            nx, ny, nz = Nx / nN, Ny / nN, Nz / nN
            rx, ry, rz = p[iq, 0] - ax, p[iq, 1] - ay, p[iq, 2] - az
            rn = rx * nx + ry * ny + rz * nz
            C = s * rn - h                                # Eq. 4.6 / 4.7
            if C >= 0:
                continue
            px, py, pz = rx - rn * nx, ry - rn * ny, rz - rn * nz      # r projected into the plane
            gqx, gqy, gqz = s * nx, s * ny, s * nz
            gbx = s * (vy * pz - vz * py) / nN                          # s (c - a) x rp / |N|
            gby = s * (vz * px - vx * pz) / nN
            gbz = s * (vx * py - vy * px) / nN
            gcx = s * (py * uz - pz * uy) / nN                          # s rp x (b - a) / |N|
            gcy = s * (pz * ux - px * uz) / nN
            gcz = s * (px * uy - py * ux) / nN
            gax, gay, gaz = -(gqx + gbx + gcx), -(gqy + gby + gcy), -(gqz + gbz + gcz)
            den = (w[iq] * (gqx * gqx + gqy * gqy + gqz * gqz) + w[ia] * (gax * gax + gay * gay + gaz * gaz)
                   + w[ib] * (gbx * gbx + gby * gby + gbz * gbz) + w[ic] * (gcx * gcx + gcy * gcy + gcz * gcz))
            if den < 1e-300:
                continue
            lam = k * C / den
            # Step limiter [INFERRED]: on a sliver triangle the in-plane gradients of b and c are huge;
            # never move a vertex by more than twice the violation (the iterations finish the job).
            gm = max(w[iq] * np.sqrt(gqx * gqx + gqy * gqy + gqz * gqz), w[ia] * np.sqrt(gax * gax + gay * gay + gaz * gaz),
                     w[ib] * np.sqrt(gbx * gbx + gby * gby + gbz * gbz), w[ic] * np.sqrt(gcx * gcx + gcy * gcy + gcz * gcz))
            if abs(lam) * gm > 2.0 * abs(C):
                lam *= 2.0 * abs(C) / (abs(lam) * gm)
            _correct(p, iq, lam * w[iq], gqx, gqy, gqz)
            _correct(p, ia, lam * w[ia], gax, gay, gaz)
            _correct(p, ib, lam * w[ib], gbx, gby, gbz)
            _correct(p, ic, lam * w[ic], gcx, gcy, gcz)



# ---------------------------------------------------------------------------------------------------------
# Static intersection check (sanity check, V23)


@numba.njit(cache=True, nogil=True)
def _seg_tri_count(x, pairs, edges, faces):
    cnt = 0
    for k in range(pairs.shape[0]):
        e = pairs[k, 0]
        f = pairs[k, 1]
        i0, i1 = edges[e, 0], edges[e, 1]
        ia, ib, ic = faces[f, 0], faces[f, 1], faces[f, 2]
        d0 = _side_s(x[i0], x[ia], x[ib], x[ic])
        d1 = _side_s(x[i1], x[ia], x[ib], x[ic])
        if (d0 > 0 and d1 > 0) or (d0 < 0 and d1 < 0) or d0 == d1:
            continue
        t = d0 / (d0 - d1)
        if _vt_inside_s(x[i0, 0] + t * (x[i1, 0] - x[i0, 0]), x[i0, 1] + t * (x[i1, 1] - x[i0, 1]),
                        x[i0, 2] + t * (x[i1, 2] - x[i0, 2]), x[ia, 0], x[ia, 1], x[ia, 2],
                        x[ib, 0], x[ib, 1], x[ib, 2], x[ic, 0], x[ic, 1], x[ic, 2], 0.0):
            cnt += 1
    return cnt

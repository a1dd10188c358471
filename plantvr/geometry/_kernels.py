"""Hot loops of the tree geometry (spec 000_treewand §3.1–§3.3, §3.5): numba kernels and their numpy twins.

Every ``_x_numba`` kernel has a readable ``_x_numpy`` twin with the same signature and results; the tests
assert their equality on seeded input (CONVENTIONS, numba). Kernels do no I/O and allocate only scratch.

Segment record layout (the 20-float patch of spec §3.5, ERRATUM A.12: radii added)::

    0:3 P0   3:6 P1   6:9 P2   9:12 bx(0)   12:15 bx(1)   15 w   16 t0   17 t1   18 r0   19 r2
"""
from __future__ import annotations

import math

import numba
import numpy as np

from plantvr._threading import parallel_region

REC_P0, REC_P1, REC_P2, REC_BX0, REC_BX1 = 0, 3, 6, 9, 12
REC_W, REC_T0, REC_T1, REC_R0, REC_R2 = 15, 16, 17, 18, 19
REC_SIZE = 20
CAP_START, CAP_END = 1, 2
_EPS = 1e-12


# ---------------------------------------------------------------------------------------------------------
# small vector helpers (numba-compiled, also callable from Python)
@numba.njit(cache=True, nogil=True)
def _perp(d):
    """A unit vector perpendicular to unit ``d``, from the world axis least aligned with it."""
    ax = np.abs(d)
    e = np.zeros(3)
    if ax[0] <= ax[1] and ax[0] <= ax[2]:
        e[0] = 1.0
    elif ax[1] <= ax[2]:
        e[1] = 1.0
    else:
        e[2] = 1.0
    p = e - (e[0] * d[0] + e[1] * d[1] + e[2] * d[2]) * d
    return p / math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])


@numba.njit(cache=True, nogil=True)
def _rotate_between(v, a, b):
    """Rotate ``v`` by the rotation about â×b̂ that takes unit ``a`` to unit ``b`` (Eqs. 10.2–10.5)."""
    kx = a[1] * b[2] - a[2] * b[1]
    ky = a[2] * b[0] - a[0] * b[2]
    kz = a[0] * b[1] - a[1] * b[0]
    kn = math.sqrt(kx * kx + ky * ky + kz * kz)
    if kn < _EPS:                       # collinear: theta = 0 (spec §3.2 [INFERRED])
        return v.copy()
    kx /= kn
    ky /= kn
    kz /= kn
    c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]       # Eq. 10.3
    c = min(1.0, max(-1.0, c))
    s = math.sqrt(1.0 - c * c)                        # Eq. 10.4
    kv = kx * v[0] + ky * v[1] + kz * v[2]
    out = np.empty(3)
    out[0] = v[0] * c + (ky * v[2] - kz * v[1]) * s + kx * kv * (1.0 - c)   # Eq. 10.2
    out[1] = v[1] * c + (kz * v[0] - kx * v[2]) * s + ky * kv * (1.0 - c)
    out[2] = v[2] * c + (kx * v[1] - ky * v[0]) * s + kz * kv * (1.0 - c)
    return out


def _unit(v):
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------------------------------------------------
# TreeUnfold: effective liveness, main child, start frames, texture coordinate at each internode midpoint
@numba.njit(cache=True, nogil=True)
def _rot_scalar(vx, vy, vz, ax, ay, az, bx, by, bz):
    """Allocation-free :func:`_rotate_between` on scalars (Eqs. 10.2–10.5)."""
    kx = ay * bz - az * by
    ky = az * bx - ax * bz
    kz = ax * by - ay * bx
    kn = math.sqrt(kx * kx + ky * ky + kz * kz)
    if kn < _EPS:
        return vx, vy, vz
    kx /= kn
    ky /= kn
    kz /= kn
    c = min(1.0, max(-1.0, ax * bx + ay * by + az * bz))
    s = math.sqrt(1.0 - c * c)
    kv = kx * vx + ky * vy + kz * vz
    return (vx * c + (ky * vz - kz * vy) * s + kx * kv * (1.0 - c),
            vy * c + (kz * vx - kx * vz) * s + ky * kv * (1.0 - c),
            vz * c + (kx * vy - ky * vx) * s + kz * kv * (1.0 - c))


@numba.njit(cache=True, nogil=True)
def _unfold_numba(pos, parent, alive, main_child, rate):
    n = pos.shape[0]
    eff = np.zeros(n, np.bool_)
    first = np.full(n, -1, np.int64)
    frame = np.zeros((n, 3))
    tmid = np.zeros(n)
    axis = np.full(n, -1, np.int64)
    dirs = np.zeros((n, 3))
    half = np.zeros(n)
    for c in range(n):
        p = parent[c]
        eff[c] = alive[c] and (p < 0 or eff[p])
        if eff[c] and p >= 0 and first[p] < 0:
            first[p] = c
    main = first.copy()
    if main_child.shape[0] == n:
        for i in range(n):
            m = main_child[i]
            main[i] = m if (m >= 0 and eff[m] and parent[m] == i) else -1
    for c in range(n):
        p = parent[c]
        if p < 0 or not eff[c]:
            continue
        dx = pos[c, 0] - pos[p, 0]
        dy = pos[c, 1] - pos[p, 1]
        dz = pos[c, 2] - pos[p, 2]
        ln = math.sqrt(dx * dx + dy * dy + dz * dz)
        dirs[c, 0] = dx / ln
        dirs[c, 1] = dy / ln
        dirs[c, 2] = dz / ln
        half[c] = 0.5 * ln
        if parent[p] < 0:                 # first internode: straight root half, first frame any perpendicular
            frame[c] = _perp(dirs[c])
            tmid[c] = rate * half[c]
        else:                             # sequential start frame: rotate by angle(N'(0), N'(1))  (A.10)
            fx, fy, fz = _rot_scalar(frame[p, 0], frame[p, 1], frame[p, 2], dirs[p, 0], dirs[p, 1], dirs[p, 2],
                                     dirs[c, 0], dirs[c, 1], dirs[c, 2])
            frame[c, 0] = fx
            frame[c, 1] = fy
            frame[c, 2] = fz
            tmid[c] = tmid[p] + rate * (half[p] + half[c])
        axis[c] = axis[p] if (main[p] == c and axis[p] >= 0) else c
    return eff, main, frame, tmid, axis


def _unfold_numpy(pos, parent, alive, main_child, rate):
    """Readable twin of :func:`_unfold_numba` (plain Python loop over nodes in index order)."""
    n = len(pos)
    eff = np.zeros(n, bool)
    main = np.full(n, -1, np.int64)
    for c in range(n):
        p = parent[c]
        eff[c] = bool(alive[c]) and (p < 0 or eff[p])
        if eff[c] and p >= 0 and main[p] < 0:
            main[p] = c
    if len(main_child) == n:
        main = np.array([m if (m >= 0 and eff[m] and parent[m] == i) else -1 for i, m in enumerate(main_child)],
                        np.int64)
    frame = np.zeros((n, 3))
    tmid = np.zeros(n)
    axis = np.full(n, -1, np.int64)
    for c in range(n):
        p = parent[c]
        if p < 0 or not eff[c]:
            continue
        d = _unit(pos[c] - pos[p])
        if parent[p] < 0:
            frame[c] = _perp(d)
            tmid[c] = rate * np.linalg.norm(0.5 * (pos[c] - pos[p]))
        else:
            q = parent[p]
            frame[c] = _rotate_between(frame[p], _unit(pos[p] - pos[q]), d)
            tmid[c] = tmid[p] + rate * (np.linalg.norm(0.5 * (pos[p] - pos[q])) + np.linalg.norm(0.5 * (pos[c] - pos[p])))
        axis[c] = axis[p] if (main[p] == c and axis[p] >= 0) else c
    return eff, main, frame, tmid, axis


# ---------------------------------------------------------------------------------------------------------
# Generalized-cylinder evaluation of segments (Eqs. 10.1–10.10, 10.13)
def _trig_table(nmax: int = 64) -> np.ndarray:
    """cos/sin of 2πi/n for every ring size n ≤ nmax: ``T[n, i] = (cos, sin)`` (i = n wraps to 0)."""
    T = np.zeros((nmax + 1, nmax + 1, 2))
    for n in range(1, nmax + 1):
        for i in range(n + 1):
            ang = 2.0 * math.pi * (0 if i == n else i) / n
            T[n, i, 0] = math.cos(ang)
            T[n, i, 1] = math.sin(ang)
    return T


_TRIG = _trig_table()


@numba.njit(cache=True, nogil=True)
def _eval_one(s, rec, cnt, ksteps, nodes, caps, repeat, v0, f0, V, NRM, UV, NID, F, full=True):
    """Evaluate segment ``s`` into the buffers from vertex ``v0`` and face ``f0`` (scalar, allocation-free).

    ``full=False`` writes only positions and normals (a radius-only change keeps UVs, node ids and faces).
    """
    r = rec[s]
    K = ksteps
    w = r[REC_W]
    p0x, p0y, p0z = r[0], r[1], r[2]
    p1x, p1y, p1z = r[3], r[4], r[5]
    p2x, p2y, p2z = r[6], r[7], r[8]
    b0x, b0y, b0z = r[9], r[10], r[11]
    ax_, ay_, az_ = p1x - p0x, p1y - p0y, p1z - p0z
    bx_, by_, bz_ = p2x - p1x, p2y - p1y, p2z - p1z
    la = math.sqrt(ax_ * ax_ + ay_ * ay_ + az_ * az_)
    lb = math.sqrt(bx_ * bx_ + by_ * by_ + bz_ * bz_)
    if la > _EPS:
        t0x, t0y, t0z = ax_ / la, ay_ / la, az_ / la
    else:
        cx_, cy_, cz_ = p2x - p0x, p2y - p0y, p2z - p0z
        cn = max(_EPS, math.sqrt(cx_ * cx_ + cy_ * cy_ + cz_ * cz_))
        t0x, t0y, t0z = cx_ / cn, cy_ / cn, cz_ / cn
    t_start = r[REC_T0]
    t_end = r[REC_T1]
    r0 = r[REC_R0]
    r2 = r[REC_R2]
    dtot = la + lb
    vi = v0
    fi = f0
    ring_base_prev = 0
    n_prev = 0
    tfx = tfy = tfz = 0.0
    tlx = tly = tlz = 0.0
    for j in range(K + 1):
        u = j / K
        om = 1.0 - u
        c0 = om * om
        c1 = 2.0 * om * u * w
        c2 = u * u
        den = c0 + c1 + c2
        nx_ = c0 * p0x + c1 * p1x + c2 * p2x
        ny_ = c0 * p0y + c1 * p1y + c2 * p2y
        nz_ = c0 * p0z + c1 * p1z + c2 * p2z
        px, py, pz = nx_ / den, ny_ / den, nz_ / den                    # Eq. 10.1 (A.9)
        d0 = -2.0 * om
        d1 = 2.0 * (1.0 - 2.0 * u) * w
        d2 = 2.0 * u
        dden = d0 + d1 + d2
        den2 = den * den
        dx = ((d0 * p0x + d1 * p1x + d2 * p2x) * den - nx_ * dden) / den2
        dy = ((d0 * p0y + d1 * p1y + d2 * p2y) * den - ny_ * dden) / den2
        dz = ((d0 * p0z + d1 * p1z + d2 * p2z) * den - nz_ * dden) / den2
        speed = math.sqrt(dx * dx + dy * dy + dz * dz)
        if speed > _EPS:
            tx, ty, tz = dx / speed, dy / speed, dz / speed
        else:
            tx, ty, tz = t0x, t0y, t0z
        qx, qy, qz = _rot_scalar(b0x, b0y, b0z, t0x, t0y, t0z, tx, ty, tz)   # Eq. 10.6 with N'(u) (A.10)
        bt = qx * tx + qy * ty + qz * tz
        qx -= bt * tx
        qy -= bt * ty
        qz -= bt * tz
        bn = math.sqrt(qx * qx + qy * qy + qz * qz)
        if bn < 1e-9:
            tv = np.empty(3)
            tv[0] = tx
            tv[1] = ty
            tv[2] = tz
            pp = _perp(tv)
            qx, qy, qz = pp[0], pp[1], pp[2]
        else:
            qx, qy, qz = qx / bn, qy / bn, qz / bn
        yx = qy * tz - qz * ty                                          # Eq. 10.7 with the tangent (A.11)
        yy = qz * tx - qx * tz
        yz = qx * ty - qy * tx
        sm = 3.0 * u * u - 2.0 * u * u * u                              # Eq. 10.8
        rad = (1.0 - sm) * r0 + sm * r2                                 # Eq. 10.9
        drds = (r2 - r0) * 6.0 * u * om / max(speed, _EPS)
        inv = 1.0 / math.sqrt(1.0 + drds * drds)                        # |radial - drds t| (radial ⟂ t)
        if dtot > _EPS:                                                 # Eq. 10.13 (A.12b)
            dd = (2.0 * u * om * w * la + u * u * dtot) / den
            tt = t_start + (t_end - t_start) * dd / dtot
        else:
            tt = t_start + (t_end - t_start) * u
        nid = nodes[s, 0] if u < 0.5 else nodes[s, 1]
        n = cnt[s, j]
        base = vi
        for i in range(n + 1):
            ca = _TRIG[n, i, 0]
            sa = _TRIG[n, i, 1]
            rx = ca * qx + sa * yx
            ry = ca * qy + sa * yy
            rz = ca * qz + sa * yz
            V[vi, 0] = px + rad * rx                                    # Eq. 10.10, theta = 2 pi
            V[vi, 1] = py + rad * ry
            V[vi, 2] = pz + rad * rz
            NRM[vi, 0] = (rx - drds * tx) * inv
            NRM[vi, 1] = (ry - drds * ty) * inv
            NRM[vi, 2] = (rz - drds * tz) * inv
            if full:
                UV[vi, 0] = repeat * i / n
                UV[vi, 1] = tt
                NID[vi] = nid
            vi += 1
        if j > 0 and full:                                              # zip the band between two rings
            A = ring_base_prev
            na = n_prev
            ia = 0
            ib = 0
            while ia < na or ib < n:
                if ib == n or (ia < na and (ia + 1) * n <= (ib + 1) * na):
                    F[fi, 0] = A + ia
                    F[fi, 1] = base + ib
                    F[fi, 2] = A + ia + 1
                    ia += 1
                else:
                    F[fi, 0] = A + ia
                    F[fi, 1] = base + ib
                    F[fi, 2] = base + ib + 1
                    ib += 1
                fi += 1
        if j == 0:
            tfx, tfy, tfz = tx, ty, tz
        if j == K:
            tlx, tly, tlz = tx, ty, tz
        ring_base_prev = base
        n_prev = n
    # caps: a fan on duplicated ring vertices with the axial normal
    for which in range(2):
        if which == 0 and not (caps[s] & 1):
            continue
        if which == 1 and not (caps[s] & 2):
            continue
        if which == 0:
            ring = v0
            n = cnt[s, 0]
            gx, gy, gz = -tfx, -tfy, -tfz
        else:
            ring = ring_base_prev
            n = cnt[s, K]
            gx, gy, gz = tlx, tly, tlz
        center = vi
        cx = 0.0
        cy = 0.0
        cz = 0.0
        for i in range(n):
            cx += V[ring + i, 0]
            cy += V[ring + i, 1]
            cz += V[ring + i, 2]
        V[vi, 0] = cx / n
        V[vi, 1] = cy / n
        V[vi, 2] = cz / n
        NRM[vi, 0] = gx
        NRM[vi, 1] = gy
        NRM[vi, 2] = gz
        if full:
            UV[vi, 0] = 0.5 * repeat
            UV[vi, 1] = UV[ring, 1]
            NID[vi] = NID[ring]
        vi += 1
        for i in range(n):
            V[vi, 0] = V[ring + i, 0]
            V[vi, 1] = V[ring + i, 1]
            V[vi, 2] = V[ring + i, 2]
            NRM[vi, 0] = gx
            NRM[vi, 1] = gy
            NRM[vi, 2] = gz
            if full:
                UV[vi, 0] = UV[ring + i, 0]
                UV[vi, 1] = UV[ring + i, 1]
                NID[vi] = NID[ring]
            vi += 1
        if not full:
            continue
        for i in range(n):
            i1 = center + 1 + i
            i2 = center + 1 + (i + 1) % n
            F[fi, 0] = center
            F[fi, 1], F[fi, 2] = (i1, i2) if which == 0 else (i2, i1)
            fi += 1


@numba.njit(cache=True, nogil=True, parallel=True)
def _eval_segments_numba(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F):
    for q in numba.prange(seg_idx.shape[0]):
        s = seg_idx[q]
        _eval_one(s, rec, cnt, ksteps, nodes, caps, repeat, v_off[s], f_off[s], V, NRM, UV, NID, F)


def _eval_segments_numpy(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F):
    """Readable twin of :func:`_eval_segments_numba`: numpy per ring, Python per segment."""
    for s in seg_idx:
        r = rec[s]
        p0, p1, p2, bx0 = r[0:3], r[3:6], r[6:9], r[9:12]
        w, t_start, t_end, r0, r2 = r[REC_W], r[REC_T0], r[REC_T1], r[REC_R0], r[REC_R2]
        la, lb = np.linalg.norm(p1 - p0), np.linalg.norm(p2 - p1)
        t0 = (p1 - p0) / la if la > _EPS else (p2 - p0) / max(_EPS, np.linalg.norm(p2 - p0))
        vi, fi = int(v_off[s]), int(f_off[s])
        bases, tangents = [], []
        for j in range(ksteps + 1):
            u = j / ksteps
            bern = np.array([(1 - u) ** 2, 2 * (1 - u) * u * w, u * u])
            dbern = np.array([-2 * (1 - u), 2 * (1 - 2 * u) * w, 2 * u])
            num, den = bern @ np.stack([p0, p1, p2]), bern.sum()
            der = (dbern @ np.stack([p0, p1, p2]) * den - num * dbern.sum()) / den ** 2
            speed = np.linalg.norm(der)
            tg = der / speed if speed > _EPS else t0
            bx = _rotate_between(bx0, t0, tg)
            bx = bx - (bx @ tg) * tg
            bx = _perp(tg) if np.linalg.norm(bx) < 1e-9 else bx / np.linalg.norm(bx)
            by = np.cross(bx, tg)
            sm = 3 * u * u - 2 * u ** 3
            rad = (1 - sm) * r0 + sm * r2
            drds = (r2 - r0) * 6 * u * (1 - u) / max(speed, _EPS)
            dd = (2 * u * (1 - u) * w * la + u * u * (la + lb)) / den
            tt = t_start + (t_end - t_start) * (dd / (la + lb) if la + lb > _EPS else u)
            n = int(cnt[s, j])
            ang = 2 * np.pi * (np.arange(n + 1) % n) / n
            radial = np.cos(ang)[:, None] * bx + np.sin(ang)[:, None] * by
            nrm = radial - drds * tg
            V[vi:vi + n + 1] = num / den + rad * radial
            NRM[vi:vi + n + 1] = nrm / np.linalg.norm(nrm, axis=1)[:, None]
            UV[vi:vi + n + 1, 0] = repeat * np.arange(n + 1) / n
            UV[vi:vi + n + 1, 1] = tt
            NID[vi:vi + n + 1] = nodes[s, 0] if u < 0.5 else nodes[s, 1]
            if j > 0:
                fi = _zip_numpy(bases[-1], int(cnt[s, j - 1]), vi, n, F, fi)
            bases.append(vi)
            tangents.append(tg)
            vi += n + 1
        for which, flag in ((0, CAP_START), (1, CAP_END)):
            if not caps[s] & flag:
                continue
            ring, n = (bases[0], int(cnt[s, 0])) if which == 0 else (bases[-1], int(cnt[s, ksteps]))
            nrm = (-tangents[0]) if which == 0 else tangents[-1]
            V[vi] = V[ring:ring + n].mean(axis=0)
            V[vi + 1:vi + 1 + n] = V[ring:ring + n]
            NRM[vi:vi + 1 + n] = nrm
            UV[vi] = (0.5 * repeat, UV[ring, 1])
            UV[vi + 1:vi + 1 + n] = UV[ring:ring + n]
            NID[vi:vi + 1 + n] = NID[ring]
            i1 = vi + 1 + np.arange(n)
            i2 = vi + 1 + (np.arange(n) + 1) % n
            tri = np.stack([np.full(n, vi), i1, i2] if which == 0 else [np.full(n, vi), i2, i1], axis=1)
            F[fi:fi + n] = tri
            fi += n
            vi += n + 1


def _zip_numpy(A, na, B, nb, F, fi):
    ia = ib = 0
    while ia < na or ib < nb:
        if ib == nb or (ia < na and (ia + 1) * nb <= (ib + 1) * na):
            F[fi] = (A + ia, B + ib, A + ia + 1)
            ia += 1
        else:
            F[fi] = (A + ia, B + ib, B + ib + 1)
            ib += 1
        fi += 1
    return fi


@numba.njit(cache=True, nogil=True, parallel=True)
def _copy_blocks_numba(src_v0, dst_v0, nv, src_f0, dst_f0, nf, V0, N0, UV0, ID0, F0, V, NRM, UV, NID, F):
    """Copy unchanged segments' vertex and face blocks from an old layout to a new one (faces re-based)."""
    for q in numba.prange(src_v0.shape[0]):
        a = src_v0[q]
        b = dst_v0[q]
        for k in range(nv[q]):
            for c in range(3):
                V[b + k, c] = V0[a + k, c]
                NRM[b + k, c] = N0[a + k, c]
            UV[b + k, 0] = UV0[a + k, 0]
            UV[b + k, 1] = UV0[a + k, 1]
            NID[b + k] = ID0[a + k]
        shift = b - a
        fa = src_f0[q]
        fb = dst_f0[q]
        for k in range(nf[q]):
            for c in range(3):
                F[fb + k, c] = F0[fa + k, c] + shift


# ---------------------------------------------------------------------------------------------------------
# Segment records straight from the tree (keys 2c for the segment ending at internode c's midpoint, 2i+1 for
# the tip half of terminal node i; emitted in key order)
@numba.njit(cache=True, nogil=True)
def _records_numba(pos, parent, radius, eff, main, frame, tmid, axis, w, rate):
    n = pos.shape[0]
    has_child = np.zeros(n, np.bool_)
    for c in range(n):
        if eff[c] and parent[c] >= 0:
            has_child[parent[c]] = True
    S = 0
    for c in range(n):
        if eff[c] and parent[c] >= 0:
            S += 1 if has_child[c] else 2
    rec = np.empty((S, REC_SIZE))
    nodes = np.empty((S, 2), np.int64)
    keys = np.empty(S, np.int64)
    ax = np.empty(S, np.int64)
    caps = np.zeros(S, np.uint8)
    s = 0
    for c in range(n):
        p = parent[c]
        if p < 0 or not eff[c]:
            continue
        root = parent[p] < 0
        for k in range(3):
            mc = 0.5 * (pos[p, k] + pos[c, k])
            if root:
                rec[s, k] = pos[p, k]
                rec[s, 3 + k] = 0.5 * (pos[p, k] + mc)
                rec[s, 9 + k] = frame[c, k]
            else:
                rec[s, k] = 0.5 * (pos[parent[p], k] + pos[p, k])
                rec[s, 3 + k] = pos[p, k]
                rec[s, 9 + k] = frame[p, k]
            rec[s, 6 + k] = mc
            rec[s, 12 + k] = frame[c, k]
        rec[s, REC_W] = w
        rec[s, REC_T0] = 0.0 if root else tmid[p]
        rec[s, REC_T1] = tmid[c]
        rec[s, REC_R0] = radius[c] if root else radius[p]
        rec[s, REC_R2] = radius[c]
        nodes[s, 0] = c if root else p
        nodes[s, 1] = c
        keys[s] = 2 * c
        ax[s] = axis[c]
        caps[s] = CAP_START if (root or main[p] != c) else 0
        s += 1
        if not has_child[c]:
            ln = 0.0
            for k in range(3):
                mc = 0.5 * (pos[p, k] + pos[c, k])
                rec[s, k] = mc
                rec[s, 3 + k] = 0.5 * (mc + pos[c, k])
                rec[s, 6 + k] = pos[c, k]
                rec[s, 9 + k] = frame[c, k]
                rec[s, 12 + k] = frame[c, k]
                ln += (pos[c, k] - mc) ** 2
            rec[s, REC_W] = w
            rec[s, REC_T0] = tmid[c]
            rec[s, REC_T1] = tmid[c] + rate * math.sqrt(ln)
            rec[s, REC_R0] = radius[c]
            rec[s, REC_R2] = radius[c]
            nodes[s, 0] = c
            nodes[s, 1] = c
            keys[s] = 2 * c + 1
            ax[s] = axis[c]
            caps[s] = CAP_END
            s += 1
    return rec, nodes, keys, ax, caps


@numba.njit(cache=True, nogil=True)
def _eval_segments_serial(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F,
                          full=True):
    for q in range(seg_idx.shape[0]):
        s = seg_idx[q]
        _eval_one(s, rec, cnt, ksteps, nodes, caps, repeat, v_off[s], f_off[s], V, NRM, UV, NID, F, full)


@numba.njit(cache=True, nogil=True, parallel=True)
def _eval_geometry_numba(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F):
    """Positions and normals only of the segments ``seg_idx`` (radius-only changes), in parallel."""
    for q in numba.prange(seg_idx.shape[0]):
        s = seg_idx[q]
        _eval_one(s, rec, cnt, ksteps, nodes, caps, repeat, v_off[s], f_off[s], V, NRM, UV, NID, F, False)


PARALLEL_MIN_SEGMENTS = 4096
"""Below this many segments an update runs on one thread: waking the pool costs more than it saves, and on a
busy machine a descheduled worker stalls the whole loop."""


def copy_blocks(src_v0, dst_v0, nv, src_f0, dst_f0, nf, V0, N0, UV0, ID0, F0, V, NRM, UV, NID, F):
    """:func:`_copy_blocks_numba` inside :func:`~plantvr._threading.parallel_region`."""
    with parallel_region():
        _copy_blocks_numba(src_v0, dst_v0, nv, src_f0, dst_f0, nf, V0, N0, UV0, ID0, F0, V, NRM, UV, NID, F)


def eval_segments(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F,
                  full: bool = True):
    """Evaluate the segments ``seg_idx`` into the buffers; threads only when there is enough work.

    ``full=False``: positions and normals only (UVs, node ids and faces of those blocks are kept).
    """
    if len(seg_idx) < PARALLEL_MIN_SEGMENTS:
        _eval_segments_serial(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F,
                              full)
    elif full:
        with parallel_region():
            _eval_segments_numba(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F)
    else:
        with parallel_region():
            _eval_geometry_numba(rec, cnt, ksteps, nodes, caps, seg_idx, v_off, f_off, repeat, V, NRM, UV, NID, F)


def _records_numpy(pos, parent, radius, eff, main, frame, tmid, axis, bezier_w, bark_rate):
    """Readable, vectorised twin of :func:`_records_numba`."""
    n = len(pos)
    has_parent = parent >= 0
    # incoming segment of every live internode c
    c = np.flatnonzero(eff & has_parent)
    p = parent[c]
    root = parent[p] < 0
    q = np.where(root, p, parent[p])
    mid_p = 0.5 * (pos[q] + pos[p])
    mid_c = 0.5 * (pos[p] + pos[c])
    P0 = np.where(root[:, None], pos[p], mid_p)
    P1 = np.where(root[:, None], 0.5 * (pos[p] + mid_c), pos[p])
    rin = np.empty((len(c), REC_SIZE))
    rin[:, 0:3], rin[:, 3:6], rin[:, 6:9] = P0, P1, mid_c
    rin[:, 9:12] = np.where(root[:, None], frame[c], frame[p])
    rin[:, 12:15] = frame[c]
    rin[:, 15] = bezier_w
    rin[:, 16] = np.where(root, 0.0, tmid[p])
    rin[:, 17] = tmid[c]
    rin[:, 18] = np.where(root, radius[c], radius[p])
    rin[:, 19] = radius[c]
    nin = np.stack([np.where(root, c, p), c], axis=1)
    cin = np.where(root | (main[p] != c), CAP_START, 0).astype(np.uint8)
    # tip halves
    has_child = np.zeros(n, bool)
    has_child[parent[eff & has_parent]] = True
    t = np.flatnonzero(eff & has_parent & ~has_child)
    mid_t = 0.5 * (pos[parent[t]] + pos[t])
    rtp = np.empty((len(t), REC_SIZE))
    rtp[:, 0:3], rtp[:, 3:6], rtp[:, 6:9] = mid_t, 0.5 * (mid_t + pos[t]), pos[t]
    rtp[:, 9:12] = rtp[:, 12:15] = frame[t]
    rtp[:, 15] = bezier_w
    rtp[:, 16] = tmid[t]
    rtp[:, 17] = tmid[t] + bark_rate * np.linalg.norm(pos[t] - mid_t, axis=1)
    rtp[:, 18] = rtp[:, 19] = radius[t]
    ntp = np.stack([t, t], axis=1)
    # root-half segments whose internode is also a tip end in a cap too (via the tip segment)
    keys = np.concatenate([2 * c, 2 * t + 1])
    order = np.argsort(keys, kind="stable")
    return (np.concatenate([rin, rtp])[order], np.concatenate([nin, ntp])[order], keys[order],
            np.concatenate([axis[c], axis[t]])[order],
            np.concatenate([cin, np.full(len(t), CAP_END, np.uint8)])[order])


# ---------------------------------------------------------------------------------------------------------
# Slot layout of the incremental mesh (spec §3.5): every segment owns a vertex/face block with slack capacity
@numba.njit(cache=True, nogil=True)
def _counts_numba(rec, sm, tip_radius, lo, hi, caps):
    """Ring counts per ring (LOD of both end radii blended by the smoothstep ``sm``) and block sizes.

    Twin: :func:`plantvr.geometry.mesh.lod_level`, :func:`~plantvr.geometry.mesh.ring_counts` and the block
    sizes of the mesh layout.
    """
    S = rec.shape[0]
    J = sm.shape[0]
    cnt = np.empty((S, J), np.int32)
    nv = np.empty(S, np.int64)
    nf = np.empty(S, np.int64)
    for s in range(S):
        x0 = lo + (hi - lo) * (rec[s, REC_R0] / tip_radius - 1.0) / 49.0
        x1 = lo + (hi - lo) * (rec[s, REC_R2] / tip_radius - 1.0) / 49.0
        n0 = float(np.rint(min(max(x0, float(lo)), float(hi))))
        n1 = float(np.rint(min(max(x1, float(lo)), float(hi))))
        v = 0
        f = 0
        for j in range(J):
            c = np.int32(np.rint((1.0 - sm[j]) * n0 + sm[j] * n1))
            cnt[s, j] = c
            v += c + 1
            if j > 0:
                f += cnt[s, j - 1] + c
        if caps[s] & CAP_START:
            v += cnt[s, 0] + 1
            f += cnt[s, 0]
        if caps[s] & CAP_END:
            v += cnt[s, J - 1] + 1
            f += cnt[s, J - 1]
        nv[s] = v
        nf[s] = f
    return cnt, nv, nf


@numba.njit(cache=True, nogil=True)
def _diff_numba(keys, rec, cnt, nodes, caps, nv, nf, slot_of_key, srec, scnt, snodes, scaps, svcap, sfcap):
    """Match segments to the slots of the previous layout by key.

    Returns ``slot`` (-1: no slot with that key) and ``status``: 0 unchanged, 1 only the radii changed (same
    ring counts: positions and normals are rewritten in place), 2 changed and fits its slot (rewritten in
    place), 3 needs a new slot (new key, or more vertices/faces than the slot's capacity).
    """
    S = keys.shape[0]
    slot = np.full(S, -1, np.int64)
    status = np.zeros(S, np.int8)
    m = slot_of_key.shape[0]
    R = rec.shape[1]
    J = cnt.shape[1]
    for s in range(S):
        k = keys[s]
        sl = slot_of_key[k] if k < m else -1
        slot[s] = sl
        if sl < 0:
            status[s] = 3
            continue
        same = caps[s] == scaps[sl] and nodes[s, 0] == snodes[sl, 0] and nodes[s, 1] == snodes[sl, 1]
        if same:
            for c in range(R):
                if c != REC_R0 and c != REC_R2 and rec[s, c] != srec[sl, c]:
                    same = False
                    break
        if same:
            for j in range(J):
                if cnt[s, j] != scnt[sl, j]:
                    same = False
                    break
        if same:
            status[s] = 0 if (rec[s, REC_R0] == srec[sl, REC_R0] and rec[s, REC_R2] == srec[sl, REC_R2]) else 1
        elif nv[s] <= svcap[sl] and nf[s] <= sfcap[sl]:
            status[s] = 2
        else:
            status[s] = 3
    return slot, status


def _diff_numpy(keys, rec, cnt, nodes, caps, nv, nf, slot_of_key, srec, scnt, snodes, scaps, svcap, sfcap):
    """Readable twin of :func:`_diff_numba`."""
    inmap = keys < len(slot_of_key)
    slot = np.where(inmap, slot_of_key[np.minimum(keys, len(slot_of_key) - 1)], -1).astype(np.int64)
    j = np.maximum(slot, 0)
    geo = np.ones(rec.shape[1], bool)
    geo[[REC_R0, REC_R2]] = False
    same = ((slot >= 0) & (caps == scaps[j]) & np.all(nodes == snodes[j], axis=1)
            & np.all(rec[:, geo] == srec[j][:, geo], axis=1) & np.all(cnt == scnt[j], axis=1))
    same_r = np.all(rec[:, ~geo] == srec[j][:, ~geo], axis=1)
    fits = (slot >= 0) & (nv <= svcap[j]) & (nf <= sfcap[j])
    status = np.where(same, np.where(same_r, 0, 1), np.where(fits, 2, 3)).astype(np.int8)
    return slot, status


@numba.njit(cache=True, nogil=True)
def _fill_slack_numba(v0, nv, vcap, f0, nf, fcap, V, NRM, UV, NID, F):
    """Make the unused tail of each block degenerate: vertices copy the block's first vertex, faces collapse
    onto it (zero area)."""
    for q in range(v0.shape[0]):
        a = v0[q]
        for k in range(a + nv[q], a + vcap[q]):
            for c in range(3):
                V[k, c] = V[a, c]
                NRM[k, c] = NRM[a, c]
            UV[k, 0] = UV[a, 0]
            UV[k, 1] = UV[a, 1]
            NID[k] = NID[a]
        for k in range(f0[q] + nf[q], f0[q] + fcap[q]):
            F[k, 0] = a
            F[k, 1] = a
            F[k, 2] = a


@numba.njit(cache=True, nogil=True)
def _free_numba(v0, vcap, f0, fcap, point, V, NRM, UV, NID, F):
    """Blank freed blocks: vertices at ``point`` with node id -1, faces collapsed onto the first vertex."""
    for q in range(v0.shape[0]):
        a = v0[q]
        for k in range(a, a + vcap[q]):
            for c in range(3):
                V[k, c] = point[c]
            NRM[k, 0] = 0.0
            NRM[k, 1] = 1.0
            NRM[k, 2] = 0.0
            UV[k, 0] = 0.0
            UV[k, 1] = 0.0
            NID[k] = -1
        for k in range(f0[q], f0[q] + fcap[q]):
            F[k, 0] = a
            F[k, 1] = a
            F[k, 2] = a

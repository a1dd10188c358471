"""The turtle's interpretation loop (issue 23, PlantGL ``Turtle``): a numba kernel over op codes and CSR parameters,
and its readable pure-Python twin (the oracle of the kernel test).

Both follow PlantGL's ``turtle.cpp`` step by step: the frame (heading H, left L, up U) starts at H = +Z,
L = -Y, U = +X; ``+``/``-`` rotate H and L about U, ``&``/``^`` rotate H and U about L (``&`` pitches down),
``/``/``\\`` rotate L and U about H (``/`` is PlantGL's ``rollL``), ``|`` is ``left(180)``; tropism bends the
frame toward the tropism vector by ``elasticity`` times the angle between H and it before every ``F`` (length > 0)
and every ``f`` (``Turtle::_tendTo``). Rotations are right-handed (``Matrix3::axisRotation``).

Node model (:class:`~plantvr.types.TreeArrays`): every drawn ``F`` makes a node at its end whose parent is the
turtle's current node; the first ``F`` (and the first after an ``f``) first makes a root node where it starts.
A node's order is its axis's: the first ``F`` after a ``[`` raises the order by one; ``main_child`` is the child
of the same order.
"""
from __future__ import annotations

import math

import numba
import numpy as np

# op codes (0: a module the turtle does not interpret)
NOP, F, FMOVE, LEFT, RIGHT, UP, DOWN, ROLLL, ROLLR, TURN, ROLLVERT, ROLLHORIZ, PUSH, POP = range(14)
INCW, DECW, SETW, INCC, DECC, SETC, CUT, TROPISM, ELASTICITY = range(14, 23)
SPHERE, CIRCLE, SURFACE, GC_START, GC_END, POLY_START, POLY_END, POLY_POINT, QUERY = range(23, 32)
#: issue 33: absolute moves and orientation (``@M``/``MoveTo``, ``MoveRel``, ``LineTo``, ``OLineTo``, ``LineRel``,
#: ``OLineRel``, ``Pinpoint``, ``PinpointRel``, ``@R``/``SetHead``, ``EulerAngles``), ``nF``, the scale
#: (``@D``/``SetScale``, ``@Di``/``MultScale``, ``@Dd``/``DivScale``) and ``@L``/``Label``.
MOVETO, MOVEREL, LINETO, OLINETO, LINEREL, OLINEREL, PINPOINT, PINPOINTREL, SETHEAD, EULER = range(32, 42)
NF, SETSCALE, MULTSCALE, DIVSCALE, LABEL = range(42, 47)
#: ``@B``/``Box`` and ``@b``/``Quad`` (shapes drawn along a step, PlantGL ``Turtle::box`` / ``quad``), ``Frame``.
BOX, QUAD, FRAME = range(47, 50)
#: ``surface(name[, scale])`` / ``~(name[, scale])``: a named surface, the name a str parameter.
SURFACE_NAMED = 50
#: Kinds of the shape records (``sint[:, 0]``): ``@O`` sphere, ``@o`` disc, ``~name`` surface, ``{ }`` polygon
#: (fan, or ear clipping after ``}(1)``, PlantGL's concave test), ``@Gc``/``@Ge`` generalized cylinder; and
#: ``SH_QUERY``, not a shape: the frame at a request module (``?P``, ``?H``, ... of L-Py; issue 33).
SH_SPHERE, SH_CIRCLE, SH_SURFACE, SH_POLYGON, SH_POLYGON_CONCAVE, SH_TUBE, SH_QUERY = range(1, 8)
#: Not a shape either: a text label's frame (``@L``; the text is the module's parameter).
SH_LABEL = 8
#: A box or a quad along a step: its frame at the start, its length, bottom and top half-widths; ``SH_FRAME``
#: (not a shape): a ``Frame`` annotation, its size.
SH_BOX, SH_QUAD, SH_FRAME = 9, 10, 11
#: PlantGL's GEOM_EPSILON.
EPS = 1e-6
#: Warning slots of the kernel: a width below zero, a colour below zero, an elasticity outside [0, 1] (PlantGL
#: warns and keeps the current value); a scale factor of 0 to divide by or a scale beyond +-1e6 (kept too).
IGNORED_WIDTH, IGNORED_COLOR, IGNORED_ELASTICITY, IGNORED_SIZE, IGNORED_SCALE = 0, 1, 2, 3, 4
#: PlantGL's ``scale_multiplier``: ``@Di`` / ``@Dd`` without a parameter multiply / divide the scale by it.
SCALE_MULTIPLIER = 0.5
#: The largest scale component the kernel keeps (``MAX_COORD`` of :mod:`plantvr._validation`).
MAX_SCALE = 1e6
#: ``SetColor(r, g, b[, a])`` (L-Py's custom appearance): colour code ``CUSTOM_COLOR + (r << 16 | g << 8 | b)``,
#: each channel rounded and clipped to 0..255 (the alpha is not kept).
CUSTOM_COLOR = 1 << 32

_NF = 20  # float state per stack frame: pos 3, H 3, L 3, U 3, width, tropism 3, elasticity, scale 3
_NI = 11  # int state per stack frame: current node, order, branch pending, colour, GC on, GC tail, GC count,
#           GC colour, polygon on, polygon colour, colour index
_NS = 18  # float columns of a shape record: position 3, H 3, L 3, U 3, size, bottom and top radius, scale 3


@numba.njit(cache=True, nogil=True, inline="always")
def _rot(vx, vy, vz, kx, ky, kz, c, s):
    """``v`` rotated about the axis ``k`` (normalised here: a frame vector's rounding would otherwise grow at every
    turn, exponentially over a long string) by the angle of cosine ``c``, sine ``s`` (Rodrigues)."""
    n = math.sqrt(kx * kx + ky * ky + kz * kz)
    kx, ky, kz = kx / n, ky / n, kz / n
    d = (kx * vx + ky * vy + kz * vz) * (1.0 - c)
    return (vx * c + (ky * vz - kz * vy) * s + kx * d,
            vy * c + (kz * vx - kx * vz) * s + ky * d,
            vz * c + (kx * vy - ky * vx) * s + kz * d)


@numba.njit(cache=True, nogil=True, inline="always")
def _vec3(args, a, n, x, y, z):
    """The vector of up to 3 module arguments from ``args[a]`` (``n`` of them, maybe more): the default
    ``(x, y, z)`` when there is none, else the given ones and zeros (L-Py's Vector3 from 1 to 3 numbers)."""
    if n > 0:
        x, y, z = args[a], 0.0, 0.0
    if n > 1:
        y = args[a + 1]
    if n > 2:
        z = args[a + 2]
    return x, y, z


@numba.njit(cache=True, nogil=True, inline="always")
def _tend(hx, hy, hz, lx, ly, lz, ux, uy, uz, tx, ty, tz, strength):
    """PlantGL ``Turtle::_tendTo(t, strength)``: the frame (H, L, U) turned about H x t by ``strength`` times the
    angle from H to the unit vector ``t`` (half a turn about U when t is -H)."""
    cx, cy, cz = hy * tz - hz * ty, hz * tx - hx * tz, hx * ty - hy * tx
    sn = math.sqrt(cx * cx + cy * cy + cz * cz)
    cs = hx * tx + hy * ty + hz * tz
    kx, ky, kz, ang = ux, uy, uz, 0.0
    if sn > EPS:
        kx, ky, kz = cx / sn, cy / sn, cz / sn
        ang = math.atan2(sn, cs) * strength
    elif cs < EPS:
        ang = math.pi * strength
    if ang != 0.0:
        c, s = math.cos(ang), math.sin(ang)
        hx, hy, hz = _rot(hx, hy, hz, kx, ky, kz, c, s)
        lx, ly, lz = _rot(lx, ly, lz, kx, ky, kz, c, s)
        ux, uy, uz = _rot(ux, uy, uz, kx, ky, kz, c, s)
    return hx, hy, hz, lx, ly, lz, ux, uy, uz


@numba.njit(cache=True, nogil=True)
def _point(pool, prev, npool, tail, x, y, z, lx, ly, lz, r):
    """Append a path point (position, left, radius) after ``tail`` in the point pool: its index."""
    pool[npool, 0], pool[npool, 1], pool[npool, 2] = x, y, z
    pool[npool, 3], pool[npool, 4], pool[npool, 5] = lx, ly, lz
    pool[npool, 6] = r
    prev[npool] = tail
    return npool


@numba.njit(cache=True, nogil=True)
def _radius(pool, prev, npool, tail, r):
    """PlantGL ``pushRadius``: the last point's radius set to ``r``, copy-on-write (a branch shares its first
    point with its parent's path): the new tail's index."""
    for k in range(6):
        pool[npool, k] = pool[tail, k]
    pool[npool, 6] = r
    prev[npool] = prev[tail]
    return npool


@numba.njit(cache=True, nogil=True, inline="always")
def _set_width(v, gc_on, gc_cnt, pool, prev, npool, gc_tail):
    """The turtle's width set to ``v``, and pushed as the radius of an open generalized cylinder that has points
    (PlantGL ``setWidth`` + ``pushRadius``; the twin's ``set_width``): ``(width, gc_tail, npool)``."""
    if gc_on and gc_cnt > 0:
        gc_tail = _radius(pool, prev, npool, gc_tail, v)
        npool += 1
    return v, gc_tail, npool


@numba.njit(cache=True, nogil=True)
def _record(sint, sflt, ns, kind, col, mod, px, py, pz, hx, hy, hz, lx, ly, lz, ux, uy, uz, size):
    """A placed shape (sphere, disc, surface): its kind, colour, module, frame and size in row ``ns``."""
    sint[ns, 0], sint[ns, 1], sint[ns, 2], sint[ns, 3], sint[ns, 4] = kind, col, mod, 0, 0
    r = sflt[ns]
    r[0], r[1], r[2], r[3], r[4], r[5] = px, py, pz, hx, hy, hz
    r[6], r[7], r[8], r[9], r[10], r[11] = lx, ly, lz, ux, uy, uz
    r[12] = size
    return ns + 1


@numba.njit(cache=True, nogil=True)
def _record_path(sint, spts, ns, nsp, kind, col, mod, pool, prev, tail, cnt):
    """A path shape (polygon, tube): its ``cnt`` points, walked back from ``tail``, copied to ``spts[nsp:]``."""
    sint[ns, 0], sint[ns, 1], sint[ns, 2], sint[ns, 3], sint[ns, 4] = kind, col, mod, nsp, cnt
    k = tail
    for j in range(cnt - 1, -1, -1):
        for c in range(7):
            spts[nsp + j, c] = pool[k, c]
        k = prev[k]
    return ns + 1, nsp + cnt


@numba.njit(cache=True, nogil=True)
def turtle_kernel(op, ptr, args, angle, step, width0, winc, trop0, elast0, max_depth, n_out, n_shapes=0,
                  n_pool=0, with_frames=False):
    """Interpret ``op[i]`` (module ``i``'s op code) with parameters ``args[ptr[i]:ptr[i+1]]``.

    Returns ``(pos, parent, radius, order, main_child, color, module, n_nodes, ignored, ignored_at, sint, sflt,
    spts, n_shapes, n_points, seg)``; the node arrays have ``n_out`` rows of which the first ``n_nodes`` are used.
    ``with_frames``: ``seg[k]`` = (H, L, U, base width) of the turtle when it drew the segment ending at node
    ``k`` (what PlantGL's scene needs: ``PglTurtleDrawer::frustum``); one unused row otherwise.
    ``ignored[k]`` counts the PlantGL warnings of slot ``k``, ``ignored_at[k]`` is the first module index (-1 if
    none). Shape ``s`` is ``sint[s] = (kind, colour, module, first point, point count)`` and ``sflt[s]`` =
    (position, H, L, U, size); a polygon's or tube's points are ``spts[first:first + count]`` = (position, left,
    radius). ``n_shapes`` and ``n_pool`` bound the shapes and path points (the caller counts the modules).
    """
    n = op.shape[0]
    pos = np.zeros((n_out, 3))
    parent = np.full(n_out, -1, np.int64)
    radius = np.zeros(n_out)
    order = np.zeros(n_out, np.int64)
    main = np.full(n_out, -1, np.int64)
    color = np.zeros(n_out, np.int64)
    module = np.full(n_out, -1, np.int64)
    seg = np.zeros((n_out if with_frames else 1, 10))
    fstack = np.zeros((max_depth + 1, _NF))
    istack = np.zeros((max_depth + 1, _NI), np.int64)
    ignored = np.zeros(5, np.int64)
    ignored_at = np.full(5, -1, np.int64)
    sint = np.zeros((n_shapes, 5), np.int64)
    sflt = np.zeros((n_shapes, _NS))
    spts = np.zeros((n_pool + n_shapes, 7))
    pool = np.zeros((n_pool, 7))
    prev = np.full(n_pool, -1, np.int64)
    ns = nsp = npool = 0
    gc_on = gc_tail = gc_cnt = 0
    gc_tail = -1
    gc_col = 1
    poly_on = poly_cnt = 0
    poly_tail = -1
    poly_col = 1
    deg = math.pi / 180.0
    sx = sy = sz = 1.0            # PlantGL's scale: F and f move length * sz; widths scale by sx when sx == sy
    nf_i = nf_n = nf_k = nf_r = 0  # the nF being expanded (module, steps, steps done, has a radius)
    nf_i = -1
    nf_dl = nf_rest = nf_cw = nf_dw = nf_top = 0.0

    px = py = pz = 0.0
    hx, hy, hz = 0.0, 0.0, 1.0
    lx, ly, lz = 0.0, -1.0, 0.0
    ux, uy, uz = 1.0, 0.0, 0.0
    w = width0
    tx, ty, tz = trop0[0], trop0[1], trop0[2]
    el = elast0
    cur = -1          # -1: at the start (the base node is made on demand), -2: after an f (a new root)
    base = -1
    ordr = 0
    pending = 0
    col = 1
    cidx = 1          # the colour index: PlantGL keeps it under a custom appearance (SetColor(r, g, b))
    depth = 0
    nn = 0
    i = 0
    while i < n:
        o = op[i]
        a0 = ptr[i]
        na = ptr[i + 1] - a0
        if o == NOP:
            i += 1
            continue
        forced = False            # a LineTo / nF step: F with the length and top width computed here
        keep = False              # LineTo / LineRel: the frame is restored after the segment
        again = False             # an nF with steps left stays on this module
        length, top = step, -1.0
        ohx, ohy, ohz, olx, oly, olz, oux, ouy, ouz = hx, hy, hz, lx, ly, lz, ux, uy, uz
        if o >= LINETO and o <= PINPOINTREL:
            # Turtle::oLineTo / oLineRel / pinpoint / pinpointRel (lineTo, lineRel: the same, frame kept)
            vx, vy, vz = _vec3(args, a0, na, 0.0, 0.0, 0.0)
            if o == LINETO or o == OLINETO or o == PINPOINT:
                vx, vy, vz = vx - px, vy - py, vz - pz
            ln = math.sqrt(vx * vx + vy * vy + vz * vz)
            if na == 0 or ln <= EPS:
                i += 1
                continue
            hx, hy, hz, lx, ly, lz, ux, uy, uz = _tend(hx, hy, hz, lx, ly, lz, ux, uy, uz, vx / ln, vy / ln,
                                                       vz / ln, 1.0)
            if o == PINPOINT or o == PINPOINTREL:
                i += 1
                continue
            keep = o == LINETO or o == LINEREL
            length = ln
            if na > 3:
                top = args[a0 + 3]
            o, forced = F, True
        elif o == NF:
            # Turtle::nF(length, dl[, radius]): int(length / dl) steps of dl, then the rest if above epsilon
            if nf_i != i:
                nf_i, nf_k = i, 0
                nf_dl = args[a0 + 1]
                nf_n = int(args[a0] / nf_dl)
                nf_rest = args[a0] - nf_n * nf_dl
                nf_r = 1 if na > 2 else 0
                nf_cw = w
                nf_dw = 0.0
                if nf_r:
                    nf_top = args[a0 + 2]
                    if args[a0] > 0.0:
                        nf_dw = (nf_top - w) / args[a0]
            total = nf_n + (1 if nf_rest > EPS else 0)
            if nf_k >= total:
                nf_i = -1
                i += 1
                continue
            if nf_k < nf_n:
                length = nf_dl
                if nf_r:
                    nf_cw += nf_dw * nf_dl
                    top = nf_cw
            else:
                length = nf_rest
                if nf_r:
                    top = nf_top
            nf_k += 1
            again = True
            o, forced = F, True
        if o == F or o == FMOVE:
            if not forced:
                if na > 0:
                    length = args[a0]
                if o == F and na > 1:
                    top = args[a0 + 1]
            flip = o == F and length < -EPS
            if flip:          # PlantGL: turnAround(); F(-length, r); turnAround()
                length = -length
                hx, hy, hz = -hx, -hy, -hz
                lx, ly, lz = -lx, -ly, -lz
            if (o == F and length > 0.0 and el > EPS) or (o == FMOVE and el > EPS):
                # Turtle::_tendTo(tropism, elasticity)
                hx, hy, hz, lx, ly, lz, ux, uy, uz = _tend(hx, hy, hz, lx, ly, lz, ux, uy, uz, tx, ty, tz, el)
            rs = abs(sx) if sx == sy else 1.0             # PglTurtleDrawer::cylinder: width * |sx| when sx == sy
            if o == FMOVE:
                px += hx * length * sz
                py += hy * length * sz
                pz += hz * length * sz
                cur = -2
            elif length > EPS:
                if cur < 0:
                    if cur == -1 and base >= 0:
                        cur = base
                    else:         # the base node (order 0) or a root after an f (this axis's order)
                        if pending and cur == -2:
                            ordr += 1
                            pending = 0
                        pos[nn, 0], pos[nn, 1], pos[nn, 2] = px, py, pz
                        radius[nn] = max(w, 0.0) * rs
                        order[nn] = ordr if cur == -2 else 0
                        color[nn] = col
                        module[nn] = i
                        if cur == -1:
                            base = nn
                        cur = nn
                        nn += 1
                if pending:
                    ordr += 1
                    pending = 0
                px += hx * length * sz
                py += hy * length * sz
                pz += hz * length * sz
                if with_frames:
                    seg[nn, 0], seg[nn, 1], seg[nn, 2], seg[nn, 3], seg[nn, 4] = hx, hy, hz, lx, ly
                    seg[nn, 5], seg[nn, 6], seg[nn, 7], seg[nn, 8], seg[nn, 9] = lz, ux, uy, uz, max(w, 0.0) * rs
                if top > -EPS:
                    w = top
                pos[nn, 0], pos[nn, 1], pos[nn, 2] = px, py, pz
                parent[nn] = cur
                radius[nn] = max(w, 0.0) * rs
                order[nn] = ordr
                color[nn] = col
                module[nn] = i
                if order[cur] == ordr and main[cur] < 0:
                    main[cur] = nn
                cur = nn
                nn += 1
                if gc_on:                                 # PlantGL pushPosition (then pushRadius of the top)
                    gc_tail = _point(pool, prev, npool, gc_tail, px, py, pz, lx, ly, lz, max(w, 0.0))
                    npool += 1
                    gc_cnt += 1
                if poly_on:
                    poly_tail = _point(pool, prev, npool, poly_tail, px, py, pz, lx, ly, lz, max(w, 0.0))
                    npool += 1
                    poly_cnt += 1
            elif length > 0.0 and top > -EPS:
                w, gc_tail, npool = _set_width(top, gc_on, gc_cnt, pool, prev, npool, gc_tail)
            if flip:
                hx, hy, hz = -hx, -hy, -hz
                lx, ly, lz = -lx, -ly, -lz
        elif o <= ROLLR or o == TURN:
            a = angle
            if o == TURN:
                a = 180.0
            elif na > 0:
                a = args[a0]
            if o == RIGHT or o == UP or o == ROLLR:
                a = -a
            c, s = math.cos(a * deg), math.sin(a * deg)
            if o == LEFT or o == RIGHT or o == TURN:      # about U: H, L
                hx, hy, hz = _rot(hx, hy, hz, ux, uy, uz, c, s)
                lx, ly, lz = _rot(lx, ly, lz, ux, uy, uz, c, s)
            elif o == UP or o == DOWN:                    # about L: H, U
                hx, hy, hz = _rot(hx, hy, hz, lx, ly, lz, c, s)
                ux, uy, uz = _rot(ux, uy, uz, lx, ly, lz, c, s)
            else:                                         # about H: L, U
                lx, ly, lz = _rot(lx, ly, lz, hx, hy, hz, c, s)
                ux, uy, uz = _rot(ux, uy, uz, hx, hy, hz, c, s)
        elif o == ROLLVERT:
            alpha = 1.0
            if na > 0:
                alpha = args[a0]
            if alpha > 0.0:
                # Turtle::rollToVert(top = +Z): L = top x H, U = H x L
                nx, ny, nz = -hy, hx, 0.0
                ln = math.sqrt(nx * nx + ny * ny)
                if ln < EPS:
                    nx, ny, nz = 0.0, -1.0, 0.0
                else:
                    nx, ny = nx / ln, ny / ln
                if alpha < 1.0:   # a fraction of the roll from L to the horizontal left
                    sn = (ly * nz - lz * ny) * hx + (lz * nx - lx * nz) * hy + (lx * ny - ly * nx) * hz
                    cs = lx * nx + ly * ny + lz * nz
                    ang = math.atan2(sn, cs) * alpha
                    c, s = math.cos(ang), math.sin(ang)
                    lx, ly, lz = _rot(lx, ly, lz, hx, hy, hz, c, s)
                else:
                    lx, ly, lz = nx, ny, nz
                ux, uy, uz = hy * lz - hz * ly, hz * lx - hx * lz, hx * ly - hy * lx
        elif o == ROLLHORIZ:
            alpha = 1.0
            if na > 0:
                alpha = min(args[a0], 1.0)
            if alpha > 0.0 and abs(hz) > EPS:
                # Turtle::rollToHorizontal(top = +Z): H turned into the horizontal plane
                gx, gy, gz = hx, hy, 0.0
                gn = math.sqrt(gx * gx + gy * gy)
                if gn < EPS:
                    gx, gy = 1.0, 0.0
                else:
                    gx, gy = gx / gn, gy / gn
                kx, ky, kz = hy * gz - hz * gy, hz * gx - hx * gz, hx * gy - hy * gx
                kn = math.sqrt(kx * kx + ky * ky + kz * kz)
                if kn > EPS:
                    kx, ky, kz = kx / kn, ky / kn, kz / kn
                    ang = math.atan2(kn, hx * gx + hy * gy + hz * gz) * alpha
                    c, s = math.cos(ang), math.sin(ang)
                    hx, hy, hz = _rot(hx, hy, hz, kx, ky, kz, c, s)
                    lx, ly, lz = _rot(lx, ly, lz, kx, ky, kz, c, s)
                    ux, uy, uz = _rot(ux, uy, uz, kx, ky, kz, c, s)
        elif o == PUSH:
            fs = fstack[depth]
            fs[0], fs[1], fs[2], fs[3], fs[4], fs[5] = px, py, pz, hx, hy, hz
            fs[6], fs[7], fs[8], fs[9], fs[10], fs[11] = lx, ly, lz, ux, uy, uz
            fs[12], fs[13], fs[14], fs[15], fs[16] = w, tx, ty, tz, el
            fs[17], fs[18], fs[19] = sx, sy, sz
            ist = istack[depth]
            ist[0], ist[1], ist[2], ist[3] = cur, ordr, pending, col
            ist[4], ist[5], ist[6], ist[7], ist[8], ist[9] = gc_on, gc_tail, gc_cnt, gc_col, poly_on, poly_col
            ist[10] = cidx
            depth += 1
            pending = 1
            if gc_on and gc_cnt > 1:                      # PlantGL keepLastPoint: the branch's tube starts here
                gc_cnt = 1
        elif o == POP:
            if gc_on and gc_cnt > 1:                      # the branch's tube is drawn when it ends
                ns, nsp = _record_path(sint, spts, ns, nsp, SH_TUBE, gc_col, i, pool, prev, gc_tail, gc_cnt)
            depth -= 1
            fs = fstack[depth]
            px, py, pz, hx, hy, hz = fs[0], fs[1], fs[2], fs[3], fs[4], fs[5]
            lx, ly, lz, ux, uy, uz = fs[6], fs[7], fs[8], fs[9], fs[10], fs[11]
            w, tx, ty, tz, el = fs[12], fs[13], fs[14], fs[15], fs[16]
            sx, sy, sz = fs[17], fs[18], fs[19]
            ist = istack[depth]
            cur, ordr, pending, col = ist[0], ist[1], ist[2], ist[3]
            gc_on, gc_tail, gc_cnt, gc_col, poly_on, poly_col = ist[4], ist[5], ist[6], ist[7], ist[8], ist[9]
            cidx = ist[10]
        elif o == INCW or o == DECW or o == SETW:
            v = w + winc if o == INCW else w - winc
            if na > 0:
                v = args[a0]
            if v > -EPS:
                w, gc_tail, npool = _set_width(v, gc_on, gc_cnt, pool, prev, npool, gc_tail)
            else:
                ignored[IGNORED_WIDTH] += 1
                if ignored_at[IGNORED_WIDTH] < 0:
                    ignored_at[IGNORED_WIDTH] = i
        elif o == INCC or o == DECC or o == SETC:
            v = cidx + 1 if o == INCC else cidx - 1       # PlantGL: from the index, dropping a custom colour
            if o == SETC and na == 0:                     # L-Py: setColor(getColor())
                v = cidx
            elif na >= 3:
                v = CUSTOM_COLOR
                for c in range(3):
                    v += min(max(int(round(args[a0 + c])), 0), 255) << (16 - 8 * c)  # noqa: RUF046 (numba)
            elif na > 0:
                v = int(args[a0])
            if v >= 0:
                col = v
                if v < CUSTOM_COLOR:
                    cidx = v
            else:
                ignored[IGNORED_COLOR] += 1
                if ignored_at[IGNORED_COLOR] < 0:
                    ignored_at[IGNORED_COLOR] = i
        elif o == CUT:                                    # skip to the ']' closing this branch
            d = 0
            j = i + 1
            while j < n:
                if op[j] == PUSH:
                    d += 1
                elif op[j] == POP:
                    if d == 0:
                        break
                    d -= 1
                j += 1
            i = j
            continue
        elif o == TROPISM:
            vx, vy, vz = _vec3(args, a0, na, 0.0, 0.0, 1.0)
            vn = math.sqrt(vx * vx + vy * vy + vz * vz)
            tx, ty, tz = vx / vn, vy / vn, vz / vn
        elif o == ELASTICITY:
            v = 0.0
            if na > 0:
                v = args[a0]
            if 0.0 <= v <= 1.0:
                el = v
            else:
                ignored[IGNORED_ELASTICITY] += 1
                if ignored_at[IGNORED_ELASTICITY] < 0:
                    ignored_at[IGNORED_ELASTICITY] = i
        elif o == SPHERE or o == CIRCLE or o == SURFACE or o == SURFACE_NAMED:
            size = 1.0 if o >= SURFACE else w              # a sphere's or disc's radius defaults to the width
            if o == SURFACE_NAMED:                         # surface(name, scale): the name is parameter 0
                if na > 1:
                    size = args[a0 + 1]
            elif na > 0:
                size = args[a0]
            if size < -EPS:
                ignored[IGNORED_SIZE] += 1
                if ignored_at[IGNORED_SIZE] < 0:
                    ignored_at[IGNORED_SIZE] = i
            elif size > EPS:
                kind = SH_SPHERE if o == SPHERE else (SH_CIRCLE if o == CIRCLE else SH_SURFACE)
                ns = _record(sint, sflt, ns, kind, col, i, px, py, pz, hx, hy, hz, lx, ly, lz, ux, uy, uz, size)
                # PglTurtleDrawer: a sphere or surface Scaled(scale * size) along (U, -L, H); a disc times scale.x
                # when the scale is isotropic
                qx, qy, qz = sx, sy, sz
                if o == CIRCLE:
                    if sx == sy and sy == sz:
                        qy, qz = sx, sx
                    else:
                        qx, qy, qz = 1.0, 1.0, 1.0
                sflt[ns - 1, 15], sflt[ns - 1, 16], sflt[ns - 1, 17] = qx, qy, qz
        elif o == QUERY:                                  # a request module: the frame here, drawing nothing
            ns = _record(sint, sflt, ns, SH_QUERY, col, i, px, py, pz, hx, hy, hz, lx, ly, lz, ux, uy, uz, 0.0)
        elif o == BOX or o == QUAD:
            # Turtle::box / quad: tropism, the shape from here along H (length * scale.z, half-widths the width and
            # the top width, times scale.x when x = y), a move, then the width set to the top's; negative: turned
            # around. The skeleton is not drawn: the next F starts a new root
            length = step
            if na > 0:
                length = args[a0]
            top = w
            if na > 1:
                top = args[a0 + 1]
            if length > 0.0 or length < -EPS:
                flip = length < 0.0
                if flip:
                    length = -length
                    hx, hy, hz = -hx, -hy, -hz
                    lx, ly, lz = -lx, -ly, -lz
                if el > EPS:
                    hx, hy, hz, lx, ly, lz, ux, uy, uz = _tend(hx, hy, hz, lx, ly, lz, ux, uy, uz, tx, ty, tz, el)
                rs = abs(sx) if sx == sy else 1.0
                ns = _record(sint, sflt, ns, SH_BOX if o == BOX else SH_QUAD, col, i, px, py, pz, hx, hy, hz, lx, ly,
                             lz, ux, uy, uz, length * sz)
                sflt[ns - 1, 13] = max(w, 0.0) * rs
                sflt[ns - 1, 14] = max(top, 0.0) * rs
                px += hx * length * sz
                py += hy * length * sz
                pz += hz * length * sz
                cur = -2
                if top > -EPS:
                    w, gc_tail, npool = _set_width(top, gc_on, gc_cnt, pool, prev, npool, gc_tail)
                if flip:
                    hx, hy, hz = -hx, -hy, -hz
                    lx, ly, lz = -lx, -ly, -lz
        elif o == FRAME:                                  # Turtle::frame(size, cap height ratio, ...): annotated
            size = step
            if na > 0:
                size = args[a0]
            cap = 0.2
            if na > 1:
                cap = args[a0 + 1]
            if size > EPS and 0.0 < cap < 1.0:
                ns = _record(sint, sflt, ns, SH_FRAME, col, i, px, py, pz, hx, hy, hz, lx, ly, lz, ux, uy, uz, size)
        elif o == LABEL:                                  # Turtle::label: the text at the turtle's frame
            size = -1.0
            if na > 1 and args[a0 + 1] == args[a0 + 1]:
                size = args[a0 + 1]
            ns = _record(sint, sflt, ns, SH_LABEL, col, i, px, py, pz, hx, hy, hz, lx, ly, lz, ux, uy, uz, size)
        elif o == MOVETO or o == MOVEREL:
            # Turtle::move / shift; L-Py's MoveTo keeps the coordinates not given (None: NaN here), MoveRel
            # pads with 0; the next F starts a new root, as after an f, if the turtle moved
            qx, qy, qz = px, py, pz
            if o == MOVETO and na == 0:
                qx, qy, qz = 0.0, 0.0, 0.0
            for c in range(min(na, 3)):
                v = args[a0 + c]
                if v == v:
                    if o == MOVEREL:
                        v += px if c == 0 else (py if c == 1 else pz)
                    if c == 0:
                        qx = v
                    elif c == 1:
                        qy = v
                    else:
                        qz = v
            if abs(qx - px) + abs(qy - py) + abs(qz - pz) > 0.0:
                px, py, pz = qx, qy, qz
                cur = -2
        elif o == SETHEAD:
            # L-Py's SetHead: no up vector (or a null one): pinpointRel(h); else Turtle::setHead(h, u), up
            # re-orthogonalised (the door refuses a null heading and a heading colinear with the up vector)
            vx, vy, vz = _vec3(args, a0, na, 0.0, 0.0, 1.0)
            wx, wy, wz = _vec3(args, a0 + 3, na - 3, 1.0, 0.0, 0.0)
            vn = math.sqrt(vx * vx + vy * vy + vz * vz)
            wn = math.sqrt(wx * wx + wy * wy + wz * wz)
            if vn > EPS:
                vx, vy, vz = vx / vn, vy / vn, vz / vn
                if (na > 0 and na < 4) or wn < EPS:
                    hx, hy, hz, lx, ly, lz, ux, uy, uz = _tend(hx, hy, hz, lx, ly, lz, ux, uy, uz, vx, vy, vz, 1.0)
                else:
                    wx, wy, wz = wx / wn, wy / wn, wz / wn
                    cx, cy, cz = wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx   # L = U x H
                    cn = math.sqrt(cx * cx + cy * cy + cz * cz)
                    if cn > EPS:
                        hx, hy, hz = vx, vy, vz
                        lx, ly, lz = cx / cn, cy / cn, cz / cn
                        ux, uy, uz = hy * lz - hz * ly, hz * lx - hx * lz, hx * ly - hy * lx  # U = H x L
        elif o == EULER:
            # Turtle::eulerAngles: M = Matrix3::eulerRotationZYX(azimuth, -elevation, roll), H = M x, U = M z,
            # L = U x H (defaults 180, 90, 0: the initial frame)
            az, elv, rl = 180.0, 90.0, 0.0
            if na > 0:
                az = args[a0]
            if na > 1:
                elv = args[a0 + 1]
            if na > 2:
                rl = args[a0 + 2]
            cx_, sx_ = math.cos(az * deg), math.sin(az * deg)
            cy_, sy_ = math.cos(-elv * deg), math.sin(-elv * deg)
            cz_, sz_ = math.cos(rl * deg), math.sin(rl * deg)
            hx, hy, hz = cx_ * cy_, sx_ * cy_, -sy_
            ux, uy, uz = cx_ * sy_ * cz_ + sx_ * sz_, sx_ * sy_ * cz_ - cx_ * sz_, cy_ * cz_
            lx, ly, lz = uy * hz - uz * hy, uz * hx - ux * hz, ux * hy - uy * hx
        elif o == SETSCALE or o == MULTSCALE or o == DIVSCALE:
            v = 1.0 if o == SETSCALE else SCALE_MULTIPLIER
            if na > 0:
                v = args[a0]
            qx, qy, qz = v, v, v
            ok = True
            if o == MULTSCALE:
                qx, qy, qz = sx * v, sy * v, sz * v
            elif o == DIVSCALE:
                ok = v != 0.0
                if ok:
                    qx, qy, qz = sx / v, sy / v, sz / v
            if ok and abs(qx) <= MAX_SCALE and abs(qy) <= MAX_SCALE and abs(qz) <= MAX_SCALE:
                sx, sy, sz = qx, qy, qz
            else:
                ignored[IGNORED_SCALE] += 1
                if ignored_at[IGNORED_SCALE] < 0:
                    ignored_at[IGNORED_SCALE] = i
        elif o == GC_START:                               # PlantGL startGC: a new path from here
            gc_on, gc_cnt, gc_col = 1, 1, col
            gc_tail = _point(pool, prev, npool, -1, px, py, pz, lx, ly, lz, max(w, 0.0))
            npool += 1
        elif o == GC_END:
            if gc_on and gc_cnt > 1:
                ns, nsp = _record_path(sint, spts, ns, nsp, SH_TUBE, gc_col, i, pool, prev, gc_tail, gc_cnt)
            gc_on, gc_tail, gc_cnt = 0, -1, 0
        elif o == POLY_START:
            poly_on, poly_tail, poly_cnt, poly_col = 1, -1, 0, col
        elif o == POLY_POINT:
            if poly_on:
                poly_tail = _point(pool, prev, npool, poly_tail, px, py, pz, lx, ly, lz, max(w, 0.0))
                npool += 1
                poly_cnt += 1
            if gc_on:                                     # PlantGL's one point list: '.' adds a tube point too
                gc_tail = _point(pool, prev, npool, gc_tail, px, py, pz, lx, ly, lz, max(w, 0.0))
                npool += 1
                gc_cnt += 1
        elif o == POLY_END:
            if poly_on and poly_cnt > 2:
                kind = SH_POLYGON_CONCAVE if na > 0 and args[a0] != 0.0 else SH_POLYGON
                ns, nsp = _record_path(sint, spts, ns, nsp, kind, poly_col, i, pool, prev, poly_tail, poly_cnt)
            poly_on, poly_tail, poly_cnt = 0, -1, 0
        if keep:                                          # Turtle::lineTo / lineRel restore the frame
            hx, hy, hz, lx, ly, lz, ux, uy, uz = ohx, ohy, ohz, olx, oly, olz, oux, ouy, ouz
        if not again:
            i += 1
    if gc_on and gc_cnt > 1:                              # PlantGL Turtle::stop()
        ns, nsp = _record_path(sint, spts, ns, nsp, SH_TUBE, gc_col, -1, pool, prev, gc_tail, gc_cnt)
    return (pos, parent, radius, order, main, color, module, nn, ignored, ignored_at, sint, sflt, spts, ns,
            nsp, seg)


# -- the readable twin ------------------------------------------------------------------------------------------

def _rotation(axis: np.ndarray, degrees: float) -> np.ndarray:
    """Right-handed rotation matrix about an axis, normalised as the kernel's ``_rot`` (PlantGL
    ``Matrix3::axisRotation``)."""
    a = np.radians(degrees)
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def turtle_python(op, ptr, args, angle, step, width0, winc, trop0, elast0):
    """The twin of :func:`turtle_kernel`: the same interpretation with numpy vectors and a dict of states.

    Returns ``(pos, parent, radius, order, main_child, color, module, ignored, sint, sflt, spts)`` (used rows
    only); a tube's path is a Python list per turtle state (a branch starts from its parent's last point), the
    polygon's one list is shared by every state, as PlantGL's ``pointList``.
    """
    st = {"p": np.zeros(3), "H": np.array([0.0, 0, 1]), "L": np.array([0.0, -1, 0]), "U": np.array([1.0, 0, 0]),
          "w": float(width0), "T": np.asarray(trop0, float), "e": float(elast0), "cur": -1, "order": 0,
          "pending": False, "color": 1, "cidx": 1, "gc": None, "gc_color": 1, "poly": False, "poly_color": 1}
    stack = []
    poly: list = []
    shapes: list = []                               # (kind, colour, module, frame + size, points)

    def point():
        return [*st["p"], *st["L"], max(st["w"], 0.0)]

    def record(kind, col, i, size=0.0, pts=()):
        scale = [1.0, 1.0, 1.0] if kind in (SH_SPHERE, SH_CIRCLE, SH_SURFACE) else [0.0, 0.0, 0.0]
        frame = [*st["p"], *st["H"], *st["L"], *st["U"], size, 0.0, 0.0, *scale] if not pts else [0.0] * 18
        shapes.append((kind, col, i, frame, [list(q) for q in pts]))

    def set_width(v):
        st["w"] = v
        if st["gc"]:                                  # pushRadius
            st["gc"][-1] = st["gc"][-1][:6] + [v]
    nodes = {k: [] for k in ("pos", "parent", "radius", "order", "color", "module")}
    main: list[int] = []
    base = [-1]
    ignored = [0, 0, 0, 0, 0]

    def frame_rotate(R):
        st["H"], st["L"], st["U"] = R @ st["H"], R @ st["L"], R @ st["U"]

    def tropism():
        h, t = st["H"], st["T"]
        cp = np.cross(h, t)
        sn, cs = np.linalg.norm(cp), float(h @ t)
        if sn > EPS:
            frame_rotate(_rotation(cp / sn, np.degrees(np.arctan2(sn, cs) * st["e"])))
        elif cs < EPS:
            frame_rotate(_rotation(st["U"], 180.0 * st["e"]))

    def add_node(p, par, i):
        nodes["pos"].append(p.copy())
        nodes["parent"].append(par)
        nodes["radius"].append(max(st["w"], 0.0))
        nodes["order"].append(st["order"])
        nodes["color"].append(st["color"])
        nodes["module"].append(i)
        main.append(-1)
        if par >= 0 and nodes["order"][par] == st["order"] and main[par] < 0:
            main[par] = len(main) - 1
        return len(main) - 1

    def take_branch():
        if st["pending"]:
            st["order"] += 1
            st["pending"] = False

    i, n = 0, len(op)
    while i < n:
        o, vals = int(op[i]), [float(v) for v in args[ptr[i]:ptr[i + 1]]]
        if o in (F, FMOVE):
            length = vals[0] if vals else step
            top = vals[1] if o == F and len(vals) > 1 else -1.0
            flip = o == F and length < -EPS
            if flip:
                length = -length
                frame_rotate(_rotation(st["U"], 180.0))
            if st["e"] > EPS and (o == FMOVE or length > 0):
                tropism()
            if o == FMOVE:
                st["p"] = st["p"] + st["H"] * length
                st["cur"] = -2
            elif length > EPS:
                if st["cur"] == -1 and base[0] >= 0:
                    st["cur"] = base[0]
                elif st["cur"] == -2:                     # a new root after an f, on this axis
                    take_branch()
                    st["cur"] = add_node(st["p"], -1, i)
                elif st["cur"] == -1:                     # the base node, order 0
                    keep, st["order"] = st["order"], 0
                    base[0] = st["cur"] = add_node(st["p"], -1, i)
                    st["order"] = keep
                take_branch()
                st["p"] = st["p"] + st["H"] * length
                if top > -EPS:
                    st["w"] = top
                st["cur"] = add_node(st["p"], st["cur"], i)
                if st["gc"] is not None:
                    st["gc"].append(point())
                if st["poly"]:
                    poly.append(point())
            elif length > 0 and top > -EPS:
                set_width(top)
            if flip:
                frame_rotate(_rotation(st["U"], 180.0))
        elif o in (LEFT, RIGHT, TURN):
            a = 180.0 if o == TURN else (vals[0] if vals else angle)
            R = _rotation(st["U"], -a if o == RIGHT else a)
            st["H"], st["L"] = R @ st["H"], R @ st["L"]
        elif o in (UP, DOWN):
            a = vals[0] if vals else angle
            R = _rotation(st["L"], -a if o == UP else a)
            st["H"], st["U"] = R @ st["H"], R @ st["U"]
        elif o in (ROLLL, ROLLR):
            a = vals[0] if vals else angle
            R = _rotation(st["H"], -a if o == ROLLR else a)
            st["L"], st["U"] = R @ st["L"], R @ st["U"]
        elif o == ROLLVERT:
            alpha = vals[0] if vals else 1.0
            if alpha > 0:
                nl = np.cross([0.0, 0, 1], st["H"])
                nl = np.array([0.0, -1, 0]) if np.linalg.norm(nl) < EPS else nl / np.linalg.norm(nl)
                if alpha < 1:
                    ang = np.arctan2(np.cross(st["L"], nl) @ st["H"], st["L"] @ nl) * alpha
                    st["L"] = _rotation(st["H"], np.degrees(ang)) @ st["L"]
                else:
                    st["L"] = nl
                st["U"] = np.cross(st["H"], st["L"])
        elif o == ROLLHORIZ:
            alpha = min(vals[0], 1.0) if vals else 1.0
            h = st["H"]
            if alpha > 0 and abs(h[2]) > EPS:
                g = np.array([h[0], h[1], 0.0])
                g = np.array([1.0, 0, 0]) if np.linalg.norm(g) < EPS else g / np.linalg.norm(g)
                k = np.cross(h, g)
                if np.linalg.norm(k) > EPS:
                    ang = np.arctan2(np.linalg.norm(k), h @ g) * alpha
                    frame_rotate(_rotation(k / np.linalg.norm(k), np.degrees(ang)))
        elif o == PUSH:
            stack.append({k: (v.copy() if isinstance(v, (np.ndarray, list)) else v) for k, v in st.items()})
            st["pending"] = True
            if st["gc"]:
                st["gc"] = st["gc"][-1:]
        elif o == POP:
            if st["gc"] is not None and len(st["gc"]) > 1:
                record(SH_TUBE, st["gc_color"], i, pts=st["gc"])
            st = stack.pop()
        elif o in (INCW, DECW, SETW):
            v = vals[0] if vals else (st["w"] + winc if o == INCW else st["w"] - winc)
            if v > -EPS:
                set_width(v)
            else:
                ignored[IGNORED_WIDTH] += 1
        elif o in (INCC, DECC, SETC):
            v = int(vals[0]) if vals else (st["cidx"] + 1 if o == INCC else st["cidx"] - 1)
            if o == SETC and not vals:
                v = st["cidx"]
            elif len(vals) >= 3:
                r, g, b = (min(max(round(c), 0), 255) for c in vals[:3])
                v = CUSTOM_COLOR + (r << 16) + (g << 8) + b
            if v >= 0:
                st["color"] = v
                st["cidx"] = v if v < CUSTOM_COLOR else st["cidx"]
            else:
                ignored[IGNORED_COLOR] += 1
        elif o == CUT:
            d, i = 0, i + 1
            while i < n and not (op[i] == POP and d == 0):
                d += int(op[i] == PUSH) - int(op[i] == POP)
                i += 1
            continue
        elif o == TROPISM:
            v = np.array([0.0, 0, 1]) if not vals else np.array((vals + [0.0, 0.0])[:3])
            st["T"] = v / np.linalg.norm(v)
        elif o == ELASTICITY:
            v = vals[0] if vals else 0.0
            if 0 <= v <= 1:
                st["e"] = v
            else:
                ignored[IGNORED_ELASTICITY] += 1
        elif o in (SPHERE, CIRCLE, SURFACE):
            size = vals[0] if vals else (1.0 if o == SURFACE else st["w"])
            if size < -EPS:
                ignored[IGNORED_SIZE] += 1
            elif size > EPS:
                record({SPHERE: SH_SPHERE, CIRCLE: SH_CIRCLE, SURFACE: SH_SURFACE}[o], st["color"], i, size)
        elif o == QUERY:
            record(SH_QUERY, st["color"], i)
        elif o == GC_START:
            st["gc"], st["gc_color"] = [point()], st["color"]
        elif o == GC_END:
            if st["gc"] is not None and len(st["gc"]) > 1:
                record(SH_TUBE, st["gc_color"], i, pts=st["gc"])
            st["gc"] = None
        elif o == POLY_START:
            st["poly"], st["poly_color"] = True, st["color"]
            poly.clear()
        elif o == POLY_POINT:
            if st["poly"]:
                poly.append(point())
            if st["gc"] is not None:
                st["gc"].append(point())
        elif o == POLY_END:
            if st["poly"] and len(poly) > 2:
                record(SH_POLYGON_CONCAVE if vals and vals[0] != 0 else SH_POLYGON, st["poly_color"], i, pts=poly)
            st["poly"] = False
            poly.clear()
        i += 1
    if st["gc"] is not None and len(st["gc"]) > 1:
        record(SH_TUBE, st["gc_color"], -1, pts=st["gc"])
    m = len(main)
    sint, sflt, spts, at = [], [], [], 0
    for kind, col, mod, frame, pts in shapes:
        sint.append([kind, col, mod, at if pts else 0, len(pts)])
        sflt.append(frame)
        spts.extend(pts)
        at += len(pts)
    return (np.array(nodes["pos"], float).reshape(m, 3), np.array(nodes["parent"], np.int64),
            np.array(nodes["radius"], float), np.array(nodes["order"], np.int64), np.array(main, np.int64),
            np.array(nodes["color"], np.int64), np.array(nodes["module"], np.int64), ignored,
            np.array(sint, np.int64).reshape(-1, 5), np.array(sflt, float).reshape(-1, 18),
            np.array(spts, float).reshape(-1, 7))

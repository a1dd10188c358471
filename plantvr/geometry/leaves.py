"""Leaves: placement at buds on thin internodes, elastic reorientation, petioles, blades (spec 000_treewand §3.4).

Each leaf starts with the heading of its bud (§10.2.1) and is turned toward the vertical by three rotations
(Eq. 10.15) with separate elasticities, repeated in small increments (§10.2.2). The petiole is a generalized
cylinder through p0 = bud, p1 = p0 + l·ĥ_init, p2 = p1 + l·ĥ_final, meshed by the branch kernel; the blade is a
textured quad (or a folded quad) attached at p2 with the final frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from plantvr._threading import parallel_region
from plantvr._validation import check_array, check_choice, check_int, check_points, check_range
from plantvr.types import BufferMesh, TriMesh

from . import _kernels as K

__all__ = ["LEAF_SHAPES", "IncrementalLeafMesh", "LeafMesh", "build_leaves", "initial_leaf_frames", "orient_leaves", "select_leaf_buds"]

LEAF_SHAPES = ("ovate", "lobed")
_PETIOLE_UV = (0.5, 0.03)      # a texel of the stem drawn at the bottom of every leaf texture


@dataclass(eq=False)
class LeafMesh(TriMesh):
    """Triangle mesh of all leaves (blades and petioles).

    Attributes
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int64 ndarray
    normals : (V, 3) float32 ndarray
    uv : (V, 2) float32 ndarray
        Leaf texture coordinates (blade: the whole image; petiole: the stem texel).
    bud_id : (V,) int64 ndarray
        Index of the bud (row of the bud arrays) each vertex belongs to.
    frames : (L, 3, 3) float64 ndarray
        Final (heading, right, up) of each leaf.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray
    bud_id: np.ndarray
    frames: np.ndarray


def select_leaf_buds(bud_radius, *, radius_threshold: float, leaf_size: float) -> np.ndarray:
    """Indices of the buds that carry a leaf: internode radius below the threshold, and leaf size > 0 (§10.2.1).

    Parameters
    ----------
    bud_radius : (B,) float64 ndarray
        Radius of the internode each bud sits on (lateral **and** main buds).
    radius_threshold : float
        Leaves grow only where ``bud_radius < radius_threshold``.
    leaf_size : float
        Leaf scale; 0 gives no leaves (B.2 "Leaf size").

    Returns
    -------
    (L,) int64 ndarray
    """
    bud_radius = check_array("bud_radius", bud_radius, shape=(None,))
    radius_threshold = check_range("radius_threshold", radius_threshold, 0.0, np.inf)
    leaf_size = check_range("leaf_size", leaf_size, 0.0, np.inf)
    if leaf_size == 0.0:
        return np.zeros(0, np.int64)
    return np.flatnonzero(bud_radius < radius_threshold).astype(np.int64)


def _normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _orthonormalize(h, u):
    h = _normalize(h)
    u = u - np.sum(u * h, axis=-1, keepdims=True) * h
    n = np.linalg.norm(u, axis=-1, keepdims=True)
    fallback = np.array([K._perp(x) for x in h]) if np.any(n < 1e-12) else u
    u = np.where(n < 1e-12, fallback, u / np.maximum(n, 1e-300))
    return h, np.cross(h, u), u


def initial_leaf_frames(bud_dir, *, bud_up=None, rng=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Initial (heading, right, up) of leaves: heading = bud direction, up = bud lateral vector ⟂ heading.

    Parameters
    ----------
    bud_dir : (L, 3) float64 ndarray
        Heading the bud's internode would have (Eqs. 9.1/9.2).
    bud_up : (L, 3) float64 ndarray, optional
        The node's lateral vector l̂; its component ⟂ heading becomes û. Default: a random perpendicular.
    rng : int or numpy.random.Generator, optional
        Seed for the default up vectors.

    Returns
    -------
    h, r, u : (L, 3) float64 ndarray
        Right-handed unit frame with ``r = h × u`` (spec §3.4 [INFERRED]).
    """
    bud_dir = check_points("bud_dir", bud_dir)
    if np.any(np.linalg.norm(bud_dir, axis=1) < 1e-12):
        raise ValueError("bud_dir must contain non-zero direction vectors")
    if bud_up is None:
        bud_up = np.random.default_rng(rng).normal(size=bud_dir.shape)
    else:
        bud_up = check_array("bud_up", bud_up, shape=bud_dir.shape)
    return _orthonormalize(bud_dir, bud_up)


def _rotate(vecs, axis, ang):
    c, s = np.cos(ang)[:, None], np.sin(ang)[:, None]
    return [v * c + np.cross(axis, v) * s + axis * np.sum(axis * v, 1, keepdims=True) * (1 - c) for v in vecs]


def orient_leaves(h, r, u, *, e_twist: float = 0.05, e_up: float = 0.05, e_right: float = 0.05,
                  iterations: int = 15, up=(0.0, 1.0, 0.0), increment: str = "per_iteration",
                  kernel: str = "numba"):
    """Turn leaf frames toward the light with three elastic rotations (Eq. 10.15, spec §3.4).

    Per iteration, in this order and reading the current frame each time: about û (target ĥ, "petiole bend
    right"), about r̂ (target û, "bend up"), about ĥ (target û, "twist"), each by
    θ = e‖b̂×ŷ‖‖v̂×ŷ‖ toward +ŷ, then re-orthonormalise. θ is capped at the angle that brings b̂ closest to
    ŷ about that axis [INFERRED]: Eq. 10.15 does not vanish there, and without the cap frames chatter.

    Parameters
    ----------
    h, r, u : (L, 3) float64 ndarray
        Unit frames (heading, right, up = leaf normal).
    e_twist, e_up, e_right : float
        Elasticities in [0, 10]; 0 disables that rotation (B.2 "Petiole twist / bend up / bend right").
    iterations : int
        Number of increments, in [1, 1000] ("typically between 10 and 20").
    up : (3,) float64 array_like
        The vertical ŷ (y is up in PlantVR).
    increment : {"per_iteration", "split"}
        ``"per_iteration"``: θ of Eq. 10.15 in radians per iteration (spec §3.4 [INFERRED]); ``"split"``:
        θ/iterations per iteration, so the result converges as iterations grow (spec TW-V21 reading).
    kernel : {"numba", "numpy"}
        Per-leaf compiled loop, or the vectorised numpy twin.

    Returns
    -------
    h, r, u : (L, 3) float64 ndarray

    References
    ----------
    .. [1] Thesis §10.2.2, Eq. 10.15, Fig. 10.8; rotation sign and units [INFERRED] (spec §3.4).
    """
    h, r, u = (check_points(n, x) for n, x in (("h", h), ("r", r), ("u", u)))
    if not (len(h) == len(r) == len(u)):
        raise ValueError(f"h, r and u must have the same length, got {len(h)}, {len(r)}, {len(u)}")
    e = {k: check_range(k, v, 0.0, 10.0) for k, v in (("e_twist", e_twist), ("e_up", e_up), ("e_right", e_right))}
    iterations = check_int("iterations", iterations, 1, 1000)
    y = _normalize(np.asarray(check_array("up", up, shape=(3,)), float))
    check_choice("increment", increment, ("per_iteration", "split"))
    check_choice("kernel", kernel, ("numba", "numpy"))
    scale = 1.0 / iterations if increment == "split" else 1.0
    h, r, u = _orthonormalize(h, u)
    if len(h) == 0:
        return h, r, u
    if kernel == "numba":
        fn = _orient_numba if len(h) >= 2048 else _orient_serial
        with parallel_region():
            return fn(h, r, u, np.array([e["e_right"], e["e_up"], e["e_twist"]]), iterations, y, scale)
    for _ in range(iterations):
        for ax_name, tg_name, ek in (("u", "h", "e_right"), ("r", "u", "e_up"), ("h", "u", "e_twist")):
            if e[ek] == 0.0:
                continue
            frame = {"h": h, "r": r, "u": u}
            axis, target = frame[ax_name], frame[tg_name]
            bxy = np.cross(target, y)
            th = scale * e[ek] * np.linalg.norm(bxy, axis=1) * np.linalg.norm(np.cross(axis, y), axis=1)
            # no overshoot [INFERRED]: the angle about the axis that brings the target closest to y bounds θ,
            # otherwise θ (which does not vanish there) makes the frame chatter around that optimum
            b_perp = target - np.sum(target * axis, 1, keepdims=True) * axis
            sn = np.sum(axis * bxy, axis=1)
            best = np.where(np.abs(sn) < 1e-12, 0.0, np.arctan2(sn, b_perp @ y))   # equilibrium: no turn
            th = np.sign(best) * np.minimum(th, np.abs(best))
            h, r, u = _rotate((h, r, u), axis, th)
            h, r, u = _orthonormalize(h, u)
    return h, r, u


@numba.njit(cache=True, nogil=True)
def _cr(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(cache=True, nogil=True)
def _rot3(v0, v1, v2, a0, a1, a2, c, s_):
    """Rodrigues rotation of v about unit a by (cos, sin) = (c, s_)."""
    x0, x1, x2 = _cr(a0, a1, a2, v0, v1, v2)
    av = (a0 * v0 + a1 * v1 + a2 * v2) * (1.0 - c)
    return v0 * c + x0 * s_ + a0 * av, v1 * c + x1 * s_ + a1 * av, v2 * c + x2 * s_ + a2 * av


@numba.njit(cache=True, nogil=True, parallel=True)
def _orient_numba(h, r, u, e, iterations, y, scale):
    """Per-leaf, allocation-free loop of Eq. 10.15 (twin: the vectorised body of :func:`orient_leaves`).

    Leaves run in parallel; r̂ is not rotated but rebuilt as ĥ × û after each step, as the twin does.
    """
    L = h.shape[0]
    H, R, U = h.copy(), r.copy(), u.copy()
    y0, y1, y2 = y[0], y[1], y[2]
    for i in numba.prange(L):
        h0, h1, h2 = H[i, 0], H[i, 1], H[i, 2]
        r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
        u0, u1, u2 = U[i, 0], U[i, 1], U[i, 2]
        for _ in range(iterations):
            for step in range(3):
                if e[step] == 0.0:
                    continue
                if step == 0:                      # about u, target h ("bend right")
                    a0, a1, a2, t0, t1, t2 = u0, u1, u2, h0, h1, h2
                elif step == 1:                    # about r, target u ("bend up")
                    a0, a1, a2, t0, t1, t2 = r0, r1, r2, u0, u1, u2
                else:                              # about h, target u ("twist")
                    a0, a1, a2, t0, t1, t2 = h0, h1, h2, u0, u1, u2
                c0, c1, c2 = _cr(t0, t1, t2, y0, y1, y2)
                d0, d1, d2 = _cr(a0, a1, a2, y0, y1, y2)
                th = scale * e[step] * math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) * math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                ta = t0 * a0 + t1 * a1 + t2 * a2
                sn = a0 * c0 + a1 * c1 + a2 * c2
                best = 0.0 if abs(sn) < 1e-12 else math.atan2(
                    sn, (t0 - ta * a0) * y0 + (t1 - ta * a1) * y1 + (t2 - ta * a2) * y2)
                th = math.copysign(min(th, abs(best)), best) if best != 0.0 else 0.0
                c, s_ = math.cos(th), math.sin(th)
                h0, h1, h2 = _rot3(h0, h1, h2, a0, a1, a2, c, s_)
                u0, u1, u2 = _rot3(u0, u1, u2, a0, a1, a2, c, s_)
                hn = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
                h0, h1, h2 = h0 / hn, h1 / hn, h2 / hn
                uh = u0 * h0 + u1 * h1 + u2 * h2
                u0, u1, u2 = u0 - uh * h0, u1 - uh * h1, u2 - uh * h2
                un = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
                u0, u1, u2 = u0 / un, u1 / un, u2 / un
                r0, r1, r2 = _cr(h0, h1, h2, u0, u1, u2)
        H[i, 0], H[i, 1], H[i, 2] = h0, h1, h2
        R[i, 0], R[i, 1], R[i, 2] = r0, r1, r2
        U[i, 0], U[i, 1], U[i, 2] = u0, u1, u2
    return H, R, U


def _orient_serial(h, r, u, e, iterations, y, scale):
    """:func:`_orient_numba` on one thread (small batches: waking the pool costs more than it saves)."""
    prev = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        with parallel_region():
            return _orient_numba(h, r, u, e, iterations, y, scale)
    finally:
        numba.set_num_threads(prev)


def _blade(shape: str):
    """Local blade vertices (x along r̂, y along ĥ, z along û), UVs and faces."""
    if shape == "ovate":
        loc = np.array([[-0.5, 0, 0], [0.5, 0, 0], [0.5, 1, 0], [-0.5, 1, 0]], float)
        faces = np.array([[0, 1, 2], [0, 2, 3]])
    else:                                      # folded along the midrib (a shallow V)
        loc = np.array([[-0.5, 0, 0.12], [0, 0, 0], [0.5, 0, 0.12], [-0.5, 1, 0.12], [0, 1, 0], [0.5, 1, 0.12]])
        faces = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]])
    uv = np.stack([loc[:, 0] + 0.5, 0.08 + 0.92 * loc[:, 1]], axis=1)
    return loc, uv, faces


def build_leaves(bud_pos, bud_dir, bud_radius, *, bud_up=None, leaf_size: float = 0.5,
                 radius_threshold: float | None = None, petiole_length: float = 0.1,
                 petiole_radius: float | None = None, e_twist: float = 0.05, e_up: float = 0.05,
                 e_right: float = 0.05, iterations: int = 15, leaf_shape: str = "ovate",
                 up=(0.0, 1.0, 0.0), increment: str = "per_iteration", petiole_sides: int = 5,
                 rng=None) -> LeafMesh:
    """Leaf mesh at the buds of thin internodes: blades plus petiole generalized cylinders (spec §3.4).

    Parameters
    ----------
    bud_pos : (B, 3) float64 ndarray
        Bud positions (the node each bud sits on).
    bud_dir : (B, 3) float64 ndarray
        Initial leaf heading = heading an internode from that bud would have.
    bud_radius : (B,) float64 ndarray
        Radius of the internode the bud sits on.
    bud_up : (B, 3) float64 ndarray, optional
        Lateral vector of the node; default random (seeded by ``rng``).
    leaf_size : float
        Blade length; 0 gives no leaves.
    radius_threshold : float, optional
        Only buds with ``bud_radius`` below it get leaves; default 3 × the smallest bud radius.
    petiole_length : float
        Control-point spacing l of the petiole (0: blade attached at the bud, no petiole).
    petiole_radius : float, optional
        Default 0.3 × the smallest bud radius.
    e_twist, e_up, e_right, iterations, up, increment
        As in :func:`orient_leaves`.
    leaf_shape : {"ovate", "lobed"}
        Blade geometry (a flat quad or a quad folded along the midrib); pairs with the leaf texture.
    petiole_sides : int
        Ring subdivisions of the petiole, in [3, 16].
    rng : int or numpy.random.Generator, optional

    Returns
    -------
    LeafMesh

    References
    ----------
    .. [1] Thesis §10.2, Eq. 10.15, Figs. 10.8–10.9; petiole p0, p1, p2 of §10.2.2.
    """
    bud_pos = check_points("bud_pos", bud_pos)
    nb = len(bud_pos)
    bud_dir = check_array("bud_dir", bud_dir, shape=(nb, 3))
    bud_radius = check_array("bud_radius", bud_radius, shape=(nb,))
    if bud_up is not None:
        bud_up = check_array("bud_up", bud_up, shape=(nb, 3))
    leaf_size = check_range("leaf_size", leaf_size, 0.0, np.inf)
    if radius_threshold is None:
        radius_threshold = 3.0 * float(bud_radius.min()) if nb else 0.0
    petiole_length = check_range("petiole_length", petiole_length, 0.0, np.inf)
    check_choice("leaf_shape", leaf_shape, LEAF_SHAPES)
    petiole_sides = check_int("petiole_sides", petiole_sides, 3, 16)
    if petiole_radius is None:
        petiole_radius = 0.3 * float(bud_radius.min()) if nb else 0.0
    petiole_radius = check_range("petiole_radius", petiole_radius, 0.0, np.inf)
    sel = select_leaf_buds(bud_radius, radius_threshold=radius_threshold, leaf_size=leaf_size)
    h0, r0, u0 = initial_leaf_frames(bud_dir[sel], bud_up=None if bud_up is None else bud_up[sel], rng=rng)
    h, r, u = orient_leaves(h0, r0, u0, e_twist=e_twist, e_up=e_up, e_right=e_right, iterations=iterations,
                            up=up, increment=increment)
    L = len(sel)
    p0 = bud_pos[sel]
    p1 = p0 + petiole_length * h0
    p2 = p1 + petiole_length * h
    loc, buv, bf = _blade(leaf_shape)
    nv, nfb = len(loc), len(bf)
    # petiole layout (generalized cylinders through the branch kernel, w = 1: a polynomial quadratic)
    ks = 3
    pet = petiole_length > 0 and petiole_radius > 0 and L > 0
    npv = (ks + 1) * (petiole_sides + 1) if pet else 0
    npf = ks * 2 * petiole_sides if pet else 0
    nbv, nbf = L * nv, L * nfb
    V = np.empty((nbv + L * npv, 3))
    NRM = np.empty((len(V), 3), np.float32)
    UV = np.empty((len(V), 2), np.float32)
    NID = np.empty(len(V), np.int64)
    F = np.empty((nbf + L * npf, 3), np.int64)
    # blades: written straight into the first L × nv vertices and L × nfb faces
    bv = V[:nbv].reshape(L, nv, 3)
    bv[:] = p2[:, None, :]
    for k in range(nv):
        bv[:, k] += leaf_size * (loc[k, 0] * r + loc[k, 1] * h + loc[k, 2] * u)
    NRM[:nbv].reshape(L, nv, 3)[:] = u[:, None, :]
    UV[:nbv].reshape(L, nv, 2)[:] = buv
    NID[:nbv].reshape(L, nv)[:] = sel[:, None]
    F[:nbf].reshape(L, nfb, 3)[:] = bf[None] + (nv * np.arange(L))[:, None, None]
    if pet:
        rec = np.zeros((L, K.REC_SIZE))
        rec[:, 0:3], rec[:, 3:6], rec[:, 6:9] = p0, p1, p2
        rec[:, 9:12] = u0
        rec[:, 15] = 1.0
        rec[:, 17] = 1.0
        rec[:, 18] = rec[:, 19] = petiole_radius
        cnt = np.full((L, ks + 1), petiole_sides, np.int32)
        v_off = nbv + npv * np.arange(L + 1, dtype=np.int64)
        f_off = nbf + npf * np.arange(L + 1, dtype=np.int64)
        nodes = np.stack([sel, sel], axis=1).astype(np.int64)
        K.eval_segments(rec, cnt, ks, nodes, np.zeros(L, np.uint8), np.arange(L, dtype=np.int64), v_off, f_off,
                        1.0, V, NRM, UV, NID, F)
        UV[nbv:] = _PETIOLE_UV
    return LeafMesh(V, F, NRM, UV, NID, np.stack([h, r, u], axis=1))


# ---------------------------------------------------------------------------------------------------------
# Incremental leaves (spec §3.5 applied to §3.4): a leaf is a pure function of its bud row, so unchanged buds
# keep their geometry and only new or changed buds are oriented and meshed.
def _row_hash(rows: np.ndarray) -> np.ndarray:
    """(L,) uint64 FNV-1a-style hash of the float64 bit patterns of each row."""
    bits = np.ascontiguousarray(rows, np.float64).view(np.uint64)
    h = np.full(len(rows), np.uint64(0xCBF29CE484222325))
    for c in range(bits.shape[1]):
        h = (h ^ bits[:, c]) * np.uint64(0x100000001B3)
    return h


@numba.njit(cache=True, nogil=True)
def _match_in_order(rows, old_rows, seq, match, window):
    """Match bud rows to the previous update's rows in order (``seq``: their slots, in the previous row order).

    Between growth steps the bud list keeps its order (buds are consumed, new nodes' buds come last), so one
    forward walk with a short look-ahead (``window`` rows) matches nearly every row in O(L). Rows are equal when
    their float64 bit patterns are (``rows``/``old_rows`` as uint64 views). ``match[j]`` gets the slot, or
    stays -1 (the caller matches the rest by hash). Twin: the hash match of :meth:`IncrementalLeafMesh.update`.
    """
    n = seq.shape[0]
    w = rows.shape[1]
    i = 0
    for j in range(rows.shape[0]):
        hi = min(n, i + window)
        for k in range(i, hi):
            same = True
            for c in range(w):
                if old_rows[seq[k], c] != rows[j, c]:
                    same = False
                    break
            if same:
                match[j] = seq[k]
                i = k + 1
                break


class IncrementalLeafMesh(BufferMesh):
    """Leaf mesh kept up to date bud by bud (spec §3.4 with the incremental update of §3.5).

    Each leaf (blade + petiole) owns a fixed-size block of the buffers. A leaf's geometry depends only on its
    bud's position, heading and lateral vector (and the options), so :meth:`update` matches bud rows by
    content, keeps the blocks of unchanged buds, blanks those of vanished buds (degenerate faces) and orients
    and meshes only new buds, in free blocks first. :meth:`to_leaf_mesh` returns the compact mesh, equal to
    :func:`build_leaves` of the same buds with the same options.

    Parameters
    ----------
    leaf_size, radius_threshold, petiole_length, e_twist, e_up, e_right, iterations, leaf_shape, up, increment,
    petiole_sides
        As in :func:`build_leaves` (``radius_threshold`` is required here).
    petiole_radius : float
        Required here (``build_leaves`` derives it from the smallest bud radius).

    Attributes
    ----------
    buffer_version : int
        Bumped when the buffers are re-allocated or compacted.
    """

    def __init__(self, *, radius_threshold: float, petiole_radius: float, leaf_size: float = 0.5,
                 petiole_length: float = 0.1, e_twist: float = 0.05, e_up: float = 0.05, e_right: float = 0.05,
                 iterations: int = 15, leaf_shape: str = "ovate", up=(0.0, 1.0, 0.0),
                 increment: str = "per_iteration", petiole_sides: int = 5):
        super().__init__()
        self.options = dict(
            leaf_size=check_range("leaf_size", leaf_size, 0.0, np.inf),
            radius_threshold=check_range("radius_threshold", radius_threshold, 0.0, np.inf),
            petiole_length=check_range("petiole_length", petiole_length, 0.0, np.inf),
            petiole_radius=check_range("petiole_radius", petiole_radius, 0.0, np.inf),
            e_twist=check_range("e_twist", e_twist, 0.0, 10.0), e_up=check_range("e_up", e_up, 0.0, 10.0),
            e_right=check_range("e_right", e_right, 0.0, 10.0),
            iterations=check_int("iterations", iterations, 1, 1000),
            leaf_shape=check_choice("leaf_shape", leaf_shape, LEAF_SHAPES),
            up=tuple(float(x) for x in check_array("up", up, shape=(3,))),
            increment=check_choice("increment", increment, ("per_iteration", "split")),
            petiole_sides=check_int("petiole_sides", petiole_sides, 3, 16))
        loc, _, bf = _blade(self.options["leaf_shape"])
        self._nbv, self._nbf = len(loc), len(bf)
        pet = self.options["petiole_length"] > 0 and self.options["petiole_radius"] > 0
        ps = self.options["petiole_sides"]
        self._npv, self._npf = (4 * (ps + 1), 3 * 2 * ps) if pet else (0, 0)
        self.Bv, self.Bf = self._nbv + self._npv, self._nbf + self._npf
        self.buffer_version = 0
        self._n = 0                                    # slots in use (live or free)
        self._V, self._NRM = np.zeros((0, 3)), np.zeros((0, 3), np.float32)
        self._UV = np.zeros((0, 2), np.float32)
        self._F = np.zeros((0, 3), np.int64)
        self._rows, self._live, self._hash = np.zeros((0, 9)), np.zeros(0, bool), np.zeros(0, np.uint64)
        self._frames, self._order = np.zeros((0, 3, 3)), np.zeros(0, np.int64)
        self._seq = np.zeros(0, np.int64)  # slots of the last update's leaves, in bud-row order
        self._grow_to(64)

    def _grow_to(self, slots: int) -> None:
        """Capacity for ``slots`` blocks (geometric growth; bumps ``buffer_version``)."""
        cap = len(self._live)
        if slots <= cap:
            return
        cap = max(slots + slots // 4, int(1.5 * cap) + 16)
        n = self._n

        def grow(a, rows, used, fill=0):
            out = np.full((rows,) + a.shape[1:], fill, a.dtype)
            out[:used] = a[:used]
            return out
        nv, nf = n * self.Bv, n * self.Bf
        self._V, self._NRM = grow(self._V, cap * self.Bv, nv), grow(self._NRM, cap * self.Bv, nv)
        self._UV = grow(self._UV, cap * self.Bv, nv)
        self._F = grow(self._F, cap * self.Bf, nf)
        self._rows, self._live, self._hash = grow(self._rows, cap, n), grow(self._live, cap, n), grow(self._hash, cap, n)
        self._frames, self._order = grow(self._frames, cap, n), grow(self._order, cap, n, -1)
        self.buffer_version += 1

    # -- arrays -----------------------------------------------------------------------------------------
    @property
    def vertices(self) -> np.ndarray:
        """(V, 3) float64 vertex rows in use (blocks of free slots are collapsed, degenerate)."""
        return self._V[:self._n * self.Bv]

    @property
    def normals(self) -> np.ndarray:
        """(V, 3) float32."""
        return self._NRM[:self._n * self.Bv]

    @property
    def uv(self) -> np.ndarray:
        """(V, 2) float32 leaf texture coordinates."""
        return self._UV[:self._n * self.Bv]

    @property
    def bud_id(self) -> np.ndarray:
        """(V,) int64 row of the latest bud arrays each vertex belongs to, -1 in free blocks (computed)."""
        return np.repeat(np.where(self._live[:self._n], self._order[:self._n], -1), self.Bv)

    @property
    def faces(self) -> np.ndarray:
        """(F, 3) int64 faces in use; faces of free blocks are degenerate."""
        return self._F[:self._n * self.Bf]

    @property
    def n_leaves(self) -> int:
        """Live leaves."""
        return int(self._live[:self._n].sum())

    # -- update -----------------------------------------------------------------------------------------
    def update(self, bud_pos, bud_dir, bud_radius, bud_up) -> dict:
        """Bring the leaves to a new set of buds; orient and mesh only the new ones.

        Parameters
        ----------
        bud_pos, bud_dir, bud_radius, bud_up
            As in :func:`build_leaves` (``bud_up`` required: a leaf must be a function of its bud).

        Returns
        -------
        dict
            ``added`` and ``removed`` (leaf counts), ``slots`` (block indices written: block k covers vertex
            rows ``k*Bv:(k+1)*Bv`` and face rows ``k*Bf:(k+1)*Bf``) and ``relayout`` (buffers re-allocated).
        """
        bud_pos = check_points("bud_pos", bud_pos)
        nb = len(bud_pos)
        bud_dir = check_array("bud_dir", bud_dir, shape=(nb, 3))
        bud_radius = check_array("bud_radius", bud_radius, shape=(nb,))
        bud_up = check_array("bud_up", bud_up, shape=(nb, 3))
        o = self.options
        sel = select_leaf_buds(bud_radius, radius_threshold=o["radius_threshold"], leaf_size=o["leaf_size"])
        rows = np.hstack([bud_pos[sel], bud_dir[sel], bud_up[sel]])
        n = self._n
        match = np.full(len(sel), -1, np.int64)
        seq = self._seq[self._live[self._seq]] if n else self._seq
        if len(seq) and len(sel):  # in order first (O(L)), then by hash for what is left
            _match_in_order(rows.view(np.uint64), self._rows.view(np.uint64), seq, match, 64)
        left = np.flatnonzero(match < 0)
        h_left = _row_hash(rows[left])
        free_live = np.ones(n, bool)
        free_live[match[match >= 0]] = False
        live = np.flatnonzero(self._live[:n] & free_live)
        if len(live) and len(left):
            lo = np.argsort(self._hash[live], kind="stable")
            lh = self._hash[live][lo]
            j = np.minimum(np.searchsorted(lh, h_left), len(lh) - 1)
            cand = live[lo[j]]
            ok = (lh[j] == h_left) & np.all(self._rows[cand] == rows[left], axis=1)
            match[left[ok]] = cand[ok]
            # a slot serves one bud: duplicates beyond the first become new leaves
            m_idx = left[ok]
            o = np.argsort(match[m_idx], kind="stable")
            ms = match[m_idx][o]
            match[m_idx[o][1:][ms[1:] == ms[:-1]]] = -1
        keep = np.zeros(n, bool)
        keep[match[match >= 0]] = True
        gone = np.flatnonzero(self._live[:n] & ~keep)
        self._live[gone] = False
        self._blank(gone)
        new = np.flatnonzero(match < 0)
        free = np.flatnonzero(~self._live[:n])
        take = free[:len(new)]
        extra = len(new) - len(take)
        v0 = self.buffer_version
        if extra > 0:
            self._grow_to(n + extra)
            take = np.concatenate([take, np.arange(n, n + extra)])
            self._n = n + extra
        match[new] = take
        if len(new):
            h_new = np.zeros(len(sel), np.uint64)
            h_new[left] = h_left
            self._write(take, bud_pos[sel[new]], bud_dir[sel[new]], bud_up[sel[new]], rows[new], h_new[new])
        # bud rows shift between snapshots: refresh each live block's row index
        self._order[:self._n] = -1
        self._order[match] = sel
        self._seq = match.copy()
        return dict(added=len(new), removed=len(gone),
                    slots=np.concatenate([take, gone]), relayout=self.buffer_version != v0)

    def _blank(self, slots: np.ndarray) -> None:
        if not len(slots):
            return
        V = self._V.reshape(-1, self.Bv, 3)
        V[slots] = V[slots, :1]
        F = self._F.reshape(-1, self.Bf, 3)
        F[slots] = (slots * self.Bv)[:, None, None]
        self._hash[slots] = 0

    def _write(self, slots, pos, dirs, ups, rows, h) -> None:
        o = self.options
        L = len(slots)
        m = build_leaves(pos, dirs, np.zeros(L), bud_up=ups, leaf_size=o["leaf_size"], radius_threshold=1.0,
                         petiole_length=o["petiole_length"], petiole_radius=o["petiole_radius"],
                         e_twist=o["e_twist"], e_up=o["e_up"], e_right=o["e_right"], iterations=o["iterations"],
                         leaf_shape=o["leaf_shape"], up=o["up"], increment=o["increment"],
                         petiole_sides=o["petiole_sides"])
        nbv, nbf, npv, npf = self._nbv, self._nbf, self._npv, self._npf
        base = slots * self.Bv
        src_b = (np.arange(L)[:, None] * nbv + np.arange(nbv)).ravel()
        dst_b = (base[:, None] + np.arange(nbv)).ravel()
        src_p = (L * nbv + np.arange(L)[:, None] * npv + np.arange(npv)).ravel()
        dst_p = (base[:, None] + nbv + np.arange(npv)).ravel()
        src, dst = np.concatenate([src_b, src_p]), np.concatenate([dst_b, dst_p])
        self._V[dst] = m.vertices[src]
        self._NRM[dst] = m.normals[src]
        self._UV[dst] = m.uv[src]
        fb = m.faces[:L * nbf].reshape(L, nbf, 3) - (np.arange(L) * nbv)[:, None, None] + base[:, None, None]
        F = self._F.reshape(-1, self.Bf, 3)
        F[slots, :nbf] = fb
        if npf:
            fp = (m.faces[L * nbf:].reshape(L, npf, 3) - (L * nbv + np.arange(L) * npv)[:, None, None]
                  + (base + nbv)[:, None, None])
            F[slots, nbf:] = fp
        self._rows[slots], self._hash[slots], self._live[slots] = rows, h, True
        self._frames[slots] = m.frames

    def to_leaf_mesh(self) -> LeafMesh:
        """The compact leaf mesh in bud order (blades, then petioles): equal to :func:`build_leaves`."""
        q = np.flatnonzero(self._live[:self._n])
        q = q[np.argsort(self._order[q], kind="stable")]
        L, nbv, nbf, npv = len(q), self._nbv, self._nbf, self._npv
        base = q * self.Bv
        src = np.concatenate([(base[:, None] + np.arange(nbv)).ravel(), (base[:, None] + nbv + np.arange(npv)).ravel()])
        V, NRM, UV = self._V[src], self._NRM[src], self._UV[src]
        BID = np.concatenate([np.repeat(self._order[q], nbv), np.repeat(self._order[q], npv)])
        F = self._F.reshape(-1, self.Bf, 3)
        fb = F[q, :nbf] - base[:, None, None] + (np.arange(L) * nbv)[:, None, None]
        fp = F[q, nbf:] - (base + nbv)[:, None, None] + (L * nbv + np.arange(L) * npv)[:, None, None]
        faces = np.concatenate([fb.reshape(-1, 3), fp.reshape(-1, 3)])
        return LeafMesh(V, faces, NRM, UV, BID, self._frames[q].copy())

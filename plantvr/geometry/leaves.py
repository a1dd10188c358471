"""Leaves: placement at buds on thin internodes, elastic reorientation, petioles, blades (spec 000_treewand §3.4).

Each leaf starts with the heading of its bud (§10.2.1) and is turned toward the vertical by three rotations
(Eq. 10.15) with separate elasticities, repeated in small increments (§10.2.2). The petiole is a generalized
cylinder through p0 = bud, p1 = p0 + l·ĥ_init, p2 = p1 + l·ĥ_final, meshed by the branch kernel; the blade is a
textured quad (or a folded quad) attached at p2 with the final frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import math

import numba
import numpy as np

from plantvr._validation import check_array, check_choice, check_int, check_points, check_range

from . import _kernels as K

__all__ = ["LeafMesh", "LEAF_SHAPES", "select_leaf_buds", "initial_leaf_frames", "orient_leaves", "build_leaves"]

LEAF_SHAPES = ("ovate", "lobed")
_PETIOLE_UV = (0.5, 0.03)      # a texel of the stem drawn at the bottom of every leaf texture


@dataclass
class LeafMesh:
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

    def to_trimesh(self):
        """Return a ``trimesh.Trimesh`` (``process=False``) with the vertex normals."""
        import trimesh
        return trimesh.Trimesh(self.vertices, self.faces, vertex_normals=self.normals, process=False)


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
        return _orient_numba(h, r, u, np.array([e["e_right"], e["e_up"], e["e_twist"]]), iterations, y, scale)
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

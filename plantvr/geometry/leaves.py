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
from .mesh import ring_counts

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
def _orient_numba(h, r, u, e, iterations, y, scale):
    """Per-leaf, allocation-free loop of Eq. 10.15 (twin: the vectorised body of :func:`orient_leaves`)."""
    L = h.shape[0]
    H, R, U = h.copy(), r.copy(), u.copy()
    y0, y1, y2 = y[0], y[1], y[2]
    for i in range(L):
        f = np.empty((3, 3))
        f[0], f[1], f[2] = H[i], R[i], U[i]          # rows: h, r, u
        for _ in range(iterations):
            for step in range(3):
                if e[step] == 0.0:
                    continue
                ai = 2 if step == 0 else (1 if step == 1 else 0)
                ti = 0 if step == 0 else 2
                a0, a1, a2 = f[ai, 0], f[ai, 1], f[ai, 2]
                t0, t1, t2 = f[ti, 0], f[ti, 1], f[ti, 2]
                c0, c1, c2 = _cr(t0, t1, t2, y0, y1, y2)
                d0, d1, d2 = _cr(a0, a1, a2, y0, y1, y2)
                th = scale * e[step] * math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) * math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                ta = t0 * a0 + t1 * a1 + t2 * a2
                sn = a0 * c0 + a1 * c1 + a2 * c2
                best = 0.0 if abs(sn) < 1e-12 else math.atan2(
                    sn, (t0 - ta * a0) * y0 + (t1 - ta * a1) * y1 + (t2 - ta * a2) * y2)
                th = math.copysign(min(th, abs(best)), best) if best != 0.0 else 0.0
                c, s_ = math.cos(th), math.sin(th)
                for k in range(3):
                    v0, v1, v2 = f[k, 0], f[k, 1], f[k, 2]
                    x0, x1, x2 = _cr(a0, a1, a2, v0, v1, v2)
                    av = a0 * v0 + a1 * v1 + a2 * v2
                    f[k, 0] = v0 * c + x0 * s_ + a0 * av * (1.0 - c)
                    f[k, 1] = v1 * c + x1 * s_ + a1 * av * (1.0 - c)
                    f[k, 2] = v2 * c + x2 * s_ + a2 * av * (1.0 - c)
                hn = math.sqrt(f[0, 0] ** 2 + f[0, 1] ** 2 + f[0, 2] ** 2)
                h0, h1, h2 = f[0, 0] / hn, f[0, 1] / hn, f[0, 2] / hn
                uh = f[2, 0] * h0 + f[2, 1] * h1 + f[2, 2] * h2
                u0, u1, u2 = f[2, 0] - uh * h0, f[2, 1] - uh * h1, f[2, 2] - uh * h2
                un = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
                u0, u1, u2 = u0 / un, u1 / un, u2 / un
                r0, r1, r2 = _cr(h0, h1, h2, u0, u1, u2)
                f[0, 0], f[0, 1], f[0, 2] = h0, h1, h2
                f[1, 0], f[1, 1], f[1, 2] = r0, r1, r2
                f[2, 0], f[2, 1], f[2, 2] = u0, u1, u2
        H[i], R[i], U[i] = f[0], f[1], f[2]
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
    # blades
    loc, buv, bf = _blade(leaf_shape)
    nv = len(loc)
    bv = (p2[:, None, :] + leaf_size * (loc[None, :, 0:1] * r[:, None] + loc[None, :, 1:2] * h[:, None]
                                         + loc[None, :, 2:3] * u[:, None]))
    verts = [bv.reshape(-1, 3)]
    norms = [np.repeat(u, nv, axis=0).astype(np.float32)]
    uvs = [np.tile(buv, (L, 1)).astype(np.float32)]
    ids = [np.repeat(sel, nv)]
    faces = [(bf[None] + nv * np.arange(L)[:, None, None]).reshape(-1, 3)]
    # petioles through the branch kernel (w = 1: a polynomial quadratic)
    if petiole_length > 0 and petiole_radius > 0 and L:
        rec = np.zeros((L, K.REC_SIZE))
        rec[:, 0:3], rec[:, 3:6], rec[:, 6:9] = p0, p1, p2
        rec[:, 9:12] = u0
        rec[:, 15] = 1.0
        rec[:, 17] = 1.0
        rec[:, 18] = rec[:, 19] = petiole_radius
        ks = 3
        cnt = ring_counts(np.full(L, petiole_sides), np.full(L, petiole_sides), ks)
        nvs = (cnt + 1).sum(1)
        nfs = (cnt[:, :-1] + cnt[:, 1:]).sum(1)
        v_off = np.concatenate([[0], np.cumsum(nvs)]).astype(np.int64)
        f_off = np.concatenate([[0], np.cumsum(nfs)]).astype(np.int64)
        V, NRM = np.empty((v_off[-1], 3)), np.empty((v_off[-1], 3), np.float32)
        UV, NID, F = np.empty((v_off[-1], 2), np.float32), np.empty(v_off[-1], np.int64), np.empty((f_off[-1], 3), np.int64)
        nodes = np.stack([sel, sel], axis=1).astype(np.int64)
        K._eval_segments_numba(rec, cnt, ks, nodes, np.zeros(L, np.uint8), np.arange(L, dtype=np.int64), v_off,
                               f_off, 1.0, V, NRM, UV, NID, F)
        UV[:] = _PETIOLE_UV
        faces.append(F + len(verts[0]))
        verts.append(V)
        norms.append(NRM)
        uvs.append(UV)
        ids.append(NID)
    return LeafMesh(np.concatenate(verts), np.concatenate(faces).astype(np.int64), np.concatenate(norms),
                    np.concatenate(uvs), np.concatenate(ids), np.stack([h, r, u], axis=1))

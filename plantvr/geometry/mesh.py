"""Branch mesh: rational-Bézier skeleton, generalized cylinders, LOD and bark UVs (spec 000_treewand §3.1–§3.3, §3.5).

A tree given as plain arrays (``pos``, ``parent``, ``radius``; optionally ``alive``, ``main_child``) becomes a
set of segments, one rational quadratic Bézier around every node (Eq. 10.1, ERRATUM A.9) plus a straight half
at the root and at every tip. Each segment is one compact 20-float record (the §3.5 patch, ERRATUM A.12), the
unit of incremental update. A numba kernel sweeps a circle along every segment with the closed-form planar
parallel-transport frame (Eqs. 10.2–10.7, ERRATA A.10/A.11), the smoothstep radius (Eqs. 10.8–10.10) and the
1D rational-Bézier length estimate for the bark coordinate (Eq. 10.13, ERRATUM A.12b).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from plantvr._validation import check_array, check_index, check_int, check_range, check_tree_arrays
from plantvr.types import BufferMesh, TriMesh

from . import _kernels as K
from ._kernels import CAP_END, CAP_START

__all__ = [
    "BranchMesh",
    "IncrementalBranchMesh",
    "MeshUpdate",
    "Segments",
    "build_branch_mesh",
    "length_estimate",
    "lod_level",
    "rational_bezier",
    "rational_bezier_tangent",
    "ring_counts",
    "smoothstep",
    "transport_frame",
    "tree_segments",
    "update_branch_mesh",
]

LOD_FULL = (10, 64)
LOD_FAST = (6, 32)


# ---------------------------------------------------------------------------------------------------------
# the equations, vectorised (used by tests and by the leaves)
def rational_bezier(p0, p1, p2, u, w: float = 3.0) -> np.ndarray:
    """Point of the quadratic rational Bézier around a node (Eq. 10.1).

    Parameters
    ----------
    p0, p1, p2 : (3,) or (S, 3) float64 ndarray
        Control points: mid-internode, node, mid-internode.
    u : float or (M,) float64 ndarray
        Curve parameter in [0, 1].
    w : float
        Weight of the central control point.

    Returns
    -------
    (M, 3) or (S, M, 3) float64 ndarray
        Cartesian points (homogeneous form divided by the fourth coordinate).

    References
    ----------
    .. [1] Thesis Eq. 10.1, with ERRATUM A.9 ((1-u)^2 and the middle point [w P_i; w]).
    """
    u = np.atleast_1d(np.asarray(u, float))[..., None]
    p0, p1, p2 = (np.asarray(p, float)[..., None, :] for p in (p0, p1, p2))
    b0, b1, b2 = (1 - u) ** 2, 2 * (1 - u) * u * w, u * u
    return (b0 * p0 + b1 * p1 + b2 * p2) / (b0 + b1 + b2)


def rational_bezier_tangent(p0, p1, p2, u, w: float = 3.0) -> np.ndarray:
    """Derivative N'(u) of :func:`rational_bezier` (quotient rule), same shapes (Eq. 10.1)."""
    u = np.atleast_1d(np.asarray(u, float))[..., None]
    p0, p1, p2 = (np.asarray(p, float)[..., None, :] for p in (p0, p1, p2))
    b0, b1, b2 = (1 - u) ** 2, 2 * (1 - u) * u * w, u * u
    d0, d1, d2 = -2 * (1 - u), 2 * (1 - 2 * u) * w, 2 * u
    num, den = b0 * p0 + b1 * p1 + b2 * p2, b0 + b1 + b2
    return ((d0 * p0 + d1 * p1 + d2 * p2) * den - num * (d0 + d1 + d2)) / den ** 2


def length_estimate(p0, p1, p2, u, w: float = 3.0) -> np.ndarray:
    """Arc-length estimate D(u) of a segment: a 1D rational Bézier with the same weight (Eq. 10.13).

    Returns
    -------
    (M,) float64 ndarray
        D(u); exact for collinear control points in order.

    References
    ----------
    .. [1] Thesis Eq. 10.13 with ERRATUM A.12b (third 1D control point ‖P1−P0‖ + ‖P2−P1‖).
    """
    u = np.atleast_1d(np.asarray(u, float))
    la = np.linalg.norm(np.asarray(p1, float) - p0)
    lb = np.linalg.norm(np.asarray(p2, float) - p1)
    return (2 * u * (1 - u) * w * la + u * u * (la + lb)) / ((1 - u) ** 2 + 2 * (1 - u) * u * w + u * u)


def smoothstep(u) -> np.ndarray:
    """Smoothstep s(u) of Eq. 10.8 (0 below 0, 3u²−2u³ on [0, 1], 1 above 1)."""
    u = np.clip(np.asarray(u, float), 0.0, 1.0)
    return 3 * u * u - 2 * u ** 3


def transport_frame(p0, p1, p2, bx0, u, w: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form parallel-transport frame on one planar segment (Eqs. 10.2–10.7).

    Parameters
    ----------
    p0, p1, p2 : (3,) float64 ndarray
        Control points of the segment.
    bx0 : (3,) float64 ndarray
        Unit start frame vector, perpendicular to N'(0).
    u : (M,) float64 ndarray
        Curve parameters.
    w : float
        Central weight.

    Returns
    -------
    bx, by : (M, 3) float64 ndarray
        Frame vectors; ``by = bx × N̂'(u)``.

    References
    ----------
    .. [1] Thesis Eqs. 10.2–10.7; ERRATUM A.10 (N̂'(u) per vertex) and A.11 (cross with the unit tangent).
    """
    tg = rational_bezier_tangent(p0, p1, p2, u, w)
    tg = tg / np.linalg.norm(tg, axis=-1, keepdims=True)
    t0 = tg[0] if np.isclose(np.atleast_1d(u)[0], 0.0) else K._unit(np.asarray(p1, float) - p0)
    bx = np.array([K._rotate_between(np.asarray(bx0, float), t0, t) for t in tg])
    return bx, np.cross(bx, tg)


def lod_level(radius, *, tip_radius: float, lod: tuple[int, int] = LOD_FULL) -> np.ndarray:
    """Ring subdivisions from the radius: ``lod[0]`` at the tip radius, ``lod[1]`` at 50× (spec §3.5).

    Parameters
    ----------
    radius : float or (M,) float64 ndarray
        Radii, in scene units.
    tip_radius : float
        Radius of the end internodes.
    lod : (int, int)
        Minimum and maximum subdivisions, (10, 64) or the fast (6, 32) of §12.2 (ERRATUM A.14).

    Returns
    -------
    (M,) int64 ndarray
        ``clamp(lo + (hi−lo)·(r/r_tip − 1)/49, lo, hi)``, rounded.

    References
    ----------
    .. [1] Thesis §10.3 ("linearly blend"); linear form [INFERRED] in spec §3.5.
    """
    lo, hi = lod
    x = lo + (hi - lo) * (np.asarray(radius, float) / tip_radius - 1.0) / 49.0
    return np.rint(np.clip(x, lo, hi)).astype(np.int64)


def ring_counts(n0, n1, ksteps: int) -> np.ndarray:
    """Ring counts along each segment: the two end counts blended by the smoothstep (Eq. 10.8).

    Returns
    -------
    (S, ksteps+1) int32 ndarray
        Equal to ``n0`` at u = 0 and ``n1`` at u = 1, so rings shared at a join get equal counts.
    """
    s = smoothstep(np.arange(ksteps + 1) / ksteps)
    return np.rint((1 - s) * np.asarray(n0)[:, None] + s * np.asarray(n1)[:, None]).astype(np.int32)


# ---------------------------------------------------------------------------------------------------------
@dataclass
class Segments:
    """Compact per-segment records of a tree skeleton (spec §3.5 patch; the unit of incremental update).

    Attributes
    ----------
    records : (S, 20) float64 ndarray
        P0, P1, P2, bx(0), bx(1), w, t0, t1, r0, r2 (layout in ``plantvr.geometry._kernels``).
    nodes : (S, 2) int64 ndarray
        Node id of the internode under the first and second half of the segment.
    keys : (S,) int64 ndarray
        Stable identity: ``2c`` for the segment ending at internode c's midpoint, ``2i+1`` for tip i's half.
    axis : (S,) int64 ndarray
        Index of the node that starts the segment's axis (chain of main children).
    caps : (S,) uint8 ndarray
        Bit 1: start cap (root, lateral start), bit 2: end cap (tip).
    """

    records: np.ndarray
    nodes: np.ndarray
    keys: np.ndarray
    axis: np.ndarray
    caps: np.ndarray

    def __len__(self) -> int:
        return len(self.keys)


def _check_tree(pos, parent, radius, alive, main_child, *, forest: bool = False):
    """The door of every tree mesher; ``forest``: the plain branch meshers take several roots (a turtle move
    before ``F``), which the kernels draw as separate trees."""
    pos, parent, radius = check_tree_arrays(pos, parent, radius, forest=forest)
    n = len(pos)
    inner = parent >= 0                                    # nodes that end an internode (the others are roots)
    if np.any(radius[inner] <= 0):
        raise ValueError(f"radius must be > 0 for every internode, got min {radius[inner].min()!r}")
    if alive is None:
        alive = np.ones(n, bool)
    else:
        a = np.asarray(alive) if not isinstance(alive, str) else None
        if a is None or not (a.dtype == np.bool_ or (a.dtype.kind in "iu" and np.isin(a, (0, 1)).all())):
            raise ValueError(f"alive must be a bool array of shape ({n},), got "
                             f"{type(alive).__name__ if a is None else a.dtype}")
        alive = check_array("alive", a, shape=(n,), dtype=np.bool_)
    if main_child is None:
        main_child = np.zeros(0, np.int64)
    else:
        main_child = check_index("main_child", main_child, shape=(n,), low=-1, high=n - 1)
    d = pos[inner] - pos[parent[inner]]
    if np.any((np.einsum("ij,ij->i", d, d) <= 0) & alive[inner]):
        raise ValueError("pos must give every live internode a positive length")
    return pos, parent, radius, alive, main_child


def tree_segments(pos, parent, radius, *, alive=None, main_child=None, bezier_w: float = 3.0,
                  bark_rate: float = 1.0, _checked: bool = False) -> Segments:
    """Skeleton segments of a tree: one rational Bézier around every node, straight halves at root and tips.

    Parameters
    ----------
    pos : (N, 3) float64 ndarray
        Node positions; a root (node 0, and any node with parent -1 in a forest) is a base point, node i
        with ``parent[i] >= 0`` the tip of internode parent[i] → i.
    parent : (N,) int ndarray
        Parent index, -1 for a root (always node 0), ``parent[i] < i``.
    radius : (N,) float64 ndarray
        Radius of the internode ending at each node (unused at roots).
    alive : (N,) bool ndarray, optional
        Dead nodes and their subtrees are skipped.
    main_child : (N,) int ndarray, optional
        Main child of each node (-1: none); default the lowest live child index (thesis §9.2).
    bezier_w : float
        Central weight w of Eq. 10.1 (default 3, Fig. 10.6).
    bark_rate : float
        Texture coordinate per unit length along the branch (B.2 "Bark texture rate").

    Returns
    -------
    Segments
        Records sorted by key.

    References
    ----------
    .. [1] Thesis §10.1.1, Eq. 10.1 (ERRATUM A.9); start frames propagated with a TreeUnfold (§10.1.2,
       ERRATUM A.10 for N'(1)); t0/t1 continuous along paths (§10.1.3, Eq. 10.13 with ERRATUM A.12b).
    """
    if not _checked:
        pos, parent, radius, alive, main_child = _check_tree(pos, parent, radius, alive, main_child, forest=True)
        bezier_w = check_range("bezier_w", bezier_w, 0.0, 1e3, low_open=True)
        bark_rate = check_range("bark_rate", bark_rate, 0.0, 1e6)
    eff, main, frame, tmid, axis = K._unfold_numba(pos, parent, alive, main_child, bark_rate)
    rec, nodes, keys, ax, caps = K._records_numba(pos, parent, radius, eff, main, frame, tmid, axis, bezier_w,
                                                  bark_rate)
    return Segments(records=rec, nodes=nodes, keys=keys, axis=ax, caps=caps)


# ---------------------------------------------------------------------------------------------------------
@dataclass(eq=False)
class BranchMesh(TriMesh):
    """Triangle mesh of the branches plus the layout that allows segment-wise updates.

    Attributes
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int64 ndarray
        Counter-clockwise seen from outside (normals point outward).
    normals : (V, 3) float32 ndarray
        Analytic unit normals of the generalized cylinder.
    uv : (V, 2) float32 ndarray
        Bark coordinates: around (v × repeat), along (bark rate × D(u), continuous along paths).
    node_id : (V,) int64 ndarray
        Node whose internode the vertex belongs to.
    segments : Segments
    counts : (S, K+1) int32 ndarray
        Ring subdivisions per ring.
    v_off, f_off : (S+1,) int64 ndarray
        Vertex and face ranges of each segment.
    options : dict
        Build options, reused by :func:`update_branch_mesh`.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray
    node_id: np.ndarray
    segments: Segments
    counts: np.ndarray
    v_off: np.ndarray
    f_off: np.ndarray
    options: dict = field(default_factory=dict)

    def segment_slice(self, s: int) -> tuple[slice, slice]:
        """Vertex and face slices of segment ``s``."""
        return slice(self.v_off[s], self.v_off[s + 1]), slice(self.f_off[s], self.f_off[s + 1])


def _offsets(cnt: np.ndarray, caps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First vertex and first face of each segment's block (ring counts ``cnt``, end-cap flags ``caps``)."""
    cap_s = (caps & CAP_START) > 0
    cap_e = (caps & CAP_END) > 0
    nv = (cnt + 1).sum(1) + cap_s * (cnt[:, 0] + 1) + cap_e * (cnt[:, -1] + 1)
    nf = (cnt[:, :-1] + cnt[:, 1:]).sum(1) + cap_s * cnt[:, 0] + cap_e * cnt[:, -1]
    v_off = np.zeros(len(cnt) + 1, np.int64)
    f_off = np.zeros(len(cnt) + 1, np.int64)
    np.cumsum(nv, out=v_off[1:])
    np.cumsum(nf, out=f_off[1:])
    return v_off, f_off


def _layout(seg: Segments, ksteps: int, tip_radius: float, lod):
    r = seg.records
    n0 = lod_level(r[:, K.REC_R0], tip_radius=tip_radius, lod=lod)
    n1 = lod_level(r[:, K.REC_R2], tip_radius=tip_radius, lod=lod)
    cnt = ring_counts(n0, n1, ksteps)
    return (cnt, *_offsets(cnt, seg.caps))


def _alloc(nv: int, nf: int):
    return (np.empty((nv, 3)), np.empty((nv, 3), np.float32), np.empty((nv, 2), np.float32),
            np.empty(nv, np.int64), np.empty((nf, 3), np.int64))


def _check_options(bezier_w, u_steps, lod, tip_radius, bark_rate, bark_repeat, radius, parent, alive):
    bezier_w = check_range("bezier_w", bezier_w, 0.0, 1e3, low_open=True)
    u_steps = check_int("u_steps", u_steps, 1, 64)
    if not (isinstance(lod, (tuple, list)) and len(lod) == 2):
        raise ValueError(f"lod must be a pair (min, max) of subdivisions, got {lod!r}")
    lo = check_int("lod[0]", lod[0], 3, 64)
    hi = check_int("lod[1]", lod[1], lo, 64)
    if tip_radius is None:
        live = radius[(parent >= 0) & alive]
        tip_radius = float(live.min()) if live.size else 1.0
    tip_radius = check_range("tip_radius", tip_radius, 0.0, np.inf, low_open=True)
    bark_rate = check_range("bark_rate", bark_rate, 0.0, 1e6)
    bark_repeat = check_int("bark_repeat", bark_repeat, 1, 64)
    return {"bezier_w": bezier_w, "u_steps": u_steps, "lod": (lo, hi), "tip_radius": tip_radius,
            "bark_rate": bark_rate, "bark_repeat": bark_repeat}


def build_branch_mesh(pos, parent, radius, *, alive=None, main_child=None, bezier_w: float = 3.0,
                      u_steps: int = 4, lod: tuple[int, int] = LOD_FULL, tip_radius: float | None = None,
                      bark_rate: float = 1.0, bark_repeat: int = 1, kernel: str = "numba") -> BranchMesh:
    """Generalized-cylinder mesh of all branches of a tree (Eqs. 10.1–10.10, 10.13; spec §3.1–§3.3, §3.5).

    Parameters
    ----------
    pos, parent, radius, alive, main_child
        The tree, as in :func:`tree_segments`.
    bezier_w : float
        Central weight w of Eq. 10.1.
    u_steps : int
        Bands along each segment (rings = u_steps + 1), in [1, 64].
    lod : (int, int)
        Ring subdivisions at the tip radius and at 50× the tip radius: (10, 64) or (6, 32) (spec §3.5).
    tip_radius : float, optional
        Tip radius of the LOD rule; default the smallest live radius.
    bark_rate : float
        Bark texture coordinate per unit length (B.2 "Bark texture rate").
    bark_repeat : int
        Texture repeats around the branch.
    kernel : {"numba", "numpy"}
        The compiled kernel or its readable twin (tests).

    Returns
    -------
    BranchMesh
        Each axis (chain of main children) is a closed, outward-oriented tube once coincident vertices at
        joins and seams are merged; rings at shared midpoints coincide and have equal counts.

    References
    ----------
    .. [1] Thesis §10.1–§10.3; Eqs. 10.1 (A.9), 10.2–10.7 (A.10, A.11), 10.8–10.10, 10.13 (A.12b); LOD §10.3.
    """
    pos, parent, radius, alive, main_child = _check_tree(pos, parent, radius, alive, main_child, forest=True)
    opts = _check_options(bezier_w, u_steps, lod, tip_radius, bark_rate, bark_repeat, radius, parent, alive)
    if not isinstance(kernel, str) or kernel not in ("numba", "numpy"):
        raise ValueError(f"kernel must be one of ['numba', 'numpy'], got {kernel!r}")
    seg = tree_segments(pos, parent, radius, alive=alive, main_child=main_child, bezier_w=opts["bezier_w"],
                        bark_rate=opts["bark_rate"], _checked=True)
    return _build(seg, opts, kernel)


def _build(seg: Segments, opts: dict, kernel: str = "numba") -> BranchMesh:
    cnt, v_off, f_off = _layout(seg, opts["u_steps"], opts["tip_radius"], opts["lod"])
    return _evaluate(seg, cnt, v_off, f_off, opts, kernel)


def _evaluate(seg: Segments, cnt, v_off, f_off, opts: dict, kernel: str = "numba") -> BranchMesh:
    """Mesh every segment of ``seg`` with the ring counts ``cnt`` in the blocks ``v_off``/``f_off``."""
    V, NRM, UV, NID, F = _alloc(int(v_off[-1]), int(f_off[-1]))
    fn = K.eval_segments if kernel == "numba" else K._eval_segments_numpy   # threads only for big trees
    fn(seg.records, cnt, opts["u_steps"], seg.nodes, seg.caps, np.arange(len(seg), dtype=np.int64), v_off,
       f_off, float(opts["bark_repeat"]), V, NRM, UV, NID, F)
    return BranchMesh(V, F, NRM, UV, NID, seg, cnt, v_off, f_off, dict(opts))


def update_branch_mesh(old: BranchMesh, pos, parent, radius, *, alive=None,
                       main_child=None) -> tuple[BranchMesh, np.ndarray]:
    """Re-mesh a tree after a change, re-evaluating only the segments whose record changed (spec §3.5, item 20).

    When the layout changes this copies every unchanged block into new arrays; for a stream of growth steps
    use :class:`IncrementalBranchMesh`, which rewrites only the changed blocks.

    Parameters
    ----------
    old : BranchMesh
        The previous mesh; its build options are kept.
    pos, parent, radius, alive, main_child
        The changed tree, as in :func:`build_branch_mesh`.

    Returns
    -------
    mesh : BranchMesh
        Equal to a full :func:`build_branch_mesh` with the same options. When the set of segments and their
        ring counts are unchanged, ``old``'s arrays are updated in place and ``old`` is returned.
    changed : (C,) int64 ndarray
        Indices of the segments re-evaluated (vertex ranges ``mesh.v_off[c]:mesh.v_off[c+1]``).
    """
    pos, parent, radius, alive, main_child = _check_tree(pos, parent, radius, alive, main_child, forest=True)
    o = old.options
    seg = tree_segments(pos, parent, radius, alive=alive, main_child=main_child, bezier_w=o["bezier_w"],
                        bark_rate=o["bark_rate"], _checked=True)
    cnt, v_off, f_off = _layout(seg, o["u_steps"], o["tip_radius"], o["lod"])
    os_ = old.segments
    j = np.minimum(np.searchsorted(os_.keys, seg.keys), max(len(os_) - 1, 0))
    same = (len(os_) > 0) & (os_.keys[j] == seg.keys)
    same &= np.all(os_.records[j] == seg.records, axis=1) & np.all(old.counts[j] == cnt, axis=1)
    same &= np.all(os_.nodes[j] == seg.nodes, axis=1) & (os_.caps[j] == seg.caps)
    changed = np.flatnonzero(~same).astype(np.int64)
    args = (float(o["bark_repeat"]),)
    if len(os_) == len(seg) and np.array_equal(os_.keys, seg.keys) and np.array_equal(old.counts, cnt):
        K.eval_segments(seg.records, cnt, o["u_steps"], seg.nodes, seg.caps, changed, v_off, f_off,
                        *args, old.vertices, old.normals, old.uv, old.node_id, old.faces)
        old.segments = seg
        return old, changed
    V, NRM, UV, NID, F = _alloc(int(v_off[-1]), int(f_off[-1]))
    keep = np.flatnonzero(same)
    jk = j[keep]
    K.copy_blocks(old.v_off[jk], v_off[keep], v_off[keep + 1] - v_off[keep], old.f_off[jk], f_off[keep],
                         f_off[keep + 1] - f_off[keep], old.vertices, old.normals, old.uv, old.node_id,
                         old.faces, V, NRM, UV, NID, F)
    K.eval_segments(seg.records, cnt, o["u_steps"], seg.nodes, seg.caps, changed, v_off, f_off, *args,
                    V, NRM, UV, NID, F)
    return BranchMesh(V, F, NRM, UV, NID, seg, cnt, v_off, f_off, dict(o)), changed


# ---------------------------------------------------------------------------------------------------------
# Incremental mesh: slot layout with slack capacity (spec §3.5, checklist item 20)
@dataclass
class MeshUpdate:
    """What one :meth:`IncrementalBranchMesh.update` rewrote.

    Attributes
    ----------
    changed : (C,) int64 ndarray
        Keys (see :class:`Segments`) of the segments re-evaluated.
    removed : (D,) int64 ndarray
        Keys of the segments that vanished (their blocks are now degenerate).
    vertex_ranges, face_ranges : (R, 2) int64 ndarray
        ``[start, stop)`` rows of the vertex and face buffers that were written (re-evaluated or blanked
        blocks); only these need re-uploading when ``relayout`` is False.
    relayout : bool
        The buffers were re-allocated, re-laid out (full rebuild) or compacted: re-bind and re-upload all.
    n_vertices, n_faces : int
        Rows in use after the update (``mesh.vertices`` / ``mesh.faces`` lengths).
    """

    changed: np.ndarray
    removed: np.ndarray
    vertex_ranges: np.ndarray
    face_ranges: np.ndarray
    relayout: bool
    n_vertices: int
    n_faces: int


def _block_sizes(cnt: np.ndarray, caps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cap_s = (caps & CAP_START) > 0
    cap_e = (caps & CAP_END) > 0
    nv = (cnt + 1).sum(1) + cap_s * (cnt[:, 0] + 1) + cap_e * (cnt[:, -1] + 1)
    nf = (cnt[:, :-1] + cnt[:, 1:]).sum(1) + cap_s * cnt[:, 0] + cap_e * cnt[:, -1]
    return nv.astype(np.int64), nf.astype(np.int64)


def _grow(a: np.ndarray, n: int, fill=None) -> np.ndarray:
    out = np.empty((n,) + a.shape[1:], a.dtype) if fill is None else np.full((n,) + a.shape[1:], fill, a.dtype)
    out[:len(a)] = a
    return out


def _in_use(buffer: str, used: str, doc: str) -> property:
    """The rows of a growable buffer attribute in use (a view, no copy)."""
    return property(lambda self: getattr(self, buffer)[:getattr(self, used)], doc=doc)


class IncrementalBranchMesh(BufferMesh):
    """Branch mesh kept up to date segment by segment after growth steps (spec §3.5, checklist item 20).

    Every segment (one 20-float record, :class:`Segments`) owns a block of the vertex and face buffers with
    slack capacity. :meth:`update` re-evaluates only the segments whose record or ring counts changed; a
    segment that outgrows its block, or a new one, gets a free block of the same size or a new block at the
    end; blocks of vanished or moved segments become degenerate (zero-area faces, node id -1) until the next
    compaction. Unused tails of blocks are degenerate too, so ``vertices``/``faces`` always render as the
    tree. :meth:`to_branch_mesh` returns the compact mesh, equal array for array to
    :func:`build_branch_mesh` with the same options (the test oracle).

    Parameters
    ----------
    pos, parent, radius, alive, main_child
        The tree, as in :func:`tree_segments`.
    bezier_w, u_steps, lod, tip_radius, bark_rate, bark_repeat
        As in :func:`build_branch_mesh`; fixed for the life of the object. ``tip_radius`` defaults to the
        smallest live radius of the first tree (pass the model's tip radius so growth does not change it).
    slack : float
        Extra capacity of each block, as a fraction of its size, in [0, 4] (capped at the size the block
        would have with every ring at ``lod[1]``); lets ring counts grow in place as radii grow.
    max_waste : float
        Compact when the rows of free blocks exceed this fraction of the rows in use, in (0, 1].
    rebuild_fraction : float
        Re-lay out everything when more than this fraction of the segments would move (e.g. after pruning,
        which renumbers the snapshot's nodes), in (0, 1].

    Attributes
    ----------
    options : dict
        The build options.
    buffer_version : int
        Bumped whenever the buffers are re-allocated or re-laid out; views re-bind their arrays then.

    References
    ----------
    .. [1] Thesis §10.3: the per-cylinder patch as the unit of CPU→GPU update; spec 000_treewand §3.5.
    """

    def __init__(self, pos, parent, radius, *, alive=None, main_child=None, bezier_w: float = 3.0,
                 u_steps: int = 4, lod: tuple[int, int] = LOD_FULL, tip_radius: float | None = None,
                 bark_rate: float = 1.0, bark_repeat: int = 1, slack: float = 0.25, max_waste: float = 0.5,
                 rebuild_fraction: float = 0.5):
        pos, parent, radius, alive, main_child = _check_tree(pos, parent, radius, alive, main_child, forest=True)
        opts = _check_options(bezier_w, u_steps, lod, tip_radius, bark_rate, bark_repeat, radius, parent, alive)
        super().__init__()
        self.slack = check_range("slack", slack, 0.0, 4.0)
        self.max_waste = check_range("max_waste", max_waste, 0.0, 1.0, low_open=True)
        self.rebuild_fraction = check_range("rebuild_fraction", rebuild_fraction, 0.0, 1.0, low_open=True)
        self.options = opts
        self.buffer_version = 0
        self._sm = smoothstep(np.arange(opts["u_steps"] + 1) / opts["u_steps"])
        seg = tree_segments(pos, parent, radius, alive=alive, main_child=main_child, bezier_w=opts["bezier_w"],
                            bark_rate=opts["bark_rate"], _checked=True)
        self._root = pos[0].copy()
        self._relayout(seg, *self._counts(seg))

    # -- public arrays ----------------------------------------------------------------------------------
    vertices = _in_use("_V", "_v_used", "(V, 3) float64 vertex rows in use (a view of the buffer; free rows sit at "
                       "the root, degenerate).")
    normals = _in_use("_NRM", "_v_used", "(V, 3) float32 unit normals.")
    uv = _in_use("_UV", "_v_used", "(V, 2) float32 bark coordinates.")
    node_id = _in_use("_NID", "_v_used", "(V,) int64 node of each vertex, -1 in free blocks.")
    faces = _in_use("_F", "_f_used", "(F, 3) int64 faces in use; faces of free blocks and block tails are degenerate "
                    "(a, a, a).")

    @property
    def n_segments(self) -> int:
        """Live segments."""
        return int(self._live[:self._n].sum())

    @property
    def waste(self) -> float:
        """Fraction of the vertex rows in use that belong to free blocks."""
        n = self._n
        return float(self._vcap[:n][~self._live[:n]].sum()) / max(self._v_used, 1)

    # -- layout -----------------------------------------------------------------------------------------
    def _counts(self, seg: Segments):
        o = self.options
        return K._counts_numba(seg.records, self._sm, o["tip_radius"], o["lod"][0], o["lod"][1], seg.caps)

    def _capacity(self, cnt, caps, nv, nf):
        hi = self.options["lod"][1]
        nv_max, nf_max = _block_sizes(np.full((1, cnt.shape[1]), hi, np.int32), caps)
        vcap = np.minimum(np.maximum(nv_max, nv), nv + np.ceil(self.slack * nv).astype(np.int64))
        fcap = np.minimum(np.maximum(nf_max, nf), nf + np.ceil(self.slack * nf).astype(np.int64))
        return vcap, fcap

    def _alloc_buffers(self, nv: int, nf: int):
        self._V, self._NRM, self._UV, self._NID, self._F = _alloc(nv, nf)
        self.buffer_version += 1

    def _relayout(self, seg: Segments, cnt, nv, nf) -> None:
        """Fresh layout of all segments in key order, each block with slack, everything evaluated."""
        S = len(seg)
        vcap, fcap = self._capacity(cnt, seg.caps, nv, nf)
        v0 = np.zeros(S + 1, np.int64)
        f0 = np.zeros(S + 1, np.int64)
        np.cumsum(vcap, out=v0[1:])
        np.cumsum(fcap, out=f0[1:])
        self._alloc_buffers(int(v0[-1] * 1.1) + 64, int(f0[-1] * 1.1) + 64)
        self._v_used, self._f_used = int(v0[-1]), int(f0[-1])
        self._set_slots(seg, cnt, nv, nf, v0[:-1], vcap, f0[:-1], fcap)
        idx = np.arange(S, dtype=np.int64)
        K.eval_segments(seg.records, cnt, self.options["u_steps"], seg.nodes, seg.caps, idx, self._v0,
                        self._f0, float(self.options["bark_repeat"]), self._V, self._NRM, self._UV,
                        self._NID, self._F)
        K._fill_slack_numba(self._v0[:S], nv, vcap, self._f0[:S], nf, fcap, self._V, self._NRM, self._UV,
                            self._NID, self._F)

    def _set_slots(self, seg, cnt, nv, nf, v0, vcap, f0, fcap) -> None:
        S = len(seg)
        self._key = seg.keys.copy()
        self._rec = seg.records.copy()
        self._cnt = cnt.copy()
        self._nodes = seg.nodes.copy()
        self._caps = seg.caps.copy()
        self._axis = seg.axis.copy()
        self._nv, self._nf = nv.copy(), nf.copy()
        self._v0, self._vcap, self._f0, self._fcap = v0.copy(), vcap.copy(), f0.copy(), fcap.copy()
        self._live = np.ones(S, bool)
        self._n = S
        self._extend_slots(S + S // 8 + 64)                      # headroom for the next growth steps
        self._slot_of_key = np.full(int(seg.keys.max()) + 1 if S else 0, -1, np.int64)
        self._slot_of_key[seg.keys] = np.arange(S)

    # -- update -----------------------------------------------------------------------------------------
    def update(self, pos, parent, radius, *, alive=None, main_child=None) -> MeshUpdate:
        """Bring the mesh to a changed tree, re-evaluating only the segments that changed.

        Parameters
        ----------
        pos, parent, radius, alive, main_child
            The changed tree, as in :func:`tree_segments`. Segments are identified by key (node index), so
            node indices must be stable between calls (true between growth steps of a snapshot; after
            pruning most keys move and the update becomes a full re-layout).

        Returns
        -------
        MeshUpdate
        """
        pos, parent, radius, alive, main_child = _check_tree(pos, parent, radius, alive, main_child, forest=True)
        o = self.options
        seg = tree_segments(pos, parent, radius, alive=alive, main_child=main_child, bezier_w=o["bezier_w"],
                            bark_rate=o["bark_rate"], _checked=True)
        self._root = pos[0].copy()
        cnt, nv, nf = self._counts(seg)
        slot, status = K._diff_numba(seg.keys, seg.records, cnt, seg.nodes, seg.caps, nv, nf, self._slot_of_key,
                                     self._rec, self._cnt, self._nodes, self._caps, self._vcap, self._fcap)
        kept = slot[status < 3]
        seen = np.zeros(self._n, bool)
        seen[kept] = True
        gone = np.flatnonzero(self._live[:self._n] & ~seen)   # vanished keys and segments that must move
        changed = np.flatnonzero(status > 0)
        moving = np.flatnonzero(status == 3)
        empty = np.zeros((0, 2), np.int64)
        if len(moving) > self.rebuild_fraction * max(len(seg), 1):
            removed = np.setdiff1d(self._key[self._live], seg.keys)
            self._relayout(seg, cnt, nv, nf)
            return MeshUpdate(seg.keys[changed], removed, empty, empty, True, self._v_used, self._f_used)
        removed_keys = self._key[gone][~np.isin(self._key[gone], seg.keys)]
        # free the blocks of vanished and moving segments
        self._live[gone] = False
        self._slot_of_key[self._key[gone]] = -1
        self._key[gone] = -1
        K._free_numba(self._v0[gone], self._vcap[gone], self._f0[gone], self._fcap[gone], self._root, self._V,
                      self._NRM, self._UV, self._NID, self._F)
        relayout = False
        if len(moving):
            relayout = self._place(slot, moving, cnt, seg.caps, nv, nf)
        # record the new state of every changed segment in its slot
        sl = slot[changed]
        if len(seg.keys) and seg.keys.max() >= len(self._slot_of_key):
            need = int(seg.keys.max()) + 1
            self._slot_of_key = _grow(self._slot_of_key, max(need, int(1.5 * len(self._slot_of_key))), -1)
        self._key[sl] = seg.keys[changed]
        self._slot_of_key[seg.keys[changed]] = sl
        self._rec[sl] = seg.records[changed]
        self._cnt[sl] = cnt[changed]
        self._nodes[sl] = seg.nodes[changed]
        self._caps[sl] = seg.caps[changed]
        self._axis[slot] = seg.axis
        self._nv[sl], self._nf[sl] = nv[changed], nf[changed]
        self._live[sl] = True
        geo = slot[status == 1]                               # radius only: positions and normals
        full = slot[status > 1]
        bufs = (self._V, self._NRM, self._UV, self._NID, self._F)
        args = (self._rec, self._cnt, o["u_steps"], self._nodes, self._caps)
        if len(geo):
            K.eval_segments(*args, geo, self._v0, self._f0, float(o["bark_repeat"]), *bufs, full=False)
        if len(full):
            K.eval_segments(*args, full, self._v0, self._f0, float(o["bark_repeat"]), *bufs)
            K._fill_slack_numba(self._v0[full], self._nv[full], self._vcap[full], self._f0[full], self._nf[full],
                                self._fcap[full], *bufs)
        if self.waste > self.max_waste:
            self.compact()
            relayout = True
        if relayout:
            return MeshUpdate(seg.keys[changed], removed_keys, empty, empty, True, self._v_used, self._f_used)
        blocks = np.concatenate([sl, gone])
        vr = np.stack([self._v0[blocks], self._v0[blocks] + self._vcap[blocks]], axis=1)
        fr = np.stack([self._f0[blocks], self._f0[blocks] + self._fcap[blocks]], axis=1)
        return MeshUpdate(seg.keys[changed], removed_keys, vr, fr, relayout, self._v_used, self._f_used)

    def _place(self, slot, moving, cnt, caps, nv, nf) -> bool:
        """Give each moving segment a free block of exactly its capacity, else a new block at the end."""
        vcap, fcap = self._capacity(cnt[moving], caps[moving], nv[moving], nf[moving])
        free = np.flatnonzero(~self._live[:self._n])
        take = np.full(len(moving), -1, np.int64)
        if len(free):
            # exact size classes: a freed tip half is reused by the next new tip half (same ring counts)
            fkey = self._vcap[free] * (1 << 32) + self._fcap[free]
            nkey = vcap * (1 << 32) + fcap
            fo = np.argsort(fkey, kind="stable")
            fkey, free = fkey[fo], free[fo]
            no = np.argsort(nkey, kind="stable")
            first = np.searchsorted(fkey, nkey[no], side="left")
            avail = np.searchsorted(fkey, nkey[no], side="right") - first
            rank = np.arange(len(no)) - np.searchsorted(nkey[no], nkey[no], side="left")
            ok = rank < avail
            take[no[ok]] = free[first[ok] + rank[ok]]
        new = take < 0
        n_new = int(new.sum())
        relayout = False
        if n_new:
            S0 = self._n
            ids = np.arange(S0, S0 + n_new)
            take[new] = ids
            self._extend_slots(S0 + n_new)
            self._n = S0 + n_new
            v_start = self._v_used + np.concatenate([[0], np.cumsum(vcap[new])[:-1]]).astype(np.int64)
            f_start = self._f_used + np.concatenate([[0], np.cumsum(fcap[new])[:-1]]).astype(np.int64)
            self._v0[ids], self._f0[ids] = v_start, f_start
            self._vcap[ids], self._fcap[ids] = vcap[new], fcap[new]
            need_v = self._v_used + int(vcap[new].sum())
            need_f = self._f_used + int(fcap[new].sum())
            if need_v > len(self._V) or need_f > len(self._F):
                self._reserve(max(need_v, int(1.5 * len(self._V))), max(need_f, int(1.5 * len(self._F))))
                relayout = True
            self._v_used, self._f_used = need_v, need_f
        slot[moving] = take
        return relayout

    def _extend_slots(self, n: int) -> None:
        if n <= len(self._key):
            return
        n = max(n, int(1.5 * len(self._key)) + 16)             # amortised: slot arrays grow geometrically
        for name in ("_rec", "_cnt", "_nodes", "_caps", "_axis", "_nv", "_nf", "_v0", "_vcap", "_f0", "_fcap"):
            setattr(self, name, _grow(getattr(self, name), n, 0))
        self._key = _grow(self._key, n, -1)
        self._live = _grow(self._live, n, False)

    def _reserve(self, nv: int, nf: int) -> None:
        old = (self._V, self._NRM, self._UV, self._NID, self._F)
        self._alloc_buffers(nv, nf)
        for a, b in zip(old, (self._V, self._NRM, self._UV, self._NID, self._F)):
            n = self._v_used if a is not old[-1] else self._f_used
            b[:n] = a[:n]

    # -- compaction -------------------------------------------------------------------------------------
    def _live_order(self) -> np.ndarray:
        live = np.flatnonzero(self._live[:self._n])
        return live[np.argsort(self._key[live], kind="stable")]

    def segments(self) -> Segments:
        """The live segments' records, in key order (as :func:`tree_segments` returns them)."""
        q = self._live_order()
        return Segments(records=self._rec[q].copy(), nodes=self._nodes[q].copy(), keys=self._key[q].copy(),
                        axis=self._axis[q].copy(), caps=self._caps[q].copy())

    def compact(self) -> None:
        """Re-lay out the live blocks in key order with fresh slack, dropping free blocks (copies, no re-evaluation)."""
        q = self._live_order()
        vcap, fcap = self._capacity(self._cnt[q], self._caps[q], self._nv[q], self._nf[q])
        v0 = np.concatenate([[0], np.cumsum(vcap)]).astype(np.int64)
        f0 = np.concatenate([[0], np.cumsum(fcap)]).astype(np.int64)
        old = (self._V, self._NRM, self._UV, self._NID, self._F)
        src_v0, src_f0, nv, nf = self._v0[q], self._f0[q], self._nv[q], self._nf[q]
        self._alloc_buffers(int(v0[-1] * 1.1) + 64, int(f0[-1] * 1.1) + 64)
        K.copy_blocks(src_v0, v0[:-1], nv, src_f0, f0[:-1], nf, *old, self._V, self._NRM, self._UV,
                             self._NID, self._F)
        seg = Segments(records=self._rec[q], nodes=self._nodes[q], keys=self._key[q], axis=self._axis[q],
                       caps=self._caps[q])
        self._set_slots(seg, self._cnt[q], nv, nf, v0[:-1], vcap, f0[:-1], fcap)
        self._v_used, self._f_used = int(v0[-1]), int(f0[-1])
        n = self._n
        K._fill_slack_numba(self._v0[:n], self._nv[:n], self._vcap[:n], self._f0[:n], self._nf[:n],
                            self._fcap[:n], self._V, self._NRM, self._UV, self._NID, self._F)

    def to_branch_mesh(self) -> BranchMesh:
        """The compact mesh (no free blocks, no slack): equal to :func:`build_branch_mesh` of the same tree."""
        q = self._live_order()
        cnt, nv, nf = self._cnt[q], self._nv[q], self._nf[q]
        v_off = np.concatenate([[0], np.cumsum(nv)]).astype(np.int64)
        f_off = np.concatenate([[0], np.cumsum(nf)]).astype(np.int64)
        V, NRM, UV, NID, F = _alloc(int(v_off[-1]), int(f_off[-1]))
        K.copy_blocks(self._v0[q], v_off[:-1], nv, self._f0[q], f_off[:-1], nf, self._V, self._NRM,
                             self._UV, self._NID, self._F, V, NRM, UV, NID, F)
        return BranchMesh(V, F, NRM, UV, NID, self.segments(), cnt.copy(), v_off, f_off, dict(self.options))

"""Control mesh: k-sided branch tubes + convex-hull joints (spec 001_subdivision §2.3, §2.4, §3 radius note).

Every branch is a truncated cone of ``sides``-gon loops triangulated by Algorithm 1 (faces ABC, BDC,
ERRATUM A7); every joint is the convex hull of the parent's last loop and the children's first loops,
projected onto a sphere (spec §2.4.2, with its n·d > 0 sign rule), with the cap triangles removed and
the original positions restored. Joint faces reuse the loop vertex ids, so the result is one manifold
mesh, open only at the base and the branch tips.
"""
from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np

from plantvr._validation import MAX_COUNT, check_choice, check_index, check_int, check_range
from plantvr.types import TriMesh

from ._checks import MAX_JOINT_POINTS
from .graph import BranchGraph, Joints, _simplify, joint_pairs
from .hull import joint_hulls
from .loop import cap_boundaries, subdivide_loop

__all__ = ["ControlMesh", "build_control_mesh", "radius_factor"]


def radius_factor(sides: int) -> float:
    """Mean limit-surface radius / control radius of a long straight tube of ``sides``-gon loops.

    Measured once per ``sides`` (and cached) on a reference tube (radius 1, 12 segments of length π/2, fixed
    ends) after 5 Loop levels, over its middle fifth. At a loop *vertex* the regular limit mask (1/2 for the
    vertex, 1/12 for each of its six neighbours) gives ``1/2 + (1 + 2 cos(2π/S))/6`` (0.667 for S = 4); the
    mean over the whole cross-section is a little lower (0.657 for S = 4, 0.832 for S = 6, 0.902 for S = 8,
    the spec's measured values). [INFERRED; spec §2.3 "radius_compensation".]

    Parameters
    ----------
    sides : int
        Vertices per loop, 3–64.

    Returns
    -------
    float
        The shrink factor.

    Examples
    --------
    >>> round(radius_factor(4), 2)
    0.66
    """
    sides = check_int("sides", sides, 3, 64)
    return _radius_factor(sides)


@functools.cache
def _radius_factor(S: int) -> float:
    N = 12
    th = 2.0 * np.pi * np.arange(S) / S
    y = np.arange(N + 1) * (np.pi / 2)
    V = np.stack([np.broadcast_to(np.cos(th), (N + 1, S)), np.broadcast_to(y[:, None], (N + 1, S)),
                  -np.broadcast_to(np.sin(th), (N + 1, S))], -1).reshape(-1, 3)
    j = np.arange(S)
    A = np.arange(N)[:, None] * S + j[None, :]
    B = np.arange(N)[:, None] * S + ((j + 1) % S)[None, :]
    F = np.stack([A, B, A + S, B, B + S, A + S], -1).reshape(-1, 3)
    V5, _ = subdivide_loop(V, F, 5)
    mid = np.abs(V5[:, 1] - y[-1] / 2) < y[-1] / 10
    return float(np.hypot(V5[mid, 0], V5[mid, 2]).mean())


@dataclass(eq=False)
class ControlMesh(TriMesh):
    """The Yggdrasil control mesh and the bookkeeping the tests and views need: a
    :class:`~plantvr.types.TriMesh` (cached normals, edges, bounds, ``to_trimesh`` keeping vertex ids).

    Attributes
    ----------
    vertices : (V, 3) float64 ndarray
    faces : (F, 3) int64 ndarray
        Outward-wound triangles; open at the base and the branch tips unless ``capped``.
    graph : BranchGraph
        The simplified graph the mesh was built from.
    n_segments : (B,) int64 ndarray
        Segments N per branch.
    first_loop, last_loop : (B, S) int64 ndarray
        Vertex ids of each branch's first and last loop.
    joint_sizes : (J,) int64 ndarray
        Loops k per joint.
    hull_faces : (J,) int64 ndarray
        Convex-hull triangles per joint before cap removal (spec V6: 8k - 4 for S = 4).
    joint_faces : (J,) int64 ndarray
        Joint triangles kept (spec V8: 6k - 4 for S = 4).
    n_boundary_loops : int
        Open loops (base + tips) before capping.
    capped : bool
        Whether the open loops were closed by fans.
    """

    vertices: np.ndarray
    faces: np.ndarray
    graph: BranchGraph
    n_segments: np.ndarray
    first_loop: np.ndarray
    last_loop: np.ndarray
    joint_sizes: np.ndarray
    hull_faces: np.ndarray
    joint_faces: np.ndarray
    n_boundary_loops: int
    capped: bool


def _frames(g: BranchGraph) -> tuple[np.ndarray, np.ndarray]:
    """Per-branch (u, w) with u x w = axis, u parallel-transported from the parent [INFERRED]."""
    ax = g.axis
    nb = len(g)
    depth = np.zeros(nb, np.int64)
    par = g.parent
    for i in range(nb):  # parent < i
        if par[i] >= 0:
            depth[i] = depth[par[i]] + 1
    u = np.zeros((nb, 3))
    roots = np.flatnonzero(par < 0)
    ref = np.where(np.abs(ax[roots, 0:1]) < 0.9, [[1.0, 0, 0]], [[0, 0, 1.0]])
    u[roots] = ref - np.einsum("ij,ij->i", ref, ax[roots])[:, None] * ax[roots]
    u[roots] /= np.linalg.norm(u[roots], axis=1, keepdims=True)
    order = np.argsort(depth, kind="stable")
    bounds = np.searchsorted(depth[order], np.arange(depth.max() + 2))
    w = np.zeros((nb, 3))
    w[roots] = np.cross(ax[roots], u[roots])
    for lv in range(1, depth.max() + 1):
        ids = order[bounds[lv]:bounds[lv + 1]]
        a = ax[ids]
        up = u[par[ids]]
        wp = w[par[ids]]
        cand = up - np.einsum("ij,ij->i", up, a)[:, None] * a
        n = np.linalg.norm(cand, axis=1)
        alt = wp - np.einsum("ij,ij->i", wp, a)[:, None] * a
        cand = np.where((n < 1e-6)[:, None], alt, cand)
        u[ids] = cand / np.linalg.norm(cand, axis=1, keepdims=True)
        w[ids] = np.cross(a, u[ids])
    return u, w


def _rotation_to(n: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(M, 3, 3) rotations taking unit n to unit d (Rodrigues)."""
    ax = np.cross(n, d)
    s = np.linalg.norm(ax, axis=1)
    c = np.einsum("ij,ij->i", n, d)
    axn = ax / np.where(s > 1e-12, s, 1.0)[:, None]
    K = np.zeros((len(n), 3, 3))
    K[:, 0, 1], K[:, 0, 2] = -axn[:, 2], axn[:, 1]
    K[:, 1, 0], K[:, 1, 2] = axn[:, 2], -axn[:, 0]
    K[:, 2, 0], K[:, 2, 1] = -axn[:, 1], axn[:, 0]
    Q = np.eye(3)[None] + s[:, None, None] * K + (1.0 - c)[:, None, None] * (K @ K)
    same = (s <= 1e-12) & (c > 0)
    Q[same] = np.eye(3)
    opp = np.flatnonzero((s <= 1e-12) & (c <= 0))       # half turn about any axis perpendicular to n
    if opp.size:
        ref = np.where(np.abs(n[opp, 0:1]) < 0.9, [[1.0, 0, 0]], [[0, 0, 1.0]])
        p = np.cross(n[opp], ref)
        p /= np.linalg.norm(p, axis=1, keepdims=True)
        Q[opp] = 2.0 * p[:, :, None] * p[:, None, :] - np.eye(3)[None]
    return Q


def build_control_mesh(graph: BranchGraph, *, sides: int = 4, compensate_radius: bool = True,
                       offset_mode: str = "geometric", min_offset: float = 0.5, offset_margin: float = 0.1,
                       max_offset_factor: float = 4.0, rounding: str = "round", cap: bool = False,
                       overlap: str = "enlarge", hull: str = "incremental", short_leaves="auto",
                       fold_level: int = 3) -> ControlMesh:
    """Build the Yggdrasil control mesh of a branch graph (spec §2.1–§2.4, Alg. 4).

    Parameters
    ----------
    graph : BranchGraph
        Branches from :func:`~plantvr.subdivision.parse_lsystem` or
        :func:`~plantvr.subdivision.graph_from_arrays`.
    sides : int
        Vertices per loop S (3–64; the report uses 4).
    compensate_radius : bool
        Scale inner loops by ``1 / radius_factor(sides)`` so the Loop limit surface has the requested radius
        (issue 5; spec §2.3 offers it as an option). Base and tip loops stay at the requested radius, since
        subdivision keeps them fixed.
    offset_mode : {"geometric", "report"}
        Trimming formula (spec §2.1, ERRATA A4/A5).
    min_offset : float
        Floor on joint offsets as a multiple of the member radius (0–10) [INFERRED].
    offset_margin : float
        Added to every joint offset as a multiple of the member radius (0–10), so that loops of neighbouring
        members never touch (no zero-area joint faces, spec V10) [INFERRED].
    max_offset_factor : float
        Cap on joint offsets as a multiple of the larger radius (1–100).
    rounding : {"round", "floor", "ceil"}
        Rounding of N = L / (π r_avg), with N >= 1 (spec §8.3 item 1).
    cap : bool
        Close the base and tip loops with fans (watertight control mesh).
    overlap : {"enlarge", "raise"}
        What to do when two loops of a joint overlap on the joint sphere (spec V7, common in grown trees
        whose siblings leave almost parallel): ``"raise"`` refuses the joint as the spec asks; ``"enlarge"``
        (default) warns and builds that joint's hull on a larger sphere, which keeps the mesh manifold and
        watertight but may fold where the real branches overlap [INFERRED].
    hull : {"incremental", "qhull"}
        Joint hulls from the batched numba incremental kernel (default; the report's Alg. 3) or one
        ``scipy.spatial.ConvexHull`` (Qhull) per joint (spec C7 asks for both).
    short_leaves : {"auto", "tube", "stub"} or sequence of int
        How a leaf too short for its joint offsets (spec §2.2 edge case: its offset is scaled to 90 % of its
        length) is meshed. ``"tube"``: one segment from its joint loop at 90 % of the length to the fixed tip
        loop (the spec's rule). At a crowded joint (issue 22) the Loop smoothing pulls that joint loop through
        the fixed tip, whose loop is only 0.1 L away, when the neighbours' loops lie further out along the
        leaf's axis than its tip, and the surface folds. ``"stub"``: no tube (N = 0); the fixed tip loop is the
        leaf's loop in the joint hull, so no loop can be pulled through it; but where the neighbours' loops lie
        ahead of the tip plane the tip sits in a pit whose rim can fold over it. ``"auto"`` (default): tubes;
        then the control mesh is subdivided ``fold_level`` times and every short leaf whose tube, tip cap or
        joint faces self-intersect there gets the stub, and the better of the two is kept [INFERRED]. A
        sequence gives the branch ids of the simplified graph (``ControlMesh.graph``) to build as stubs.
        Joints without short leaves are identical in every mode.
    fold_level : int
        Subdivision level (1–4) of the fold test of ``short_leaves="auto"`` (default 3, the default of
        :func:`~plantvr.subdivision.tree_mesh`); pass the level you will subdivide to.

    Returns
    -------
    ControlMesh

    Raises
    ------
    ValueError
        On a bad parameter, an invalid graph, two branches leaving a joint in the same direction, or a joint
        whose hull misses a loop vertex (caps overlapping on the sphere, spec V6/V7).

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.2.2–4.2.5, Algs. 1, 3, 4, Fig. 4.15; spec 001 ERRATA A5, A6, A7.
    """
    sides = check_int("sides", sides, 3, 64)
    check_choice("offset_mode", offset_mode, ("geometric", "report"))
    min_offset = check_range("min_offset", min_offset, 0.0, 10.0)
    offset_margin = check_range("offset_margin", offset_margin, 0.0, 10.0)
    max_offset_factor = check_range("max_offset_factor", max_offset_factor, 1.0, 100.0)
    check_choice("rounding", rounding, ("round", "floor", "ceil"))
    check_choice("overlap", overlap, ("enlarge", "raise"))
    check_choice("hull", hull, ("incremental", "qhull"))
    fold_level = check_int("fold_level", fold_level, 1, 4)
    mode = short_leaves if isinstance(short_leaves, str) else None
    if mode is not None:
        check_choice("short_leaves", short_leaves, ("auto", "tube", "stub"))
    if not isinstance(graph, BranchGraph):
        raise ValueError(f"graph must be a BranchGraph, got {type(graph).__name__}")
    graph.validate()
    S = sides
    roots = np.flatnonzero(graph.parent < 0)
    _, shared = np.unique(graph.start[roots], axis=0, return_counts=True)
    big = max(int(graph.n_children.max(initial=0)) + 1, int(shared.max(initial=0)))
    if big * S > MAX_JOINT_POINTS:
        raise ValueError(f"graph: a joint has {big} branches; at sides={S} at most {MAX_JOINT_POINTS // S} "
                         f"branches may meet at one joint")
    f = radius_factor(S) if compensate_radius else 1.0
    scaled = BranchGraph(graph.start, graph.end, graph.r0 / f, graph.r1 / f, graph.parent)
    g, off_s, off_e, joints, short = _simplify(scaled, offset_mode=offset_mode, min_offset=min_offset,
                                               max_offset_factor=max_offset_factor, offset_margin=offset_margin,
                                               stacklevel=3)
    nb = len(g)
    big = int(np.diff(joints.joint_ptr).max(initial=0))
    if big * S > MAX_JOINT_POINTS:
        raise ValueError(f"graph: a joint has {big} branches; at sides={S} at most {MAX_JOINT_POINTS // S} "
                         f"branches may meet at one joint")
    base = np.zeros(nb, bool)
    base[joints.base_branches] = True
    # leaves too short for their joint (offset scaled to 0.9 L) that start at a joint: tube or stub
    short = short & g.is_leaf & ~base
    stub = np.zeros(nb, bool)
    if mode == "stub":
        stub = short.copy()
    elif mode is None:
        ids = check_index("short_leaves", short_leaves, shape=(None,), low=0, high=nb - 1, table="branches")
        bad = ids[~short[ids]]
        if bad.size:
            raise ValueError(f"short_leaves must name leaves too short for their joint offsets (branch ids of the "
                             f"simplified graph), got branch {int(bad[0])}")
        stub[ids] = True
    parts = {"g": g, "off_s": off_s, "off_e": off_e, "joints": joints, "f": f, "S": S, "base": base,
             "rounding": rounding, "overlap": overlap, "hull": hull}
    built = _assemble(stub=stub, **parts)
    if mode == "auto" and short.any():
        stub, built = _unfold(built, short, fold_level, parts)
    V, faces, N, first_loop, last_loop, hull_n, joint_n = built
    n_open = int(base.sum() + g.is_leaf.sum())
    if cap:
        V, faces = cap_boundaries(V, faces)
    return ControlMesh(V, faces, g, N, first_loop, last_loop, np.diff(joints.joint_ptr), hull_n, joint_n,
                       n_open, bool(cap))


def _assemble(*, g: BranchGraph, off_s, off_e, joints: Joints, f: float, S: int, base, rounding, overlap, hull,
              stub):
    """Tubes (Alg. 1) and joint hulls (Alg. 3) of a simplified graph; ``stub`` branches get N = 0 (their tip
    loop is their joint loop). Returns (V, faces, N, first_loop, last_loop, hull_n, joint_n)."""
    nb = len(g)
    L = g.length
    ax = g.axis
    leaf = g.is_leaf
    # trimmed ends and their radii (radii interpolated along the original length, spec §2.3 [INFERRED])
    ts, te = off_s / L, 1.0 - off_e / L
    rs = g.r0 + (g.r1 - g.r0) * ts
    re = g.r0 + (g.r1 - g.r0) * te
    ps = g.start + off_s[:, None] * ax
    pe = g.start + (L * te)[:, None] * ax
    Lt = L * (te - ts)
    rnd = {"round": np.round, "floor": np.floor, "ceil": np.ceil}[rounding]
    with np.errstate(over="ignore", invalid="ignore"):
        Nf = np.maximum(1, rnd(Lt / (np.pi * 0.5 * (rs + re))))                  # Eq. E10, E11
    if not np.all(np.isfinite(Nf)) or float(Nf.sum() + nb) * S > MAX_COUNT:
        raise ValueError(f"graph: the control mesh would need {float(np.nansum(Nf) + nb) * S:.3g} vertices, more "
                         f"than the {MAX_COUNT} allowed (branches far longer than their radius); thicken or "
                         f"shorten the branches")
    N = Nf.astype(np.int64)
    N[stub] = 0                          # a stub's only loop is its (fixed) tip loop, at the branch end
    u, w = _frames(g)
    # --- tube vertices (all branches at once)
    rings = N + 1
    ring_b = np.repeat(np.arange(nb), rings)
    ring_ptr = np.zeros(nb + 1, np.int64)
    np.cumsum(rings, out=ring_ptr[1:])
    ring_i = np.arange(ring_ptr[-1]) - ring_ptr[ring_b]
    t = ring_i / np.maximum(N[ring_b], 1)
    t[stub[ring_b]] = 1.0
    c = ps[ring_b] + t[:, None] * (pe - ps)[ring_b]
    c[stub[ring_b]] = g.end[ring_b[stub[ring_b]]]
    r = rs[ring_b] + t * (re - rs)[ring_b]
    r[stub[ring_b]] = g.r1[ring_b[stub[ring_b]]]
    r[ring_ptr[:-1][base]] *= f          # open loops (base, tips) stay fixed under subdivision:
    r[ring_ptr[1:][leaf] - 1] *= f       # they keep the requested radius
    th = 2.0 * np.pi * np.arange(S) / S
    # loops counter-clockwise seen from the tip: u x w = axis (spec §2.3)
    V = (c[:, None, :] + r[:, None, None] * (np.cos(th)[None, :, None] * u[ring_b][:, None, :]
                                              + np.sin(th)[None, :, None] * w[ring_b][:, None, :])).reshape(-1, 3)
    # --- tube faces, Algorithm 1: ABC and BDC (ERRATUM A7)
    seg_b = np.repeat(np.arange(nb), N)
    seg_ring = np.arange(int(N.sum())) - np.repeat(np.cumsum(N) - N, N) + ring_ptr[seg_b]
    j = np.arange(S)
    A = seg_ring[:, None] * S + j[None, :]
    B = seg_ring[:, None] * S + ((j + 1) % S)[None, :]
    C, D = A + S, B + S
    tube_f = np.stack([A, B, C, B, D, C], axis=-1).reshape(-1, 3)
    first_loop = ring_ptr[:-1, None] * S + j[None, :]
    last_loop = (ring_ptr[1:, None] - 1) * S + j[None, :]
    # --- joints (§2.4)
    jf, hull_n, joint_n = _joints(V, g, joints, off_s, off_e, first_loop, last_loop, overlap, hull)
    faces = np.vstack([tube_f, jf]).astype(np.int64)
    return V, faces, N, first_loop, last_loop, hull_n, joint_n


def _fold_pairs(built, g: BranchGraph, joints: Joints, short, level: int) -> np.ndarray:
    """Self-intersecting pairs at subdivision ``level`` near the short leaves, each named by the short leaf it
    touches: (P,) int64 branch ids, one per (pair, leaf) incidence [INFERRED, issue 22].

    Only faces that descend from the short leaves' joints are tested: the joint faces, the tubes of every
    member and the fan caps of the short leaves' tips (added as :func:`tree_mesh` adds them)."""
    from .loop import boundary_loops
    from .selfintersect import self_intersections

    V, F, N, first_loop, _, _, joint_n = built
    S = first_loop.shape[1]
    nb = len(g)
    mb, mj = joints.member_branch, joints.member_joint
    hot_j = np.zeros(joints.n_joints, bool)
    hot_j[mj[short[mb]]] = True
    hot_b = np.zeros(nb, bool)
    hot_b[mb[hot_j[mj]]] = True
    vert_b = np.repeat(np.arange(nb), (N + 1) * S)            # control vertex -> branch
    ntube = 2 * S * int(N.sum())
    face_b = np.full(len(F), -1, np.int64)                     # tube face -> branch
    face_b[:ntube] = np.repeat(np.arange(nb), 2 * S * N)
    face_j = np.full(len(F), -1, np.int64)                     # joint face -> joint
    face_j[ntube:] = np.repeat(np.arange(joints.n_joints), joint_n)
    hot = np.where(face_j >= 0, hot_j[np.maximum(face_j, 0)], hot_b[np.maximum(face_b, 0)])
    V2, F2 = subdivide_loop(V, F, level)
    k = 4 ** level
    # fan caps of the short leaves' tip loops (their loop keeps the original even vertex ids < len(V))
    be, lab = boundary_loops(F2, len(V2))
    nl = int(lab.max(initial=-1)) + 1
    loop_b = np.full(nl, -1, np.int64)
    even = be[:, 0] < len(V)
    loop_b[lab[even]] = vert_b[be[even, 0]]
    keep = (loop_b[lab] >= 0) & short[np.maximum(loop_b[lab], 0)]
    be, lab = be[keep], lab[keep]
    cnt = np.maximum(np.bincount(lab, minlength=nl), 1)
    cen = np.stack([np.bincount(lab, weights=V2[be[:, 0], c], minlength=nl) for c in range(3)], 1) / cnt[:, None]
    caps = np.stack([be[:, 1], be[:, 0], len(V2) + lab], axis=1)
    sel = np.flatnonzero(np.repeat(hot, k))
    Fc = np.vstack([F2[sel], caps])
    pairs = self_intersections(np.vstack([V2, cen]), Fc)
    if len(pairs) == 0:
        return np.zeros(0, np.int64)
    # name each face by the short leaves it belongs to: tube / cap of the leaf, or a joint face on its loop
    cf = np.r_[sel // k, np.full(len(caps), -1)]
    cap_b = np.r_[np.full(len(sel), -1), loop_b[lab]]
    out = []
    for pr in pairs:
        leaves = set()
        for q in pr:
            if cf[q] < 0:
                leaves.add(int(cap_b[q]))
            elif face_b[cf[q]] >= 0:
                if short[face_b[cf[q]]]:
                    leaves.add(int(face_b[cf[q]]))
            else:
                bs = vert_b[F[cf[q]]]
                leaves.update(int(b) for b in bs[short[bs]])
        if not leaves:                       # a fold between the other members of a short leaf's joint
            for q in pr:
                if cf[q] >= 0 and face_j[cf[q]] >= 0:
                    jm = mb[joints.joint_ptr[face_j[cf[q]]]:joints.joint_ptr[face_j[cf[q]] + 1]]
                    leaves.update(int(b) for b in jm[short[jm]])
        out.extend(leaves)
    return np.array(out, np.int64)


def _unfold(built, short, level: int, parts: dict):
    """``short_leaves="auto"``: stub the short leaves whose tubes fold at ``level``, keep the better variant
    per leaf, and warn naming the leaves that still fold (issue 22) [INFERRED]."""
    g, joints = parts["g"], parts["joints"]
    nb = len(g)
    hits = np.bincount(_fold_pairs(built, g, joints, short, level), minlength=nb)
    if not hits.any():
        return np.zeros(nb, bool), built
    tube_hits = hits
    stub = hits > 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # the first build already warned about this graph
        cand = _assemble(stub=stub, **parts)
    stub_hits = np.bincount(_fold_pairs(cand, g, joints, short, level), minlength=nb)
    # a stub that folds more than its tube goes back to the tube (pairs counted per leaf)
    worse = stub & (stub_hits > tube_hits)
    if worse.any():
        stub &= ~worse
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cand = _assemble(stub=stub, **parts)
        stub_hits = np.bincount(_fold_pairs(cand, g, joints, short, level), minlength=nb)
    if stub_hits.any():
        jb = np.full(nb, -1, np.int64)
        jb[joints.member_branch[~joints.member_is_end]] = joints.member_joint[~joints.member_is_end]
        left = np.flatnonzero(stub_hits)
        names = ", ".join(f"branch {b} at joint {jb[b]}" for b in left[:8])
        warnings.warn(f"{len(left)} short leaf branch(es) still self-intersect at subdivision level {level} "
                      f"({names}{', ...' if len(left) > 8 else ''}; branch ids of the simplified graph), with and "
                      f"without their tube; the surface folds at these joints", stacklevel=3)
    return stub, cand


def _joints(V, g: BranchGraph, joints: Joints, off_s, off_e, first_loop, last_loop, overlap, hull):
    S = first_loop.shape[1]
    mb, me, mj = joints.member_branch, joints.member_is_end, joints.member_joint
    nj = joints.n_joints
    if nj == 0:
        z = np.zeros(0, np.int64)
        return np.zeros((0, 3), np.int64), z, z
    loops = np.where(me[:, None], last_loop[mb], first_loop[mb])          # (M, S)
    off = np.where(me, off_e[mb], off_s[mb])
    X = V[loops]                                                            # (M, S, 3)
    cl = X.mean(axis=1)
    size = np.diff(joints.joint_ptr)
    # the joint sphere is centred on the joint point itself, so each loop's direction d on it is its branch's
    # own direction: the mean of the loop centres drifts towards the long members at a crowded joint (short
    # leaves with small offsets) and squeezes the short members' caps together (issue 22) [INFERRED]
    C = joints.joint_point.astype(np.float64)
    Rs = np.maximum.reduceat(off, joints.joint_ptr[:-1])
    rad = np.linalg.norm(X - cl[:, None], axis=2).max(axis=1)
    Rs = np.where(Rs > 1e-12, Rs, np.maximum.reduceat(rad, joints.joint_ptr[:-1]))
    d = cl - C[mj]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    loc = X - cl[:, None]
    # Loop orientation reference: the member's away-from-joint axis (child +axis, parent -axis). This is the
    # spec's "n·d > 0" sign rule (§2.4.2) whenever the loop centre lies on the away side of the joint centre,
    # and keeps the winding consistent when it does not (crowded joints of grown trees) [INFERRED].
    ax = g.axis
    n = np.where(me[:, None], -ax[mb], ax[mb])
    # V7: loop caps must not overlap on the joint sphere, angle(d_A, d_B) > theta_A + theta_B
    pa, pb = joint_pairs(joints.joint_ptr, mj)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", d[pa], d[pb]), -1.0, 1.0))
    bad = ang <= np.arctan(rad[pa] / Rs[mj[pa]]) + np.arctan(rad[pb] / Rs[mj[pa]])
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        msg = (f"joint {mj[pa[i]]} of branches {mb[pa[i]]} and {mb[pb[i]]}: their loops overlap on the joint sphere "
               f"({np.degrees(ang[i]):.2f} deg apart; spec V7)")
        if overlap == "raise" or ang[bad].min() < 1e-4:
            raise ValueError(msg + "; the branches leave the joint too close in direction for their radii")
        # [INFERRED] the sphere only supplies connectivity (positions are restored), so a larger sphere
        # shrinks every cap to atan(r / Rs) until they separate; the surface stays one manifold but the
        # joint may fold where the real branches overlap.
        need = (rad[pa] + rad[pb]) / (0.8 * ang)
        grow = np.zeros(nj)
        np.maximum.at(grow, mj[pa[bad]], need[bad])
        Rs = np.maximum(Rs, grow)
        warnings.warn(f"{len(np.unique(mj[pa[bad]]))} joint(s) had overlapping loop caps (first: {msg}); "
                      f"their hulls were built on an enlarged sphere; pass overlap='raise' to refuse",
                      stacklevel=4)
    Q = _rotation_to(n, d)
    Y = C[mj][:, None] + Rs[mj][:, None, None] * d[:, None] + np.einsum("mij,msj->msi", Q, loc)
    P = C[mj][:, None] + Rs[mj][:, None, None] * (Y - C[mj][:, None]) / np.linalg.norm(
        Y - C[mj][:, None], axis=2, keepdims=True)
    P = P.reshape(-1, S, 3)
    if not np.all(np.isfinite(P)):
        jj = int(mj[np.flatnonzero(~np.isfinite(P).all(axis=(1, 2)))[0]])
        raise ValueError(f"graph: joint of branches {mb[joints.joint_ptr[jj]:joints.joint_ptr[jj + 1]].tolist()} is "
                         f"degenerate (its loops collapse to a point); thicken or lengthen these branches")
    ptr = joints.joint_ptr
    tri, hull_n, hull_v = joint_hulls(P.reshape(-1, 3), ptr * S, method=hull)   # outward, ERRATUM A6
    miss = hull_v != size * S
    if miss.any():
        jj = int(np.flatnonzero(miss)[0])
        br = mb[ptr[jj]:ptr[jj + 1]].tolist()
        raise ValueError(f"joint of branches {br}: the convex hull misses {size[jj] * S - hull_v[jj]} loop "
                         f"vertices (loop caps overlap on the joint sphere, spec V6/V7); branches are too "
                         f"close in direction or too short")
    owner = tri // S
    keep = ~((owner[:, 0] == owner[:, 1]) & (owner[:, 1] == owner[:, 2]))   # delete caps (Fig. 4.17c)
    tri_j = np.repeat(np.arange(nj), hull_n)
    joint_n = np.bincount(tri_j[keep], minlength=nj).astype(np.int64)
    wrong = joint_n != size * S + 2 * size - 4          # V8: k S + 2k - 4 joint faces (6k - 4 for S = 4)
    if wrong.any():
        jj = int(np.flatnonzero(wrong)[0])
        raise ValueError(f"joint of branches {mb[ptr[jj]:ptr[jj + 1]].tolist()} failed: {joint_n[jj]} joint faces "
                         f"instead of {size[jj] * S + 2 * size[jj] - 4} (loops not in convex position, spec V6-V8)")
    tri = tri[keep]
    return loops.reshape(-1)[tri], hull_n, joint_n

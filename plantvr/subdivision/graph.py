"""Branch graph, trimming offsets and graph simplification (spec 001_subdivision §1.5, §2.1, §2.2).

The graph is a struct of arrays: one row per straight branch (an LST ``Cylinder`` or one internode of a
grown tree). Parents always come before their children (``parent[i] < i``), so one forward pass visits
the tree depth-first-compatible and no cycle can exist.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from plantvr._validation import (
    MAX_COORD,
    MAX_COUNT,
    check_array,
    check_choice,
    check_index,
    check_range,
    check_tree_arrays,
)

__all__ = ["BranchGraph", "graph_from_arrays", "joint_offsets", "pair_offset", "random_tree", "simplify"]

_EPS = 1e-9
#: Smallest branch radius accepted (model units); thinner joints degenerate to points in float64.
MIN_RADIUS = 1e-9


@dataclass(frozen=True)
class BranchGraph:
    """A tree of straight, truncated-cone branches (spec §1.5).

    Attributes
    ----------
    start, end : (B, 3) float64 ndarray
        Branch start and end points. A child's start equals its parent's end.
    r0, r1 : (B,) float64 ndarray
        Radius at the start and at the end of each branch (> 0).
    parent : (B,) int64 ndarray
        Parent branch index, ``-1`` for a root; ``parent[i] < i``.
    """

    start: np.ndarray
    end: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    parent: np.ndarray

    def __len__(self) -> int:
        return len(self.parent)

    @property
    def length(self) -> np.ndarray:
        """(B,) float64: branch lengths."""
        return np.linalg.norm(self.end - self.start, axis=1)

    @property
    def axis(self) -> np.ndarray:
        """(B, 3) float64: unit branch directions, start to end."""
        return (self.end - self.start) / self.length[:, None]

    @property
    def n_children(self) -> np.ndarray:
        """(B,) int64: number of children of each branch."""
        p = self.parent[self.parent >= 0]
        return np.bincount(p, minlength=len(self)).astype(np.int64)

    @property
    def is_leaf(self) -> np.ndarray:
        """(B,) bool: branches without children (their tips stay open/fixed)."""
        return self.n_children == 0

    def validate(self) -> BranchGraph:
        """Check shapes, ordering, radii, lengths and connectivity; return self.

        Raises
        ------
        ValueError
            Naming the offending array and the first bad branch.
        """
        try:
            n = len(self.parent)
        except TypeError:
            raise ValueError(f"parent must be an integer array, got {type(self.parent).__name__}") from None
        if not 1 <= n <= MAX_COUNT:
            raise ValueError(f"the graph must have between 1 and {MAX_COUNT} branches, got {n}")
        arr = {}
        for name in ("start", "end"):
            arr[name] = check_array(name, getattr(self, name), shape=(n, 3), max_abs=MAX_COORD)
        for name in ("r0", "r1"):
            r = arr[name] = check_array(name, getattr(self, name), shape=(n,))
            bad = np.flatnonzero(~((r >= MIN_RADIUS) & (r <= MAX_COORD)))
            if bad.size:
                raise ValueError(f"{name} must be > 0 (in [{MIN_RADIUS:g}, {MAX_COORD:g}]) for every branch, got "
                                 f"{r[bad[0]]!r} at branch {bad[0]}")
        parent = arr["parent"] = check_index("parent", self.parent, shape=(n,), low=-1, high=n - 1)
        idx = np.arange(n)
        bad = np.flatnonzero((parent < -1) | (parent >= idx))
        if bad.size:
            raise ValueError(f"parent must satisfy -1 <= parent[i] < i (no cycles), got parent[{bad[0]}] = "
                             f"{parent[bad[0]]}")
        start, end = arr["start"], arr["end"]
        L = np.linalg.norm(end - start, axis=1)
        bad = np.flatnonzero(~(L > _EPS))
        if bad.size:
            raise ValueError(f"branch {bad[0]} has zero length (start == end)")
        has_p = parent >= 0
        gap = np.linalg.norm(start[has_p] - end[parent[has_p]], axis=1)
        bad = np.flatnonzero(gap > 1e-9 * max(1.0, float(np.abs(end).max())))
        if bad.size:
            b = np.flatnonzero(has_p)[bad[0]]
            raise ValueError(f"branch {b} starts {gap[bad[0]]:.3g} away from the end of its parent {parent[b]}")
        for k, v in arr.items():              # canonical float64 / int64 arrays (equal values) once all passed
            if getattr(self, k) is not v:
                object.__setattr__(self, k, v)
        return self


def graph_from_arrays(pos, parent, radius) -> BranchGraph:
    """Build a :class:`BranchGraph` from a grown tree's node arrays.

    Node ``i > 0`` is the tip of the internode from ``pos[parent[i]]`` to ``pos[i]``; every internode
    becomes one branch, with radius ``radius[parent[i]]`` at its start and ``radius[i]`` at its end.

    Parameters
    ----------
    pos : (N, 3) float64 ndarray
        Node positions.
    parent : (N,) int ndarray
        Parent node index, ``-1`` for the root (node 0 only); ``parent[i] < i``.
    radius : (N,) float64 ndarray
        Node radii (> 0).

    Returns
    -------
    BranchGraph
        ``N - 1`` branches; branch ``i - 1`` is the internode ending at node ``i``.

    Raises
    ------
    ValueError
        If shapes disagree, ``parent`` is not a forward-ordered tree (a cycle), a radius is not positive or
        an internode has zero length.
    """
    pos, parent, radius = check_tree_arrays(pos, parent, radius, max_radius=None)
    bad = np.flatnonzero(~((radius >= MIN_RADIUS) & (radius <= MAX_COORD)))
    if bad.size:
        raise ValueError(f"radius must be > 0 (in [{MIN_RADIUS:g}, {MAX_COORD:g}]) at every node, got "
                         f"{radius[bad[0]]!r} at node {bad[0]}")
    L = np.linalg.norm(pos[1:] - pos[parent[1:]], axis=1)
    bad = np.flatnonzero(~(L > _EPS))
    if bad.size:
        raise ValueError(f"pos: internode ending at node {bad[0] + 1} has zero length")
    bpar = parent[1:] - 1  # branch of the parent node; -1 when the parent is the root node
    return BranchGraph(start=pos[parent[1:]].copy(), end=pos[1:].copy(), r0=radius[parent[1:]].copy(),
                       r1=radius[1:].copy(), parent=bpar.astype(np.int64))


# ----------------------------------------------------------------------------------------------
# joints and offsets (§2.1)
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Joints:
    """Joint membership (struct of arrays), one row per (joint, member branch end).

    ``member_branch[m]`` meets joint ``member_joint[m]`` with its end if ``member_is_end[m]`` (the incoming
    parent) or with its start otherwise. Members are sorted by joint; ``joint_ptr`` are CSR offsets.
    """

    member_joint: np.ndarray
    member_branch: np.ndarray
    member_is_end: np.ndarray
    joint_ptr: np.ndarray
    joint_point: np.ndarray   # (J, 3)
    base_branches: np.ndarray  # root branches whose start is an open boundary

    @property
    def n_joints(self) -> int:
        return len(self.joint_ptr) - 1


def find_joints(g: BranchGraph) -> Joints:
    """Group branch ends into joints: the end of every branch with children, and root starts shared by
    two or more root branches (a grown tree whose root node forks) [INFERRED]."""
    nb = len(g)
    nch = g.n_children
    inner = np.flatnonzero(nch > 0)
    jid_of_branch = np.full(nb, -1, np.int64)
    jid_of_branch[inner] = np.arange(len(inner))
    mj = [jid_of_branch[inner]]
    mb = [inner]
    me = [np.ones(len(inner), bool)]
    pts = [g.end[inner]]
    ch = np.flatnonzero(g.parent >= 0)
    mj.append(jid_of_branch[g.parent[ch]])
    mb.append(ch)
    me.append(np.zeros(len(ch), bool))
    roots = np.flatnonzero(g.parent < 0)
    base = roots
    if len(roots) > 1:
        _, grp, cnt = np.unique(g.start[roots], axis=0, return_inverse=True, return_counts=True)
        grp = grp.ravel()
        shared = cnt[grp] > 1
        if shared.any():
            ugrp, jloc = np.unique(grp[shared], return_inverse=True)
            mj.append(len(inner) + jloc.ravel())
            mb.append(roots[shared])
            me.append(np.zeros(int(shared.sum()), bool))
            first = np.array([roots[shared][jloc.ravel() == i][0] for i in range(len(ugrp))])
            pts.append(g.start[first])
        base = roots[~shared]
    mj, mb, me = np.concatenate(mj), np.concatenate(mb), np.concatenate(me)
    order = np.lexsort((mb, ~me, mj))  # by joint, incoming first, then branch order
    mj, mb, me = mj[order], mb[order], me[order]
    nj = len(inner) + (len(pts[-1]) if len(pts) == 2 else 0)
    ptr = np.zeros(nj + 1, np.int64)
    np.cumsum(np.bincount(mj, minlength=nj), out=ptr[1:])
    return Joints(mj, mb, me, ptr, np.concatenate(pts), base)


def joint_pairs(joint_ptr: np.ndarray, member_joint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All ordered pairs (A, B), A != B, of members that share a joint (CSR ``joint_ptr``)."""
    size = np.diff(joint_ptr)
    ka = size[member_joint]
    A = np.repeat(np.arange(len(member_joint)), ka)
    local = np.arange(len(A)) - np.repeat(np.cumsum(ka) - ka, ka)
    B = np.repeat(joint_ptr[member_joint], ka) + local
    keep = A != B
    return A[keep], B[keep]


def pair_offset(cos_a: np.ndarray, ra: np.ndarray, rb: np.ndarray, *, offset_mode: str = "geometric",
                max_offset_factor: float = 4.0) -> np.ndarray:
    """Trimming offset of branch A against branch B at a joint (spec §2.1, Eqs. E2–E6).

    Parameters
    ----------
    cos_a : (P,) float64 ndarray
        Cosine of the angle between the two away-from-joint unit axes.
    ra, rb : (P,) float64 ndarray
        Radii of A and B at the joint.
    offset_mode : {"geometric", "report"}
        ``"geometric"`` (default) uses the corrected general formula
        ``offsetA = (R_B + R_A cos α) / sin α`` (ERRATUM A5), zero when the intersection lies behind B's start;
        ``"report"`` reproduces the printed five cases literally.
    max_offset_factor : float
        Cap on the offset as a multiple of ``max(R_A, R_B)`` (near-parallel pairs blow up).

    Returns
    -------
    (P,) float64 ndarray
        Offsets of A along its own axis.

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.1.3, cases 1–5; spec 001 §2.1 ERRATA A4, A5.
    """
    check_choice("offset_mode", offset_mode, ("geometric", "report"))
    c = np.clip(np.asarray(cos_a, float), -1.0, 1.0)
    s = np.sqrt(np.maximum(1.0 - c * c, 0.0))
    ra, rb = np.broadcast_arrays(np.asarray(ra, float), np.asarray(rb, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        if offset_mode == "geometric":  # ERRATUM A5: one continuous formula for cases 1, 2, 4, 5
            off = (rb + ra * c) / s
            behind = off * c + ra * s < 0      # intersection point behind B's start
            off = np.where(behind | (s < 1e-12), 0.0, np.maximum(off, 0.0))
        else:  # the printed cases, discontinuous at 90 degrees
            alpha = np.arccos(c)
            off = np.where(np.abs(c) < 1e-12, rb,
                           np.where(c > 0, ra / np.tan(alpha) + rb / s, ra / np.tan(np.pi - alpha)))
            off = np.where(c <= -1 + 1e-12, 0.0, off)
    cap = max_offset_factor * np.maximum(ra, rb)
    return np.minimum(np.nan_to_num(off, nan=0.0, posinf=np.inf), cap)


def joint_offsets(g: BranchGraph, joints: Joints | None = None, *, offset_mode: str = "geometric",
                  min_offset: float = 0.5, max_offset_factor: float = 4.0,
                  parallel_tol: float = 1e-6, offset_margin: float = 0.1) -> tuple[np.ndarray, np.ndarray, Joints]:
    """Trim distances at the start and end of every branch so no two branches overlap at a joint (spec §2.1).

    Parameters
    ----------
    g : BranchGraph
        The branch graph.
    joints : Joints, optional
        Precomputed :func:`find_joints` result.
    offset_mode : {"geometric", "report"}
        See :func:`pair_offset`.
    min_offset : float
        Floor on every joint offset, as a multiple of the member's own radius, so that the loops of a
        straight continuation do not coincide [INFERRED; the report leaves zero offsets unhandled].
    max_offset_factor : float
        See :func:`pair_offset`.
    offset_margin : float
        Added to every joint offset, as a multiple of the member's own radius. The geometric offset puts the
        trimmed loops of two members exactly through the point where their cylinders meet, so in a planar
        L-system two loop vertices can coincide and give a zero-area joint face (spec V10); a small margin
        keeps the loops apart [INFERRED].
    parallel_tol : float
        Pairs with ``cos α > 1 - parallel_tol`` (two branches leaving in the same direction) are bad input.

    Returns
    -------
    off_start, off_end : (B,) float64 ndarray
        Trim distances along each branch axis; 0 at open ends (base and tips).
    joints : Joints

    Raises
    ------
    ValueError
        If two branches leave a joint in the same direction (report case 3, "bad input").
    """
    if joints is None:
        joints = find_joints(g)
    ax = g.axis
    mb, me, mj = joints.member_branch, joints.member_is_end, joints.member_joint
    d = np.where(me[:, None], -ax[mb], ax[mb])           # away-from-joint directions
    r = np.where(me, g.r1[mb], g.r0[mb])
    A, B = joint_pairs(joints.joint_ptr, mj)
    cos_a = np.einsum("ij,ij->i", d[A], d[B])
    par = cos_a > 1.0 - parallel_tol
    if par.any():
        i = np.flatnonzero(par)[0]
        raise ValueError(f"branches {mb[A[i]]} and {mb[B[i]]} leave joint {mj[A[i]]} in the same direction "
                         f"(cos = {cos_a[i]:.9f}); the report calls this bad input (§4.1.3 case 3)")
    off_pair = pair_offset(cos_a, r[A], r[B], offset_mode=offset_mode, max_offset_factor=max_offset_factor)
    off = np.full(len(mb), 0.0)
    np.maximum.at(off, A, off_pair)
    off = np.maximum(off + offset_margin * r, min_offset * r)
    off_start = np.zeros(len(g))
    off_end = np.zeros(len(g))
    off_end[mb[me]] = off[me]
    off_start[mb[~me]] = off[~me]
    return off_start, off_end, joints


def simplify(g: BranchGraph, *, offset_mode: str = "geometric", min_offset: float = 0.5,
             max_offset_factor: float = 4.0, offset_margin: float = 0.1, max_rounds: int = 10_000
             ) -> tuple[BranchGraph, np.ndarray, np.ndarray, Joints]:
    """Collapse branches whose start and end offsets cross over, re-trim, until stable (spec §2.2).

    A collapsed branch is deleted; its children are re-parented to its parent and start at the parent's
    end, so every branch tip keeps its exact position. Each round collapses, shallowest first, the
    crossing branches whose parent does not cross over itself, then re-trims. Leaves and roots that cross
    over cannot be collapsed without moving a tip; their offsets are scaled down to 90 % of the length
    and a warning is issued [INFERRED, spec §2.2 edge cases].

    Parameters
    ----------
    g : BranchGraph
        The input graph (validated).
    offset_mode, min_offset, max_offset_factor, offset_margin
        See :func:`joint_offsets`.
    max_rounds : int
        Safety cap on trim/collapse rounds.

    Returns
    -------
    graph : BranchGraph
        The simplified graph (a new object; branch order kept, ``parent[i] < i``).
    off_start, off_end : (B,) float64 ndarray
        Final trim distances.
    joints : Joints
        Final joints.

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.1.4, Fig. 4.5.
    """
    cur, off_s, off_e, joints, _ = _simplify(g, offset_mode=offset_mode, min_offset=min_offset,
                                             max_offset_factor=max_offset_factor, offset_margin=offset_margin,
                                             max_rounds=max_rounds, stacklevel=3)
    return cur, off_s, off_e, joints


def _simplify(g: BranchGraph, *, offset_mode: str, min_offset: float, max_offset_factor: float,
              offset_margin: float, max_rounds: int = 10_000, stacklevel: int = 2
              ) -> tuple[BranchGraph, np.ndarray, np.ndarray, Joints, np.ndarray]:
    """:func:`simplify`, also returning the (B,) bool mask of the leaf/root branches whose offsets were scaled
    to 90 % of their length (too short for their joint, spec §2.2 edge case)."""
    start, end, r0, r1, parent = g.start, g.end, g.r0, g.r1, g.parent
    for _ in range(max_rounds):
        cur = BranchGraph(start, end, r0, r1, parent)
        off_s, off_e, joints = joint_offsets(cur, offset_mode=offset_mode, min_offset=min_offset,
                                             max_offset_factor=max_offset_factor, offset_margin=offset_margin)
        L = cur.length
        cross = off_s + off_e > L
        nch = cur.n_children
        collapsible = cross & (parent >= 0) & (nch > 0)
        if not collapsible.any():
            break
        sel = collapsible & ~collapsible[np.maximum(parent, 0)] | (collapsible & (parent < 0))
        # re-parent children of every selected branch to its parent
        newpar = parent.copy()
        kids = np.flatnonzero((parent >= 0) & sel[np.maximum(parent, 0)])
        newpar[kids] = parent[parent[kids]]
        start = start.copy()
        start[kids] = end[newpar[kids]]
        keep = ~sel
        remap = np.cumsum(keep) - 1
        parent = np.where(newpar[keep] >= 0, remap[np.maximum(newpar[keep], 0)], -1)
        start, end, r0, r1 = start[keep], end[keep], r0[keep], r1[keep]
        # r0 of a re-parented child stays its own start radius (radii are not linked, §1.5)
    else:  # pragma: no cover - safety net
        raise RuntimeError("graph simplification did not converge")
    cur = BranchGraph(start, end, r0, r1, parent)
    L = cur.length
    cross = off_s + off_e > 0.9 * L
    if cross.any():
        # name each branch and its joint: such a branch ends inside its joint's blend and may fold there (issue 22)
        jb = np.full(len(cur), -1, np.int64)
        jb[joints.member_branch[~joints.member_is_end]] = joints.member_joint[~joints.member_is_end]
        short = np.flatnonzero(cross)
        names = ", ".join(f"branch {b} at joint {jb[b]}" if jb[b] >= 0 else f"branch {b}" for b in short[:8])
        warnings.warn(f"{len(short)} leaf/root branch(es) too short for their joint offsets ({names}"
                      f"{', ...' if len(short) > 8 else ''}; branch ids of the simplified graph); offsets scaled "
                      f"to 90 % of the branch length (spec §2.2 edge case); build_control_mesh gives each one whose tube "
                      f"folds a stub (short_leaves), the surface may fold at these joints",
                      stacklevel=stacklevel)
        s = np.where(cross, 0.9 * L / np.maximum(off_s + off_e, 1e-300), 1.0)
        off_s, off_e = off_s * s, off_e * s
    return cur, off_s, off_e, joints, cross


def random_tree(n_nodes: int, *, rng: int | np.random.Generator | None = None, length: float = 1.0,
                radius: float = 0.08, branch_angle: float = 45.0, p_lateral: float = 0.35
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A random grown-tree skeleton in the growth engine's node format (for tests, benchmarks, demos).

    Every node may get a continuation child (tilted <= 10 degrees) and up to two opposite lateral children
    at ``branch_angle`` from its direction; slots are filled in random order until ``n_nodes`` exist.

    Parameters
    ----------
    n_nodes : int
        Number of nodes (2 ... 10**6); the tree has ``n_nodes - 1`` internodes.
    rng : int or numpy.random.Generator, optional
        Seed.
    length : float
        Mean internode length.
    radius : float
        Root radius; node radii shrink by 3 % per depth level down to 25 % of it.
    branch_angle : float
        Angle of lateral children to their parent direction, degrees (20–80).
    p_lateral : float
        Probability that a node opens each lateral slot.

    Returns
    -------
    pos : (N, 3) float64 ndarray
    parent : (N,) int64 ndarray
    radius : (N,) float64 ndarray
    """
    from plantvr._validation import check_int

    n_nodes = check_int("n_nodes", n_nodes, 2, 10**6)
    length = check_range("length", length, 0.0, np.inf, low_open=True)
    radius = check_range("radius", radius, 0.0, np.inf, low_open=True)
    ang = np.deg2rad(check_range("branch_angle", branch_angle, 20.0, 80.0))
    p_lateral = check_range("p_lateral", p_lateral, 0.0, 1.0)
    rng = np.random.default_rng(rng)
    pos = np.zeros((n_nodes, 3))
    dirs = np.zeros((n_nodes, 3))
    dirs[0] = (0.0, 1.0, 0.0)
    parent = np.full(n_nodes, -1, np.int64)
    depth = np.zeros(n_nodes, np.int64)
    roll = rng.uniform(0, 2 * np.pi, n_nodes)
    slots: list[tuple[int, int]] = [(0, 0)]
    count = 1
    while count < n_nodes:
        if not slots:
            slots.append((count - 1, 0))
        k = int(rng.integers(len(slots)))
        slots[k], slots[-1] = slots[-1], slots[k]
        node, kind = slots.pop()
        d = dirs[node]
        ref = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 0, 1.0])
        e1 = np.cross(d, ref)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(d, e1)
        if kind == 0:
            tilt, az = rng.uniform(0, np.deg2rad(10)), rng.uniform(0, 2 * np.pi)
        else:
            tilt, az = ang, roll[node] + (0.0 if kind == 1 else np.pi)
        nd = np.cos(tilt) * d + np.sin(tilt) * (np.cos(az) * e1 + np.sin(az) * e2)
        i = count
        count += 1
        dirs[i] = nd
        parent[i] = node
        depth[i] = depth[node] + 1
        pos[i] = pos[node] + nd * length * rng.uniform(0.8, 1.2)
        slots.append((i, 0))
        for lat in (1, 2):
            if rng.random() < p_lateral:
                slots.append((i, lat))
    rad = radius * np.maximum(0.97 ** depth, 0.25)
    return pos, parent, rad

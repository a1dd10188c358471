"""LOD chain of a tree mesh: fewer cylinder sides and pruned twigs per level (spec 000_treewand §3.5; issue 16).

Each level lowers the ring subdivisions (the ``lod`` pair of :func:`plantvr.geometry.mesh.lod_level`) and the
bands along each segment, and widens each ring so that its polygon keeps the circle's mean projected width
(:func:`silhouette_radius_scale`: a triangle inscribed in the circle is on average 17 % narrower, which at a
distance where twigs are a pixel wide loses a fifth of the crown's silhouette). Twigs are pruned by projected
size when ``prune_px`` is given (axes thinner than ``prune_px`` pixels at the nearest distance the level is used),
then, if the mesh is still above the level's triangle budget, the thinnest twigs go: every lateral axis (chain of main children) whose base radius is below a cut radius is marked dead with
its subtree, so the axes that stay keep their full length and the crown keeps its extent. The cut radius is
the smallest one that meets the budget, found by bisection on the sorted radii using the exact face count of
the segment layout (no mesh is built during the search).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantvr._validation import check_array, check_int, check_range

from .mesh import BranchMesh, _build, _check_options, _check_tree, _layout, lod_level, tree_segments

__all__ = ["LOD_RATIOS", "LOD_RINGS", "LOD_U_STEPS", "LodLevel", "axis_start", "lod_chain", "silhouette_radius_scale",
           "triangle_count"]

LOD_RINGS = ((10, 64), (4, 16), (3, 8), (3, 4))
"""Ring subdivisions (at the tip radius, at 50× the tip radius) of levels 0–3."""
LOD_U_STEPS = (4, 3, 2, 2)
"""Bands along each segment of levels 0–3.

Two bands is the least that keeps curved internodes curved: with one band (straight segments) a grown model
tree's silhouette at 96 px falls to IoU 0.87 (with leaves), with two it stays at 0.96 (tests/view/test_billboard.py)."""
LOD_RATIOS = (1.0, 0.32, 0.17, 0.16)
"""Default triangle budgets of levels 0–3, as fractions of the full mesh.

Measured (grown model tree, 356 nodes; random tree, 400 nodes): levels 1–3 make 0.30, 0.154, 0.154 of the full
triangles without pruning, and keep rendered-silhouette IoU ≥ 0.94 (tree with its leaves) at the nearest distance
where :func:`plantvr.view.billboard.lod_by_distance` picks them (384, 192, 96 px). Lower budgets force pruning,
and pruning costs silhouette on such trees: their crowns are a haze of sub-pixel twigs whose sum is the silhouette
(pruning axes below 0.25 px drops IoU to 0.78–0.89). On large trees (the 22,000-internode benchmark) levels 2 and 3
differ more: (3, 4) rings on the thick limbs."""


@dataclass
class LodLevel:
    """One level of an LOD chain.

    Attributes
    ----------
    mesh : BranchMesh
    level : int
    lod : (int, int)
        Ring subdivisions used.
    u_steps : int
    cut_radius : float
        Axes whose base is thinner than this were pruned (0: none).
    budget : int
        Target triangle count.
    alive : (N,) bool ndarray
        Nodes kept.
    """

    mesh: BranchMesh
    level: int
    lod: tuple
    u_steps: int
    cut_radius: float
    budget: int
    alive: np.ndarray

    @property
    def triangles(self) -> int:
        return len(self.mesh.faces)

    @property
    def met(self) -> bool:
        """Whether the triangle budget is met."""
        return self.triangles <= self.budget


def axis_start(parent, main_child=None, alive=None) -> np.ndarray:
    """First node of the axis (chain of main children) each node belongs to.

    Parameters
    ----------
    parent : (N,) int64 ndarray
    main_child : (N,) int64 ndarray, optional
        Default the lowest live child index (as :func:`plantvr.geometry.tree_segments`).
    alive : (N,) bool ndarray, optional

    Returns
    -------
    (N,) int64 ndarray
        ``start[0] = 0``; the trunk starts at node 1.
    """
    n = len(parent)
    alive = np.ones(n, bool) if alive is None else alive
    if main_child is None or len(main_child) == 0:
        main_child = np.full(n, -1, np.int64)
        for i in range(n - 1, 0, -1):
            if alive[i]:
                main_child[parent[i]] = i
    start = np.zeros(n, np.int64)
    par = parent.tolist()
    mc = main_child.tolist()
    st = start.tolist()
    for i in range(1, n):
        p = par[i]
        st[i] = st[p] if (p > 0 and mc[p] == i) else i
    return np.asarray(st, np.int64)


def silhouette_radius_scale(sides) -> np.ndarray:
    """Radius factor that gives a regular polygon of ``sides`` corners the mean projected width of its circle.

    A regular n-gon inscribed in a circle of radius r has perimeter ``2 n r sin(π/n)``, so its width averaged over
    directions is that over π (Cauchy), against 2r for the circle: the factor is ``π / (n sin(π/n))`` (1.209 for
    a triangle, 1.111 for a square, 1.016 for 10 sides).

    Parameters
    ----------
    sides : int or (M,) int array_like
        At least 3.

    Returns
    -------
    (M,) float64 ndarray
    """
    n = np.asarray(sides, float)
    if np.any(n < 3):
        raise ValueError(f"sides must be >= 3, got min {n.min()!r}")
    return np.pi / (n * np.sin(np.pi / n))


def _prune_mask(start, radius, alive, cut):
    keep = alive & (radius[start] >= cut)      # whole axes go: those whose base is thinner than the cut
    keep[0] = True
    keep[1] = alive[1]                         # the trunk always stays
    return keep


def _count(pos, parent, radius, alive, main_child, opts) -> int:
    seg = tree_segments(pos, parent, radius, alive=alive, main_child=main_child, bezier_w=opts["bezier_w"],
                        bark_rate=opts["bark_rate"], _checked=True)
    _, _, f_off = _layout(seg, opts["u_steps"], opts["tip_radius"], opts["lod"])
    return int(f_off[-1])


def triangle_count(pos, parent, radius, *, alive=None, main_child=None, lod=(10, 64), u_steps: int = 4,
                   tip_radius: float | None = None) -> int:
    """Triangles :func:`plantvr.geometry.build_branch_mesh` would make, without building the mesh.

    Parameters
    ----------
    pos, parent, radius, alive, main_child
        The tree, as in :func:`plantvr.geometry.tree_segments`.
    lod : (int, int)
    u_steps : int
    tip_radius : float, optional

    Returns
    -------
    int
    """
    pos, parent, radius, alive, main_child = _check_tree(pos, parent, radius, alive, main_child)
    opts = _check_options(3.0, u_steps, lod, tip_radius, 1.0, 1, radius, parent, alive)
    return _count(pos, parent, radius, alive, main_child, opts)


def lod_chain(pos, parent, radius, *, alive=None, main_child=None, levels: int = 4, budgets=None,
              rings=LOD_RINGS, u_steps=LOD_U_STEPS, tip_radius: float | None = None, bezier_w: float = 3.0,
              bark_rate: float = 1.0, bark_repeat: int = 1, widen: bool = True, prune_px: float = 0.0,
              screen_px=None) -> list[LodLevel]:
    """Branch meshes of decreasing detail meeting triangle budgets (spec §3.5 LOD rule; issue 16).

    Parameters
    ----------
    pos, parent, radius, alive, main_child
        The tree, as in :func:`plantvr.geometry.build_branch_mesh`.
    levels : int
        Number of levels, in [1, len(rings)].
    budgets : sequence of int, optional
        Triangle budget of each level; default ``LOD_RATIOS`` × the full mesh's triangles. Level 0 is never
        pruned when its budget is None or at least the full count.
    rings : sequence of (int, int)
        Ring subdivisions of each level.
    u_steps : sequence of int
        Bands along each segment of each level.
    tip_radius : float, optional
        Tip radius of the LOD rule, shared by all levels; default the smallest live radius.
    bezier_w, bark_rate, bark_repeat
        As in :func:`plantvr.geometry.build_branch_mesh`.
    widen : bool
        Scale the radii of levels ≥ 1 by :func:`silhouette_radius_scale` of their ring subdivisions, so coarse
        rings keep the silhouette width of level 0.
    prune_px : float
        Prune, at each level ≥ 1, the axes whose base radius projects below ``prune_px`` pixels when the tree
        spans ``screen_px[k]`` pixels (its height, or crown width if larger). 0 (default): prune only to meet a
        budget.
    screen_px : sequence of float, optional
        On-screen size of the tree at the nearest distance each level is used (required when ``prune_px > 0``),
        e.g. ``(inf,) + LOD_SCREEN_PX[:3]`` of :mod:`plantvr.view.billboard`.

    Returns
    -------
    list of LodLevel
        Triangle counts never increase from one level to the next. A level whose budget cannot be met even
        with only the trunk keeps the trunk (``LodLevel.met`` is False).

    References
    ----------
    .. [1] Thesis §10.3 (subdivisions from the radius); spec §3.5, ERRATUM A.14 for the (6, 32) pair.
    """
    pos, parent, radius, alive, main_child = _check_tree(pos, parent, radius, alive, main_child)
    if not (isinstance(rings, (tuple, list)) and len(rings) >= 1):
        raise ValueError(f"rings must be a non-empty sequence of (min, max) pairs, got {rings!r}")
    levels = check_int("levels", levels, 1, len(rings))
    if len(u_steps) < levels:
        raise ValueError(f"u_steps must have at least levels={levels} entries, got {len(u_steps)}")
    optss = [_check_options(bezier_w, u_steps[k], rings[k], tip_radius, bark_rate, bark_repeat, radius, parent, alive)
             for k in range(levels)]
    full = _count(pos, parent, radius, alive, main_child, optss[0])
    if budgets is None:
        budgets = [max(1, int(full * LOD_RATIOS[min(k, len(LOD_RATIOS) - 1)])) for k in range(levels)]
    else:
        budgets = check_array("budgets", budgets, shape=(levels,), dtype=np.int64)
        if np.any(budgets < 1):
            raise ValueError(f"budgets must be >= 1, got {budgets.tolist()!r}")
        budgets = [int(b) for b in budgets]
    prune_px = check_range("prune_px", prune_px, 0.0, 1e6)
    if prune_px > 0:
        if screen_px is None or len(screen_px) < levels:
            raise ValueError(f"screen_px must give one size per level ({levels}) when prune_px > 0, got {screen_px!r}")
        live = pos[1:][alive[1:]]
        ext = np.ptp(live, axis=0) if len(live) else np.ones(3)
        size = max(float(ext[1]), float(ext[0]), float(ext[2]), 1e-12)
    start = axis_start(parent, main_child, alive)
    cuts = np.unique(radius[start[1:]][alive[1:]])
    out: list[LodLevel] = []
    prev_cut = 0.0
    prev_tris = None
    for k in range(levels):
        opts = optss[k]
        rad = radius
        if widen and k > 0:
            rad = radius * silhouette_radius_scale(lod_level(radius, tip_radius=opts["tip_radius"], lod=opts["lod"]))
        budget = budgets[k] if prev_tris is None else min(budgets[k], prev_tris)
        cut = prev_cut
        if prune_px > 0 and k > 0:
            cut = max(cut, prune_px * size / float(screen_px[k]))
        keep = _prune_mask(start, radius, alive, cut)
        if _count(pos, parent, rad, keep, main_child, opts) > budget:
            lo = int(np.searchsorted(cuts, cut))      # candidates cuts[lo:]; find the smallest that fits
            hi = len(cuts) - 1
            while lo < hi:
                mid = (lo + hi) // 2
                if _count(pos, parent, rad, _prune_mask(start, radius, alive, cuts[mid]), main_child,
                          opts) <= budget:
                    hi = mid
                else:
                    lo = mid + 1
            cut = float(cuts[lo])
            keep = _prune_mask(start, radius, alive, cut)
        seg = tree_segments(pos, parent, rad, alive=keep, main_child=main_child, bezier_w=opts["bezier_w"],
                            bark_rate=opts["bark_rate"], _checked=True)
        mesh = _build(seg, opts)
        out.append(LodLevel(mesh=mesh, level=k, lod=tuple(opts["lod"]), u_steps=opts["u_steps"],
                            cut_radius=cut, budget=budgets[k], alive=keep))
        prev_cut, prev_tris = cut, len(mesh.faces)
    return out

"""Crown -> attraction points -> space colonization glue, and pipe-model radii (spec 003_implicit_sca §1, §1.7;
C-17 to C-19).

The colonization algorithm itself is ``plantvr.growth.colonize.space_colonization`` (one kernel for the project);
this module only validates the markers, picks default roots under the crown and computes Eq. 2.1 radii.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import MAX_COORD, MAX_COUNT, check_int, check_points, check_range

from .blobtree import Node

__all__ = ["default_roots", "grow_in_crown", "pipe_radii"]


def default_roots(node_or_points, *, up: int = 1) -> np.ndarray:
    """One root under the crown: bottom centre of its box minus 0.1 x its height along ``up`` (spec §1.5).

    Parameters
    ----------
    node_or_points : Node or (N, 3) array_like
        The crown envelope (its support box) or its attraction points.
    up : int
        Vertical axis (1 = y, the thesis's ``scale s 50 80 50`` reading; 2 = z).

    Returns
    -------
    (1, 3) float64 ndarray
        Root position.
    """
    up = check_int("up", up, 0, 2)
    if isinstance(node_or_points, Node):
        from .sampling import _tight_box

        lo, hi = _tight_box(node_or_points, 0.5)       # box of the envelope (F > iso), not of the support
    else:
        p = check_points("points", node_or_points, min_rows=1)
        lo, hi = p.min(axis=0), p.max(axis=0)
    root = 0.5 * (lo + hi)
    root[up] = lo[up] - 0.1 * (hi[up] - lo[up])
    return root[None, :]


def grow_in_crown(markers, roots=None, *, step_size: float, kill_radius: float, influence_radius: float = np.inf,
                  max_steps: int = 500, children_limit: int | None = None, stall_steps: int | None = -1,
                  up: int = 1):
    """Grow a tree toward the crown's attraction points with the project's space colonization.

    Parameters
    ----------
    markers : (M, 3) float64 array_like
        Attraction points (M >= 1); an empty envelope gives a ValueError, not an empty tree.
    roots : (R, 3) float64 array_like, optional
        Start nodes (several roots compete for markers); default :func:`default_roots` of the markers.
    step_size : float
        Segment length D > 0.
    kill_radius : float
        Kill distance d_k > 0.
    influence_radius : float
        Radius of influence d_i (``inf`` reproduces thesis §2.5; small values grow around surfaces, §7.2).
    max_steps : int
        Iteration cap.
    children_limit : int, optional
        Passed through to the colonization kernel.
    stall_steps : int, optional
        Stop after this many steps without a kill (spec §1.4 stall guard; None: off). The default (-1) is 20 plus
        the steps the trunk needs to reach the nearest marker from the farthest root.
    up : int
        Vertical axis for the default root.

    Returns
    -------
    object
        The colonization result with ``nodes (N, 3)``, ``parent (N,)`` (-1 for roots), ``markers_left``, ``steps``.

    References
    ----------
    .. [1] Kochhar 2010, §2.5, §7.2; Runions et al. 2007 [83]; spec 003 §1.3-1.5.
    """
    markers = check_points("markers", markers)
    if len(markers) > MAX_COUNT:
        raise ValueError(f"markers must have at most {MAX_COUNT} rows, got {len(markers)}")
    if len(markers) == 0:
        raise ValueError("markers is empty: the crown envelope produced no attraction points "
                         "(check the surface, its scale and the distribution)")
    roots = default_roots(markers, up=up) if roots is None else check_points("roots", roots, min_rows=1)
    step_size = check_range("step_size", step_size, 1e-9, MAX_COORD)
    kill_radius = check_range("kill_radius", kill_radius, 1e-9, MAX_COORD)
    if not (isinstance(influence_radius, (int, float, np.integer, np.floating))
            and not isinstance(influence_radius, bool) and float(influence_radius) == np.inf):
        influence_radius = check_range("influence_radius", influence_radius, 0.0, 4 * MAX_COORD, low_open=True)
    influence_radius = float(influence_radius)
    max_steps = check_int("max_steps", max_steps, 1, 10**7)
    if children_limit is not None:
        children_limit = check_int("children_limit", children_limit, 1, 10**6)
    if stall_steps is not None and not (isinstance(stall_steps, (int, np.integer)) and stall_steps == -1):
        stall_steps = check_int("stall_steps", stall_steps, 1, 10**7)
    try:
        from plantvr.growth.colonize import space_colonization
    except ImportError as exc:  # pragma: no cover - depends on the growth package landing
        raise ValueError("space colonization needs plantvr.growth.colonize, which is not installed yet") from exc
    if stall_steps == -1:
        from scipy.spatial import cKDTree

        gap = float(cKDTree(markers).query(roots)[0].max())
        stall_steps = 20 + int(np.ceil(gap / step_size))
    if not np.isfinite(influence_radius):
        # the kernel takes a finite d_i: twice the diagonal of markers and roots reaches every marker from any node
        allp = np.vstack([markers, roots])
        influence_radius = 2.0 * float(np.linalg.norm(allp.max(axis=0) - allp.min(axis=0))) + 2.0 * step_size
        if influence_radius <= kill_radius:         # coincident markers and roots: any node reaches them all
            influence_radius = 2.0 * kill_radius
    if kill_radius >= influence_radius:
        raise ValueError(f"kill_radius must be smaller than influence_radius ({influence_radius}), got {kill_radius}")
    return space_colonization(markers, roots, influence_radius=influence_radius, kill_radius=kill_radius,
                              step_size=step_size, max_steps=max_steps, children_limit=children_limit,
                              stall_steps=stall_steps)


def pipe_radii(parent, *, r0: float = 0.01, exponent: float = 2.5) -> np.ndarray:
    """Pipe-model branch radii ``r^n = sum_children r_child^n`` from tips of radius ``r0`` (Eq. 2.1).

    Parameters
    ----------
    parent : (N,) int array_like
        Parent index of each node, -1 for roots.
    r0 : float
        Tip radius > 0.
    exponent : float
        Pipe exponent n in [2, 3] (Holton: 2).

    Returns
    -------
    (N,) float64 ndarray
        Radius of each node (of the segment ending at it).

    References
    ----------
    .. [1] Kochhar 2010, §2.6, Eq. 2.1; spec 003 §1.7 (k children generalization [INFERRED]).

    Examples
    --------
    >>> pipe_radii([-1, 0, 0], r0=1.0, exponent=2.0).round(6).tolist()
    [1.414214, 1.0, 1.0]
    """
    try:
        par = np.asarray(parent)
    except (TypeError, ValueError):
        raise ValueError(f"parent must be a 1D integer array, got {type(parent).__name__}") from None
    if par.ndim != 1 or (par.size and not np.issubdtype(par.dtype, np.integer)):
        raise ValueError(f"parent must be a 1D integer array, got dtype {par.dtype} shape {par.shape}")
    par = par.astype(np.int64)
    n = len(par)
    if n and (par.min() < -1 or par.max() >= n):
        raise ValueError(f"parent must hold -1 or indices in [0, {n - 1}], got range [{par.min()}, {par.max()}]")
    r0 = check_range("r0", r0, 0.0, np.inf, low_open=True)
    exponent = check_range("exponent", exponent, 2.0, 3.0)
    # breadth-first order from the roots; every node must be reached (no cycles)
    children_start = np.argsort(par, kind="stable")
    counts = np.bincount(par[par >= 0], minlength=n)
    offsets = np.r_[0, np.cumsum(counts)]
    kids = children_start[np.sum(par < 0):]
    order = list(np.flatnonzero(par < 0))
    head = 0
    while head < len(order):
        v = order[head]
        head += 1
        order.extend(kids[offsets[v]:offsets[v + 1]].tolist())
    if len(order) != n:
        raise ValueError(f"parent must describe a forest: {n - len(order)} nodes are not reachable from a root "
                         "(cycle)")
    acc = np.zeros(n)
    only = np.zeros(n)               # radius of the single child (exact, no power round trip along chains)
    r = np.empty(n)
    for v in reversed(order):
        r[v] = r0 if counts[v] == 0 else (only[v] if counts[v] == 1 else acc[v] ** (1.0 / exponent))
        if par[v] >= 0:
            acc[par[v]] += r[v] ** exponent
            only[par[v]] = r[v]
    return r

"""Branch editing: bending with stiffness w = r^4 / l (spec 004_treesketch §2.9, Eq. A.3) and pipe-model widths
with width constraints (§2.10, Eqs. 5.1–5.3).

The path B..E is a chain of internodes; each joint (the node at the proximal end of an internode) carries a
rotation phi_j of everything distal to it relative to its supporting internode. A drag of the end node E to a
target is solved as the stiffness-weighted least-change problem

    min_phi  sum_j w_j |phi_j|^2   subject to   E(phi) = target,    w_j = r_j^4 / l_j   (Eq. A.3),

by Gauss-Newton with the constraint linearised at every iteration (closed-form weighted minimum-norm step).
Every node distal to a joint is moved by the same rigid map as the internode that supports it, so internode
lengths are preserved exactly and side branches keep their pose relative to their supporting internode. The
global minimum for an undisplaced handle is the rest state, so the editing is circular: solving always starts
from the rest pose, and dragging the end back to its rest position restores the branch exactly.

This replaces PriMo's prism shape matching (Eqs. A.1–A.2), whose local Gauss-Seidel matching converges slowly
(spec §2.9 [PROTOTYPE-MEASURED]); it keeps the properties the spec tests (V14): rest state at zero
displacement, circular editing, thicker internodes bend less, side branches transported rigidly. Stretching,
which PriMo allows, is not modelled: a target beyond the path's reach raises ``ValueError``.

:func:`pipe_widths` computes branch diameters by the pipe model d^n = sum d_i^n (Eq. 5.1) with any number of
width constraints: they partition the tree into subtrees, and the exponent n of each is found by a safeguarded
Newton solve (ERRATUM E2: the exact equal-tip solution is n = log(M+1) / (log d_b - log d_e)).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .._validation import MAX_COORD, MAX_COUNT, check_array, check_int, check_point, check_range

__all__ = ["BendResult", "WidthResult", "bend_path", "pipe_widths", "rotation_matrix", "solve_exponent", "stiffness"]


@dataclass(frozen=True)
class BendResult:
    """Bent node positions and the rigid map of every node (identity for nodes that did not move).

    pos : (n, 3) float64; rot : (n, 3, 3) float64, the rotation applied to a node's frame (head, lat);
    phi : (m, 3) float64, the joint rotation vectors (radians, in the rest frame of the parent internode);
    residual : float, |E' − target|; iterations : int.
    """

    pos: np.ndarray
    rot: np.ndarray
    phi: np.ndarray
    residual: float
    iterations: int


def rotation_matrix(v: np.ndarray) -> np.ndarray:
    """Rodrigues: the rotation matrix of rotation vector ``v`` (3,) (angle = |v|, radians)."""
    v = np.asarray(v, float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        v = check_array("v", v, shape=(3,), max_abs=1e12)
    a = float(np.linalg.norm(v))
    if a < 1e-300:
        return np.eye(3)
    k = v / a
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(a) * K + (1.0 - np.cos(a)) * (K @ K)


def _log(R: np.ndarray) -> np.ndarray:
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    a = np.arccos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if a < 1e-12:
        return 0.5 * w
    return a / (2.0 * np.sin(a)) * w if np.pi - a > 1e-6 else a * np.sqrt(np.maximum((np.diag(R) + 1) / 2, 0))


def stiffness(radius: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Eq. A.3: flexural stiffness w = r^4 / l per internode (elastic modulus and constants dropped).

    ``radius`` and ``length`` are positive and finite (arrays of one shape, or scalars).
    """
    try:
        r, ln = np.asarray(radius, float), np.asarray(length, float)
    except (TypeError, ValueError):
        raise ValueError(f"radius and length must be numbers or arrays, got {type(radius).__name__} and "
                         f"{type(length).__name__}") from None
    for name, a in (("radius", r), ("length", ln)):
        if not np.all(np.isfinite(a) & (a > 0) & (a <= MAX_COORD)):
            raise ValueError(f"{name} must be positive and at most {MAX_COORD:g}")
    if r.shape != ln.shape and r.ndim and ln.ndim:
        raise ValueError(f"radius and length must have one shape, got {r.shape} and {ln.shape}")
    return r ** 4 / ln


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _governing_joint(parent: np.ndarray, path: np.ndarray) -> np.ndarray:
    """For each node, the index k of the last path node on its ancestor chain minus 1 (joint that moves it),
    or -1 when no joint moves it (not below path[1])."""
    n = len(parent)
    anc = np.full(n, -2, np.int64)
    anc[path] = np.arange(len(path))
    ptr = parent.copy()
    unknown = anc == -2
    while unknown.any():
        u = np.flatnonzero(unknown)
        top = ptr[u] < 0
        anc[u[top]] = -1
        rest = u[~top]
        known = anc[ptr[rest]] != -2
        anc[rest[known]] = anc[ptr[rest[known]]]
        ptr[rest[~known]] = ptr[ptr[rest[~known]]]  # pointer jumping
        unknown = anc == -2
    return np.where(anc >= 1, anc - 1, -1)


def bend_path(pos: np.ndarray, parent: np.ndarray, radius: np.ndarray, path, target, *,
              max_iter: int = 100, tol: float = 1e-9) -> BendResult:
    """Bend the internode chain ``path`` so its end node reaches ``target`` (spec 004 §2.9).

    Parameters
    ----------
    pos : (n, 3) float64 array
        Rest node positions.
    parent : (n,) int64 array
        Parent index of each node, -1 for a root.
    radius : (n,) float64 array
        Radius of the internode ending at each node (> 0 on the path), e.g. ``Tree.radius``.
    path : (m + 1,) int sequence
        Nodes p_0 .. p_m with parent[p_k] == p_{k-1}; p_0 stays fixed, p_m is the handle E.
    target : (3,) float64
        Where E should go; must be within the summed internode lengths of p_0.
    max_iter : int
        Gauss-Newton iterations.
    tol : float
        Stop when |E − target| < tol.

    Returns
    -------
    BendResult

    References
    ----------
    .. [1] Longay thesis §5.3.1, App. A, Eq. A.3 (w = r^4/l); spec 004 §2.9 (circular editing, rigid transport).
    """
    pos = check_array("pos", pos, shape=(None, 3), max_abs=MAX_COORD)
    n = len(pos)
    parent = np.asarray(parent)
    if parent.shape != (n,) or not np.issubdtype(parent.dtype, np.integer) or (parent >= n).any() or \
            (parent < -1).any():
        raise ValueError(f"parent must be an (n,) int array of indices in [-1, {n - 1}], got shape {parent.shape}")
    parent = parent.astype(np.int64)
    radius = check_array("radius", radius, shape=(n,), max_abs=MAX_COORD)
    try:
        path = np.asarray(path)
    except (TypeError, ValueError):
        raise ValueError(f"path must be a sequence of node indices, got {type(path).__name__}") from None
    if path.ndim != 1 or len(path) < 2 or not np.issubdtype(path.dtype, np.integer) or \
            (path < 0).any() or (path >= n).any():
        raise ValueError(f"path must be a sequence of at least 2 node indices in [0, {n - 1}], got {path!r}")
    path = path.astype(np.int64)
    if not np.all(parent[path[1:]] == path[:-1]):
        raise ValueError("path must follow the tree: parent[path[k]] == path[k-1] for every k >= 1")
    target = check_point("target", target)
    max_iter = check_int("max_iter", max_iter, 1, 100_000)
    tol = check_range("tol", tol, 0.0, MAX_COORD, low_open=True)
    seg = pos[path[1:]] - pos[path[:-1]]
    length = np.linalg.norm(seg, axis=1)
    r = radius[path[1:]]
    if (length <= 1e-12).any() or (r <= 1e-12).any():
        raise ValueError("every path internode needs a length and radius above 1e-12")
    if float(r.max()) / float(r.min()) > 1e6:  # w = r^4 / l spans at most 1e24 (the solve stays well posed)
        raise ValueError(f"radius along the path must stay within a factor 1e6, got {float(r.min()):.3g} .. "
                         f"{float(r.max()):.3g}")
    reach = float(length.sum())
    if np.linalg.norm(target - pos[path[0]]) > reach * (1 + 1e-12):
        raise ValueError(f"target is {np.linalg.norm(target - pos[path[0]]):.6g} from the path base, "
                         f"beyond the path's reach {reach:.6g} (internode lengths are preserved)")
    m = len(seg)
    w = stiffness(r, length)
    winv = np.repeat(1.0 / w, 3)

    R = np.tile(np.eye(3), (m, 1, 1))  # joint j: rotation of internode j+1 relative to internode j (rest frame)

    def forward(R):
        G = np.empty((m, 3, 3))
        P = np.empty((m + 1, 3))
        P[0] = pos[path[0]]
        g = np.eye(3)
        for j in range(m):
            g = g @ R[j]
            G[j] = g
            P[j + 1] = P[j] + g @ seg[j]
        return G, P

    G, P = forward(R)
    it = 0
    res = target - P[m]
    while np.linalg.norm(res) >= tol and it < max_iter:
        it += 1
        J = np.concatenate([-_skew(P[m] - P[j]) @ G[j] for j in range(m)], axis=1)  # (3, 3m)
        a = -np.concatenate([_log(R[j]) for j in range(m)])
        JW = J * winv
        A = JW @ J.T
        A += (1e-12 * np.trace(A) + 1e-300) * np.eye(3)
        x = a + JW.T @ np.linalg.solve(A, res - J @ a)
        step = 1.0
        base = np.linalg.norm(res)
        for _ in range(30):  # backtracking: accept a step that reduces the residual
            Rn = np.array([R[j] @ rotation_matrix(step * x[3 * j:3 * j + 3]) for j in range(m)])
            Gn, Pn = forward(Rn)
            rn = target - Pn[m]
            if np.linalg.norm(rn) < base or step < 1e-6:
                break
            step *= 0.5
        R, G, P, res = Rn, Gn, Pn, rn

    gov = _governing_joint(parent, path)
    out = pos.copy()
    rot = np.tile(np.eye(3), (n, 1, 1))
    moved = np.flatnonzero(gov >= 0)
    j = gov[moved]
    out[moved] = np.einsum("nij,nj->ni", G[j], pos[moved] - pos[path[j]]) + P[j]
    rot[moved] = G[j]
    out[path] = P  # the same values, without round-off from the subtree map
    phi = np.array([_log(R[k]) for k in range(m)])
    return BendResult(out, rot, phi, float(np.linalg.norm(res)), it)


# -- pipe-model widths (§2.10) ------------------------------------------------------------------------------
@dataclass(frozen=True)
class WidthResult:
    """Diameters of a tree under the pipe model with width constraints.

    diameter : (n,) float64, diameter of the internode ending at each node (dead nodes 0);
    exponent : dict {constraint node: n of its subtree} (``-1`` key: the unconstrained part at the root);
    infeasible : tuple of constraint nodes whose diameter is not larger than all their extremities'
    (their n is clamped to the upper bound).
    """

    diameter: np.ndarray
    exponent: dict
    infeasible: tuple


def solve_exponent(d_c: float, d_k: np.ndarray, *, bounds: tuple[float, float] = (0.5, 10.0),
                   tol: float = 1e-13, max_iter: int = 100) -> tuple[float, bool]:
    """Solve sum_k d_k^n = d_c^n for n (Eq. 5.2) by Newton-Raphson, safeguarded by bisection.

    Works on g(n) = log sum_k d_k^n - n log d_c, which is convex, positive at n = 0 (log m) and decreasing when
    d_c > max d_k; the start is n0 = log m / (log d_c - mean log d_k) (Eq. 5.3, exact for equal extremities).

    Parameters
    ----------
    d_c : float
        Constrained diameter at the subtree's root (> 0).
    d_k : (m,) float64 array
        Diameters of the subtree's extremities (tips and lower constraints), m >= 2, all > 0.
    bounds : (float, float)
        Bracket [n_lo, n_hi] for the root.

    Returns
    -------
    (n, feasible) : (float, bool)
        ``feasible`` is False when d_c <= max d_k (no root above n_lo) and n is clamped to n_hi.

    References
    ----------
    .. [1] Longay thesis §5.3.2, Eqs. 5.1–5.3; spec 004 §2.10, ERRATUM E2 (log(M+1)).
    """
    d_c = check_range("d_c", d_c, _MIN_D, MAX_COORD)
    try:
        d_k = np.asarray(d_k, float)
    except (TypeError, ValueError):
        raise ValueError(f"d_k must be a 1-D array of positive diameters, got {type(d_k).__name__}") from None
    if d_k.ndim != 1 or len(d_k) < 2 or not np.all(np.isfinite(d_k) & (d_k >= _MIN_D) & (d_k <= MAX_COORD)):
        raise ValueError(f"d_k must be a 1-D array of at least 2 diameters in [{_MIN_D:g}, {MAX_COORD:g}], "
                         f"got {d_k!r}")
    lo, hi = _check_bounds(bounds)
    tol = check_range("tol", tol, 0.0, 1.0, low_open=True)
    max_iter = check_int("max_iter", max_iter, 1, 100_000)
    lk, lc = np.log(d_k), np.log(d_c)
    m = len(d_k)

    def g(n):
        a = n * lk
        mx = a.max()
        w = np.exp(a - mx)
        s = w.sum()
        return mx + np.log(s) - n * lc, float(w @ lk / s) - lc

    if d_c <= d_k.max() or g(hi)[0] > 0:
        return hi, False
    if g(lo)[0] < 0:
        return lo, False
    denom = lc - lk.mean()
    n = min(max(np.log(m) / denom, lo), hi)
    for _ in range(max_iter):
        f, df = g(n)
        if f > 0:
            lo = n
        else:
            hi = n
        if abs(f) < tol:
            break
        nn = n - f / df if df < 0 else 0.5 * (lo + hi)
        if not (lo < nn < hi):
            nn = 0.5 * (lo + hi)
        if abs(nn - n) < 1e-15 * max(1.0, n):
            n = nn
            break
        n = nn
    return float(n), True


#: Diameters and exponents of the pipe model are bounded so that d^n neither overflows nor underflows
#: (1e-9^20 and 1e6^20 are far inside float64).
_MIN_D, _MAX_EXP = 1e-9, 20.0


def _check_bounds(bounds) -> tuple[float, float]:
    if isinstance(bounds, (str, bytes)) or not hasattr(bounds, "__len__") or len(bounds) != 2:
        raise ValueError(f"bounds must be (n_lo, n_hi), got {bounds!r}")
    lo = check_range("bounds[0]", bounds[0], 0.05, _MAX_EXP)
    hi = check_range("bounds[1]", bounds[1], lo, _MAX_EXP, low_open=True)
    return lo, hi


@numba.njit(cache=True, nogil=True)
def _pipe_fold(parent, alive, fixed, fixed_d, node_n, tip_d, out):
    """Backward fold (children have larger indices): d = (sum of children d^n)^(1/n), fixed where constrained."""
    n_all = parent.shape[0]
    acc = np.zeros(n_all)
    has = np.zeros(n_all, np.bool_)
    for i in range(n_all - 1, -1, -1):
        if not alive[i]:
            out[i] = 0.0
            continue
        if fixed[i]:
            d = fixed_d[i]
        elif has[i]:
            d = acc[i] ** (1.0 / node_n[i])
        else:
            d = tip_d
        out[i] = d
        p = parent[i]
        if p >= 0 and alive[p]:
            acc[p] += d ** node_n[p]
            has[p] = True


@numba.njit(cache=True, nogil=True)
def _segments(parent, fixed):
    """Segment of each node: its nearest constrained ancestor-or-self (-1: none); one forward pass."""
    seg = np.full(parent.shape[0], -1, np.int64)
    for i in range(parent.shape[0]):
        if fixed[i]:
            seg[i] = i
        elif parent[i] >= 0:
            seg[i] = seg[parent[i]]
    return seg


def _segments_numpy(parent, fixed):
    """Readable twin of :func:`_segments`: pointer jumping up to the first constrained ancestor."""
    seg = np.where(fixed, np.arange(len(parent)), -1)
    ptr = np.where(fixed | (parent < 0), -1, parent)
    while (ptr >= 0).any():
        a = np.flatnonzero(ptr >= 0)
        hit = seg[ptr[a]] >= 0
        seg[a[hit]] = seg[ptr[a[hit]]]
        ptr[a[hit]] = -1
        rest = a[~hit]
        ptr[rest] = np.where(fixed[ptr[rest]] | (parent[ptr[rest]] < 0), -1, parent[ptr[rest]])
        seg[rest] = np.where(fixed[ptr[rest]] & (ptr[rest] >= 0), ptr[rest], seg[rest])
    return seg


def _pipe_fold_numpy(parent, alive, fixed, fixed_d, node_n, tip_d):
    """Readable twin of :func:`_pipe_fold`: the same fold, level by level from the deepest nodes."""
    n_all = len(parent)
    depth = np.zeros(n_all, np.int64)
    for i in range(n_all):
        if parent[i] >= 0:
            depth[i] = depth[parent[i]] + 1
    out = np.zeros(n_all)
    acc = np.zeros(n_all)
    has = np.zeros(n_all, bool)
    for lev in range(depth.max(initial=0), -1, -1):
        idx = np.flatnonzero((depth == lev) & alive)
        d = np.where(fixed[idx], fixed_d[idx], np.where(has[idx], acc[idx] ** (1.0 / node_n[idx]), tip_d))
        out[idx] = d
        p = parent[idx]
        ok = (p >= 0)
        ok[ok] &= alive[p[ok]]
        np.add.at(acc, p[ok], d[ok] ** node_n[p[ok]])
        has[p[ok]] = True
    return out


def pipe_widths(parent: np.ndarray, alive: np.ndarray, *, tip_diameter: float, exponent: float = 2.5,
                constraints: dict[int, float] | None = None, bounds: tuple[float, float] = (0.5, 10.0)
                ) -> WidthResult:
    """Pipe-model diameters (Eq. 5.1) with width constraints solved per subtree (spec 004 §2.10).

    Every constrained node c (the internode ending at c has diameter d_c) roots a subtree that reaches down to
    the tips (diameter ``tip_diameter`` = d_e) and to the next constraints below it. Its exponent n solves
    sum_k d_k^n = d_c^n over the subtree's extremities (Eq. 5.2, :func:`solve_exponent`); a subtree with a single
    extremity is an unbranched path, whose diameter is interpolated linearly along it (the pipe model allows no
    taper there, spec [INFERRED]). The part above every constraint uses ``exponent``. Inner diameters follow
    bottom-up from d = (sum_children d^n)^(1/n).

    Parameters
    ----------
    parent : (n,) int64 array
        Parent of each node (-1 at the root); parent index < child index.
    alive : (n,) bool array
        Live nodes.
    tip_diameter : float
        d_e, the diameter of every tip internode (> 0).
    exponent : float
        n of the unconstrained part (Eq. 5.1; "usually between 2 and 3").
    constraints : dict {node: diameter}, optional
        Width constraints on live nodes >= 1 (d_b at node 1 fixes the trunk base).
    bounds : (float, float)
        Bracket for the Newton solves.

    Returns
    -------
    WidthResult

    References
    ----------
    .. [1] Longay thesis §5.3.2, Eqs. 5.1–5.3, Figs. 5.19–5.20; spec 004 §2.10, ERRATUM E2.
    """
    try:
        parent = np.asarray(parent)
    except (TypeError, ValueError):
        raise ValueError(f"parent must be an (n,) int array, got {type(parent).__name__}") from None
    n_all = len(parent) if parent.ndim else 0
    if parent.ndim != 1 or not np.issubdtype(parent.dtype, np.integer) or n_all > MAX_COUNT or \
            np.any(parent >= np.arange(n_all)) or np.any(parent < -1):
        raise ValueError("parent must be an (n,) int array with -1 <= parent[i] < i")
    parent = parent.astype(np.int64)
    alive = check_array("alive", alive, shape=(n_all,), dtype=bool)
    tip_d = check_range("tip_diameter", tip_diameter, _MIN_D, MAX_COORD)
    exponent = check_range("exponent", exponent, 0.1, _MAX_EXP)
    bounds = _check_bounds(bounds)
    if constraints is not None and not isinstance(constraints, dict):
        raise ValueError(f"constraints must be a dict {{node: diameter}} or None, got {type(constraints).__name__}")
    cons = {}
    for k, v in (constraints or {}).items():
        k = check_int("constraint node", k, 1, n_all - 1)
        if not alive[k]:
            raise ValueError(f"constraint node {k} is not alive")
        cons[k] = check_range(f"constraint diameter at node {k}", v, _MIN_D, MAX_COORD)
    fixed = np.zeros(n_all, bool)
    fixed_d = np.zeros(n_all)
    for k, v in cons.items():
        fixed[k], fixed_d[k] = True, v
    seg = _segments(parent, fixed)
    nchild = np.bincount(parent[alive & (parent >= 0)], minlength=n_all)
    tips = np.flatnonzero(alive & (nchild == 0) & ~fixed)
    tseg = seg[tips]
    ext_nodes: dict[int, list[int]] = {c: tips[tseg == c].tolist() for c in cons}
    for c in cons:
        p = parent[c]
        if p >= 0 and seg[p] >= 0:
            ext_nodes[seg[p]].append(c)
    node_n = np.full(n_all, exponent)
    exps: dict[int, float] = {-1: exponent}
    bad = []
    for c, ext in ext_nodes.items():
        if not ext:
            exps[c] = exponent
            continue
        dk = np.array([fixed_d[e] if fixed[e] else tip_d for e in ext])
        if len(ext) == 1:  # unbranched path c .. e: linear interpolation
            path = [ext[0]]
            while path[-1] != c:
                path.append(int(parent[path[-1]]))
            path = path[::-1]
            m = len(path) - 1
            for j, node in enumerate(path[1:-1], 1):
                fixed[node], fixed_d[node] = True, cons[c] + (dk[0] - cons[c]) * j / m
            if not fixed[ext[0]]:
                fixed[ext[0]], fixed_d[ext[0]] = True, dk[0]
            exps[c] = exponent
            continue
        nc, ok = solve_exponent(cons[c], dk, bounds=bounds)
        exps[c] = nc
        if not ok:
            bad.append(c)
    for c in cons:
        node_n[seg == c] = exps[c]
    out = np.zeros(n_all)
    _pipe_fold(parent, alive, fixed, fixed_d, node_n, tip_d, out)
    return WidthResult(out, exps, tuple(bad))

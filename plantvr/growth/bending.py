"""Branch bending with stiffness w = r^4 / l and rigid transport of subtrees (spec 004_treesketch §2.9, Eq. A.3).

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
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_array, check_int, check_point, check_range

__all__ = ["BendResult", "bend_path", "rotation_matrix", "stiffness"]


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
    """Eq. A.3: flexural stiffness w = r^4 / l per internode (elastic modulus and constants dropped)."""
    return np.asarray(radius, float) ** 4 / np.asarray(length, float)


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
    pos = check_array("pos", pos, shape=(None, 3))
    n = len(pos)
    parent = np.asarray(parent)
    if parent.shape != (n,) or not np.issubdtype(parent.dtype, np.integer) or (parent >= n).any() or \
            (parent < -1).any():
        raise ValueError(f"parent must be an (n,) int array of indices in [-1, {n - 1}], got shape {parent.shape}")
    parent = parent.astype(np.int64)
    radius = check_array("radius", radius, shape=(n,))
    path = np.asarray(path)
    if path.ndim != 1 or len(path) < 2 or not np.issubdtype(path.dtype, np.integer) or \
            (path < 0).any() or (path >= n).any():
        raise ValueError(f"path must be a sequence of at least 2 node indices in [0, {n - 1}], got {path!r}")
    path = path.astype(np.int64)
    if not np.all(parent[path[1:]] == path[:-1]):
        raise ValueError("path must follow the tree: parent[path[k]] == path[k-1] for every k >= 1")
    target = check_point("target", target)
    max_iter = check_int("max_iter", max_iter, 1, 100_000)
    tol = check_range("tol", tol, 0.0, np.inf, low_open=True)
    seg = pos[path[1:]] - pos[path[:-1]]
    length = np.linalg.norm(seg, axis=1)
    r = radius[path[1:]]
    if (length <= 0).any() or (r <= 0).any():
        raise ValueError("every path internode needs a positive length and radius")
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

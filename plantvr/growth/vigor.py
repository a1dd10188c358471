"""Extended Borchert–Honda light and vigor, shedding, pipe-model radius (spec 000_treewand §2.5, §2.8).

All four are TreeFold/TreeUnfold passes (§2.10), written as array-order loops: children have larger
indices than their parents, so a backward loop is a fold and a forward loop an unfold.

The public functions check their arrays at the door (shapes, dtypes, writable outputs) and run the
``*_kernel`` numba loops, which the engine calls directly. The kernels never index outside their arrays
(issue 20): a child or parent index outside ``[0, N)`` (other than the BUD/NO_SLOT markers) counts as an
absent slot, at the cost of one well-predicted compare per slot.
"""
from __future__ import annotations

import numba
import numpy as np

from plantvr._validation import check_range

__all__ = ["accumulate_light", "distribute_vigor", "shed_mask", "pipe_radius",
           "accumulate_light_kernel", "distribute_vigor_kernel", "shed_mask_kernel", "pipe_radius_kernel",
           "accumulate_light_numpy", "distribute_vigor_numpy", "shed_mask_numpy", "pipe_radius_numpy"]

BUD, NO_SLOT = -1, -2


@numba.njit(cache=True, nogil=True)
def accumulate_light_kernel(child, alive, L, factor, kappa, lam, Q, Qw, Qslot):
    """Basipetal TreeFold of light: Q = Σ slots, bud slots give Q = b·L^κ (Eq. 9.8, 0^0 = 1).

    ``factor`` is the per-node b (1 in Tree Wand; TreeSketch's gravimorphism, spec 004 Eq. 4.6).
    """
    nn = child.shape[0]
    for n in range(nn - 1, -1, -1):
        if not alive[n]:
            continue
        qb = factor[n] * (L[n] ** kappa if kappa > 0 else 1.0)
        tot = 0.0
        for s in range(3):
            c = child[n, s]
            if c >= 0:
                q = Q[c] if c < nn else 0.0
            else:
                q = qb if c == BUD else 0.0
            Qslot[n, s] = q
            tot += q
        Q[n] = tot
        Qw[n] = lam * Qslot[n, 0] + (1.0 - lam) * (Qslot[n, 1] + Qslot[n, 2])


@numba.njit(cache=True, nogil=True)
def distribute_vigor_kernel(child, alive, Qslot, Qw, lam, vigor_mult, vigor, bud_vigor):
    """Acropetal TreeUnfold: v_base = α Q_base, then Eqs. 9.6/9.7 (ERRATUM A.2, A.8) at every node."""
    nn = child.shape[0]
    if nn == 0:
        return
    root = 0
    vigor[root] = vigor_mult * (Qslot[root, 0] + Qslot[root, 1] + Qslot[root, 2])
    for n in range(nn):
        if not alive[n]:
            continue
        for s in range(3):
            c = child[n, s]
            if c == NO_SLOT:
                bud_vigor[n, s] = 0.0
                continue
            w = lam if s == 0 else 1.0 - lam
            vs = vigor[n] * w * Qslot[n, s] / Qw[n] if Qw[n] > 0 else 0.0
            if c >= 0:
                if c < nn:
                    vigor[c] = vs
                bud_vigor[n, s] = 0.0
            else:
                bud_vigor[n, s] = vs


@numba.njit(cache=True, nogil=True)
def _subtree_sizes(child, alive):
    nn = child.shape[0]
    size = np.zeros(nn, np.int64)
    for n in range(nn - 1, -1, -1):
        if not alive[n]:
            continue
        for s in range(3):
            c = child[n, s]
            if c >= 0 and c < nn:
                size[n] += 1 + size[c]
    return size


@numba.njit(cache=True, nogil=True)
def shed_mask_kernel(child, parent, alive, vigor, subtree):
    """§2.5 shedding: nodes whose vigor < their internode-children count (direct, or subtree if ``subtree``).

    The base point and the first internode are protected. Returns the mask of nodes removed,
    closed under descendants.
    """
    n_all = child.shape[0]
    size = _subtree_sizes(child, alive) if subtree else np.zeros(0, np.int64)
    out = np.zeros(n_all, np.bool_)
    for n in range(2, n_all):
        if not alive[n]:
            continue
        p = parent[n]
        if p >= 0 and p < n_all and out[p]:
            out[n] = True
            continue
        if subtree:
            cnt = size[n]
        else:
            cnt = 0
            for s in range(3):
                if child[n, s] >= 0:
                    cnt += 1
        if vigor[n] < cnt:
            out[n] = True
    return out


@numba.njit(cache=True, nogil=True)
def pipe_radius_kernel(child, alive, tip_radius, exponent, radius):
    """TreeFold of Eq. 9.15: r^n = Σ r_c^n over child internodes; nodes without one get the tip radius."""
    nn = child.shape[0]
    for n in range(nn - 1, -1, -1):
        if not alive[n]:
            continue
        acc = 0.0
        for s in range(3):
            c = child[n, s]
            if c >= 0 and c < nn:
                acc += radius[c] ** exponent
        radius[n] = acc ** (1.0 / exponent) if acc > 0 else tip_radius


# ---- door checks -----------------------------------------------------------------------------------------------
def _tree_arrays(child, alive, **arrays) -> int:
    """Check the topology and per-node arrays of a vigor pass; returns N. Arrays are used in place, so they must
    already have the right dtype and shape (no silent copies)."""
    if not isinstance(child, np.ndarray) or child.dtype != np.int64 or child.ndim != 2 or child.shape[1] != 3:
        raise ValueError(f"child must be an (N, 3) int64 ndarray, got {_describe(child)}")
    n = child.shape[0]
    if not isinstance(alive, np.ndarray) or alive.dtype != np.bool_ or alive.shape != (n,):
        raise ValueError(f"alive must be an ({n},) bool ndarray, got {_describe(alive)}")
    for name, (a, width) in arrays.items():
        shape = (n,) if width is None else (n, width)
        if not isinstance(a, np.ndarray) or a.dtype != np.float64 or a.shape != shape:
            raise ValueError(f"{name} must be a {shape} float64 ndarray, got {_describe(a)}")
    return n


def _describe(a) -> str:
    return f"{a.dtype} array of shape {a.shape}" if isinstance(a, np.ndarray) else type(a).__name__


def _writable(**arrays) -> None:
    for name, a in arrays.items():
        if not a.flags.writeable:
            raise ValueError(f"{name} must be writable (it receives the result)")


def accumulate_light(child, alive, L, factor, kappa, lam, Q, Qw, Qslot) -> None:
    """Basipetal light fold (Eq. 9.8) into ``Q``, ``Qw`` (N,) and ``Qslot`` (N, 3), all float64, in place.

    Parameters
    ----------
    child : (N, 3) int64 ndarray
        Child per slot: a node index, BUD (-1) or NO_SLOT (-2); children have larger indices than parents.
    alive : (N,) bool ndarray
        Nodes taking part.
    L, factor : (N,) float64 ndarray
        Illumination and the per-node factor b.
    kappa : float
        κ in [0, inf), the light exponent.
    lam : float
        λ in [0, 1], the apical dominance.

    References
    ----------
    .. [1] Tree Wand thesis §9.5, Eq. 9.8; spec 000_treewand §2.5.
    """
    _tree_arrays(child, alive, L=(L, None), factor=(factor, None), Q=(Q, None), Qw=(Qw, None), Qslot=(Qslot, 3))
    kappa = check_range("kappa", kappa, 0.0, np.inf, high_open=True)
    lam = check_range("lam", lam, 0.0, 1.0)
    _writable(Q=Q, Qw=Qw, Qslot=Qslot)
    accumulate_light_kernel(child, alive, L, factor, kappa, lam, Q, Qw, Qslot)


def distribute_vigor(child, alive, Qslot, Qw, lam, vigor_mult, vigor, bud_vigor) -> None:
    """Acropetal vigor unfold (Eqs. 9.6/9.7) into ``vigor`` (N,) and ``bud_vigor`` (N, 3) float64, in place.

    ``Qslot`` (N, 3) and ``Qw`` (N,) come from :func:`accumulate_light`; ``lam`` in [0, 1]; ``vigor_mult``
    (α, v_base = α Q_base) in [0, inf).

    References
    ----------
    .. [1] Tree Wand thesis §9.5, Eqs. 9.6/9.7 (ERRATUM A.2, A.8); spec 000_treewand §2.5.
    """
    _tree_arrays(child, alive, Qslot=(Qslot, 3), Qw=(Qw, None), vigor=(vigor, None), bud_vigor=(bud_vigor, 3))
    lam = check_range("lam", lam, 0.0, 1.0)
    vigor_mult = check_range("vigor_mult", vigor_mult, 0.0, np.inf, high_open=True)
    _writable(vigor=vigor, bud_vigor=bud_vigor)
    distribute_vigor_kernel(child, alive, Qslot, Qw, lam, vigor_mult, vigor, bud_vigor)


def shed_mask(child, parent, alive, vigor, subtree) -> np.ndarray:
    """(N,) bool mask of the nodes §2.5 sheds (vigor below the direct or, if ``subtree``, subtree internode count).

    ``parent`` (N,) int64 ndarray; the other arrays as in :func:`distribute_vigor`.

    References
    ----------
    .. [1] Tree Wand thesis §9.5; spec 000_treewand §2.5 (ambiguity A.18).
    """
    n = _tree_arrays(child, alive, vigor=(vigor, None))
    if not isinstance(parent, np.ndarray) or parent.dtype != np.int64 or parent.shape != (n,):
        raise ValueError(f"parent must be an ({n},) int64 ndarray, got {_describe(parent)}")
    if not isinstance(subtree, (bool, np.bool_)):
        raise ValueError(f"subtree must be True or False, got {subtree!r}")
    return shed_mask_kernel(child, parent, alive, vigor, bool(subtree))


def pipe_radius(child, alive, tip_radius, exponent, radius) -> None:
    """Pipe-model radius fold (Eq. 9.15) into ``radius`` (N,) float64, in place.

    ``tip_radius`` in (0, inf) m; ``exponent`` n in [1, 4] (r^n = Σ r_c^n).

    References
    ----------
    .. [1] Tree Wand thesis §9.8, Eq. 9.15; spec 000_treewand §2.8.
    """
    _tree_arrays(child, alive, radius=(radius, None))
    tip_radius = check_range("tip_radius", tip_radius, 0.0, np.inf, low_open=True, high_open=True)
    exponent = check_range("exponent", exponent, 1.0, 4.0)
    _writable(radius=radius)
    pipe_radius_kernel(child, alive, tip_radius, exponent, radius)


# ---- numpy twins (readable, per-node loops over the same order; used by the twin tests) ---------------------------
def _child_ok(c, nn):
    return 0 <= c < nn


def accumulate_light_numpy(child, alive, L, factor, kappa, lam, Q, Qw, Qslot) -> None:
    """numpy twin of :func:`accumulate_light_kernel`."""
    nn = len(child)
    for n in range(nn - 1, -1, -1):
        if not alive[n]:
            continue
        qb = factor[n] * (L[n] ** kappa if kappa > 0 else 1.0)
        c = child[n]
        Qslot[n] = [Q[x] if _child_ok(x, nn) else (qb if x == BUD else 0.0) for x in c]
        Q[n] = Qslot[n, 0] + Qslot[n, 1] + Qslot[n, 2]
        Qw[n] = lam * Qslot[n, 0] + (1.0 - lam) * (Qslot[n, 1] + Qslot[n, 2])


def distribute_vigor_numpy(child, alive, Qslot, Qw, lam, vigor_mult, vigor, bud_vigor) -> None:
    """numpy twin of :func:`distribute_vigor_kernel`."""
    nn = len(child)
    if nn == 0:
        return
    vigor[0] = vigor_mult * (Qslot[0, 0] + Qslot[0, 1] + Qslot[0, 2])
    for n in np.flatnonzero(alive):
        for s, c in enumerate(child[n]):
            w = lam if s == 0 else 1.0 - lam
            vs = vigor[n] * w * Qslot[n, s] / Qw[n] if Qw[n] > 0 else 0.0
            if c == NO_SLOT or c >= 0:
                bud_vigor[n, s] = 0.0
                if _child_ok(c, nn):
                    vigor[c] = vs
            else:
                bud_vigor[n, s] = vs


def shed_mask_numpy(child, parent, alive, vigor, subtree) -> np.ndarray:
    """numpy twin of :func:`shed_mask_kernel`."""
    nn = len(child)
    size = np.zeros(nn, np.int64)
    for n in range(nn - 1, -1, -1):
        if alive[n]:
            size[n] = sum(1 + size[c] for c in child[n] if _child_ok(c, nn))
    out = np.zeros(nn, bool)
    for n in range(2, nn):
        if not alive[n]:
            continue
        if _child_ok(parent[n], nn) and out[parent[n]]:
            out[n] = True
        else:
            out[n] = vigor[n] < (size[n] if subtree else int(np.sum(child[n] >= 0)))
    return out


def pipe_radius_numpy(child, alive, tip_radius, exponent, radius) -> None:
    """numpy twin of :func:`pipe_radius_kernel`."""
    nn = len(child)
    for n in range(nn - 1, -1, -1):
        if alive[n]:
            acc = 0.0
            for c in child[n]:
                if _child_ok(c, nn):
                    acc += radius[c] ** exponent
            radius[n] = acc ** (1.0 / exponent) if acc > 0 else tip_radius

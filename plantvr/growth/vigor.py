"""Extended Borchert–Honda light and vigor, shedding, pipe-model radius (spec 000_treewand §2.5, §2.8).

All four are TreeFold/TreeUnfold passes (§2.10), written as array-order loops: children have larger
indices than their parents, so a backward loop is a fold and a forward loop an unfold.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["accumulate_light", "distribute_vigor", "shed_mask", "pipe_radius"]

BUD, NO_SLOT = -1, -2


@numba.njit(cache=True, nogil=True)
def accumulate_light(child, alive, L, factor, kappa, lam, Q, Qw, Qslot):
    """Basipetal TreeFold of light: Q = Σ slots, bud slots give Q = b·L^κ (Eq. 9.8, 0^0 = 1).

    ``factor`` is the per-node b (1 in Tree Wand; TreeSketch's gravimorphism, spec 004 Eq. 4.6).
    """
    for n in range(child.shape[0] - 1, -1, -1):
        if not alive[n]:
            continue
        qb = factor[n] * (L[n] ** kappa if kappa > 0 else 1.0)
        tot = 0.0
        for s in range(3):
            c = child[n, s]
            q = Q[c] if c >= 0 else (qb if c == BUD else 0.0)
            Qslot[n, s] = q
            tot += q
        Q[n] = tot
        Qw[n] = lam * Qslot[n, 0] + (1.0 - lam) * (Qslot[n, 1] + Qslot[n, 2])


@numba.njit(cache=True, nogil=True)
def distribute_vigor(child, alive, Qslot, Qw, lam, vigor_mult, vigor, bud_vigor):
    """Acropetal TreeUnfold: v_base = α Q_base, then Eqs. 9.6/9.7 (ERRATUM A.2, A.8) at every node."""
    root = 0
    vigor[root] = vigor_mult * (Qslot[root, 0] + Qslot[root, 1] + Qslot[root, 2])
    for n in range(child.shape[0]):
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
                vigor[c] = vs
                bud_vigor[n, s] = 0.0
            else:
                bud_vigor[n, s] = vs


@numba.njit(cache=True, nogil=True)
def _subtree_sizes(child, alive):
    size = np.zeros(child.shape[0], np.int64)
    for n in range(child.shape[0] - 1, -1, -1):
        if not alive[n]:
            continue
        for s in range(3):
            c = child[n, s]
            if c >= 0:
                size[n] += 1 + size[c]
    return size


@numba.njit(cache=True, nogil=True)
def shed_mask(child, parent, alive, vigor, subtree):
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
        if out[parent[n]]:
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
def pipe_radius(child, alive, tip_radius, exponent, radius):
    """TreeFold of Eq. 9.15: r^n = Σ r_c^n over child internodes; nodes without one get the tip radius."""
    for n in range(child.shape[0] - 1, -1, -1):
        if not alive[n]:
            continue
        acc = 0.0
        for s in range(3):
            c = child[n, s]
            if c >= 0:
                acc += radius[c] ** exponent
        radius[n] = acc ** (1.0 / exponent) if acc > 0 else tip_radius

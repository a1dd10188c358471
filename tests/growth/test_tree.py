"""TW-V1 (data structure) and item 2 (fold/unfold = recursive reference)."""
import numpy as np

from plantvr.growth.tree import BUD, NO_SLOT, Tree
from plantvr.growth.vigor import accumulate_light, distribute_vigor, pipe_radius


def test_tw_v1_seed_and_consistency(grown):
    t = grown.tree
    live = np.flatnonzero(t.alive)
    assert t.parent[0] == -1 and all(t.parent[live[1:]] < live[1:])
    for n in live:
        for c in t.child[n]:
            if c >= 0 and t.alive[c]:
                assert t.parent[c] == n
    assert Tree.seed(1.0).child.tolist() == [[1, NO_SLOT, NO_SLOT], [BUD, BUD, NO_SLOT]]
    assert Tree.seed(1.0, nslots=3).child[1].tolist() == [BUD, BUD, BUD]


def test_tw_v1_removed_subtree_leaves_bud_and_compaction_keeps_order(grown):
    t = grown.tree.copy()
    n = int(np.flatnonzero(t.alive & (t.child[:, 0] >= 0))[5])
    par, slot = t.parent[n], None
    slot = int(np.flatnonzero(t.child[par] == n)[0])
    sub = t.subtree_mask([n])
    gone = t.remove(sub)
    assert t.child[par, slot] == BUD and len(gone) == sub.sum()
    before = t.pos[t.alive].copy()
    t.compact()
    assert t.alive.all() and np.array_equal(t.pos, before)
    assert np.all(t.parent[1:] < np.arange(1, t.n))


def _recursive_Q(t, n, kappa):
    qs = []
    for c in t.child[n]:
        qs.append(_recursive_Q(t, c, kappa) if c >= 0 and t.alive[c] else
                  ((t.L[n] ** kappa if kappa > 0 else 1.0) if c == BUD else 0.0))
    return sum(qs)


def test_fold_unfold_equal_recursive_reference(grown):
    t = grown.tree
    assert np.isclose(t.Q[0], _recursive_Q(t, 0, 1.0), rtol=1e-12)
    n = int(np.flatnonzero(t.alive)[len(np.flatnonzero(t.alive)) // 2])
    assert np.isclose(t.Q[n], _recursive_Q(t, n, 1.0), rtol=1e-12)


def test_tw_v10_vigor_conserved_and_lambda(grown):
    t = grown.tree.copy()
    for lam in (0.5, 0.55, 1.0):
        accumulate_light(t.child, t.alive, t.L, t.light_factor, 1.0, lam, t.Q, t.Qw, t.Qslot)
        distribute_vigor(t.child, t.alive, t.Qslot, t.Qw, lam, 2.0, t.vigor, t.bud_vigor)
        live = np.flatnonzero(t.alive)
        for n in live:
            share = sum(t.vigor[c] if c >= 0 else t.bud_vigor[n, s] for s, c in enumerate(t.child[n]) if c != NO_SLOT)
            if t.Qw[n] > 0:
                assert np.isclose(share, t.vigor[n], rtol=1e-9, atol=1e-12)
        if lam == 0.5:  # shares proportional to Q
            n = live[np.argmax((t.child[live] >= 0).sum(1))]
            ratio = t.vigor[t.child[n, 0]] / t.vigor[n]
            assert np.isclose(ratio, t.Qslot[n, 0] / t.Qslot[n].sum())
        if lam == 1.0:
            lat = t.child[live][:, 1:]
            assert np.all(t.vigor[lat[lat >= 0]] == 0)


def test_tw_v10_kappa_zero_ignores_light(grown):
    t = grown.tree.copy()
    t.L[:] = np.random.default_rng(0).random(t.n)
    accumulate_light(t.child, t.alive, t.L, t.light_factor, 0.0, 0.5, t.Q, t.Qw, t.Qslot)
    q1 = t.Q.copy()
    t.L[:] = 0.0
    accumulate_light(t.child, t.alive, t.L, t.light_factor, 0.0, 0.5, t.Q, t.Qw, t.Qslot)
    assert np.array_equal(q1, t.Q)


def test_tw_v14_pipe_radius(grown):
    t = grown.tree.copy()
    for n_exp in (2.0, 2.5):
        pipe_radius(t.child, t.alive, 0.02, n_exp, t.radius)
        for n in np.flatnonzero(t.alive):
            kids = [c for c in t.child[n] if c >= 0]
            if kids:
                assert np.isclose(t.radius[n] ** n_exp, sum(t.radius[c] ** n_exp for c in kids), rtol=1e-6)
            else:
                assert t.radius[n] == 0.02
    tips = np.flatnonzero(t.alive & ~(t.child >= 0).any(1))
    pipe_radius(t.child, t.alive, 0.02, 2.0, t.radius)
    assert np.isclose(t.radius[1] ** 2, len(tips) * 0.02 ** 2)  # n = 2 conserves area


def test_engine_pickles_for_dask_and_resumes_identically(grown):
    import pickle
    a = pickle.loads(pickle.dumps(grown))
    b = pickle.loads(pickle.dumps(grown))
    for e in (a, b):
        e.paint(np.array([0.0, 9.0, 0.0]), 3.0, 100)
        e.step()
    assert np.array_equal(a.tree.pos, b.tree.pos) and a.tree.n > 0

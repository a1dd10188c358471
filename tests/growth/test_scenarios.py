"""TW-V23: the thesis scenarios of Figs. 12.1, 12.3 and 12.7 as seeded stroke replays."""
import numpy as np

from plantvr.growth.engine import GrowthEngine
from plantvr.growth.scenarios import sweep_session, vertical_stroke, run
from plantvr.params import defaults


def _grow(session, steps=45, seed=0, **params):
    e = GrowthEngine({**defaults(), **params}, rng=seed)
    run(e, session, steps)
    return e


def _trunk_height_fraction(e):
    t = e.tree
    n = 1
    while t.child[n, 0] >= 0 and t.alive[t.child[n, 0]]:
        n = t.child[n, 0]
    return t.pos[n, 1] / t.pos[t.alive, 1].max()


def test_tw_v23a_fig_12_7_length_modes():
    frac = {mode: np.mean([_trunk_height_fraction(_grow(vertical_stroke(), seed=s, apical_dominance=0.6,
                                                        length_mode=mode)) for s in range(3)])
            for mode in ("constant", "vigor", "order")}
    assert frac["vigor"] > frac["constant"] and frac["order"] > frac["constant"]


def _crown_ratio(e):
    p = e.tree.pos[e.tree.alive]
    width = np.ptp(p[:, 0]) + np.ptp(p[:, 2])
    return width / (2 * np.ptp(p[:, 1]))


def test_tw_v23b_fig_12_3_columnar():
    broad = dict(view_angle=180.0, tropism_angle=90.0)
    columnar = dict(view_angle=40.0, tropism_angle=0.0, w_heading=0.2, w_tropism=0.2, w_env=0.6)
    s = sweep_session(8, 20)
    assert _crown_ratio(_grow(s, **columnar)) < _crown_ratio(_grow(s, **broad))


def test_tw_v23d_lower_apical_dominance_more_laterals():
    """λ 0.4 vs 0.6 on the same strokes: a larger share of order-≥1 internodes and a shorter trunk with 0.4."""
    def shares(lam):
        out = []
        for seed in range(3):
            t = _grow(sweep_session(8, 20), seed=seed, apical_dominance=lam).tree
            out.append((np.sum(t.alive & (t.order >= 1)) / t.alive[1:].sum(), np.sum(t.alive & (t.order == 0))))
        return np.mean(out, axis=0)
    low, high = shares(0.4), shares(0.6)
    assert low[0] > high[0] and low[1] < high[1]

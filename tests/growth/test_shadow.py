"""TW-V12 (shadow pyramids), TW-V13 (two-tier grid), TW-V16 (shedding)."""
import numpy as np

from plantvr.growth.engine import GrowthEngine
from plantvr.growth.shadow import ShadowGrid, coarse_key, shadow_lut, szudzik
from plantvr.params import defaults


def test_tw_v12_lut_equals_eq_9_10_and_footprints():
    offs, vals = shadow_lut(0.3, 0.6, 5)
    q = -offs[:, 1]
    assert np.allclose(vals, 0.3 * 0.6 ** np.sqrt(q ** 2 + offs[:, 0] ** 2 + offs[:, 2] ** 2))
    assert sorted(set(q)) == [1, 2, 3, 4]  # printed loop bound q_max − 1 (ERRATUM A.5)
    for lvl in range(1, 5):
        assert np.sum(q == lvl) == (1 + 2 * lvl) ** 2
    assert len(shadow_lut(0.2, 0.5, 12)[0]) == 2299  # ERRATUM A.6: not 78
    assert sorted(set(-shadow_lut(0.3, 0.6, 5, inclusive=True)[0][:, 1])) == [1, 2, 3, 4, 5]


def test_tw_v12_own_cell_untouched_and_add_remove_symmetric():
    g = ShadowGrid(1.0, 8)
    cells = g.cells_of(np.array([[0.2, 0.5, -0.3], [3.7, -2.0, 5.5]]))
    offs, vals = shadow_lut(0.2, 0.5, 6)
    g.add(cells, offs, vals)
    assert np.all(g.read(cells) == 0.0)
    assert g.read(cells + [0, -1, 0]).min() > 0
    g.add(cells, offs, vals, sign=-1.0)
    assert np.abs(g.blocks[: g.nblocks]).max() < 1e-15


def test_tw_v13_szudzik_injective_and_dense_reference():
    assert szudzik(1, 0) != szudzik(0, 1)  # ERRATUM A.7
    r = range(-12, 13)
    keys = {coarse_key(i, j, k) for i in r for j in r for k in r}
    assert len(keys) == 25 ** 3
    rng = np.random.default_rng(0)
    g = ShadowGrid(1.0, 4)
    dense = np.zeros((40, 40, 40))
    cells = rng.integers(-20, 20, (300, 3))
    offs, vals = shadow_lut(0.25, 0.7, 3)
    g.add(cells, offs, vals)
    for c in cells:
        for o, v in zip(offs, vals):
            x, y, z = c + o + 20
            if 0 <= x < 40 and 0 <= y < 40 and 0 <= z < 40:
                dense[x, y, z] += v
    probe = rng.integers(-18, 18, (2000, 3))
    assert np.allclose(g.read(probe), dense[tuple((probe + 20).T)])


def test_tw_v16_shaded_limb_is_shed_and_its_shadow_removed():
    p = {**defaults(), "shadow_intensity": 3.0, "shadow_falloff": 0.9, "apical_dominance": 0.5}
    e = GrowthEngine(p, rng=0)
    shed_total = 0
    for s in range(40):
        e.paint(np.array([0.0, 2 + 0.4 * s, 0.0]), 3.0, 150)
        shed_total += e.step().shed
    assert shed_total > 0
    t = e.tree
    # every removed node gave its slot back as a bud, and the grid equals a rebuild from live nodes
    assert not np.any(t.child[t.alive] >= 0) or np.all(t.alive[t.child[t.alive][t.child[t.alive] >= 0]])
    live = np.flatnonzero(t.alive)
    probe = e.grid.cells_of(t.pos[live])
    before = e.grid.read(probe)
    e.rebuild_light()
    assert np.allclose(before, e.grid.read(probe), atol=1e-9)


def test_steps_without_markers_cast_no_extra_shadow():
    """Regression: a step with no markers must not cast the previous step's new nodes' shadows again."""
    e = GrowthEngine(defaults(), rng=0)
    for s in range(12):
        e.paint(np.array([0.0, 2 + 0.4 * s, 0.0]), 3.0, 150)
        e.step()
    e.markers, e.marker_age = np.zeros((0, 3)), np.zeros(0, np.int64)
    for _ in range(5):
        e.step()
    t = e.tree
    probe = e.grid.cells_of(t.pos[t.alive]) + [0, -1, 0]
    before = e.grid.read(probe)
    e.rebuild_light()
    assert np.allclose(before, e.grid.read(probe), atol=1e-9)

"""Distribution kernels (V18) and Ripley's K (V27), spec 004 §3.4.2, §3.9."""
import numpy as np
import pytest

from plantvr.landscape.distribution import clustering_kernel, inhibitory_kernel, ripley_k


def test_ts_v18_kernels():
    r, a, s = 2.0, 6.0, 3.0
    d = np.array([1.0, 2.0, r + 1e-12, 4.0, 6.0, 9.0])
    np.testing.assert_allclose(clustering_kernel(d, r=r, a=a, s=s), [0, 0, s, (s + 1) / 2, 1, 1], atol=1e-9)
    np.testing.assert_allclose(inhibitory_kernel(d, r=r, a=a, s=s), [0, 0, 1 - 1 / s, 1 - 1 / (2 * s), 1, 1],
                               atol=1e-9)
    dd = np.linspace(r + 1e-9, a, 50)
    assert np.all(np.diff(inhibitory_kernel(dd, r=r, a=a, s=s)) >= 0)  # monotone recovery
    with pytest.raises(ValueError, match="s must be in"):
        inhibitory_kernel(d, r=r, a=a, s=0.5)  # ERRATUM E9
    with pytest.raises(ValueError, match="a must be in"):
        clustering_kernel(d, r=3.0, a=2.0, s=2.0)


def _thomas(rng, n_parents, per, sigma, size):
    parents = rng.uniform(0, size, (n_parents, 2))
    kids = np.repeat(parents, per, axis=0) + rng.normal(0, sigma, (n_parents * per, 2))
    return np.mod(kids, size)


def test_ts_v27_ripley_patterns():
    size, t = 100.0, 5.0
    rng = np.random.default_rng(0)
    csr = [ripley_k(rng.uniform(0, size, (400, 2)), t, box=(size, size))[0] - np.pi * t * t for _ in range(20)]
    assert abs(np.mean(csr)) < 0.05 * np.pi * t * t  # CSR: K(5) ≈ 25π
    thomas = ripley_k(_thomas(rng, 20, 20, 2.0, size), t, box=(size, size))[0] - np.pi * t * t
    assert thomas > 0.5 * np.pi * t * t  # clustered
    g = np.arange(0.0, size, 100.0 / 20) + 2.5
    lattice = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)  # spacing 5 > d for d < t
    assert ripley_k(lattice, t, box=(size, size))[0] - np.pi * t * t < -0.9 * np.pi * t * t


def test_ripley_brute_force_oracle():
    rng = np.random.default_rng(1)
    p = rng.uniform(0, 10, (60, 2))
    t = np.array([0.5, 1.0, 2.5])
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    brute = [(100.0 / 60) * ((d < x).sum() - 60) / 60 for x in t]
    np.testing.assert_allclose(ripley_k(p, t, area=100.0), brute)
    with pytest.raises(ValueError, match="area"):
        ripley_k(p, 1.0)


# -- deformation-kernel distribution (V19, V20) -----------------------------------------------------------------
from scipy import stats

from plantvr.landscape.distribution import Species, distribute, row_prefix, sample_field

FIG65 = np.array([[6, 0, 2, 3, 0], [1, 2, 3, 4, 0], [2, 3, 1, 6, 2], [5, 5, 7, 8, 4], [0, 1, 4, 1, 5],
                  [1, 1, 3, 2, 1]], float)


def test_ts_v19_fig65_prefix_and_sampler_chi2():
    np.testing.assert_array_equal(row_prefix(FIG65)[1:], [11, 21, 35, 64, 75, 83])
    xy = sample_field(FIG65, 100_000, rng=1)
    cells = np.floor(xy).astype(int)
    counts = np.zeros_like(FIG65)
    np.add.at(counts, (cells[:, 1], cells[:, 0]), 1)
    assert counts[FIG65 == 0].sum() == 0
    p = FIG65[FIG65 > 0] / FIG65.sum()
    chi2 = stats.chisquare(counts[FIG65 > 0], p * len(xy))
    assert chi2.pvalue > 1e-3
    mask = np.ones_like(FIG65, bool)
    mask[3] = False  # e.g. water across row 3
    xy = sample_field(FIG65, 20_000, mask=mask, rng=2)
    assert not np.any(np.floor(xy[:, 1]) == 3)
    with pytest.raises(ValueError, match="no positive cell"):
        sample_field(FIG65, 1, mask=np.zeros_like(FIG65, bool))


def test_ts_v20_species_choice_scale_and_kernels():
    sp = [Species(1.0, 0.4, (0.5, 1.5)), Species(0.25, 0.4, (2.0, 3.0))]
    d = distribute(400, sp, {}, size=(60.0, 60.0), shape=(96, 96), rng=3)
    frac = np.mean(d.species == 1)
    assert abs(frac - 0.2) < 0.06  # P_1 / (P_0 + P_1)
    s0 = d.scale[d.species == 0]
    assert s0.min() >= 0.5 and s0.max() <= 1.5 and stats.kstest((s0 - 0.5) / 1.0, "uniform").pvalue > 1e-3
    # clustering within a species vs strong inhibition: Ripley K at 3 m is larger for the clustered pattern
    one = [Species(1.0, 0.4, (1.0, 1.0))]
    clus = distribute(150, one, {(0, 0): ("cluster", 6.0, 4.0)}, rng=4)
    inh = distribute(150, one, {(0, 0): ("inhibit", 1.0, 2.5)}, rng=4)
    k_c = ripley_k(clus.xy, 3.0, box=(30.0, 30.0))[0]
    k_i = ripley_k(inh.xy, 3.0, box=(30.0, 30.0))[0]
    assert k_c > np.pi * 9 > k_i
    d_min = np.min([np.linalg.norm(inh.xy[i] - inh.xy[j]) for i in range(150) for j in range(i)])
    assert d_min > 0.2  # never inside another tree's occupied radius (S T_w / 2 = 0.2)
    with pytest.raises(ValueError, match="s must be in"):
        distribute(1, one, {(0, 0): ("inhibit", 0.5, 3.0)})
    with pytest.raises(ValueError, match=r"interactions\[\(0, 0\)\] kind"):
        distribute(1, one, {(0, 0): ("attract", 2.0, 3.0)})
    with pytest.raises(ValueError, match=r"interactions\[\(0, 0\)\] kind"):   # found by the landscape fuzz
        distribute(1, one, {(0, 0): (1.0, 2.0, 3.0)})


def test_ts_terrain_brushes_water_and_exclusion_mask_placement():
    from plantvr.landscape.terrain import brush_height, brush_mask, placement_mask

    size = (30.0, 30.0)
    hf = np.zeros((61, 61))
    up = brush_height(hf, size, (15.0, 15.0), 6.0, 2.0)
    assert up[30, 30] == pytest.approx(2.0) and up[0, 0] == 0.0 and (up >= 0).all()
    down = brush_height(up, size, (15.0, 15.0), 6.0, -2.0)
    np.testing.assert_allclose(down, hf, atol=1e-12)  # raise then lower restores
    excl = brush_mask(np.zeros_like(hf, bool), size, (5.0, 5.0), 4.0)
    assert excl[10, 10] and not excl[40, 40]
    water = brush_height(hf, size, (25.0, 25.0), 5.0, -3.0)
    ok = placement_mask(water, water_level=-0.5, excluded=excl, shape=(32, 32))
    assert ok.shape == (32, 32) and not ok[5, 5] and not ok[26, 26] and ok[16, 5]
    d = distribute(200, [Species(1.0, 0.2)], {}, size=size, shape=(32, 32), mask=ok, rng=0)
    cells = np.floor(d.xy / (30.0 / 32)).astype(int)
    assert ok[cells[:, 1], cells[:, 0]].all()  # no tree under water or in the exclusion area
    with pytest.raises(ValueError, match="radius"):
        brush_height(hf, size, (1.0, 1.0), 0.0, 1.0)

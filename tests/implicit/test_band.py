"""V16-V18, V33-V34 ordering (small): near-surface band by rejection, the cache, band-initialized Lane (spec 003 §3.6)."""
import numpy as np
import pytest

from plantvr.implicit.band import FieldCache, sample_band
from plantvr.implicit.blobtree import Blend, sphere
from plantvr.implicit.sampling import field_pdf, lane_in_node, lane_sample, poisson_kernel


def _blob(k=40, seed=0):
    rng = np.random.default_rng(seed)
    return Blend(*[sphere(c, 4.0) for c in rng.uniform(-6, 6, (k, 3))])


def test_v16_outside_near_rejection():
    s = sphere(radius=2.0)
    p = sample_band(s, 2000, band=(0.4, 0.5), method="rejection", rng=16)
    f = s.field(p)
    assert np.all((f > 0.4) & (f < 0.5))
    assert np.all((p >= s.bbox[0]) & (p <= s.bbox[1]))


def test_v17_cache_corners_interpolation_and_modes():
    blob = _blob()
    c = FieldCache(blob, edge=0.5, band=(0.40, 0.41))
    axes = [c.origin[i] + 0.5 * np.arange(c.shape[i] + 1) for i in range(3)]
    rng = np.random.default_rng(17)
    idx = rng.integers(0, np.array(c.shape) + 1, (500, 3))
    corners = np.column_stack([axes[i][idx[:, i]] for i in range(3)])
    exact = blob.field(corners)
    assert np.allclose(c.corners[idx[:, 0], idx[:, 1], idx[:, 2]], exact, atol=1e-12)
    inner = np.all(idx < np.array(c.shape), axis=1)
    assert np.allclose(c.interpolate(corners[inner]), exact[inner], atol=1e-12)
    pf = sample_band(blob, 1000, band=(0.40, 0.41), cache=c, cache_mode="filter", rng=1)
    f = blob.field(pf)
    assert np.all((f > 0.40) & (f < 0.41))
    pa = sample_band(blob, 1000, band=(0.40, 0.41), cache=c, cache_mode="approx", rng=1)
    frac = np.mean((blob.field(pa) > 0.40) & (blob.field(pa) < 0.41))
    print(f"approx-mode in-band fraction (edge 0.5, band 0.40-0.41): {frac:.3f}; cubes {c.n_cubes}")
    assert 0.1 < frac < 1.0


def test_v18_band_initialized_lane():
    s = sphere(radius=20.0)            # surface radius 10
    band = (0.40, 0.50)
    ex = lane_in_node(s, 500, kernel=poisson_kernel(1.0), shape=(48, 48, 48), mode="band_corners", band=band,
                      exact=True, rng=18)
    f = s.field(ex.points)
    assert len(ex.points) == 500 and np.all(f < 0.5) and np.all(f > 0.4)
    pdf, box = field_pdf(s, shape=(48, 48, 48), mode="band", band=band)
    pts = lane_sample(pdf, 500, bbox=box, kernel=poisson_kernel(1.0), rng=18).points
    h = (box[1] - box[0]) / 48
    diag = np.linalg.norm(h)
    r = np.linalg.norm(pts, axis=1)
    r_lo, r_hi = 10.0, 20 * 0.5635
    assert np.all((r > r_lo - diag) & (r < r_hi + diag))


def test_cache_classification_of_lane_grid():
    blob = _blob(20)
    c = FieldCache(blob, edge=0.5, band=(0.40, 0.41))
    pdf_cache, _ = field_pdf(blob, shape=(40, 40, 40), mode="band", band=(0.40, 0.41), cache=c)
    pdf_exact, _ = field_pdf(blob, shape=(40, 40, 40), mode="band", band=(0.40, 0.41))
    assert pdf_cache.sum() > 0 and pdf_exact.sum() > 0


def test_band_bad_input():
    s = sphere()
    with pytest.raises(ValueError, match="band must satisfy"):
        sample_band(s, 10, band=(0.5, 0.4))
    with pytest.raises(ValueError, match="method"):
        sample_band(s, 10, method="magic")
    with pytest.raises(ValueError, match="edge"):
        FieldCache(s, edge=0.0)
    with pytest.raises(ValueError, match="no cube meeting the band"):
        sample_band(s, 10, band=(2.0, 3.0))


def test_bfs_continuation_cache_matches_dense_with_fewer_evaluations():
    blob = _blob(30, seed=3)
    dense = FieldCache(blob, edge=0.5, band=(0.40, 0.41))
    bfs = FieldCache(blob, edge=0.5, band=(0.40, 0.41), method="bfs", seeds=64, rng=0)
    assert not np.any(bfs.table & ~dense.table)
    assert bfs.n_cubes >= 0.95 * dense.n_cubes and bfs.evaluations < dense.evaluations
    kept = np.argwhere(bfs.table)
    assert np.allclose(bfs.corners[tuple(kept.T)], dense.corners[tuple(kept.T)], atol=1e-12)
    p = sample_band(blob, 300, band=(0.40, 0.41), cache=bfs, rng=2)
    f = blob.field(p)
    assert np.all((f > 0.40) & (f < 0.41))

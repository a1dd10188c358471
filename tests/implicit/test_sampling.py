"""V12-V15, V31, C-8 and Lane twins: rejection, inverse CDF, Lane's method, field pdfs (spec 003 §3.2-3.5)."""
import numpy as np
import pytest
from scipy import stats
from scipy.spatial import cKDTree

from plantvr.implicit import _lane_kernels as lk
from plantvr.implicit.blobtree import sphere
from plantvr.implicit.sampling import (cluster_kernel, custom_kernel, field_pdf, icdf_step_1d, lane_in_node,
                                       lane_sample, poisson_kernel, sample_inside, sample_step_pdf, step_cdf)

BALL = sphere(radius=20.0)              # surface radius 10
BOX = [[-10, -10, -10], [10, 10, 10]]


def test_c8_uniform_rejection_inside_and_deterministic():
    crown = sphere(radius=2.0).scaled(1, 2, 1)
    p = sample_inside(crown, 5000, rng=3)
    assert p.shape == (5000, 3) and np.all(crown.field(p) > 0.5)
    assert np.array_equal(p, sample_inside(crown, 5000, rng=3))
    assert not np.array_equal(p, sample_inside(crown, 5000, rng=4))
    with pytest.raises(ValueError, match="envelope is empty"):
        sample_inside(crown, 10, rng=0, bbox=[[5, 5, 5], [6, 6, 6]], max_draws=10000)


def test_v12_inverse_cdf_1d_chi2_and_uniform_within_cells():
    c = np.array([1.0, 3.0, 0.0, 2.0, 4.0])
    cdf = step_cdf(c)
    assert cdf[0] == 0 and cdf[-1] == 1 and np.all(np.diff(cdf) >= 0)
    y = np.random.default_rng(12).random(1_000_000)
    x = icdf_step_1d(c, y, a=2.0, b=7.0)
    counts = np.bincount(np.floor(x - 2.0).astype(int), minlength=5)
    assert counts[2] == 0
    nz = c > 0
    assert stats.chisquare(counts[nz], c[nz] / c.sum() * len(x)).pvalue > 0.001
    frac = (x - 2.0) % 1.0
    assert stats.kstest(frac, "uniform").pvalue > 0.001


@pytest.mark.parametrize("shape", [(6,), (4, 5), (3, 4, 5)])
def test_v12_step_pdf_chi2_nd(shape):
    rng = np.random.default_rng(sum(shape))
    pdf = rng.random(shape)
    pdf.ravel()[::7] = 0.0
    x = sample_step_pdf(pdf, 1_000_000, rng=1)
    idx = np.floor(x * np.array(shape)).astype(int)
    flat = np.ravel_multi_index(tuple(idx.T), shape)
    counts = np.bincount(flat, minlength=pdf.size)
    nz = pdf.ravel() > 0
    assert counts[~nz].sum() == 0
    expected = pdf.ravel()[nz] / pdf.sum() * len(x)
    assert stats.chisquare(counts[nz], expected).pvalue > 0.001
    frac = (x * np.array(shape)) % 1.0
    for d in range(len(shape)):
        assert stats.kstest(frac[:200_000, d], "uniform").pvalue > 0.001


def test_v13_lane_poisson_spacing_and_saturation():
    h = 20 / 64
    r = lane_in_node(BALL, 1000, kernel=poisson_kernel(1.0), shape=(64, 64, 64), rng=0, bbox=BOX)
    d, _ = cKDTree(r.points).query(r.points, k=2)
    assert len(r.points) == 1000 and d[:, 1].min() >= 1.0 - np.sqrt(3) * h
    ex = lane_in_node(BALL, 1000, kernel=poisson_kernel(1.0), shape=(64, 64, 64), rng=0, bbox=BOX, exact=True)
    d, _ = cKDTree(ex.points).query(ex.points, k=2)
    assert d[:, 1].min() >= 1.0 and np.all(BALL.field(ex.points) > 0.5)
    counts = [len(lane_in_node(BALL, 100_000, kernel=poisson_kernel(1.0), shape=(64, 64, 64), rng=s,
                               bbox=BOX).points) for s in range(2)]
    assert all(abs(c - 2785) <= 0.1 * 2785 for c in counts)


def test_v14_cluster_kernel_clusters():
    def stats_for(kernel):
        nn, ce = [], []
        for s in range(3):
            p = lane_in_node(BALL, 1000, kernel=kernel, shape=(64, 64, 64), rng=s, bbox=BOX).points
            d, _ = cKDTree(p).query(p, k=2)
            vol = 4 / 3 * np.pi * 10**3
            expected = 0.554 * (vol / len(p)) ** (1 / 3)       # 3D Poisson-process mean NN distance
            nn.append(d[:, 1].mean())
            ce.append(d[:, 1].mean() / expected)
        return np.mean(nn), np.mean(ce)
    nn_p, ce_p = stats_for(poisson_kernel(1.0))
    nn_c, ce_c = stats_for(cluster_kernel(1.0, 2.0, 3.0))
    assert nn_c < nn_p and ce_c < ce_p
    assert nn_p == pytest.approx(1.192, abs=0.05) and nn_c == pytest.approx(1.042, abs=0.05)


def test_v15_inverse_field_density_ratio():
    s = sphere(radius=2.0)                # surface radius 1
    pdf, box = field_pdf(s, shape=(64, 64, 64), mode="inverse", gamma=1.0, bbox=[[-1, -1, -1], [1, 1, 1]])
    p = sample_step_pdf(pdf, 400_000, bbox=box, rng=15)
    r = np.linalg.norm(p, axis=1)
    shell = ((r > 0.93) & (r < 0.99)).sum() / (4 / 3 * np.pi * (0.99**3 - 0.93**3))
    centre = (r < 0.2).sum() / (4 / 3 * np.pi * 0.2**3)
    assert shell / centre == pytest.approx(2.0, rel=0.15)


def test_lane_twins_equal_on_seeded_input():
    g = (np.random.default_rng(2).random((12, 10, 8)) > 0.3).astype(float)
    box = np.array([[0, 0, 0], [3.0, 2.5, 2.0]])
    lo, h = box[0], (box[1] - box[0]) / np.array(g.shape)
    U = np.random.default_rng(3).random((400, 6))
    kr, kv = np.array([0.6]), np.array([0.0])
    res = []
    for run in (lk.lane_run_numba, lk.lane_run_numpy):
        G = g.copy()
        Y, Z = lk.recompute_sums(G)
        out = np.empty((400, 3))
        n, used, sat = run(G, Y, Z, lo, h, kr, kv, False, U, 400, out, 0)
        res.append((out[:n].copy(), used, sat, G))
    assert np.array_equal(res[0][0], res[1][0]) and res[0][1:3] == res[1][1:3]
    assert np.array_equal(res[0][3], res[1][3])
    assert res[0][2]   # saturated


def test_lane_backends_and_custom_kernel():
    pdf, box = field_pdf(BALL, shape=(16, 16, 16), bbox=BOX)
    k = custom_kernel([1.0, 3.0], [0.0, 1.0], interp="linear")
    a = lane_sample(pdf, 150, bbox=box, kernel=k, rng=5)
    b = lane_sample(pdf, 150, bbox=box, kernel=k, rng=5, backend="numpy")
    assert np.allclose(a.points, b.points, atol=1e-12)
    assert k(np.array([0.5, 2.0, 5.0])).tolist() == [0.0, 0.5, 1.0]


def test_v31_lane_determinism():
    a = lane_in_node(BALL, 300, kernel=cluster_kernel(1.0), shape=(32, 32, 32), rng=31, bbox=BOX).points
    b = lane_in_node(BALL, 300, kernel=cluster_kernel(1.0), shape=(32, 32, 32), rng=31, bbox=BOX).points
    c = lane_in_node(BALL, 300, kernel=cluster_kernel(1.0), shape=(32, 32, 32), rng=32, bbox=BOX).points
    assert a.tobytes() == b.tobytes() and not np.array_equal(a, c)


def test_sampling_bad_input():
    with pytest.raises(ValueError, match="r_min"):
        poisson_kernel(0.0)
    with pytest.raises(ValueError, match="radii must be positive and strictly increasing"):
        custom_kernel([2.0, 1.0], [0.0, 1.0])
    with pytest.raises(ValueError, match="pdf must be"):
        sample_step_pdf(np.zeros(4), 10)
    with pytest.raises(ValueError, match="mode"):
        field_pdf(BALL, mode="sparkly")
    with pytest.raises(ValueError, match="band must be"):
        field_pdf(BALL, mode="band")
    with pytest.raises(ValueError, match="envelope is empty"):
        lane_in_node(BALL, 10, kernel=poisson_kernel(1.0), bbox=[[30, 30, 30], [40, 40, 40]])
    with pytest.raises(ValueError, match="kernel must be a LaneKernel"):
        lane_sample(np.ones((2, 2, 2)), 3, bbox=BOX, kernel=1.0)

"""Spec 003 §8.3 B-1: the pass/fail orderings V33 (deep BlobTree: the cache pays) and V34 (single sphere: it does not).

Times are best-of-N process CPU times (the implicit kernels are single-threaded, so other jobs on shared CI cores
barely move them), measured interleaved; only orderings are asserted (the spec's rule). The figures themselves,
beside the thesis's, are printed by benchmarks/implicit.py.
"""
import time

import numpy as np
import pytest

from plantvr.implicit import Blend, FieldCache, field_pdf, lane_sample, poisson_kernel, sample_band, sphere

BAND = (0.40, 0.41)


def _best(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t)
    return best, out


def _best_interleaved(fns, repeat):
    """Best CPU time of each callable, run in turn ``repeat`` times (so a slow patch hits all alike)."""
    best, outs = [np.inf] * len(fns), [None] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t, outs[i] = _best(fn, 1)
            best[i] = min(best[i], t)
    return best, outs


@pytest.fixture(scope="module")
def deep_blob():
    """Appendix B.5 stand-in for Fig. 6.4: 120 Wyvill point primitives, R = 4, centres in [-6, 6]³, summed."""
    rng = np.random.default_rng(0)
    blob = Blend(*[sphere(c, 4.0) for c in rng.uniform(-6, 6, (120, 3))])
    blob.field(np.zeros((4, 3)))                                                   # JIT warm-up
    lane_sample(np.ones((4, 4, 4)), 2, bbox=[[0, 0, 0], [1, 1, 1]], kernel=poisson_kernel(0.3), rng=0)
    sample_band(blob, 5, band=BAND, method="cache", rng=0)
    return blob


def test_v33_cache_beats_rejection_on_the_deep_blobtree(deep_blob):
    """Table 6.1 analogue: 1000 points in the band (0.40, 0.41); cube cache (edge 0.5, build included) < none."""
    (t_rej, t_cache), (p_rej, p_cache) = _best_interleaved(
        [lambda: sample_band(deep_blob, 1000, band=BAND, method="rejection", rng=2),
         lambda: sample_band(deep_blob, 1000, band=BAND, method="cache", rng=2)], 2)
    for p in (p_rej, p_cache):                                                     # both give what was asked
        f = deep_blob.field(p)
        assert len(p) == 1000 and np.all((f > BAND[0]) & (f < BAND[1]))
    print(f"V33 Table 6.1 analogue: rejection {t_rej:.3f} s, cache incl. build {t_cache:.3f} s "
          f"(x{t_rej / t_cache:.1f}; thesis 94.7 s vs 4.1 s)")
    assert t_cache < t_rej, (t_cache, t_rej)


def test_v33_lane_ordering_cache_grid_exact_grid_rejection(deep_blob):
    """Table 6.2 analogue, Poisson points on a 64³ grid: Lane with the cache-initialized grid < Lane with the
    exact-initialized grid < Lane with rejection of every draw.

    500 points, not the benchmark's 1000: with band-mode grids (a cell counts when its centre is in the band) the
    thin band (0.40, 0.41) holds only ~600 cells at 64³, so grid-initialized Lane saturates below 1000 points.
    """
    grid, kern, box, N = (64, 64, 64), poisson_kernel(0.25), deep_blob.bbox, 500

    def lane_rejection():
        def accept(q):
            f = deep_blob.field(q)
            return (f > BAND[0]) & (f < BAND[1])
        return lane_sample(np.ones(grid), N, bbox=box, kernel=kern, rng=4, accept=accept)

    def lane_exact_grid():
        pdf, b = field_pdf(deep_blob, shape=grid, bbox=box, mode="band", band=BAND)
        return lane_sample(pdf, N, bbox=b, kernel=kern, rng=4)

    def lane_cache_grid():
        cache = FieldCache(deep_blob, edge=0.5, band=BAND)
        pdf, b = field_pdf(deep_blob, shape=grid, bbox=box, mode="band", band=BAND, cache=cache)
        return lane_sample(pdf, N, bbox=b, kernel=kern, rng=4)

    (t_cache, t_exact), (r_cache, r_exact) = _best_interleaved([lane_cache_grid, lane_exact_grid], 5)
    t_rej, r_rej = _best(lane_rejection, 1)
    print(f"V33 Table 6.2 analogue (64³): cache grid {t_cache:.3f} s < exact grid {t_exact:.3f} s < "
          f"rejection {t_rej:.3f} s ({r_rej.draws} draws); thesis 8.67 < 45.01 < 145.9 s")
    assert len(r_cache.points) == len(r_exact.points) == len(r_rej.points) == N
    # why the cache grid wins: its exact evaluations (the cube corners) are fewer than the grid's 64³ cells
    assert FieldCache(deep_blob, edge=0.5, band=BAND).evaluations < np.prod(grid)
    assert t_cache < t_exact < t_rej, (t_cache, t_exact, t_rej)


def test_v34_single_sphere_cache_gives_no_speed_up():
    """§6.2.2: for one sphere of radius 10 the field is so cheap that the cache cannot pay for its build (the
    thesis saw it "about twenty times slower"; numpy narrows the gap but the direction holds)."""
    ball = sphere(radius=10.0)
    sample_band(ball, 5, band=BAND, method="cache", rng=0)                         # warm-up
    (t_rej, t_cache), (p, _) = _best_interleaved(
        [lambda: sample_band(ball, 1000, band=BAND, method="rejection", rng=3),
         lambda: sample_band(ball, 1000, band=BAND, method="cache", rng=3)], 7)
    f = ball.field(p)
    assert np.all((f > BAND[0]) & (f < BAND[1]))
    print(f"V34 sphere r = 10: rejection {t_rej:.4f} s, cache incl. build {t_cache:.4f} s "
          f"(cache x{t_cache / t_rej:.1f} slower; thesis about x20)")
    assert t_cache > t_rej, (t_cache, t_rej)

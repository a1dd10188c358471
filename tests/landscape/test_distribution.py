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

"""numba kernels run as plain Python (DISABLE_JIT) and still equal their numpy twins (STYLE §8)."""
import importlib

import numba
import numpy as np
import pytest

from plantvr.implicit import _kernels, _lane_kernels


@pytest.fixture
def nojit(monkeypatch):
    monkeypatch.setattr(numba.core.config, "DISABLE_JIT", True)
    mods = [importlib.reload(_kernels), importlib.reload(_lane_kernels)]
    yield mods
    monkeypatch.undo()
    importlib.reload(_kernels)
    importlib.reload(_lane_kernels)


def test_kernels_without_jit_match_twins(nojit):
    kern, lane = nojit
    rng = np.random.default_rng(0)
    a = rng.uniform(-1, 1, (5, 3))
    b = a + rng.normal(size=(5, 3))
    radius = np.full(5, 1.5)
    minv = np.ascontiguousarray(np.tile(np.eye(4)[:3], (5, 1, 1)))
    lo, hi = np.minimum(a, b) - 1.5, np.maximum(a, b) + 1.5
    p = rng.uniform(-3, 3, (200, 3))
    assert np.allclose(kern.segment_blend_numba(p, a, b, radius, minv, lo, hi),
                       kern.segment_blend_numpy(p, a, b, radius, minv, lo, hi), atol=1e-12)
    g = np.ones((6, 5, 4))
    box_lo, h = np.zeros(3), np.array([0.5, 0.5, 0.5])
    U = rng.random((60, 6))
    outs = []
    for run, linear, kr, kv in ((lane.lane_run_numba, False, np.array([0.6]), np.array([0.0])),
                                (lane.lane_run_numpy, False, np.array([0.6]), np.array([0.0])),
                                (lane.lane_run_numba, True, np.array([0.3, 0.9]), np.array([0.0, 1.0])),
                                (lane.lane_run_numpy, True, np.array([0.3, 0.9]), np.array([0.0, 1.0]))):
        G = g.copy()
        Y, Z = lane.recompute_sums(G)
        out = np.empty((60, 3))
        n, used, _ = run(G, Y, Z, box_lo, h, kr, kv, linear, U, 60, out, 0)
        outs.append(out[:n].copy())
    assert np.array_equal(outs[0], outs[1])
    assert np.allclose(outs[2], outs[3])

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from plantvr.vine.index import GridIndex, KDTreeIndex, _paint_numpy, ball_query_brute


def _cloud(n=20000, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    return (p * [40, 40, 12] + rng.normal(0, 0.3, p.shape)).astype(np.float32)


PTS = _cloud()
GRID = GridIndex(PTS)
KD = KDTreeIndex(PTS)


@pytest.mark.parametrize("radius", [0.0, 0.5, 2.0, 8.0, 30.0, 200.0])
def test_tw_v2_grid_and_kdtree_equal_brute_force(radius):
    rng = np.random.default_rng(int(radius * 10))
    for c in list(PTS[rng.integers(0, len(PTS), 5)].astype(np.float64)) + [np.array([500.0, 0, 0])]:
        ref = ball_query_brute(PTS, c, radius)
        assert np.array_equal(np.sort(GRID.query(c, radius)), ref)
        assert np.array_equal(np.sort(KD.query(c, radius)), ref)


@settings(max_examples=40, deadline=None)
@given(cx=st.floats(-60, 60), cy=st.floats(-60, 60), cz=st.floats(-20, 20), r=st.floats(0, 40),
       cell=st.sampled_from([None, 0.3, 3.0, 50.0]))
def test_grid_query_equals_brute_force_hypothesis(cx, cy, cz, r, cell):
    idx = GRID if cell is None else GridIndex(PTS[:3000], cell_size=cell)
    pts = PTS if cell is None else PTS[:3000]
    c = np.array([cx, cy, cz])
    assert np.array_equal(np.sort(idx.query(c, r)), ball_query_brute(pts, c, r))


def test_grid_paint_kernel_equals_numpy_twin():
    rng = np.random.default_rng(3)
    lab_a = rng.integers(0, 5, len(PTS)).astype(np.uint8)
    lab_b = lab_a.copy()
    paintable = np.ones(256, bool)
    paintable[2] = False
    for _ in range(30):
        c = PTS[rng.integers(len(PTS))].astype(np.float64)
        r, label = float(rng.uniform(0, 10)), int(rng.integers(0, 5))
        ia, oa = GRID.paint(c, r, lab_a, paintable, label)
        ib, ob = _paint_numpy(PTS, c, r, lab_b, paintable, label)
        order = np.argsort(ia)
        assert np.array_equal(ia[order], ib) and np.array_equal(oa[order], ob)
        assert np.array_equal(lab_a, lab_b)
    for c in ([500.0, 0, 0], [0, -500.0, 0], [0, 0, 500.0]):          # the ball's box misses the grid
        ia, oa = GRID.paint(np.array(c), 5.0, lab_a, paintable, 1)
        assert len(ia) == len(oa) == 0 and np.array_equal(lab_a, lab_b)


def test_grid_memory_is_small():
    assert GRID.nbytes <= 6 * len(PTS)             # int32 order + about 1 B/vertex of cell starts
    assert GRID.order.dtype == np.int32


def test_grid_rejects_bad_input():
    with pytest.raises(ValueError, match="points"):
        GridIndex(np.zeros((5, 2)))
    with pytest.raises(ValueError, match="radius"):
        GRID.query([0, 0, 0], -1)
    with pytest.raises(ValueError, match="center"):
        GRID.query([0, 0], 1)
    with pytest.raises(ValueError, match="too many cells"):
        GridIndex(PTS, cell_size=1e-6)

"""The one uniform grid (plantvr.grid): kernels against their numpy twins and brute-force oracles."""
import numpy as np
import pytest

from plantvr import grid as G
from plantvr._sorting import counting_sort
from plantvr.growth.spatial import within_any_numpy


def _cloud(n, seed=0, lattice=False):
    rng = np.random.default_rng(seed)
    if lattice:  # points on cell boundaries: the rounding cases
        return rng.integers(-6, 7, (n, 3)).astype(np.float64) * 0.5
    return rng.normal(size=(n, 3)) * [4.0, 3.0, 2.0]


def test_bounds_kernel_equals_numpy():
    for pts in (_cloud(500), _cloud(500).astype(np.float32), _cloud(200, lattice=True)):
        lo, hi = G.bounds(pts)
        assert np.array_equal(lo, pts.min(0).astype(np.float64))
        assert np.array_equal(hi, pts.max(0).astype(np.float64))


@pytest.mark.parametrize("lattice", [False, True])
@pytest.mark.parametrize("h", [0.07, 0.5, 1.0, 3.0])
def test_dense_cell_ids_and_sort_equal_numpy_twin(lattice, h):
    pts = _cloud(3000, 1, lattice)
    lo, hi = G.bounds(pts)
    dims = (np.floor((hi - lo) / h) + 1).astype(np.int64)
    ids = G.dense_cell_ids(pts, lo, h, dims)
    assert np.array_equal(ids, G.dense_cell_ids_numpy(pts, lo, h, dims))
    far = np.array([[1e30, -1e30, 0.0], [-5e3, 7e3, 1.0]])  # outside: border cells, no int overflow
    assert np.array_equal(G.dense_cell_ids(far, lo, h, dims), G.dense_cell_ids_numpy(far, lo, h, dims))
    for dtype in (np.int32, np.int64):
        order, start = G.sort_by_cell(pts, lo, h, dims, dtype)
        assert order.dtype == dtype and start.dtype == dtype
        assert np.array_equal(order, np.argsort(ids, kind="stable"))
        assert np.array_equal(np.diff(start), np.bincount(ids, minlength=int(np.prod(dims))))


def _brute_ball(pts, c, r):
    d = pts.astype(np.float64) - c
    return np.flatnonzero(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2] <= r * r)


@pytest.mark.parametrize("lattice", [False, True])
def test_dense_ball_query_equals_brute_force(lattice):
    pts = _cloud(4000, 2, lattice).astype(np.float32)
    lo, hi = G.bounds(pts)
    h = 0.5
    dims = (np.floor((hi - lo) / h) + 1).astype(np.int64)
    order, start = G.sort_by_cell(pts, lo, h, dims, np.int32)
    rng = np.random.default_rng(3)
    for k in range(60):
        c = pts[rng.integers(len(pts))].astype(np.float64) if k % 3 else rng.uniform(-12, 12, 3)
        r = float([0.0, 0.5, 1.0, 2.7, 40.0][k % 5])
        n = G.ball_candidates(start, lo, h, dims, c, r)
        out = np.empty(n, np.int64)
        got = G.ball_query(pts, order, start, lo, h, dims, c, r, out)
        assert got <= n
        assert np.array_equal(np.sort(out[:got]), _brute_ball(pts, c, r))
    assert len(G.row_spans(start, lo, h, dims, np.array([1e3, 0.0, 0.0]), 1.0)) == 0  # box misses the grid


def test_ball_cells_equal_enumeration():
    pts = _cloud(800, 4)
    lo, hi = G.bounds(pts)
    h, reach = 0.4, 3
    dims = (np.floor((hi - lo) / h) + 1).astype(np.int64)
    cells, gaps = G.cell_buffers(reach)
    rng = np.random.default_rng(5)
    for _ in range(30):
        p = rng.uniform(lo - 1, hi + 1)
        r2 = float(rng.uniform(0, (reach * h) ** 2))
        n = G.ball_cells(p[0], p[1], p[2], r2, lo, h, dims, reach, cells, gaps)
        c = np.floor((p - lo) / h).astype(np.int64)
        want = []
        for i in range(max(c[0] - reach, 0), min(c[0] + reach, dims[0] - 1) + 1):
            for j in range(max(c[1] - reach, 0), min(c[1] + reach, dims[1] - 1) + 1):
                for k in range(max(c[2] - reach, 0), min(c[2] + reach, dims[2] - 1) + 1):
                    box_lo = lo + np.array([i, j, k]) * h
                    g = float(np.sum(np.maximum(np.maximum(box_lo - p, p - box_lo - h), 0.0) ** 2))
                    if g <= r2:
                        want.append(((i * dims[1] + j) * dims[2] + k, g))
        assert [int(x) for x in cells[:n]] == [w for w, _ in want]
        np.testing.assert_allclose(gaps[:n], [g for _, g in want], rtol=1e-12, atol=1e-15)
    assert G.ball_cells(np.nan, 0.0, 0.0, 1.0, lo, h, dims, reach, cells, gaps) == 0  # NaN: no cell


@pytest.mark.parametrize("lattice", [False, True])
@pytest.mark.parametrize("h", [1e-3, 0.25, 0.5, 2.0, 50.0])
def test_hashed_points_equal_twin_and_brute_force(lattice, h):
    pts = _cloud(2000, 6, lattice)
    order, start, mask = G.sort_by_bucket(pts, h)
    o2, s2, m2 = G.sort_by_bucket_numpy(pts, h)
    assert mask == m2 and np.array_equal(order, o2) and np.array_equal(start, s2)
    q = _cloud(50, 7, lattice)
    for r in (0.0, 0.5, 1.0, 3.0):
        out = np.zeros(len(pts), np.bool_)
        G.mark_within(pts, order, start, mask, h, q, r, out)
        assert np.array_equal(out, within_any_numpy(pts, q, r))


def test_cell_coord_clips_and_maps_nan_low():
    assert G.cell_coord(1e300, 1e10, -G.HASH_LIMIT, G.HASH_LIMIT) == int(G.HASH_LIMIT)
    assert G.cell_coord(-1e300, 1e10, -G.HASH_LIMIT, G.HASH_LIMIT) == -int(G.HASH_LIMIT)
    assert G.cell_coord(np.nan, 1.0, -5.0, 5.0) == -5
    assert G.cell_coord(-0.5, 1.0, -5.0, 5.0) == -1


def test_spatial_hash_cells_equal_box_enumeration():
    rng = np.random.default_rng(8)
    lo = rng.uniform(-3, 3, (200, 3))
    hi = lo + rng.uniform(0, 0.8, (200, 3))
    g = G.SpatialHash(200)
    g.clear(0.5, 200)
    g.insert(lo, hi, np.arange(150, dtype=np.int64))
    g.insert(lo, hi, np.arange(150, 200, dtype=np.int64))  # inserts between queries append
    want: dict[int, list[int]] = {}
    for e in range(200):
        a, b = np.floor(lo[e] / 0.5).astype(np.int64), np.floor(hi[e] / 0.5).astype(np.int64)
        for iz in range(a[2], b[2] + 1):
            for iy in range(a[1], b[1] + 1):
                for ix in range(a[0], b[0] + 1):
                    key = (ix + G.KEY_LIMIT) | ((iy + G.KEY_LIMIT) << 21) | ((iz + G.KEY_LIMIT) << 42)
                    want.setdefault(key, []).append(e)
    assert g.cells_numpy() == want
    g.clear(0.5, 200)  # O(1) clear through the stamp
    assert g.cells_numpy() == {}
    with pytest.raises(ValueError, match="grid cells"):
        g.insert(np.array([[0.0, 0, 0]]), np.array([[np.inf, 0, 0]]), np.array([0]))


def test_counting_sort_is_the_stable_argsort():
    keys = np.random.default_rng(9).integers(0, 50, 1000)
    order, start = counting_sort(keys, 50, np.int64)
    assert np.array_equal(order, np.argsort(keys, kind="stable"))
    assert np.array_equal(np.diff(start), np.bincount(keys, minlength=50))


def test_hash_coords_is_the_unmasked_hash_cell():
    c = np.random.default_rng(5).integers(-2 ** 30, 2 ** 30, (500, 3))
    got = G.hash_coords(c)
    mask = (1 << 12) - 1
    assert np.array_equal(got & mask, [G.hash_cell(int(x), int(y), int(z), mask) for x, y, z in c])
    assert np.array_equal(got, (c[:, 0] * 73856093) ^ (c[:, 1] * 19349663) ^ (c[:, 2] * 83492791))


def test_dense_box_ranges_and_entries_equal_numpy():
    rng = np.random.default_rng(6)
    lo = rng.uniform(-1, 1, (400, 3))
    hi = lo + rng.uniform(0, 0.6, (400, 3))
    origin, h = lo.min(0), 0.17
    dims = (np.floor((hi.max(0) - origin) / h) + 1).astype(np.int64)
    dims[2] = max(dims[2] - 2, 1)                                  # some boxes stick out: clamped into the grid
    c0, c1, total = G.dense_box_ranges(lo, hi, origin, 1.0 / h, dims)
    want0 = np.clip(np.floor((lo - origin) * (1.0 / h)), 0, dims - 1).astype(np.int64)
    want1 = np.clip(np.floor((hi - origin) * (1.0 / h)), 0, dims - 1).astype(np.int64)
    assert np.array_equal(c0, want0) and np.array_equal(c1, want1)
    assert total == int(np.prod(want1 - want0 + 1, axis=1).sum())
    keys, ids = G.dense_box_entries(c0, c1, dims, total)
    wk, wi = [], []
    for f in range(len(lo)):
        ijk = np.stack(np.meshgrid(*[np.arange(want0[f, a], want1[f, a] + 1) for a in range(3)], indexing="ij"), -1)
        ijk = ijk.reshape(-1, 3)
        wk.append((ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2])
        wi.append(np.full(len(ijk), f))
    assert np.array_equal(keys, np.concatenate(wk)) and np.array_equal(ids, np.concatenate(wi))


def test_cell_lists_near_holds_every_item_within_h():
    pts = _cloud(800, 7)
    cl = G.CellLists(0.9)
    for i, p in enumerate(pts):
        cl.add(i, p)
    for q in _cloud(50, 8):
        near = cl.near(q)
        assert len(near) == len(set(near))
        within = np.flatnonzero(np.linalg.norm(pts - q, axis=1) <= 0.9)
        assert set(within) <= set(near)
        k = cl.cell(q)
        assert near == [i for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                        for i in cl.cells.get((k[0] + dx, k[1] + dy, k[2] + dz), [])]

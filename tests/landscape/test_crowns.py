"""Competition for crown space on layered voxels (spec 004 §3.5, §3.7; V21, V22)."""
import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import cKDTree

from plantvr.landscape.crowns import (
    VoxelSketchEngine,
    claim_segments,
    crown_voxels,
    in_tree_region,
    propagate_layer,
    region_geometry,
    tree_region,
)
from plantvr.params import defaults

SIZE = (30.0, 30.0)


def _centres(ny, nx, size=SIZE):
    X, Z = np.meshgrid((np.arange(nx) + 0.5) * size[0] / nx, (np.arange(ny) + 0.5) * size[1] / ny)
    return np.column_stack([X.ravel(), Z.ravel()])


def test_ts_v21_every_cell_claimed_regions_connected_twin_equal():
    rng = np.random.default_rng(0)
    b, a = rng.uniform(0, 30, (25, 2)), rng.uniform(1.0, 5.0, 25)
    o = propagate_layer((80, 80), b, a, size=SIZE, trunk_radius=0.3)
    assert o.dtype == np.int32 and np.all(o >= 0)
    four = ndimage.generate_binary_structure(2, 1)
    for i in range(25):
        m = o == i
        assert m.any() and ndimage.label(m, four)[1] == 1, i  # one 4-connected region per tree
    np.testing.assert_array_equal(o, propagate_layer((80, 80), b, a, size=SIZE, trunk_radius=0.3, engine="python"))


def test_ts_v21_equal_trees_on_a_lattice_give_the_voronoi_diagram():
    g = (np.arange(5) + 0.5) * 6.0
    b = np.array([(x + 0.7 * (j % 2), z) for j, z in enumerate(g) for x in g])  # staggered rows: no ties
    o = propagate_layer((90, 90), b, np.ones(len(b)), size=SIZE)
    vor = cKDTree(b).query(_centres(90, 90))[1].reshape(90, 90)  # Voronoi diagram as the oracle
    iou = [np.sum((o == i) & (vor == i)) / np.sum((o == i) | (vor == i)) for i in range(len(b))]
    assert min(iou) > 0.9


def test_ts_v21_claimed_area_grows_with_crown_area():
    rng = np.random.default_rng(3)
    b, a = rng.uniform(0, 30, (30, 2)), rng.uniform(1.0, 6.0, 30)
    cnt = np.bincount(propagate_layer((128, 128), b, a, size=SIZE).ravel(), minlength=30)
    assert np.corrcoef(cnt, a)[0, 1] > 0.4  # spec prototype r = 0.761 (same trend)
    # two trees: the faster (larger crown) one claims more than half, and the boundary is curved around the small one
    o = propagate_layer((64, 64), np.array([[10.0, 15.0], [20.0, 15.0]]), np.array([4.0, 1.0]), size=SIZE)
    assert np.sum(o == 0) > 0.7 * o.size
    cols = [np.flatnonzero(o[r] == 1) for r in (0, 32)]
    assert len(cols[0]) < len(cols[1])  # narrower away from the small tree's row: a closed curve, not a line


def test_ts_v22_layers_heights_and_hero_claims():
    rng = np.random.default_rng(1)
    b = rng.uniform(0, 30, (12, 2))
    h = np.r_[20.0, rng.uniform(4.0, 12.0, 11)]
    v = crown_voxels(b, np.ones(12), h, size=SIZE, shape=(10, 48, 48))
    L = v.owner.shape[0]
    for k in range(L):
        z = k * v.layer_height
        present = np.unique(v.owner[k])
        assert np.all(h[present[present >= 0]] > z)  # no tree above its shape's height
        assert np.all(v.owner[k] >= 0)  # tree 0 reaches every layer, so every layer is fully claimed
    top = np.flatnonzero(h[1:].max() <= np.arange(L) * v.layer_height)
    assert len(top) and np.all(v.owner[top] == 0)  # the tall tree owns the upper layers alone (overhang)
    assert v.counts()[0] > v.counts()[1:].max()
    np.testing.assert_array_equal(v.owner, crown_voxels(b, np.ones(12), h, size=SIZE, shape=(10, 48, 48),
                                                        engine="python").owner)  # twin
    s, e = np.array([[b[3, 0], 0.0, b[3, 1]]]), np.array([[b[4, 0], 9.0, b[4, 1]]])
    hv = claim_segments(v, 3, s, e)
    t = np.linspace(0, 1, 200)[:, None]
    p = s + t * (e - s)
    cx, cz = v.cell
    idx = (np.minimum((p[:, 1] / v.layer_height).astype(int), L - 1), (p[:, 2] / cz).astype(int),
           (p[:, 0] / cx).astype(int))
    assert np.all(hv.owner[idx] == 3) and not np.all(v.owner[idx] == 3)
    assert np.sum(hv.owner != v.owner) > 0 and np.all(hv.owner[hv.owner != v.owner] == 3)


def test_tree_region_and_geometry_match_owner():
    rng = np.random.default_rng(2)
    b = rng.uniform(0, 30, (8, 2))
    h = rng.uniform(5.0, 10.0, 8)
    v = crown_voxels(b, rng.uniform(1, 3, 8), h, size=SIZE, shape=(6, 40, 40))
    pts = rng.uniform([0, 0, 0], [30, 10, 30], (2000, 3))
    L = v.owner.shape[0]
    cx, cz = v.cell
    lay = (pts[:, 1] / v.layer_height).astype(int)
    ok = lay < L
    owner = np.full(len(pts), -1)
    owner[ok] = v.owner[lay[ok], (pts[ok, 2] / cz).astype(int), (pts[ok, 0] / cx).astype(int)]
    base = np.array([b[2, 0], 0.0, b[2, 1]])
    np.testing.assert_array_equal(in_tree_region(tree_region(v, 2), pts - base, base), owner == 2)
    C, B = region_geometry(v)
    o = v.owner
    cells = np.argwhere(o == 5)
    xz = np.column_stack([(cells[:, 2] + 0.5) * cx, (cells[:, 1] + 0.5) * cz])
    np.testing.assert_allclose(C[5], xz.mean(0))
    assert B[5] == pytest.approx(np.linalg.norm(xz - C[5], axis=1).max())


def test_voxel_engine_drops_points_outside_its_voxels():
    v = crown_voxels(np.array([[10.0, 15.0], [20.0, 15.0]]), np.ones(2), np.array([8.0, 8.0]), size=SIZE,
                     shape=(8, 32, 32))
    base = np.array([10.0, 1.0, 15.0])
    reg = {**tree_region(v, 0), "base": base}
    p = {**defaults(), "activation_threshold": 0.0, "length_mode": "constant"}
    e = VoxelSketchEngine(p, rng=1, voxel_region=reg, mode="autonomous", n_max=2,
                          region={"sites": [], "weights": [], "weight": 1.0, "h_max": 8.0})
    pts = np.array([[-3.0, 2.0, 0.0], [7.0, 2.0, 0.0], [-3.0, 9.0, 0.0]])  # own side, neighbour side, too high
    np.testing.assert_array_equal(e.in_region(pts), [True, False, False])
    for _ in range(6):
        e.step()
    live = e.tree.pos[e.tree.alive]
    assert len(live) > 3 and np.all(live[:, 0] < 5.0 + 2 * 2.0)  # boundary at x = 15 (local 5) + one shoot
    import pickle
    f = pickle.loads(pickle.dumps(e))
    assert f.voxel_region["mask"].tobytes() == reg["mask"].tobytes()
    with pytest.raises(ValueError, match="voxel_region"):
        VoxelSketchEngine(p, voxel_region={"mask": 1})


def test_crown_validation():
    with pytest.raises(ValueError, match="areas"):
        propagate_layer((8, 8), np.zeros((2, 2)), np.array([1.0, 0.0]), size=SIZE)
    with pytest.raises(ValueError, match="engine"):
        propagate_layer((8, 8), np.zeros((2, 2)), np.ones(2), size=SIZE, engine="gpu")
    with pytest.raises(ValueError, match="h_max"):
        crown_voxels(np.zeros((2, 2)), np.ones(2), np.array([1.0, -1.0]), size=SIZE)
    with pytest.raises(ValueError, match="shape"):
        crown_voxels(np.zeros((2, 2)), np.ones(2), np.ones(2), size=SIZE, shape=(0, 8, 8))

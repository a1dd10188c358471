"""Landscape: terrain, Poisson-disc placement, forests grown on dask (spec 004 §3; issue 11 determinism checks)."""
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantvr.io.landscape import export_forest
from plantvr.landscape import grow_forest, heightfield, poisson_disc, sample_height
from plantvr.landscape.forest import _compete, engine_from_state, engine_state, grow_tree_task
from plantvr.params import defaults
from plantvr.types import TreeArrays

SMALL = {"size": (30.0, 30.0), "min_dist": 7.0, "rounds": 2, "steps_per_round": 3, "n_darts": 120, "seed": 7}


def _same(f, g):
    assert len(f.trees) == len(g.trees)
    np.testing.assert_array_equal(f.bases, g.bases)
    for a, b in zip(f.trees, g.trees):
        for k in a:
            assert a[k].tobytes() == b[k].tobytes(), k


def test_heightfield_range_and_seed():
    h = heightfield((40, 50), amplitude=4.0, rng=1)
    assert h.shape == (40, 50) and h.min() == 0.0 and h.max() == pytest.approx(4.0)
    np.testing.assert_array_equal(h, heightfield((40, 50), amplitude=4.0, rng=1))
    assert np.all(heightfield((8, 8), amplitude=0.0, rng=1) == 0)
    with pytest.raises(ValueError, match="amplitude"):
        heightfield((8, 8), amplitude=-1)


def test_sample_height_bilinear():
    h = np.arange(12.0).reshape(3, 4)  # z rows, x columns
    size = (3.0, 2.0)
    np.testing.assert_allclose(sample_height(h, size, np.array([[0.0, 0.0], [3.0, 2.0], [1.0, 1.0]])), [0, 11, 5])
    np.testing.assert_allclose(sample_height(h, size, np.array([[0.5, 0.5]])), [0.5 * (0 + 1 + 4 + 5) / 2])


def test_poisson_disc_min_distance_and_bounds():
    pts = poisson_disc((50.0, 30.0), 3.0, rng=2)
    assert len(pts) > 60
    assert np.all((pts >= 0) & (pts < [50.0, 30.0]))
    d, _ = cKDTree(pts).query(pts, k=2)
    assert d[:, 1].min() >= 3.0  # cKDTree as the oracle
    np.testing.assert_array_equal(pts, poisson_disc((50.0, 30.0), 3.0, rng=2))
    assert len(poisson_disc((50.0, 30.0), 3.0, max_points=10, rng=2)) == 10
    with pytest.raises(ValueError, match="min_dist"):
        poisson_disc((5.0, 5.0), 0.0)


def test_state_roundtrip_is_exact():
    from plantvr.growth.engine import GrowthEngine
    e = GrowthEngine(defaults(), rng=3)
    e.paint(np.array([0.0, 4.0, 0.0]), 3.0, 150)
    for _ in range(3):
        e.step()
    s = engine_state(e)
    a = grow_tree_task(defaults(), s, 2)
    b = grow_tree_task(defaults(), s, 2)
    for k in a["tree"]:
        assert a["tree"][k].tobytes() == b["tree"][k].tobytes()
    e2 = engine_from_state(defaults(), s)
    np.testing.assert_array_equal(e2.tree.pos, e.tree.pos)
    assert e2.rng.random() == e.rng.random()


def test_competition_removes_neighbour_claimed_markers():
    f = grow_forest(client="sync", **{**SMALL, "min_dist": 4.0, "rounds": 1})
    r = defaults()["occupation_radius"]
    # after the last round's competition no marker sits in another tree's occupation zone: recheck directly
    states = [{"tree": {k: v.copy() for k, v in t.items()}, "markers": np.zeros((0, 3)),
               "marker_age": np.zeros(0, np.int64)} for t in f.trees]
    for s, b in zip(states, f.bases):
        s["tree"]["pos"] -= b
    rng = np.random.default_rng(0)
    pts = rng.uniform([0, 0, 0], [30, 10, 30], (400, 3))
    states[0]["markers"], states[0]["marker_age"] = pts - f.bases[0], np.zeros(400, np.int64)
    _compete(states, f.bases, r)
    kept = states[0]["markers"] + f.bases[0]
    others = np.concatenate([t["pos"][t["alive"]] for t in f.trees[1:]])
    assert cKDTree(others).query(kept)[0].min() > r
    assert len(kept) < 400 or cKDTree(others).query(pts)[0].min() > r


def test_forest_sync_equals_two_thread_workers():
    pytest.importorskip("dask.distributed")
    f = grow_forest(4, client="sync", geometry=True, **SMALL)
    g = grow_forest(4, n_workers=2, processes=False, geometry=True, **SMALL)
    for (va, fa), (vb, fb) in zip(f.meshes, g.meshes):  # byte-identical meshes with 1 and 2 workers
        assert len(fa) > 0 and va.tobytes() == vb.tobytes() and fa.tobytes() == fb.tobytes()
    lo, hi = f.trees[0]["pos"][f.trees[0]["alive"]].min(0), f.trees[0]["pos"][f.trees[0]["alive"]].max(0)
    v0 = f.meshes[0][0]
    assert np.all(v0.min(0) > lo - 1.0) and np.all(v0.max(0) < hi + 1.0)  # mesh in world coordinates
    assert len(f.trees) == 4 and f.n_internodes > 4 * 10
    _same(f, g)
    _same(f, grow_forest(4, n_workers=2, processes=False, tasks_per_round=3, **SMALL))  # batching is invisible
    h = grow_forest(4, client="sync", **{**SMALL, "seed": 8})
    assert not np.array_equal(h.bases, f.bases)


def test_forest_remote_scheduler_address_and_stats():
    """The same call runs against a scheduler address (a client connected and closed for the call): the same
    bytes as a synchronous run; task timing is reported and batching gives a few tasks per worker."""
    distributed = pytest.importorskip("dask.distributed")
    f = grow_forest(5, client="sync", geometry=True, **SMALL)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        g = grow_forest(5, client=cluster.scheduler_address, geometry=True, progress=True, **SMALL)
        h = grow_forest(5, client=cluster.scheduler_address, compete=False, **SMALL)
    _same(f, g)
    assert all(a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes() and a[1].dtype == np.int64
               for a, b in zip(f.meshes, g.meshes))
    assert all(a["markers"].tobytes() == b["markers"].tobytes() for a, b in zip(f.seeds, g.seeds))
    s = g.stats
    assert s["n_workers"] == 2 and s["n_tasks"] == 5 * (SMALL["rounds"] + 1)  # 5 trees: one batch each
    assert 0.0 <= s["overhead"] <= 1.0 and s["body_s"] > 0 and f.stats["n_workers"] == 1
    _same(grow_forest(5, client="sync", compete=False, **SMALL), h)
    assert h.stats["n_tasks"] == 5  # independent trees: one wave, seeded, grown and meshed in the task


@pytest.mark.slow  # ~20 s: two worker processes start, import and JIT-load the kernels
def test_forest_dask_two_processes_same_bytes():
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        g = grow_forest(3, client=client, **SMALL)
        gv = grow_forest(4, client=client, geometry=True, **VOX)  # voxel crown spaces travel with the records
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        g1 = grow_forest(3, client=client, **SMALL)
    _same(g1, g)  # 1 vs 2 worker processes
    f = grow_forest(3, client="sync", **SMALL)
    _same(f, g)
    fv = grow_forest(4, client="sync", geometry=True, **VOX)
    _same(fv, gv)
    assert all(a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()
               for a, b in zip(fv.meshes, gv.meshes))


def test_forest_validation():
    with pytest.raises(ValueError, match="n_trees"):
        grow_forest(0)
    with pytest.raises(ValueError, match="steps_per_round"):
        grow_forest(2, steps_per_round=0, client="sync")


def test_forest_option_checks_are_shared_with_the_document():
    """grow_forest and ForestDocument check client and sketch options through the same helpers."""
    from plantvr.documents.forest import ForestDocument
    from plantvr.landscape.forest import check_client, check_sketch

    sk = {"n_max": 3}
    assert check_sketch(None) is None and check_sketch(sk) == sk and check_sketch(sk) is not sk
    assert check_client(None) is None and check_client("sync") == "sync"
    for bad, match in (([1], "sketch must be a dict"), ({"rng": 1}, r"sketch must not set \['rng'\]"),
                       ({"n_max": -1}, "sketch: ")):
        with pytest.raises(ValueError, match=match):
            check_sketch(bad)
        with pytest.raises(ValueError, match=match):
            grow_forest(2, client="sync", sketch=bad)
        with pytest.raises(ValueError, match=match):
            ForestDocument().grow(sketch=bad)
    for entry in (check_client, lambda c: grow_forest(2, client=c), lambda c: ForestDocument(client=c)):
        with pytest.raises(ValueError, match="client must be None, 'sync' or a dask Client"):
            entry("threads")
        with pytest.raises(ValueError, match="client must be"):
            entry("tcp://")
    with pytest.raises(ValueError, match="progress must be True or False"):
        grow_forest(2, client="sync", progress="yes")


def test_ts_v25_v26_sketch_forest_in_crown_space():
    """TreeSketch trees grow autonomously inside their weighted Voronoi cells below h_max; identical bytes with
    a synchronous run and 2 thread workers (each tree depends on its own state only)."""
    pytest.importorskip("dask.distributed")
    kw = {"size": (30.0, 30.0), "min_dist": 8.0, "rounds": 2, "steps_per_round": 4, "crown_height": 5.0,
          "crown_radius": 3.0, "seed": 2, "sketch": {"n_max": 2, "bud_lifetime": 6}}
    f = grow_forest(4, client="sync", **kw)
    g = grow_forest(4, n_workers=2, processes=False, **kw)
    _same(f, g)
    h_max = 5.0 + 3.0
    for tr, b in zip(f.trees, f.bases):
        live = tr["pos"][tr["alive"]]
        assert len(live) > 5
        assert (live[:, 1] - b[1]).max() <= h_max + 2 * 2.0 + 1e-9  # at most one shoot (n_max * max length)
    with pytest.raises(ValueError, match="sketch"):
        grow_forest(2, client="sync", sketch="yes")


def test_ts_forest_neighbour_asymmetry_lean():
    """Eqs. 6.3-6.5 in the forest: with ``lean`` crowns shift along their neighbourhood-asymmetry vectors."""
    from plantvr.landscape.asymmetry import cell_geometry, neighbour_asymmetry

    kw = {"size": (24.0, 24.0), "min_dist": 4.0, "rounds": 2, "steps_per_round": 4, "crown_height": 5.0,
          "crown_radius": 3.0, "seed": 3, "client": "sync", "sketch": {"n_max": 2, "bud_lifetime": 6},
          "params": {"activation_threshold": 0.0, "length_mode": "constant", "w_tropism": 0.4, "w_heading": 0.3,
                     "w_env": 0.3}}
    plain, lean = grow_forest(12, **kw), grow_forest(12, lean=True, **kw)
    xz = plain.bases[:, [0, 2]]
    C, B = cell_geometry(xz, kw["size"])
    V = neighbour_asymmetry(xz, np.ones(len(xz)), 6.0, centroids=C, bounding=B)
    moving = np.linalg.norm(V, axis=1) > 0.1
    assert moving.sum() >= 3

    def shift(f):
        c = np.array([t["pos"][t["alive"]][:, [0, 2]].mean(0) for t in f.trees]) - xz
        return np.sum(c[moving] * V[moving] / np.linalg.norm(V[moving], axis=1)[:, None], axis=1).mean()

    assert shift(lean) > shift(plain) + 0.2


VOX = {"size": (30.0, 30.0), "min_dist": 6.0, "rounds": 2, "steps_per_round": 4, "crown_height": 5.0,
       "crown_radius": 3.0, "seed": 2, "sketch": {"n_max": 2, "bud_lifetime": 6}, "regions": "voxels",
       "voxel_shape": (10, 64, 64), "scale_range": (0.7, 1.4),
       "params": {"activation_threshold": 0.0, "length_mode": "constant"}}


def test_ts_v25_v26_voxel_forest_grows_inside_its_voxels():
    """Crown-space competition on layered voxels as the forest's competition mode: nodes stay in their tree's
    voxels up to one shoot, below h_max + one shoot; byte-identical meshes with a synchronous run and 2 workers."""
    pytest.importorskip("dask.distributed")
    from plantvr.landscape.crowns import in_tree_region, tree_region

    f = grow_forest(6, client="sync", geometry=True, **VOX)
    g = grow_forest(6, n_workers=2, processes=False, geometry=True, **VOX)
    _same(f, g)
    for (va, fa), (vb, fb) in zip(f.meshes, g.meshes):
        assert len(fa) > 0 and va.tobytes() == vb.tobytes() and fa.tobytes() == fb.tobytes()
    v = f.voxels
    assert v is not None and v.owner.shape == (10, 64, 64) and np.all(v.owner[0] >= 0)
    reach = 2 * 2.0  # n_max internodes of at most 2 length units
    for i, (tr, b) in enumerate(zip(f.trees, f.bases)):
        live = tr["pos"][tr["alive"]] - b
        assert len(live) > 5
        assert live[:, 1].max() <= v.h_max[i] + reach + 1e-9
        inside = in_tree_region(tree_region(v, i), live, b)
        assert inside.mean() > 0.8
        cells = np.argwhere(v.owner == i)  # outside nodes are within one shoot of an own voxel centre
        cx, cz = v.cell
        centres = np.column_stack([(cells[:, 2] + 0.5) * cx, (cells[:, 0] + 0.5) * v.layer_height,
                                   (cells[:, 1] + 0.5) * cz])
        out = live[~inside] + [b[0], 0.0, b[2]]
        if len(out):
            d = cKDTree(centres).query(out)[0]
            assert d.max() <= reach + 0.5 * np.linalg.norm([cx, v.layer_height, cz]) + 1e-9
    # painted crowns in the same regions: markers kept only inside each tree's voxels
    p = grow_forest(4, client="sync", **{**VOX, "sketch": None, "n_darts": 150, "rounds": 1})
    assert p.n_internodes > 4


def test_ts_v26_regrow_one_tree_leaves_the_others_unchanged():
    f = grow_forest(5, client="sync", geometry=True, **VOX)
    same = f.regrow(2)  # a replay from the seed state: the same bytes
    _same(f, same)
    h = f.regrow(2, params={"branch_angle": 70.0}, sketch={"n_max": 3})
    for k, (a, b) in enumerate(zip(f.trees, h.trees)):
        changed = any(a[key].tobytes() != b[key].tobytes() for key in a)
        assert changed == (k == 2)
        assert (f.meshes[k][0].tobytes() == h.meshes[k][0].tobytes()) == (k != 2)
    assert h.voxels is f.voxels and f.trees[2] is not h.trees[2]
    with pytest.raises(ValueError, match="n_max"):
        f.regrow(1, sketch={"n_max": 0})
    with pytest.raises(ValueError, match="tree"):
        f.regrow(9)
    c = grow_forest(3, client="sync", **{**SMALL, "rounds": 1})
    with pytest.raises(ValueError, match="independent"):
        c.regrow(0)


def test_forest_regions_validation():
    with pytest.raises(ValueError, match="regions"):
        grow_forest(2, client="sync", regions="cubes")
    with pytest.raises(ValueError, match="voxel_shape"):
        grow_forest(2, client="sync", regions="voxels", voxel_shape=(0, 8, 8))
    with pytest.raises(ValueError, match="scale_range"):
        grow_forest(2, client="sync", scale_range=(2.0, 1.0))


def test_ts_v27_crown_centroids_more_uniform_than_clustered_bases():
    """Fig. 6.24 on generated landscapes: clustered bases (deformation kernels), crowns grown in their voxels,
    then with the neighbourhood-asymmetry tropism; K(5) - 25 pi of the crown centroids is closer to uniform than
    the bases', and lower again with the tropism, in >= 4 of 5 seeds."""
    from plantvr.landscape import Species, distribute, ripley_k

    def excess(xz):
        return float(np.ravel(ripley_k(xz, 5.0, box=(30.0, 30.0)))[0] - 25 * np.pi)

    wins_bases = wins_na = 0
    for seed in range(5):
        d = distribute(30, [Species(1.0, 1.0, (0.7, 1.4))], {(0, 0): ("cluster", 4.0, 6.0)}, rng=seed)
        kw = {"size": (30.0, 30.0), "rounds": 2, "steps_per_round": 4, "crown_height": 3.0, "crown_radius": 2.5,
              "seed": seed, "client": "sync", "positions": d.xy, "scales": d.scale, "regions": "voxels",
              "voxel_shape": (10, 96, 96), "sketch": {"n_max": 2, "bud_lifetime": 6},
              "params": {"activation_threshold": 0.0, "length_mode": "constant", "w_tropism": 0.3, "w_heading": 0.3,
                         "w_env": 0.4, "tropism_angle": 20.0}}
        k = [excess(np.array([t["pos"][t["alive"]][:, [0, 2]].mean(0) for t in grow_forest(30, lean=lean, **kw).trees]))
             for lean in (False, True)]
        wins_bases += k[1] < excess(d.xy)
        wins_na += k[1] < k[0]
    assert wins_bases >= 4 and wins_na >= 4


def test_ts_v22_hero_tree_claims_its_voxels_in_the_forest(tmp_path):
    """A hero tree (placed as designed) claims every voxel its internodes pass through; the grown trees' regions
    exclude them, it is exported with the others and cannot be regrown."""
    import trimesh

    one = grow_forest(1, client="sync", **{**VOX, "scale_range": (1.3, 1.3), "seed": 9})
    hero = {**one.trees[0], "pos": one.trees[0]["pos"] - one.bases[0]}
    f = grow_forest(5, client="sync", geometry=True, heroes=[{"tree": hero, "position": (15.0, 15.0)}], **VOX)
    n = len(f.trees) - 1
    assert len(f.bases) == n + 1 and len(f.meshes) == n + 1
    hb = f.bases[n]
    np.testing.assert_allclose(f.trees[n]["pos"], hero["pos"] + hb)
    v = f.voxels
    alive = np.flatnonzero(hero["alive"] & (hero["parent"] >= 0))
    t = np.linspace(0.0, 1.0, 9)[:, None, None]
    p = (hero["pos"][hero["parent"][alive]] + t * (hero["pos"][alive] - hero["pos"][hero["parent"][alive]])).reshape(-1, 3)
    cx, cz = v.cell
    lay = (p[:, 1] / v.layer_height).astype(int)
    ok = lay < v.owner.shape[0]
    own = v.owner[lay[ok], ((p[ok, 2] + hb[2]) / cz).astype(int), ((p[ok, 0] + hb[0]) / cx).astype(int)]
    assert len(own) > 10 and np.all(own == n)
    with pytest.raises(ValueError, match="hero"):
        f.regrow(n)
    s = trimesh.load(export_forest(tmp_path / "h.glb", f), force="scene")
    assert len(s.graph.nodes_geometry) == n + 2
    with pytest.raises(ValueError, match="heroes"):
        grow_forest(2, client="sync", heroes=[{"tree": hero}])
    # a hero given as the shared tree type: every node live, main children as the first child slot
    ta = TreeArrays.from_tree(SimpleNamespace(**hero))
    g = grow_forest(5, client="sync", geometry=True, heroes=[{"tree": ta, "position": (15.0, 15.0)}], **VOX)
    np.testing.assert_array_equal(g.voxels.owner, f.voxels.owner)
    np.testing.assert_allclose(g.trees[n]["pos"], ta.pos + hb)
    assert len(g.meshes[n][1]) > 0
    with pytest.raises(ValueError, match=r"heroes\[0\] tree: parent"):
        grow_forest(2, client="sync", heroes=[{"tree": {**hero, "parent": hero["parent"][::-1].copy()},
                                               "position": (1.0, 1.0)}])

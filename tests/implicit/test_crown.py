"""V25-V27 and the crown -> points -> colonization glue; pipe-model radii (spec 003 §1.7, §4.2; C-17 to C-19)."""
import numpy as np
import pytest

from plantvr.implicit.blobtree import sphere
from plantvr.implicit.crown import default_roots, grow_in_crown, pipe_radii
from plantvr.implicit.sampling import lane_in_node, poisson_kernel, sample_inside

pytest.importorskip("plantvr.growth.colonize")


def test_v26_pipe_model_identity():
    rng = np.random.default_rng(26)
    n = 500
    parent = np.r_[-1, [rng.integers(0, i) for i in range(1, n)]]
    for exponent in (2.0, 2.5, 3.0):
        r = pipe_radii(parent, r0=0.01, exponent=exponent)
        children = [[] for _ in range(n)]
        for i, p in enumerate(parent):
            if p >= 0:
                children[p].append(i)
        for v in range(n):
            if children[v]:
                assert abs(r[v] ** exponent - sum(r[c] ** exponent for c in children[v])) < 1e-12
            else:
                assert r[v] == 0.01


def test_pipe_radii_bad_input():
    with pytest.raises(ValueError, match="exponent"):
        pipe_radii([-1, 0], exponent=4)
    with pytest.raises(ValueError, match="cycle"):
        pipe_radii([1, 0])
    with pytest.raises(ValueError, match="parent must hold"):
        pipe_radii([-1, 5])


def test_crown_points_colonize_pipeline():
    crown = sphere((0, 12.0, 0), 20.0).scaled(1.0, 1.3, 1.0)
    pts = lane_in_node(crown, 2000, kernel=poisson_kernel(0.6), shape=(48, 48, 48), rng=0).points
    roots = default_roots(crown)
    assert roots[0, 1] < pts[:, 1].min()
    res = grow_in_crown(pts, roots, step_size=0.5, kill_radius=1.0)
    assert len(res.nodes) > 500 and len(res.markers_left) < 0.05 * len(pts)
    assert res.parent[0] == -1 and np.all(res.parent[1:] < np.arange(1, len(res.parent)))
    seg = np.linalg.norm(res.nodes[1:] - res.nodes[res.parent[1:]], axis=1)
    assert np.allclose(seg, 0.5)
    r = pipe_radii(res.parent, r0=0.02, exponent=2.5)
    assert r[0] == pytest.approx(r.max(), rel=1e-12) and r.min() == 0.02
    again = grow_in_crown(pts, roots, step_size=0.5, kill_radius=1.0)
    assert again.nodes.tobytes() == res.nodes.tobytes()          # V31 for trees


def test_empty_envelope_gives_clear_error():
    with pytest.raises(ValueError, match="markers is empty"):
        grow_in_crown(np.empty((0, 3)), step_size=1.0, kill_radius=2.0)
    with pytest.raises(ValueError, match="step_size"):
        grow_in_crown(np.ones((3, 3)), step_size=0.0, kill_radius=2.0)


def _shell_points(n, rng):
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return d * rng.uniform(5.0, 5.6, (n, 1))


def test_v25_growth_around_sphere_small_influence_radius():
    rng = np.random.default_rng(25)
    pts = _shell_points(3000, rng)
    root = np.array([[0, 0, -5.6]])
    frac = {}
    for di in (2.0, np.inf):
        res = grow_in_crown(pts, root, step_size=0.3, kill_radius=0.6, influence_radius=di, max_steps=400)
        frac[di] = np.mean(np.linalg.norm(res.nodes, axis=1) < 5.0)
    assert frac[2.0] < 0.01 and frac[np.inf] > 0.10


def test_v25_growth_around_torus():
    rng = np.random.default_rng(250)
    R, r = 6.0, 2.0

    def dist(p):
        return np.hypot(np.hypot(p[:, 0], p[:, 1]) - R, p[:, 2]) - r

    cand = rng.uniform([-8.6, -8.6, -2.6], [8.6, 8.6, 2.6], (200_000, 3))
    dd = dist(cand)
    pts = cand[(dd > 0) & (dd < 0.6)][:4000]
    root = np.array([[6.0, 0.0, -2.3]])
    out = {}
    for di in (2.0, np.inf):
        res = grow_in_crown(pts, root, step_size=0.3, kill_radius=0.6, influence_radius=di, max_steps=400)
        d = dist(res.nodes)
        out[di] = (np.mean(d < 0), np.mean(d > 1.0))
    assert out[2.0][0] < 0.01 and out[2.0][1] == 0.0
    assert out[np.inf][0] > 0.10


def test_v27_two_roots_two_crowns():
    left = sample_inside(sphere((-10, 15, 0), 12.0), 1500, rng=1)
    right = sample_inside(sphere((10, 15, 0), 12.0), 1500, rng=2)
    roots = np.array([[-10, 0, 0], [10, 0, 0.0]])
    res = grow_in_crown(np.vstack([left, right]), roots, step_size=0.5, kill_radius=1.0)
    # which root each node descends from
    owner = np.empty(len(res.nodes), dtype=int)
    for i, p in enumerate(res.parent):
        owner[i] = i if p < 0 else owner[p]
    x = res.nodes[:, 0]
    assert np.mean(np.sign(x[owner == 0]) < 0) > 0.95 and np.mean(np.sign(x[owner == 1]) > 0) > 0.95


def test_grown_tree_meshes_with_project_geometry():
    geometry = pytest.importorskip("plantvr.geometry")
    pts = sample_inside(sphere((0, 12.0, 0), 20.0), 800, rng=0)
    res = grow_in_crown(pts, step_size=0.5, kill_radius=1.0)
    r = pipe_radii(res.parent, r0=0.02)
    mesh = geometry.build_branch_mesh(res.nodes, res.parent, r)
    assert len(mesh.faces) > 0 and np.isfinite(mesh.vertices).all()
    assert mesh.vertices[:, 1].min() >= res.nodes[:, 1].min() - r.max() - 1e-9

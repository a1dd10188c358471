"""Depth cueing (spec §2.2, V8)."""
import numpy as np
import pytest

from plantvr.vine.depthcue import (
    _closest_on_triangles,
    coarse_hull,
    depth_cue_colors,
    depth_factor,
    hull_distances,
    inside_hull,
)


def _shell(n=60000, axes=(100, 100, 30), seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True) * axes


@pytest.fixture(scope="module")
def hull():
    return coarse_hull(_shell())


def test_tw_v8_coarse_hull_has_274_vertices(hull):
    assert len(hull.vertices) == 274
    # outward orientation: all hull vertices are behind every face plane
    V, T = hull.vertices, hull.faces
    n = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert (np.einsum("ij,kj->ik", n, V) - np.einsum("ij,ij->i", n, V[T[:, 0]])[:, None]).max() < 1e-6


def _halfspace_inside(hull, E):
    V, T = hull.vertices, hull.faces
    n = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
    return bool((np.einsum("ij,ij->i", n, E - V[T[:, 0]]) <= 0).all())


def test_tw_v8_ray_parity_agrees_with_half_space(hull):
    rng = np.random.default_rng(1)
    for E in rng.uniform([-130, -130, -45], [130, 130, 45], (60, 3)):
        assert inside_hull(hull, E, rng=2) == _halfspace_inside(hull, E)


def test_tw_v8_closest_point_matches_dense_sampling(hull):
    rng = np.random.default_rng(3)
    V, T = hull.vertices, hull.faces
    E = np.array([150.0, 20.0, 60.0])
    d_c, d_f = hull_distances(hull, E)
    assert d_f == pytest.approx(np.linalg.norm(V - E, axis=1).max())
    uv = rng.random((400, 2))
    uv[uv.sum(1) > 1] = 1 - uv[uv.sum(1) > 1]
    A, B, C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    samples = A[:, None] + uv[None, :, :1] * (B - A)[:, None] + uv[None, :, 1:] * (C - A)[:, None]
    dense = np.linalg.norm(samples - E, axis=2).min()
    assert d_c <= dense + 1e-9 and d_c > dense - 1.0
    X = _closest_on_triangles(E, A, B, C)
    assert np.all(np.linalg.norm(X - E, axis=1) <= np.linalg.norm(samples - E, axis=2).min(axis=1) + 1e-9)
    assert hull_distances(hull, [0.0, 0.0, 0.0])[0] == 0.0


@pytest.mark.parametrize("mode", ["p_exp", "fog", "literal"])
def test_tw_v8_factor_range_and_monotone(mode):
    d = np.linspace(-10, 300, 500)
    f = depth_factor(d, 20.0, 250.0, p=0.85, s=3.0, mode=mode)
    assert f.min() >= 0 and f.max() <= 0.85 + 1e-12
    assert np.all(np.diff(f) >= -1e-12)
    if mode == "p_exp":
        assert f.min() > 0 and f.max() == pytest.approx(0.85)


def test_tw_v8_temporal_continuity_vs_visible_minmax():
    """Along a camera orbit, (d_c, d_f) from the hull change less than frustum min/max depth."""
    pts = _shell(20000, axes=(100, 100, 30), seed=4)
    h = coarse_hull(pts)
    hull_track, frustum_track = [], []
    for k, t in enumerate(np.linspace(-0.6, 0.6, 60)):         # walk slowly while panning the head
        E = np.array([0.0, -220.0 + 0.5 * k, 20.0])
        fwd = np.array([np.sin(t), np.cos(t), 0.0])
        rel = pts - E
        depth = rel @ fwd
        lateral = np.linalg.norm(rel - depth[:, None] * fwd, axis=1)
        vis = (depth > 0) & (lateral < 0.3 * depth)           # narrow frustum: parts enter and leave
        frustum_track.append((depth[vis].min(), depth[vis].max()))
        hull_track.append(hull_distances(h, E))
    jump = lambda tr: np.abs(np.diff(np.asarray(tr), axis=0)).max()
    assert jump(hull_track) < 0.5 * jump(frustum_track)


def test_tw_v8_gradient_utilisation_hull_beats_bounding_sphere():
    disk = _shell(20000, axes=(100, 100, 8), seed=5)
    h = coarse_hull(disk)
    E = np.array([0.0, 0.0, 150.0])                            # looking down the thin axis
    d = np.linalg.norm(disk - E, axis=1)
    d_c, d_f = hull_distances(h, E)
    r = np.linalg.norm(disk, axis=1).max()
    s_c, s_f = np.linalg.norm(E) - r, np.linalg.norm(E) + r
    span = lambda a, b: np.ptp(depth_factor(d, a, b, mode="fog"))
    assert span(d_c, d_f) > span(s_c, s_f)


def test_depth_cue_colors_darken_far_vertices(hull):
    pts = _shell(2000, seed=6)
    cols = np.full((len(pts), 4), 200, np.uint8)
    E = np.array([0.0, -200.0, 0.0])
    out = depth_cue_colors(cols, pts, E, hull)
    near, far = np.argmin(pts[:, 1]), np.argmax(pts[:, 1])
    assert out[near, 0] > out[far, 0] and np.all(out[:, 3] == 200)
    with pytest.raises(ValueError, match="colors"):
        depth_cue_colors(cols.astype(float), pts, E, hull)
    with pytest.raises(ValueError, match="p must be"):
        depth_factor(np.ones(3), 0, 1, p=1.5)


def test_hull_distance_kernel_equals_numpy_twin(hull):
    from plantvr.vine.depthcue import _hull_distances_numpy
    rng = np.random.default_rng(8)
    for E in rng.uniform(-200, 200, (40, 3)):
        a = hull_distances(hull, E)
        b = _hull_distances_numpy(hull, E)
        assert a == pytest.approx(b, abs=1e-9)


def test_ray_parity_kernel_equals_numpy_twin(hull):
    from plantvr.vine.depthcue import _inside_fast
    rng = np.random.default_rng(9)
    for E in rng.uniform([-130, -130, -45], [130, 130, 45], (60, 3)):
        assert _inside_fast(hull, E, np.random.default_rng(0)) == inside_hull(hull, E, rng=0)

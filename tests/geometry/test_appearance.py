"""TreeSketch appearance: Eq. C.2 side counts on thickest-path tubes, fruit by p = r L^2, leaf hue by vigor (spec 004
§4.1, §4.2, §4.4; V28, V30)."""
import colorsys
import itertools

import numpy as np
import pytest
import trimesh

from plantvr.geometry import build_branch_mesh
from plantvr.geometry.appearance import (
    HASH_PRIMES,
    contour_sides,
    fruit_probability,
    hash_random,
    hsv_to_rgb,
    place_fruit,
    position_hash,
    rgb_to_hsv,
    thickest_main_child,
    thickest_path_mesh,
    vigor_leaf_colors,
)
from plantvr.geometry.synthetic import random_tree


# ---- V28: side counts and thickest-path tubes ---------------------------------------------------------------------
def test_ts_v28_side_count_eq_c2_erratum_e4():
    d_e = 0.02
    assert contour_sides(d_e, d_e=d_e).tolist() == [3]                       # 3 sides at d_e, for every n
    assert contour_sides([d_e] * 3, d_e=d_e, n=2.5).tolist() == [3, 3, 3]
    d = np.linspace(d_e, 40 * d_e, 200)
    for n in (1.0, 1.5, 3.0):
        c = contour_sides(d, d_e=d_e, n=n, c_max=64)
        assert np.all(np.diff(c) >= 0)                                     # non-decreasing in d
    k = np.arange(1, 11)
    assert contour_sides(k * d_e, d_e=d_e, n=1.0, c_max=64).tolist() == (3 * k).tolist()  # n = 1: linear
    c2 = contour_sides(k * d_e, d_e=d_e, n=2.0, c_max=64)
    np.testing.assert_array_equal(c2, np.ceil(3 * np.sqrt(k) - 1e-9))      # n = 2: sublinear
    assert np.all(c2[1:] < 3 * k[1:])
    assert contour_sides(1e3, d_e=d_e, c_max=12).tolist() == [12]
    assert contour_sides(d_e / 2, d_e=d_e).tolist() == [3]                 # thinner than d_e: still 3


@pytest.mark.parametrize("kw, match", [({"d_e": 0.0}, "d_e"), ({"d_e": 1.0, "n": 0.5}, "n must"),
                                       ({"d_e": 1.0, "c_max": 2}, "c_max")])
def test_contour_sides_validation(kw, match):
    with pytest.raises(ValueError, match=match):
        contour_sides(1.0, **kw)
    with pytest.raises(ValueError, match="diameter"):
        contour_sides([1.0, -1.0], d_e=1.0)


def test_thickest_main_child_follows_the_widest_child():
    #      0 - 1 - 2 (thin, slot-0 child)   1 - 3 (thick lateral)   3 - 4, 3 - 5 equal radii: lowest index
    parent = np.array([-1, 0, 1, 1, 3, 3])
    radius = np.array([0.0, 0.5, 0.1, 0.3, 0.2, 0.2])
    main = thickest_main_child(parent, radius)
    assert main.tolist() == [1, 3, -1, 4, -1, -1]
    alive = np.array([True, True, True, False, False, False])
    assert thickest_main_child(parent, radius, alive=alive).tolist() == [1, 2, -1, -1, -1, -1]


@pytest.fixture(scope="module")
def tree():
    pos, parent, radius, _ = random_tree(250, seed=3, tip_radius=0.01)
    return pos, parent, radius


def test_ts_v28_thickest_path_mesh_tubes_closed_three_sides_at_tips(tree):
    pos, parent, radius = tree
    m = thickest_path_mesh(pos, parent, radius, side_exponent=1.5)
    seg = m.segments
    sides = m.options["sides"]
    np.testing.assert_array_equal(m.options["main_child"], thickest_main_child(parent, radius))
    # one side count per branch, from the width at its base (Eq. C.2), 3 on every branch of tip width
    for a in np.unique(seg.axis):
        rows = m.counts[seg.axis == a]
        assert np.all(rows == sides[int(a)])
    tip_axes = [a for a in sides if np.isclose(radius[a], radius[1:].min())]
    assert tip_axes and all(sides[a] == 3 for a in tip_axes)
    trunk = int(seg.axis[0])
    assert sides[trunk] == max(sides.values()) > 3
    assert sides[trunk] == contour_sides(2 * radius[1], d_e=2 * radius[1:].min(), n=1.5)[0]
    for a in list(sides)[:30]:  # every tube is closed and outward
        s = np.flatnonzero(seg.axis == a)
        f = np.concatenate([m.faces[m.f_off[i]:m.f_off[i + 1]] for i in s])
        tm = trimesh.Trimesh(m.vertices, f, process=False)
        tm.merge_vertices(digits_vertex=9)
        tm.remove_unreferenced_vertices()
        assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0


def test_ts_v28_no_lateral_thicker_than_its_continuation(tree):
    # the crack of Fig. C.7: a lateral tube wider than the tube continuing through its node; the thickest path
    # never has one, while the apex-path (growth) topology of the same tree does
    pos, parent, radius = tree
    _, _, _, apex_main = random_tree(250, seed=3, tip_radius=0.01)

    def cracks(main):
        lat = np.flatnonzero((parent > 0) & (main[np.maximum(parent, 0)] != np.arange(len(parent))))
        return int(np.sum(radius[lat] > radius[main[parent[lat]]] * (1 + 1e-12)))
    assert cracks(thickest_main_child(parent, radius)) == 0
    assert cracks(apex_main) > 0


def test_thickest_path_mesh_matches_library_mesh_with_fixed_sides(tree):
    pos, parent, radius = tree
    ours = thickest_path_mesh(pos, parent, radius, c_max=3)  # every branch 3-sided
    ref = build_branch_mesh(pos, parent, radius, main_child=thickest_main_child(parent, radius), lod=(3, 3))
    np.testing.assert_array_equal(ours.faces, ref.faces)
    np.testing.assert_allclose(ours.vertices, ref.vertices, atol=1e-12)


def test_thickest_path_mesh_validation(tree):
    pos, parent, radius = tree
    with pytest.raises(ValueError, match="side_exponent"):
        thickest_path_mesh(pos, parent, radius, side_exponent=0.5)
    with pytest.raises(ValueError, match="radius"):
        thickest_path_mesh(pos, parent, -radius)


# ---- V30: fruit -----------------------------------------------------------------------------------------------------
def test_position_hash_is_the_xor_formula():
    pos = np.array([[0.12, 3.4, -0.7], [-5.0, 0.0, 2.25], [0.0, 0.0, 0.0]])
    idx = position_hash(pos, quant=0.05, table_size=1000)
    for p, k in zip(pos, idx):
        ix, iy, iz = (int(np.floor(x / 0.05)) for x in p)
        want = ((ix * HASH_PRIMES[0]) ^ (iy * HASH_PRIMES[1]) ^ (iz * HASH_PRIMES[2])) % 1000
        assert k == want
    with pytest.raises(ValueError, match="quant"):
        position_hash(pos, quant=0.0)


def _buds(n=400, seed=0):
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-3, 3, (n, 3))
    d = rng.normal(size=(n, 3))
    return pos, d / np.linalg.norm(d, axis=1, keepdims=True)


def test_ts_v30_fruit_probability_and_hash_stability():
    pos, _d = _buds()
    r = hash_random(pos, seed=7)
    assert np.all((r >= 0) & (r < 1))
    p = fruit_probability(r, np.full(len(r), 0.5))
    np.testing.assert_allclose(p, r * 0.25)
    assert np.all((p >= 0) & (p <= 1))
    # same position -> same r, whatever other buds are hashed with it (the tree grows; nothing flickers)
    more, _ = _buds(900, seed=1)
    r2 = hash_random(np.vstack([more, pos]), seed=7)[len(more):]
    np.testing.assert_array_equal(r, r2)
    assert not np.array_equal(hash_random(pos, seed=8), r)
    with pytest.raises(ValueError, match="light must be in"):
        fruit_probability(r, np.full(len(r), 1.5))


def test_ts_v30_more_light_more_fruit_thin_branches_only():
    pos, d = _buds()
    thin = np.full(len(pos), 0.01)
    counts = [place_fruit(pos, d, thin, np.full(len(pos), L), threshold=0.2, radius_threshold=0.02, seed=1).n_fruit
              for L in (0.3, 0.5, 0.7, 0.9, 1.0)]
    assert counts[0] == 0 and all(b >= a for a, b in itertools.pairwise(counts)) and counts[-1] > counts[1]
    light = np.random.default_rng(2).random(len(pos))
    f = place_fruit(pos, d, thin, light, threshold=0.2, radius_threshold=0.02, seed=1)
    r = hash_random(pos, seed=1)
    np.testing.assert_array_equal(f.index, np.flatnonzero(r * light ** 2 > 0.2))
    thick = thin.copy()
    thick[::2] = 0.05
    g = place_fruit(pos, d, thick, light, threshold=0.2, radius_threshold=0.02, seed=1)
    assert set(g.index) == {i for i in f.index if i % 2}                   # thin-branch filter
    assert np.all(g.probability[::2] == 0)
    h = place_fruit(pos, d, thin, light, threshold=0.2, radius_threshold=0.02, seed=1)
    np.testing.assert_array_equal(h.transforms, f.transforms)              # deterministic per seed


def test_fruit_frames_droop_and_mesh():
    pos, d = _buds(300)
    light = np.ones(len(pos))
    kw = {"threshold": 0.3, "radius_threshold": 1.0, "size": 0.2, "seed": 4}
    for droop in (0.0, 0.5, 1.0):
        f = place_fruit(pos, d, np.full(len(pos), 0.1), light, droop=droop, **kw)
        H = d[f.index]
        ang_h = np.arccos(np.clip(np.sum(f.axis * H, 1), -1, 1))
        ang_down = np.arccos(np.clip(-f.axis[:, 1], -1, 1))
        total = np.arccos(np.clip(-H[:, 1], -1, 1))
        np.testing.assert_allclose(ang_h, droop * total, atol=1e-6)         # rotated downward by Droop
        np.testing.assert_allclose(ang_down, (1 - droop) * total, atol=1e-6)
        R = f.transforms[:, :3, :3] / 0.2
        np.testing.assert_allclose(np.einsum("fji,fjk->fik", R, R), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
        np.testing.assert_allclose(f.transforms[:, :3, 3], pos[f.index])
    mesh = f.mesh(subdivisions=1)
    assert len(mesh.vertices) == f.n_fruit * 42 and len(mesh.faces) == f.n_fruit * 80
    centre = mesh.vertices.reshape(f.n_fruit, 42, 3).mean(1)
    np.testing.assert_allclose(centre, pos[f.index] + 0.2 * f.axis, atol=1e-9)  # sphere hangs from the bud
    assert place_fruit(pos, d, np.full(len(pos), 0.1), light * 0, **kw).mesh().faces.shape == (0, 3)


def test_place_fruit_validation():
    pos, d = _buds(10)
    kw = {"radius_threshold": 0.1}
    with pytest.raises(ValueError, match="bud_light must be in"):
        place_fruit(pos, d, np.zeros(10), np.full(10, 2.0), **kw)
    with pytest.raises(ValueError, match="threshold"):
        place_fruit(pos, d, np.zeros(10), np.ones(10), threshold=1.5, **kw)
    with pytest.raises(ValueError, match="droop"):
        place_fruit(pos, d, np.zeros(10), np.ones(10), droop=-0.1, **kw)
    with pytest.raises(ValueError, match="bud_radius"):
        place_fruit(pos, d, np.zeros(9), np.ones(10), **kw)


# ---- leaf hue by vigor ----------------------------------------------------------------------------------------------
def test_hsv_twins_match_colorsys():
    rgb = np.random.default_rng(0).random((500, 3))
    hsv = rgb_to_hsv(rgb)
    ref = np.array([colorsys.rgb_to_hsv(*c) for c in rgb]) * [360, 1, 1]
    np.testing.assert_allclose(hsv, ref, atol=1e-12)
    np.testing.assert_allclose(hsv_to_rgb(hsv), rgb, atol=1e-12)
    ref2 = np.array([colorsys.hsv_to_rgb(h / 360 % 1, s, v) for h, s, v in hsv - [400, 0, 0]])
    np.testing.assert_allclose(hsv_to_rgb(hsv - [400, 0, 0]), ref2, atol=1e-12)  # hue wraps


def test_leaf_hue_shift_by_vigor():
    base = (0.2, 0.6, 0.1)
    v = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    rgb = vigor_leaf_colors(v, base_rgb=base, shift=80.0)
    hsv, h0 = rgb_to_hsv(rgb), rgb_to_hsv(np.array([base]))[0]
    np.testing.assert_allclose(hsv[:, 0], h0[0] - 80.0 * (1 - v / 4.0), atol=1e-9)  # hue -= shift (1 - v/v_max)
    np.testing.assert_allclose(hsv[:, 1:], np.broadcast_to(h0[1:], (5, 2)), atol=1e-12)
    np.testing.assert_allclose(rgb[-1], base, atol=1e-12)
    assert rgb[0, 0] > rgb[0, 1]                                            # weakest leaves turn red-orange
    assert np.all(np.diff(hsv[:, 0]) > 0)                                   # greener with vigor
    np.testing.assert_allclose(vigor_leaf_colors(v, base_rgb=base, shift=0.0), np.tile(base, (5, 1)), atol=1e-12)
    np.testing.assert_allclose(vigor_leaf_colors(v, base_rgb=base, v_max=2.0)[2:], np.tile(base, (3, 1)), atol=1e-12)
    with pytest.raises(ValueError, match="vigor must be >= 0"):
        vigor_leaf_colors([-1.0])
    with pytest.raises(ValueError, match="shift"):
        vigor_leaf_colors(v, shift=400.0)

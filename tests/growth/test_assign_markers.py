"""TW-V5 (grid assignment == brute force, ties), TW-V6 (perception), TW-V7 (occupation), TW-V8/V9 (markers)."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from plantvr.growth.colonize import assign_treewand as assign_markers
from plantvr.growth.colonize import assign_treewand_reference as assign_markers_bruteforce
from plantvr.growth.engine import GrowthEngine
from plantvr.growth.markers import poisson_darts
from plantvr.growth.spatial import build_grid, within_any
from plantvr.params import defaults


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), nb=st.integers(1, 60), nm=st.integers(0, 400),
       angle=st.floats(10, 360), radius=st.floats(0.2, 4.0))
def test_tw_v5_grid_equals_bruteforce(seed, nb, nm, angle, radius):
    rng = np.random.default_rng(seed)
    m = rng.uniform(-3, 3, (nm, 3))
    bp = rng.uniform(-3, 3, (nb, 3))
    bp[nb // 2:] = np.round(bp[nb // 2:])  # coincident buds produce exact ties
    bd = rng.normal(size=(nb, 3))
    bd /= np.linalg.norm(bd, axis=1, keepdims=True)
    bl = rng.choice([0.5, 1.0, 2.0], nb)
    kw = dict(view_radius=radius, view_angle=np.radians(angle))
    a = assign_markers(m, bp, bd, bl, **kw)
    assert np.array_equal(a, assign_markers_bruteforce(m, bp, bd, bl, **kw))


def test_tw_v5_tie_goes_to_lowest_bud():
    bp = np.zeros((3, 3))
    bd = np.tile([0.0, 1.0, 0.0], (3, 1))
    owner = assign_markers(np.array([[0.0, 1.0, 0.0]]), bp, bd, np.ones(3), view_radius=2, view_angle=np.pi)
    assert owner.tolist() == [0]


def test_tw_v6_perception_and_d_over_l():
    bp = np.array([[0.0, 0, 0], [2.0, 0, 0]])
    bd = np.array([[0.0, 1, 0], [0.0, 1, 0]])
    m = np.array([[1.0, 1.0, 0], [0.0, -1.0, 0], [0.0, 9.0, 0]])  # equidistant; behind; out of reach
    owner = assign_markers(m, bp, bd, np.array([1.0, 2.0]), view_radius=3, view_angle=np.radians(120))
    assert owner.tolist() == [1, -1, -1]  # the longer internode wins at equal distance
    owner = assign_markers(m, bp, bd, np.array([2.0, 1.0]), view_radius=3, view_angle=np.radians(120))
    assert owner[0] == 0


def test_grid_within_any_matches_brute_force():
    rng = np.random.default_rng(3)
    pts, q = rng.uniform(-5, 5, (3000, 3)), rng.uniform(-5, 5, (40, 3))
    ref = (np.linalg.norm(pts[:, None] - q[None], axis=2) <= 0.7).any(1)
    assert np.array_equal(within_any(build_grid(pts, 0.5), q, 0.7), ref)


def test_tw_v7_occupation_after_step():
    e = GrowthEngine(defaults(), rng=0)
    for s in range(25):
        e.paint(np.array([0.0, 2 + 0.3 * s, 0.0]), 2.5, 200)
        e.step()
        e.paint(np.array([0.0, 3.0, 0.0]), 2.0, 100)  # fresh markers next to old nodes
    e.step()
    live = e.tree.pos[e.tree.alive]
    if len(e.markers):
        d = np.linalg.norm(e.markers[:, None] - live[None], axis=2).min(1)
        fresh = e.marker_age == 0
        assert np.all(d[~fresh] >= e.params["occupation_radius"])


def test_tw_v8_poisson_darts():
    rng = np.random.default_rng(0)
    c = np.array([1.0, 2.0, 3.0])
    pts = poisson_darts(c, 3.0, 2000, np.zeros((0, 3)), 0.5, rng)
    assert len(pts) > 50
    assert np.all(np.linalg.norm(pts - c, axis=1) <= 3.0)
    d = np.linalg.norm(pts[:, None] - pts[None], axis=2) + np.eye(len(pts)) * 9
    assert d.min() >= 0.5
    more = poisson_darts(c, 3.0, 500, pts, 0.5, rng)
    all_pts = np.concatenate([pts, more])
    d = np.linalg.norm(all_pts[:, None] - all_pts[None], axis=2) + np.eye(len(all_pts)) * 9
    assert d.min() >= 0.5


def test_tw_v9_marker_lifetime_exactly_60_steps():
    e = GrowthEngine({**defaults(), "activation_threshold": 100.0}, rng=0)  # nothing grows
    e.add_markers(np.array([[5.0, 30.0, 5.0]]))
    for _ in range(59):
        e.step()
    assert len(e.markers) == 1
    e.step()
    assert len(e.markers) == 0

"""TreeSketch growth variants (spec 004 §1.4, tests V1–V12)."""
import math

import numpy as np
import pytest

from plantvr.growth.sketch import SketchEngine
from plantvr.growth.sketch_rules import (
    autonomous_points,
    barycentric,
    deflect_heading,
    ellipse_distance,
    gravimorphism,
    set_point_tropism,
    shoot_lengths,
)
from plantvr.params import defaults

Y = np.array([0.0, 1.0, 0.0])


def _engine(n_max=3, **kw):
    params = {**defaults(), **kw.pop("params", {})}
    return SketchEngine(params, rng=kw.pop("rng", 3), n_max=n_max, **kw)


def test_ts_v2_eq43_shoot_lengths():
    v = np.array([1.0, 0.5, 0.249, 0.25, 0.1])
    n = shoot_lengths(v, 4)
    assert n[0] == 4  # v = v_max → exactly n_max
    np.testing.assert_array_equal(n, np.floor(v / 1.0 * 4))
    assert n[2] == 0 and n[4] == 0  # v < v_max / n_max → dormant
    assert shoot_lengths(np.array([0.3 * 3]), 7)[0] == 7  # rounding never loses the top bud
    assert shoot_lengths(np.zeros(3), 5).tolist() == [0, 0, 0]
    with pytest.raises(ValueError, match="n_max"):
        shoot_lengths(v, -1)


def test_ts_v4_tropism_cases():
    H = np.array([[0.6, 0.0, 0.8], [0.3, 0.5, -0.4]])
    H /= np.linalg.norm(H, axis=1, keepdims=True)
    np.testing.assert_allclose(set_point_tropism(H, 0.0), np.tile(Y, (2, 1)), atol=1e-15)
    np.testing.assert_allclose(set_point_tropism(H, math.pi), np.tile(-Y, (2, 1)), atol=1e-15)
    T = set_point_tropism(H, math.pi / 2)
    np.testing.assert_allclose(T @ Y, 0.0, atol=1e-15)  # ⟂ Y
    hz = H - np.outer(H @ Y, Y)
    hz /= np.linalg.norm(hz, axis=1, keepdims=True)
    np.testing.assert_allclose(T, hz, atol=1e-12)  # same compass heading, vertical plane of H
    T45 = set_point_tropism(H, math.pi / 4)
    np.testing.assert_allclose(np.linalg.det(np.stack([T45[0], H[0], Y])), 0.0, atol=1e-12)  # coplanar
    # H = Y: random horizontal plane, reproducible for a seed
    up = np.tile(Y, (3, 1))
    a, b = set_point_tropism(up, math.pi / 2, rng=5), set_point_tropism(up, math.pi / 2, rng=5)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(a @ Y, 0.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1.0)
    assert not np.allclose(a, set_point_tropism(up, math.pi / 2, rng=6))
    # trunk-up: T = Y on the main axis only
    T = set_point_tropism(H, math.pi / 2, main_axis=np.array([True, False]), trunk_up=True)
    np.testing.assert_array_equal(T[0], Y)
    assert abs(T[1] @ Y) < 1e-12
    with pytest.raises(ValueError, match="theta"):
        set_point_tropism(H, 4.0)


def test_ts_v5_barycentric_weights():
    assert barycentric(2.0, 1.0, 1.0) == (0.5, 0.25, 0.25)
    assert sum(barycentric(0.4, 0.1, 0.5)) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="all be zero"):
        barycentric(0, 0, 0)
    with pytest.raises(ValueError, match="beta"):
        barycentric(0.5, -0.1, 0.6)


@pytest.mark.parametrize("w, expect", [((1.0, 0.0, 0.0), "H"), ((0.0, 0.0, 1.0), "E"), ((0.0, 1.0, 0.0), "T")])
def test_ts_v5_eq45_extremes(w, expect):
    """(1,0,0) keeps the bud heading, (0,0,1) follows E, (0,1,0) follows T (θ = 90°)."""
    params = {"w_heading": w[0], "w_tropism": w[1], "w_env": w[2], "tropism_angle": 90.0, "length_mode": "constant",
                  "activation_threshold": 0.0, "shed_count": "direct"}
    e = _engine(n_max=1, params=params)
    target = np.array([1.5, 2.8, 0.4])
    e.add_markers(target[None])
    e.step()
    t = e.tree
    new = np.flatnonzero(t.born == 1)
    assert len(new) == 1
    d = t.pos[new[0]] - t.pos[t.parent[new[0]]]
    d /= np.linalg.norm(d)
    bud = t.pos[t.parent[new[0]]]
    if expect == "H":
        np.testing.assert_allclose(d, Y, atol=1e-12)
    elif expect == "E":
        np.testing.assert_allclose(d, (target - bud) / np.linalg.norm(target - bud), atol=1e-12)
    else:
        assert abs(d @ Y) < 1e-12


def test_ts_deflection_angle():
    H = np.array([[0.0, 1.0, 0.0], [0.3, 0.9, 0.1]])
    H /= np.linalg.norm(H, axis=1, keepdims=True)
    lat_axis = np.array([[1.0, 0.0, 0.0], [0.0, 0.1, 1.0]])
    psi, delta = math.radians(40), math.radians(25)
    lp = lat_axis - np.sum(lat_axis * H, 1, keepdims=True) * H
    lp /= np.linalg.norm(lp, axis=1, keepdims=True)
    lateral = np.cos(psi) * H + np.sin(psi) * lp
    d = deflect_heading(H, lateral, delta)
    ang = np.degrees(np.arccos(np.clip(np.sum(d * lateral, 1), -1, 1)))
    np.testing.assert_allclose(ang, 65.0, atol=1e-9)  # ψ + δ: away from the lateral
    np.testing.assert_allclose(np.degrees(np.arccos(np.sum(d * H, 1))), 25.0, atol=1e-9)
    for i in range(2):  # in the plane of H and the lateral
        assert abs(np.linalg.det(np.stack([d[i], H[i], lateral[i]]))) < 1e-12
    np.testing.assert_array_equal(deflect_heading(H, lateral, 0.0), H)


def test_ts_n_max_shoot_grows_n_max_internodes():
    params = {"length_mode": "constant", "activation_threshold": 0.0}
    e = _engine(n_max=4, params=params)
    e.add_markers(np.array([[0.0, 4.0, 0.0]]))
    e.step()
    t = e.tree
    new = np.flatnonzero(t.born == 1)
    assert len(new) == 4  # the only enabled bud has v = v_max
    chain = [1]
    for _ in range(4):
        chain.append(t.child[chain[-1], 0])
    assert sorted(chain[1:]) == sorted(new.tolist())
    np.testing.assert_allclose(np.linalg.norm(np.diff(t.pos[chain], axis=0), axis=1), 1.0)


def test_ts_v10_deflection_turns_more():
    def mean_turn(delta):
        e = _engine(n_max=3, deflection=delta, mode="autonomous", rng=11)
        for _ in range(8):
            e.step()
        t = e.tree
        i = np.flatnonzero(t.alive & (t.parent > 0))
        a = t.pos[i] - t.pos[t.parent[i]]
        b = t.pos[t.parent[i]] - t.pos[t.parent[t.parent[i]]]
        main = t.child[t.parent[i], 0] == i
        c = np.sum(a * b, 1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        return np.degrees(np.arccos(np.clip(c[main], -1, 1))).mean()

    assert mean_turn(30.0) > mean_turn(0.0) + 5.0


def test_ts_v8_directed_keeps_autonomous_clears():
    far = np.array([[50.0, 50.0, 50.0]])
    params = {"marker_lifetime": 2}
    d = _engine(params=params, mode="directed")
    d.add_markers(far)
    for _ in range(4):
        d.step()
    np.testing.assert_array_equal(d.markers, far)  # unconsumed user point persists past the lifetime
    a = _engine(params=params, mode="autonomous")
    a.add_markers(far)
    s = a.step()
    assert len(a.markers) == 0 and s.grown > 0


def test_ts_autonomous_points_in_sector():
    rng = np.random.default_rng(0)
    pos = rng.normal(size=(5, 3))
    H = rng.normal(size=(5, 3))
    H /= np.linalg.norm(H, axis=1, keepdims=True)
    v = np.array([1.0, 0.5, 0.0, 0.26, 0.9])
    pts = autonomous_points(pos, H, v, density=4, r_in=1.0, r_out=3.0, half_angle=math.radians(45), rng=1)
    k = 1 + np.floor(4 * v / v.max()).astype(int)
    assert len(pts) == k.sum()
    idx = np.repeat(np.arange(5), k)
    off = pts - pos[idx]
    r = np.linalg.norm(off, axis=1)
    assert np.all((r >= 1.0 - 1e-12) & (r <= 3.0 + 1e-12))
    assert np.all(np.sum(off / r[:, None] * H[idx], 1) >= math.cos(math.radians(45)) - 1e-12)


def test_ts_deterministic_per_seed():
    def grow(seed):
        e = _engine(n_max=3, deflection=10, trunk_up=True, mode="autonomous", rng=seed,
                    params={"tropism_angle": 100.0})
        for _ in range(6):
            e.step()
        return e.tree.arrays()

    a, b, c = grow(4), grow(4), grow(5)
    for k in a:
        assert a[k].tobytes() == b[k].tobytes(), k
    assert a["pos"].shape != c["pos"].shape or not np.array_equal(a["pos"], c["pos"])


def test_ts_trunk_up_keeps_main_axis_vertical():
    params = {"w_heading": 0.2, "w_tropism": 0.8, "w_env": 0.0, "tropism_angle": 90.0, "length_mode": "constant"}
    e = _engine(n_max=2, trunk_up=True, mode="autonomous", params=params)
    for _ in range(5):
        e.step()
    t = e.tree
    i = np.flatnonzero(t.alive & (t.order == 0) & (t.parent >= 0))
    d = t.pos[i] - t.pos[t.parent[i]]
    np.testing.assert_allclose(d[:, [0, 2]], 0.0, atol=1e-12)


def test_ts_validation():
    with pytest.raises(ValueError, match="n_max"):
        SketchEngine(defaults(), n_max=0)
    with pytest.raises(ValueError, match="mode"):
        SketchEngine(defaults(), mode="selective")
    with pytest.raises(ValueError, match="deflection"):
        SketchEngine(defaults(), deflection=120)


def test_ts_v6_gravimorphism_cases():
    up, down, side = np.array([0.0, 1.0, 0.0]), np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    # tau = 0: b = 1 whatever the ellipse
    np.testing.assert_allclose(gravimorphism(np.tile(Y, (2, 1)), [[1.0, 0, 0], [0, 0, 1.0]], s_v=0.3, s_p=2.0,
                                             e_v=0.5), 1.0)
    H = np.tile([1.0, 0.0, 0.0], (3, 1))  # horizontal axis: b = d
    buds = np.stack([up, down, side])
    np.testing.assert_allclose(gravimorphism(H, buds), 1.0)  # neutral ellipse
    epi = gravimorphism(H, buds, e_v=0.4)
    assert epi[0] > epi[1]  # epitony: upper bud favoured
    np.testing.assert_allclose(epi[:2], [1.4, 0.6])  # d = s_v ± e_v along ±V
    hypo = gravimorphism(H, buds, e_v=-0.4)
    assert hypo[1] > hypo[0]
    amphi = gravimorphism(np.tile([1.0, 0.0, 0.0], (5, 1)),
                          [up, down, side, -side, normalize_row([0.0, 1.0, 1.0])], s_v=0.5, s_p=1.5)
    assert np.argmax(amphi) in (2, 3) and amphi[2] == pytest.approx(1.5)  # amphitony: side bud maximal
    # slanted axis: b = cos^2 tau + d sin^2 tau
    tau = math.radians(30)
    h = np.array([[math.sin(tau), math.cos(tau), 0.0]])
    V = np.array([[-math.cos(tau), math.sin(tau), 0.0]])
    np.testing.assert_allclose(gravimorphism(h, V, e_v=0.4), math.cos(tau) ** 2 + 1.4 * math.sin(tau) ** 2)


def normalize_row(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def test_ts_ellipse_distance_closed_form():
    chi = np.linspace(0, 2 * math.pi, 37)
    d = ellipse_distance(chi, s_v=0.7, s_p=1.3, e_v=0.2)
    x, y = d * np.cos(chi), d * np.sin(chi)  # points on the ellipse ((x - e)/s_v)^2 + (y/s_p)^2 = 1
    np.testing.assert_allclose(((x - 0.2) / 0.7) ** 2 + (y / 1.3) ** 2, 1.0, atol=1e-12)
    assert np.all(ellipse_distance(chi, s_v=0.5, s_p=0.5, e_v=2.0) >= 0)  # ray may miss: clamped / 0
    assert ellipse_distance(np.array([math.pi]), s_v=0.5, s_p=0.5, e_v=2.0)[0] == 0.0
    with pytest.raises(ValueError, match="s_v"):
        ellipse_distance(chi, s_v=0.0, s_p=1.0, e_v=0.0)


# -- engine hooks: gravimorphism, shedding, selective growth, stroke tropism, widths, pruning, pickling ------
def _grown(steps=6, **kw):
    e = _engine(mode="autonomous", **kw)
    for _ in range(steps):
        e.step()
    return e


def test_ts_v6_gravimorphism_in_vigor_eq47():
    """light_factor = b of Eq. 4.6 at nodes with a lateral bud and a main child; bud signal Q = b L^kappa."""
    ell = (0.6, 1.4, 0.3)
    e = _grown(params={"tropism_angle": 90.0, "light_exponent": 1.5}, ellipse=ell)
    t = e.tree
    inner = np.flatnonzero(t.alive & (t.child[:, 1] == -1) & (t.child[:, 0] >= 0))
    assert len(inner) > 5
    b = gravimorphism(t.head[inner], e._bud_dirs(inner, np.ones(len(inner), np.int64)), s_v=ell[0], s_p=ell[1],
                      e_v=ell[2])
    np.testing.assert_allclose(t.light_factor[inner], b, rtol=1e-12)
    assert np.ptp(b) > 0.05  # not all vertical: the ellipse matters
    np.testing.assert_allclose(t.Qslot[inner, 1], b * t.L[inner] ** 1.5, rtol=1e-12)  # Eq. 4.7
    tips = np.flatnonzero(t.alive & (t.child[:, 0] == -1))
    np.testing.assert_array_equal(t.light_factor[tips], 1.0)  # terminal buds unaffected
    neutral = _grown(params={"tropism_angle": 90.0})
    np.testing.assert_array_equal(neutral.tree.light_factor, 1.0)


def test_ts_v6_epitony_favours_upper_buds_in_engine():
    """Two nodes on a horizontal axis, lateral up / lateral down: e_v > 0 gives b = s_v ± e_v (tau = 90°), and
    the upper bud's signal Q = b L^0 is the larger (epitony); e_v < 0 reverses it (hypotony)."""
    def factors(e_v):
        e = _engine(params={"activation_threshold": 0.0, "light_exponent": 0.0, "branch_angle": 90.0},
                    ellipse=(1.0, 1.0, e_v))
        t = e.tree
        t.head[1], t.lat[1] = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]  # horizontal axis, lateral up
        x = np.array([[1.0, 0, 0]])
        a = t.append_many(np.array([[1.0, 1.0, 0.0]]), np.array([1]), x, np.array([[0, -1.0, 0]]), np.array([0]))
        t.child[1, 0] = a[0]
        b = t.append_many(np.array([[2.0, 1.0, 0.0]]), a, x, np.array([[0, 1.0, 0]]), np.array([0]))
        t.child[a[0], 0] = b[0]
        e.update_light()
        return t.light_factor[1], t.light_factor[a[0]], t.Qslot[1, 1], t.Qslot[a[0], 1]
    up, down, q_up, q_down = factors(0.4)
    np.testing.assert_allclose([up, down, q_up, q_down], [1.4, 0.6, 1.4, 0.6], rtol=1e-12)
    up, down, q_up, q_down = factors(-0.4)
    assert down > up and q_down > q_up


def test_ts_v12_shedding_threshold():
    none = _grown(steps=8, shed_threshold=0.0)
    assert all(s.shed == 0 for s in none.history)
    e = _grown(steps=8, shed_threshold=0.0)
    mask = (e.set_options(shed_threshold=0.9), e.shed_mask())[1]
    assert mask.any() and not mask[:2].any()
    t = e.tree
    v = t.vigor / t.vigor[0]
    roots = np.flatnonzero(mask & ~mask[np.maximum(t.parent, 0)])
    for r in roots:  # each shed root is a lateral branch below the threshold
        n_i = e.tree.subtree_mask([r]).sum()
        assert v[r] / (n_i / t.n_internodes) < 0.9 and t.child[t.parent[r], 0] != r
    r = roots[0]
    leaf = np.flatnonzero(e.tree.subtree_mask([r]))[-1]
    e.set_width(int(leaf), 0.1)  # a constrained branch is protected
    assert not e.shed_mask()[r]
    e.step()
    assert e.history[-1].shed > 0
    assert all(e.tree.alive[k] for k in e.width_constraints)  # the protected branch survived


def test_ts_v11_selective_growth_only_subtree():
    e = _grown(steps=5)
    t = e.tree
    lat = np.flatnonzero(t.alive & (t.order == 1))
    sel = int(lat[0])
    before = t.n
    e.set_options(mode="directed")
    e.select(sel)
    rng = np.random.default_rng(0)
    lo, hi = t.pos[t.alive].min(0) - 2, t.pos[t.alive].max(0) + 2
    e.add_markers(rng.uniform(lo, hi, (400, 3)))
    e.step()
    t = e.tree
    new = np.arange(before, t.n)
    assert len(new) > 0
    assert t.subtree_mask([e.selected])[new].all()
    # every node, selected or not, still occupies: no marker is left within the occupation radius of a node
    # that existed at the step's start (new nodes occupy at the next step, as in the engine)
    old = t.pos[:before][t.alive[:before]]
    d = np.linalg.norm(e.markers[:, None] - old[None], axis=2).min(1)
    assert (d > e.params["occupation_radius"]).all()
    e.select(None)
    with pytest.raises(ValueError, match="node"):
        e.select(10 ** 6)


def test_ts_stroke_tropism_follows_stroke_direction():
    params = {"w_heading": 0.0, "w_tropism": 1.0, "w_env": 0.0, "length_mode": "constant", "activation_threshold": 0.0}
    e = _engine(n_max=1, params=params, stroke_tropism=True)
    e.add_stroke_points(np.array([[0.3, 2.5, 0.2]]), np.array([[0.0, 0.0, 2.0]]))
    e.step()
    t = e.tree
    new = np.flatnonzero(t.born == 1)
    d = t.pos[new[0]] - t.pos[t.parent[new[0]]]
    np.testing.assert_allclose(d / np.linalg.norm(d), [0, 0, 1], atol=1e-12)
    off = _engine(n_max=1, params=params, stroke_tropism=False)  # switch off: GSA tropism (theta = 0 → up)
    off.add_stroke_points(np.array([[0.3, 2.5, 0.2]]), np.array([[0.0, 0.0, 2.0]]))
    off.step()
    t = off.tree
    new = np.flatnonzero(t.born == 1)
    np.testing.assert_allclose(t.pos[new[0]] - t.pos[t.parent[new[0]]], [0, 1, 0], atol=1e-12)
    with pytest.raises(ValueError, match="directions"):
        e.add_stroke_points(np.zeros((2, 3)), np.ones((1, 3)))


def test_ts_prune_at_branch_point_and_widths_as_if_never_there():
    from plantvr.growth.bending import pipe_widths

    e = _grown(steps=6)
    e.set_width(1, 0.5)
    t = e.tree
    tip = int(np.flatnonzero(t.alive & (t.order == 1) & (t.child[:, 0] == -1))[0])
    from plantvr.growth.sketch_rules import branch_point
    cut = branch_point(t.parent, t.alive, tip, protected=e.width_constraints)
    p = t.parent[cut]
    assert (t.parent[t.alive] == p).sum() >= 2  # the cut is at a branching point
    gone = t.subtree_mask([cut])
    n = e.prune_at(tip)
    assert n == gone.sum()
    t = e.tree
    live = np.flatnonzero(t.alive)
    remap = np.full(t.n, -1)
    remap[live] = np.arange(len(live))
    par = np.where(t.parent[live] >= 0, remap[np.maximum(t.parent[live], 0)], -1)
    fresh = pipe_widths(par, np.ones(len(live), bool), tip_diameter=2 * e.params["tip_radius"],
                        exponent=e.params["radius_exp"], constraints={int(remap[1]): 0.5})
    np.testing.assert_allclose(2 * t.radius[live], fresh.diameter, rtol=1e-12)
    assert e.prune_at(1) == 0  # the first internode is never pruned


def test_ts_prune_leaves_stub_over_constraint():
    from plantvr.growth.sketch_rules import branch_point

    par = np.array([-1, 0, 1, 2, 3, 2, 5, 6])  # 0-1-2 branches into 3-4 and 5-6-7
    alive = np.ones(8, bool)
    assert branch_point(par, alive, 7) == 5
    assert branch_point(par, alive, 7, protected={6}) == 7  # stub: cut just above the constraint at 6
    assert branch_point(par, alive, 6, protected={6}) == -1


def test_ts_pickle_roundtrip_continues_identically():
    import pickle

    a = _grown(steps=4, ellipse=(0.8, 1.2, 0.2), deflection=10.0)
    a.set_width(1, 0.3)
    b = pickle.loads(pickle.dumps(a))
    assert b.sketch == a.sketch and b.width_constraints == a.width_constraints
    for _ in range(3):
        a.step()
        b.step()
    for k, v in a.tree.arrays().items():
        np.testing.assert_array_equal(v, b.tree.arrays()[k], err_msg=k)


def test_ts_engine_bend_keeps_lengths_and_side_branch_pose():
    e = _grown(steps=6)
    t = e.tree
    tip = int(np.flatnonzero(t.alive & (t.order == 0) & (t.child[:, 0] == -1))[0])
    path = e.branch_path(1, tip)
    par = np.maximum(t.parent, 0)
    lengths = np.linalg.norm(t.pos - t.pos[par], axis=1)
    rel_before = t.head.copy()
    target = t.pos[tip] + np.array([1.5, -0.8, 0.3])
    res = e.bend(1, tip, target)
    t = e.tree
    assert np.linalg.norm(t.pos[tip] - target) < 1e-3  # V14 tolerance
    np.testing.assert_allclose(np.linalg.norm(t.pos - t.pos[par], axis=1), lengths, atol=1e-9)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", res.rot, rel_before), t.head, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(t.head[t.alive], axis=1), 1.0)
    assert e.step().internodes >= t.n_internodes - 0  # growth goes on after a bend
    with pytest.raises(ValueError, match="subtree"):
        e.branch_path(tip, 1)
    assert len(path) >= 2


def test_ts_bud_lifetime_bounds_dormant_buds():
    keep = _grown(steps=10)
    e = _grown(steps=10, bud_lifetime=3)
    t = e.tree
    lat_bud = (t.child[:, 1:] == -1).any(1) & t.alive
    assert (t.born[lat_bud] > e.step_count - 3).all()  # no lateral bud older than the lifetime
    assert len(e.buds().node) < len(keep.buds().node)
    with pytest.raises(ValueError, match="bud_lifetime"):
        e.set_options(bud_lifetime=0)


def test_ts_v25_region_constrains_autonomous_growth():
    """Crown space of a landscape tree: points only in its weighted Voronoi cell below h_max; a shoot may
    overshoot the cell by at most one shoot length; growth halts at h_max and the arrays stop changing."""
    region = {"sites": [[4.0, 0.0], [-3.0, 3.0]], "weights": [1.0, 2.0], "weight": 1.0, "h_max": 9.0}
    e = _engine(n_max=3, mode="autonomous", region=region, rng=2,
                params={"length_mode": "constant", "activation_threshold": 0.0})
    pts = np.random.default_rng(0).uniform(-8, 8, (2000, 3))
    inside = e.in_region(pts)
    q = pts[:, [0, 2]]
    own = np.linalg.norm(q, axis=1)
    d1, d2 = np.linalg.norm(q - [4, 0], axis=1), np.linalg.norm(q - [-3, 3], axis=1) / 2
    np.testing.assert_array_equal(inside, (own <= np.minimum(d1, d2)) & (pts[:, 1] <= 9.0))
    for _ in range(40):
        e.step()
        if e.halted:
            break
    assert e.halted
    t = e.tree
    live = t.pos[t.alive]
    n_max = 3
    assert live[:, 1].max() <= 9.0 + n_max + 1e-9
    q = live[:, [0, 2]]
    slack = np.linalg.norm(q, axis=1) - np.minimum(np.linalg.norm(q - [4, 0], axis=1),
                                                   np.linalg.norm(q - [-3, 3], axis=1) / 2)
    assert slack.max() <= 2 * n_max  # points are constrained, branches are not
    ref = e.tree.arrays()
    e.step()
    e.step()
    for k, v in e.tree.arrays().items():
        assert ref[k].tobytes() == v.tobytes(), k
    with pytest.raises(ValueError, match="region"):
        e.set_options(region={"sites": [[0, 0]]})


def test_ts_selective_reorients_nearest_bud():
    """§2.8: press-hold on a branch point with a stroke direction turns that bud toward it; only it grows."""
    params = {"w_heading": 1.0, "w_tropism": 0.0, "w_env": 0.0, "length_mode": "constant", "activation_threshold": 0.0}
    e = _engine(n_max=1, params=params)
    e.select(1, direction=[1.0, 0.0, 0.0])  # node 1: lateral bud re-oriented along +x
    assert (1, 1) in e.bud_override
    b = e.buds()
    i = np.flatnonzero((b.node == 1) & (b.slot == 1))[0]
    np.testing.assert_allclose(b.dir[i], [1.0, 0.0, 0.0])
    e.add_markers(np.array([[2.5, 1.2, 0.0]]))
    e.step()
    t = e.tree
    new = np.flatnonzero(t.born == 1)
    assert len(new) == 1 and t.parent[new[0]] == 1 and t.child[1, 1] == new[0]
    np.testing.assert_allclose(t.pos[new[0]] - t.pos[1], [1.0, 0.0, 0.0], atol=1e-12)  # alpha = 1 keeps it
    assert not e.bud_override  # the bud grew: override dropped
    import pickle

    e.select(new[0], direction=[0, 0, 2.0])
    f = pickle.loads(pickle.dumps(e))
    np.testing.assert_array_equal(f.bud_override[(int(new[0]), 1)], [0, 0, 1.0])
    with pytest.raises(ValueError, match="direction"):
        e.select(None, direction=[1, 0, 0])


def _trend_tree(target=600, n_max=3, **params):
    e = _engine(n_max=n_max, mode="autonomous", rng=1,
                params={"activation_threshold": 0.0, "length_mode": "constant", **params})
    while e.tree.n_internodes < target and e.step_count < 80:  # matched size, not matched iterations (§6.4)
        e.step()
    p = e.tree.pos[e.tree.alive]
    return e, p[:, 1].max(), np.ptp(p[:, [0, 2]], axis=0).max()


def test_ts_v10_trends_at_matched_size():
    _, h0, w0 = _trend_tree(w_heading=0.3, w_tropism=0.3, w_env=0.4, tropism_angle=0.0)
    _, h90, w90 = _trend_tree(w_heading=0.3, w_tropism=0.3, w_env=0.4, tropism_angle=90.0)
    assert w90 / h90 > w0 / h0  # Fig. 4.17: plagiotropism is broad
    ratios = [h / w for _, h, w in (_trend_tree(apical_dominance=lam) for lam in (0.46, 0.5, 0.54))]
    assert ratios[0] < ratios[1] < ratios[2]  # Fig. 4.13: lambda up → excurrent

    def grown_per_step(e):
        return np.mean([s.grown for s in e.history])

    assert grown_per_step(_trend_tree(light_exponent=2.5)[0]) < grown_per_step(_trend_tree(light_exponent=0.5)[0])

    def mean_shoot(e):  # internodes per shoot: a shoot starts where the parent was made in another step
        t = e.tree
        i = np.flatnonzero(t.alive & (t.born > 0))
        return len(i) / np.sum(t.born[t.parent[i]] != t.born[i])

    assert mean_shoot(_trend_tree(n_max=6)[0]) > mean_shoot(_trend_tree(n_max=2)[0])  # Fig. 4.18


def test_ts_v16_depth_constraint():
    """No attraction point outside the depth slab reaches the competition step (App. B)."""
    e = _engine(mode="autonomous", depth={"normal": [0.0, 0.0, 2.0], "depth": 1.5})
    pts = np.random.default_rng(0).uniform(-5, 5, (500, 3))
    e.add_markers(pts)
    np.testing.assert_array_equal(e.markers, pts[np.abs(pts[:, 2]) <= 1.5])
    e.markers, e.marker_age = e.markers[:0], e.marker_age[:0]
    seen = []
    orig = e._occupy

    def spy():
        seen.append(e.markers.copy())
        orig()

    e._occupy = spy
    for _ in range(8):
        e.step()
    allpts = np.concatenate(seen)
    assert len(allpts) > 50 and np.abs(allpts[:, 2]).max() <= 1.5
    t = e.tree
    assert np.abs(t.pos[t.alive, 2]).max() <= 1.5 + 2 * 3  # trees may extend slightly outside (one shoot)
    with pytest.raises(ValueError, match="depth"):
        e.set_options(depth={"normal": [0, 0, 0], "depth": 1.0})


def test_ts_asymmetry_tropism_leans_away():
    """Eq. 6.5 in growth: a tree with V = +x leans toward +x; the lean fades as it nears h_max."""
    params = {"w_heading": 0.3, "w_tropism": 0.4, "w_env": 0.3, "activation_threshold": 0.0,
              "length_mode": "constant"}
    region = {"sites": [], "weights": [], "weight": 1.0, "h_max": 12.0}

    def centroid_x(v):
        e = _engine(n_max=2, mode="autonomous", params=params, region=region, asymmetry=v, rng=5)
        for _ in range(8):
            e.step()
        return e.tree.pos[e.tree.alive, 0].mean()

    assert centroid_x([2.0, 0.0]) > centroid_x(None) + 0.5
    with pytest.raises(ValueError, match="asymmetry"):
        _engine(asymmetry=[1.0, 2.0, 3.0])


# ---------------------------------------------------------------------------------------------- V1, V3, V7, V9
def _grown_sketch(**params):
    e = _engine(params={"shadow_intensity": 0.05, **params}, rng=4)
    rng = np.random.default_rng(4)
    for _ in range(6):
        e.add_markers(rng.uniform([-4, 1, -4], [4, 9, 4], (300, 3)))
        e.step()
    assert e.tree.n_internodes > 20
    return e


def _slot_vigor(t, n):
    """Vigor handed to each of node n's slots: the child's vigor, or the bud's (0 for an absent slot)."""
    return np.array([t.vigor[c] if c >= 0 else t.bud_vigor[n, s] for s, c in enumerate(t.child[n])])


@pytest.mark.parametrize("lam", [0.5, 0.7, 0.999999, 1e-6])
def test_ts_v1_eq41_conservation_and_limits(lam):
    """Eq. 4.1: v_m + v_l = v at every node; λ = 0.5 splits by Q; λ → 1 starves laterals, λ → 0 the main axis."""
    e = _grown_sketch()
    e.set_params({"apical_dominance": lam})             # vigor of the same tree under this λ
    t = e.tree
    nodes = [n for n in np.flatnonzero(t.alive) if t.Qw[n] > 0]
    for n in nodes:
        vs = _slot_vigor(t, n)
        assert math.isclose(vs.sum(), t.vigor[n], rel_tol=1e-12, abs_tol=1e-300)
        q_m, q_l = t.Qslot[n, 0], t.Qslot[n, 1:].sum()
        if lam == 0.5 and q_m > 0 and q_l > 0:
            assert math.isclose(vs[0] / vs[1:].sum(), q_m / q_l, rel_tol=1e-9)
        if lam > 0.99 and q_m > 0:                         # v_l / v ≤ (1 − λ)/λ · Q_l/Q_m → 0
            assert vs[1:].sum() <= (1 - lam) / lam * q_l / q_m * t.vigor[n] * (1 + 1e-9)
        if lam < 0.01 and q_l > 0:                         # v_m / v ≤ λ/(1 − λ) · Q_m/Q_l → 0
            assert vs[0] <= lam / (1 - lam) * q_m / q_l * t.vigor[n] * (1 + 1e-9)
    shares = [(_slot_vigor(t, n)[1:].sum() if lam > 0.5 else _slot_vigor(t, n)[0]) / t.vigor[n] for n in nodes
              if t.Qslot[n, 0] > 0 and t.Qslot[n, 1:].sum() > 0]
    if lam > 0.99 or lam < 0.01:
        assert np.median(shares) < 1e-3                    # the starved side gets almost nothing


def test_ts_v3_space_only_growth_all_buds_get_n_max():
    """κ = 0 and a neutral ellipse: every bud collects Q = 1, so with λ = 0.5 all get v_max and n = n_max."""
    e = _grown_sketch(light_exponent=0.0, apical_dominance=0.5)
    assert e.sketch["ellipse"] == (1.0, 1.0, 0.0)
    buds = e.buds()
    np.testing.assert_allclose(buds.vigor, buds.vigor.max(), rtol=1e-12)
    assert np.all(shoot_lengths(buds.vigor, e.sketch["n_max"]) == e.sketch["n_max"])


def test_ts_v7_space_colonization_rules_fig44():
    """Fig. 4.4: removal inside r, one cone selects its bud, two cones the closer, outside all stays; growth
    follows the mean direction of the selecting points."""
    from plantvr.growth.colonize import assign_treewand

    buds = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    heads = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    lens = np.ones(2)
    pts = np.array([[-0.5, 2.0, 0.0],     # only bud 0's cone
                    [0.8, 2.0, 0.0],      # both cones, closer to bud 0
                    [1.4, 2.0, 0.0],      # both cones, closer to bud 1
                    [0.0, -2.0, 0.0]])    # behind both buds: no cone
    owner = assign_treewand(pts, buds, heads, lens, view_radius=3.0, view_angle=math.radians(120))
    assert owner.tolist() == [0, 0, 1, -1]
    # occupation: a point inside r of a node is removed at the next step, the others stay
    e = _engine(params={"w_heading": 0.0, "w_tropism": 0.0, "w_env": 1.0, "occupation_radius": 0.5}, n_max=1)
    tip = int(np.flatnonzero(e.tree.alive)[-1])
    p = e.tree.pos[tip]
    e.add_markers(np.array([p + [0.1, 0.2, 0.0], p + [0.6, 2.0, 0.0], p + [-0.3, 2.5, 0.4]]))
    e._occupy()
    assert len(e.markers) == 2
    # the enabled tip bud grows toward the mean direction of its selecting points (γ = 1: E only)
    u = e.markers - p
    E = (u / np.linalg.norm(u, axis=1, keepdims=True)).sum(0)
    E /= np.linalg.norm(E)
    e.step()
    c = e.tree.child[tip, 0]
    assert c >= 0
    d = e.tree.pos[c] - p
    np.testing.assert_allclose(d / np.linalg.norm(d), E, atol=1e-12)


def test_ts_v9_shadow_isolated_below_and_reversible():
    """An isolated bud is fully lit; q cells straight below a node the light is 1 − a·b^(−q) (b = 1/β > 1 here);
    removing a node restores the previous grid."""
    from plantvr.growth.shadow import ShadowGrid, shadow_lut

    a, beta, q_max = 0.3, 0.6, 6
    e = _engine(params={"shadow_intensity": a, "shadow_falloff": beta, "shadow_depth": q_max})
    e.update_light()
    tip = int(np.argmax(np.where(e.tree.alive, e.tree.pos[:, 1], -np.inf)))
    assert e.tree.L[tip] == 1.0                                   # nothing above the top bud
    g = ShadowGrid(1.0, 8)
    offs, vals = shadow_lut(a, beta, q_max)
    top = np.array([[4, 10, -3]])
    g.add(top, offs, vals)
    for q in range(1, q_max):
        s = g.read(top + [0, -q, 0])[0]
        assert math.isclose(1.0 - s, 1.0 - a * (1.0 / beta) ** (-q), rel_tol=1e-12)
    assert g.read(top + [0, -q_max - 1, 0])[0] == 0.0
    assert g.read(np.array([[40, 40, 40]]))[0] == 0.0            # an isolated bud: L = 1
    before = g.blocks[: g.nblocks].copy()
    other = np.array([[5, 12, -2]])
    g.add(other, offs, vals)
    g.add(other, offs, vals, sign=-1.0)
    np.testing.assert_allclose(g.blocks[: g.nblocks][: len(before)], before, atol=1e-15, rtol=0)

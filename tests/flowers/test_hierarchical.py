"""Tests for spec 002 §4.4: hierarchical and recursive phyllotaxis, Hofmeister's rule (V32)."""
import numpy as np
import pytest

from plantvr.flowers import cone_dmin, cone_receptacle, dome_receptacle, floret_fate
from plantvr.flowers.hierarchical import HierarchicalPhyllotaxis, LevelSpec, hofmeister_angles


def _two_level(profile0=None, profile1=None, steps=40, packing=1.0):
    """Fig. 5.4-like: a main meristem whose elements become heads that produce florets."""
    H = HierarchicalPhyllotaxis(
        [LevelSpec(primordium_area=lambda a: 0.05 * np.exp(0.3 * a), inner_rate=0.05, meristem_area=0.1,
                   max_elements=8, profile=profile0, packing=packing),
         LevelSpec(primordium_area=0.01, inner_rate=lambda a: 0.02 * np.exp(0.2 * a), threshold=0.012,
                   max_elements=40, profile=profile1)], inner_area=0.05)
    H.run(steps, 0.5)
    return H


def _three_level():
    """Fig. 5.3-like recursive segregation in a flat, exponentially growing space."""
    grow = LevelSpec(primordium_area=lambda a: 0.02 * np.exp(0.25 * a),
                     inner_rate=lambda a: 0.01 * np.exp(0.25 * a),
                     threshold=0.03, meristem_area=0.06, max_elements=6)
    last = LevelSpec(primordium_area=lambda a: 0.005 * np.exp(0.1 * a), inner_rate=0.01, threshold=0.006,
                     max_elements=12)
    H = HierarchicalPhyllotaxis([grow, grow, last], inner_area=0.02)
    H.run(50, 0.5)
    return H


@pytest.mark.parametrize("profiles", [(None, None), (cone_receptacle(1.0, 0.5), cone_receptacle(1.0, 0.3)),
                                      (dome_receptacle(1.0, 0.8), None)])
def test_v32_hofmeister_rule(profiles):
    H = _two_level(*profiles)
    ang = hofmeister_angles(H)
    assert len(H.meristems) == 9 and ang.size == 8              # 8 heads, each with elements
    assert ang.max() <= 1e-9


def test_v32_hofmeister_rule_recursive_three_levels():
    H = _three_level()
    levels = np.array([m.level for m in H.meristems])
    assert (levels == 2).sum() >= 10
    ang = hofmeister_angles(H)
    assert ang.size == len(H.meristems) - 1 - sum(m.pattern.n == 0 for m in H.meristems[1:])
    assert ang.max() <= 1e-9


def test_first_element_points_away_from_grandparent_centre():
    H = _two_level()
    for i, m in enumerate(H.meristems[1:], start=1):
        first = H.element_positions(i)[0]
        parent = H.meristems[m.parent].centre
        # as far as possible from the grandparent centre: farther than every other point at that radius
        assert np.linalg.norm(first - parent) >= np.linalg.norm(m.centre - parent)


def test_area_bookkeeping_at_every_level():
    H = _two_level(cone_receptacle(1.0, 0.5))
    for m in H.meristems:
        fr = m.pattern.frame
        assert abs(fr.receptacle.area - fr.total_area) <= 1e-9 * fr.total_area
    root = H.meristems[0].pattern.frame
    for e, c in H.meristems[0].children.items():                 # a sub-head occupies its own surface area
        assert root.area[e] == H.meristems[c].pattern.frame.total_area
    H = _two_level(packing=0.5)
    for e, c in H.meristems[0].children.items():
        child_area = H.meristems[c].pattern.frame.total_area
        assert H.meristems[0].pattern.frame.area[e] == pytest.approx(2 * child_area)


def test_only_last_level_makes_florets_and_fate_per_head():
    H = _two_level(packing=0.4)
    fl = H.florets()
    heads = [i for i, m in enumerate(H.meristems) if m.level == 1]
    assert fl["position"].shape == (40 * len(heads), 3)
    assert set(fl["head"].tolist()) == set(heads)
    assert np.all(fl["birth"] >= 0)
    C = np.array([H.meristems[i].centre for i in heads])
    R = np.array([H.meristems[i].pattern.frame.receptacle.r[-1] for i in heads])
    gap = np.linalg.norm(C[:, None] - C[None], axis=2) - (R[:, None] + R[None])
    assert gap[~np.eye(len(heads), dtype=bool)].min() > 0       # packing 0.4: sub-heads do not overlap
    d = cone_dmin(fl["position"], alpha_deg=53.0, centres=fl["centre"])
    cone = np.bincount(fl["head"][np.isinf(d)], minlength=len(H.meristems))[heads]
    kind, _ = floret_fate(d, th_a=0.2)
    th_a = np.bincount(fl["head"][kind > 0], minlength=len(H.meristems))[heads]
    assert th_a.min() >= 1 and np.all(th_a == th_a[0])     # Th_a: identical heads, identical ray counts (V34)
    r = np.linalg.norm(C[:, :2], axis=1)                   # cone rule alone: neighbours suppress rays, so the
    assert cone[np.argmin(r)] < cone[np.argmax(r)]         # central head has fewer than the peripheral one
    assert cone.sum() < th_a.sum()


def test_deterministic():
    a, b = _three_level().florets(), _three_level().florets()
    assert all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("make, match", [
    (lambda: HierarchicalPhyllotaxis([LevelSpec(), LevelSpec()]), "meristem_area must be set"),
    (lambda: HierarchicalPhyllotaxis([]), "non-empty sequence of LevelSpec"),
    (lambda: LevelSpec(mode="whorl"), "mode must be one of"),
    (lambda: LevelSpec(mode="divergent"), "outer_rate > 0"),
    (lambda: LevelSpec(packing=0.0), "packing must be in"),
    (lambda: LevelSpec(profile="cone"), "profile must be a Receptacle"),
], ids=["meristem_area", "empty", "mode", "outer_rate", "packing", "profile"])
def test_bad_input(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_failed_step_leaves_the_tree_unchanged():
    H = HierarchicalPhyllotaxis(
        [LevelSpec(primordium_area=lambda a: 0.05 * np.exp(0.3 * a), inner_rate=0.05, meristem_area=0.1,
                   max_elements=4),
         LevelSpec(primordium_area=lambda a: 0.01 * (3.0 - a),             # negative from age 3 on
                   inner_rate=0.02, threshold=0.012)],
        inner_area=0.05)
    for _ in range(60):
        before = (H.t, len(H.meristems), [m.pattern.n for m in H.meristems], H.florets()["position"].copy())
        try:
            H.step(0.5)
        except ValueError as err:
            assert "primordium_area" in str(err)
            break
    else:
        pytest.fail("the level-1 area function never failed")
    after = (H.t, len(H.meristems), [m.pattern.n for m in H.meristems], H.florets()["position"])
    assert after[:3] == before[:3] and np.array_equal(after[3], before[3])

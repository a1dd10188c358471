"""Tests for spec 002 §4.2–4.6: Ridley/Vogel placement, fractionation, parastichies, fate (V27–V29, V33)."""
import numpy as np
import pytest

from plantvr.flowers import (
    GOLDEN_ANGLE_DEG,
    centripetal_fractionation,
    cone_receptacle,
    disc_receptacle,
    dome_receptacle,
    floret_fate,
    floret_stage,
    parastichy_numbers,
    place_on_receptacle,
    ray_florets,
    receptacle_from_profile,
    ridley_placement,
    vogel_disc,
)
from plantvr.flowers.fate import LARGE_RAY, SMALL_RAY, cone_dmin

FIB = {1, 2, 3, 5, 8, 13, 21, 34, 55, 89, 144, 233}


def test_v27_disc_reproduces_vogel():
    A = 0.01
    s, _ = ridley_placement(disc_receptacle(1.0), area=A, offset=0.0)
    assert np.max(np.abs(s - np.sqrt(np.arange(s.size) * A / np.pi))) <= 1e-9
    assert s.size == int(np.pi / A) + 1


def test_v27_hemisphere_band_areas_equal_A():
    A = 0.05
    s, _ = ridley_placement(dome_receptacle(1.0, 1.0), area=A, offset=0.0)
    band = np.diff(2 * np.pi * (1 - np.cos(s)))
    assert np.max(np.abs(band - A)) <= 1e-8


def test_v28_divergence_is_137_5():
    _, a = ridley_placement(cone_receptacle(1.0, 0.4), area=0.02)
    d = np.rad2deg(np.diff(a)) % 360.0
    assert np.allclose(d, GOLDEN_ANGLE_DEG, atol=1e-9)


def test_v29_centripetal_fractionation_count():
    s, _, birth = centripetal_fractionation(disc_receptacle(1.0), area=0.05)
    assert s.size == 63                                  # pi R^2 / A = 62.83, first at the rim
    assert s[0] == pytest.approx(1.0) and np.all(np.diff(s) < 0)
    assert np.pi * s[-1] ** 2 < 0.05                     # inner region left < one primordium
    assert np.all(np.diff(birth) > 0)                    # outer = older (phase effect)


def test_place_on_receptacle_normals():
    rec = dome_receptacle(1.0, 1.0)
    s, a = ridley_placement(rec, area=0.05)
    pos, up, right = place_on_receptacle(rec, s, a)
    centre = np.array([0, 0, 0.0])                       # hemisphere centre at rim height
    radial = (pos - centre) / np.linalg.norm(pos - centre, axis=1, keepdims=True)
    assert np.allclose(np.einsum("ij,ij->i", up, radial), 1.0, atol=1e-3)
    assert np.allclose(np.einsum("ij,ij->i", up, right), 0.0, atol=1e-12)
    pos, up, _ = place_on_receptacle(disc_receptacle(), *ridley_placement(disc_receptacle(), area=0.1))
    assert np.allclose(up, [0, 0, 1])


def test_parastichy_numbers_are_fibonacci_and_grow_outward():
    P = vogel_disc(2000)
    inner = parastichy_numbers(P, select=np.arange(100, 200))
    outer = parastichy_numbers(P, select=np.arange(1500, 2000))
    assert set(inner) <= FIB and set(outer) <= FIB
    assert inner == (21, 34)
    assert max(outer) > max(inner)


@pytest.mark.parametrize("n, rays", [(50, 13), (80, 13), (150, 21), (240, 21), (280, 34), (300, 34)])
def test_v33_ray_canalization_vs_n(n, rays):
    assert ray_florets(vogel_disc(n), alpha_deg=75.0).sum() == rays


@pytest.mark.parametrize("alpha, rays", [(30.0, 34), (60.0, 21), (80.0, 13)])
def test_v33_ray_canalization_vs_alpha(alpha, rays):
    assert ray_florets(vogel_disc(82), alpha_deg=alpha).sum() == rays


def test_v33_literal_eq_6_1_gives_no_rays_erratum_a4():
    assert np.isinf(cone_dmin(vogel_disc(150), alpha_deg=75.0, literal=True)).sum() == 0


def test_v35_emergent_counts_gaillardia_and_sunflower():
    # counts are emergent from n and alpha, never assigned
    assert ray_florets(vogel_disc(150, c=0.05), alpha_deg=75.0).sum() == 21
    assert ray_florets(vogel_disc(280, c=0.05), alpha_deg=75.0).sum() == 34


def test_v34_thresholds_size_monotone():
    d = np.array([0.1, 0.4, 0.8, 1.2, 2.0, np.inf])
    kind, size = floret_fate(d, th_a=0.3, th_b=1.5)
    assert list(kind) == [0, SMALL_RAY, SMALL_RAY, SMALL_RAY, LARGE_RAY, LARGE_RAY]
    assert np.all(np.diff(size) >= 0) and size[-1] == 1.0


def test_stage_from_age():
    st = floret_stage(np.array([-1.0, 0.0, 5.0, 10.0, 20.0]), opening_duration=10.0)
    assert list(st) == [0.0, 0.0, 0.5, 1.0, 1.0]


def test_bad_profile_not_function_of_height():
    with pytest.raises(ValueError, match="function of height"):
        receptacle_from_profile([0.0, 0.5, 1.0], [0.0, 0.3, 0.0])
    with pytest.raises(ValueError, match="start on the axis"):
        receptacle_from_profile([0.1, 1.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="area"):
        ridley_placement(disc_receptacle(), area=-1.0)
    with pytest.raises(ValueError, match="alpha_deg"):
        ray_florets(vogel_disc(10), alpha_deg=200.0)

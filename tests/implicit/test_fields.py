"""V1-V2: Wyvill field identities and sign convention (spec 003 §2.1, §2.3)."""
import numpy as np
import pytest

from plantvr.implicit.fields import ISO, WYVILL_A, WYVILL_B, WYVILL_C, blinn, wyvill, wyvill_derivative


@pytest.mark.parametrize("radius", [0.3, 1.0, 7.5])
def test_v1_wyvill_exact(radius):
    assert WYVILL_A == -4 / 9 and WYVILL_B == 17 / 9 and WYVILL_C == -22 / 9
    assert wyvill(0.0, radius) == pytest.approx(1.0, abs=1e-12)
    assert abs(wyvill(radius / 2, radius) - 0.5) < 1e-12
    assert abs(wyvill(radius, radius)) < 1e-12
    assert abs(wyvill_derivative(radius * (1 - 1e-12), radius)) < 1e-9
    assert np.all(wyvill(np.linspace(radius, 10 * radius, 50), radius) == 0.0)
    r = np.linspace(0, radius, 2001)
    assert np.all(np.diff(wyvill(r, radius)) < 0)


def test_v1_rounded_thesis_coefficients_within_2e6():
    a, b, c = -0.44444, 1.888889, -2.44444
    t = 0.25
    assert abs(((a * t + b) * t + c) * t + 1 - 0.5) < 2e-6


def test_wyvill_known_values_and_max_slope():
    # spec §2.3 numbers: f = 0.41 at r/R = 0.5571, 0.40 at 0.5635, 0.1 at 0.7922; max slope 1.583/R near 0.503R
    assert wyvill(0.5571) == pytest.approx(0.41, abs=5e-4)
    assert wyvill(0.5635) == pytest.approx(0.40, abs=5e-4)
    assert wyvill(0.7922) == pytest.approx(0.10, abs=5e-4)
    r = np.linspace(0, 1, 100001)
    slope = wyvill_derivative(r)
    assert -slope.min() == pytest.approx(1.583, abs=2e-3)
    assert r[np.argmin(slope)] == pytest.approx(0.503, abs=2e-3)


def test_derivative_matches_finite_difference():
    r = np.linspace(0.01, 1.5, 300)
    fd = (wyvill(r + 1e-6, 1.3) - wyvill(r - 1e-6, 1.3)) / 2e-6
    assert np.allclose(wyvill_derivative(r, 1.3), fd, atol=1e-6)


def test_v2_sign_convention_inside_is_greater_than_iso():
    from plantvr.implicit import sphere
    s = sphere(radius=2.0)
    f = s.field([[0, 0, 0], [0.99, 0, 0], [1.01, 0, 0]])
    assert f[0] > ISO and f[1] > ISO and f[2] < ISO
    assert s.inside([[0.5, 0, 0]]).tolist() == [True]


def test_bad_radius_names_parameter():
    with pytest.raises(ValueError, match="radius"):
        wyvill(0.1, 0.0)
    with pytest.raises(ValueError, match="a must"):
        blinn(1.0, a=-1)

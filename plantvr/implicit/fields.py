"""Wyvill and Blinn field functions (spec 003_implicit_sca §2.3, C-1).

Fields increase inward; the library-wide inside test is ``F > iso`` with ``iso = 0.5`` (spec §2.1).
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import check_range, check_values

__all__ = ["WYVILL_A", "WYVILL_B", "WYVILL_C", "ISO", "wyvill", "wyvill_from_sq", "wyvill_derivative", "blinn"]

# ERRATUM A.4: the thesis prints rounded coefficients (-0.44444, 1.888889, -2.44444); the exact ones are used.
WYVILL_A = -4.0 / 9.0
WYVILL_B = 17.0 / 9.0
WYVILL_C = -22.0 / 9.0
ISO = 0.5


def wyvill_from_sq(t: np.ndarray) -> np.ndarray:
    """Wyvill polynomial of ``t = r^2 / R^2`` (no square root), zero for ``t >= 1``.

    Parameters
    ----------
    t : ndarray of float64
        Squared normalized distance ``r^2 / R^2``, dimensionless.

    Returns
    -------
    ndarray of float64
        ``((a t + b) t + c) t + 1`` where ``t < 1``, else 0.

    References
    ----------
    .. [1] Kochhar 2010, §3.2 (Wyvill et al. soft objects); spec 003 §2.3, ERRATUM A.4 (exact coefficients).
    """
    t = check_values("t", t, finite=False)          # NaN rows (no preimage) give 0
    f = ((WYVILL_A * t + WYVILL_B) * t + WYVILL_C) * t + 1.0
    return np.where(t < 1.0, f, 0.0)


def wyvill(r: np.ndarray, radius: float = 1.0) -> np.ndarray:
    """Wyvill field ``f(r) = a r^6/R^6 + b r^4/R^4 + c r^2/R^2 + 1`` for ``r <= R``, else 0.

    Parameters
    ----------
    r : ndarray of float64
        Distance from the skeleton, in scene units.
    radius : float
        Radius of influence R > 0; the iso-0.5 surface lies at ``r = R/2``.

    Returns
    -------
    ndarray of float64
        Field values in [0, 1].

    References
    ----------
    .. [1] Kochhar 2010, §3.2; spec 003 §2.3, ERRATUM A.4.

    Examples
    --------
    >>> float(wyvill(0.5, 1.0))
    0.5
    """
    radius = check_range("radius", radius, 1e-100, 1e100)
    r = check_values("r", r)
    with np.errstate(over="ignore"):
        return wyvill_from_sq(np.minimum((r / radius) ** 2, 2.0))


def wyvill_derivative(r: np.ndarray, radius: float = 1.0) -> np.ndarray:
    """Derivative ``df/dr`` of the Wyvill field (zero for ``r >= R``).

    Parameters
    ----------
    r : ndarray of float64
        Distance from the skeleton.
    radius : float
        Radius of influence R > 0.

    Returns
    -------
    ndarray of float64
        ``df/dr``, in 1/scene units.

    References
    ----------
    .. [1] Kochhar 2010, §3.2 (constraint f'(R) = 0).
    """
    radius = check_range("radius", radius, 1e-100, 1e100)
    r = check_values("r", r)
    with np.errstate(over="ignore"):
        t = np.minimum((r / radius) ** 2, 2.0)
    dfdt = (3.0 * WYVILL_A * t + 2.0 * WYVILL_B) * t + WYVILL_C
    return np.where(t < 1.0, dfdt * 2.0 * r / radius**2, 0.0)


def blinn(r: np.ndarray, *, a: float = 1.0, b: float = 1.0) -> np.ndarray:
    """Blinn's blob ``g = b exp(-a r^2)`` (reviewed in the thesis, not used by it; infinite support).

    Parameters
    ----------
    r : ndarray of float64
        Distance from the atom centre.
    a : float
        Fall-off > 0.
    b : float
        Peak value > 0.

    Returns
    -------
    ndarray of float64
        Field values.

    References
    ----------
    .. [1] Kochhar 2010, §3.2 (Blinn).
    """
    a = check_range("a", a, 0.0, np.inf, low_open=True)
    b = check_range("b", b, 0.0, np.inf, low_open=True)
    r = check_values("r", r)
    with np.errstate(over="ignore", under="ignore"):
        return b * np.exp(-a * np.minimum(r**2, 1e300))

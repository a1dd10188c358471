"""Terrain height field (spec 004_treesketch §3.3): a seeded multi-octave smoothed-noise surface, y up."""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter, map_coordinates

from .._validation import check_array, check_int, check_range

__all__ = ["heightfield", "sample_height"]


def heightfield(shape: tuple[int, int] = (128, 128), *, amplitude: float = 5.0, octaves: int = 4,
                rng: int | np.random.Generator | None = None) -> np.ndarray:
    """Return a (nz, nx) float64 height field with values in [0, amplitude].

    Octave k is white noise blurred with sigma = min(nz, nx) / 2^(k+2) cells and weighted 2^-k; the sum is
    rescaled to [0, amplitude] (a flat field when ``amplitude`` is 0).
    """
    nz = check_int("shape[0]", shape[0], 2, 8192)
    nx = check_int("shape[1]", shape[1], 2, 8192)
    amplitude = check_range("amplitude", amplitude, 0.0, 1e6)
    octaves = check_int("octaves", octaves, 1, 12)
    rng = np.random.default_rng(rng)
    h = np.zeros((nz, nx))
    for k in range(octaves):
        sigma = max(min(nz, nx) / 2.0 ** (k + 2), 0.5)
        h += 0.5 ** k * gaussian_filter(rng.standard_normal((nz, nx)), sigma, mode="wrap")
    span = h.max() - h.min()
    return (h - h.min()) / span * amplitude if span > 0 else np.zeros((nz, nx))


def sample_height(hf: np.ndarray, size: tuple[float, float], xz: np.ndarray) -> np.ndarray:
    """Bilinear height at world points ``xz`` (N, 2) on a field covering [0, size[0]] x [0, size[1]] (x, z)."""
    hf = check_array("hf", hf, shape=(None, None))
    sx = check_range("size[0]", size[0], 0.0, np.inf, low_open=True)
    sz = check_range("size[1]", size[1], 0.0, np.inf, low_open=True)
    xz = check_array("xz", xz, shape=(None, 2))
    nz, nx = hf.shape
    cx = np.clip(xz[:, 0] / sx * (nx - 1), 0, nx - 1)
    cz = np.clip(xz[:, 1] / sz * (nz - 1), 0, nz - 1)
    return map_coordinates(hf, [cz, cx], order=1, mode="nearest")



"""Terrain height field (spec 004_treesketch §3.3): a seeded multi-octave smoothed-noise surface (y up), raise /
lower and exclusion brushes, water level, and the placement mask for the distribution."""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter, map_coordinates

from .._validation import MAX_COORD, check_array, check_int, check_range

__all__ = ["brush_height", "brush_mask", "heightfield", "placement_mask", "sample_height"]

#: Largest grid (cells) a terrain or distribution field may have: 8192 x 8192.
MAX_CELLS = 1 << 26


def pair(name: str, value, *, kind: str = "float", low: float = 0.0, high: float = MAX_COORD) -> tuple:
    """``value`` as a checked 2-tuple: floats in (low, high] (``kind="float"``) or ints in [low, high]."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ValueError(f"{name} must be a pair of numbers, got {value!r}")
    if kind == "int":
        return check_int(f"{name}[0]", value[0], int(low), int(high)), check_int(f"{name}[1]", value[1], int(low),
                                                                             int(high))
    return (check_range(f"{name}[0]", value[0], low, high, low_open=True),
            check_range(f"{name}[1]", value[1], low, high, low_open=True))


def check_field(name: str, value, *, shape=(None, None), dtype=np.float64, max_abs: float = MAX_COORD
                ) -> np.ndarray:
    """A non-empty 2-D field (finite, |h| <= ``max_abs`` for floats) of at most :data:`MAX_CELLS` cells."""
    a = check_array(name, value, shape=shape, dtype=dtype, max_abs=max_abs if dtype is np.float64 else None)
    if a.size == 0 or a.size > MAX_CELLS:
        raise ValueError(f"{name} must have between 1 and {MAX_CELLS} cells, got shape {a.shape}")
    return a


def heightfield(shape: tuple[int, int] = (128, 128), *, amplitude: float = 5.0, octaves: int = 4,
                rng: int | np.random.Generator | None = None) -> np.ndarray:
    """Return a (nz, nx) float64 height field with values in [0, amplitude].

    Octave k is white noise blurred with sigma = min(nz, nx) / 2^(k+2) cells and weighted 2^-k; the sum is
    rescaled to [0, amplitude] (a flat field when ``amplitude`` is 0).
    """
    nz, nx = pair("shape", shape, kind="int", low=2, high=8192)
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
    hf = check_field("hf", hf)
    sx, sz = pair("size", size)
    xz = check_array("xz", xz, shape=(None, 2), max_abs=1e12)
    nz, nx = hf.shape
    cx = np.clip(xz[:, 0] / sx * (nx - 1), 0, nx - 1)
    cz = np.clip(xz[:, 1] / sz * (nz - 1), 0, nz - 1)
    return map_coordinates(hf, [cz, cx], order=1, mode="nearest")




def _falloff(shape, size, center, radius):
    nz, nx = shape
    sx, sz = size
    x = np.linspace(0.0, sx, nx)[None, :]
    z = np.linspace(0.0, sz, nz)[:, None]
    u = np.clip(1.0 - np.hypot(x - center[0], z - center[1]) / radius, 0.0, 1.0)
    return u * u * u * (u * (6.0 * u - 15.0) + 10.0)  # the smoothstep of Eq. 6.1


def brush_height(hf: np.ndarray, size: tuple[float, float], center, radius: float, amount: float) -> np.ndarray:
    """Raise (``amount`` > 0) or lower the terrain under a round brush: h += amount * S(1 - d / radius), with the
    smoothstep S of Eq. 6.1 (1 at the centre, 0 from the rim outwards). Returns a new (nz, nx) field (§3.3)."""
    hf = check_field("hf", hf)
    sx, sz = pair("size", size)
    c = check_array("center", center, shape=(2,), max_abs=MAX_COORD)
    radius = check_range("radius", radius, 0.0, MAX_COORD, low_open=True)
    amount = check_range("amount", amount, -1e6, 1e6)
    return hf + amount * _falloff(hf.shape, (sx, sz), c, radius)


def brush_mask(mask: np.ndarray, size: tuple[float, float], center, radius: float, value: bool = True
               ) -> np.ndarray:
    """Paint ``value`` into a (nz, nx) bool mask (e.g. the exclusion brush, §3.3) inside a round brush; new array."""
    mask = check_field("mask", mask, dtype=bool)
    sx, sz = pair("size", size)
    c = check_array("center", center, shape=(2,), max_abs=MAX_COORD)
    radius = check_range("radius", radius, 0.0, MAX_COORD, low_open=True)
    if not isinstance(value, (bool, np.bool_, int, np.integer)) or value not in (0, 1):
        raise ValueError(f"value must be True or False, got {value!r}")
    out = mask.copy()
    out[_falloff(mask.shape, (sx, sz), c, radius) > 0] = bool(value)
    return out


def placement_mask(hf: np.ndarray, *, water_level: float = -np.inf, excluded: np.ndarray | None = None,
                   shape: tuple[int, int] | None = None) -> np.ndarray:
    """Cells where trees may be placed: above ``water_level`` and not ``excluded`` (§3.3, §3.4.3), resampled by
    nearest cell centre to ``shape`` (the distribution field's (ny, nx)) when given."""
    hf = check_field("hf", hf)
    if not (isinstance(water_level, (int, float, np.integer, np.floating)) and water_level == -np.inf):
        water_level = check_range("water_level", water_level, -1e12, 1e12)
    ok = hf >= float(water_level)
    if excluded is not None:
        ok &= ~check_array("excluded", excluded, shape=hf.shape, dtype=bool)
    if shape is None:
        return ok
    ny, nx = pair("shape", shape, kind="int", low=1, high=8192)
    iy = np.minimum(((np.arange(ny) + 0.5) / ny * ok.shape[0]).astype(int), ok.shape[0] - 1)
    ix = np.minimum(((np.arange(nx) + 0.5) / nx * ok.shape[1]).astype(int), ok.shape[1] - 1)
    return ok[np.ix_(iy, ix)]

"""Procedural bark and leaf textures made by the project itself (spec 000_treewand §3.3, §3.4; B.2 selectors).

Images are RGBA uint8 arrays, row 0 at the top (v = 1), tileable in both directions for bark, with an alpha
mask for leaves (the stem texel at the bottom centre colours the petioles). They are deterministic.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy import ndimage

from plantvr._validation import check_choice, check_int

__all__ = ["BARK_TEXTURES", "LEAF_TEXTURES", "bark_texture", "leaf_texture"]

BARK_TEXTURES = ("furrowed", "birch")
LEAF_TEXTURES = ("ovate", "lobed")


def bark_texture(name: str = "furrowed", size: int = 256) -> np.ndarray:
    """Tileable bark image (B.2 "Bark texture select").

    Parameters
    ----------
    name : {"furrowed", "birch"}
        Dark ridged bark with vertical furrows, or white bark with dark horizontal lenticels.
    size : int
        Width and height in pixels, in [16, 2048].

    Returns
    -------
    (size, size, 4) uint8 ndarray
        Read-only; alpha is 255.
    """
    check_choice("name", name, BARK_TEXTURES)
    size = check_int("size", size, 16, 2048)
    return _bark(name, size)


@lru_cache(maxsize=8)
def _bark(name, size):
    rng = np.random.default_rng(4 if name == "furrowed" else 5)
    noise = rng.random((size, size))
    if name == "furrowed":
        ridges = ndimage.gaussian_filter(noise, (size / 10, size / 90), mode="wrap")     # long along v (rows)
        ridges = (ridges - ridges.min()) / np.ptp(ridges)
        fine = ndimage.gaussian_filter(noise, 1.0, mode="wrap")
        x = np.clip(0.55 * ridges + 0.45 * (fine - fine.min()) / np.ptp(fine), 0, 1)
        furrow = np.clip((x - 0.35) * 3, 0, 1)
        rgb = np.stack([70 + 70 * furrow, 48 + 45 * furrow, 30 + 30 * furrow], axis=-1)
    else:
        base = ndimage.gaussian_filter(noise, 2.0, mode="wrap")
        base = (base - base.min()) / np.ptp(base)
        lent = ndimage.gaussian_filter(rng.random((size, size)), (size / 200, size / 20), mode="wrap")
        lent = (lent - lent.min()) / np.ptp(lent)
        dark = np.clip((lent - 0.72) * 6, 0, 1)
        shade = 215 + 30 * base
        rgb = np.stack([shade, shade - 5, shade - 15], axis=-1) * (1 - dark[..., None]) + 40 * dark[..., None]
    img = np.concatenate([np.clip(rgb, 0, 255), np.full((size, size, 1), 255.0)], axis=-1).astype(np.uint8)
    img.flags.writeable = False
    return img


def leaf_texture(name: str = "ovate", size: int = 256) -> np.ndarray:
    """Leaf image with an alpha mask (B.2 "Leaf texture select"); pairs with the blade of the same name.

    Parameters
    ----------
    name : {"ovate", "lobed"}
        An elliptic leaf with a midrib and veins, or a five-lobed (maple-like) leaf.
    size : int
        Width and height in pixels, in [16, 2048].

    Returns
    -------
    (size, size, 4) uint8 ndarray
        Read-only. The blade spans v in [0.08, 1]; a stem runs from the bottom centre (v = 0) to the blade.
    """
    check_choice("name", name, LEAF_TEXTURES)
    size = check_int("size", size, 16, 2048)
    return _leaf(name, size)


@lru_cache(maxsize=8)
def _leaf(name, size):
    yy, xx = np.mgrid[0:size, 0:size]
    x = (xx + 0.5) / size - 0.5                       # [-0.5, 0.5]
    v = 1.0 - (yy + 0.5) / size                       # v = 1 at the top row
    b = (v - 0.08) / 0.92                             # blade coordinate, 0 at the base
    if name == "ovate":
        half = 0.46 * np.sin(np.pi * np.clip(b, 0, 1)) ** 0.8 * (1 - 0.35 * b)
        inside = (np.abs(x) < half) & (b >= 0) & (b <= 1)
    else:
        cy = 0.45
        ang = np.arctan2(x, b - cy)
        rad = np.hypot(x, b - cy)
        lobes = 0.30 + 0.18 * np.abs(np.cos(2.5 * ang)) ** 2
        inside = (rad < lobes) & (b >= 0) & (b <= 1) & (np.abs(ang) < 0.92 * np.pi)
    vein = np.exp(-(x / 0.012) ** 2)
    side = np.exp(-((np.abs(x) * 0.8 - (b - 0.1) % 0.16 + 0.08) / 0.01) ** 2) * 0.5
    g = np.clip(0.55 + 0.2 * b - 0.25 * vein - 0.15 * side, 0, 1)
    rgb = np.stack([60 * g + 25, 150 * g + 40, 40 * g + 15], axis=-1)
    stem = (np.abs(x) < 0.025) & (v < 0.12)
    alpha = np.where(inside | stem, 255, 0)
    rgb = np.where(stem[..., None] & ~inside[..., None], np.array([70, 110, 40]), rgb)
    img = np.concatenate([np.clip(rgb, 0, 255), alpha[..., None]], axis=-1).astype(np.uint8)
    img.flags.writeable = False
    return img

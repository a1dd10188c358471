"""Small procedural icons for the bark and leaf texture selectors (spec 000_treewand §4.8).

Each icon is a PNG (bytes) of the texture the geometry package renders with
(:mod:`plantvr.geometry.textures`); a choice it does not know gets a deterministic procedural stand-in.
"""
from __future__ import annotations

import io
import zlib
from functools import lru_cache

import numpy as np

__all__ = ["icon_png"]


def _png(rgba: np.ndarray) -> bytes:
    """Encode an (H, W, 4) uint8 image as PNG (zlib, no dependency)."""
    h, w, _ = rgba.shape
    raw = b"".join(b"\x00" + rgba[i].tobytes() for i in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        c = tag + data
        return len(data).to_bytes(4, "big") + c + zlib.crc32(c).to_bytes(4, "big")

    hdr = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([8, 6, 0, 0, 0])
    out = io.BytesIO()
    out.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", hdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    return out.getvalue()


@lru_cache(maxsize=64)
def icon_png(param: str, choice: str, index: int = 0, size: int = 48) -> bytes:
    """PNG icon for ``choice`` of the texture parameter ``param`` (``"bark_texture"`` or ``"leaf_texture"``).

    Parameters
    ----------
    param : str
        Parameter name; its prefix (``bark``/``leaf``) picks the kind of icon.
    choice : str
        The texture name, e.g. ``"birch"``.
    index : int
        Position of the choice (seeds the stand-in pattern).
    size : int
        Pixels per side.
    """
    kind = "bark" if param.startswith("bark") else "leaf"
    try:
        from plantvr.geometry import textures  # noqa: PLC0415
        make = textures.bark_texture if kind == "bark" else textures.leaf_texture
        return _png(np.ascontiguousarray(make(choice, size)))
    except (ImportError, ValueError):
        pass
    k = int(index)
    rng = np.random.default_rng(k + (0 if kind == "bark" else 100))
    y, x = np.mgrid[0:size, 0:size] / size
    img = np.zeros((size, size, 4), np.float64)
    if kind == "bark":
        base = np.array([[110, 72, 40], [150, 130, 110], [80, 60, 50]][k % 3], float)
        freq = 6 + 4 * k
        stripes = 0.5 + 0.5 * np.sin(2 * np.pi * (x * freq + 0.3 * np.sin(2 * np.pi * y * (1 + k))))
        noise = rng.random((size, size))
        shade = 0.6 + 0.3 * stripes + 0.1 * noise
        img[..., :3] = base * shade[..., None]
        img[..., 3] = 255
    else:
        green = np.array([[60, 150, 60], [110, 170, 40], [40, 110, 70]][k % 3], float)
        u, v = x - 0.5, y - 0.5
        shapes = [(u / 0.22) ** 2 + (v / 0.42) ** 2, (np.abs(u) / 0.38) ** 1.5 + (np.abs(v) / 0.38) ** 1.5,
                  (u / 0.12) ** 2 + (v / 0.45) ** 2]
        inside = shapes[k % 3] <= 1.0
        vein = np.abs(u) < 0.015
        img[..., :3] = np.where(vein[..., None], green * 0.6, green)
        img[..., 3] = np.where(inside, 255, 0)
    return _png(np.clip(img, 0, 255).astype(np.uint8))

"""Thumbnails of grown trees and a captioned grid of a parameter sweep (spec 000_treewand §4.11, §6.1): each tree
is the lossless ``state`` bytes :func:`plantvr.documents.sweep.grow_variant` returns, rendered offscreen by
:class:`plantvr.View`."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from .._validation import check_size
from ..params import PARAM_BY_NAME

__all__ = ["thumbnail", "thumbnail_grid"]


def _size(size) -> tuple[int, int]:
    return check_size("size", size, 16, 4096)


def thumbnail(state: bytes, *, size: tuple[int, int] = (200, 200), leaves: bool = True) -> np.ndarray:
    """Render one tree (the ``state`` bytes of :func:`plantvr.documents.sweep.grow_variant`) offscreen.

    Returns
    -------
    (H, W, 3) uint8 ndarray
    """
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    from ..documents.treewand import Model
    from . import View
    if not isinstance(state, (bytes, bytearray)) or not state:
        raise ValueError("state must be the non-empty .npz bytes of grow_variant")
    size = _size(size)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "tree.npz"
        path.write_bytes(state)
        model = Model.load(path)
    view = View(model, off_screen=True, window_size=size, show_leaves=leaves)
    try:
        markers = view.plotter.actors.get("markers")
        if markers is not None:  # the tree only
            markers.SetVisibility(False)
        view.frame()
        return np.asarray(view.screenshot())[..., :3].copy()
    finally:
        view.close()


def _caption_font():
    """A TrueType font with Greek letters (DejaVu Sans, from the system or matplotlib) and whether it has them;
    else Pillow's default bitmap font, with parameter names instead of symbols."""
    from PIL import ImageFont
    candidates = ["DejaVuSans.ttf"]
    try:
        import matplotlib
        candidates.append(str(Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"))
    except ImportError:
        pass
    for c in candidates:
        try:
            return ImageFont.truetype(c, 12), True
        except OSError:
            continue
    return ImageFont.load_default(), False


def thumbnail_grid(table, rows: str, cols: str, *, size: tuple[int, int] = (200, 200),
                   metric: str | None = "internodes") -> np.ndarray:
    """Thumbnails of a :func:`sweep` table laid out with ``rows`` down and ``cols`` across, each captioned
    with its two parameter values (and ``metric``).

    Returns
    -------
    (H, W, 3) uint8 ndarray
    """
    from PIL import Image, ImageDraw
    size = _size(size)
    for name in (rows, cols) + ((metric,) if metric else ()):
        if name not in table.columns:
            raise ValueError(f"{name!r} must be a column of the sweep table, got {list(table.columns)}")
    rv, cv = sorted(table[rows].unique()), sorted(table[cols].unique())
    w, h = int(size[0]), int(size[1])
    band = 34 if metric else 18  # white caption strip above each picture

    font, greek = _caption_font()

    def short(name: str) -> str:
        p = PARAM_BY_NAME.get(name)
        return p.symbol if greek and p is not None and p.symbol else name

    out = np.full((len(rv) * (h + band), len(cv) * w, 3), 255, np.uint8)
    for _, r in table.iterrows():
        i, j = rv.index(r[rows]), cv.index(r[cols])
        tile = Image.new("RGB", (w, h + band), "white")
        tile.paste(Image.fromarray(thumbnail(r["state"], size=(w, h))), (0, band))
        caption = f"{short(rows)} = {r[rows]:.3g}   {short(cols)} = {r[cols]:.3g}"
        if metric:
            caption += f"\n{metric} = {r[metric]:.3g}"
        ImageDraw.Draw(tile).multiline_text((4, 2), caption, fill=(20, 20, 20), font=font)
        out[i * (h + band):(i + 1) * (h + band), j * w:(j + 1) * w] = np.asarray(tile)
    return out

"""Editable colour table with per-colour visibility (spec 000_vine §2.4.2, §2.6; checklist items 13, 17).

Labels are one uint8 per vertex indexing this table; recolouring edits only the table.
"""
from __future__ import annotations

import math

import numpy as np

from plantvr._validation import check_array, check_int, check_range

__all__ = ["DEAD_ZONE", "DEFAULT_PALETTE", "ColorTable", "slice_at"]

#: 12 wheel colours plus index 0 = unpainted grey (spec §2.4.1 [INFERRED] 12 slices + unpainted).
DEFAULT_PALETTE = np.array([
    [190, 190, 190], [139, 90, 43], [220, 40, 40], [240, 200, 30], [60, 170, 60], [255, 140, 0],
    [40, 110, 220], [160, 70, 200], [0, 190, 190], [230, 100, 170], [120, 200, 90], [110, 110, 30],
    [250, 250, 250]], np.uint8)


class ColorTable:
    """Up to 256 RGBA colours, each with a visibility flag.

    Parameters
    ----------
    colors : (N, 3) or (N, 4) uint8 array-like, optional
        Initial colours, N in [1, 256]; default :data:`DEFAULT_PALETTE`.
    """

    def __init__(self, colors=None):
        if colors is None:
            colors = DEFAULT_PALETTE
        try:
            c = np.asarray(colors)
        except (TypeError, ValueError):
            raise ValueError(f"colors must be an (N, 3) or (N, 4) uint8 array, got {type(colors).__name__}") from None
        if c.ndim != 2 or c.shape[1] not in (3, 4) or not 1 <= c.shape[0] <= 256:
            raise ValueError(f"colors must have shape (N, 3) or (N, 4) with N in [1, 256], got {c.shape}")
        if c.dtype.kind not in "iu":
            raise ValueError(f"colors must be integers in [0, 255] (uint8), got dtype {c.dtype}")
        if c.min() < 0 or c.max() > 255:
            raise ValueError(f"colors must be in [0, 255], got range [{c.min()}, {c.max()}]")
        self.rgba = np.full((c.shape[0], 4), 255, np.uint8)
        self.rgba[:, :c.shape[1]] = c
        self.visible = np.ones(c.shape[0], bool)
        self.version = 0

    def __len__(self) -> int:
        return self.rgba.shape[0]

    def check_label(self, name: str, label) -> int:
        """Validate a label index against this table."""
        return check_int(name, label, 0, len(self) - 1)

    @staticmethod
    def check_rgb(name: str, rgb) -> np.ndarray:
        """Validate a colour: 3 or 4 integer components in [0, 255] (RGB or RGBA); returns them as uint8.

        Non-integral components (``200.7``) are refused rather than rounded, out-of-range ones rather than
        clamped.
        """
        if isinstance(rgb, (str, bytes)):
            raise ValueError(f"{name} must be 3 or 4 integers in [0, 255], got {rgb!r}")
        try:
            c = check_array(name, rgb, shape=(None,), dtype=np.float64)
        except ValueError:
            raise ValueError(f"{name} must be 3 or 4 integers in [0, 255], got {rgb!r}") from None
        if c.shape[0] not in (3, 4):
            raise ValueError(f"{name} must be 3 or 4 integers in [0, 255], got {c.shape[0]} values")
        bad = [float(x) for x in c if not (0 <= x <= 255 and float(x).is_integer())]
        if bad:
            raise ValueError(f"{name} components must be integers in [0, 255], got {[float(x) for x in c]} "
                             f"(bad: {bad})")
        return c.astype(np.uint8)

    def set_color(self, label: int, rgb) -> None:
        """Recolour one entry (indices untouched)."""
        label = self.check_label("label", label)
        c = self.check_rgb("rgb", rgb)
        self.rgba[label, :c.shape[0]] = c
        self.version += 1

    def add_color(self, rgb) -> int:
        """Append a colour; returns its label."""
        if len(self) >= 256:
            raise ValueError("colour table is full (256 entries, one uint8 per vertex)")
        c = self.check_rgb("rgb", rgb)
        row = np.full((1, 4), 255, np.uint8)
        row[0, :c.shape[0]] = c
        self.rgba = np.vstack([self.rgba, row])
        self.visible = np.append(self.visible, True)
        self.version += 1
        return len(self) - 1

    def set_visible(self, label: int, visible: bool) -> None:
        """Show or hide every vertex of one colour."""
        label = self.check_label("label", label)
        if not isinstance(visible, (bool, np.bool_)):
            raise ValueError(f"visible must be True or False, got {visible!r}")
        self.visible[label] = bool(visible)
        self.version += 1

    def paintable_lut(self) -> np.ndarray:
        """(256,) bool: True for labels that may be painted over (visible ones)."""
        lut = np.zeros(256, bool)
        lut[:len(self)] = self.visible
        return lut

    def colors_of(self, labels: np.ndarray) -> np.ndarray:
        """(V, 4) uint8 colours for a label array (gather through the table)."""
        return self.rgba[labels]

    def copy(self) -> ColorTable:
        """Independent copy."""
        t = ColorTable(self.rgba)
        t.visible = self.visible.copy()
        t.version = self.version
        return t


#: Thumb radius (wheel units) below which the slice is ambiguous and the last one is kept (§2.4.1 [INFERRED]).
DEAD_ZONE = 0.15


def slice_at(x: float, y: float, n_slices: int, last: int = 0) -> int:
    """Slice under a thumb/mouse position on the unit wheel (y up, counter-clockwise from +x).

    ``k = floor((atan2(y, x) mod 2π) / (2π / K))``; within :data:`DEAD_ZONE` of the centre ``last`` is kept.

    Parameters
    ----------
    x, y : float
        Position in wheel units (radius 1).
    n_slices : int
        K, the number of slices (colour-table entries), >= 1.
    last : int
        Slice returned in the dead zone.

    Returns
    -------
    int
        Slice index in [0, K).

    References
    ----------
    .. [1] spec 000_vine §2.4.1 (slice index [INFERRED]).
    """
    x, y = check_range("x", x, -math.inf, math.inf), check_range("y", y, -math.inf, math.inf)
    n_slices = check_int("n_slices", n_slices, 1, 256)
    last = check_int("last", last, 0, n_slices - 1)
    if math.hypot(x, y) < DEAD_ZONE:
        return last
    return min(int((math.atan2(y, x) % (2 * math.pi)) / (2 * math.pi / n_slices)), n_slices - 1)

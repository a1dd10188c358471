"""Editable colour table with per-colour visibility (spec 000_vine §2.4.2, §2.6; checklist items 13, 17).

Labels index this table, one uint8 per vertex while it has at most 256 entries and one uint16 per vertex once a
segmentation widens it (up to 65536 entries, e.g. a confocal stack with 918 cells, issue 22); recolouring edits
only the table.
"""
from __future__ import annotations

import colorsys
import math

import numpy as np

from plantvr._validation import check_array, check_int, check_range

__all__ = ["DEAD_ZONE", "DEFAULT_PALETTE", "MAX_COLORS", "NARROW_COLORS", "ColorTable", "distinct_color", "label_dtype",
           "slice_at"]

#: 12 wheel colours plus index 0 = unpainted grey (spec §2.4.1 [INFERRED] 12 slices + unpainted).
DEFAULT_PALETTE = np.array([
    [190, 190, 190], [139, 90, 43], [220, 40, 40], [240, 200, 30], [60, 170, 60], [255, 140, 0],
    [40, 110, 220], [160, 70, 200], [0, 190, 190], [230, 100, 170], [120, 200, 90], [110, 110, 30],
    [250, 250, 250]], np.uint8)

#: Entries a table of uint8 labels can hold (one byte per vertex, spec §2.4.2).
NARROW_COLORS = 256
#: Entries a table of uint16 labels can hold (issue 22).
MAX_COLORS = 65536


def label_dtype(n_colors: int) -> np.dtype:
    """The label dtype a table of ``n_colors`` entries needs: uint8 up to 256 entries, uint16 up to 65536."""
    n_colors = check_int("n_colors", n_colors, 1, MAX_COLORS)
    return np.dtype(np.uint8 if n_colors <= NARROW_COLORS else np.uint16)


def distinct_color(k: int) -> tuple[int, int, int]:
    """A saturated colour for the k-th table entry (golden-ratio hue steps, so neighbours differ)."""
    k = check_int("k", k, 0, 2 ** 62)
    h = (0.11 + k * 0.618033988749895) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, 0.55 + 0.35 * ((k * 7) % 3) / 2, 0.95 - 0.2 * (k % 2))
    return round(255 * r), round(255 * g), round(255 * b)


class ColorTable:
    """RGBA colours, each with a visibility flag: up to 256 (uint8 labels) or, once wide, 65536 (uint16 labels).

    Parameters
    ----------
    colors : (N, 3) or (N, 4) uint8 array-like, optional
        Initial colours, N in [1, 65536]; default :data:`DEFAULT_PALETTE`. A table of more than 256 colours is
        wide from the start.
    wide : bool
        Let :meth:`add_color` grow the table past 256 entries (the labels it serves are uint16).

    Attributes
    ----------
    capacity : int
        Most entries :meth:`add_color` grows the table to: 256, or 65536 when wide.
    """

    def __init__(self, colors=None, *, wide: bool = False):
        if colors is None:
            colors = DEFAULT_PALETTE
        try:
            c = np.asarray(colors)
        except (TypeError, ValueError):
            raise ValueError(f"colors must be an (N, 3) or (N, 4) uint8 array, got {type(colors).__name__}") from None
        if c.ndim != 2 or c.shape[1] not in (3, 4) or not 1 <= c.shape[0] <= MAX_COLORS:
            raise ValueError(f"colors must have shape (N, 3) or (N, 4) with N in [1, {MAX_COLORS}], got {c.shape}")
        if not isinstance(wide, (bool, np.bool_)):
            raise ValueError(f"wide must be True or False, got {wide!r:.80}")  # noqa: TRY004
        if c.dtype.kind not in "iu":
            raise ValueError(f"colors must be integers in [0, 255] (uint8), got dtype {c.dtype}")
        if c.min() < 0 or c.max() > 255:
            raise ValueError(f"colors must be in [0, 255], got range [{c.min()}, {c.max()}]")
        self.rgba = np.full((c.shape[0], 4), 255, np.uint8)
        self.rgba[:, :c.shape[1]] = c
        self.visible = np.ones(c.shape[0], bool)
        self.version = 0
        self.capacity = MAX_COLORS if wide or c.shape[0] > NARROW_COLORS else NARROW_COLORS

    @classmethod
    def with_size(cls, n: int) -> ColorTable:
        """A table of ``n`` entries: :data:`DEFAULT_PALETTE` then :func:`distinct_color` ones (n in [1, 65536])."""
        n = check_int("n", n, 1, MAX_COLORS)
        rgb = np.array([distinct_color(k) for k in range(len(DEFAULT_PALETTE), n)], np.uint8).reshape(-1, 3)
        return cls(np.vstack([DEFAULT_PALETTE, rgb])[:n])

    @property
    def wide(self) -> bool:
        """True when the table may hold more than 256 entries (its labels are uint16)."""
        return self.capacity > NARROW_COLORS

    def widen(self) -> None:
        """Let the table grow to 65536 entries (the labels it serves become uint16); idempotent."""
        self.capacity = MAX_COLORS

    @property
    def label_dtype(self) -> np.dtype:
        """uint8 for a narrow table, uint16 for a wide one."""
        return np.dtype(np.uint16 if self.wide else np.uint8)

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
        if len(self) >= self.capacity:
            raise ValueError(f"colour table is full ({self.capacity} entries, one "
                             f"{self.label_dtype.name} per vertex)")
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
        """(256,) bool, or (65536,) for a wide table: True for labels that may be painted over (visible ones)."""
        lut = np.zeros(self.capacity, bool)
        lut[:len(self)] = self.visible
        return lut

    def colors_of(self, labels: np.ndarray) -> np.ndarray:
        """(V, 4) uint8 colours for a label array (gather through the table)."""
        return self.rgba[labels]

    def copy(self) -> ColorTable:
        """Independent copy."""
        t = ColorTable(self.rgba, wide=self.wide)
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

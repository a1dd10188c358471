"""SVG controls of the ViNE review page (spec 000_vine §2.4.1, §2.6; issue 22).

The iso-value slider's range and the volume histogram drawn above it, and the colour wheel: its geometry
(:data:`WHEEL_RADIUS`, :func:`wheel_geometry`) and its SVG (:func:`wheel_svg`), re-sent by
:class:`~plantvr.view.vine_app.VineReviewApp` when the selection, a colour or a visibility changes.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import check_array, check_int, check_range
from plantvr.vine.colors import DEAD_ZONE

__all__ = ["WHEEL_RADIUS", "histogram_svg", "wheel_geometry", "wheel_svg"]


def _level_slider(volume: np.ndarray) -> dict:
    """``min``, ``max`` and ``step`` of the iso-value slider, from the data's range in its own units (issue 22):
    integer volumes step by 1 between ``min + 0.5`` and ``max - 0.5`` (no level equals a voxel value), float
    volumes in 1000 steps strictly inside (min, max), so every position gives a surface."""
    from plantvr.vine.volume import _data_range
    volume, lo, hi = _data_range("volume", volume)
    if volume.dtype.kind in "iu":
        return {"min": lo + 0.5, "max": max(lo + 0.5, hi - 0.5), "step": 1}
    step = (hi - lo) / 1000 if hi > lo else 1.0
    return {"min": lo + step, "max": max(lo + step, hi - step), "step": step}


def histogram_svg(volume: np.ndarray, level: float, *, bins: int = 64, width: int = 260, height: int = 48) -> str:
    """A small SVG bar chart of a volume's intensity histogram (log counts) with the iso-value as a red line."""
    from plantvr.vine.volume import histogram
    counts, edges = histogram(volume, bins=bins)
    c = np.log1p(np.asarray(counts, np.float64))
    c = c / max(c.max(), 1e-9)
    w = width / len(c)
    bars = "".join(f'<rect x="{i * w:.1f}" y="{height * (1 - h):.1f}" width="{max(w - 0.5, 0.5):.1f}" '
                   f'height="{height * h:.1f}" fill="#8aa"/>' for i, h in enumerate(c))
    x = width * (float(level) - float(edges[0])) / max(float(edges[-1] - edges[0]), 1e-9)
    return (f'<svg class="vine-histogram" width="{width}" height="{height}" style="background:#223">{bars}'
            f'<line x1="{x:.1f}" x2="{x:.1f}" y1="0" y2="{height}" stroke="#f33" stroke-width="2"/></svg>')


#: Wheel radius in CSS pixels; the selected slice is raised by a sixth of it, with a margin around.
WHEEL_RADIUS = 72.0


def wheel_geometry(radius: float) -> tuple[float, float]:
    """(raise, centre) in px of a wheel of ``radius`` px in [8, 1000]: the selected slice reaches
    ``radius + raise``; the wheel's square box has side ``2 * centre``."""
    radius = check_range("radius", radius, 8.0, 1000.0)
    lift = radius / 6.0
    return lift, radius + lift + 6.0


def _ink(rgb) -> str:
    """Black or white, whichever contrasts with ``rgb`` (luma 0.299/0.587/0.114)."""
    r, g, b = (float(v) for v in rgb[:3])
    return "#000" if 0.299 * r + 0.587 * g + 0.114 * b > 140 else "#fff"


def wheel_svg(rgba, visible, selected: int, *, radius: float = WHEEL_RADIUS) -> str:
    """The colour wheel as an SVG string (spec 000_vine §2.4.1, §2.6; Fig. 5.9, 5.11).

    Slice ``k`` spans angles ``[k, k + 1) * 2π / K`` counter-clockwise from +x (y up), the rule of
    :func:`plantvr.vine.colors.slice_at`. The selected slice is drawn last, raised by ``radius / 6`` and outlined;
    a hidden colour keeps its slice, crossed by five contrasting radial lines. Each slice is a ``<g>`` with
    ``data-index``, class ``wheel-slice`` and, where they apply, ``selected`` and ``hidden``.

    Parameters
    ----------
    rgba : (K, 3 or 4) uint8 array_like
        The colour table, K in [1, 256].
    visible : (K,) bool array_like
        Visibility per colour.
    selected : int
        The active label, in [0, K).
    radius : float
        Wheel radius in px, in [8, 1000].

    Returns
    -------
    str
        ``<svg class="vine-wheel-svg" ...>`` of side ``2 * (radius + radius / 6 + 6)`` px.

    References
    ----------
    .. [1] spec 000_vine §2.4.1 (wheel, slice index [INFERRED]) and §2.6 (hidden colours: radial lines).
    """
    c = np.asarray(rgba)
    if c.ndim != 2 or c.shape[1] not in (3, 4) or not 1 <= c.shape[0] <= 256:
        raise ValueError(f"rgba must have shape (K, 3) or (K, 4) with K in [1, 256], got {c.shape}")
    c = check_array("rgba", c, shape=(None, c.shape[1]), dtype=np.float64)
    if np.any(c < 0) or np.any(c > 255):
        raise ValueError("rgba must be in [0, 255]")
    n = c.shape[0]
    vis = check_array("visible", visible, shape=(n,), dtype=bool)
    selected = check_int("selected", selected, 0, n - 1)
    radius = check_range("radius", radius, 8.0, 1000.0)
    lift, cen = wheel_geometry(radius)
    da = 2 * np.pi / n

    def xy(r, a):
        return cen + r * np.cos(a), cen - r * np.sin(a)

    def pt(r, a):
        return "{:.2f} {:.2f}".format(*xy(r, a))

    parts = []
    for k in [k for k in range(n) if k != selected] + [selected]:        # the selection on top
        sel, hid = k == selected, not vis[k]
        r, a0, a1 = (radius + lift if sel else radius), k * da, (k + 1) * da
        fill = "rgb({},{},{})".format(*(round(v) for v in c[k, :3]))
        if n == 1:
            d = (f"M {cen - r:.2f} {cen:.2f} a {r:.2f} {r:.2f} 0 1 0 {2 * r:.2f} 0 "
                 f"a {r:.2f} {r:.2f} 0 1 0 {-2 * r:.2f} 0")
        else:
            d = f"M {cen:.2f} {cen:.2f} L {pt(r, a0)} A {r:.2f} {r:.2f} 0 {int(da > np.pi)} 0 {pt(r, a1)} Z"
        cls = "wheel-slice" + (" selected" if sel else "") + (" hidden" if hid else "")
        g = [f'<g class="{cls}" data-index="{k}">',
             (f'<path d="{d}" fill="{fill}" stroke="{"#111" if sel else "#fff"}" '
              f'stroke-width="{3 if sel else 1}" stroke-linejoin="round"/>')]
        ink = _ink(c[k])
        if hid:                                                            # §2.6: radial lines across the slice
            for i in range(1, 6):
                a = a0 + i / 6 * da
                (x1, y1), (x2, y2) = xy(0.25 * r, a), xy(0.97 * r, a)
                g.append(f'<line class="wheel-hidden-line" x1="{x1:.2f}" y1="{y1:.2f}" x2="{x2:.2f}" '
                         f'y2="{y2:.2f}" stroke="{ink}" stroke-width="2"/>')
        tx, ty = xy(0.7 * r, a0 + da / 2)
        g.append(f'<text x="{tx:.2f}" y="{ty + 4:.2f}" text-anchor="middle" font-size="11" '
                 f'font-family="sans-serif" fill="{ink}" pointer-events="none">{k}</text></g>')
        parts.append("".join(g))
    side = 2 * cen
    return (f'<svg class="vine-wheel-svg" xmlns="http://www.w3.org/2000/svg" width="{side:.0f}" '
            f'height="{side:.0f}" viewBox="0 0 {side:.0f} {side:.0f}" style="display:block">{"".join(parts)}'
            f'<circle cx="{cen:.2f}" cy="{cen:.2f}" r="{DEAD_ZONE * radius:.2f}" fill="#2a2a30" stroke="#888"/>'
            "</svg>")

"""Colour wheel: slices of a label colour table, selection, hidden colours with radial lines
(spec 000_vine §2.4.1 [T §5.4.1, Fig. 5.9] and §2.6 [T §5.6, Fig. 5.11]).

The widget holds a generic colour table as synced traits (``colors`` hex strings, ``hidden`` flags,
``selected`` index). A click selects a slice; a shift-click (the trackpad press) toggles that colour's
visibility; a colour picker edits the selected colour. :meth:`ColorWheel.link` binds it to a
segmentation by duck typing: any document with ``colors.rgba`` ``(N, 3|4)``, ``colors.visible`` ``(N,)``,
``set_color(label, rgb)``, ``set_visible(label, visible)`` and ``on``/``off`` change events (as
:class:`plantvr.documents.labels.Segmentation`), or any ``HasTraits`` with ``colors``/``hidden`` traits.
"""
from __future__ import annotations


import anywidget
import numpy as np
import traitlets

from .._validation import check_int
from ..vine.colors import slice_at
from ._assets import asset
from ._sync import SyncGuard

__all__ = ["slice_at", "hex_to_rgb", "rgb_to_hex", "ColorWheel"]

def rgb_to_hex(rgb) -> str:
    """``(r, g, b)`` in [0, 255] → ``"#rrggbb"``."""
    try:
        c = np.asarray(rgb, dtype=float)
    except (TypeError, ValueError):
        c = np.zeros(0)
    c = c[:3] if c.shape in ((3,), (4,)) else np.zeros(0)      # RGB or RGBA, nothing nested
    if c.shape != (3,) or not np.all((c >= 0) & (c <= 255)):  # NaN fails too
        raise ValueError(f"rgb must be 3 values in [0, 255], got {rgb!r}")
    return "#" + "".join(f"{int(round(v)):02x}" for v in c)


def hex_to_rgb(color: str) -> tuple[int, int, int]:
    """``"#rrggbb"`` → ``(r, g, b)``; anything else raises ``ValueError``."""
    s = str(color)
    if len(s) != 7 or s[0] != "#":
        raise ValueError(f"color must be '#rrggbb', got {color!r}")
    try:
        return tuple(int(s[i:i + 2], 16) for i in (1, 3, 5))
    except ValueError:
        raise ValueError(f"color must be '#rrggbb', got {color!r}") from None


class ColorWheel(anywidget.AnyWidget):
    """Colour-wheel widget over a label colour table (spec 000_vine §2.4.1, §2.6).

    Parameters
    ----------
    colors : list of str, optional
        ``"#rrggbb"`` per label (default: a 13-entry table is expected from :meth:`link`).
    hidden : list of bool, optional
        Hidden flag per label.
    target : object, optional
        A segmentation (or colour-table ``HasTraits``) to :meth:`link` to.

    Attributes
    ----------
    colors : list of str
    hidden : list of bool
    selected : int
        Active label (the slice that is drawn extruded).
    """

    _esm = asset("color_wheel.js")
    _css = asset("color_wheel.css")
    colors = traitlets.List(traitlets.Unicode(), default_value=["#bebebe"]).tag(sync=True)
    hidden = traitlets.List(traitlets.Bool(), default_value=[False]).tag(sync=True)
    selected = traitlets.Int(0).tag(sync=True)
    error = traitlets.Unicode("").tag(sync=True)

    def __init__(self, colors=None, hidden=None, *, target=None, **kwargs):
        if colors is not None:
            colors = [rgb_to_hex(hex_to_rgb(c)) for c in colors]
            kwargs["colors"] = colors
            kwargs.setdefault("hidden", list(hidden) if hidden is not None else [False] * len(colors))
        super().__init__(**kwargs)
        self.target = None
        self._busy = SyncGuard()
        if target is not None:
            self.link(target)
        self.observe(self._to_target, names=["colors", "hidden"])

    @traitlets.validate("selected")
    def _check_selected(self, proposal):
        return check_int("selected", proposal["value"], 0, len(self.colors) - 1)

    @traitlets.validate("colors")
    def _check_colors(self, proposal):
        value = list(proposal["value"])
        if not 1 <= len(value) <= 256:
            raise traitlets.TraitError(f"colors must have 1 to 256 entries, got {len(value)}")
        for c in value:
            hex_to_rgb(c)
        return value

    # -- linking -------------------------------------------------------------------------------------
    def link(self, target) -> None:
        """Two-way link to a segmentation or colour-table object (duck-typed, see the module docstring)."""
        if isinstance(target, traitlets.HasTraits) and {"colors", "hidden"} <= set(target.trait_names()):
            kind = "traits"
        elif hasattr(target, "colors") and hasattr(target.colors, "rgba") and hasattr(target, "set_color") \
                and hasattr(target, "set_visible") and isinstance(target, traitlets.HasTraits) \
                and callable(getattr(target, "on", None)):
            kind = "segmentation"
        else:
            raise ValueError("target must be a Segmentation-like document (colors.rgba, colors.visible, set_color, "
                             "set_visible, on/off events) or a HasTraits with 'colors' and 'hidden' traits, "
                             f"got {type(target).__name__}")
        self.unlink()
        self.target, self._kind = target, kind
        if kind == "traits":
            target.observe(self._from_target, names=["colors", "hidden"])
        else:
            target.on(self._seg_changed, "colors", "visibility")
        self._from_target(None)

    def unlink(self) -> None:
        """Stop following the linked object."""
        t = self.target
        if t is None:
            return
        if self._kind == "traits":
            t.unobserve(self._from_target, names=["colors", "hidden"])
        else:
            t.off(self._seg_changed)
        self.target = None

    def _seg_changed(self, change) -> None:
        self._from_target(None)

    def _table(self) -> tuple[list[str], list[bool]]:
        t = self.target
        if self._kind == "traits":
            return [rgb_to_hex(hex_to_rgb(c)) for c in t.colors], [bool(h) for h in t.hidden]
        return [rgb_to_hex(c[:3]) for c in np.asarray(t.colors.rgba)], [not bool(v) for v in t.colors.visible]

    def _from_target(self, change) -> None:
        if self._busy:
            return
        colors, hidden = self._table()
        with self._busy, self.hold_trait_notifications():
            if self.selected >= len(colors):
                self.selected = 0
            self.colors, self.hidden = colors, hidden

    def _to_target(self, change) -> None:
        if self._busy or self.target is None:
            return
        with self._busy:
            try:
                old_colors, old_hidden = self._table()
                new_colors, new_hidden = list(self.colors), list(self.hidden)
                if len(new_colors) != len(old_colors) or len(new_hidden) != len(old_hidden):
                    raise ValueError(f"the wheel edits colours, it cannot resize the table ({len(old_colors)} entries)")
                if self._kind == "traits":
                    with self.target.hold_trait_notifications():
                        self.target.colors, self.target.hidden = new_colors, new_hidden
                else:
                    for k, (a, b) in enumerate(zip(old_colors, new_colors)):
                        if a != b:
                            self.target.set_color(k, hex_to_rgb(b))
                    for k, (a, b) in enumerate(zip(old_hidden, new_hidden)):
                        if a != b:
                            self.target.set_visible(k, not b)
                self.error = ""
            except ValueError as exc:
                self.error = str(exc)
        if self.target is not None:
            self._from_target(None)  # show what the target really holds

    # -- commands (what the browser's clicks do) ------------------------------------------------------
    def select(self, label: int) -> None:
        """Make ``label`` the active colour."""
        self.selected = check_int("label", label, 0, len(self.colors) - 1)

    def toggle_hidden(self, label: int | None = None) -> bool:
        """Hide or show every vertex of ``label`` (default: the selected one); returns the new hidden flag."""
        label = self.selected if label is None else check_int("label", label, 0, len(self.colors) - 1)
        h = list(self.hidden)
        h[label] = not h[label]
        self.hidden = h
        return self.hidden[label]

    def set_color(self, label: int, color: str) -> None:
        """Edit one colour (``"#rrggbb"``)."""
        label = check_int("label", label, 0, len(self.colors) - 1)
        c = list(self.colors)
        c[label] = rgb_to_hex(hex_to_rgb(color))
        self.colors = c

    def close(self) -> None:
        """Unlink and close the comm."""
        self.unlink()
        super().close()

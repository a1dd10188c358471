"""The keyword options of :class:`plantvr.View`, checked at the door (each error names the option)."""
from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

from .._validation import check_array, check_size  # noqa: E402
from .layers import LOD  # noqa: E402

__all__ = ["ViewOptions", "check_bool"]


def check_bool(name: str, v) -> bool:
    """``v`` as a bool, or ``ValueError`` naming ``name`` unless it is True or False."""
    if not isinstance(v, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {v!r}")
    return bool(v)


@dataclass(frozen=True)
class ViewOptions:
    """:class:`plantvr.View`'s options as the view uses them (see its parameters): ``lod`` becomes an
    :class:`~plantvr.view.layers.LOD` or None, ``panels`` a tuple of name tuples, ``background`` a
    ``pyvista.Color`` or None, ``depth_cue`` the cue's target colour (RGB ints) or None, ``sides`` two ints."""

    window_size: Any = (900, 700)
    show_markers: bool = True
    show_leaves: bool = True
    ground: bool | None = None
    lod: Any = None
    panels: Any = None
    titles: Sequence[str] | None = None
    styles: Mapping[str, dict] | None = None
    params: Mapping | None = None
    background: Any = None
    depth_cue: Any = False
    sides: Any = (6, 32)

    def __post_init__(self):
        put = object.__setattr__
        put(self, "window_size", check_size("window_size", self.window_size, 16, 16384))
        for name in ("show_markers", "show_leaves", "depth_cue"):
            put(self, name, check_bool(name, getattr(self, name)))
        if self.ground is not None:
            check_bool("ground", self.ground)
        lod = LOD() if self.lod is True else (None if self.lod is None or self.lod is False else self.lod)
        if lod is not None and not isinstance(lod, LOD):
            raise ValueError(f"lod must be True, False, None or a plantvr.view.LOD, got {type(lod).__name__}")
        put(self, "lod", lod)
        panels = _check_panels(self.panels)
        put(self, "panels", panels)
        titles = self.titles
        if titles is not None and (isinstance(titles, str) or len(titles) != max(len(panels), 1)
                                   or not all(isinstance(t, str) for t in titles)):
            raise ValueError(f"titles must be one str per panel ({max(len(panels), 1)}), got {titles!r}")
        styles = dict(self.styles or {})
        if not all(isinstance(k, str) and isinstance(v, Mapping) for k, v in styles.items()):
            raise ValueError("styles must map scene names to dicts of add_mesh options")
        put(self, "styles", styles)
        if self.params is not None and not isinstance(self.params, Mapping):
            raise ValueError(f"params must be a dict, got {type(self.params).__name__}")
        put(self, "params", dict(self.params or {}))
        try:
            background = None if self.background is None else pv.Color(self.background)
        except ValueError:
            raise ValueError(f"background must be a colour (name, hex or RGB), got {self.background!r}"[:300]) \
                from None
        put(self, "background", background)
        put(self, "depth_cue", None if not self.depth_cue else (0, 0, 0) if background is None
            else tuple(background.int_rgb))
        s = check_array("sides", self.sides, shape=(2,))
        if not (np.all(s == np.round(s)) and 3 <= s[0] <= s[1] <= 64):
            raise ValueError(f"sides must be two whole numbers in [3, 64], tips then base (tips <= base), got "
                             f"{s.tolist()}")
        put(self, "sides", (int(s[0]), int(s[1])))


def _check_panels(panels) -> tuple[tuple[str, ...], ...]:
    if panels is None:
        return ()
    if isinstance(panels, str) or not isinstance(panels, Sequence) or not 1 <= len(panels) <= 8 or not all(
            isinstance(p, Sequence) and not isinstance(p, str) and all(isinstance(n, str) for n in p)
            for p in panels):
        raise ValueError(f"panels must be 1 to 8 sequences of scene names, got {panels!r}"[:300])
    return tuple(tuple(p) for p in panels)

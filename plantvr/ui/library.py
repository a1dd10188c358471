"""Tree library panel: saved TreeSketch trees with thumbnails, reload, and parameters as presets (spec 004 §2.3 Fig. E.8,
§2.4 "Parameter presets", §4.6 (1)).

Storage is :class:`plantvr.growth.sketch_tools.TreeLibrary` (``<name>.tree`` + ``<name>.json``, lossless, and
``<name>.preset.json`` presets); this module adds what the thesis's library page does on top of it:

* a thumbnail per saved tree (``<name>.thumb.svg``, the skeleton seen from the front) so trees "can be viewed";
* :func:`preset_from_tree`: the parameters of a *saved tree* loaded as a growth or rendering preset ("The
  parameters of saved trees can also be loaded, acting as growth or rendering presets");
* :func:`apply_preset_values`: a preset applied to a SketchEngine, a Model or an :class:`ArchitectureState`,
  everything checked before anything is written;
* :class:`LibraryPanel`: list, view, save, reload (the loaded engine is bound to the architecture panel only after
  it loaded completely, so a failed load leaves the current tree and panel unchanged), delete, presets.
"""
from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path
from typing import Any

import ipywidgets as W
import numpy as np

from .._fileio import write_atomic
from ..growth.sketch import SketchEngine
from ..growth.sketch_tools import TreeLibrary
from ..growth.treefile import tree_from_text
from ..documents.treewand import Model
from ..params import PARAM_BY_NAME, validate
from .architecture import ArchitectureState

__all__ = ["LibraryPanel", "apply_preset_values", "preset_from_tree", "tree_svg"]

_KINDS = ("growth", "rendering", "all")


def tree_svg(pos, parent, *, alive=None, radius=None, size: int = 160) -> str:
    """SVG thumbnail of a tree skeleton projected on the x-y plane (front view, y up).

    Parameters
    ----------
    pos : (N, 3) float64 array_like
        Node positions; node 0 is the base.
    parent : (N,) int array_like
        Parent index, -1 for the base.
    alive : (N,) bool array_like, optional
    radius : (N,) float64 array_like, optional
        Internode radii (line widths); default thin lines.
    size : int
        Width and height in pixels, in [16, 2048].

    Returns
    -------
    str
        A standalone ``<svg>`` element.
    """
    from .._validation import check_int, check_points

    from .._validation import check_array

    pos = check_points("pos", pos)
    n = len(pos)
    parent = check_array("parent", parent, shape=(n,), dtype=np.int64)
    if n and (parent.min() < -1 or parent.max() >= n):
        raise ValueError(f"parent must hold indices in [-1, {n - 1}], got {int(parent.min())} .. {int(parent.max())}")
    size = check_int("size", size, 16, 2048)
    alive = np.ones(n, bool) if alive is None else check_array("alive", alive, shape=(n,), dtype=bool)
    if radius is not None:
        radius = check_array("radius", radius, shape=(n,), max_abs=1e6)
    live = np.flatnonzero(alive & (parent >= 0))
    pad = 0.06 * size
    pts = pos[alive][:, :2] if alive.any() else np.zeros((1, 2))
    lo, hi = pts.min(0), pts.max(0)
    span = max(float((hi - lo).max()), 1e-9)
    sc = (size - 2 * pad) / span
    cx = 0.5 * (lo[0] + hi[0])

    def X(x):
        return size / 2 + sc * (x - cx)

    def Y(y):
        return size - pad - sc * (y - lo[1])
    r = np.zeros(len(pos)) if radius is None else np.asarray(radius, float)
    lines = []
    for i in live:
        a, b = pos[parent[i]], pos[i]
        w = max(0.6, min(8.0, 2.0 * r[i] * sc))
        lines.append(f'<line x1="{X(a[0]):.1f}" y1="{Y(a[1]):.1f}" x2="{X(b[0]):.1f}" y2="{Y(b[1]):.1f}" '
                     f'stroke-width="{w:.2f}"/>')
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size}" viewBox="0 0 {size} {size}">'
            f'<rect width="{size}" height="{size}" fill="#fbfbf7"/>'
            f'<g stroke="#5b3a1e" stroke-linecap="round">{"".join(lines)}</g></svg>')


_THUMB_TAGS = {"svg", "rect", "g", "line"}
_MAX_THUMB_BYTES = 4 << 20


def _read_thumbnail(path: Path) -> str:
    """A saved thumbnail's SVG, shown only if it is what :func:`tree_svg` writes (bounded; no scripts, links or
    event handlers, since the text goes into the page's HTML)."""
    import re

    try:
        if path.stat().st_size > _MAX_THUMB_BYTES:
            return "<i>thumbnail too large</i>"
        text = path.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return "<i>unreadable thumbnail</i>"
    tags = set(re.findall(r"<\s*/?\s*([A-Za-z][\w:-]*)", text))
    if not text.startswith("<svg") or not tags <= _THUMB_TAGS or re.search(r"\son\w*\s*=|href|javascript:|<!", text,
                                                                          re.IGNORECASE):
        return "<i>thumbnail not shown (not a PlantVR thumbnail)</i>"
    return text


def _select(params: dict[str, Any], kind: str) -> dict[str, Any]:
    """Growth = every parameter outside the Appearance window; rendering = the Appearance window."""
    if kind == "all":
        return dict(params)
    rendering = kind == "rendering"
    return {k: v for k, v in params.items() if (PARAM_BY_NAME[k].window == "appearance") == rendering}


def preset_from_tree(library: TreeLibrary, name: str, *, kind: str = "growth") -> dict[str, Any]:
    """The parameters of the saved tree ``name`` as a preset ``{"params": ..., "options": ...}``.

    Parameters
    ----------
    library : TreeLibrary
    name : str
        A saved tree.
    kind : {"growth", "rendering", "all"}
        Growth presets carry the growth parameters and the TreeSketch options; rendering presets carry the
        Appearance-window parameters only.

    Returns
    -------
    dict
        Checked values (raises ``ValueError`` for a missing or corrupt entry).
    """
    from .._validation import check_choice

    kind = check_choice("kind", kind, _KINDS)
    text, meta = library.read_entry(name)
    _, params = tree_from_text(text)
    params.pop("branching", None)  # the node topology of that tree, not a parameter to carry to another
    opts = dict(meta.get("options", {})) if isinstance(meta, dict) else {}
    for k in ("region", "depth", "asymmetry"):  # where the tree stood, not how it grows
        opts.pop(k, None)
    out = {"params": _select(validate(params), kind), "options": opts if kind != "rendering" else {}}
    return out


def apply_preset_values(target, preset: dict[str, Any]) -> None:
    """Apply ``{"params": ..., "options": ...}`` to a SketchEngine, a Model or an :class:`ArchitectureState`.

    Everything is checked first (the table, then the engine's own option checks on a probe), so a rejected preset
    changes nothing. A Model takes the parameters only (it has no TreeSketch options).
    """
    if not isinstance(preset, dict) or not isinstance(preset.get("params", {}), dict) \
            or not isinstance(preset.get("options", {}), dict):
        raise ValueError(f"preset must be {{'params': {{...}}, 'options': {{...}}}}, got {preset!r}")  # noqa: TRY004
    params = validate(dict(preset.get("params", {})))
    opts = dict(preset.get("options", {}))
    if "ellipse" in opts:
        opts["ellipse"] = tuple(opts["ellipse"])
    state = target if isinstance(target, ArchitectureState) else None
    engine = state.engine if state is not None else target if isinstance(target, SketchEngine) else None
    model = state.target if state is not None and state.engine is None else target if isinstance(target, Model) \
        else None
    if engine is None and model is None:
        raise TypeError(f"target must be a SketchEngine, a Model or an ArchitectureState, got {type(target).__name__}")
    if engine is not None:  # everything is checked before the engine is touched
        opts = engine._check_options(opts)
        engine.checked_params(params)
    if engine is not None:
        if opts:
            engine.set_options(**opts)
        if params:
            engine.set_params(params)
    else:
        model.set_params(**params)
    if state is not None:
        state.refresh()


class LibraryPanel(W.VBox):
    """The tree library page (Fig. E.8): saved trees with thumbnails, save / reload / delete, presets.

    Parameters
    ----------
    folder : str or Path
        The library folder (created if missing).
    target : ArchitectureState or ArchitecturePanel or SketchEngine
        The current tree. With a state (or panel), a reloaded tree is bound to it, so the architecture widgets
        follow; with a bare engine, ``on_load`` receives the new engine.
    on_load : callable, optional
        Called with the reloaded :class:`SketchEngine` after a successful load.

    Attributes
    ----------
    library : TreeLibrary
    engine : SketchEngine
        The current tree.
    message : ipywidgets.HTML
        The result of the last command (errors in red).
    """

    def __init__(self, folder: str | Path, target, *, on_load: Callable[[SketchEngine], None] | None = None):
        state = getattr(target, "state", target)
        self.state = state if isinstance(state, ArchitectureState) else None
        if self.state is None and not isinstance(target, SketchEngine):
            raise TypeError(f"target must be an ArchitectureState, ArchitecturePanel or SketchEngine, "
                            f"got {type(target).__name__}")
        if self.state is not None and self.state.engine is None:
            raise TypeError("the library saves SketchEngine trees; bind the architecture state to a SketchEngine")
        self._engine = target if self.state is None else None
        self.library = TreeLibrary(folder)
        self.on_load = on_load
        self.trees = W.Select(options=self.library.trees(), rows=6, description="Trees")
        self.thumb = W.HTML("")
        self.name = W.Text(value="", placeholder="name", description="Name")
        self.save_button = W.Button(description="Save", icon="save")
        self.load_button = W.Button(description="Reload", icon="folder-open")
        self.delete_button = W.Button(description="Delete", icon="trash")
        self.presets = W.Dropdown(options=self.library.presets(), description="Presets")
        self.preset_kind = W.ToggleButtons(options=["growth", "rendering"], value="growth")
        self.apply_button = W.Button(description="Apply preset")
        self.tree_preset_button = W.Button(description="Use tree's parameters")
        self.save_preset_button = W.Button(description="Save as preset")
        self.message = W.HTML("")
        self.trees.observe(lambda ch: self._show(ch["new"]), names="value")
        self.save_button.on_click(lambda _: self._guard(lambda: self.save(self.name.value)))
        self.load_button.on_click(lambda _: self._guard(lambda: self.load(self.trees.value)))
        self.delete_button.on_click(lambda _: self._guard(lambda: self.delete(self.trees.value)))
        self.apply_button.on_click(lambda _: self._guard(lambda: self.apply_preset(self.presets.value)))
        self.tree_preset_button.on_click(lambda _: self._guard(
            lambda: self.use_tree_parameters(self.trees.value, kind=self.preset_kind.value)))
        self.save_preset_button.on_click(lambda _: self._guard(lambda: self.save_preset(self.name.value)))
        super().__init__([
            W.HTML("<b>Tree library</b>"),
            W.HBox([W.VBox([self.trees, W.HBox([self.load_button, self.delete_button])]), self.thumb]),
            W.HBox([self.name, self.save_button, self.save_preset_button]),
            W.HBox([self.presets, self.apply_button]),
            W.HBox([self.preset_kind, self.tree_preset_button]),
            self.message])
        if self.trees.options:
            self._show(self.trees.value)

    # -- plumbing ----------------------------------------------------------------------------------------------
    @property
    def engine(self) -> SketchEngine:
        """The current tree's engine."""
        return self.state.engine if self.state is not None else self._engine

    def _guard(self, fn) -> None:
        try:
            fn()
        except (ValueError, TypeError) as exc:
            self.message.value = f"<span style='color:#c0392b'>{html.escape(str(exc), quote=False)}</span>"

    def _ok(self, text: str) -> None:
        self.message.value = f"<span style='color:#2e7d32'>{html.escape(text, quote=False)}</span>"

    def _refresh_lists(self, select: str | None = None) -> None:
        self.trees.options = self.library.trees()
        self.presets.options = self.library.presets()
        if select is not None and select in self.trees.options:
            self.trees.value = select

    def _show(self, name: str | None) -> None:
        if not name:
            self.thumb.value = ""
            return
        path = self.library.folder / f"{name}.thumb.svg"
        self.thumb.value = _read_thumbnail(path) if path.exists() else "<i>no thumbnail</i>"

    # -- commands (what the buttons call) -------------------------------------------------------------------------
    def save(self, name: str) -> Path:
        """Save the current tree as ``name`` (lossless, :meth:`TreeLibrary.save`) with its thumbnail."""
        e = self.engine
        name = self.library._name(name)
        files = [self.library.folder / f"{name}{x}" for x in (".tree", ".json", ".thumb.svg")]
        existed = [f.exists() for f in files]
        t = e.tree
        try:
            path = self.library.save(name, e)
            write_atomic(files[2], tree_svg(t.pos[: t.n], t.parent[: t.n], alive=t.alive[: t.n],
                                            radius=t.radius[: t.n]))
        except OSError as exc:  # no half-written new entry is left behind
            for f, old in zip(files, existed):
                if not old:
                    f.unlink(missing_ok=True)
            raise ValueError(f"cannot save {name!r} in {self.library.folder}: {exc}") from None
        self._refresh_lists(select=name)
        self._ok(f"saved {name!r} ({t.n_internodes} internodes)")
        return path

    def load(self, name: str | None) -> SketchEngine:
        """Reload the saved tree ``name`` and make it the current tree; on any error nothing changes."""
        if not name:
            raise ValueError("select a saved tree to reload")
        try:
            e = self.library.load(name)
        except (KeyError, TypeError, IndexError) as exc:  # a malformed entry that slipped past the format checks
            raise ValueError(f"library tree {name!r} is corrupt: {exc!r}") from None
        if self.state is not None:
            self.state.bind(e)
        else:
            self._engine = e
        if self.on_load is not None:
            self.on_load(e)
        self._ok(f"reloaded {name!r} ({e.tree.n_internodes} internodes, step {e.step_count})")
        return e

    def delete(self, name: str | None) -> None:
        """Remove the saved tree ``name`` (its files) from the library."""
        if not name:
            raise ValueError("select a saved tree to delete")
        name = self.library._name(name)
        if name not in self.library.trees():
            raise ValueError(f"no saved tree {name!r} in {self.library.folder}")
        for suffix in (".tree", ".json", ".thumb.svg"):
            (self.library.folder / f"{name}{suffix}").unlink(missing_ok=True)
        self._refresh_lists()
        self._ok(f"deleted {name!r}")

    def apply_preset(self, name: str) -> None:
        """Apply a built-in or saved preset to the current tree (checked first)."""
        apply_preset_values(self.state if self.state is not None else self.engine, self.library.preset(name))
        self._ok(f"applied preset {name!r}")

    def use_tree_parameters(self, name: str | None, *, kind: str = "growth") -> None:
        """Load the parameters of the saved tree ``name`` as a growth or rendering preset."""
        if not name:
            raise ValueError("select a saved tree whose parameters to use")
        apply_preset_values(self.state if self.state is not None else self.engine,
                            preset_from_tree(self.library, name, kind=kind))
        self._ok(f"applied the {kind} parameters of {name!r}")

    def save_preset(self, name: str) -> Path:
        """Save the current growth parameters and options as preset ``name``."""
        path = self.library.save_preset(name, self.engine)
        self._refresh_lists()
        self._ok(f"saved preset {name!r}")
        return path

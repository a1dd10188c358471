"""Tree library panel: saved TreeSketch trees with thumbnails, reload, and parameters as presets (spec 004 §2.3 Fig. E.8,
§2.4 "Parameter presets", §4.6 (1)).

Storage is :class:`plantvr.growth.sketch_tools.TreeLibrary` (``<name>.tree`` + ``<name>.json``, lossless, and
``<name>.preset.json`` presets); this module adds what the thesis's library page does on top of it:

* a thumbnail per saved tree (``<name>.thumb.svg``, the skeleton seen from the front) so trees "can be viewed";
* :func:`preset_from_tree`: the parameters of a *saved tree* loaded as a growth or rendering preset ("The
  parameters of saved trees can also be loaded, acting as growth or rendering presets");
* :func:`apply_preset_values`: a preset (:data:`~plantvr.growth.sketch.TREESKETCH` values) applied to a
  :class:`~plantvr.documents.treesketch.SketchDocument` or a Tree Wand :class:`~plantvr.Model`, everything checked
  before anything is written;
* :class:`LibraryPanel`: a view of a SketchDocument: list, view, save, reload (:meth:`SketchDocument.restore`, which
  checks the entry in full first, so a failed load leaves the current tree unchanged; the architecture panel
  follows the document's change events), delete, presets.
"""
from __future__ import annotations

import html
import re
from pathlib import Path
from typing import Any

import ipywidgets as W
import numpy as np

from .._fileio import read_text, write_atomic
from .._validation import check_array, check_choice, check_int, check_points
from ..documents.treesketch import SketchDocument
from ..documents.treewand import Model
from ..growth.sketch import TREESKETCH, SketchEngine
from ..growth.sketch_tools import TreeLibrary
from ..params import TREEWAND
from .architecture import ArchitecturePanel

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
    try:
        text = read_text(path, what="thumbnail", max_bytes=_MAX_THUMB_BYTES)
    except ValueError:
        return "<i>unreadable thumbnail (missing, too large or not text)</i>"
    tags = set(re.findall(r"<\s*/?\s*([A-Za-z][\w:-]*)", text))
    if not text.startswith("<svg") or not tags <= _THUMB_TAGS or re.search(r"\son\w*\s*=|href|javascript:|<!", text,
                                                                          re.IGNORECASE):
        return "<i>thumbnail not shown (not a PlantVR thumbnail)</i>"
    return text


def _select(values: dict[str, Any], kind: str) -> dict[str, Any]:
    """Growth = every row outside the Appearance window (the TreeSketch rows included); rendering = the Appearance
    window."""
    if kind == "all":
        return dict(values)
    rendering = kind == "rendering"
    return {k: v for k, v in values.items() if (TREESKETCH[k].window == "appearance") == rendering}


def preset_from_tree(library: TreeLibrary, name: str, *, kind: str = "growth") -> dict[str, Any]:
    """The parameters of the saved tree ``name`` as a preset: :data:`~plantvr.growth.sketch.TREESKETCH` values.

    Parameters
    ----------
    library : TreeLibrary
    name : str
        A saved tree.
    kind : {"growth", "rendering", "all"}
        Growth presets carry the growth parameters and the TreeSketch rows; rendering presets carry the
        Appearance-window parameters only.

    Returns
    -------
    dict
        Checked values ``{name: value}`` (the entry is loaded in full, so a missing or corrupt one raises
        ``ValueError``).
    """
    kind = check_choice("kind", kind, _KINDS)
    values = library.load(name).table_values()
    values.pop("branching")  # the node topology of that tree, not a parameter to carry to another
    return _select(values, kind)


def apply_preset_values(target: SketchDocument | Model, preset: dict[str, Any]) -> None:
    """Apply a preset of :data:`~plantvr.growth.sketch.TREESKETCH` values ``{name: value}`` to a
    :class:`SketchDocument` (``doc.set_params``) or a Tree Wand :class:`~plantvr.Model`, which takes the Tree Wand
    rows only (``model.set_params``).

    Everything is checked first (the table, then the target's own checks), so a rejected preset changes nothing.
    """
    if not isinstance(target, (SketchDocument, Model)):
        raise TypeError(f"target must be a SketchDocument or a Model, got {type(target).__name__}")
    if not isinstance(preset, dict):
        raise ValueError(  # noqa: TRY004 - a bad value at the door, like every preset error
            f"preset must be a dict of TREESKETCH values {{name: value}}, got {type(preset).__name__}")
    values = TREESKETCH.validate(preset)
    if isinstance(target, Model):
        values = {k: v for k, v in values.items() if k in TREEWAND}
    target.set_params(**values)


class LibraryPanel(W.VBox):
    """The tree library page (Fig. E.8): saved trees with thumbnails, save / reload / delete, presets; a view of a
    :class:`SketchDocument`.

    Parameters
    ----------
    folder : str or Path
        The library folder (created if missing).
    target : ArchitecturePanel or SketchDocument
        The current tree: the document, or the architecture panel whose document (:attr:`ArchitecturePanel.doc`,
        followed when the panel is bound to another) the library reads and commands. A reloaded tree replaces the
        document's tree; the panel's widgets follow the document's ``change`` events.

    Attributes
    ----------
    library : TreeLibrary
    doc : SketchDocument
        The current tree's document.
    engine : SketchEngine
        Its engine.
    message : ipywidgets.HTML
        The result of the last command (errors in red).
    """

    def __init__(self, folder: str | Path, target: ArchitecturePanel | SketchDocument):
        if not isinstance(target, (ArchitecturePanel, SketchDocument)):
            raise TypeError(f"target must be an ArchitecturePanel or a SketchDocument, got {type(target).__name__}")
        self._target = target
        self.library = TreeLibrary(folder)
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
    def doc(self) -> SketchDocument:
        """The current tree's document (the architecture panel's, when the library views a panel)."""
        t = self._target
        return t.doc if isinstance(t, ArchitecturePanel) else t

    @property
    def engine(self) -> SketchEngine:
        """The current tree's engine."""
        return self.doc.engine

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
        """Reload the saved tree ``name`` into the document (:meth:`SketchDocument.restore`: the entry is checked in
        full first, so on any error nothing changes); returns the document's new engine."""
        if not name:
            raise ValueError("select a saved tree to reload")
        name = self.library._name(name)
        doc = self.doc
        doc.restore(self.library.folder / f"{name}.tree")
        e = doc.engine
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
        self.doc.set_params(**self.library.preset(name))
        self._ok(f"applied preset {name!r}")

    def use_tree_parameters(self, name: str | None, *, kind: str = "growth") -> None:
        """Load the parameters of the saved tree ``name`` as a growth or rendering preset."""
        if not name:
            raise ValueError("select a saved tree whose parameters to use")
        apply_preset_values(self.doc, preset_from_tree(self.library, name, kind=kind))
        self._ok(f"applied the {kind} parameters of {name!r}")

    def save_preset(self, name: str) -> Path:
        """Save the current growth parameters and options as preset ``name``."""
        path = self.library.save_preset(name, self.engine)
        self._refresh_lists()
        self._ok(f"saved preset {name!r}")
        return path

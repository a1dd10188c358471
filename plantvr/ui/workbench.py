"""The live workbench: a document's 3D view beside its generated panel, in JupyterLab or headless (spec
000_treewand §4.3, §4.4, §4.11; 000_vine §2.4, §2.6; issue 21, "The experience in JupyterLab").

:func:`workbench` lays out, for any document, the view of :class:`plantvr.View` (left) and the document's
controls (right): the :class:`~plantvr.ui.ParameterPanels` generated from its table (with the influence
triangle for Tree Wand), a :class:`~plantvr.ui.GrowthControl` for a growth document, a
:class:`~plantvr.ui.ColorWheel` for a ViNE :class:`~plantvr.documents.labels.Segmentation`, the part's own
panel where it has one (:data:`EDITORS`: the :class:`~plantvr.ui.FloretEditor` of an inflorescence, the
:class:`~plantvr.ui.implicit_panel.ImplicitPanel` of an implicit crown, the
:class:`~plantvr.ui.ArchitecturePanel` of a TreeSketch document), and a status line that follows the document. Every widget is a view of the document; the workbench keeps no state of its own.

* **Live** (a JupyterLab kernel, see :func:`live_frontend`): the view is a trame view rendered on the kernel
  (:meth:`plantvr.View.widget`); the browser's mouse reaches the plotter's VTK interactor, where the brush
  (:class:`~plantvr.view.interaction.BrushInteractor` for Tree Wand: paint markers, prune in prune mode;
  :class:`~plantvr.view.interaction.LabelBrush` for ViNE: paint the wheel's selected label) issues document
  commands. A *Camera* toggle gives the mouse back to the camera.
* **Headless** (nbval, scripts): the view is an ``ipywidgets.Image`` of an offscreen render, redrawn after
  every change, so the same cell runs without a browser and returns the same layout.

"Dragging a slider regrows": a Tree Wand parameter of the *Tree form* or *Light* window changed (a slider, the
triangle, ``set_params``) grows the tree again from the session's own commands — :meth:`Workbench.regrow`:
``reset`` with the model's seed, then the ``paint`` / ``paint_stroke`` / ``add_markers`` / ``step`` / ``prune``
commands logged since the last reset, re-issued in order (same darts, same step count), as one undo item and
one redraw. Inside a kernel the regrow runs once after the message that changed the parameters (several
changes in one cell or one slider release regrow once); :meth:`Workbench.flush` runs a pending one now.
"""
from __future__ import annotations

import importlib.util
import os

import ipywidgets as W

from .._validation import check_size
from ..document import kernel_loop
from ..documents.treesketch import SketchDocument
from ..documents.treewand import Model
from .architecture import ArchitecturePanel
from .floret_editor import FloretEditor
from .growth import GrowthControl
from .implicit_panel import ImplicitPanel
from .lsystem_panel import LsystemPanel
from .panels import ParameterPanels
from .wheel import ColorWheel

__all__ = ["EDITORS", "OWN_PANEL_ONLY", "REGROW_BY_KIND", "REGROW_COMMANDS", "REGROW_WINDOWS",
           "SKETCH_REGROW_COMMANDS", "Workbench", "close_when_headless", "live_frontend", "workbench"]

#: Tree Wand commands re-issued by a regrow (what grew the tree since the last reset).
REGROW_COMMANDS = Model.REGROW_COMMANDS
#: TreeSketch commands re-issued by a regrow (the strokes, markers and growth since the last reset; edits that
#: name nodes of the old tree, ``select`` / ``set_width`` / ``bend``, are not).
SKETCH_REGROW_COMMANDS = SketchDocument.REGROW_COMMANDS
#: Parameter windows whose parameters change growth (the others only change the picture).
REGROW_WINDOWS = ("form", "light")
#: By document kind: the windows whose parameters change growth (a forest: all of them).
REGROW_BY_KIND = {"treewand": REGROW_WINDOWS, "treesketch": (*REGROW_WINDOWS, "sketch"), "forest": ("forest",)}
#: The part's own panel by document kind (``doc.KIND``), shown under the generated panel.
EDITORS = {"inflorescence": FloretEditor, "crown": ImplicitPanel, "treesketch": ArchitecturePanel,
           "lsystem": LsystemPanel}
#: Kinds whose own panel edits every row of the table (the floret editor: settings, each key pose, growth): the
#: generated panel is left out, so one part has one panel.
OWN_PANEL_ONLY = ("inflorescence",)


def live_frontend() -> bool:
    """Whether a browser front end is attached to this kernel, so a live trame view can be shown.

    ``$PLANTVR_LIVE`` = ``1`` / ``0`` decides when set. Otherwise live means: an IPython kernel that a Jupyter
    server started for a notebook session (the server sets ``$JPY_SESSION_NAME``; nbval, nbclient and scripts
    do not) and ``trame-pyvista`` is installed.
    """
    env = os.environ.get("PLANTVR_LIVE", "").strip()
    if env in ("0", "1"):
        return env == "1"
    if not os.environ.get("JPY_SESSION_NAME"):
        return False
    try:
        from IPython import get_ipython  # noqa: PLC0415
    except ImportError:
        return False
    shell = get_ipython()
    return (shell is not None and getattr(shell, "kernel", None) is not None
            and importlib.util.find_spec("trame_pyvista") is not None)


def close_when_headless(*widgets) -> bool:
    """Close ``widgets`` (workbenches, panels, any object with ``close()``) at the end of a notebook, but only
    when no browser shows them: under nbval, nbclient or a script (:func:`live_frontend` False) they are closed
    to free their render windows and observers; in JupyterLab they stay, so *Run All* leaves the live views
    usable. Returns whether they were closed."""
    bad = [type(w).__name__ for w in widgets if not callable(getattr(w, "close", None))]
    if bad:
        raise ValueError(f"close_when_headless takes objects with close(), got {bad[0]}")
    if live_frontend():
        return False
    for w in widgets:
        w.close()
    return True


def workbench(doc, *, live: bool | None = None, window_size=(640, 520)) -> Workbench:
    """The live view of ``doc`` beside its generated panel (see the module docstring).

    Parameters
    ----------
    doc : Document
        Any document (``plantvr.Model``, a ViNE ``Segmentation``, TreeSketch, crown, inflorescence, forest).
    live : bool, optional
        Show the trame view (True) or an offscreen image (False); default :func:`live_frontend`.
    window_size : (int, int)
        Pixels of the view.

    Returns
    -------
    Workbench
        An ``ipywidgets.HBox``; display it (the last expression of a cell).
    """
    return Workbench(doc, live=live, window_size=window_size)


class Workbench(W.HBox):
    """A document's view beside its panel (:func:`workbench`).

    Attributes
    ----------
    doc : Document
    view : plantvr.View
        The document's view (offscreen plotter; in live mode served through trame).
    screen : ipywidgets.Widget
        The view in the layout: the trame widget (live) or an ``ipywidgets.Image`` (headless).
    brush : BrushInteractor or LabelBrush or None
        The brush over the view (Tree Wand: markers / prune; ViNE: the wheel's label); None for other documents.
    panels : ParameterPanels or None
        The generated parameter windows (None for a document without a table, and for the kinds of
        :data:`OWN_PANEL_ONLY`, whose own panel edits every parameter).
    growth : GrowthControl or None
        Play / pause / step / reset (Tree Wand).
    wheel : ColorWheel or None
        The colour wheel (ViNE); its selection is the label the brush paints.
    editor : FloretEditor or ImplicitPanel or ArchitecturePanel or None
        The part's own panel (:data:`EDITORS`), a view of the same document; None for the other kinds. The
        floret editor's preview image is left out (the view shows the floret).
    status : ipywidgets.HTML
        One line that follows the document (internodes / markers / brush commands, or painted vertices / label).
    mode : ipywidgets.ToggleButtons
        ``"Brush"`` (the mouse paints) or ``"Camera"`` (the mouse turns the camera), live mode only.
    regrows : int
        Regrows run so far.
    """

    def __init__(self, doc, *, live: bool | None = None, window_size=(640, 520)):
        from ..documents.labels import Segmentation  # noqa: PLC0415
        from ..documents.treewand import Model  # noqa: PLC0415
        from ..view import View  # noqa: PLC0415
        from ..view.interaction import BrushInteractor, LabelBrush  # noqa: PLC0415

        if not (callable(getattr(doc, "scene", None)) and callable(getattr(doc, "observe", None))):
            raise ValueError(f"doc must be a document (with scene() and observe), got {type(doc).__name__}")
        if live is not None and not isinstance(live, bool):
            raise ValueError(f"live must be True, False or None, got {live!r}")
        window_size = check_size("window_size", window_size, 64, 4096)
        live = live_frontend() if live is None else live
        self.doc, self.live = doc, live
        self.regrows = 0
        self._pending = False
        self._refit = False           # the next change is a regrow's: refit the camera
        self._redraw = False          # a headless picture is due
        self._fits: list = []         # (undo item of a regrow, camera before it): undone, the camera goes back
        self._start = len(doc.log)
        self._closed = True           # until the layout is built
        self.view = View(doc, off_screen=True, window_size=window_size)
        self._framed = self._has_content()   # a document that starts empty is framed when content comes
        self.treewand = isinstance(doc, Model)
        self.labels = isinstance(doc, Segmentation)
        self.panels = (ParameterPanels(doc) if getattr(doc, "PARAMS", None) is not None
                       and getattr(doc, "KIND", None) not in OWN_PANEL_ONLY else None)
        self.growth = GrowthControl(doc) if self.treewand else None
        self.wheel = ColorWheel(target=doc) if self.labels else None
        self.editor = _editor(doc)
        if self.treewand:
            self.brush = BrushInteractor(self.view)
        elif self.labels:
            self.brush = LabelBrush(self.view, label=min(1, len(doc.colors) - 1))
            self.wheel.selected = self.brush.label
            self.wheel.observe(self._on_label, names="selected")
        else:
            self.brush = None
        self.status = W.HTML("")
        self.status.add_class("plantvr-status")
        if live:
            self.screen = self.view.widget(width=window_size[0], height=window_size[1])
        else:
            self.screen = W.Image(value=self.view.png(), format="png", width=window_size[0],
                                  height=window_size[1])
        self.screen.add_class("plantvr-view")
        self.mode = W.ToggleButtons(options=["Brush", "Camera"], value="Brush" if self.brush else "Camera",
                                    tooltips=["the mouse paints (left drag; wheel: radius)",
                                              "the mouse turns the camera"],
                                    style={"button_width": "72px"}, disabled=self.brush is None,
                                    layout=W.Layout(width="auto"))
        self.mode.observe(self._on_mode, names="value")
        tools: list[W.Widget] = [self.mode]
        if self.treewand:
            self.prune = W.ToggleButton(value=bool(doc.prune_mode), description="Prune", icon="cut",
                                        layout=W.Layout(width="80px"),
                                        tooltip="the brush prunes (red) instead of painting markers (green)")
            self.prune.observe(lambda ch: self.doc.set_prune_mode(bool(ch["new"])), names="value")
            doc.observe(self._on_prune_mode, names="prune_mode")
            tools.append(self.prune)
        self.undo_button = W.Button(description="Undo", icon="undo", layout=W.Layout(width="76px"))
        self.redo_button = W.Button(description="Redo", icon="repeat", layout=W.Layout(width="76px"))
        self.undo_button.on_click(lambda _b: self.doc.undo() if self.doc.history.can_undo else None)
        self.redo_button.on_click(lambda _b: self.doc.redo() if self.doc.history.can_redo else None)
        tools += [self.undo_button, self.redo_button]
        left = W.VBox([self.screen, W.HBox(tools, layout=W.Layout(flex_flow="row wrap")), self.status],
                      layout=W.Layout(flex="0 0 auto", width=f"{window_size[0] + 8}px"))
        right = [w for w in (self.panels, self.growth, self.wheel, self.editor) if w is not None]
        self._regrow_kind = getattr(doc, "KIND", None) if getattr(doc, "KIND", None) in REGROW_BY_KIND else None
        windows = REGROW_BY_KIND.get(self._regrow_kind, ())
        self._regrow_names = {p.name for p in doc.PARAMS if p.window in windows} if windows else set()
        if self._regrow_names:
            doc.observe(self._on_param, names=sorted(self._regrow_names))
        doc.on(self._on_change)  # after the view's own observer: it has redrawn
        if live and self.brush is not None:
            self.brush.attach()
        self._sync()
        self._closed = False
        # the controls sit beside the view, or below it when the output is too narrow for both (JupyterLab
        # with its side bar open at 1280 px): never squeezed until labels are clipped
        column = W.Layout(max_width="680px" if self.editor is None else "960px", flex="1 1 0",
                          min_width="480px" if self.editor is None else "400px")
        super().__init__([left, W.VBox(right, layout=column)],
                         layout=W.Layout(flex_flow="row wrap", align_items="flex-start"))

    # -- document -> widgets -------------------------------------------------------------------------------
    def _has_content(self) -> bool:
        return any(len(lay.points()) for lay in self.view.layers.values())

    def _on_change(self, change) -> None:
        if self.view._held:
            return
        camera = None if self._refit else self._regrow_camera(change)
        if not self._framed and self._has_content():
            self._framed = True
            self.view.frame()
            if self.live:
                self.view._render_soon()
        elif self._refit or camera is True:  # a regrow (or its redo) changed the size: fit, same direction
            self.view.fit()
            if self.live:
                self.view._render_soon()
        elif camera is not None:          # a regrow undone: the camera it had before, exactly
            with self.view.lock:
                self.view.plotter.camera_position = camera
                self.view.plotter.reset_camera_clipping_range()
            if self.live:
                self.view._render_soon()
        self._refit = False
        if not self.live and not self._redraw:
            loop = kernel_loop()          # in a kernel, one picture after the cell / message, not one per command
            self._redraw = True
            if loop is None:
                self._draw()
            else:
                loop.call_soon(self._draw)
        self._sync()

    def _regrow_camera(self, change):
        """For the undo of a regrow, the camera before it; for its redo, True (fit again); else None."""
        h, command = self.doc.history, getattr(change, "command", None)
        item = h.next_redo if command == "undo" else h.top if command == "redo" else None
        camera = next((cam for fit, cam in self._fits if item is not None and item is fit), None)
        return camera if command == "undo" or camera is None else True

    def _note_fit(self, camera) -> None:
        """Remember the regrow's undo item (the history's top) and the camera before the first regrow joined to it
        (a slider drag regrows many times into one item)."""
        top = self.doc.history.top
        if top is not None and not any(top is fit for fit, _ in self._fits):
            self._fits = [*self._fits[-self.doc.history.max_items:], (top, camera)]

    def _draw(self) -> None:
        if self._redraw and not self._closed:
            self._redraw = False
            self.screen.value = self.view.png()

    def _sync(self) -> None:
        d = self.doc
        if self.treewand:
            n_cmd = sum(1 for e in d.log.events[self._start:]
                        if e.command in ("paint", "paint_stroke", "prune"))   # a regrow logs one regrow
            text = (f"internodes {d.n_internodes} · markers {d.n_markers} · steps {d.steps_done} · "
                    f"brush commands {n_cmd} · regrows {self.regrows}")
        elif self.labels:
            text = (f"painted vertices {int((d.labels > 0).sum())} · label {self.brush.label} · "
                    f"strokes {sum(1 for e in d.log.events if e.command == 'end_stroke')}")
        else:
            text = " · ".join([*_summary(d), f"version {d.version}"])
        self.status.value = f"<span class='plantvr-status-text'>{text}</span>"

    def _on_prune_mode(self, change) -> None:
        self.prune.value = bool(change["new"])

    def _on_label(self, change) -> None:
        self.brush.label = int(change["new"])
        self._sync()

    def _on_mode(self, change) -> None:
        if self.brush is None or not self.live:
            return
        if change["new"] == "Brush":
            self.brush.attach()
        else:
            self.brush.detach()

    # -- regrow (Tree Wand) --------------------------------------------------------------------------------
    def _on_param(self, change) -> None:
        if self._pending or self.doc.restoring:   # an undo restoring a parameter restores its tree too
            return
        self._pending = True
        loop = kernel_loop()
        if loop is None:
            self.doc.after_command(self.flush)    # after the set_params that set it is logged
        else:
            loop.call_soon(self.flush)

    def flush(self) -> None:
        """Run a pending regrow now (after parameters were set in a cell)."""
        if self._pending:
            self._pending = False
            self.regrow()

    def regrow(self) -> int:
        """Grow the document again with its current parameters; returns the number of commands re-issued.

        Tree Wand and TreeSketch: the document's own ``regrow`` command (:meth:`plantvr.Model.regrow`,
        :meth:`~plantvr.documents.treesketch.SketchDocument.regrow`): ``reset``, then the growth commands since
        the last reset that are not undone, re-issued in order, logged as one ``regrow`` and one undo item joined
        to the parameter change that caused it; the document's observers are notified once, at the end. A forest: its
        last ``grow`` again (same overrides and TreeSketch options), when it was grown, joined to the parameter
        change's undo item the same way. The camera is then fitted to the new size (same direction); undoing the
        regrow puts back the camera it had before, redoing it fits again.
        """
        if self._regrow_kind is None:
            raise ValueError(f"regrow needs a Tree Wand, TreeSketch or forest document, got {type(self.doc).__name__}")
        doc = self.doc
        if self._regrow_kind == "forest":
            grows = [e for e in doc.log.events if e.command == "grow"]
            if doc.forest is None or not grows:
                return 0
            self._refit = True
            camera = self.view.plotter.camera_position
            with doc.history_block(amend=True):     # one undo item with the change that caused it
                doc.grow(**dict(grows[-1].kwargs))
            self._note_fit(camera)
            self.regrows += 1
            self._sync()
            return 1
        # a model operation: the document's regrow command (one undo item joined to the parameter change that
        # caused it, logged as one ``regrow``); this view is held, so it redraws once
        camera = self.view.plotter.camera_position
        with self.view.hold():
            n = doc.regrow(amend=True)
        self._note_fit(camera)
        self.regrows += 1
        self._refit = True
        self._on_change(None)
        return n

    # -- lifetime ---------------------------------------------------------------------------------------------
    def close(self) -> None:
        """Stop following the document, detach the brush and close the view and the widgets."""
        doc = getattr(self, "doc", None)
        if doc is None or getattr(self, "_closed", True):  # refused by the constructor, or closed already
            super().close()
            return
        self._closed = True
        doc.off(self._on_change)
        if self._regrow_names:
            doc.unobserve(self._on_param, names=sorted(self._regrow_names))
        if self.treewand:
            doc.unobserve(self._on_prune_mode, names="prune_mode")
        if self.brush is not None:
            self.brush.close()
        if self.wheel is not None:
            self.wheel.unlink()
        if self.growth is not None:
            self.growth.close()
        if self.editor is not None:
            self.editor.close()
        self.view.close()
        super().close()


# -- the part's own panel ------------------------------------------------------------------------------------
def _editor(doc):
    """The part's own panel of ``doc`` (:data:`EDITORS`), or None."""
    cls = EDITORS.get(getattr(doc, "KIND", None))
    if cls is None:
        return None
    if cls is FloretEditor:
        editor = cls(doc, live_preview=False)
        editor.preview.layout.display = "none"      # the workbench's view shows the floret
        return editor
    return cls(doc)


def _summary(doc) -> list[str]:
    """Status items of a document without a brush: what it holds (by kind)."""
    kind = getattr(doc, "KIND", None)
    if kind == "lsystem":
        return [f"step {doc.step} / {doc.derivation_length}", f"modules {doc.n_modules}",
                f"segments {doc.tree.n_internodes}"]
    if kind == "treesketch":
        return [f"internodes {doc.n_internodes}", f"points {doc.n_markers}"]
    if kind == "inflorescence":
        fm = doc.floret
        return [f"floret {fm.frames.shape[1]} vertices", f"{len(fm.faces)} triangles", f"time {doc.time:.2f}"]
    if kind == "crown":
        return [f"surfaces {len(doc.surfaces)}", f"points {len(doc.points)}", f"trees {len(doc.trees)}"]
    if kind == "forest":
        f = doc.forest
        return ["not grown" if f is None else f"trees {len(f.trees)}", *([] if f is None else
                                                                        [f"internodes {f.n_internodes}"])]
    return [type(doc).__name__]

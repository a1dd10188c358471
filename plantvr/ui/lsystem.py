"""The L-system widget: derive an L-Py grammar in the notebook, in the spirit of pgljupyter's ``LsystemWidget``
(issue 23, "A notebook widget").

:class:`LsystemWidget` is the :class:`~plantvr.ui.workbench.Workbench` of an
:class:`~plantvr.documents.lsystem.LSystemDocument` (the live 3D view, or an offscreen image headless, with
undo / redo and a status line) with the :class:`LsystemPanel` beside it: a derivation-step slider, one editor
per parameter the grammar declares (``extern(name=value)``: a slider whose range comes from the default value,
through :func:`~plantvr.ui.panels.make_control`), and the grammar in a text area with an *Apply* button; an
error of the engine is shown with its line and column. Every control issues the document's commands
(``set_step``, ``set_externs``, ``set_grammar``) and follows its changes; none keeps a copy of the state.
"""
from __future__ import annotations

import ipywidgets as W
import numpy as np

from ..documents.lsystem import LSystemDocument
from .lsystem_panel import LsystemPanel, extern_param
from .workbench import Workbench

__all__ = ["LsystemPanel", "LsystemWidget", "extern_param"]

class LsystemWidget(Workbench):
    """The L-system workbench: the document's live 3D view (offscreen image headless) beside its
    :class:`LsystemPanel`, in the spirit of pgljupyter's ``LsystemWidget``.

    Parameters
    ----------
    doc : LSystemDocument or str
        The document, or a grammar (``.lpy`` text) to make one of.
    trusted : bool
        With a grammar str: whether its Python code may run (``LSystemDocument(..., trusted=)``; default False,
        the restricted evaluator). The panel's "Trust this grammar" box sets it for each *Apply*.
    live : bool, optional
        Trame view (True) or offscreen image (False); default :func:`~plantvr.ui.workbench.live_frontend`.
    window_size : (int, int)
        Pixels of the view.

    Attributes
    ----------
    panel : LsystemPanel
        Step slider, parameter editors, grammar and *Apply* (also :attr:`editor`).
    step_slider, controls, grammar, apply_button, trust_box
        The panel's controls.

    The camera is fitted again whenever the tree's size changes by more than a quarter (a derivation step
    doubles it), so the whole plant stays in the picture while the slider is dragged.
    """

    def __init__(self, doc: LSystemDocument | str, *, live: bool | None = None, window_size=(640, 520),
                 trusted: bool = False):
        if isinstance(doc, str):
            doc = LSystemDocument(doc, trusted=trusted)
        if not isinstance(doc, LSystemDocument):
            raise ValueError(f"doc must be an LSystemDocument or a grammar str, got {type(doc).__name__}")
        self._fitted = None
        super().__init__(doc, live=live, window_size=window_size)
        self.panel = self.editor                              # the workbench's LsystemPanel (EDITORS)
        self.step_slider = self.panel.step_slider
        self.grammar, self.apply_button = self.panel.grammar, self.panel.apply_button
        self.trust_box = self.panel.trust_box
        self._fitted = self._extent()
        self._fit()
        if not self.live:
            self.screen.value = self.view.png()
        self._sync()

    def apply(self) -> bool:
        """Issue ``set_grammar`` with the text area's grammar (:meth:`LsystemPanel.apply`)."""
        return self.panel.apply()

    def _fit(self) -> None:
        """The view's three-quarter framing, a little wider, so the top of a tall plant stays in the picture."""
        self.view.frame()
        cam = self.view.plotter.camera
        focal = np.asarray(cam.focal_point, float)
        cam.position = tuple(focal + 1.3 * (np.asarray(cam.position, float) - focal))

    def _extent(self) -> float:
        tree = self.view.tree
        if tree is None or len(tree.pos) == 0:
            return 0.0
        p = tree.pos
        return float((p.max(0) - p.min(0)).max())

    def _on_change(self, change) -> None:
        if self._fitted is not None and not self.view._held:
            size = self._extent()
            if size > 0 and not (0.8 * self._fitted <= size <= 1.25 * self._fitted):
                self._fitted = size
                self._fit()
                if self.live:
                    self.view._render_soon()
        super()._on_change(change)

    @property
    def controls(self) -> dict[str, W.Widget]:
        """The panel's parameter editors (rebuilt when the grammar declares other parameters)."""
        return self.panel.controls

    def _sync(self) -> None:
        if getattr(self, "_fitted", None) is None:      # inside the workbench's constructor
            return super()._sync()
        d = self.doc
        text = (f"step {d.step} / {d.derivation_length} · modules {d.n_modules} · "
                f"segments {d.tree.n_internodes} · version {d.version}")
        self.status.value = f"<span class='plantvr-status-text'>{text}</span>"

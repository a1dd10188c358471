"""The controls of an L-system document (issue 23): step slider, one editor per declared parameter, the grammar
with *Apply*; the workbench shows it beside the view (:class:`~plantvr.ui.lsystem.LsystemWidget`)."""
from __future__ import annotations

import contextlib
import html
import math
import time

import ipywidgets as W

from ..documents.lsystem import LSystemDocument
from ..lsystem.engine import LSystemError
from ..params import Param
from ._sync import SyncGuard
from .panels import make_control, show_value

__all__ = ["LsystemPanel", "extern_param"]

_ERROR = "#c0392b"
#: Seconds between two values of the step slider that still belong to one drag, so one undo item (issue 31).
DRAG_GAP = 0.6


def extern_param(name: str, default: float) -> Param:
    """The :class:`~plantvr.params.Param` of a declared grammar parameter, its range taken from its default:
    ``[0, 3 d]`` for ``d > 0`` (``[3 d, 0]`` for ``d < 0``; ``[-1, 1]`` for 0); an integer default gets an
    integer range of at least ``[0, 10]``. A value set from code outside the range widens the slider."""
    is_int = isinstance(default, int) and not isinstance(default, bool)
    d = float(default)
    if is_int:
        lo, hi = min(0, 3 * int(d)), max(10, 3 * int(d))
    elif d == 0.0 or not math.isfinite(d):
        lo, hi = -1.0, 1.0
    else:
        lo, hi = sorted((0.0, 3.0 * d))
    return Param(name=name, kind=int if is_int else float, default=int(d) if is_int else d,
                 doc=f"Parameter {name} the grammar declares (extern).", ref="grammar extern", window="externs",
                 range=(lo, hi))


class LsystemPanel(W.VBox):
    """The controls of an L-system document: step slider, parameter editors, grammar text with *Apply*.

    Parameters
    ----------
    doc : LSystemDocument

    Attributes
    ----------
    step_slider : ipywidgets.IntSlider
        The derivation step (``doc.set_step`` while dragging).
    controls : dict[str, ipywidgets.Widget]
        One editor per declared parameter (``doc.set_externs`` on release).
    grammar : ipywidgets.Textarea
        The grammar text; *Apply* issues ``doc.set_grammar``.
    trust_box : ipywidgets.Checkbox
        "Trust this grammar (runs its Python code)": *Apply* passes it as ``set_grammar(..., trusted=...)``
        (issue 34: unticked, a grammar with Python code is refused with its line, as Jupyter does not run an
        untrusted notebook's code); it shows the document's flag after every change.
    apply_button : ipywidgets.Button
    status : ipywidgets.HTML
        What the document holds, or the last refusal (an engine error with its line and column) in red.
    """

    def __init__(self, doc: LSystemDocument):
        if not isinstance(doc, LSystemDocument):
            raise ValueError(f"doc must be an LSystemDocument, got {type(doc).__name__}")
        self.doc = doc
        self._busy = SyncGuard()
        self._closed = False
        self.error = ""
        self.step_slider = W.IntSlider(value=doc.step, min=0, max=max(doc.derivation_length, doc.step, 1),
                                       description="Step", continuous_update=True,
                                       tooltip="derivation step (the grammar's derivation length at the right)",
                                       style={"description_width": "150px"},
                                       layout=W.Layout(width="420px", max_width="100%"))
        self.step_slider.observe(self._on_step, names="value")
        self._drag: tuple[float, int] | None = None     # (time, log length) after the last step slider value
        self.controls: dict[str, W.Widget] = {}
        self.params_box = W.VBox([])
        self.grammar = W.Textarea(value=doc.text, description="", continuous_update=False,
                                  layout=W.Layout(width="520px", max_width="100%", height="220px"))
        self.grammar.add_class("plantvr-lpy")
        self.trust_box = W.Checkbox(value=bool(doc.trusted), description="Trust this grammar (runs its Python code)",
                                    indent=False, layout=W.Layout(width="auto"),
                                    tooltip="only for grammars you trust: their imports, functions and rule bodies "
                                            "run as Python")
        self.apply_button = W.Button(description="Apply", icon="check", tooltip="read and derive the grammar",
                                     layout=W.Layout(width="90px"))
        self.apply_button.on_click(lambda _b: self.apply())
        self.status = W.HTML("")
        self._controls_for = None
        self._build_controls()
        doc.on(self._on_change)
        self._show_status()
        title = W.HTML("<div style='background:#3a7a3a;color:white;padding:3px 8px;font-weight:bold'>"
                       "L-system</div>")
        super().__init__([title, self.step_slider, self.params_box, W.Label("Grammar (.lpy)"), self.grammar,
                          W.HBox([self.apply_button, self.trust_box]), self.status],
                         layout=W.Layout(border="2px solid #3a7a3a", padding="0 0 4px 0"))

    # -- widgets -> document -----------------------------------------------------------------------------
    def _on_step(self, change) -> None:
        """A step slider value: one drag (values less than :data:`DRAG_GAP` apart, no other command between) is
        one undo item, the later values joining the first one's (``history_block(amend=True)``)."""
        if self._busy:
            return
        log = self.doc.log.events
        drag = self._drag is not None and time.monotonic() - self._drag[0] < DRAG_GAP and len(log) == self._drag[1]
        with self.doc.history_block(amend=True) if drag else contextlib.nullcontext():
            ok = self._issue(self.doc.set_step, int(change["new"]))
        self._drag = (time.monotonic(), len(log)) if ok else None

    def _on_extern(self, name: str, value) -> None:
        if self._busy:
            return
        self._issue(self.doc.set_externs, {name: value})

    def apply(self) -> bool:
        """Issue ``set_grammar`` with the text area's grammar; returns whether the document took it (a refusal,
        with the engine's line and column, is shown in :attr:`status`)."""
        return self._issue(self.doc.set_grammar, self.grammar.value, None, bool(self.trust_box.value))

    def _issue(self, command, *args) -> bool:
        try:
            command(*args)
        except LSystemError as exc:
            line, col = getattr(exc, "line", None), getattr(exc, "column", None)
            where = f"line {line}, column {col}: " if line is not None and f"line {line}" not in str(exc) else ""
            self._refused(f"{where}{exc}")
            return False
        except ValueError as exc:
            self._refused(str(exc))
            return False
        self.error = ""
        self._show_status()
        return True

    def _refused(self, message: str) -> None:
        self.error = message
        self._pull()                   # the controls show the document's (unchanged) values again
        self.status.value = (f"<span style='color:{_ERROR}' class='plantvr-lsystem-error'>Not applied: "
                             f"{html.escape(message)}</span>")

    # -- document -> widgets -----------------------------------------------------------------------------
    def _on_change(self, change) -> None:
        if self._closed:
            return
        self._pull()
        if not self.error:
            self._show_status()

    def _pull(self) -> None:
        d = self.doc
        with self._busy:
            self._build_controls()
            self.step_slider.max = max(d.derivation_length, d.step, 1, self.step_slider.min)
            self.step_slider.value = d.step
            for name, value in d.externs.items():
                if name in self.controls and self.controls[name].value != value:
                    show_value(self.controls[name], value)
            if self.grammar.value != d.text and not self.error:
                self.grammar.value = d.text
            if not self.error and self.trust_box.value != d.trusted:
                self.trust_box.value = bool(d.trusted)

    def _build_controls(self) -> None:
        """One editor per declared parameter; rebuilt when the grammar declares others."""
        d = self.doc
        values, defaults = d.externs, d.defaults
        names = tuple(values)
        if names == self._controls_for:
            return
        for ctl in self.controls.values():
            ctl.close()
        self.controls = {}
        for name in names:
            ctl = make_control(extern_param(name, defaults.get(name, values[name])), values[name])
            ctl.observe(lambda ch, n=name: self._on_extern(n, ch["new"]), names="value")
            self.controls[name] = ctl
        self._controls_for = names
        self.params_box.children = ([W.Label("Parameters (extern)")] if names else []) + list(self.controls.values())

    def _show_status(self) -> None:
        d = self.doc
        tree = d.tree
        self.status.value = (f"<span class='plantvr-lsystem-status'>step {d.step} / {d.derivation_length} · "
                             f"{d.n_modules} modules · {tree.n_internodes} segments</span>")

    def close(self) -> None:
        """Stop following the document and close the controls."""
        if not getattr(self, "_closed", True):
            self._closed = True
            self.doc.off(self._on_change)
            for ctl in self.controls.values():
                ctl.close()
        super().close()

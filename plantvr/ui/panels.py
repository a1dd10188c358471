"""Parameter windows generated from a document's parameter table (spec 000_treewand §4.6–§4.8, §4.11).

:class:`ParameterPanels` works for any :class:`~plantvr.document.Document` with a ``PARAMS`` table
(:class:`~plantvr.params.ParamTable`): each row becomes one control in the window named by ``param.window``
(windows, titles and colours from ``PARAMS.windows``): a slider for numbers (the row's finite slider span and step,
logarithmic where the row says so, doc as tooltip; a value set from code outside the span widens it), an icon selector with a yellow highlight for texture choices, a dropdown for other choices, a
checkbox for flags. Nothing here restates a parameter: adding a row to a table adds its control. The
Tree Wand influence weights (``w_heading``, ``w_tropism``, ``w_env``) are edited by the
:class:`InfluenceTriangle`, shown when a document has all three.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import ipywidgets as W
import traitlets

from ..params import Param, ParamTable
from .icons import icon_png
from .triangle import InfluenceTriangle

__all__ = ["HIGHLIGHT", "IconSelector", "ParameterPanels", "make_control", "param_traits", "push_param",
           "show_value"]

#: Yellow highlight of the selected icon (§4.8).
HIGHLIGHT = "#f5d142"
#: Parameters edited by the influence triangle (the names ``Model.set_influence`` writes).
INFLUENCE = ("w_heading", "w_tropism", "w_env")
_TEXT_LIMIT = 2000  # integer ranges wider than this get a typed box instead of a slider
_LABEL_WIDTH = "190px"  # the longest label, "Occupation radius (r_occ)", in JupyterLab's 13 px font


def _table(doc) -> ParamTable:
    table = getattr(type(doc), "PARAMS", None)
    if not isinstance(table, ParamTable):
        raise ValueError(f"doc must be a document with a parameter table (PARAMS), got {type(doc).__name__}")
    return table


def param_traits(doc, window: str | None = None) -> list[Param]:
    """The :class:`~plantvr.params.Param` rows of ``doc``'s table (each one of its traits), in table order.

    Parameters
    ----------
    doc : Document
        Any document with a ``PARAMS`` table (a :class:`plantvr.Model`, ...).
    window : str, optional
        Keep only parameters of this window.
    """
    return [p for p in _table(doc) if window is None or p.window == window]


def _label(p: Param) -> str:
    text = p.name.replace("_", " ").capitalize()
    return f"{text} ({p.symbol})" if p.symbol else text


def _tooltip(p: Param) -> str:
    unit = f" [{p.unit}]" if p.unit else ""
    if p.choices:
        allowed = f"one of {list(p.choices)}"
    elif p.range is not None:
        allowed = f"{'(' if p.low_open else '['}{p.range[0]}, {p.range[1]}{')' if p.high_open else ']'}"
    else:
        allowed = ""
    return f"{p.doc}{unit} Allowed: {allowed}; default {p.default!r}. Ref: {p.ref}"


def _float_step(p: Param) -> float:
    if p.step:
        return float(p.step)
    lo, hi = p.slider_span()
    step = (hi - lo) / 200
    if p.default:
        step = min(step, 10 ** math.floor(math.log10(abs(p.default))) / 10)
    return float(f"{step:.1g}")


def _log_bounds(p: Param, value: float) -> tuple[float, float, float]:
    """(min, max, step) exponents of a log slider of ``p`` showing ``value`` (base 10, ~200 steps)."""
    lo, hi = (math.log10(v) for v in p.slider_span())
    if value > 0:
        lo, hi = _log_widen(lo, hi, value)
    return lo, hi, float(f"{(hi - lo) / 200:.1g}")


def _log_widen(lo: float, hi: float, value: float) -> tuple[float, float]:
    """Exponent bounds widened to hold ``value`` (a hair beyond it: ``10 ** log10(v)`` may round below v, and
    the slider would clamp the value)."""
    e = math.log10(value)
    return min(lo, e - 1e-9), max(hi, e + 1e-9)


class IconSelector(W.HBox):
    """A row of image buttons; the selected one has a yellow highlight (spec 000_treewand §4.8).

    Parameters
    ----------
    options : sequence of str
        Choice names (icons from :func:`plantvr.ui.icons.icon_png`).
    param : str
        The texture parameter (picks bark or leaf icons).
    value : str
        Initial choice.
    """

    value = traitlets.Unicode()
    #: Not synced: ipywidgets' front end fails to render a Box with a tooltip; the label and buttons show it.
    tooltip = traitlets.Unicode(None, allow_none=True)

    def __init__(self, options, value: str, description: str = "", tooltip: str = "", param: str = "bark_texture"):
        self.options = tuple(options)
        self.buttons: dict[str, W.Button] = {}
        self.images: dict[str, W.Image] = {}
        items = []
        for i, name in enumerate(self.options):
            img = W.Image(value=icon_png(param, name, i), format="png", width=48, height=48,
                          layout=W.Layout(border="3px solid transparent"))
            btn = W.Button(description=name, tooltip=f"{tooltip} ({name})", layout=W.Layout(width="64px"))
            btn.on_click(lambda _b, n=name: setattr(self, "value", n))
            self.buttons[name], self.images[name] = btn, img
            items.append(W.VBox([img, btn], layout=W.Layout(align_items="center")))
        label = W.Label(description, tooltip=tooltip, layout=W.Layout(width=_LABEL_WIDTH))
        super().__init__([label, *items], tooltip=tooltip)
        self.observe(self._highlight, names=["value"])
        self.value = value
        self._highlight(None)

    @traitlets.validate("value")
    def _check(self, proposal):
        if proposal["value"] not in self.options:
            raise traitlets.TraitError(f"value must be one of {list(self.options)}, got {proposal['value']!r}")
        return proposal["value"]

    def _highlight(self, change) -> None:
        for name in self.options:
            on = name == self.value
            self.images[name].layout.border = f"3px solid {HIGHLIGHT if on else 'transparent'}"
            self.buttons[name].style.button_color = HIGHLIGHT if on else None
            self.buttons[name].style.font_weight = "bold" if on else ""


def make_control(p: Param, value: Any) -> W.Widget:
    """One widget for parameter ``p`` showing ``value``: bounds, step and tooltip come from ``p``."""
    tip, desc = _tooltip(p), _label(p)
    style = {"description_width": _LABEL_WIDTH}
    if p.choices:
        if p.name.endswith("_texture"):
            return IconSelector(p.choices, value, description=desc, tooltip=tip, param=p.name)
        return W.Dropdown(options=list(p.choices), value=value, description=desc, tooltip=tip, style=style)
    if p.kind is bool:
        return W.Checkbox(value=bool(value), description=desc, tooltip=tip, style=style, layout=_slider_layout())
    lo, hi = p.slider_span()
    if p.kind is int:
        if hi - lo > _TEXT_LIMIT:
            return W.IntText(value=int(value), description=desc, tooltip=tip, style=style)
        lo, hi = min(int(lo), int(value)), max(int(hi), int(value))
        return W.IntSlider(value=int(value), min=int(lo), max=int(hi), step=1, description=desc, tooltip=tip,
                           style=style, continuous_update=False, layout=_slider_layout())
    if p.log:
        elo, ehi, estep = _log_bounds(p, float(value))
        return W.FloatLogSlider(value=float(value), base=10, min=elo, max=ehi, step=estep, description=desc,
                                tooltip=tip, style=style, continuous_update=False, readout_format=".3g",
                                layout=_slider_layout())
    step = _float_step(p)
    low = lo + step if p.low_open and lo == p.range[0] else lo
    high = hi - step if p.high_open and hi == p.range[1] else hi
    low, high = min(low, value), max(high, value)  # a valid value set from code is always shown as it is
    return W.FloatSlider(value=float(value), min=low, max=high, step=step, description=desc, tooltip=tip,
                         style=style, continuous_update=False, readout_format=".3g", layout=_slider_layout())


def _slider_layout() -> W.Layout:
    return W.Layout(width="470px", max_width="100%")   # never wider than its column


def push_param(doc, name: str, value: Any, message: W.HTML) -> bool:
    """``doc.set_params(name=value)``; a refusal is shown in red in ``message`` (cleared on success).

    Returns whether the document took the value (on False the caller shows the unchanged value again)."""
    try:
        doc.set_params(**{name: value})
    except ValueError as exc:
        message.value = f"<span style='color:#c0392b'>{exc}</span>"
        return False
    message.value = ""
    return True


def show_value(ctl: W.Widget, value: Any) -> None:
    """Show ``value`` in ``ctl``, widening a slider's range first so a valid value set from code shows as is."""
    if isinstance(ctl, W.FloatLogSlider):
        if value > 0 and not 10 ** ctl.min <= value <= 10 ** ctl.max:
            ctl.min, ctl.max = _log_widen(ctl.min, ctl.max, value)
    elif isinstance(ctl, (W.FloatSlider, W.IntSlider)):
        ctl.min, ctl.max = min(ctl.min, value), max(ctl.max, value)
    ctl.value = value


class ParameterPanels(W.VBox):
    """The parameter windows of one document (Tree Wand: Tree form / Appearance / Light, optionally Settings).

    Parameters
    ----------
    doc : Document
        Any document with a ``PARAMS`` table; the panels keep no values of their own.
    include_hidden : bool
        Also build the ``"hidden"`` window (parameters that appear in no thesis window).
    triangle : InfluenceTriangle, optional
        Influence triangle to show in the window of the influence weights, when ``doc`` has them (one is made
        if omitted).

    Attributes
    ----------
    controls : dict[str, ipywidgets.Widget]
        One control per parameter name.
    windows : dict[str, ipywidgets.VBox]
        One titled, coloured box per window key.
    message : ipywidgets.HTML
        The last rejected value or preset error, in red.
    """

    def __init__(self, doc, *, include_hidden: bool = False, triangle: InfluenceTriangle | None = None):
        table = _table(doc)
        self.doc = doc
        self.controls: dict[str, W.Widget] = {}
        self.windows: dict[str, W.VBox] = {}
        self._busy: set[str] = set()
        self.message = W.HTML("")
        influence = all(n in table for n in INFLUENCE)
        self.triangle = (triangle if triangle is not None else InfluenceTriangle(doc)) if influence else None
        keys = [k for k in table.windows if (k != "hidden" or include_hidden) and param_traits(doc, k)]
        for key in keys:
            title, colour = table.windows[key]
            rows: list[W.Widget] = [W.HTML(f"<div style='background:{colour};color:white;padding:3px 8px;"
                                           f"font-weight:bold'>{title}</div>")]
            for p in param_traits(doc, key):
                if influence and p.name in INFLUENCE:
                    continue
                ctl = make_control(p, getattr(doc, p.name))
                ctl.observe(lambda ch, n=p.name: self._push(n, ch["new"]), names=["value"])
                self.controls[p.name] = ctl
                rows.append(ctl)
            if influence and table[INFLUENCE[0]].window == key:
                rows.insert(1, W.VBox([W.Label("Influence triangle (H, T, E)"), self.triangle]))
            self.windows[key] = W.VBox(rows, layout=W.Layout(border=f"2px solid {colour}", padding="0 0 4px 0"))
        doc.observe(self._pull, names=list(self.controls))
        tabs = W.Tab(children=[self.windows[k] for k in keys])
        for i, k in enumerate(keys):
            tabs.set_title(i, table.windows[k][0])
        self.tabs = tabs
        self.preset_path = W.Text(value="preset.json", description="Preset", layout=W.Layout(width="260px"))
        save = W.Button(description="Save preset", icon="save", layout=W.Layout(width="auto"))
        load = W.Button(description="Load preset", icon="folder-open", layout=W.Layout(width="auto"))
        save.on_click(lambda _b: self._click(self.save))
        load.on_click(lambda _b: self._click(self.load))
        super().__init__([tabs, W.HBox([self.preset_path, save, load], layout=W.Layout(flex_flow="row wrap")),
                          self.message])

    # -- synchronisation --------------------------------------------------------------------------------
    def _push(self, name: str, value) -> None:
        if name in self._busy:
            return
        if not push_param(self.doc, name, value, self.message):
            self._pull({"name": name})  # show the document's (unchanged) value again

    def _pull(self, change) -> None:
        name = change["name"]
        self._busy.add(name)
        try:
            show_value(self.controls[name], getattr(self.doc, name))
        finally:
            self._busy.discard(name)

    def _click(self, action) -> None:
        try:
            action(self.preset_path.value)
        except ValueError:
            pass  # already shown in self.message; a button has no caller to raise to

    # -- presets ----------------------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path | None:
        """Save all parameters as a JSON preset; errors are shown in :attr:`message` and re-raised."""
        try:
            out = self.doc.save_preset(path)
        except ValueError as exc:
            self.message.value = f"<span style='color:#c0392b'>{exc}</span>"
            raise
        self.message.value = f"saved {out!s}"
        return out

    def load(self, path: str | Path) -> None:
        """Load a JSON preset into the document (nothing changes if any value is bad)."""
        try:
            self.doc.load_preset(path)
        except ValueError as exc:
            self.message.value = f"<span style='color:#c0392b'>{exc}</span>"
            raise
        self.message.value = f"loaded {Path(path)!s}"

    def close(self) -> None:
        """Stop observing the document and close every control."""
        doc = getattr(self, "doc", None)  # None when the constructor refused its arguments
        if doc is not None:
            doc.unobserve(self._pull, names=list(self.controls))
        if getattr(self, "triangle", None) is not None:
            self.triangle.close()
        super().close()

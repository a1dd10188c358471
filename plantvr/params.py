"""The one parameter-table mechanism, and the Tree Wand table (spec 000_treewand §4.11, tables B.1–B.3 + hidden).

Every document declares its parameters once, as a :class:`ParamTable` of :class:`Param` rows (name, symbol,
range or choices, default, unit, doc, thesis reference, window). From the table come the document's traits
(:meth:`ParamTable.traits`), validation (:meth:`ParamTable.validate`), the notebook sliders and panels
(:mod:`plantvr.ui.panels`), JSON presets in one format (:meth:`ParamTable.preset_text`,
:meth:`ParamTable.read_preset`) and the parameter reference page (:meth:`ParamTable.reference`); nothing else
restates a range or a default. :data:`TREEWAND` is the Tree Wand table; :data:`PARAMS`, :func:`validate` and
:func:`defaults` are its rows and checks.
Defaults marked [INFERRED] in the spec are the spec's suggested values unless noted.

Every range was reviewed for issue 20: each value it accepts, extremes included (a denormal ``base_length`` or
``view_radius``, ``darts_per_paint = 10**6``, ``fine_cells = 64`` with ``shadow_depth = 32``), keeps growth
working; the kernels clip, cap or coarsen instead (tests/growth/test_hardening.py), so no range was narrowed.

Issue 31: every numeric row's range is finite (a table refuses ``inf`` when it is built), and where the accepted
range is wider than a slider can show, the row declares the span its slider covers (``slider``) and, where that
span covers decades, a logarithmic slider (``log``); values outside the span stay valid from code (the slider
widens to show them). A panel's bounds therefore always serialise as strict JSON.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Iterable

from traitlets import HasTraits, TraitType

from ._fileio import read_json, write_atomic
from ._validation import check_choice, check_int, check_range

__all__ = ["Param", "ParamTable", "ParamTrait", "PRESET_FORMAT", "PARAMS", "PARAM_BY_NAME", "TREEWAND", "WINDOWS",
           "check_params", "defaults", "validate"]

#: Version of the JSON preset format, ``{"plantvr_preset": 1, "table": name, "params": {name: value}}``.
PRESET_FORMAT = 1

#: Parameter windows (spec §4.6; colours are the menu colours of §4.5, ambiguity A.21 resolved in figure order).
WINDOWS = {"form": ("Tree form", "#3a9a3a"), "appearance": ("Appearance", "#c0392b"),
           "light": ("Light", "#2e6fd0"), "hidden": ("Settings", "#777777")}


@dataclass(frozen=True)
class Param:
    """One model parameter: its symbol, allowed values, default, unit, doc and thesis reference."""

    name: str
    kind: type
    default: Any
    doc: str
    ref: str
    window: str
    symbol: str = ""
    unit: str = ""
    range: tuple[float, float] | None = None
    choices: tuple = ()
    low_open: bool = False
    high_open: bool = False
    step: float | None = field(default=None, compare=False)
    #: The span a slider covers when the accepted range is wider than a slider can show (values outside it are
    #: still accepted from code; the slider widens to show them); default the range itself.
    slider: tuple[float, float] | None = field(default=None, compare=False)
    #: A logarithmic slider (for spans over decades; needs a positive low end).
    log: bool = field(default=False, compare=False)

    def slider_span(self) -> tuple[float, float]:
        """The finite ``(low, high)`` of this parameter's slider: :attr:`slider`, else :attr:`range`."""
        lo, hi = self.slider if self.slider is not None else self.range
        return lo, hi

    def check(self, value: Any) -> Any:
        """Return ``value`` converted to this parameter's type, or raise ``ValueError`` naming it."""
        if self.choices:
            return check_choice(self.name, value, self.choices)
        if self.kind is bool:
            if not isinstance(value, (bool, int)) or value not in (0, 1):
                raise ValueError(f"{self.name} must be True or False, got {value!r}")
            return bool(value)
        low, high = self.range
        if self.kind is int:
            return check_int(self.name, value, int(low), int(high))
        return check_range(self.name, value, low, high, low_open=self.low_open, high_open=self.high_open)


class ParamTrait(TraitType):
    """A trait whose default, type and range come from one :class:`Param`."""

    def __init__(self, param: Param):
        super().__init__(default_value=param.default, help=param.doc)
        self.param = param
        self.tag(param=param, window=param.window)

    def validate(self, obj, value):
        return self.param.check(value)


class ParamTable:
    """A document's parameters, declared once.

    Parameters
    ----------
    name : str
        Table name (``"treewand"``, ``"treesketch"``, ...), written into presets.
    params : iterable of Param
        The rows, in display order; names must be unique.
    windows : dict, optional
        ``{window: (title, colour)}`` of the panels the rows are grouped in (default: one window per distinct
        ``Param.window``, titled by its name).
    """

    def __init__(self, name: str, params: Iterable[Param], windows: dict[str, tuple[str, str]] | None = None):
        self.name = name
        self.params: tuple[Param, ...] = tuple(params)
        self.by_name: dict[str, Param] = {p.name: p for p in self.params}
        if len(self.by_name) != len(self.params):
            raise ValueError(f"parameter table {name!r} repeats a name")
        for p in self.params:
            _check_span(name, p)
        self.windows = dict(windows) if windows is not None else {p.window: (p.window.title(), "#777777")
                                                                  for p in self.params}

    def __iter__(self):
        return iter(self.params)

    def __len__(self) -> int:
        return len(self.params)

    def __contains__(self, name: object) -> bool:
        return name in self.by_name

    def __getitem__(self, name: str) -> Param:
        return self.by_name[name]

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    def defaults(self) -> dict[str, Any]:
        """``{name: default}`` of every row."""
        return {p.name: p.default for p in self.params}

    def validate(self, values: dict[str, Any]) -> dict[str, Any]:
        """A checked copy of ``values``; unknown names and bad values raise ``ValueError`` naming them."""
        out = {}
        for name, value in values.items():
            if name not in self.by_name:
                raise ValueError(f"unknown parameter {name!r}; known parameters: {sorted(self.by_name)}")
            out[name] = self.by_name[name].check(value)
        return out

    def check(self, params: Any, *, partial: bool = False) -> dict[str, Any]:
        """``params`` (a dict) checked: names known, values in range, and complete unless ``partial``."""
        if not isinstance(params, dict):
            raise ValueError(f"params must be a dict of {self.name} parameters, got {type(params).__name__}")
        bad = [k for k in params if not isinstance(k, str)]
        if bad:
            raise ValueError(f"params keys must be parameter names, got {bad[0]!r}")
        out = self.validate(params)
        if not partial:
            missing = sorted(set(self.by_name) - set(out))
            if missing:
                raise ValueError(f"params is missing {missing[:5]} (start from the table's defaults())")
        return out

    @cached_property
    def traits(self) -> type[HasTraits]:
        """A ``HasTraits`` class with one :class:`ParamTrait` per row: a document class lists it as a base."""
        return type(f"_{self.name.title()}Params", (HasTraits,), {p.name: ParamTrait(p) for p in self.params})

    # -- presets: the one JSON format -------------------------------------------------------------------
    def preset_text(self, values: dict[str, Any]) -> str:
        """``values`` (checked) as preset JSON text."""
        return json.dumps({"plantvr_preset": PRESET_FORMAT, "table": self.name, "params": self.validate(values)},
                          indent=1)

    def save_preset(self, path: str | os.PathLike, values: dict[str, Any]) -> Path:
        """Write ``values`` as a ``.json`` preset, atomically."""
        path = _json_path(path)
        try:
            return write_atomic(path, self.preset_text(values))
        except OSError as exc:
            raise ValueError(f"cannot write preset {path!s}: {exc}") from None

    def read_preset(self, path: str | os.PathLike) -> dict[str, Any]:
        """The checked ``{name: value}`` of a preset file; a foreign, damaged or out-of-range one raises
        ``ValueError`` naming the file (presets written before tables had names load too)."""
        path = Path(path)
        data = read_json(path, "preset")
        if (not isinstance(data, dict) or data.get("plantvr_preset") != PRESET_FORMAT
                or not isinstance(data.get("params"), dict)):
            raise ValueError(f"preset {path!s} is not a PlantVR preset "
                             f"(expected {{'plantvr_preset': {PRESET_FORMAT}, 'params': {{...}}}})")
        if data.get("table", self.name) != self.name:
            raise ValueError(f"preset {path!s} holds {data['table']!r} parameters, not {self.name!r} ones"[:300])
        try:
            return self.validate(data["params"])
        except ValueError as exc:
            raise ValueError(f"preset {path!s}: {exc}") from None

    # -- the reference page ---------------------------------------------------------------------------------
    def reference(self) -> str:
        """The parameter reference page of this table, as Markdown (one section per window)."""
        lines = [f"## {self.name} parameters", ""]
        for key, (title, _) in self.windows.items():
            rows = [p for p in self.params if p.window == key]
            if not rows:
                continue
            lines += [f"### {title}", "", "| name | symbol | default | allowed | unit | thesis | meaning |",
                      "|---|---|---|---|---|---|---|"]
            for p in rows:
                allowed = ", ".join(map(str, p.choices)) if p.choices else _interval(p)
                lines.append(f"| `{p.name}` | {p.symbol} | {p.default!r} | {allowed} | {p.unit} | {p.ref} | "
                             f"{p.doc} |")
            lines.append("")
        return "\n".join(lines)


def _check_span(table: str, p: Param) -> None:
    """A numeric row's range and slider span are finite, and the span is a slider's (inside the range, low <
    high, positive when logarithmic): a panel can send its bounds as JSON and a pixel of it means something."""
    if p.choices or p.kind is bool:
        return
    where = f"parameter {p.name!r} of table {table!r}"
    if p.range is None or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in p.range):
        raise ValueError(f"{where} needs a finite range, got {p.range!r}")
    lo, hi = p.slider_span()
    if not (math.isfinite(lo) and math.isfinite(hi) and p.range[0] <= lo < hi <= p.range[1]):
        raise ValueError(f"{where}: slider span {(lo, hi)!r} must be finite, increasing and inside {p.range!r}")
    if p.log and (lo <= 0 or (p.range[0] <= 0 and not p.low_open)):
        raise ValueError(f"{where}: a logarithmic slider needs positive values, got span {(lo, hi)!r} of {p.range!r}")


def _interval(p: Param) -> str:
    if p.kind is bool or p.range is None:
        return "True, False"
    lo, hi = p.range
    return f"{'(' if p.low_open else '['}{lo:g}, {hi:g}{')' if p.high_open else ']'}"


def _json_path(path) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"preset path must be a str or path-like ending in .json, got {type(path).__name__}")
    path = Path(path)
    if path.suffix != ".json":
        raise ValueError(f"preset path must end in .json, got {path.suffix!r}")
    return path


def _p(name, kind, default, window, ref, doc, **kw) -> Param:
    return Param(name=name, kind=kind, default=default, window=window, ref=ref, doc=doc, **kw)


PARAMS: tuple[Param, ...] = (
    # B.1 Tree form window
    _p("w_heading", float, 0.4, "form", "§2.4 Eq. 9.5", "Influence-triangle weight H of the bud heading.",
       symbol="H", range=(0.0, 1.0)),
    _p("w_tropism", float, 0.1, "form", "§2.4 Eq. 9.5", "Influence-triangle weight T of the tropism vector.",
       symbol="T", range=(0.0, 1.0)),
    _p("w_env", float, 0.5, "form", "§2.4 Eq. 9.5",
       "Influence-triangle weight E of the direction to the assigned markers.", symbol="E", range=(0.0, 1.0)),
    _p("tropism_angle", float, 0.0, "form", "§2.4 (ERRATUM A.4: from vertical)",
       "Angle from vertical for the tropism influence (0 up, 90 horizontal, 180 down).",
       symbol="φ", unit="deg", range=(0.0, 180.0)),
    _p("max_len_mult", float, 2.0, "form", "§2.9 Eqs. 9.16/9.17",
       "Maximum internode length as a multiple of the base length (α).", symbol="α", range=(1.0, 10.0)),
    _p("apical_dominance", float, 0.55, "form", "§2.5 Eqs. 9.6/9.7",
       "λ: share of vigor sent to the main child (> 0.5 excurrent).", symbol="λ", range=(0.0, 1.0)),
    _p("branch_angle", float, 45.0, "form", "§2.1 Eq. 9.2", "Lateral branching angle.",
       symbol="θ_lat", unit="deg", range=(0.0, 90.0)),
    _p("main_branch_angle", float, 0.0, "form", "§2.1 Eq. 9.1", "Main branching angle.",
       symbol="θ_main", unit="deg", range=(0.0, 90.0)),
    _p("phyllotaxis_angle", float, 137.5, "form", "§2.1 Eq. 9.3", "Divergence angle between successive buds.",
       symbol="θ_div", unit="deg", range=(0.0, 360.0)),
    _p("view_angle", float, 90.0, "form", "§2.3 (A.19: full apex angle)",
       "Full apex angle of a bud's perception cone.", unit="deg", range=(0.0, 360.0), low_open=True),
    _p("view_radius", float, 4.0, "form", "§2.3", "Radius of a bud's perception volume.",
       symbol="r_v", unit="m", range=(0.0, 100.0), low_open=True),
    _p("occupation_radius", float, 1.0, "form", "§2.3, §2.2",
       "Radius of the occupation zone around each node; also the Poisson-dart rejection radius.",
       symbol="r_occ", unit="m", range=(0.0, 50.0), low_open=True),
    # B.2 Appearance window
    _p("bark_texture", str, "furrowed", "appearance", "§3.3", "Bark texture.", choices=("furrowed", "birch")),
    _p("bark_rate", float, 1.0, "appearance", "§3.3", "How stretched vertically the bark texture is.",
       symbol="ρ", range=(0.0, 100.0), low_open=True, slider=(0.05, 50.0), log=True),
    _p("tip_radius", float, 0.02, "appearance", "§2.8", "Radius of the end internodes of each branch.",
       symbol="r_tip", unit="m", range=(0.0, 10.0), low_open=True, slider=(0.002, 1.0), log=True),
    _p("radius_exp", float, 2.5, "appearance", "§2.8 Eq. 9.15", "Pipe-model exponent n in r^n = Σ r_i^n.",
       symbol="n", range=(1.0, 4.0)),
    _p("leaf_texture", str, "ovate", "appearance", "§3.4", "Leaf texture and its geometry.",
       choices=("ovate", "lobed")),
    _p("leaf_size", float, 0.5, "appearance", "§3.4", "Scale of the leaves; 0 produces no leaves.",
       unit="m", range=(0.0, 10.0)),
    _p("petiole_length", float, 0.1, "appearance", "§3.4", "Length of the petioles.", unit="m", range=(0.0, 5.0)),
    _p("petiole_twist", float, 0.05, "appearance", "§3.4 Eq. 10.15", "Elasticity around the leaf heading.",
       range=(0.0, 1.0)),
    _p("petiole_bend_up", float, 0.05, "appearance", "§3.4 Eq. 10.15", "Elasticity around the leaf right vector.",
       range=(0.0, 1.0)),
    _p("petiole_bend_right", float, 0.05, "appearance", "§3.4 Eq. 10.15", "Elasticity around the leaf up vector.",
       range=(0.0, 1.0)),
    # B.3 Light window
    _p("shadow_intensity", float, 0.2, "light", "§2.6 Eq. 9.10", "α: intensity of a node's shadow.",
       symbol="α_s", range=(0.0, 10.0), low_open=True, slider=(0.01, 10.0), log=True),
    _p("shadow_falloff", float, 0.5, "light", "§2.6 Eq. 9.10", "β: how quickly the shadow falls off.",
       symbol="β", range=(0.0, 1.0), low_open=True, high_open=True),
    _p("shadow_depth", int, 6, "light", "§2.6 Alg. 9.1", "q_max: cells downward the shadow pyramid extends.",
       symbol="q_max", range=(1, 32)),
    _p("vigor_mult", float, 2.0, "light", "§2.5", "α: converts base light into vigor, v_base = α Q_base.",
       symbol="α_v", range=(0.0, 100.0), low_open=True, slider=(0.05, 100.0), log=True),
    _p("activation_threshold", float, 0.2, "light", "§2.5", "Vigor a bud needs to become active.",
       range=(0.0, 100.0), slider=(0.0, 10.0)),
    _p("light_exponent", float, 1.0, "light", "§2.5 Eq. 9.8", "κ in Q = L^κ; 0 ignores light.",
       symbol="κ", range=(0.0, 10.0)),
    # Settings that appear in no window (spec §4.11, last table)
    _p("base_length", float, 1.0, "hidden", "§2.9", "Base internode length l_b (also the shadow cell size d).",
       symbol="l_b", unit="m", range=(0.0, 100.0), low_open=True, slider=(0.05, 20.0), log=True),
    _p("length_mode", str, "vigor", "hidden", "§2.9", "Internode-length mode (vigor is the thesis default).",
       choices=("vigor", "order", "constant")),
    _p("branching", str, "alternate", "hidden", "§2.1", "Two-way (alternate) or three-way (opposite) nodes.",
       choices=("alternate", "opposite")),
    _p("opposite_main", str, "eq9.1", "hidden", "§2.1 (ambiguity A.3)", "Main-bud rule in opposite mode.",
       choices=("eq9.1", "perpendicular", "none")),
    _p("shed_count", str, "direct", "hidden", "§2.5 (ambiguity A.18)",
       "Shed when vigor < direct child internodes, or < subtree internodes.", choices=("direct", "subtree")),
    _p("tropism_min_order", int, 0, "hidden", "§2.4 (ambiguity A.22)", "Lowest branch order tropism acts on.",
       range=(0, 100)),
    _p("shadow_loop_inclusive", bool, False, "hidden", "§2.6 (ERRATUM A.5)",
       "Run the shadow pyramid to q_max instead of the printed q_max − 1.", range=(0, 1)),
    _p("marker_lifetime", int, 60, "hidden", "§2.2", "Growth steps a marker lives.", range=(1, 100_000),
       slider=(1, 1000)),
    _p("darts_per_paint", int, 50, "hidden", "§2.2", "Poisson-dart candidates per paint call.", range=(1, 1_000_000),
       slider=(1, 2000)),
    _p("brush_radius", float, 1.0, "hidden", "§4.3", "Wand (brush) radius.", unit="m", range=(0.05, 20.0)),
    _p("fine_cells", int, 16, "hidden", "§2.7", "Fine cells per coarse-cell edge of the shadow grid.",
       range=(2, 64)),
    _p("bezier_weight", float, 3.0, "hidden", "§3.1 Eq. 10.1", "Weight w of the central Bézier control point.",
       range=(0.0, 100.0), low_open=True, slider=(0.05, 50.0), log=True),
    _p("leaf_iterations", int, 15, "hidden", "§3.4", "Leaf reorientation iterations.", range=(1, 100)),
)

#: The Tree Wand parameter table (the :class:`plantvr.Model` document's).
TREEWAND = ParamTable("treewand", PARAMS, WINDOWS)
PARAM_BY_NAME: dict[str, Param] = TREEWAND.by_name
#: ``{name: default}`` of the Tree Wand table.
defaults = TREEWAND.defaults
#: Tree Wand values checked (unknown names and bad values raise ``ValueError``).
validate = TREEWAND.validate
#: A Tree Wand parameter dict checked, complete unless ``partial``.
check_params = TREEWAND.check


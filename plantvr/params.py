"""The one parameter table of the Tree Wand model (spec 000_treewand §4.11, tables B.1–B.3 + hidden settings).

Traits of :class:`plantvr.Model`, notebook sliders, the ``.tree`` file header and validation are all
generated from :data:`PARAMS`; nothing else restates a range or a default.
Defaults marked [INFERRED] in the spec are the spec's suggested values unless noted.

Every range was reviewed for issue 20: each value it accepts, extremes included (a denormal ``base_length`` or
``view_radius``, ``darts_per_paint = 10**6``, ``fine_cells = 64`` with ``shadow_depth = 32``), keeps growth
working; the kernels clip, cap or coarsen instead (tests/growth/test_hardening.py), so no range was narrowed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ._validation import check_choice, check_int, check_range

__all__ = ["Param", "PARAMS", "PARAM_BY_NAME", "WINDOWS", "check_params", "defaults", "validate"]

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
       symbol="ρ", range=(0.0, 100.0), low_open=True),
    _p("tip_radius", float, 0.02, "appearance", "§2.8", "Radius of the end internodes of each branch.",
       symbol="r_tip", unit="m", range=(0.0, 10.0), low_open=True),
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
       symbol="α_s", range=(0.0, 10.0), low_open=True),
    _p("shadow_falloff", float, 0.5, "light", "§2.6 Eq. 9.10", "β: how quickly the shadow falls off.",
       symbol="β", range=(0.0, 1.0), low_open=True, high_open=True),
    _p("shadow_depth", int, 6, "light", "§2.6 Alg. 9.1", "q_max: cells downward the shadow pyramid extends.",
       symbol="q_max", range=(1, 32)),
    _p("vigor_mult", float, 2.0, "light", "§2.5", "α: converts base light into vigor, v_base = α Q_base.",
       symbol="α_v", range=(0.0, 100.0), low_open=True),
    _p("activation_threshold", float, 0.2, "light", "§2.5", "Vigor a bud needs to become active.",
       range=(0.0, 100.0)),
    _p("light_exponent", float, 1.0, "light", "§2.5 Eq. 9.8", "κ in Q = L^κ; 0 ignores light.",
       symbol="κ", range=(0.0, 10.0)),
    # Settings that appear in no window (spec §4.11, last table)
    _p("base_length", float, 1.0, "hidden", "§2.9", "Base internode length l_b (also the shadow cell size d).",
       symbol="l_b", unit="m", range=(0.0, 100.0), low_open=True),
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
    _p("marker_lifetime", int, 60, "hidden", "§2.2", "Growth steps a marker lives.", range=(1, 100_000)),
    _p("darts_per_paint", int, 50, "hidden", "§2.2", "Poisson-dart candidates per paint call.", range=(1, 1_000_000)),
    _p("brush_radius", float, 1.0, "hidden", "§4.3", "Wand (brush) radius.", unit="m", range=(0.05, 20.0)),
    _p("fine_cells", int, 16, "hidden", "§2.7", "Fine cells per coarse-cell edge of the shadow grid.",
       range=(2, 64)),
    _p("bezier_weight", float, 3.0, "hidden", "§3.1 Eq. 10.1", "Weight w of the central Bézier control point.",
       range=(0.0, 100.0), low_open=True),
    _p("leaf_iterations", int, 15, "hidden", "§3.4", "Leaf reorientation iterations.", range=(1, 100)),
)

PARAM_BY_NAME: dict[str, Param] = {p.name: p for p in PARAMS}


def defaults() -> dict[str, Any]:
    """Return ``{name: default}`` for every parameter."""
    return {p.name: p.default for p in PARAMS}


def validate(values: dict[str, Any]) -> dict[str, Any]:
    """Return a checked copy of ``values``; unknown names and bad values raise ``ValueError``."""
    out = {}
    for name, value in values.items():
        if name not in PARAM_BY_NAME:
            raise ValueError(f"unknown parameter {name!r}; known parameters: {sorted(PARAM_BY_NAME)}")
        out[name] = PARAM_BY_NAME[name].check(value)
    return out


def radians(values: dict[str, Any], name: str) -> float:
    """Return the degree-valued parameter ``name`` of ``values`` in radians."""
    return math.radians(values[name])


def check_params(params: Any, *, partial: bool = False) -> dict[str, Any]:
    """``params`` checked against the parameter table (names known, values in range), complete unless ``partial``.

    Raises ``ValueError`` naming the parameter; returns a new dict of converted values.
    """
    if not isinstance(params, dict):
        raise ValueError(f"params must be a dict of growth parameters, got {type(params).__name__}")
    bad = [k for k in params if not isinstance(k, str)]
    if bad:
        raise ValueError(f"params keys must be parameter names, got {bad[0]!r}")
    out = validate(params)
    if not partial:
        missing = sorted(set(PARAM_BY_NAME) - set(out))
        if missing:
            raise ValueError(f"params is missing {missing[:5]} (start from plantvr.params.defaults())")
    return out

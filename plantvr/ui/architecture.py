"""TreeSketch architecture panel (spec 004_treesketch §2.3 items 1–7, §1.4.5–1.4.7, §1.6.1; Fig. 5.4).

:class:`ArchitectureState` is the panel's model: one trait per architecture parameter, bound to a
:class:`~plantvr.growth.sketch.SketchEngine` (growth parameters of the table *and* TreeSketch options) or to a
:class:`plantvr.Model` (table parameters only; the TreeSketch options are then kept on the state, ready for an
engine, because the Model has no TreeSketch options). Every edit goes through :meth:`ArchitectureState.set`,
which checks all values first (the parameter table, then the engine's own option checks on a probe engine) and
only then writes the target, so a rejected edit leaves everything unchanged and the message names the parameter.

The anywidgets (one front end, ``widgets/architecture.js``, that draws the widget's ``kind``) keep no state beyond
their synced traits:

* :class:`SchematicTree`: the live 2D schematic tree, grown by the same model constrained to a plane (a fixed-seed
  autonomous run of a SketchEngine in a depth slab, distichous in-plane laterals), with the set-point tropism
  arrow theta that a drag "pushes", and a top-view inset of the divergence (phyllotaxis) angle;
* :class:`GravimorphismEllipse`: the control ellipse (s_v, s_p, e_v) of Eq. 4.6 with bud lines coloured red to green
  by the relative resource factor b at tau = 90 degrees; drag the centre vertically (e_v) or the top / side handles
  (s_v / s_p);
* :class:`AngleWidget`: draggable rays from a vertical parent axis, used for the branching angles (psi, delta) and
  the set-point tropism angle theta;
* the barycentric (alpha, beta, gamma) triangle is :class:`plantvr.ui.triangle.InfluenceTriangle`, reused as is.

:class:`ArchitecturePanel` lays them out with the sliders (lambda, kappa, Th, n_max, internode length, divergence)
and the switches (stroke tropism, trunk up).
"""
from __future__ import annotations

import math
from typing import Any

import anywidget
import ipywidgets as W
import numpy as np
import traitlets

from ..growth.sketch import SketchEngine, barycentric, ellipse_distance
from ..documents.treewand import Model
from ..params import ParamTrait
from ..params import PARAM_BY_NAME, defaults, validate
from ._assets import asset
from .panels import make_control
from .triangle import InfluenceTriangle

__all__ = ["ARCH_PARAMS", "SKETCH_OPTIONS", "AngleWidget", "ArchitecturePanel", "ArchitectureState",
           "GravimorphismEllipse", "SchematicTree", "ellipse_rays", "schematic_tree"]

#: Growth parameters of the parameter table that the architecture panel edits.
ARCH_PARAMS = ("w_heading", "w_tropism", "w_env", "tropism_angle", "branch_angle", "phyllotaxis_angle",
               "base_length", "apical_dominance", "light_exponent")
#: TreeSketch options (SketchEngine keywords) that the panel edits.
SKETCH_OPTIONS = ("n_max", "deflection", "ellipse", "shed_threshold", "trunk_up", "stroke_tropism")
_INFLUENCE = ("w_heading", "w_tropism", "w_env")
_DEFAULT_OPTIONS = {"n_max": 3, "deflection": 0.0, "ellipse": (1.0, 1.0, 0.0), "shed_threshold": 0.0,
                    "trunk_up": False, "stroke_tropism": False}


# -- numeric helpers (pure functions, tested without a browser) --------------------------------------------------
def ellipse_rays(s_v: float, s_p: float, e_v: float, *, n: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Bud lines of the gravimorphism widget: polar angles chi (from +V toward +P) and the distance d to the
    control ellipse along each, which is b of Eq. 4.6 on a horizontal axis (tau = 90 degrees).

    Parameters
    ----------
    s_v, s_p : float
        Semi-axes along **V** (up) and **P** (side), > 0.
    e_v : float
        Offset of the ellipse centre along **V**.
    n : int
        Number of lines, evenly spaced over the full circle.

    Returns
    -------
    chi : (n,) float64 ndarray
        Radians.
    d : (n,) float64 ndarray
        Distance from the axis to the ellipse (0 where the ray misses it).

    References
    ----------
    .. [1] Longay thesis §4.4.3, Fig. 4.20B, §5.1.1 (red-to-green bud lines); spec 004 §1.4.6, §2.3 item 3.
    """
    from .._validation import check_int

    n = check_int("n", n, 1, 360)
    chi = np.arange(n) * (2.0 * math.pi / n)
    return chi, ellipse_distance(chi, s_v=s_v, s_p=s_p, e_v=e_v)


def schematic_tree(params: dict[str, Any], options: dict[str, Any], *, iterations: int = 12, seed: int = 0,
                   slab: float = 0.5, point_density: int = 4, max_internodes: int = 400) -> np.ndarray:
    """The 2D schematic tree: the same growth model constrained to the plane z = 0 (spec 004 §2.3 item 1).

    A fixed-seed autonomous run of a :class:`~plantvr.growth.sketch.SketchEngine` whose attraction points are kept in
    a slab |z| <= ``slab`` (the depth constraint, App. B) and whose laterals alternate in the plane (divergence
    180 degrees, the lateral vector of the seedling along x) [INFERRED in the spec].

    Parameters
    ----------
    params : dict
        Growth parameters (table names); missing ones take their defaults.
    options : dict
        TreeSketch options (``n_max``, ``deflection``, ``ellipse``, ``shed_threshold``, ``trunk_up``,
        ``stroke_tropism``).
    iterations : int
        Growth steps.
    seed : int
        Seed of the run (fixed, so the picture changes only with the parameters).
    slab : float
        Half depth of the point slab around z = 0, internode lengths.
    point_density : int
        K of autonomous growth.
    max_internodes : int
        Growth stops early once the schematic has this many internodes, which bounds the refresh time whatever
        the parameters (the thesis's "instantaneously", spec §8.2 [INFERRED] <= 50 ms).

    Returns
    -------
    (S, 6) float64 ndarray
        One row per live internode: x0, y0, x1, y1 (the projection on z = 0, in internode lengths), radius and
        branch order.
    """
    from .._validation import check_int, check_range

    iterations = check_int("iterations", iterations, 0, 200)
    max_internodes = check_int("max_internodes", max_internodes, 1, 10 ** 6)
    slab = check_range("slab", slab, 0.0, 1e6, low_open=True)
    seed = check_int("seed", seed, 0, 2 ** 63 - 1)
    point_density = check_int("point_density", point_density, 0, 1000)
    if not isinstance(params, dict) or not isinstance(options, dict):
        raise ValueError(f"params and options must be dicts, got {type(params).__name__} and "
                         f"{type(options).__name__}")
    p = {**defaults(), **validate(params), "phyllotaxis_angle": 180.0, "activation_threshold": 0.0}
    opts = {k: v for k, v in options.items() if k in SKETCH_OPTIONS and k != "stroke_tropism"}
    eng = SketchEngine(p, rng=seed, mode="autonomous", point_density=point_density,
                       depth={"normal": (0.0, 0.0, 1.0), "depth": slab}, **opts)
    for _ in range(iterations):
        if eng.tree.n_internodes >= max_internodes:
            break
        eng.step()
    t = eng.tree
    live = np.flatnonzero(t.alive & (t.parent >= 0))
    a, b = t.pos[t.parent[live]], t.pos[live]
    scale = p["base_length"]
    return np.column_stack([a[:, 0] / scale, a[:, 1] / scale, b[:, 0] / scale, b[:, 1] / scale,
                            t.radius[live] / scale, t.order[live].astype(float)])


# -- the panel's model ---------------------------------------------------------------------------------------------
_ArchTraits = type("_ArchTraits", (traitlets.HasTraits,), {n: ParamTrait(PARAM_BY_NAME[n]) for n in ARCH_PARAMS})


class ArchitectureState(_ArchTraits):
    """Architecture parameters of one tree, bound to the engine (or model) that grows it.

    Parameters
    ----------
    target : SketchEngine or plantvr.Model
        What the panel commands. A SketchEngine gets parameters and options; a Model gets the table parameters
        (through ``Model.set_params``, so its own observers run) while the options stay on this state.

    Attributes
    ----------
    version : int
        Bumped after every accepted edit; widgets observe it.
    """

    n_max = traitlets.Int(3)
    deflection = traitlets.Float(0.0)
    ellipse = traitlets.Tuple(traitlets.Float(), traitlets.Float(), traitlets.Float(), default_value=(1.0, 1.0, 0.0))
    shed_threshold = traitlets.Float(0.0)
    trunk_up = traitlets.Bool(False)
    stroke_tropism = traitlets.Bool(False)
    version = traitlets.Int(0)

    def __init__(self, target):
        super().__init__()
        self._target = None
        self._probe: SketchEngine | None = None
        self.bind(target)

    # -- target --------------------------------------------------------------------------------------------
    @property
    def target(self):
        """The bound SketchEngine or Model."""
        return self._target

    @property
    def engine(self) -> SketchEngine | None:
        """The bound SketchEngine, or None when the target is a Model."""
        return self._target if isinstance(self._target, SketchEngine) else None

    def bind(self, target) -> None:
        """Bind to another SketchEngine or Model (e.g. a tree reloaded from the library) and read its values."""
        if not isinstance(target, (SketchEngine, Model)):
            raise TypeError(f"target must be a SketchEngine or a plantvr.Model, got {type(target).__name__}")
        if isinstance(self._target, Model):
            self._target.unobserve(self._from_model, names=list(ARCH_PARAMS))
        self._target = target
        if isinstance(target, Model):
            target.observe(self._from_model, names=list(ARCH_PARAMS))
        self.refresh()

    def _from_model(self, change) -> None:
        self.refresh()

    def refresh(self) -> None:
        """Re-read every value from the target (after it was changed by other code)."""
        t = self._target
        params = t.params
        opts = dict(t.sketch) if isinstance(t, SketchEngine) else {k: getattr(self, k) for k in SKETCH_OPTIONS}
        with self.hold_trait_notifications():
            for k in ARCH_PARAMS:
                self.set_trait(k, params[k])
            for k in SKETCH_OPTIONS:
                self.set_trait(k, tuple(opts[k]) if k == "ellipse" else opts[k])
        self.version += 1

    # -- reading -------------------------------------------------------------------------------------------
    @property
    def params(self) -> dict[str, Any]:
        """The architecture parameters of the table, ``{name: value}``."""
        return {k: getattr(self, k) for k in ARCH_PARAMS}

    @property
    def options(self) -> dict[str, Any]:
        """The TreeSketch options, ``{keyword: value}`` (SketchEngine keywords)."""
        return {k: (tuple(getattr(self, k)) if k == "ellipse" else getattr(self, k)) for k in SKETCH_OPTIONS}

    @property
    def influence(self) -> tuple[float, float, float]:
        """(alpha, beta, gamma) = (w_heading, w_tropism, w_env) of Eq. 4.5."""
        return (self.w_heading, self.w_tropism, self.w_env)

    # -- commands ------------------------------------------------------------------------------------------
    def check(self, **values: Any) -> tuple[dict[str, Any], dict[str, Any]]:
        """Check ``values`` without applying them; returns (table parameters, options), converted.

        Raises ``ValueError`` naming the parameter, its allowed range and the value.
        """
        unknown = sorted(set(values) - set(ARCH_PARAMS) - set(SKETCH_OPTIONS))
        if unknown:
            raise ValueError(f"unknown architecture parameter {unknown[0]!r}; "
                             f"expected one of {sorted(ARCH_PARAMS + SKETCH_OPTIONS)}")
        params = validate({k: v for k, v in values.items() if k in ARCH_PARAMS})
        if any(k in params for k in _INFLUENCE):
            w = {**{k: getattr(self, k) for k in _INFLUENCE}, **{k: params[k] for k in _INFLUENCE if k in params}}
            barycentric(w["w_heading"], w["w_tropism"], w["w_env"])
        opts = {k: v for k, v in values.items() if k in SKETCH_OPTIONS}
        if opts:
            if "ellipse" in opts:
                e = opts["ellipse"]
                if not isinstance(e, (tuple, list, np.ndarray)) or len(e) != 3:
                    raise ValueError(f"ellipse must be (s_v, s_p, e_v), got {e!r}")
                opts["ellipse"] = SketchEngine._check_ellipse(e)
            for k in ("trunk_up", "stroke_tropism"):
                if k in opts and opts[k] not in (True, False, 0, 1):
                    raise ValueError(f"{k} must be True or False, got {opts[k]!r}")
            probe = self._probe_engine()
            saved = dict(probe.sketch)
            try:  # the engine's own checks (ranges live there, not here)
                probe.set_options(**opts)
                opts = {k: probe.sketch[k] for k in opts}
            finally:
                probe.sketch = saved
        if params and isinstance(self._target, SketchEngine):
            self._target.checked_params(params)  # the engine's own checks against its tree (shadow grid reach)
        return params, opts

    def _probe_engine(self) -> SketchEngine:
        if self._probe is None:
            self._probe = SketchEngine(defaults(), rng=0)
        return self._probe

    def set(self, **values: Any) -> None:
        """Set architecture parameters and TreeSketch options; all are checked before any is written."""
        params, opts = self.check(**values)
        t = self._target
        if isinstance(t, SketchEngine):
            if opts:
                t.set_options(**opts)
            if params:
                t.set_params(params)
        elif params:
            t.set_params(**params)
        with self.hold_trait_notifications():
            for k, v in {**params, **opts}.items():
                self.set_trait(k, tuple(v) if k == "ellipse" else v)
        self.version += 1

    def set_influence(self, H: float, T: float, E: float) -> None:
        """Set (alpha, beta, gamma) normalised to sum 1 (Eq. 4.5, ERRATUM E7); the triangle widget calls this."""
        a, b, c = barycentric(H, T, E)
        self.set(w_heading=a, w_tropism=b, w_env=c)


# -- widgets -------------------------------------------------------------------------------------------------------
class _StateWidget(anywidget.AnyWidget):
    """Base: a widget whose synced traits mirror some of an :class:`ArchitectureState`'s and command it.

    All kinds share one front end, ``widgets/architecture.js``, which draws the one named by :attr:`kind`.
    """

    _esm = asset("architecture.js")
    _css = asset("architecture.css")
    kind = traitlets.Unicode("", read_only=True).tag(sync=True)
    error = traitlets.Unicode("").tag(sync=True)
    _synced: tuple[str, ...] = ()

    def __init__(self, state: ArchitectureState, **kwargs):
        if not isinstance(state, ArchitectureState):
            raise TypeError(f"state must be an ArchitectureState, got {type(state).__name__}")
        super().__init__(**kwargs)
        self.state = state
        self._busy = False
        self._pull()
        state.observe(self._on_state, names=["version"])
        self.observe(self._on_widget, names=list(self._synced))

    def _pull(self) -> None:  # state -> widget traits
        raise NotImplementedError

    def _values(self, change) -> dict[str, Any]:  # widget trait change -> state keywords
        raise NotImplementedError

    def _on_state(self, change) -> None:
        if self._busy:
            return
        self._busy = True
        try:
            self._pull()
        finally:
            self._busy = False

    def _on_widget(self, change) -> None:
        if self._busy:
            return
        self._busy = True
        try:
            self.state.set(**self._values(change))
            self.error = ""
        except ValueError as exc:  # the state is unchanged; show why and snap back
            self.error = str(exc)
        finally:
            self._busy = False
        self._on_state(None)

    def close(self) -> None:
        """Stop observing the state and close the comm."""
        state = self.__dict__.get("state")
        if state is not None:
            state.unobserve(self._on_state, names=["version"])
        super().close()


class SchematicTree(_StateWidget):
    """Live 2D schematic tree with the tropism arrow and a divergence inset (spec 004 §2.3 items 1–2).

    Attributes
    ----------
    segments : list of float
        Flat rows (x0, y0, x1, y1, radius, order) of :func:`schematic_tree`, internode lengths.
    tropism_angle : float
        Set-point angle theta (degrees from up); a drag in the browser "pushes" the arrow.
    phyllotaxis_angle : float
        Divergence angle shown in the inset (degrees).
    build_ms : float
        Time of the last schematic run.
    """

    kind = traitlets.Unicode("schematic", read_only=True).tag(sync=True)
    segments = traitlets.List(traitlets.Float()).tag(sync=True)
    tropism_angle = traitlets.Float(0.0).tag(sync=True)
    phyllotaxis_angle = traitlets.Float(137.5).tag(sync=True)
    build_ms = traitlets.Float(0.0).tag(sync=True)
    _synced = ("tropism_angle",)

    def __init__(self, state: ArchitectureState, *, iterations: int = 12, **kwargs):
        self.iterations = iterations
        self._key = None
        super().__init__(state, **kwargs)

    def _pull(self) -> None:
        s = self.state
        self.tropism_angle = s.tropism_angle
        self.phyllotaxis_angle = s.phyllotaxis_angle
        key = (tuple(s.params.items()), tuple(s.options.items()))
        if key != self._key:  # only a parameter change regrows the schematic
            import time

            t0 = time.perf_counter()
            self.segments = schematic_tree(s.params, s.options, iterations=self.iterations).ravel().tolist()
            self.build_ms = 1e3 * (time.perf_counter() - t0)
            self._key = key

    def _values(self, change) -> dict[str, Any]:
        return {"tropism_angle": change["new"]}

    @property
    def rows(self) -> np.ndarray:
        """(S, 6) view of :attr:`segments`."""
        return np.asarray(self.segments, float).reshape(-1, 6)


class GravimorphismEllipse(_StateWidget):
    """Control ellipse (s_v, s_p, e_v) with bud lines coloured by b (spec 004 §2.3 item 3, Eqs. 4.6–4.7).

    Attributes
    ----------
    ellipse : list of 3 float
        (s_v, s_p, e_v); the browser writes it while the handles are dragged.
    rays : list of float
        Distance d (= b at tau = 90 degrees) along each of ``n_rays`` bud directions, from :func:`ellipse_rays`.
    """

    kind = traitlets.Unicode("ellipse", read_only=True).tag(sync=True)
    ellipse = traitlets.List(traitlets.Float(), default_value=[1.0, 1.0, 0.0], minlen=3, maxlen=3).tag(sync=True)
    rays = traitlets.List(traitlets.Float()).tag(sync=True)
    n_rays = traitlets.Int(16).tag(sync=True)
    _synced = ("ellipse",)

    def _pull(self) -> None:
        e = list(self.state.ellipse)
        self.ellipse = e
        self.rays = ellipse_rays(*e, n=self.n_rays)[1].tolist()

    def _values(self, change) -> dict[str, Any]:
        return {"ellipse": tuple(change["new"])}

    @property
    def b(self) -> np.ndarray:
        """(n_rays,) relative resource factor of each bud line, normalised to a maximum of 1 (the line colours)."""
        d = np.asarray(self.rays, float)
        return d / d.max() if d.size and d.max() > 0 else d


def _angle_spec(name: str, label: str, side: int, color: str, lo: float | None = None, hi: float | None = None):
    p = PARAM_BY_NAME.get(name)
    if p is not None:
        lo, hi = p.range
    return {"name": name, "label": label, "lo": float(lo), "hi": float(hi), "side": side, "color": color}


#: Angle widgets: branching (psi of the lateral, to the right; delta of the main bud, to the left) and tropism.
#: The deflection range [0, 90] is the SketchEngine's (it checks it again on every edit).
BRANCHING_SPECS = [_angle_spec("branch_angle", "ψ branching", 1, "#2e8b57"),
                   _angle_spec("deflection", "δ deflection", -1, "#c0392b", 0.0, 90.0)]
TROPISM_SPECS = [_angle_spec("tropism_angle", "θ tropism", 1, "#2e6fd0")]


class AngleWidget(_StateWidget):
    """Draggable rays from a vertical parent axis, one per angle (spec 004 §2.3 items 2 and 4).

    Parameters
    ----------
    state : ArchitectureState
    specs : list of dict, optional
        ``{"name", "label", "lo", "hi", "side", "color"}`` per angle (degrees from up; ``side`` +1 draws to the
        right, -1 to the left); default :data:`BRANCHING_SPECS`.

    Attributes
    ----------
    angles : list of float
        Current values, degrees, in ``specs`` order; the browser writes them while a handle is dragged.
    """

    kind = traitlets.Unicode("angles", read_only=True).tag(sync=True)
    angles = traitlets.List(traitlets.Float()).tag(sync=True)
    specs = traitlets.List(traitlets.Dict()).tag(sync=True)
    _synced = ("angles",)

    def __init__(self, state: ArchitectureState, specs: list[dict] | None = None, **kwargs):
        specs = [dict(s) for s in (BRANCHING_SPECS if specs is None else specs)]
        for s in specs:
            if s.get("name") not in ARCH_PARAMS + SKETCH_OPTIONS:
                raise ValueError(f"angle spec name must be an architecture parameter, got {s.get('name')!r}")
        super().__init__(state, specs=specs, **kwargs)

    def _pull(self) -> None:
        self.angles = [float(getattr(self.state, s["name"])) for s in self.specs]

    def _values(self, change) -> dict[str, Any]:
        new = list(change["new"])
        if len(new) != len(self.specs):
            raise ValueError(f"angles must have {len(self.specs)} values, got {len(new)}")
        return {s["name"]: v for s, v in zip(self.specs, new)}

    def set_angle(self, name: str, value: float) -> None:
        """Set one angle as the browser would (a drag of its handle)."""
        names = [s["name"] for s in self.specs]
        if name not in names:
            raise ValueError(f"name must be one of {names}, got {name!r}")
        from .._validation import check_range

        a = list(self.angles)
        a[names.index(name)] = check_range(name, value, -1e6, 1e6)
        self.angles = a


# -- the panel -----------------------------------------------------------------------------------------------------
class ArchitecturePanel(W.VBox):
    """The TreeSketch architecture panel bound to a SketchEngine or a Model (spec 004 §2.3, Fig. 5.4).

    Parameters
    ----------
    target : SketchEngine or plantvr.Model or ArchitectureState
        What the panel reads and commands.
    schematic_iterations : int
        Growth steps of the schematic tree.

    Attributes
    ----------
    state : ArchitectureState
    schematic : SchematicTree
    ellipse : GravimorphismEllipse
    branching : AngleWidget
        psi and delta.
    tropism : AngleWidget
        theta.
    triangle : InfluenceTriangle
        (alpha, beta, gamma), the project's influence triangle.
    controls : dict[str, ipywidgets.Widget]
        Sliders and switches by parameter name.
    """

    def __init__(self, target, *, schematic_iterations: int = 12):
        state = target if isinstance(target, ArchitectureState) else ArchitectureState(target)
        self.state = state
        self.schematic = SchematicTree(state, iterations=schematic_iterations)
        self.ellipse = GravimorphismEllipse(state)
        self.branching = AngleWidget(state, BRANCHING_SPECS)
        self.tropism = AngleWidget(state, TROPISM_SPECS)
        self.triangle = InfluenceTriangle(state)
        self.triangle.labels = ["α current direction", "β tropism", "γ free space"]
        self.controls: dict[str, W.Widget] = {}
        for name in ("apical_dominance", "light_exponent", "base_length", "phyllotaxis_angle"):
            self.controls[name] = make_control(PARAM_BY_NAME[name], getattr(state, name))
        style = {"description_width": "150px"}
        self.controls["shed_threshold"] = W.BoundedFloatText(value=state.shed_threshold, min=0.0, max=1e6, step=0.05,
                                                             description="Shedding threshold (Th)", style=style)
        self.controls["n_max"] = W.IntSlider(value=state.n_max, min=1, max=12, description="Max shoot length (n_max)",
                                             style=style, continuous_update=False)
        self.controls["stroke_tropism"] = W.Checkbox(value=state.stroke_tropism, description="Tropism from strokes")
        self.controls["trunk_up"] = W.Checkbox(value=state.trunk_up, description="Trunk tropism up")
        for name, ctl in self.controls.items():
            ctl.observe(lambda ch, n=name: self._from_control(n, ch["new"]), names="value")
        self.message = W.HTML("")
        state.observe(self._to_controls, names=["version"])
        wrap = W.Layout(flex_flow="row wrap", align_items="flex-start")
        widgets = W.Box([self.schematic, self.tropism, self.branching, self.ellipse, self.triangle], layout=wrap)
        sliders = [self.controls[k] for k in ("apical_dominance", "light_exponent", "shed_threshold", "n_max",
                                              "base_length", "phyllotaxis_angle")]
        for c in sliders:
            c.layout = W.Layout(width="400px")
            c.style = {"description_width": "170px"}
        switches = W.HBox([self.controls["stroke_tropism"], self.controls["trunk_up"]])
        super().__init__([W.HTML("<b>Architecture</b>"), widgets,
                          W.GridBox(sliders, layout=W.Layout(grid_template_columns="repeat(auto-fill, 410px)")),
                          switches, self.message])

    def _from_control(self, name: str, value) -> None:
        if getattr(self, "_syncing", False):
            return
        try:
            self.state.set(**{name: value})
            self.message.value = ""
        except ValueError as exc:
            self.message.value = f"<span style='color:#c0392b'>{exc}</span>"
            self._to_controls(None)

    def _to_controls(self, change) -> None:
        self._syncing = True
        try:
            for name, ctl in self.controls.items():
                v = getattr(self.state, name)
                if isinstance(ctl, (W.FloatSlider, W.IntSlider)):
                    ctl.min, ctl.max = min(ctl.min, v), max(ctl.max, v)
                ctl.value = v
        finally:
            self._syncing = False

    @property
    def engine(self) -> SketchEngine | None:
        """The bound SketchEngine (None for a Model)."""
        return self.state.engine

    def bind(self, target) -> None:
        """Show and command another engine or model (the widgets follow)."""
        self.state.bind(target)

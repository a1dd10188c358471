"""TreeSketch architecture panel (spec 004_treesketch §2.3 items 1–7, §1.4.5–1.4.7, §1.6.1; Fig. 5.4).

The panel and its widgets are views of a :class:`~plantvr.documents.treesketch.SketchDocument`: they read its
traits (rows of :data:`~plantvr.growth.sketch.TREESKETCH`, whose ranges the sliders and angle handles take) and call
its commands (``doc.set_params``, ``doc.set_influence``), which check every value before anything is written, so a
rejected edit leaves the document unchanged and the message names the parameter. They keep no state of their own
beyond their synced traits, and follow the document's ``change`` events.

The anywidgets (one front end, ``widgets/architecture.js``, that draws the widget's ``kind``):

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

from ..documents.treesketch import SketchDocument
from ..growth.sketch import TREESKETCH, SketchEngine
from ..growth.sketch_rules import ellipse_distance
from ..params import defaults, validate
from ._assets import asset
from ._sync import SyncGuard
from .panels import make_control, push_param, show_value
from .triangle import InfluenceTriangle

__all__ = ["ARCH_PARAMS", "SKETCH_OPTIONS", "AngleWidget", "ArchitecturePanel", "GravimorphismEllipse", "SchematicTree",
           "ellipse_rays", "schematic_tree"]

#: Growth parameters of the parameter table that the architecture panel edits.
ARCH_PARAMS = ("w_heading", "w_tropism", "w_env", "tropism_angle", "branch_angle", "phyllotaxis_angle",
               "base_length", "apical_dominance", "light_exponent")
#: TreeSketch rows of the table that the panel edits (the ellipse as its three numbers).
SKETCH_OPTIONS = ("n_max", "deflection", "ellipse_sv", "ellipse_sp", "ellipse_ev", "shed_threshold", "trunk_up",
                  "stroke_tropism")
#: SketchEngine options the schematic tree is grown with.
_SCHEMATIC_OPTIONS = ("n_max", "deflection", "ellipse", "shed_threshold", "trunk_up")


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
    opts = {k: v for k, v in options.items() if k in _SCHEMATIC_OPTIONS}
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


# -- widgets -------------------------------------------------------------------------------------------------------
def _check_doc(doc) -> SketchDocument:
    if not isinstance(doc, SketchDocument):
        raise TypeError(f"doc must be a SketchDocument, got {type(doc).__name__}")
    return doc


class _DocWidget(anywidget.AnyWidget):
    """Base: a widget whose synced traits mirror some of a :class:`SketchDocument`'s traits and command it.

    All kinds share one front end, ``widgets/architecture.js``, which draws the one named by :attr:`kind`.
    """

    _esm = asset("architecture.js")
    _css = asset("architecture.css")
    kind = traitlets.Unicode("", read_only=True).tag(sync=True)
    error = traitlets.Unicode("").tag(sync=True)
    _synced: tuple[str, ...] = ()

    def __init__(self, doc: SketchDocument, **kwargs):
        doc = _check_doc(doc)
        super().__init__(**kwargs)
        self.doc = doc
        self._busy = SyncGuard()
        self._pull()
        doc.on(self._on_doc)
        self.observe(self._on_widget, names=list(self._synced))

    def _pull(self) -> None:  # document -> widget traits
        raise NotImplementedError

    def _values(self, change) -> dict[str, Any]:  # widget trait change -> set_params keywords
        raise NotImplementedError

    def _on_doc(self, change) -> None:
        if self._busy:
            return
        with self._busy:
            self._pull()

    def _on_widget(self, change) -> None:
        if self._busy:
            return
        with self._busy:
            try:
                self.doc.set_params(**self._values(change))
                self.error = ""
            except ValueError as exc:  # the document is unchanged; show why and snap back
                self.error = str(exc)
        self._on_doc(None)

    def bind(self, doc: SketchDocument) -> None:
        """Show and command another document."""
        doc = _check_doc(doc)
        self.doc.off(self._on_doc)
        self.doc = doc
        doc.on(self._on_doc)
        self._on_doc(None)

    def close(self) -> None:
        """Stop observing the document and close the comm."""
        doc = self.__dict__.get("doc")
        if doc is not None:
            doc.off(self._on_doc)
        super().close()


class SchematicTree(_DocWidget):
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

    def __init__(self, doc: SketchDocument, *, iterations: int = 12, **kwargs):
        self.iterations = iterations
        self._key = None
        super().__init__(doc, **kwargs)

    def _pull(self) -> None:
        d = self.doc
        self.tropism_angle = d.tropism_angle
        self.phyllotaxis_angle = d.phyllotaxis_angle
        params = {k: getattr(d, k) for k in ARCH_PARAMS}
        opts = {k: d.engine.sketch[k] for k in _SCHEMATIC_OPTIONS}
        key = (tuple(params.items()), tuple(opts.items()))
        if key != self._key:  # only a parameter change regrows the schematic
            import time

            t0 = time.perf_counter()
            self.segments = schematic_tree(params, opts, iterations=self.iterations).ravel().tolist()
            self.build_ms = 1e3 * (time.perf_counter() - t0)
            self._key = key

    def _values(self, change) -> dict[str, Any]:
        return {"tropism_angle": change["new"]}

    @property
    def rows(self) -> np.ndarray:
        """(S, 6) view of :attr:`segments`."""
        return np.asarray(self.segments, float).reshape(-1, 6)


class GravimorphismEllipse(_DocWidget):
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
        e = list(self.doc.ellipse)
        self.ellipse = e
        self.rays = ellipse_rays(*e, n=self.n_rays)[1].tolist()

    def _values(self, change) -> dict[str, Any]:
        return dict(zip(("ellipse_sv", "ellipse_sp", "ellipse_ev"), change["new"]))

    @property
    def b(self) -> np.ndarray:
        """(n_rays,) relative resource factor of each bud line, normalised to a maximum of 1 (the line colours)."""
        d = np.asarray(self.rays, float)
        return d / d.max() if d.size and d.max() > 0 else d


def _angle_spec(name: str, label: str, side: int, color: str) -> dict[str, Any]:
    lo, hi = TREESKETCH[name].range
    return {"name": name, "label": label, "lo": float(lo), "hi": float(hi), "side": side, "color": color}


#: Angle widgets: branching (psi of the lateral, to the right; delta of the main bud, to the left) and tropism;
#: their ranges are the table's.
BRANCHING_SPECS = [_angle_spec("branch_angle", "ψ branching", 1, "#2e8b57"),
                   _angle_spec("deflection", "δ deflection", -1, "#c0392b")]
TROPISM_SPECS = [_angle_spec("tropism_angle", "θ tropism", 1, "#2e6fd0")]


class AngleWidget(_DocWidget):
    """Draggable rays from a vertical parent axis, one per angle (spec 004 §2.3 items 2 and 4).

    Parameters
    ----------
    doc : SketchDocument
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

    def __init__(self, doc: SketchDocument, specs: list[dict] | None = None, **kwargs):
        specs = [dict(s) for s in (BRANCHING_SPECS if specs is None else specs)]
        for s in specs:
            if s.get("name") not in ARCH_PARAMS + SKETCH_OPTIONS:
                raise ValueError(f"angle spec name must be an architecture parameter, got {s.get('name')!r}")
        super().__init__(doc, specs=specs, **kwargs)

    def _pull(self) -> None:
        self.angles = [float(getattr(self.doc, s["name"])) for s in self.specs]

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
#: The panel's sliders and switches, in display order (controls generated from the table rows).
CONTROLS = ("apical_dominance", "light_exponent", "shed_threshold", "n_max", "base_length", "phyllotaxis_angle",
            "stroke_tropism", "trunk_up")


class ArchitecturePanel(W.VBox):
    """The TreeSketch architecture panel: a view of a :class:`SketchDocument` (spec 004 §2.3, Fig. 5.4).

    Parameters
    ----------
    doc : SketchDocument
        What the panel reads and commands.
    schematic_iterations : int
        Growth steps of the schematic tree.

    Attributes
    ----------
    doc : SketchDocument
    schematic : SchematicTree
    ellipse : GravimorphismEllipse
    branching : AngleWidget
        psi and delta.
    tropism : AngleWidget
        theta.
    triangle : InfluenceTriangle
        (alpha, beta, gamma), the project's influence triangle.
    controls : dict[str, ipywidgets.Widget]
        Sliders and switches by parameter name, made from the table rows.
    """

    def __init__(self, doc: SketchDocument, *, schematic_iterations: int = 12):
        doc = _check_doc(doc)
        self.doc = doc
        self.schematic = SchematicTree(doc, iterations=schematic_iterations)
        self.ellipse = GravimorphismEllipse(doc)
        self.branching = AngleWidget(doc, BRANCHING_SPECS)
        self.tropism = AngleWidget(doc, TROPISM_SPECS)
        self.triangle = InfluenceTriangle(doc)
        self.triangle.labels = ["α current direction", "β tropism", "γ free space"]
        self.controls: dict[str, W.Widget] = {name: make_control(TREESKETCH[name], getattr(doc, name))
                                              for name in CONTROLS}
        for name, ctl in self.controls.items():
            ctl.observe(lambda ch, n=name: self._from_control(n, ch["new"]), names="value")
        self.message = W.HTML("")
        doc.on(self._to_controls)
        wrap = W.Layout(flex_flow="row wrap", align_items="flex-start")
        widgets = W.Box([self.schematic, self.tropism, self.branching, self.ellipse, self.triangle], layout=wrap)
        sliders = [self.controls[k] for k in CONTROLS[:6]]
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
        if not push_param(self.doc, name, value, self.message):
            self._to_controls(None)

    def _to_controls(self, change) -> None:
        self._syncing = True
        try:
            for name, ctl in self.controls.items():
                show_value(ctl, getattr(self.doc, name))
        finally:
            self._syncing = False

    @property
    def engine(self) -> SketchEngine:
        """The document's engine."""
        return self.doc.engine

    def close(self) -> None:
        """Stop following the document, then close the panel and its widgets."""
        self.doc.off(self._to_controls)
        for w in (self.schematic, self.ellipse, self.branching, self.tropism, self.triangle):
            w.close()
        super().close()

    def bind(self, doc: SketchDocument) -> None:
        """Show and command another document (the widgets follow)."""
        doc = _check_doc(doc)
        self.doc.off(self._to_controls)
        for w in (self.schematic, self.ellipse, self.branching, self.tropism):
            w.bind(doc)
        self.triangle.close()
        self.triangle = InfluenceTriangle(doc)
        self.triangle.labels = ["α current direction", "β tropism", "γ free space"]
        self.children[1].children = (*self.children[1].children[:4], self.triangle)
        self.doc = doc
        doc.on(self._to_controls)
        self._to_controls(None)

"""The TreeSketch document (spec 004_treesketch §1.4–1.5, §2.3–2.11; V17): one tree grown by sketching.

:class:`SketchDocument` holds a :class:`~plantvr.growth.sketch.SketchEngine` (the numeric core: arrays in and out,
no log, no undo) and is the one place its state changes. Parameters are the traits of one table,
:data:`~plantvr.growth.sketch.TREESKETCH` (the Tree Wand rows and the TreeSketch rows); commands check their
arguments at the door, apply under the lock, land in the document's :class:`~plantvr.commandlog.CommandLog` and
publish one :class:`~plantvr.document.Change`. The architecture panel, its widgets, the 3D view and the headset are
views of the document: they read its traits and call its commands.

Undo and the timeline are the document's :class:`~plantvr.history.History`:

- every edit (a stroke from :meth:`~SketchDocument.begin_stroke` to :meth:`~SketchDocument.end_stroke`, growth
  made while brushing included; a paint, a lasso, a prune, a width constraint, a bend, a selection, a reset) is
  one whole-state item (:class:`~plantvr.history.StateAtom` of the engine's
  :meth:`~plantvr.growth.sketch.SketchEngine.get_state`);
- every growth step is one item too, so :meth:`~SketchDocument.ungrow` takes steps back and
  :meth:`~SketchDocument.grow` applies the undone ones again when no edit happened since (grow N, ungrow to k,
  regrow to N gives identical arrays, V17); an edit clears them, and growth continues from the edited state;
- items are dropped oldest first beyond ``max_undo`` items or ``max_undo_bytes``.

A parameter change (``set_params``, a trait set by a slider) is one undo item too, restoring the parameters (and
what they changed); inside an open stroke it joins the stroke's item.
"""
from __future__ import annotations

import contextlib
import copy
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import traitlets
from traitlets import Bool, Int

from .._fileio import check_target
from .._validation import MAX_COORD, MAX_COUNT, check_array, check_int, check_point, check_range
from ..document import Document, check_digest, file_digest, serialise
from ..growth.sketch import TREESKETCH, SketchEngine, split_values
from ..growth.sketch_rules import barycentric
from ..growth.sketch_tools import LassoVolume, StrokeEmitter, TreeLibrary, lasso_volume, nearest_node
from ..history import StateAtom
from ..types import Points, TreeArrays

__all__ = ["SketchDocument"]

#: Largest number of growth steps one command may ask for.
MAX_STEPS = 10 ** 6


@dataclass(frozen=True)
class SketchSnapshot:
    """Read-only picture of the TreeSketch document after one change (as Tree Wand's ``Snapshot``): the live tree,
    its bud slots (``"pos"``, ``"dir"``, ``"radius"``, ``"up"``: leaves grow there), the markers and the sketch."""

    tree: TreeArrays
    buds: dict[str, np.ndarray]
    markers: np.ndarray
    sketch: np.ndarray


@dataclass(frozen=True)
class _StepAtom(StateAtom):
    """One growth step: what :meth:`SketchDocument.ungrow` takes back and :meth:`SketchDocument.grow` replays."""


class SketchDocument(Document):
    """A TreeSketch tree: parameters, engine, strokes, timeline and undo (see the module docstring).

    Parameters
    ----------
    seed : int
        Seed of the engine; every random draw derives from (seed, iteration, purpose), so the same seed and the
        same commands grow the same tree.
    max_undo : int
        Undo depth (edits and growth steps), in [1, 10000].
    max_undo_bytes : int
        Byte budget of the undo and redo items.
    **params
        Initial :data:`~plantvr.growth.sketch.TREESKETCH` values.

    Examples
    --------
    >>> from plantvr.documents.treesketch import SketchDocument
    >>> doc = SketchDocument(seed=1, activation_threshold=0.0, stroke_tropism=True)
    >>> doc.begin_stroke([0.0, 1.0, 0.0]); doc.move_stroke([0.0, 6.0, 0.0], 0.0); doc.end_stroke()
    >>> doc.grow(4)
    4
    >>> doc.ungrow(2), doc.steps_done
    (2, 2)
    """

    KIND = "treesketch"
    COMMANDS = ("set_params", "set_influence", "begin_stroke", "move_stroke", "end_stroke", "paint", "add_markers",
                "lasso", "grow", "ungrow", "advance", "prune", "prune_at", "select", "set_width", "bend", "reset",
                "restore", "regrow", "undo", "redo")
    EVENTS = ("tree", "markers", "sketch")
    PARAMS = TREESKETCH
    ITEM_OPENERS = ("begin_stroke", "move_stroke")
    JOIN_OPEN = ("grow", "advance")
    #: Commands :meth:`regrow` re-issues (the strokes, markers and growth since the last reset; edits that name
    #: nodes of the old tree, ``select`` / ``set_width`` / ``bend``, are not).
    REGROW_COMMANDS = ("begin_stroke", "move_stroke", "end_stroke", "paint", "add_markers", "lasso", "grow",
                       "ungrow", "advance", "prune", "prune_at")

    n_internodes = Int(1, help="Live internodes.")
    n_markers = Int(0, help="Attraction points.")
    steps_done = Int(0, help="Growth steps of the current tree.")
    stroking = Bool(False, help="True between begin_stroke and end_stroke.")

    def __init__(self, seed: int = 0, *, max_undo: int = 1000, max_undo_bytes: int = 256 * 2 ** 20,
                 **params: Any):
        seed = check_int("seed", seed, 0, 2 ** 63 - 1)
        self._engine: SketchEngine | None = None
        super().__init__(max_undo=max_undo, max_undo_bytes=max_undo_bytes, **params)
        eng_params, opts = split_values(self.params)
        self._engine = SketchEngine(eng_params, rng=seed, **opts)
        self._emitter: StrokeEmitter | None = None
        self._stroke_before: dict | None = None
        self._strokes = 0                        # strokes made: seeds the next stroke's points
        self._samples = np.zeros((0, 3))         # brush centres of every stroke (the "sketch" content)
        self._carry = 0.0                        # fraction of a step left by advance(): the slider's, not the tree's
        self.changed("all", save=False)

    # -- reading ----------------------------------------------------------------------------------------
    @property
    def engine(self) -> SketchEngine:
        """The numeric engine (read it; change it only through commands)."""
        return self._engine

    @property
    def tree(self):
        """The engine's tree (read it; change it only through commands)."""
        return self._engine.tree

    @property
    def seed(self) -> int:
        return self._engine.seed

    @property
    def influence(self) -> tuple[float, float, float]:
        """(alpha, beta, gamma) = (w_heading, w_tropism, w_env) of Eq. 4.5."""
        return (self.w_heading, self.w_tropism, self.w_env)

    @property
    def ellipse(self) -> tuple[float, float, float]:
        """The gravimorphism control ellipse (s_v, s_p, e_v) of Eq. 4.6."""
        return (self.ellipse_sv, self.ellipse_sp, self.ellipse_ev)

    # -- parameters -------------------------------------------------------------------------------------
    def _check_set_params(self, **params: Any) -> dict[str, Any]:
        checked = TREESKETCH.validate(params)
        eng_params, opts = split_values(checked, self.ellipse)
        self._engine._check_options(opts)
        self._engine.checked_params(eng_params)  # the influence triangle, the branching of a grown tree, grid reach
        return checked

    @traitlets.validate(*TREESKETCH.names)
    def _cross_check(self, proposal):
        """A parameter set directly (``doc.w_env = 0``) passes the same checks as :meth:`set_params`."""
        if self._engine is not None and not self._restoring:
            self._check_set_params(**{proposal["trait"].name: proposal["value"]})
        return proposal["value"]

    def apply_param(self, name: str, value: Any) -> None:
        """The engine follows the traits (every value that differs, at once: a batch is consistent only whole)."""
        e = self._engine
        params, opts = split_values(self.params)
        params = {k: v for k, v in params.items() if e.params[k] != v}
        opts = {k: v for k, v in opts.items() if e.sketch[k] != v}
        if opts:
            e.set_options(**opts)
        if params:
            e.set_params(params)

    def _param_item(self, old=None):
        """A parameter change is one undo item (it clears the steps ahead, grown with other parameters), except
        inside an open stroke, whose item it joins."""
        if self._emitter is not None:
            return contextlib.nullcontext()
        return super()._param_item(old)

    def set_influence(self, H: float, T: float, E: float) -> None:
        """Set (alpha, beta, gamma) normalised to sum 1 (Eq. 4.5, ERRATUM E7); the triangle widget calls this."""
        a, b, c = self._check_set_influence(H, T, E)
        self.set_params(w_heading=a, w_tropism=b, w_env=c)

    @staticmethod
    def _check_set_influence(H: float, T: float, E: float) -> tuple[float, float, float]:
        return barycentric(H, T, E)

    # -- strokes (§2.5, §2.7) -------------------------------------------------------------------------------
    def begin_stroke(self, point) -> None:
        """Start a brush stroke at ``point`` (3,); a stroke still open is ended first."""
        point = self._check_begin_stroke(point)
        with self._lock:
            if self._emitter is not None:
                self._finish_stroke()
            self._stroke_before = self.get_state()
            e = self._engine
            self._emitter = StrokeEmitter(e, rate=self.stroke_rate, spacing=self.stroke_spacing,
                                          rng=np.random.default_rng([e.seed, self._strokes, 3]))
            self._emitter.begin(point)
            self._samples = np.concatenate([self._samples, point[None]])
            self.log.record("begin_stroke", point=point)
        self.stroking = True
        self.changed("sketch", command="begin_stroke")

    @staticmethod
    def _check_begin_stroke(point) -> np.ndarray:
        return _point("point", point)

    def move_stroke(self, point, radius: float, dt: float = 1.0 / 30.0) -> int:
        """Move the open stroke's brush to ``point`` with ``radius`` (0: a sketch on the stroke itself) over
        ``dt`` seconds; the points emitted remember the stroke direction. Returns how many were emitted."""
        point, radius, dt = self._check_move_stroke(point, radius, dt)
        with self._lock:
            if self._emitter is None:
                raise ValueError("move_stroke() before begin_stroke(): start a stroke first")
            pts = self._emitter.move(point, radius, dt)
            self._samples = np.concatenate([self._samples, point[None]])
            self.log.record("move_stroke", point=point, radius=radius, dt=dt)
        self.changed("markers", command="move_stroke")
        return len(pts)

    @staticmethod
    def _check_move_stroke(point, radius, dt=1.0 / 30.0):
        return (_point("point", point), check_range("radius", radius, 0.0, MAX_COORD),
                check_range("dt", dt, 0.0, 1e6))

    def end_stroke(self) -> None:
        """Finish the open stroke: it becomes one undo item, with the growth made while brushing."""
        with self._lock:
            if self._emitter is not None:
                self._finish_stroke()
            self.log.record("end_stroke")
        self.stroking = False
        self.changed("tree", command="end_stroke")

    @staticmethod
    def _check_end_stroke() -> None:
        return None

    def _finish_stroke(self) -> None:
        self._emitter.end()
        self._emitter = None
        self._strokes += 1
        self.history.push(StateAtom(self._stroke_before, self.get_state(), "tree"))
        self._stroke_before = None

    def transient_state(self) -> dict[str, Any]:
        """The open stroke (its emitter, copied, and the state before it) and the Grow slider's carry, which a
        replay that fails restores with the state."""
        em = self._emitter
        return {"emitter": None if em is None else copy.deepcopy(em, {id(self._engine): self._engine}),
                "stroke_before": self._stroke_before, "carry": self._carry, "samples": self._samples.copy()}

    def set_transient_state(self, state: dict[str, Any]) -> None:
        em = state["emitter"]
        self._emitter = None if em is None else copy.deepcopy(em, {id(self._engine): self._engine})
        if self._emitter is not None:
            self._emitter.engine = self._engine
        self._stroke_before, self._carry = state["stroke_before"], state["carry"]
        self._samples = state["samples"].copy()
        self.stroking = self._emitter is not None

    def before_undo(self) -> None:
        """An open stroke is ended (it becomes an undo item) before undo or redo."""
        if self._emitter is not None:
            self._finish_stroke()
            self.stroking = False

    # -- markers: paint, points, lasso (§2.2, §2.6) ------------------------------------------------------------
    def paint(self, center, radius: float | None = None, n_darts: int | None = None) -> int:
        """Throw Poisson darts in the brush sphere (default radius ``brush_radius``); returns the markers added."""
        center, radius, n_darts = self._check_paint(center, radius, n_darts)
        with self._lock, self._edit():
            n = self._engine.paint(center, self.brush_radius if radius is None else radius, n_darts)
            self.log.record("paint", center=center, radius=radius, n_darts=n_darts)
        self.changed("markers", command="paint")
        return n

    @staticmethod
    def _check_paint(center, radius=None, n_darts=None):
        center = _point("center", center)
        radius = None if radius is None else check_range("radius", radius, 0.0, MAX_COORD, low_open=True)
        n_darts = None if n_darts is None else check_int("n_darts", n_darts, 1, TREESKETCH["darts_per_paint"].range[1])
        return center, radius, n_darts

    def add_markers(self, points) -> None:
        """Add attraction points as they are (imported, scripted or from a lasso)."""
        pts = self._check_add_markers(points)
        with self._lock, self._edit():
            self._engine.add_markers(pts)
            self.log.record("add_markers", points=pts)
        self.changed("markers", command="add_markers")

    @staticmethod
    def _check_add_markers(points) -> np.ndarray:
        pts = SketchEngine._check_marker_points("points", points).copy()
        if len(pts) > MAX_COUNT:
            raise ValueError(f"points must have at most {MAX_COUNT} rows, got {len(pts)}")
        return pts

    def lasso(self, polygon, *, origin=(0.0, 0.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 1.0, 0.0),
              n_points: int = 500, pixel: float | None = None, seed: int = 0) -> LassoVolume:
        """Inflate a lasso drawn in the view plane (origin, u, v) into a volume filled with ``n_points``
        attraction points (:func:`~plantvr.growth.sketch_tools.lasso_volume`, §2.6) and add them."""
        polygon, origin, u, v, n_points, pixel, seed = self._check_lasso(polygon, origin=origin, u=u, v=v,
                                                                         n_points=n_points, pixel=pixel, seed=seed)
        vol = lasso_volume(polygon, origin=origin, u=u, v=v, n_points=n_points, pixel=pixel, rng=seed)
        with self._lock, self._edit():
            self._engine.add_markers(vol.points)
            self.log.record("lasso", polygon=polygon, origin=origin, u=u, v=v, n_points=n_points, pixel=pixel,
                            seed=seed)
        self.changed("markers", command="lasso")
        return vol

    @staticmethod
    def _check_lasso(polygon, *, origin=(0.0, 0.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 1.0, 0.0), n_points=500,
                     pixel=None, seed=0):
        return (check_array("polygon", polygon, shape=(None, 2), min_rows=3, max_abs=MAX_COORD).copy(),
                _point("origin", origin), _point("u", u), _point("v", v),
                check_int("n_points", n_points, 0, 10_000_000),
                None if pixel is None else check_range("pixel", pixel, 0.0, MAX_COORD, low_open=True),
                check_int("seed", seed, 0, 2 ** 63 - 1))

    # -- growth: the timeline (§2.4, V17) -----------------------------------------------------------------------
    def grow(self, steps: int = 1) -> int:
        """Advance ``steps`` growth steps: steps undone by :meth:`ungrow` are applied again while no edit came
        since (identical arrays), others are grown. Returns the steps made."""
        steps = self._check_grow(steps)
        with self._lock:
            self._grow(steps)
            self.log.record("grow", steps=steps)
        self.changed("tree", command="grow")
        return steps

    def _grow(self, steps: int) -> int:
        h, e = self.history, self._engine
        before = None
        for _ in range(steps):
            if self._emitter is not None:  # growth while brushing belongs to the stroke's undo item
                e.step()
            elif isinstance(h.next_redo, _StepAtom):
                h.redo(self)
                before = None
            else:
                before = self.get_state() if before is None else before
                e.step()
                after = self.get_state()
                h.push(_StepAtom(before, after, "tree"))
                before = after
        return steps

    @staticmethod
    def _check_grow(steps: int = 1) -> int:
        return check_int("steps", steps, 0, MAX_STEPS)

    def ungrow(self, steps: int = 1) -> int:
        """Take back up to ``steps`` growth steps (not past an edit, nor past the oldest step kept); an open
        stroke is ended first. Returns the steps taken back."""
        steps = self._check_ungrow(steps)
        with self._lock:
            k = self._ungrow(steps)
            self.log.record("ungrow", steps=steps)
        self.changed("tree", command="ungrow")
        return k

    def _ungrow(self, steps: int) -> int:
        self.before_undo()
        h = self.history
        k = 0
        while k < steps and isinstance(h.top, _StepAtom):
            h.undo(self)
            k += 1
        return k

    _check_ungrow = _check_grow

    def advance(self, speed: float, seconds: float) -> int:
        """Grow (``speed`` > 0) or ungrow (< 0) at ``speed`` steps per second for ``seconds``; fractional steps
        carry over between calls, as with the spring-loaded Grow slider. Returns the signed steps made."""
        speed, seconds = self._check_advance(speed, seconds)
        with self._lock:
            carry = 0.0 if speed * self._carry < 0 else self._carry  # the slider changed direction: drop the fraction
            carry += speed * seconds
            k = math.floor(abs(carry)) * (1 if carry >= 0 else -1)
            self._carry = carry - k
            done = self._grow(k) if k >= 0 else -self._ungrow(-k)
            self.log.record("advance", speed=speed, seconds=seconds)
        self.changed("tree", command="advance")
        return done

    @staticmethod
    def _check_advance(speed: float, seconds: float) -> tuple[float, float]:
        speed = check_range("speed", speed, -1e6, 1e6)
        seconds = check_range("seconds", seconds, 0.0, 1e6)
        if abs(speed * seconds) > MAX_STEPS + 1:
            raise ValueError(f"speed * seconds must ask for at most {MAX_STEPS} steps, got {speed!r} * {seconds!r}")
        return speed, seconds

    # -- editing: prune, select, widths, bend (§2.8–2.11) -----------------------------------------------------
    def prune(self, center, radius: float) -> int:
        """Remove the internodes whose midpoint is in the prune brush, with their subtrees (§4.4)."""
        center, radius = self._check_prune(center, radius)
        with self._lock, self._edit():
            n = self._engine.prune(center, radius)
            self.log.record("prune", center=center, radius=radius)
        self.changed("tree", command="prune")
        return n

    @staticmethod
    def _check_prune(center, radius):
        return _point("center", center), check_range("radius", radius, 0.0, 2 * MAX_COORD)

    def prune_at(self, point) -> int:
        """Double-tap: prune the branch nearest ``point`` at its nearest branching point (§2.11); returns the
        internodes removed."""
        point = self._check_prune_at(point)
        with self._lock, self._edit():
            n = self._engine.prune_at(nearest_node(self._engine, point))
            self.log.record("prune_at", point=point)
        self.changed("tree", command="prune_at")
        return n

    @staticmethod
    def _check_prune_at(point) -> np.ndarray:
        return _point("point", point)

    def select(self, point=None, direction=None) -> int | None:
        """Press-and-hold: only the subtree of the node nearest ``point`` grows, its bud turned along
        ``direction`` when given (§2.8); ``point=None`` ends selective growth. Returns the selected node."""
        point, direction = self._check_select(point, direction)
        with self._lock, self._edit():
            node = None if point is None else nearest_node(self._engine, point)
            self._engine.select(node, direction)
            self.log.record("select", point=point, direction=direction)
        self.changed("tree", command="select")
        return node

    @staticmethod
    def _check_select(point=None, direction=None):
        point = None if point is None else _point("point", point)
        direction = None if direction is None else _point("direction", direction)
        if direction is not None and point is None:
            raise ValueError("direction needs a point to select")
        return point, direction

    def set_width(self, node: int, diameter: float | None) -> None:
        """Add, change or (``None``) remove the width constraint on the internode ending at ``node`` (§2.10)."""
        node, diameter = self._check_set_width(node, diameter)
        with self._lock, self._edit():
            self._engine.set_width(node, diameter)
            self.log.record("set_width", node=node, diameter=diameter)
        self.changed("tree", command="set_width")

    @staticmethod
    def _check_set_width(node: int, diameter: float | None):
        return (check_int("node", node, 1, 2 ** 62),
                None if diameter is None else check_range("diameter", diameter, 1e-9, MAX_COORD))

    def bend(self, base: int, end: int, target, *, max_iter: int = 100):
        """Bend the path ``base`` .. ``end`` so that ``end`` reaches ``target`` (§2.9); returns the
        :class:`~plantvr.growth.bending.BendResult`."""
        base, end, target, max_iter = self._check_bend(base, end, target, max_iter=max_iter)
        with self._lock, self._edit():
            res = self._engine.bend(base, end, target, max_iter=max_iter)
            self.log.record("bend", base=base, end=end, target=target, max_iter=max_iter)
        self.changed("tree", command="bend")
        return res

    @staticmethod
    def _check_bend(base: int, end: int, target, *, max_iter: int = 100):
        return (check_int("base", base, 0, 2 ** 62), check_int("end", end, 0, 2 ** 62), _point("target", target),
                check_int("max_iter", max_iter, 1, 100_000))

    def reset(self, seed: int | None = None) -> None:
        """Start a new tree with the current parameters (and ``seed``, default the current one)."""
        seed = self._check_reset(seed)
        with self._lock, self._edit():
            eng_params, opts = split_values(self.params)
            self._engine.set_state(SketchEngine(eng_params, rng=self.seed if seed is None else seed, **opts).get_state())
            self._samples = np.zeros((0, 3))
            self.log.record("reset", seed=seed)
        self.changed("all", command="reset")

    def regrow(self, amend: bool = False) -> int:
        """Grow the tree again with the current parameters: ``reset()``, then the :data:`REGROW_COMMANDS` whose
        effect the tree still holds since the last reset (undone ones left out), re-issued in order, the stroke
        counter that seeds brush points restarted from the count they had (so the same parameters regrow the
        same tree); a stroke left open is closed. One undo item (``amend``: joined to the previous one), logged
        as one ``regrow`` command; returns the number of commands re-issued (0: nothing to regrow)."""
        amend = self._check_regrow(amend)
        with self._lock:
            return self._regrow(amend)

    def _regrow(self, amend: bool) -> int:
        events = self.effective_events()
        start = max((i for i, (c, _) in enumerate(events) if c in ("reset", "restore")), default=-1)
        if start >= 0 and events[start][0] == "restore":
            return 0
        commands = [(c, kw) for c, kw in events[start + 1:] if c in self.REGROW_COMMANDS]
        if not commands:
            return 0
        open_stroke = self._emitter is not None
        strokes = self._strokes - (sum(n == "begin_stroke" for n, _ in commands) - open_stroke)
        if open_stroke:
            commands.append(("end_stroke", {}))   # a stroke left open is closed in the regrown tree

        def prepare():
            self.reset()
            self._strokes = max(int(strokes), 0)
        return self._reissue(commands, prepare, amend=amend)

    @staticmethod
    def _check_reset(seed: int | None = None) -> int | None:
        return None if seed is None else check_int("seed", seed, 0, 2 ** 63 - 1)

    def _edit(self):
        """An edit is one undo item; an open stroke is ended first (it is an item of its own)."""
        self.before_undo()
        return self.undoable("tree")

    # -- whole state --------------------------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        """Copies of the parameters, the engine's full state and the document's stroke fields."""
        return {"params": self.params, "engine": self._engine.get_state(), "strokes": self._strokes,
                "samples": self._samples.copy()}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore what :meth:`get_state` returned (parameters, engine, strokes) exactly."""
        with self._lock:
            self.restore_params(state["params"])
            e = self._engine
            e.params = dict(state["engine"]["params"])
            e.set_state(state["engine"])
            self._strokes, self._samples = state["strokes"], state["samples"].copy()

    def state_bytes(self) -> bytes:
        """Deterministic bytes of the parameters, the tree, markers, step count, generator state, TreeSketch
        fields and strokes (step timings, the shadow grid, which is derived from the tree, and the Grow slider's
        carry left out)."""
        e = self._engine
        s = e.get_state(grid=False)
        sk = s["sketch_state"]
        head = {"params": self.params, "nslots": s["nslots"], "step_count": s["step_count"], "rng": s["rng"],
                "sketch": sk["sketch"], "seed": sk["seed"], "selected": sk["selected"],
                "width_constraints": sorted(sk["width_constraints"].items()),
                "bud_override": sorted((list(k), v.tolist()) for k, v in sk["bud_override"].items()),
                "stroke_dirs": sorted((k.hex(), v.tolist()) for k, v in sk["stroke_dirs"].items()),
                "strokes": self._strokes}
        arrays = [s["tree"][k] for k in sorted(s["tree"])] + [s["markers"], s["marker_age"], s["new_nodes"],
                                                              self._samples]
        return serialise({**head, "arrays": arrays})

    # -- views --------------------------------------------------------------------------------------------------
    def scene(self) -> dict[str, Any]:
        """``{"tree": TreeArrays, "markers": Points, "sketch": Points}`` of the newest snapshot (the sketch: the
        brush centres of the strokes); the views find the tree's bud slots, for the leaves, in the snapshot."""
        snap = self.latest if self.latest is not None else self.make_snapshot()
        return {"tree": snap.tree, "markers": Points(snap.markers), "sketch": Points(snap.sketch)}

    def make_snapshot(self) -> SketchSnapshot:
        """The live tree, its bud slots, the markers and the sketch, immutable, for renderers on other threads."""
        e = self._engine
        t, b = e.tree, e.buds()
        buds = {"pos": b.pos, "dir": b.dir, "radius": t.radius[b.node], "up": t.lat[b.node]}   # fresh gathers
        for v in buds.values():
            v.flags.writeable = False
        return SketchSnapshot(TreeArrays.from_tree(t), buds, _frozen(e.markers), _frozen(self._samples))

    def on_snapshot(self, snapshot: SketchSnapshot) -> None:
        self.n_internodes = snapshot.tree.n_internodes
        self.n_markers = len(snapshot.markers)
        self.steps_done = self._engine.step_count

    # -- files: a TreeLibrary entry ----------------------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Save the tree as the :class:`~plantvr.growth.sketch_tools.TreeLibrary` entry ``path`` (``<folder>/
        <name>.tree`` with its ``<name>.json``), atomically; returns the ``.tree`` path."""
        folder, name = _entry(path)
        check_target(path)                 # its folder must exist, as for every saver (no folder is created)
        with self._lock:
            return TreeLibrary(folder).save(name, self._engine)

    @classmethod
    def load(cls, path: str | os.PathLike, **kwargs: Any) -> SketchDocument:
        """A document holding the tree saved at ``path`` (see :meth:`restore`)."""
        doc = cls(**kwargs)
        doc.restore(path)
        doc.history.clear()
        doc._sync_undo_traits()
        return doc

    @staticmethod
    def _check_restore(path, digest: str | None = None) -> tuple[Path, str]:
        """Door check of :meth:`restore`: the absolute ``.tree`` path and the digest of the entry's files now
        (equal to a logged one)."""
        folder, name = _entry(path)
        tree = (folder / f"{name}.tree").absolute()
        if not tree.is_file():
            raise ValueError(f"cannot read library tree {str(tree)!r}: no such file")
        now = file_digest(*_entry_files(tree))
        check_digest(f"tree library entry {str(tree)!r}", digest, now)
        return tree, now

    def restore(self, path: str | os.PathLike, digest: str | None = None) -> None:
        """Replace the tree, its parameters and options with the library entry saved at ``path`` (one undo item).
        The entry is read and checked in full first, so a missing or corrupt one raises ``ValueError`` and changes
        nothing. Logged as ``restore(path, digest)``: the absolute path and the SHA-256 of the entry's files; a
        replay is refused at its door when they differ, so it reproduces the same state or changes nothing."""
        path, digest = self._check_restore(path, digest)
        folder, name = _entry(path)
        e = TreeLibrary(folder).load(name)
        if file_digest(*_entry_files(path)) != digest:
            raise ValueError(f"cannot load {str(path)!r}: the entry changed while it was read")
        values = e.table_values()
        with self._lock, self._edit():
            self.restore_params(values)
            self._engine = e
            self._samples = np.zeros((0, 3))
            self.log.record("restore", path=str(path), digest=digest)
        self.changed("all", command="restore")


def _point(name: str, value) -> np.ndarray:
    """A checked (3,) point, copied: the log records it after the command ran (a view of the tree would move)."""
    return check_point(name, value).copy()


def _entry(path) -> tuple[Path, str]:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or path-like ending in .tree, got {type(path).__name__}")
    path = Path(path)
    if path.suffix != ".tree":
        raise ValueError(f"path must end in .tree, got {path.suffix!r}")
    return path.parent, path.stem


def _entry_files(tree: Path) -> list[Path]:
    """The files of a library entry: its ``.tree`` and, when there, its ``.json``."""
    side = tree.with_suffix(".json")
    return [tree, side] if side.is_file() else [tree]


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, np.float64, copy=True).reshape(-1, 3)
    a.flags.writeable = False
    return a

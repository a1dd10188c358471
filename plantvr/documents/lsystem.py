"""The L-system document: an L-Py grammar, its derivation step, its declared parameters and its seed, on the
document base (issue 23; L-Py grammars in the notebook, interpreted into the shared tree).

The state is five values: the grammar text (``.lpy``), the derivation step shown, the values of the grammar's
declared parameters set by the user (``extern(name=value)`` in the grammar; the others keep the grammar's
defaults), the seed of stochastic productions and whether the grammar is trusted to run its Python code
(issue 34: grammars are code; an untrusted one goes through the engine's restricted evaluator and a grammar
that needs code is refused with its line). Commands change them (``reset``, ``set_grammar``,
``set_step``, ``grow``, ``set_externs``, ``set_seed``, ``undo``, ``redo``); each is logged, so a session
replays, and each is one undo step (a whole-state atom: four small values). A command is checked completely
before anything changes: a grammar the engine refuses raises its
:class:`~plantvr.lsystem.engine.LSystemError` (line and column) and the document stays as it was.

The constructor logs the session's starting point as a ``reset`` command, so the saved command log
(:meth:`Document.save`) is self-contained: :meth:`Document.from_log` replays it into a fresh document. The
trusted flag is part of the logged ``reset`` / ``set_grammar`` commands; replaying a log that trusted a grammar
runs that grammar's code again, so :meth:`LSystemDocument.replay` (and ``from_log``) refuse such a log, before
anything runs, unless the caller passes ``trusted=True`` again; a command logged untrusted stays untrusted.

Every derivation runs under the engine's time budget (``time_budget=``, seconds per command) and module cap,
so a runaway grammar is refused with its line instead of hanging the kernel.

Derivation is cached per (grammar, parameter values, seed): the strings of every step up to the largest one
reached are kept, so dragging the step slider back costs nothing and forward derives only the new steps (from
one running :meth:`~plantvr.lsystem.engine.LSystem.iterate`, so step ``n`` is the same string however it was
reached, stochastic grammars included). A changed grammar, parameter or seed starts a new cache (the last few
are kept, so undo is instant too). :meth:`LSystemDocument.scene` gives the interpreted tree
(:class:`~plantvr.types.TreeArrays`, turtle of :mod:`plantvr.lsystem.turtle`) and the turtle's shapes (spheres,
discs, ``~l`` leaves, polygons, generalized cylinders: one :class:`~plantvr.lsystem.shapes.ShapeMesh` per L-Py
colour index, with per-vertex colours) turned y-up as every PlantVR tree, so :class:`plantvr.View`, the
headset (:func:`plantvr.vr.attach`) and the exporters (:meth:`LSystemDocument.export`) take them.
"""
from __future__ import annotations

import contextlib
import math
import threading
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._validation import check_choice, check_int, check_range
from ..document import Document, serialise
from ..lsystem.engine import MAX_MODULES as ENGINE_MAX_MODULES
from ..lsystem.engine import TIME_BUDGET, LSystem, LSystemError, read_lpy
from ..lsystem.modules import ModuleString
from ..lsystem.shapes import ShapeMesh, shape_meshes
from ..lsystem.turtle import TurtleNodes
from ..types import TreeArrays, TriMesh

__all__ = ["DEFAULT_GRAMMAR", "MAX_MODULES", "MAX_STEP", "MAX_TEXT", "LSystemDocument", "y_up"]

#: The grammar a new document starts from: ABOP fig. 1.24 d (bracketed, edge + node rewriting), its
#: branching angle a declared parameter.
DEFAULT_GRAMMAR = """\
# ABOP fig. 1.24 d: X -> F[+X]F[-X]+X, F -> FF, delta = 20 degrees
extern(angle=20.0)

Axiom: X
derivation length: 5
production:
X --> F[+(angle)X]F[-(angle)X]+(angle)X
F --> FF
endlsystem
"""
#: Largest derivation step a command accepts (the engine's module cap bounds the string itself).
MAX_STEP = 1000
#: Longest string the document derives by default (it keeps every step's string; the engine allows more).
MAX_MODULES = 10_000_000
#: Longest grammar text accepted, in characters.
MAX_TEXT = 1_000_000
#: Largest magnitude of a declared parameter's value.
MAX_EXTERN = 1e12
#: Derivation caches kept (the current one and the last few, for undo).
_CACHES = 4


def y_up(tree: TreeArrays) -> TreeArrays:
    """``tree`` turned from L-Py's z-up frame (the turtle's heading starts along +z) to PlantVR's y-up frame
    (a rotation of -90 degrees about x: ``(x, y, z) -> (x, z, -y)``); topology, radii and orders unchanged."""
    p = tree.pos
    pos = np.column_stack([p[:, 0], p[:, 2], -p[:, 1]])
    pos.flags.writeable = False
    return TreeArrays(pos, tree.parent, tree.radius, tree.order, tree.main_child)


def _mesh_y_up(mesh):
    """A turtle shape mesh turned y-up as :func:`y_up` (a rotation: winding kept), colours kept."""
    v = mesh.vertices
    return ShapeMesh(np.column_stack([v[:, 0], v[:, 2], -v[:, 1]]), mesh.faces, colors=mesh.colors,
                     material=mesh.material)


@dataclass(eq=False)
class _Derivation:
    """The strings of one (grammar, parameters, seed) up to the largest step reached, and their trees.

    One running :meth:`LSystem.iterate` feeds the strings, so step ``n`` is the engine's ``derive(n)`` however
    it was reached (its random generator is seeded once, at step 0). After the grammar calls ``Stop()`` the later
    steps keep the last string, as L-Py's derivation does; a step that failed fails again, with the same error.
    """

    lsys: LSystem
    steps: Iterator[ModuleString]
    unsupported: str = "error"
    strings: list[ModuleString] = field(default_factory=list)
    trees: dict[int, TurtleNodes] = field(default_factory=dict)
    stopped: bool = False
    error: BaseException | None = None

    def string(self, step: int) -> ModuleString:
        with self.lsys._budget():                             # one time budget for the steps one command needs
            while len(self.strings) <= step and not self.stopped:
                if self.error is not None:
                    raise self.error
                try:
                    nxt = next(self.steps)
                except StopIteration:
                    self.stopped = True
                    break
                except ValueError as exc:           # LSystemError: the same step fails the same way
                    self.error = exc
                    raise
                self.strings.append(nxt)
        return self.strings[min(step, len(self.strings) - 1)]

    def tree(self, step: int) -> TurtleNodes:
        """The turtle's drawing of step ``step``: the tree and its shapes."""
        if step not in self.trees:
            self.trees[step] = self.lsys.draw(self.string(step), unsupported=self.unsupported, shapes=True)
        return self.trees[step]


def _lsystem(text: str, externs: dict[str, float], seed: int, trusted: bool = False,
             time_budget: float = TIME_BUDGET, max_modules: int | None = None) -> LSystem:
    return LSystem(text, seed=seed, trusted=trusted, time_budget=time_budget, max_modules=max_modules, **externs)


class LSystemDocument(Document):
    """An L-Py grammar, its derivation step, its declared parameters and its seed (see the module docstring).

    Parameters
    ----------
    text : str, optional
        The grammar (``.lpy`` text); default :data:`DEFAULT_GRAMMAR`.
    step : int, optional
        Derivation step shown, in [0, :data:`MAX_STEP`]; default the grammar's ``derivation length``.
    externs : dict, optional
        Values of the grammar's declared parameters (``extern(name=value)``) other than its defaults.
    seed : int
        Seed of stochastic productions.
    trusted : bool
        Whether the grammar may run its Python code (default False: restricted evaluator, see
        :class:`~plantvr.lsystem.engine.LSystem`).
    time_budget : float
        Seconds one command may spend deriving (the engine's ``time_budget``).
    unsupported : {"error", "warn"}
        A module L-Py draws but PlantVR's turtle does not (a sphere ``@O``...): refused with its line
        (``"error"``), or left out of the tree with a warning (``"warn"``), as
        :meth:`~plantvr.lsystem.engine.LSystem.draw`.
    max_modules : int
        Longest derived string (the engine's ``max_modules``; the document keeps the strings of every step
        reached, so its default, :data:`MAX_MODULES`, is below the engine's).
    max_undo, max_undo_bytes : int
        Undo depth and byte budget.

    Attributes
    ----------
    text : str
        The grammar.
    step : int
        The derivation step shown.
    overrides : dict
        Declared parameters the user set (``{name: value}``); :attr:`externs` holds every declared one.
    seed : int
        Seed of stochastic productions.
    trusted : bool
        Whether the current grammar runs its Python code.

    Raises
    ------
    LSystemError
        When the grammar does not read or derive (line and column in the message).
    """

    KIND = "lsystem"
    COMMANDS = ("reset", "set_grammar", "set_step", "grow", "set_externs", "set_seed", "undo", "redo")
    EVENTS = ("lsystem",)

    def __init__(self, text: str | None = None, *, step: int | None = None, externs: dict | None = None,
                 seed: int = 0, trusted: bool = False, time_budget: float = TIME_BUDGET,
                 max_modules: int = MAX_MODULES, unsupported: str = "error", max_undo: int = 20,
                 max_undo_bytes: int = 512 * 2 ** 20):
        self._unsupported = check_choice("unsupported", unsupported, ("error", "warn"))
        self._time_budget = check_range("time_budget", time_budget, 1e-3, 1e6)
        self._max_modules = check_int("max_modules", max_modules, 1, ENGINE_MAX_MODULES)
        super().__init__(max_undo=max_undo, max_undo_bytes=max_undo_bytes)
        self._caches: OrderedDict[tuple, _Derivation] = OrderedDict()
        self._cache_lock = threading.RLock()
        self.text, self.step, self.overrides, self.seed, self.trusted = "", 0, {}, 0, False
        self._tree: TreeArrays | None = None
        self._nodes: TurtleNodes | None = None
        self._meshes: tuple[TurtleNodes | None, dict] = (None, {})
        self.reset(DEFAULT_GRAMMAR if text is None else text, step=step, externs=externs, seed=seed,
                   trusted=trusted)

    @classmethod
    def from_log(cls, path, *, trusted: bool = False, **init: Any) -> LSystemDocument:
        """A new document (``cls(**init)``) with the session saved at ``path`` replayed into it; ``trusted`` as
        :meth:`replay`'s."""
        from ..commandlog import CommandLog
        doc = cls(**init)
        doc.replay(CommandLog.load(path, cls.COMMANDS, document=cls.KIND), trusted=trusted)
        return doc

    def replay(self, log, *, trusted: bool = False) -> None:
        """Issue every command of ``log`` (see :meth:`Document.replay`). A log whose ``reset`` / ``set_grammar``
        trusted its grammar is refused (ValueError, nothing run or changed) unless ``trusted=True``: replaying
        it runs that grammar's Python code, which the person replaying must agree to again."""
        from ..commandlog import CommandLog
        if not isinstance(log, CommandLog):
            raise ValueError(f"log must be a CommandLog, got {type(log).__name__}")
        self._trusted(trusted, "trusted")
        for i, ev in enumerate(log.events):
            if ev.command in ("reset", "set_grammar") and isinstance(ev.kwargs, dict) and \
                    ev.kwargs.get("trusted") is True and not trusted:
                raise ValueError(f"event {i} ({ev.command}): this log trusted its grammar to run Python code; "
                                 "replaying it runs that code again: pass trusted=True to replay() / from_log() "
                                 "if you trust this log")
        super().replay(log)

    @classmethod
    def from_file(cls, path, **kwargs: Any) -> LSystemDocument:
        """A document of the ``.lpy`` file at ``path`` (``kwargs`` as the constructor's: ``unsupported=`` as
        :meth:`LSystem.from_file`'s drawing; its Python code runs only with ``trusted=True``). A file that is not
        UTF-8 raises LSystemError naming it, with line and column."""
        text, _ = read_lpy(path)
        return cls(text, **kwargs)

    # -- derived values ----------------------------------------------------------------------------------
    @property
    def lsystem(self) -> LSystem:
        """A new :class:`~plantvr.lsystem.engine.LSystem` of the current grammar, parameters and seed (the
        document's own one feeds its derivation cache and is not shared)."""
        return _lsystem(self.text, self.overrides, self.seed, self.trusted, self._time_budget,
                        self._max_modules)

    @property
    def externs(self) -> dict[str, float]:
        """Every declared parameter of the grammar with its current value (defaults where not set)."""
        return dict(self._derivation(self.text, self.overrides, self.seed, self.trusted).lsys.externs)

    @property
    def defaults(self) -> dict[str, float]:
        """The declared parameters' defaults, as written in the grammar."""
        return dict(self._derivation(self.text, {}, self.seed, self.trusted).lsys.externs)

    @property
    def derivation_length(self) -> int:
        """The grammar's ``derivation length``."""
        return int(self._derivation(self.text, self.overrides, self.seed, self.trusted).lsys.derivation_length)

    @property
    def string(self) -> ModuleString:
        """The derived string at the current step (before interpretation)."""
        return self._derivation(self.text, self.overrides, self.seed, self.trusted).string(self.step)

    @property
    def tree(self) -> TreeArrays:
        """The interpreted tree at the current step, in the turtle's (L-Py, z-up) frame."""
        return self._tree

    @property
    def n_modules(self) -> int:
        """Modules of the derived string at the current step."""
        return len(self.string)

    # -- the derivation cache ----------------------------------------------------------------------------
    def _derivation(self, text: str, overrides: dict, seed: int, trusted: bool) -> _Derivation:
        key = (text, tuple(sorted(overrides.items())), seed, trusted)
        with self._cache_lock:
            d = self._caches.get(key)
            if d is None:
                lsys = _lsystem(text, overrides, seed, trusted, self._time_budget, self._max_modules)
                d = _Derivation(lsys, iter(lsys.iterate(MAX_STEP)), self._unsupported)
                self._caches[key] = d
                while len(self._caches) > _CACHES:
                    self._caches.popitem(last=False)
            self._caches.move_to_end(key)
            return d

    def _evaluate(self, text: str, step: int, overrides: dict, seed: int, trusted: bool) -> TurtleNodes:
        """The tree of a candidate state, deriving what the cache lacks. A derivation that fails raises with the
        current state untouched; it drops its cache unless it is the current one (an interrupt, or any error that
        is not the grammar's, drops it always: its iterator is spent, the next use derives again)."""
        key = (text, tuple(sorted(overrides.items())), seed, trusted)
        try:
            return self._derivation(text, overrides, seed, trusted).tree(step)
        except BaseException as exc:
            with self._cache_lock:
                current = (self.text, tuple(sorted(self.overrides.items())), self.seed, self.trusted)
                if key != current or not isinstance(exc, ValueError):
                    self._caches.pop(key, None)
            raise

    # -- checks ------------------------------------------------------------------------------------------
    @staticmethod
    def _text(text: Any) -> str:
        if not isinstance(text, str):
            raise ValueError(f"text must be the grammar as a str, got {type(text).__name__}")
        if len(text) > MAX_TEXT:                                # located, as the engine's errors
            line = text.count("\n", 0, MAX_TEXT) + 1
            col = MAX_TEXT - (text.rfind("\n", 0, MAX_TEXT) + 1) + 1
            raise LSystemError(f"text must be at most {MAX_TEXT} characters, got {len(text)}", line, col)
        return text

    @staticmethod
    def _step(step: Any, name: str = "step") -> int:
        return check_int(name, step, 0, MAX_STEP)

    @staticmethod
    def _seed(seed: Any) -> int:
        return check_int("seed", seed, 0, 2 ** 63 - 1)

    @staticmethod
    def _default_step(lsys: LSystem) -> int:
        """The grammar's derivation length, the step a new grammar shows: LSystemError at its line when the
        document cannot show it."""
        n = lsys.derivation_length
        if n > MAX_STEP:
            item = lsys._g.derivation_length
            raise LSystemError(f"derivation length {n} is more than the document shows (MAX_STEP = {MAX_STEP})",
                               item[1] if item else 1, 1)
        return n

    @staticmethod
    def _trusted(trusted: Any, name: str = "trusted") -> bool:
        if not isinstance(trusted, (bool, np.bool_)):
            raise ValueError(f"{name} must be True or False, got {trusted!r:.40}")
        return bool(trusted)

    @staticmethod
    def _numbers(values: Any) -> dict[str, float]:
        """``values`` checked as ``{name: finite number}`` (the names are checked against a grammar later)."""
        if values is None:
            return {}
        if not isinstance(values, dict) or not all(isinstance(k, str) for k in values):
            raise ValueError(f"externs must be a dict of {{name: number}}, got {values!r:.200}")
        out: dict[str, float] = {}
        for name, value in values.items():
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise ValueError(f"externs[{name!r}] must be a number, got {value!r:.80}")
            if not math.isfinite(float(value)) or abs(float(value)) > MAX_EXTERN:
                raise ValueError(f"externs[{name!r}] must be finite and within +-{MAX_EXTERN:g}, got {value!r}")
            out[name] = int(value) if isinstance(value, (int, np.integer)) else float(value)
        return out

    def _declared(self, text: str, seed: int, values: dict[str, float], trusted: bool) -> dict[str, float]:
        """``values`` whose names ``text`` declares as parameters; reading ``text`` raises its LSystemError."""
        declared = self._derivation(text, {}, seed, trusted).lsys.externs
        for name in values:
            if name not in declared:
                raise ValueError(f"externs: {name!r} is not a declared parameter of the grammar; declared: "
                                 f"{sorted(declared)}"[:300])
        return values

    # door checks: what holds whatever the state (a replay checks a whole log with them first) ---------------
    def _check_reset(self, text: str, step: int | None = None, externs: dict | None = None,
                     seed: int = 0, trusted: bool = False) -> tuple:
        text, seed, trusted = self._text(text), self._seed(seed), self._trusted(trusted)
        overrides = self._declared(text, seed, self._numbers(externs), trusted)
        step = self._default_step(self._derivation(text, overrides, seed, trusted).lsys) if step is None else step
        return text, self._step(step), overrides, seed, trusted

    def _check_set_grammar(self, text: str, step: int | None = None,
                           trusted: bool = False) -> tuple[str, int | None, bool]:
        text, trusted = self._text(text), self._trusted(trusted)
        self._derivation(text, {}, self.seed, trusted)  # LSystemError (line, column): a grammar that does not read
        return text, None if step is None else self._step(step), trusted

    def _check_set_step(self, step: int) -> int:
        return self._step(step)

    def _check_grow(self, steps: int = 1) -> int:
        return check_int("steps", steps, -MAX_STEP, MAX_STEP)

    def _check_set_externs(self, values: dict) -> dict[str, float]:
        return self._numbers(values)

    def _check_set_seed(self, seed: int) -> int:
        return self._seed(seed)

    # -- commands ----------------------------------------------------------------------------------------
    def _apply(self, command: str, candidate: tuple, kwargs: dict, *, undoable: bool = True) -> None:
        """Derive the candidate state (raising, with nothing changed, when it does not derive), then make it the
        state: one undo atom (none when nothing changed), one log record, one change."""
        text, step, overrides, seed, trusted = candidate
        nodes = self._evaluate(text, step, overrides, seed, trusted)
        with self._lock, self.undoable("lsystem") if undoable else contextlib.nullcontext():
            self.text, self.step, self.overrides, self.seed, self.trusted = text, step, dict(overrides), seed, trusted
            self._tree, self._nodes = nodes.tree, nodes
            self.log.record(command, **kwargs)
        self.changed("lsystem", command=command)

    def reset(self, text: str, step: int | None = None, externs: dict | None = None, seed: int = 0,
              trusted: bool = False) -> None:
        """Start a new session from the grammar ``text`` (with ``externs`` over its defaults, at ``step``, default
        its derivation length; its Python code runs only with ``trusted=True``): the undo history is cleared.
        The constructor logs one, so a saved log replays into any fresh document."""
        candidate = self._check_reset(text, step, externs, seed, trusted)
        text, step, overrides, seed, trusted = candidate
        self._apply("reset", candidate, {"text": text, "step": step, "externs": overrides, "seed": seed,
                                         "trusted": trusted}, undoable=False)
        self.history.clear()
        self._sync_undo_traits()

    def set_grammar(self, text: str, step: int | None = None, trusted: bool = False) -> None:
        """Replace the grammar. Parameters the user set and the new grammar still declares keep their values;
        ``step`` defaults to the new grammar's derivation length; the grammar's Python code runs only with
        ``trusted=True`` (each grammar is trusted on its own: the flag is not inherited).

        Raises
        ------
        LSystemError
            When the grammar does not read (an untrusted one that needs code included) or does not derive to
            ``step`` within the time budget (the document is unchanged).
        """
        text, step, trusted = self._check_set_grammar(text, step, trusted)
        declared = self._derivation(text, {}, self.seed, trusted).lsys.externs
        overrides = {k: v for k, v in self.overrides.items() if k in declared}
        if step is None:
            step = self._default_step(self._derivation(text, overrides, self.seed, trusted).lsys)
        self._apply("set_grammar", (text, step, overrides, self.seed, trusted),
                    {"text": text, "step": step, "trusted": trusted})

    def set_step(self, step: int) -> None:
        """Show derivation step ``step`` (the slider): cached steps cost nothing, new ones are derived from the
        last one reached."""
        step = self._check_set_step(step)
        self._apply("set_step", (self.text, step, dict(self.overrides), self.seed, self.trusted), {"step": step})

    def grow(self, steps: int = 1) -> None:
        """Go ``steps`` derivation steps on (back when negative, never below 0; the headset's pad click)."""
        steps = self._check_grow(steps)
        step = min(max(self.step + steps, 0), MAX_STEP)
        self._apply("grow", (self.text, step, dict(self.overrides), self.seed, self.trusted), {"steps": steps})

    def set_externs(self, values: dict) -> None:
        """Set declared parameters of the grammar, ``{name: value}`` (all checked before any is set)."""
        values = self._declared(self.text, self.seed, self._check_set_externs(values), self.trusted)
        self._apply("set_externs", (self.text, self.step, {**self.overrides, **values}, self.seed, self.trusted),
                    {"values": values})

    def set_seed(self, seed: int) -> None:
        """Seed the stochastic productions."""
        seed = self._check_set_seed(seed)
        self._apply("set_seed", (self.text, self.step, dict(self.overrides), seed, self.trusted), {"seed": seed})

    # -- state -------------------------------------------------------------------------------------------
    def get_state(self) -> dict[str, Any]:
        return {"text": self.text, "step": self.step, "overrides": dict(self.overrides), "seed": self.seed,
                "trusted": self.trusted}

    def set_state(self, state: dict[str, Any]) -> None:
        text, step, overrides, seed = state["text"], state["step"], dict(state["overrides"]), state["seed"]
        trusted = bool(state.get("trusted", False))
        nodes = self._evaluate(text, step, overrides, seed, trusted)
        self._tree, self._nodes = nodes.tree, nodes
        self.text, self.step, self.overrides, self.seed, self.trusted = text, step, overrides, seed, trusted

    def state_bytes(self) -> bytes:
        """The grammar, step, parameters and seed with the derived string and the tree, as deterministic bytes."""
        with self._lock:
            s, t = self.string, self._tree
            return serialise({"text": self.text, "step": self.step, "overrides": self.overrides, "seed": self.seed,
                              "trusted": self.trusted, "string": (list(s.names), s.ids, s.arg_ptr, s.args), "tree": t})

    def make_snapshot(self) -> TreeArrays | None:
        """The tree (immutable arrays: render threads read it as it is)."""
        return self._tree

    @property
    def shapes(self) -> dict[int, TriMesh]:
        """The turtle's shapes at the current step, one :class:`~plantvr.lsystem.shapes.ShapeMesh` per colour
        index (L-Py's frame, z-up; :func:`~plantvr.lsystem.shapes.shape_meshes`) in the grammar's material table
        (:attr:`~plantvr.lsystem.LSystem.materials`), made once per step."""
        with self._lock:
            nodes, (made_for, meshes) = self._nodes, self._meshes
            if nodes is not None and made_for is not nodes:
                meshes = shape_meshes(nodes.shapes, materials=self._derivation(self.text, self.overrides, self.seed,
                                                                                  self.trusted).lsys.materials)
                self._meshes = (nodes, meshes)
            return dict(meshes) if nodes is not None else {}

    def scene(self) -> dict[str, Any]:
        """``{"tree": TreeArrays, "shapes 2": ShapeMesh, ...}``: the interpreted tree at the current step and the
        turtle's shapes, one mesh per colour index (``shapes <index>``, per-vertex colours), all y-up
        (:func:`y_up`)."""
        with self._lock:
            nodes = self._nodes
            shapes = self.shapes
        if nodes is None:
            return {}
        from ..lsystem.shapes import shape_name
        return {"tree": y_up(nodes.drawn_tree()), **{shape_name(k): _mesh_y_up(m) for k, m in shapes.items()}}


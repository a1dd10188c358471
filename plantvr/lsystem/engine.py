"""The L-system engine (issue 23): L-Py grammars derived into :class:`~plantvr.lsystem.modules.ModuleString` s.

:class:`LSystem` reads ``.lpy`` text (:mod:`plantvr.lsystem.grammar`), runs its Python code in a namespace of its
own (``math`` names, seeded ``random``/``uniform``/``gauss``..., ``extern(name=value)`` parameters,
``forward()``/``backward()``/``getIterationNb()``/``Stop()``, ``Start``/``End``/``StartEach``/``EndEach``
hooks without arguments, ``context().turtle.setAngleIncrement(a)`` as a turtle option) and derives strings in
parallel as L-Py does: the first rule (file order) whose pattern matches and that produces replaces a module,
others are copied; decomposition rules are applied after every step up to ``maximum depth``; homomorphism rules
in :meth:`LSystem.interpret`. Issue 33 adds L-Py's module parameters of any Python value (below), constants in
pattern parameters, multi-module predecessors (rewritten left to right), rule groups (``group N:``,
``useGroup(n)``: the active group's rules, then group 0's) and contexts in decomposition / homomorphism rules (L-Py's
recursion: each successor decomposed on its own). A step skips what a cut ``%`` cuts, up to the ``]`` closing its
branch, and drops it (L-Py's ``Lsystem::__step``). What stays refused is listed in :mod:`plantvr.lsystem.grammar`.

Query modules (issue 33, L-Py's request modules ``?P``, ``?H``, ``?U``, ``?L``, ``?R``, ``?F``): before a
production step whose active rules have one in a pattern (``A > ?P(x, y, z) : z < h --> F A``), the string is
interpreted (homomorphism, then the turtle) and each request module's parameters are set to the turtle's
frame there (:meth:`LSystem._query`; one parameter: a :class:`~plantvr.lsystem.plantgl.Vector3`, whose ``x``,
``y``, ``z`` untrusted rules may read; three: x, y, z).

How a step runs, fastest first:

* every rule constant (context-free, no condition, successor parameters free of pattern variables): one numba
  count pass and one fill pass over the int ids (``_derive_kernels``); :meth:`LSystem.derive` without
  decomposition or per-step hooks does all ``n`` steps at once, each expansion E(symbol, k) built once in place
  and copied as a block wherever it recurs, so the cost is about one write of the final string;
* otherwise modules are grouped by predecessor id; one-line rules (``-->`` or ``: cond -->``) whose condition and
  successor parameters are arithmetic, comparisons, ``and/or/not``, ``a if c else b`` and ``math`` functions of
  the pattern variables and numeric constants are evaluated vectorised on numpy parameter columns;
* rules that cannot vectorise run per module in Python: block bodies (``produce`` inside Python code, hence all
  stochastic rules), calls of grammar functions or ``random``, context-sensitive rules (``<``, ``>``, with
  ``ignore:``/``consider:``, matched along the axial tree: a left context skips lateral branches, a right context
  skips them unless the pattern opens one) and steps where a new-context rule (``<<``, ``>>``) needs the string
  rewritten in order (forward, or backward after ``backward()``).

Grammars are code (issue 34): an ``.lpy`` file's Python (imports, functions, statements, indented rule bodies)
runs only with ``trusted=True``; by default one-line rules, conditions and expressions go through the
restricted evaluator of :mod:`plantvr.lsystem.sandbox`, and code is refused with its line. Every grammar is
guarded (huge integers refused before they are computed, loops of trusted code ticking the clock) and every
derivation has a time budget (``time_budget=``) and a module cap (``max_modules=``), checked while a step is built
(each rule call, each vectorised rule, each ``nproduce``), so a runaway grammar stops with LSystemError at its
line.

Parameters are float64 (integral values reach Python rule code as ``int``); a parameter of any other Python
value (str, tuple, list, None, bool: ``@L("text")``, issue 33, as L-Py's modules hold any object) is kept in the
string's object side-table (:attr:`ModuleString.objects`), literals included in untrusted grammars; strings
holding objects are derived per module in Python, numeric ones keep the numba and vectorised paths. A turtle
module's numeric vectors and bools are read as numbers. Angles are never converted (degrees, the turtle's
unit).

This module holds :class:`LSystem` itself (L-Py's ``Lsystem``, ``src/cpp/lsystem.cpp``): construction, the
public calls, the derivation driver (step by step, or all at once for constant rules) and its caps. Its bases
hold the rest: :mod:`plantvr.lsystem.namespace` (the grammar's Python namespace and code),
:mod:`plantvr.lsystem.rules` (rule compilation and calls), :mod:`plantvr.lsystem.matching` (context matching)
and :mod:`plantvr.lsystem.rewrite` (production steps, decomposition, homomorphism, the query pass).
"""
from __future__ import annotations

import math
import random as _random
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from plantvr._fileio import TextDecodeError, read_text
from plantvr._validation import check_choice, check_int, check_range
from plantvr.types import TreeArrays

from . import _derive_kernels as K
from . import sandbox as SB
from .grammar import Grammar, parse_grammar
from .lexer import LSystemError
from .matching import _Matching
from .modules import ModuleString
from .namespace import MAX_DERIVATION, _Namespace
from .rewrite import _pack, _Rewriting
from .rules import _Compiled, _Rules

__all__ = ["MAX_DERIVATION", "MAX_MODULES", "TIME_BUDGET", "LSystem", "LSystemError", "read_lpy"]

#: Longest string (modules) a derivation may produce; checked from the count pass, before allocating.
MAX_MODULES = 50_000_000
#: Most parameters a derived string may hold.
MAX_PARAMETERS = 200_000_000
#: Default time budget of building an L-system and of one derivation (:meth:`LSystem.derive`, one step of
#: :meth:`LSystem.iterate`), in seconds.
TIME_BUDGET = 10.0
#: Largest (steps + 1) x symbols length table of the all-at-once derivation of constant rules (else step-wise).
_EXPAND_CELLS = 4_000_000
#: Saturation of that table's lengths (exact below, far above MAX_MODULES and MAX_PARAMETERS).
_EXPAND_CAP = 2 ** 52


def read_lpy(path: str | Path) -> tuple[str, str]:
    """The text of the ``.lpy`` file at ``path`` and its name.

    Raises
    ------
    ValueError
        ``path`` is not a file or cannot be read.
    LSystemError
        The file is not UTF-8 text (the message names the file; line and column of the first bad byte).
    """
    try:
        return read_text(path, what="grammar"), str(Path(path))
    except TextDecodeError as e:
        raise LSystemError(str(e), e.line, e.column) from None


class _Budget:
    """:meth:`LSystem._budget`."""

    __slots__ = ("ls",)

    def __init__(self, ls) -> None:
        self.ls = ls

    def __enter__(self) -> None:
        ls = self.ls
        if ls._outer == 0:
            _warm_kernels()                                   # numba compiling is not the grammar's time
            ls._deadline = time.monotonic() + ls.time_budget
        ls._outer += 1

    def __exit__(self, *exc) -> bool:
        ls = self.ls
        ls._outer -= 1
        if ls._outer == 0:
            ls._deadline = math.inf
        return False


class LSystem(_Namespace, _Rules, _Matching, _Rewriting):
    """An L-Py grammar, ready to derive.

    Parameters
    ----------
    text : str
        The ``.lpy`` grammar text.
    seed : int, optional
        Seed of the grammar's ``random``/``uniform``/``gauss``... (reseeded at each derivation, so a seeded
        derivation is reproducible).
    trusted : bool
        Whether the grammar's Python code may run (``import``, ``def``, statements, indented rule bodies), as
        Jupyter trusts a notebook. Default False: the grammar goes through the restricted evaluator of
        :mod:`plantvr.lsystem.sandbox` and a grammar that needs code is refused with its line and column.
    time_budget : float
        Seconds that building the L-system, and each derivation (:meth:`derive`; each step of :meth:`iterate`),
        may take; checked while a step is built (each rule call, each produced chunk, each loop iteration of
        trusted code), so a runaway grammar stops with LSystemError naming its line.
    max_modules : int, optional
        Longest string a derivation may build (default :data:`MAX_MODULES`), checked as each chunk is produced.
    **externs : float
        Values of the grammar's declared parameters (``extern(name=value)`` or the editor's scalars).

    Raises
    ------
    LSystemError
        A layout or Python error in the grammar, an unsupported construct, code an untrusted grammar may not
        run, or a budget exceeded, with line and column.
    ValueError
        An unknown or non-numeric extern, or a bad option.

    References
    ----------
    .. [1] Boudon et al. 2012, L-Py: an L-system simulation framework for modeling plant architecture
       development based on a dynamic language, Front. Plant Sci. 3:76.
    .. [2] Prusinkiewicz & Lindenmayer 1990, The Algorithmic Beauty of Plants (ABOP), ch. 1.

    Examples
    --------
    >>> ls = LSystem("Axiom: F\\nderivation length: 2\\nproduction:\\nF --> F[+F]F\\nendlsystem")
    >>> str(ls.derive())
    'F[+F]F[+F[+F]F]F[+F]F'
    """

    def __init__(self, text: str, *, seed: int | None = None, filename: str = "<lpy>", trusted: bool = False,
                 time_budget: float = TIME_BUDGET, max_modules: int | None = None, **externs: float) -> None:
        if not isinstance(text, str):
            raise ValueError(f"text must be a str, got {type(text).__name__}")
        if seed is not None:
            seed = check_int("seed", seed, 0, 2 ** 63 - 1)
        if not isinstance(trusted, (bool, np.bool_)):
            raise ValueError(f"trusted must be True or False, got {trusted!r:.40}")
        self.trusted = bool(trusted)
        self.time_budget = check_range("time_budget", time_budget, 1e-3, 1e6)
        self._max_modules = None if max_modules is None else check_int("max_modules", max_modules, 1, MAX_MODULES)
        if not isinstance(filename, str):
            raise ValueError(f"filename must be a str, got {type(filename).__name__}")
        self._deadline = time.monotonic() + self.time_budget
        self._outer = 0
        self._where = (0, 0)                              # (line, column) the derivation is at, for budget errors
        for k, v in externs.items():
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or \
                    not math.isfinite(float(v)):
                raise ValueError(f"extern {k} must be a finite number, got {v!r}")
        self._text = text
        self._filename = filename
        self._seed = seed
        self._overrides = {k: float(v) if isinstance(v, (float, np.floating)) else int(v) for k, v in externs.items()}
        self._g: Grammar = parse_grammar(text, deadline=self._deadline)
        self._lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
        self._where = (self._g.axiom[1], 1)
        self._names: list[str] = ["[", "]"]
        self._index: dict[str, int] = {"[": 0, "]": 1}
        for name in self._g.first_use:
            self._sid(name)
        self._rng = _random.Random(seed)
        self._turtle: dict[str, float] = {}
        self._externs: dict[str, float] = {}
        self._nbuf: list = []
        self._direction = 1
        self._iteration = 0
        self._stopped = False
        self._next_group = 0                                  # useGroup(n): the group of the next steps
        self._group = 0
        self._scales = {self._sid(name): v for name, v in self._g.scales.items()}   # module scales, by id
        self._ns = self._namespace()
        self._exec_python()
        self._hooks = self._read_hooks()
        self.derivation_length = self._eval_int(self._g.derivation_length, "derivation length", 1)
        self._max_depth = {k: self._eval_int(self._g.max_depth.get(k), "maximum depth", 1)
                           for k in ("decomposition", "homomorphism")}
        self._ignored = None                                 # the filter of the rule being matched
        filters: dict = {}
        self._tables: dict[str, Any] = {}
        self._all_rules: list[_Compiled] = []
        for rule in self._g.rules:
            c = self._compile(rule)
            c.group = self._eval_int(rule.group, "group", 0)
            if rule.filter not in filters:
                filters[rule.filter] = self._ignore_set(rule.filter)
            c.ignored = filters[rule.filter]
            self._all_rules.append(c)
        self._start_group = self._next_group                  # a top-level useGroup(n)
        self._start_direction = self._direction               # a top-level backward()
        self._set_group(self._start_group)
        self.axiom = self._read_axiom()
        self._deadline = math.inf

    def _read_axiom(self) -> ModuleString:
        """The axiom: its L-string, or the modules its indented Python block produces (trusted grammars)."""
        src, ln, col = self._g.axiom
        if not self._g.axiom_block:
            return self._to_string(self._eval_lstring(self._g.axiom_tokens, ln, "the axiom"), ln)
        if not self.trusted:
            raise LSystemError("the axiom is a Python block: " + SB.TRUST_HINT, ln, col)
        self._ns["__lsys_axiom__"] = self._function((), self._g.axiom_block, ln, "the axiom")
        self._nbuf.clear()
        res = self._run_code(self._expr("__lsys_axiom__()", ln, col, "the axiom"), ln, "the axiom")
        mods = list(self._nbuf) + list(res or ())
        self._nbuf.clear()
        return self._to_string(mods, ln)

    @classmethod
    def from_file(cls, path: str | Path, *, seed: int | None = None, trusted: bool = False,
                  time_budget: float = TIME_BUDGET, max_modules: int | None = None, **externs: float) -> LSystem:
        """Read a ``.lpy`` file (UTF-8); errors give the file's line and column. ``trusted`` as the
        constructor's: a file's Python code runs only when the caller says so."""
        text, filename = read_lpy(path)
        return cls(text, seed=seed, filename=filename, trusted=trusted, time_budget=time_budget,
                   max_modules=max_modules, **externs)

    # -- public --------------------------------------------------------------------------------------------------
    @property
    def externs(self) -> dict[str, float]:
        """The grammar's declared parameters with their current values."""
        return dict(self._externs)

    @property
    def turtle_options(self) -> dict[str, float]:
        """Turtle keyword arguments the grammar sets (``context().turtle.setAngleIncrement(a)`` -> angle)."""
        return dict(self._turtle)

    @property
    def names(self) -> tuple[str, ...]:
        """The symbol table of the strings this L-system derives."""
        return tuple(self._names)

    def derive(self, n: int | None = None, *, string: ModuleString | None = None) -> ModuleString:
        """The string after ``n`` steps (default: the derivation length) from the axiom or ``string``;
        decomposition is applied after each step.

        When every production is constant (context-free, no condition, one rule per symbol, successor parameters
        free of pattern variables) and there is no decomposition, no cut ``%`` and no Start/End/StartEach/EndEach
        hook, the ``n`` steps are done at once (each module of the result written once, repeated blocks copied); the
        result is the one the step-wise derivation (:meth:`iterate`) gives, array for array.
        """
        n = self.derivation_length if n is None else check_int("n", n, 0, MAX_DERIVATION)
        s = self.axiom if string is None else self._adopt(string)
        with self._budget():
            try:
                out = self._expand(n, s)
                if out is not None:
                    return out
                for out in self._run(n, s):
                    pass
            except MemoryError:
                raise LSystemError(f"out of memory deriving step {self._iteration}", *self._where) from None
        return out

    def iterate(self, n: int | None = None, *, string: ModuleString | None = None) -> Iterator[ModuleString]:
        """Yield the string after each step ``0..n`` (step 0 is the start string)."""
        n = self.derivation_length if n is None else check_int("n", n, 0, MAX_DERIVATION)
        s = self.axiom if string is None else self._adopt(string)
        return self._run(n, s)

    def interpret(self, string: ModuleString) -> ModuleString:
        """The homomorphism (``interpretation:``) pass, up to its maximum depth, between what the grammar's
        ``StartInterpretation()`` and ``EndInterpretation()`` produce (L-Py's ``TurtleInterpreter::init`` /
        ``finalize``)."""
        return self._framed(self._decompose(self._adopt(string), "homomorphism"))[0]

    def _framed(self, s: ModuleString) -> tuple[ModuleString, int, int]:
        """``s`` framed by what ``StartInterpretation()`` / ``EndInterpretation()`` produce, and the two counts."""
        head, tail = (self._interpretation_hook(n) for n in ("StartInterpretation", "EndInterpretation"))
        if head is None and tail is None:
            return s, 0, 0
        out = ModuleString.concat([self._adopt(p) for p in (head, s, tail) if p is not None], self._names)
        return out, 0 if head is None else len(head), 0 if tail is None else len(tail)

    def tree(self, n: int | None = None, *, unsupported: str = "error", **turtle_options: Any) -> TreeArrays:
        """``self.draw(self.derive(n))``: the skeleton after ``n`` derivation steps (see :meth:`draw`)."""
        return self.draw(self.derive(n), unsupported=unsupported, **turtle_options)

    def draw(self, string: ModuleString, *, unsupported: str = "error", shapes: bool = False,
             **turtle_options: Any) -> TreeArrays:
        """``turtle(self.interpret(string), **options)``: the grammar's turtle options, overridden by
        ``turtle_options``; ``shapes=True``: ``turtle_nodes(...)``, the tree with its spheres, surfaces, polygons
        and tubes (:class:`~plantvr.lsystem.turtle.TurtleNodes`).

        A module that L-Py draws but the turtle does not (:data:`~plantvr.lsystem.turtle.LPY_UNSUPPORTED`: a
        PlantGL shape ``@g``, a guide ``SetGuide``, ...) raises LSystemError with the line it is first used on
        (``unsupported="error"``), or is left out of the picture with one warning naming each such module
        (``"warn"``); it never changes the skeleton, which the turtle's moves and turns alone make.
        """
        from .turtle import turtle, turtle_nodes
        unsupported = check_choice("unsupported", unsupported, ("error", "warn"))
        s = self._drawable(self.interpret(string), unsupported)
        return self._turtle_call(turtle_nodes if shapes else turtle, s, {**self._turtle, **turtle_options})

    def _drawable(self, s: ModuleString, unsupported: str, origin: list | None = None) -> ModuleString:
        """The interpreted string ``s`` as the turtle reads it (``@g`` read by :mod:`~plantvr.lsystem.pglshapes`,
        ``first_params``), after the check of the modules it does not draw (see :meth:`draw`); ``origin``
        gets the index in ``s`` of each module of the result."""
        import warnings

        from .pglshapes import expand_pgl_shapes
        from .turtle import LPY_UNSUPPORTED, first_params
        try:
            s, came = expand_pgl_shapes(s, unsupported)
        except LSystemError as e:
            at = self._g.first_use.get("@g", self._g.first_use.get("PglShape", (0, 0)))
            raise LSystemError(e.detail, *at) from None
        if origin is not None:
            origin.extend(range(len(s)) if came is None else came)
        s = first_params(s)
        used = np.flatnonzero(np.bincount(s.ids, minlength=len(s.names))) if len(s) else np.zeros(0, np.int64)
        bad = [s.names[k] for k in used.tolist() if s.names[k] in LPY_UNSUPPORTED]
        for name in bad[:1] if unsupported == "error" else ():
            line, col = self._g.first_use.get(name, (0, 0))
            raise LSystemError(f"unsupported module {name} (L-Py draws it, PlantVR's turtle does not; "
                               "unsupported='warn' draws the skeleton without it)", line, col)
        if bad:
            where = ", ".join(f"{name} (line {self._g.first_use.get(name, (0, 0))[0]})" for name in bad)
            warnings.warn(f"not drawn (L-Py draws them, PlantVR's turtle does not): {where}", stacklevel=3)
        return s

    def _turtle_call(self, fn, s: ModuleString, turtle_options: dict):
        """``fn(s, **turtle_options)``; a module the turtle refuses is an LSystemError at the grammar line it is
        first used on."""
        try:
            return fn(s, **turtle_options)
        except ValueError as e:                               # a module the turtle refuses: its grammar line
            m = re.search(r"module (\S+) at index", str(e))
            line, col = self._g.first_use.get(m.group(1), (0, 0)) if m else (0, 0)
            if not line:
                raise
            raise LSystemError(str(e), line, col) from None

    def __repr__(self) -> str:
        return (f"LSystem({len(self._g.rules)} rules, derivation length {self.derivation_length}, "
                f"axiom {self.axiom!r})")

    # -- budgets -------------------------------------------------------------------------------------------------
    def _budget(self) -> _Budget:
        """Context manager: one deadline (``time_budget`` from now) for everything inside, nested ones included."""
        return _Budget(self)

    @property
    def max_modules(self) -> int:
        """Longest string a derivation may build."""
        return MAX_MODULES if self._max_modules is None else min(self._max_modules, MAX_MODULES)

    # -- symbols, groups and strings -----------------------------------------------------------------------------
    def _sid(self, name: str) -> int:
        k = self._index.get(name)
        if k is None:
            k = self._index[name] = len(self._names)
            self._names.append(name)
            self._tables.clear() if hasattr(self, "_tables") else None
        return k

    def _set_group(self, g: int) -> None:
        """The active rules: group ``g``'s in file order, then group 0's (``Lsystem::__getRules`` of L-Py; a
        group without rules leaves group 0's)."""
        self._group = g
        self._rules = {k: [c for c in self._all_rules if c.rule.kind == k and c.group == g] +
                       ([c for c in self._all_rules if c.rule.kind == k and c.group == 0] if g else [])
                       for k in ("production", "decomposition", "homomorphism")}
        self._tables.clear()

    def _reset_group(self) -> None:
        """A derivation starts in the group the grammar's top-level code chose (0 without ``useGroup``)."""
        self._next_group = self._start_group
        if self._group != self._start_group:
            self._set_group(self._start_group)

    def _to_string(self, mods: list, line: int) -> ModuleString:
        packed = [self._produced(name, vals, line) for name, vals in mods]
        return ModuleString(tuple(self._names), *_pack(packed))

    def _adopt(self, s: ModuleString) -> ModuleString:
        if not isinstance(s, ModuleString):
            raise ValueError(f"string must be a ModuleString, got {type(s).__name__}")
        if len(s.names) <= len(self._names) and tuple(self._names[:len(s.names)]) == s.names:
            ids = s.ids
        else:
            remap = np.array([self._sid(nm) for nm in s.names], np.int32)
            ids = remap[s.ids] if len(s) else s.ids
        return ModuleString(tuple(self._names), ids, s.arg_ptr, s.args, s.objects)

    def _make(self, ids, ptr, args, objects=None) -> ModuleString:
        return ModuleString(tuple(self._names), ids, ptr, args, objects or {})

    def _make_trusted(self, ids, ptr, args) -> ModuleString:
        """A string from kernel output, valid by construction (ids from the symbol table, ptr rising)."""
        return ModuleString._trusted(tuple(self._names), ids, ptr, args)

    # -- derivation ----------------------------------------------------------------------------------------------
    def _run(self, n: int, s: ModuleString) -> Iterator[ModuleString]:
        """:meth:`_steps`, with running out of memory an LSystemError at the line being derived."""
        steps = self._steps(n, s)
        while True:
            try:
                out = next(steps)
            except StopIteration:
                return
            except MemoryError:
                raise LSystemError(f"out of memory deriving step {self._iteration}", *self._where) from None
            yield out

    def _steps(self, n: int, s: ModuleString) -> Iterator[ModuleString]:
        if self._seed is not None:                            # unseeded: the generator runs on (no urandom read)
            self._rng.seed(self._seed)
        self._reseed_globals()
        self._direction, self._iteration, self._stopped = self._start_direction, 0, False
        self._reset_group()
        if self._outer == 0:
            self._deadline = time.monotonic() + self.time_budget
        self._where = (self._g.rules[0].line if self._g.rules else 1, 1)
        with self._seeded():
            s = self._hook("Start", s)
        yield s
        for it in range(n):
            self._iteration = it
            if self._outer == 0:
                self._deadline = time.monotonic() + self.time_budget
            elif time.monotonic() > self._deadline:
                raise self._over_budget()
            with self._seeded():
                s = self._hook("StartEach", s)
                if self._next_group != self._group:           # L-Py reads the group after StartEach
                    self._set_group(self._next_group)
                if self._rules["production"]:
                    if any(c.query for c in self._rules["production"]):
                        s = self._query(s)
                    s, _ = self._rewrite(s, "production")
                s = self._decompose(s, "decomposition")
                s = self._hook("EndEach", s)
            yield s
            if self._stopped:
                break
        with self._seeded():
            self._hook("End", s)

    def _expand(self, n: int, s: ModuleString) -> ModuleString | None:
        """The string after ``n`` steps of constant productions at once, or None where the step-wise
        derivation is needed (other rules, decomposition, per-step hooks, a too large length table)."""
        self._reset_group()
        if n < 1 or not len(s) or s.objects or self._hooks or self._rules["decomposition"] or \
                not self._rules["production"] or any(c.query for c in self._rules["production"]) or \
                "%" in self._index or "Cut" in self._index:
            return None
        table = self._constant_table("production")
        if table is None:
            return None
        rule_arity, sptr, sids, saptr, sargs = table
        S = rule_arity.shape[0]
        if (n + 1) * S > _EXPAND_CELLS:
            return None
        lm, la = K.expand_lengths(n, rule_arity, sptr, sids, saptr, _EXPAND_CAP)
        nargs = np.diff(s.arg_ptr)
        rw = rule_arity[s.ids] == nargs
        c = np.bincount(s.ids[rw], minlength=S).astype(np.float64)
        kept_m, kept_a = float(np.count_nonzero(~rw)), float(nargs[~rw].sum())
        tot_m = lm[1:] @ c + kept_m                           # string length after each step 1..n
        tot_a = la[1:] @ c + kept_a
        over = np.flatnonzero((tot_m > self.max_modules) | (tot_a > MAX_PARAMETERS))
        k = int(over[0]) + 1 if over.size else n              # the step the step-wise derivation stops at
        ci = c.astype(np.int64).tolist()
        n_out = int(kept_m) + sum(x * int(v) for x, v in zip(ci, lm[k].tolist()))
        m_out = int(kept_a) + sum(x * int(v) for x, v in zip(ci, la[k].tolist()))
        self._check_size(n_out, m_out)
        with_ptr = m_out > 0
        out_ids = np.empty(n_out, np.int32)
        out_ptr = np.empty(n_out + 1, np.int64) if with_ptr else np.zeros(n_out + 1, np.int64)
        out_args = np.empty(m_out, np.float64)
        K.expand_constant(s.ids, s.arg_ptr, s.args, n, rule_arity, sptr, sids, saptr, sargs, lm, la, out_ids,
                          out_ptr, out_args, with_ptr)
        if self._seed is not None:                            # the state _run leaves
            self._rng.seed(self._seed)
        self._direction, self._iteration, self._stopped = self._start_direction, n - 1, False
        return self._make_trusted(out_ids, out_ptr, out_args)

    def _check_size(self, n_out: int, m_out: int, line: int = 0) -> None:
        """LSystemError (at ``line``, default the rule that grows the string most) for a string over the caps."""
        cap = self.max_modules
        if n_out <= cap and m_out <= MAX_PARAMETERS:
            return
        line = line or self._growth_line()
        if n_out > cap:
            name = "MAX_MODULES" if cap == MAX_MODULES else "max_modules"
            raise LSystemError(f"the derived string would have {n_out:,} modules, more than {name} = "
                               f"{cap:,}; derive fewer steps", line, 1)
        raise LSystemError(f"the derived string would have {m_out:,} parameters, more than MAX_PARAMETERS = "
                           f"{MAX_PARAMETERS:,}; derive fewer steps", line, 1)

    def _growth_line(self) -> int:
        """Line of the production rule with the longest successor (the one a too long string comes from)."""
        best, line = -1, 0
        for r in self._g.rules:
            k = len(r.successor) if r.successor is not None else 2
            if k > best:
                best, line = k, r.line
        return line or (self._g.axiom[1] if self._g.axiom else 1)

    def _constant_table(self, kind: str):
        key = ("const", kind, len(self._names))
        if key in self._tables:
            return self._tables[key]
        rules = self._rules[kind]
        table = None
        sids = [r.sid for r in rules]
        if all(r.const is not None for r in rules) and len(set(sids)) == len(sids):
            S = len(self._names)
            arity = np.full(S, -1, np.int64)
            lens = np.zeros(S, np.int64)
            succ = {}
            for r in rules:
                arity[r.sid] = r.arity
                succ[r.sid] = r.const
                lens[r.sid] = len(r.const)
            sptr = np.zeros(S + 1, np.int64)
            np.cumsum(lens, out=sptr[1:])
            flat = [m for k in range(S) for m in succ.get(k, [])]
            s_ids = np.array([m[0] for m in flat], np.int32)
            saptr = np.zeros(len(flat) + 1, np.int64)
            np.cumsum([len(m[1]) for m in flat], out=saptr[1:])
            sargs = np.array([v for m in flat for v in m[1]], np.float64)
            table = (arity, sptr, s_ids, saptr, sargs)
        self._tables[key] = table
        return table


_WARM: list = []


def _warm_kernels() -> None:
    """Compile (or load from numba's cache) the derivation kernels once per process, outside any time budget."""
    if _WARM:
        return
    _WARM.append(True)
    ls = LSystem("Axiom: F(1)X\nproduction:\nX --> F(1)[+X]X\nendlsystem\n", time_budget=1e6)
    ls.derive(2)                                              # all at once
    list(ls.iterate(2))                                       # step-wise
    K.match_brackets(ls.axiom.ids, 0, 1)

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
"""
from __future__ import annotations

import ast
import builtins
import inspect
import math
import random as _random
import re
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from plantvr._validation import check_choice, check_int, check_range
from plantvr.types import TreeArrays

from . import _derive_kernels as K
from . import sandbox as SB
from .grammar import Grammar, Rule, lstring_to_py, parse_grammar
from .lexer import LSystemError, Token, lex
from .modules import _EMPTY, ModuleString, is_number

__all__ = ["MAX_DERIVATION", "MAX_MODULES", "TIME_BUDGET", "LSystem", "LSystemError", "read_lpy"]

#: Longest string (modules) a derivation may produce; checked from the count pass, before allocating.
MAX_MODULES = 50_000_000
#: Most parameters a derived string may hold.
MAX_PARAMETERS = 200_000_000
#: Most derivation steps one call may ask for (a grammar's ``derivation length`` included).
MAX_DERIVATION = 100_000
#: Default time budget of building an L-system and of one derivation (:meth:`LSystem.derive`, one step of
#: :meth:`LSystem.iterate`), in seconds.
TIME_BUDGET = 10.0
#: Largest (steps + 1) x symbols length table of the all-at-once derivation of constant rules (else step-wise).
_EXPAND_CELLS = 4_000_000
#: Saturation of that table's lengths (exact below, far above MAX_MODULES and MAX_PARAMETERS).
_EXPAND_CAP = 2 ** 52

_RANDOM_FUNCS = ("random", "uniform", "gauss", "normalvariate", "randint", "choice", "expovariate",
                 "betavariate", "triangular", "lognormvariate", "shuffle", "sample", "randrange", "seed",
                 "vonmisesvariate", "gammavariate", "paretovariate", "weibullvariate", "getrandbits")
#: Those an untrusted grammar gets (the others can build large objects or reseed).
_SAFE_RANDOM = ("random", "uniform", "gauss", "normalvariate", "randint", "choice", "expovariate", "betavariate",
                "triangular", "lognormvariate", "randrange", "vonmisesvariate", "gammavariate", "paretovariate",
                "weibullvariate")
_NP_FUNCS = {"sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
             "log10": np.log10, "floor": np.floor, "ceil": np.ceil, "fabs": np.abs, "abs": np.abs,
             "asin": np.arcsin, "acos": np.arccos, "atan": np.arctan, "atan2": np.arctan2, "radians": np.radians,
             "degrees": np.degrees, "pow": np.power, "min": np.minimum, "max": np.maximum, "int": np.trunc,
             "float": lambda a: a, "round": np.round, "hypot": np.hypot, "sinh": np.sinh, "cosh": np.cosh,
             "tanh": np.tanh}
_PURE = {name: getattr(math, name, None) for name in _NP_FUNCS} | {"abs": abs, "min": min, "max": max, "int": int,
                                                                  "float": float, "round": round, "pow": pow}
_OK_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.IfExp, ast.Constant, ast.Name,
             ast.Load, ast.Call, ast.operator, ast.unaryop, ast.boolop, ast.cmpop)


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
        p = Path(path)
    except TypeError:
        raise ValueError(f"path must be a path, got {type(path).__name__}") from None
    if not p.is_file():
        raise ValueError(f"path {str(path)!r} is not a file")
    try:
        raw = p.read_bytes()
    except OSError as e:
        raise ValueError(f"cannot read the grammar {str(p)!r}: {e}") from None
    try:
        return raw.decode("utf-8"), str(p)
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        col = e.start - (raw.rfind(b"\n", 0, e.start) + 1) + 1
        raise LSystemError(f"{str(p)!r} is not UTF-8 text (byte {raw[e.start]:#04x} at offset {e.start})",
                           line, col) from None


class _Stop(Exception):
    pass


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


class _Seeded:
    """:meth:`LSystem._seeded`."""

    __slots__ = ("ls", "saved")

    def __init__(self, ls) -> None:
        self.ls, self.saved = ls, None

    def __enter__(self) -> None:
        ls = self.ls
        if ls._gstate is not None:
            self.saved = (_random.getstate(), np.random.get_state())
            _random.setstate(ls._gstate[0])
            np.random.set_state(ls._gstate[1])

    def __exit__(self, *exc) -> bool:
        if self.saved is not None:
            self.ls._gstate = (_random.getstate(), np.random.get_state())
            _random.setstate(self.saved[0])
            np.random.set_state(self.saved[1])
            self.saved = None
        return False


class _OverBudget(BaseException):
    """The time budget ran out (a BaseException, so a grammar's ``except Exception`` does not swallow it)."""


class _ContextStub(SB.SafeAttrs):
    """``context()`` / ``execContext()`` of L-Py: records turtle options, accepts editor settings."""

    def __init__(self, options: dict) -> None:
        self.turtle = _TurtleStub(options)
        self.options = _Ignore()
        self.animation_timestep = 0.0

    def __setitem__(self, key, value) -> None:
        pass

    def __getattr__(self, name):
        raise LSystemError(f"context().{name} is not supported")


class _Ignore(SB.SafeAttrs):
    def __getattr__(self, name):
        return lambda *a, **k: None


class _TurtleStub(SB.SafeAttrs):
    _MAP = {"setAngleIncrement": "angle", "setWidth": "width", "setDefaultStep": "step"}

    def __init__(self, options: dict) -> None:
        self._options = options

    def __getattr__(self, name):
        if name in self._MAP:
            def setter(value, _key=self._MAP[name]):
                self._options[_key] = float(value)
            return setter
        if name.startswith("setMaterial") or name.startswith("setColor"):
            return lambda *a, **k: None
        raise LSystemError(f"context().turtle.{name} is not supported")


class _Reversed:
    """Read-only view of a list in reverse order (the new string built backward)."""

    def __init__(self, seq: list) -> None:
        self.seq = seq

    def __len__(self) -> int:
        return len(self.seq)

    def __getitem__(self, k: int):
        return self.seq[len(self.seq) - 1 - k]


class _Compiled:
    """A rule ready to run: its function, pattern ids and optional vectorised or constant plans."""

    def __init__(self, rule: Rule, func, sid: int) -> None:
        self.rule = rule
        self.func = func
        self.sid = sid
        self.arity = rule.pred.arity
        self.contexts = bool(rule.left or rule.right)
        self.newcontexts = bool(rule.newleft or rule.newright)
        self.rest = list(rule.pred_rest)                     # multi-module predecessor: the modules after the first
        self.query = any(tok.name in _query_modules() for tok in (*rule.left, *rule.newleft, rule.pred, *self.rest,
                                                                  *rule.newright, *rule.right))
        self.vec = None          # (cond | None, [(sid, [fn, ...]), ...])
        self.const = None        # [(sid, (floats...)), ...]
        self.static = None       # a static rule's successor, [(sid, params), ...]
        # pattern constants (issue 33): every pattern parameter's index -> value, the variables' indices
        self.consts = list(rule.consts)
        n_all = len(rule.params) + len(self.consts)
        cidx = {k for k, _ in self.consts}
        self.keep = [k for k in range(n_all) if k not in cidx] if self.consts else None
        # the predecessor's own constants (position in its parameter list -> value) and variables' positions
        start = sum(t.arity for t in rule.left) + sum(t.arity for t in rule.newleft)
        self.pred_consts = [(k - start, v) for k, v in self.consts if start <= k < start + self.arity]
        self.pred_vars = [q for q in range(self.arity) if q + start not in cidx]


def _pyval(v):
    return int(v) if type(v) is float and v.is_integer() and abs(v) < 2 ** 53 else v


def _same(value, const) -> bool:
    """Whether a module's parameter matches a pattern constant (``==``, without raising)."""
    try:
        return bool(type(value) is type(const) or (is_number(value) and is_number(const))) and value == const
    except (TypeError, ValueError, ArithmeticError):             # e.g. an array's ambiguous truth value
        return False


def _module_vals(ptr, args, objs, i: int) -> list:
    """Parameters of module ``i`` as rule code sees them: integral floats as int, objects from the side-table."""
    a = int(ptr[i])
    vals = args[a:ptr[i + 1]].tolist()
    if objs:
        return [objs.get(a + q, v) if math.isnan(v) else _pyval(v) for q, v in enumerate(vals)]
    return [_pyval(v) for v in vals]


def _raw_vals(ptr, args, objs, i: int) -> tuple:
    """Parameters of module ``i`` as stored: floats, and objects from the side-table."""
    a = int(ptr[i])
    vals = args[a:ptr[i + 1]].tolist()
    if objs:
        return tuple(objs.get(a + q, v) if math.isnan(v) else v for q, v in enumerate(vals))
    return tuple(vals)


def _answer(kind: str, frame: np.ndarray, old: tuple) -> tuple:
    """The parameters of a request module of ``kind`` (:data:`~plantvr.lsystem.turtle.QUERY_MODULES`) that had
    ``old``, answered with the turtle's ``frame`` (position, H, L, U; see :meth:`LSystem._query`)."""
    from .plantgl import Vector3
    p, h, left, u = (Vector3(*v) for v in frame.tolist())
    if kind == "F":
        return (p, h, u, left) + old[4:]
    v = {"P": p, "H": h, "U": u, "L": left, "R": -left}[kind]
    if len(old) == 1 and is_number(old[0]):
        return (v[0],)
    if len(old) < 2:
        return (v,)
    return tuple(v[:len(old)]) + old[3:]


def _pack(mods: list) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """``[(sid, values), ...]`` (values floats or objects) as ids, arg_ptr, args and the object side-table."""
    ids = np.array([m[0] for m in mods], np.int32)
    ptr = np.zeros(len(mods) + 1, np.int64)
    np.cumsum([len(m[1]) for m in mods], out=ptr[1:])
    flat = [v for m in mods for v in m[1]]
    objs = {k: v for k, v in enumerate(flat) if type(v) is not float}
    if objs:
        flat = [math.nan if k in objs else v for k, v in enumerate(flat)]
    return ids, ptr, np.array(flat, np.float64), objs


class LSystem:
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
        self._ns = self._namespace()
        self._exec_python()
        self._hooks = self._read_hooks()
        self.derivation_length = self._eval_int(self._g.derivation_length, "derivation length", 1)
        self._max_depth = {k: self._eval_int(self._g.max_depth.get(k), "maximum depth", 1)
                           for k in ("decomposition", "homomorphism")}
        self._ignored = self._ignore_set()
        self._tables: dict[str, Any] = {}
        self._all_rules: list[_Compiled] = []
        for rule in self._g.rules:
            c = self._compile(rule)
            c.group = self._eval_int(rule.group, "group", 0)
            self._all_rules.append(c)
        self._start_group = self._next_group                  # a top-level useGroup(n)
        self._set_group(self._start_group)
        src, ln, col = self._g.axiom
        self.axiom = self._to_string(self._eval_lstring(self._g.axiom_tokens, ln, "the axiom"), ln)
        self._deadline = math.inf

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
        """The homomorphism (``interpretation:``) pass, up to its maximum depth."""
        return self._decompose(self._adopt(string), "homomorphism")

    def _decompose(self, s: ModuleString, kind: str) -> ModuleString:
        """Decomposition or homomorphism up to its maximum depth: whole-string passes for context-free rules;
        with contexts, L-Py's recursion (``Lsystem::__recursiveSteps``): each successor is decomposed on its own,
        its contexts matched within it."""
        depth = self._max_depth[kind]
        if not self._rules[kind] or not depth:
            return s
        if any(r.contexts for r in self._rules[kind]):
            try:
                return self._recursive(s, kind, depth)[0]
            except RecursionError:
                raise LSystemError(f"{kind} nested too deeply (maximum depth {depth})", *self._where) from None
        for _ in range(depth):
            s, changed = self._rewrite(s, kind)
            if not changed:
                break
        return s

    def _recursive(self, s: ModuleString, kind: str, depth: int) -> tuple[ModuleString, bool]:
        rules = self._rules[kind]
        by_sym: dict[int, list[_Compiled]] = {}
        for r in rules:
            by_sym.setdefault(r.sid, []).append(r)
        s = self._cut(s)
        ids, ptr, args, objs = s.ids, s.arg_ptr, s.args, s.objects
        partner = K.match_brackets(ids, 0, 1) if len(s) else None
        nargs = np.diff(ptr)
        idl = ids.tolist()
        out: list = []
        changed = False
        i, n = 0, len(idl)
        while i < n:
            res, step = None, 1
            for r in by_sym.get(idl[i], ()):
                if nargs[i] != r.arity:
                    continue
                vals = self._bind(r, i, ids, ptr, args, partner, None, objs)
                if vals is None:
                    continue
                res = self._call(r, vals)
                if res is not None:
                    step = 1 + len(r.rest)
                    break
            if res is None:
                out.append((idl[i], _raw_vals(ptr, args, objs, i)))
            else:
                changed = True
                if depth > 1 and res:
                    sub, _ = self._recursive(self._make(*_pack(res)), kind, depth - 1)
                    out.extend((int(sub.ids[k]), _raw_vals(sub.arg_ptr, sub.args, sub.objects, k))
                               for k in range(len(sub)))
                else:
                    out.extend(res)
                if len(out) > self.max_modules:
                    self._check_size(len(out), 0, self._where[0])
            i += step
        return self._make(*_pack(out)), changed

    def tree(self, n: int | None = None, *, unsupported: str = "error", **turtle_options: Any) -> TreeArrays:
        """``self.draw(self.derive(n))``: the skeleton after ``n`` derivation steps (see :meth:`draw`)."""
        return self.draw(self.derive(n), unsupported=unsupported, **turtle_options)

    def draw(self, string: ModuleString, *, unsupported: str = "error", shapes: bool = False,
             **turtle_options: Any) -> TreeArrays:
        """``turtle(self.interpret(string), **options)``: the grammar's turtle options, overridden by
        ``turtle_options``; ``shapes=True``: ``turtle_nodes(...)``, the tree with its spheres, surfaces, polygons
        and tubes (:class:`~plantvr.lsystem.turtle.TurtleNodes`).

        A module that L-Py draws but the turtle does not (:data:`~plantvr.lsystem.turtle.LPY_UNSUPPORTED`: a
        box ``@B``, a label ``@L``, ...) raises LSystemError with the line it is first used on
        (``unsupported="error"``), or is left out of the picture with one warning naming each such module
        (``"warn"``); it never changes the skeleton, which the turtle's moves and turns alone make.
        """
        from .turtle import turtle, turtle_nodes
        unsupported = check_choice("unsupported", unsupported, ("error", "warn"))
        s = self._drawable(self.interpret(string), unsupported)
        return self._turtle_call(turtle_nodes if shapes else turtle, s, {**self._turtle, **turtle_options})

    def _drawable(self, s: ModuleString, unsupported: str) -> ModuleString:
        """The interpreted string ``s`` as the turtle reads it (:meth:`_first_params`), after the check of the
        modules it does not draw (see :meth:`draw`)."""
        import warnings

        from .turtle import LPY_UNSUPPORTED
        s = self._first_params(s)
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

    @staticmethod
    def _first_params(s: ModuleString) -> ModuleString:
        """``s`` with each turtle module's extra parameters left out: L-Py's turtle reads the first ones
        (``-(a, t)`` turns by ``a``, ``F(1, 2, 3)`` is ``F(1, 2)``)."""
        from .turtle import TURTLE_MODULES
        most = np.array([max(TURTLE_MODULES[nm]) if nm in TURTLE_MODULES else np.iinfo(np.int64).max
                         for nm in s.names], np.int64)
        cnt = np.diff(s.arg_ptr)
        limit = most[s.ids] if len(s) else cnt
        if not len(s) or not np.any(cnt > limit):
            return s
        keep = np.minimum(cnt, limit)
        owner = np.repeat(np.arange(len(s)), cnt)
        offs = np.arange(len(s.args)) - np.repeat(s.arg_ptr[:-1], cnt)
        ptr = np.zeros(len(s) + 1, np.int64)
        np.cumsum(keep, out=ptr[1:])
        return ModuleString(s.names, s.ids, ptr, s.args[offs < keep[owner]])

    def __repr__(self) -> str:
        return (f"LSystem({len(self._g.rules)} rules, derivation length {self.derivation_length}, "
                f"axiom {self.axiom!r})")

    # -- namespace and Python code ---------------------------------------------------------------------------------
    def _namespace(self) -> dict:
        if self.trusted:
            from .plantgl import grammar_builtins  # openalea.plantgl.all -> plantvr.lsystem.plantgl
            ns: dict[str, Any] = {"__builtins__": grammar_builtins(), "__name__": "__lpy__"}
            ns.update({k: getattr(math, k) for k in dir(math) if not k.startswith("_")})
            randoms = _RANDOM_FUNCS
        else:
            ns = {"__builtins__": dict(SB.SAFE_BUILTINS), "__name__": "__lpy__"}
            ns.update(SB.math_names())
            randoms = _SAFE_RANDOM
        for name in randoms:
            ns[name] = getattr(self._rng, name)
        opts = self._turtle
        ctx = _ContextStub(opts)
        ns.update(
            extern=self._extern, context=lambda: ctx, execContext=lambda: ctx,
            forward=lambda: setattr(self, "_direction", 1), backward=lambda: setattr(self, "_direction", -1),
            isForward=lambda: self._direction == 1, getIterationNb=lambda: self._iteration,
            Stop=lambda: setattr(self, "_stopped", True), Vector3=lambda *v: tuple(float(x) for x in v),
            __lsys_produce__=lambda mods: mods, __lsys_nproduce__=self._nbuf_add,
            nproduce=self._nbuf_add, useGroup=self._use_group, frameDisplay=lambda *a: None,
        )
        ns.update(SB.guard_names(self._tick))
        if self.trusted:                                      # as the builtins, refusing only huge integers
            ns.update(pow=SB.safe_pow, round=SB._safe_round)
        for k, v in self._g.scalars.items():
            ns[k] = self._overrides.get(k, int(v) if float(v).is_integer() else v)
            self._externs[k] = float(ns[k])
        ns.update(self._overrides)
        return ns

    # -- budgets -------------------------------------------------------------------------------------------------
    def _tick(self) -> None:
        """The time budget check of grammar loops and rule calls."""
        if time.monotonic() > self._deadline:
            raise _OverBudget()

    def _over_budget(self, line: int = 0, col: int = 0, what: str = "") -> LSystemError:
        line, col = (line, col) if line else self._where
        return LSystemError(f"time budget of {self.time_budget:g} s exceeded{what} (step {self._iteration}); "
                            "pass time_budget= to allow more", line, col or 1)

    def _budget(self) -> _Budget:
        """Context manager: one deadline (``time_budget`` from now) for everything inside, nested ones included."""
        return _Budget(self)

    @property
    def max_modules(self) -> int:
        """Longest string a derivation may build."""
        return MAX_MODULES if self._max_modules is None else min(self._max_modules, MAX_MODULES)

    # -- code ----------------------------------------------------------------------------------------------------
    def _col(self, line: int, src: str, start: int = 1) -> int:
        """1-based column of ``src`` in grammar line ``line`` at or after ``start`` (``start`` if not found)."""
        if 1 <= line <= len(self._lines):
            k = self._lines[line - 1].find(src.strip(), max(start - 1, 0))
            if k >= 0:
                return k + 1
        return max(start, 1)

    def _parse(self, src: str, mode: str, line: int, col: int, what: str) -> ast.AST:
        """``ast.parse`` with errors as LSystemError at the grammar position (``src`` starts at ``line``/``col``)."""
        try:
            return ast.parse(src, filename=self._filename, mode=mode)
        except SyntaxError as e:
            ln = line + (e.lineno or 1) - 1
            c = (col + (e.offset or 1) - 1) if (e.lineno or 1) == 1 else (e.offset or 1)
            raise LSystemError(f"Python syntax error in {what}: {e.msg}", ln, c) from None
        except (ValueError, RecursionError, MemoryError) as e:
            raise LSystemError(f"{what} cannot be read: {type(e).__name__}: {str(e)[:80]}", line, col) from None

    def _restrict(self, tree: ast.AST, line: int, col: int) -> None:
        """The restricted evaluator's check of untrusted code (positions: ``tree`` starts at ``line``/``col``)."""
        if self.trusted:
            return
        try:
            SB.restrict(tree)
        except SB.Refused as e:
            ln = line + e.lineno - 1
            raise LSystemError(str(e), ln, (col + e.col_offset) if e.lineno == 1 else e.col_offset + 1) from None
        except RecursionError:
            raise LSystemError("expression nested too deeply", line, col) from None

    def _compile_tree(self, tree: ast.AST, mode: str, line: int, col: int, what: str, *, shift: int = 0):
        try:
            tree = SB.guard(tree, trusted=self.trusted)
            if shift:
                ast.increment_lineno(tree, shift)
            return compile(tree, self._filename, mode)
        except SyntaxError as e:
            raise LSystemError(f"Python syntax error in {what}: {e.msg}", e.lineno or line, e.offset or col) \
                from None
        except (ValueError, RecursionError, MemoryError, OverflowError) as e:
            raise LSystemError(f"{what} cannot be compiled: {type(e).__name__}: {str(e)[:80]}", line, col) \
                from None

    def _expr(self, src: str, line: int, col: int, what: str):
        """Code of the expression ``src`` (at grammar ``line``/``col``): checked when untrusted, guarded always."""
        tree = self._parse(src.strip(), "eval", line, col, what)
        self._restrict(tree, line, col)
        return self._compile_tree(tree, "eval", line, col, what, shift=line - 1)

    def _run_code(self, code, line: int, what: str):
        """``eval`` of ``code`` in the namespace, errors as LSystemError at the grammar line."""
        try:
            return eval(code, self._ns)
        except LSystemError as e:
            if e.line:
                raise
            raise LSystemError(e.detail, line, 1) from None
        except _OverBudget:
            raise self._over_budget(line, 1, f" in {what}") from None
        except SB.SandboxError as e:
            raise LSystemError(f"{what}: {e}"[:400], self._tb_line(sys.exc_info()[2]) or line, 1) from None
        except Exception as e:
            raise LSystemError(f"{what}: {type(e).__name__}: {e}"[:400], self._tb_line(sys.exc_info()[2]) or line,
                               1) from None

    def _use_group(self, n) -> None:
        """``useGroup(n)`` (L-Py): the steps after this one use the rules of group ``n``, then those of group 0."""
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or not 0 <= n <= MAX_DERIVATION:
            raise LSystemError(f"useGroup needs an integer group in [0, {MAX_DERIVATION}], got {n!r:.40}")
        self._next_group = int(n)

    def _set_group(self, g: int) -> None:
        """The active rules: group ``g``'s in file order, then group 0's (``Lsystem::__getRules`` of L-Py; a
        group without rules leaves group 0's)."""
        self._group = g
        self._rules = {k: [c for c in self._all_rules if c.rule.kind == k and c.group == g] +
                       ([c for c in self._all_rules if c.rule.kind == k and c.group == 0] if g else [])
                       for k in ("production", "decomposition", "homomorphism")}
        self._tables.clear()

    def _nbuf_add(self, mods) -> None:
        self._nbuf.extend(mods)
        if len(self._nbuf) > self.max_modules:
            n = len(self._nbuf)
            self._nbuf.clear()
            f = sys._getframe(1)
            line = f.f_lineno if f.f_code.co_filename == self._filename else self._where[0]
            raise LSystemError(f"nproduce built {n:,} modules, more than the module cap {self.max_modules:,}",
                               line, 1)
        if time.monotonic() > self._deadline:
            raise _OverBudget()

    def _extern(self, **kw) -> None:
        for k, v in kw.items():
            value = self._overrides.get(k, v)
            self._ns[k] = value
            try:
                self._externs[k] = float(value)
            except (TypeError, ValueError, OverflowError):
                raise LSystemError(f"extern {k} must be a number, got {value!r:.40}") from None

    def _exec_python(self) -> None:
        tree = self._parse(self._g.python, "exec", 1, 1, "the grammar's Python code")
        self._restrict(tree, 1, 1)
        code = self._compile_tree(tree, "exec", 1, 1, "the grammar's Python code")
        self._reseed_globals(force=True)
        try:
            with self._seeded():
                exec(code, self._ns)
        except LSystemError as e:
            raise LSystemError(e.detail, self._tb_line(sys.exc_info()[2]) or e.line or 1, 1) from None
        except _OverBudget:
            raise self._over_budget(self._tb_line(sys.exc_info()[2]), 1, " running the grammar's Python code") \
                from None
        except Exception as e:                                # the grammar's own code failed
            raise LSystemError(f"{type(e).__name__}: {e}"[:400], self._tb_line(sys.exc_info()[2]), 1) from None
        for name in _RANDOM_FUNCS if self.trusted else ():   # ``from random import *`` stays seeded
            if self._ns.get(name) is getattr(_random, name, None):
                self._ns[name] = getattr(self._rng, name)
        self._global_random = None
        self._global_random = self._uses_global_random()      # after the code ran: what it imported
        unknown = sorted(set(self._overrides) - set(self._externs))
        if unknown:
            raise ValueError(f"unknown extern {unknown[0]!r}: the grammar declares "
                             f"{sorted(self._externs) or 'none'}")

    def _tb_line(self, tb) -> int:
        line = 0
        while tb is not None:
            if tb.tb_frame.f_code.co_filename == self._filename:
                line = tb.tb_lineno
            tb = tb.tb_next
        return line

    def _read_hooks(self) -> dict:
        hooks = {}
        for name in ("Start", "End", "StartEach", "EndEach"):
            f = self._ns.get(name)
            if callable(f):
                try:
                    nparams = len(inspect.signature(f).parameters)
                except (TypeError, ValueError):
                    nparams = 0
                if nparams:
                    line = getattr(getattr(f, "__code__", None), "co_firstlineno", 0)
                    raise LSystemError(f"{name}() with arguments (the lstring) is not supported", line, 1)
                hooks[name] = f
        return hooks

    def _eval_int(self, item, what: str, default: int) -> int:
        if item is None:
            return default
        src, ln = item
        col = self._col(ln, src)
        v = self._run_code(self._expr(src, ln, col, f"'{what}'"), ln, f"'{what}'")
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 0 <= v <= MAX_DERIVATION:
            raise LSystemError(f"{what} must be an integer in [0, {MAX_DERIVATION}], got "
                               f"{SB._short(v) if isinstance(v, int) else repr(v)[:40]}", ln, col)
        return int(v)

    def _ignore_set(self) -> tuple[frozenset, bool] | None:
        g = self._g
        if not (g.ignore or g.consider):
            return None
        src, ln, col = g.ignore or g.consider
        names = frozenset(t.name for t in lex(src, g.declared, line=ln, col=col))
        return names, bool(g.ignore)

    def _is_ignored(self, sid: int) -> bool:
        """Whether module id ``sid`` is skipped in context matching (``ignore:`` / not in ``consider:``)."""
        if self._ignored is None or sid < 2:
            return False
        names, ignore = self._ignored
        return (self._names[sid] in names) == ignore

    # -- rules ---------------------------------------------------------------------------------------------------
    def _sid(self, name: str) -> int:
        k = self._index.get(name)
        if k is None:
            k = self._index[name] = len(self._names)
            self._names.append(name)
            self._tables.clear() if hasattr(self, "_tables") else None
        return k

    def _compile(self, rule: Rule) -> _Compiled:
        if time.monotonic() > self._deadline:
            raise LSystemError(f"time budget of {self.time_budget:g} s exceeded reading the rules", rule.line, 1)
        first = rule.body[0][0] if rule.body else rule.line
        base = max(first - 2, 0)                              # the source starts at grammar line base + 1
        params = () if rule.static else rule.params          # L-Py unbinds a static rule's pattern variables
        lines = [""] * (first - 2 - base) + [f"def __lsys_rule__({', '.join(params)}):"]
        for ln, src in rule.body:
            while len(lines) < ln - 1 - base:
                lines.append("")
            lines.append("    " + src)
        if not rule.body:
            lines.append("    pass")
        src = "\n".join(lines) + "\n"
        what = f"rule {rule.header!r}"
        tree = self._parse(src, "exec", base + 1, 1, what)
        if not self.trusted:
            self._restrict_rule(rule, tree)
        code = self._compile_tree(tree, "exec", rule.line, 1, what, shift=base)
        local: dict = {}
        exec(code, self._ns, local)
        c = _Compiled(rule, local["__lsys_rule__"], self._sid(rule.pred.name))
        if rule.static:                                       # made once, now (``LsysRule::initStaticProduction``)
            c.static = self._call(c, [])
            if all(type(v) is float for _, vals in c.static for v in vals) and \
                    not (c.contexts or c.newcontexts or c.rest or c.consts):
                c.const = c.static
            return c
        if rule.successor is not None and not (c.contexts or c.newcontexts or c.rest) and \
                all(is_number(v) for _, v in c.pred_consts):
            self._plan(c)
            c.const = None if c.consts else c.const           # the constant tables match names, not values
        return c

    def _restrict_rule(self, rule: Rule, tree: ast.Module) -> None:
        """An untrusted rule: one line (successor, condition), its expressions within the restricted evaluator."""
        if rule.successor is None:
            raise LSystemError(f"rule {rule.header!r} has a Python body: " + SB.TRUST_HINT, rule.line,
                               self._col(rule.line, rule.header))
        if rule.condition is not None:
            col = self._col(rule.line, rule.condition, len(rule.header) + 1)
            self._restrict(self._parse(rule.condition, "eval", rule.line, col, f"rule {rule.header!r}"),
                           rule.line, col)
        self._restrict_tokens(rule.successor, f"rule {rule.header!r}")
        # the generated function itself: ``[if cond:] return __lsys_produce__([...])`` and nothing else
        fn = tree.body[0]
        body = list(fn.body)
        while body:
            st = body.pop(0)
            if isinstance(st, ast.If) and not st.orelse:
                self._restrict(ast.Expression(st.test), rule.line, 1)
                body[:0] = st.body
            elif isinstance(st, ast.Return) and st.value is not None:
                self._restrict(ast.Expression(st.value), rule.line, 1)
            else:
                raise LSystemError(f"rule {rule.header!r} has a Python body: " + SB.TRUST_HINT, rule.line, 1)

    def _restrict_tokens(self, toks: list[Token], what: str) -> None:
        seen = set()
        for t in toks if not self.trusted else ():
            if not t.args or t.args in seen:
                continue
            seen.add(t.args)
            start = t.col + len(t.name)
            for a in t.args:
                col = self._col(t.line, a, start)
                start = col + len(a)
                self._restrict(self._parse(a, "eval", t.line, col, what), t.line, col)

    def _plan(self, c: _Compiled) -> None:
        """Vectorised and constant plans of a one-line context-free rule (None where it cannot)."""
        params = c.rule.params
        cond = None
        if c.rule.condition is not None:
            cond = self._vectorize(c.rule.condition, params)
            if cond is None:
                return
        slots = []
        const = c.rule.condition is None
        cvals = []
        for t in c.rule.successor:
            if t.name == "*" and len(c.rule.successor) == 1 and t.args is None:
                break
            fns = []
            vals = []
            for a in t.args or ():
                f = self._vectorize(a, params)
                if f is None:
                    return
                fns.append(f)
                if const and self._vectorize(a, []) is not None:
                    try:
                        code = self._expr(a, t.line, t.col, f"rule {c.rule.header!r}")
                        vals.extend(self._params(t.name, (eval(code, self._ns),), c.rule.line))
                    except LSystemError:
                        raise
                    except SB.SandboxError as e:
                        raise LSystemError(f"rule {c.rule.header!r}: {e}", t.line, t.col) from None
                    except Exception:
                        const = False
                else:
                    const = False
            slots.append((self._sid(t.name), fns))
            cvals.append((self._sid(t.name), tuple(vals)))
        c.vec = (cond, slots)
        if const and all(len(v) == len(f) for (_, v), (_, f) in zip(cvals, slots)):
            c.const = cvals

    def _vectorize(self, src: str, params: list[str]):
        """A numpy function of the parameter columns computing expression ``src``, or None if it cannot."""
        try:
            tree = ast.parse(src, mode="eval")
        except SyntaxError:
            return None
        env: dict[str, Any] = {"__np": np, "__builtins__": {}}
        funcs = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)}
        for node in ast.walk(tree):
            if not isinstance(node, _OK_NODES):
                return None
            if isinstance(node, ast.Constant) and not is_number(node.value):
                return None
            if isinstance(node, ast.Call):
                if not isinstance(node.func, ast.Name) or node.keywords or node.func.id in params:
                    return None
                f = node.func.id
                if f not in _NP_FUNCS or self._ns.get(f, getattr(builtins, f, None)) is not _PURE.get(f):
                    return None
                env["__np_" + f] = _NP_FUNCS[f]
            elif isinstance(node, ast.Name) and node.id not in params:
                if id(node) in funcs:
                    continue
                v = self._ns.get(node.id)
                if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                    return None
                env[node.id] = float(v)
        tree = _ToNumpy().visit(tree)
        ast.fix_missing_locations(tree)
        lam = ast.Expression(ast.Lambda(ast.arguments(posonlyargs=[], args=[ast.arg(p) for p in params],
                                                      kwonlyargs=[], kw_defaults=[], defaults=[]), tree.body))
        ast.fix_missing_locations(lam)
        return eval(compile(lam, "<vectorised>", "eval"), env)

    # -- strings -------------------------------------------------------------------------------------------------
    def _params(self, name: str, v, line: int) -> tuple:
        """The parameters of a produced module ``name(*v)``: numbers as floats, any other Python value (str,
        tuple, list, None, bool...) kept as it is, as L-Py's modules hold them (issue 33); a turtle module's
        numeric vectors (``SetHead(Vector3(...))``) and booleans are read as numbers, as its turtle does."""
        if not isinstance(v, (tuple, list)):
            v = (v,)
        out: list = []
        turtle = name in _turtle_modules()
        for x in v:
            if is_number(x) or (turtle and isinstance(x, (bool, np.bool_))):
                try:
                    out.append(float(x))
                except OverflowError:
                    raise LSystemError(f"module {name}: parameter {SB._short(x)} is too large for a float", line,
                                       1) from None
            elif turtle and isinstance(x, (tuple, list, np.ndarray)):
                out.extend(self._params(name, np.asarray(x, dtype=object).ravel().tolist(), line))
            else:
                out.append(x)
        return tuple(out)

    def _eval_lstring(self, toks: list[Token], line: int, what: str) -> list:
        self._restrict_tokens(toks, what)
        codes: dict[str, Any] = {}
        for t in toks:
            if t.args and t.args not in codes:
                codes[t.args] = self._expr(lstring_to_py([Token("", t.args, t.line, t.col)]) + "[0][1]", t.line,
                                           t.col, what)
        try:
            if len(toks) == 1 and toks[0].name == "*" and toks[0].args is None:
                return []
            return [(t.name, eval(codes[t.args], self._ns) if t.args else ()) for t in toks]
        except _OverBudget:
            raise self._over_budget(line, 1, f" in {what}") from None
        except SB.SandboxError as e:
            raise LSystemError(f"{what}: {e}"[:400], line, toks[0].col if toks else 1) from None
        except Exception as e:
            raise LSystemError(f"{what}: {type(e).__name__}: {e}"[:400], line, toks[0].col if toks else 1) \
                from None

    def _to_string(self, mods: list, line: int) -> ModuleString:
        packed = [(self._sid(name), self._params(name, vals, line) if vals != () else ()) for name, vals in mods]
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
        self._direction, self._iteration, self._stopped = 1, 0, False
        self._reset_group()
        if self._outer == 0:
            self._deadline = time.monotonic() + self.time_budget
        self._where = (self._g.rules[0].line if self._g.rules else 1, 1)
        with self._seeded():
            self._hook("Start")
        yield s
        for it in range(n):
            self._iteration = it
            if self._outer == 0:
                self._deadline = time.monotonic() + self.time_budget
            elif time.monotonic() > self._deadline:
                raise self._over_budget()
            with self._seeded():
                self._hook("StartEach")
                if self._next_group != self._group:           # L-Py reads the group after StartEach
                    self._set_group(self._next_group)
                if self._rules["production"]:
                    if any(c.query for c in self._rules["production"]):
                        s = self._query(s)
                    s, _ = self._rewrite(s, "production")
                s = self._decompose(s, "decomposition")
                self._hook("EndEach")
            yield s
            if self._stopped:
                break
        with self._seeded():
            self._hook("End")

    # -- seeding of the global generators a trusted grammar may use ------------------------------------------------
    def _uses_global_random(self) -> bool:
        """Whether the grammar's namespace reaches the global ``random`` / ``numpy.random`` generators (the
        modules, or functions bound to their shared instances), so that swapping their states is needed."""
        if not self.trusted or self._seed is None:
            return False
        if getattr(self, "_global_random", None) is not None:
            return self._global_random
        shared = (_random._inst, np.random.mtrand._rand)
        for v in list(self._ns.values()):
            if v is _random or v is np or v is np.random or getattr(v, "__self__", None) in shared:
                return True
            if getattr(v, "__name__", None) in ("numpy", "numpy.random", "random") and inspect.ismodule(v):
                return True
        return False

    def _reseed_globals(self, force: bool = False) -> None:
        """The states ``random`` and ``numpy.random`` start a derivation from (trusted grammars with a seed that
        reach them; ``force``: whenever trusted and seeded, for the grammar's own code before its imports ran)."""
        if self._uses_global_random() or (force and self.trusted and self._seed is not None):
            self._gstate = (_random.Random(self._seed).getstate(),
                            np.random.RandomState(self._seed % 2 ** 32).get_state())
        else:
            self._gstate = None

    def _seeded(self) -> _Seeded:
        """Context manager: the grammar's states of the global ``random`` and ``numpy.random`` generators swapped
        in (``import random``, ``random.random()``, ``rd.randint`` of ``import random as rd``, ``numpy.random``),
        and the caller's swapped back afterwards, so one ``seed=`` makes a derivation reproducible and leaves the
        program's generators as they were."""
        return _Seeded(self)

    def _hook(self, name: str) -> None:
        f = self._hooks.get(name)
        if f is not None:
            self._nbuf.clear()
            try:
                f()
            except LSystemError as e:
                if e.line:
                    raise
                raise LSystemError(e.detail, self._tb_line(sys.exc_info()[2]) or 1, 1) from None
            except _OverBudget:
                raise self._over_budget(self._tb_line(sys.exc_info()[2]), 1, f" in {name}()") from None
            except Exception as e:
                raise LSystemError(f"{name}() raised {type(e).__name__}: {e}", self._tb_line(sys.exc_info()[2]),
                                   1) from None

    def _rewrite(self, s: ModuleString, kind: str) -> tuple[ModuleString, bool]:
        rules = self._rules[kind]
        if not rules or not len(s):
            return s, False
        s = self._cut(s)
        if any(r.newcontexts or r.rest for r in rules):
            return self._sequential(s, rules)
        table = None if s.objects else self._constant_table(kind)
        if table is not None:
            rule_arity, sptr, sids, saptr, sargs = table
            if rule_arity.shape[0] < len(self._names):
                self._tables.clear()
                return self._rewrite(s, kind)
            with_ptr = bool(s.args.shape[0] or sargs.shape[0])
            n_out, m_out, hits = K.count_constant(s.ids, s.arg_ptr, rule_arity, sptr, saptr, with_ptr)
            self._check_size(n_out, m_out)
            out_ids = np.empty(n_out, np.int32)
            out_ptr = np.empty(n_out + 1, np.int64) if with_ptr else np.zeros(n_out + 1, np.int64)
            out_args = np.empty(m_out, np.float64)
            K.fill_constant(s.ids, s.arg_ptr, s.args, rule_arity, sptr, sids, saptr, sargs, out_ids, out_ptr,
                            out_args, with_ptr)
            return self._make_trusted(out_ids, out_ptr, out_args), hits > 0
        return self._grouped(s, rules)

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
        self._direction, self._iteration, self._stopped = 1, n - 1, False
        return self._make_trusted(out_ids, out_ptr, out_args)

    def _cut(self, s: ModuleString) -> ModuleString:
        """``s`` without what each ``%`` (``Cut``) cuts: itself and the rest of its branch, up to the ``]`` that
        closes the branch (kept) or the end of the string, as L-Py's steps skip it (``AxialTree::endBracket``)."""
        cut = [self._index[nm] for nm in ("%", "Cut") if nm in self._index]
        at = np.flatnonzero(np.isin(s.ids, cut)) if cut else ()
        if not len(at):
            return s
        depth = np.cumsum((s.ids == 0).astype(np.int64) - (s.ids == 1))      # ids 0, 1: '[', ']'
        keep = np.ones(len(s), bool)
        end = 0
        for i in at.tolist():
            if i >= end:
                below = np.flatnonzero(depth[i:] < depth[i])
                end = i + int(below[0]) if below.size else len(s)
                keep[i:end] = False
        cnt = np.diff(s.arg_ptr)
        akeep = np.repeat(keep, cnt)
        ptr = np.zeros(int(keep.sum()) + 1, np.int64)
        np.cumsum(cnt[keep], out=ptr[1:])
        new = np.cumsum(akeep) - 1
        return self._make(s.ids[keep], ptr, s.args[akeep], {int(new[k]): v for k, v in s.objects.items() if akeep[k]})

    def _query(self, s: ModuleString) -> ModuleString:
        """L-Py's query pass (``Lsystem::__step`` when a production's pattern has a request module): ``s``
        interpreted (homomorphism, then the turtle) and each request module's parameters set to the turtle's frame
        there, as ``ParamModule::_setValues`` does: none become one Vector3, one a Vector3 (or the x coordinate if
        it is a number), two x and y, three or more x, y and z; ``?F`` gets position, heading, up and left Vector3s.
        A request module a ``%`` cuts off keeps its parameters. As L-Py's query turtle (``LsysContext::envturtle``,
        a default PlantGL ``Turtle``), it ignores the grammar's turtle options (``setAngleIncrement``...)."""
        from .turtle import QUERY_MODULES, query_frames
        qsid = [k for k, nm in enumerate(self._names) if nm in QUERY_MODULES]
        at = np.flatnonzero(np.isin(s.ids, qsid))
        if not at.size:
            return s
        hom = self._rules["homomorphism"]
        for c in hom:
            if c.query:
                raise LSystemError("request modules (?P, ...) in an interpretation rule's pattern are not "
                                   "supported when productions query them (L-Py leaves them unanswered)",
                                   c.rule.line, c.rule.col)
        if not _WARM_TURTLE:                                  # numba compiling is not the grammar's time
            _WARM_TURTLE.append(True)
            start = time.monotonic()
            query_frames(ModuleString.from_modules(["F", "?P"]))
            self._deadline += time.monotonic() - start
        t = self._drawable(self.interpret(s), "error")
        tq = np.flatnonzero(np.isin(t.ids, qsid))
        if len(tq) != len(at):
            c = next((c for c in hom if any(nm in src for _, src in c.rule.body for nm in QUERY_MODULES)), hom[0])
            raise LSystemError("interpretation rules that produce request modules (?P, ...) are not supported",
                               c.rule.line, c.rule.col)
        idx, frames = self._turtle_call(query_frames, t, {})  # L-Py's envturtle: PlantGL's defaults
        answers = {int(at[k]): _answer(QUERY_MODULES[t.names[t.ids[j]]], fr,
                                       _raw_vals(s.arg_ptr, s.args, s.objects, at[k]))
                   for k, j, fr in zip(np.searchsorted(tq, idx).tolist(), idx.tolist(), frames)}
        return self._make(*_pack([(int(sid), answers[i] if i in answers else
                                   _raw_vals(s.arg_ptr, s.args, s.objects, i)) for i, sid in enumerate(s.ids)]))

    def _reset_group(self) -> None:
        """A derivation starts in the group the grammar's top-level code chose (0 without ``useGroup``)."""
        self._next_group = self._start_group
        if self._group != self._start_group:
            self._set_group(self._start_group)

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

    def _call(self, c: _Compiled, vals: list) -> list | None:
        if c.static is not None:
            return c.static
        self._nbuf.clear()
        if time.monotonic() > self._deadline:
            raise self._over_budget(c.rule.line, 1, f" in rule {c.rule.header!r}")
        self._where = (c.rule.line, 1)
        try:
            res = c.func(*vals)
        except LSystemError as e:
            if e.line:
                raise
            raise LSystemError(e.detail, self._tb_line(sys.exc_info()[2]) or c.rule.line, 1) from None
        except _OverBudget:
            line = self._tb_line(sys.exc_info()[2]) or c.rule.line
            raise self._over_budget(line, 1, f" in rule {c.rule.header!r}") from None
        except SB.SandboxError as e:
            line = self._tb_line(sys.exc_info()[2]) or c.rule.line
            raise LSystemError(f"rule {c.rule.header!r}: {e}", line, 1) from None
        except Exception as e:
            line = self._tb_line(sys.exc_info()[2]) or c.rule.line
            raise LSystemError(f"rule {c.rule.header!r} raised {type(e).__name__}: {e}"[:400], line, 1) from None
        if res is None:
            if not self._nbuf:
                return None
            res = list(self._nbuf)
        elif self._nbuf:
            res = list(self._nbuf) + list(res)
        line = c.rule.line
        return [(self._sid(name), self._params(name, v, line) if v != () else ()) for name, v in res]

    def _grouped(self, s: ModuleString, rules: list[_Compiled]) -> tuple[ModuleString, bool]:
        ids, ptr, args, objs = s.ids, s.arg_ptr, s.args, s.objects
        n = len(ids)
        nargs = np.diff(ptr)
        has_obj = None
        if objs:                                              # modules holding objects: the per-module path
            has_obj = np.zeros(n, bool)
            has_obj[np.searchsorted(ptr, np.fromiter(objs, np.int64, len(objs)), "right") - 1] = True
        out_len = np.ones(n, np.int64)
        assigned = np.zeros(n, bool)
        vec_chunks: list = []
        py_chunks: dict[int, list] = {}
        partner = None
        grown, room = 0, self.max_modules - n                # modules added so far, and how many may be
        by_sym: dict[int, list[_Compiled]] = {}
        for r in rules:
            by_sym.setdefault(r.sid, []).append(r)
        for sid, rlist in by_sym.items():
            pos_all = np.flatnonzero(ids == sid)
            for r in rlist:
                pos = pos_all[(nargs[pos_all] == r.arity) & ~assigned[pos_all]]
                if pos.size and r.pred_consts and r.vec is not None:
                    ok = np.ones(pos.size, bool)              # pattern constants, on the columns
                    for q, v in r.pred_consts:
                        ok &= args[ptr[pos] + q] == float(v)
                    pos = pos[ok | (has_obj[pos] if has_obj is not None else False)]
                if not pos.size:
                    continue
                if r.vec is not None and (has_obj is None or not has_obj[pos].any()):
                    added = self._grouped_vec(r, pos, ptr, args, vec_chunks, assigned, out_len, n + grown)
                    if added is not None:
                        grown += added
                        if time.monotonic() > self._deadline:
                            raise self._over_budget(r.rule.line, 1, f" in rule {r.rule.header!r}")
                        continue
                if r.contexts and partner is None:
                    partner = K.match_brackets(ids, 0, 1)
                for i in pos.tolist():
                    vals = self._bind(r, i, ids, ptr, args, partner, None, objs)
                    if vals is None:
                        continue
                    res = self._call(r, vals)
                    if res is not None:
                        py_chunks[i] = res
                        assigned[i] = True
                        out_len[i] = len(res)
                        grown += len(res) - 1
                        if grown > room:
                            self._check_size(n + grown, 0, r.rule.line)
        if not assigned.any():
            return s, False
        if time.monotonic() > self._deadline:
            raise self._over_budget()
        starts = np.zeros(n + 1, np.int64)
        np.cumsum(out_len, out=starts[1:])
        total = int(starts[-1])
        self._check_size(total, 0)
        out_ids = np.empty(total, np.int32)
        out_na = np.empty(total, np.int64)
        keep = np.flatnonzero(~assigned)
        out_ids[starts[keep]] = ids[keep]
        out_na[starts[keep]] = nargs[keep]
        for hit, slots, values in vec_chunks:                # one fancy assignment per chunk, all slots at once
            at = starts[hit][:, None] + np.arange(len(slots))
            out_ids[at] = np.array([tsid for tsid, _ in slots], np.int32)
            out_na[at] = np.array([len(fns) for _, fns in slots], np.int64)
        for i, res in py_chunks.items():
            b = starts[i]
            for j, (tsid, vals) in enumerate(res):
                out_ids[b + j] = tsid
                out_na[b + j] = len(vals)
        out_ptr = np.zeros(total + 1, np.int64)
        np.cumsum(out_na, out=out_ptr[1:])
        self._check_size(total, int(out_ptr[-1]))
        out_args = np.empty(int(out_ptr[-1]), np.float64)
        # copied modules: their parameter ranges, moved
        cnt = nargs[keep]
        if cnt.sum():
            L = int(cnt.sum())
            offs = np.arange(L) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            out_args[np.repeat(out_ptr[starts[keep]], cnt) + offs] = args[np.repeat(ptr[keep], cnt) + offs]
        for hit, slots, values in vec_chunks:
            cols = [(j, q, col) for j, vals in enumerate(values) for q, col in enumerate(vals)]
            if cols:
                first = out_ptr[starts[hit]]                  # where each hit's successor's parameters start
                rel = np.array([int(out_ptr[starts[hit[0]] + j] - first[0]) + q for j, q, _ in cols], np.int64)
                out_args[first[:, None] + rel] = np.stack([col for _, _, col in cols], axis=1)
        out_objs: dict = {}
        for k, v in objs.items():                             # copied modules' objects, moved
            i = int(np.searchsorted(ptr, k, "right")) - 1
            if not assigned[i]:
                out_objs[int(out_ptr[starts[i]]) + k - int(ptr[i])] = v
        for i, res in py_chunks.items():
            b = starts[i]
            for j, (tsid, vals) in enumerate(res):
                a = out_ptr[b + j]
                if all(type(v) is float for v in vals):
                    out_args[a:a + len(vals)] = vals
                    continue
                for q, v in enumerate(vals):
                    if type(v) is float:
                        out_args[a + q] = v
                    else:
                        out_args[a + q] = math.nan
                        out_objs[int(a) + q] = v
        return self._make(out_ids, out_ptr, out_args, out_objs), True

    def _grouped_vec(self, r: _Compiled, pos, ptr, args, vec_chunks, assigned, out_len, size: int) -> int | None:
        """Rule ``r`` applied on parameter columns at modules ``pos``: the modules it adds (None: it cannot,
        the per-module path runs it); ``size`` is the new string's length so far, checked against the cap before
        the successors are computed."""
        cond, slots = r.vec
        cols = [args[ptr[pos] + q] for q in r.pred_vars]
        try:
            with np.errstate(all="ignore"):
                if cond is not None:
                    mask = np.broadcast_to(np.asarray(cond(*cols), bool), pos.shape)
                    hit = pos[mask]
                    cols = [c[mask] for c in cols]
                else:
                    hit = pos
                if not hit.size:
                    return 0
                added = hit.size * (len(slots) - 1)
                self._check_size(size + added, 0, r.rule.line)
                raw = [[np.asarray(f(*cols)) for f in fns] for _, fns in slots]
                if any(v.dtype == bool for vals in raw for v in vals):
                    return None                               # a bool parameter stays a bool: Python path
                values = [[np.broadcast_to(v.astype(np.float64, copy=False), hit.shape) for v in vals]
                          for vals in raw]
        except (ArithmeticError, ValueError, TypeError) as e:
            if isinstance(e, LSystemError):
                raise
            return None                                       # let Python raise the rule's own error
        if not all(np.isfinite(v).all() for vals in values for v in vals):
            return None                                       # let Python raise the rule's own error
        vec_chunks.append((hit, slots, values))
        assigned[hit] = True
        out_len[hit] = len(slots)
        return added

    # -- context matching ----------------------------------------------------------------------------------------
    def _bind(self, r: _Compiled, i: int, ids, ptr, args, partner, dest, objs=_EMPTY) -> list | None:
        """Actual parameters of rule ``r`` at module ``i`` (None if a context does not match)."""
        rule = r.rule
        vals: list = []
        if rule.left:
            lv = self._left(rule.left, i - 1, _ArrSeq(ids, ptr, args, objs), partner)
            if lv is None:
                return None
            vals += lv
        if rule.newleft:
            if self._direction != 1:
                return None
            lv = self._left(rule.newleft, len(dest) - 1, _ListSeq(dest), None)
            if lv is None:
                return None
            vals += lv
        vals += _module_vals(ptr, args, objs, i)
        for j, t in enumerate(r.rest, 1):                     # multi-module predecessor: consecutive modules
            p = i + j
            if p >= len(ids) or ids[p] != self._pattern_sid(t) or ptr[p + 1] - ptr[p] != t.arity:
                return None
            vals += _module_vals(ptr, args, objs, p)
        if rule.newright:
            if self._direction != -1:
                return None
            rv = self._right(rule.newright, 0, _ListSeq(_Reversed(dest)), None)
            if rv is None:
                return None
            vals += rv
        if rule.right:
            rv = self._right(rule.right, i + 1 + len(r.rest), _ArrSeq(ids, ptr, args, objs), partner)
            if rv is None:
                return None
            vals += rv
        if r.keep is not None:                                # pattern constants: equal values only
            for k, v in r.consts:
                if not _same(vals[k], v):
                    return None
            vals = [vals[k] for k in r.keep]
        return vals

    def _pattern_sid(self, t: Token) -> int:
        return self._sid(t.name)

    def _left(self, pattern: list[Token], pos: int, seq, partner) -> list | None:
        vals: list = []
        for t in reversed(pattern):
            while pos >= 0:
                s = seq.sid(pos)
                if s == 1:                                     # ']': skip the lateral branch
                    if partner is not None:
                        pos = int(partner[pos])
                        if pos < 0:
                            return None
                    else:
                        depth = 1
                        while depth and pos > 0:
                            pos -= 1
                            depth += (seq.sid(pos) == 1) - (seq.sid(pos) == 0)
                        if depth:
                            return None
                    pos -= 1
                elif s == 0 or self._is_ignored(s):
                    pos -= 1
                else:
                    break
            if pos < 0 or seq.sid(pos) != self._pattern_sid(t) or seq.nargs(pos) != t.arity:
                return None
            vals[:0] = seq.args(pos)
            pos -= 1
        return vals

    def _right(self, pattern: list[Token], pos: int, seq, partner) -> list | None:
        vals: list = []
        n = len(seq)
        for t in pattern:
            if t.name == "]":                                  # the rest of this branch is skipped
                while pos < n and seq.sid(pos) != 1:
                    pos = self._skip_branch(seq, pos, partner) if seq.sid(pos) == 0 else pos + 1
                    if pos < 0:
                        return None
                if pos >= n:
                    return None
                pos += 1
                continue
            while pos < n:
                s = seq.sid(pos)
                if s == 0 and t.name != "[":
                    pos = self._skip_branch(seq, pos, partner)
                    if pos < 0:
                        return None
                elif s != 0 and s != 1 and self._is_ignored(s):
                    pos += 1
                else:
                    break
            if pos >= n or seq.sid(pos) != self._pattern_sid(t) or seq.nargs(pos) != t.arity:
                return None
            vals += seq.args(pos)
            pos += 1
        return vals

    @staticmethod
    def _skip_branch(seq, pos: int, partner) -> int:
        """Index after the branch opened at ``pos`` (-1 if it never closes)."""
        if partner is not None:
            p = int(partner[pos])
            return p + 1 if p >= 0 else -1
        depth, n = 0, len(seq)
        while pos < n:
            s = seq.sid(pos)
            depth += (s == 0) - (s == 1)
            pos += 1
            if depth == 0:
                return pos
        return -1

    def _sequential(self, s: ModuleString, rules: list[_Compiled]) -> tuple[ModuleString, bool]:
        """One step in string order (forward) or reverse order (backward): new contexts see the new string."""
        ids, ptr, args, objs = s.ids, s.arg_ptr, s.args, s.objects
        n = len(ids)
        fwd = self._direction == 1
        by_sym: dict[int, list[_Compiled]] = {}
        for r in rules:                                       # backward: a predecessor is found by its last module
            by_sym.setdefault(r.sid if fwd or not r.rest else self._pattern_sid(r.rest[-1]), []).append(r)
        partner = K.match_brackets(ids, 0, 1) if any(r.contexts for r in rules) else None
        dest: list = []
        changed = False
        order = range(n) if fwd else range(n - 1, -1, -1)
        nargs = np.diff(ptr)
        idl = ids.tolist()
        skip = -1 if fwd else n          # modules up to (forward) or from (backward) skip were matched already
        for i in order:
            if (i <= skip) if fwd else (i >= skip):
                continue
            res = None
            for r in by_sym.get(idl[i], ()):
                at = i if fwd else i - len(r.rest)           # where the predecessor starts
                if at < 0 or idl[at] != r.sid or nargs[at] != r.arity:
                    continue
                vals = self._bind(r, at, ids, ptr, args, partner, dest, objs)
                if vals is None:
                    continue
                res = self._call(r, vals)
                if res is not None:
                    if r.rest:
                        skip = i + len(r.rest) if fwd else at
                    break
            if res is None:
                res = [(idl[i], _raw_vals(ptr, args, objs, i))]
            else:
                changed = True
            dest.extend(res if self._direction == 1 else reversed(res))
            if len(dest) > self.max_modules:
                self._check_size(len(dest), 0, self._where[0])
        if self._direction != 1:
            dest.reverse()
        return self._make(*_pack(dest)), changed


_WARM: list = []
_WARM_TURTLE: list = []


def _turtle_modules() -> frozenset:
    """The turtle's module names whose parameters are read as numbers (not the request modules, which hold
    the Vector3s of L-Py's query pass)."""
    if not _TURTLE:
        from .turtle import QUERY_MODULES, TURTLE_MODULES
        _TURTLE.append(frozenset(TURTLE_MODULES) - frozenset(QUERY_MODULES))
    return _TURTLE[0]


def _query_modules() -> frozenset:
    """The request modules' names (:data:`~plantvr.lsystem.turtle.QUERY_MODULES`)."""
    from .turtle import QUERY_MODULES
    return frozenset(QUERY_MODULES)


_TURTLE: list = []


def _warm_kernels() -> None:
    """Compile (or load from numba's cache) the derivation kernels once per process, outside any time budget."""
    if _WARM:
        return
    _WARM.append(True)
    ls = LSystem("Axiom: F(1)X\nproduction:\nX --> F(1)[+X]X\nendlsystem\n", time_budget=1e6)
    ls.derive(2)                                              # all at once
    list(ls.iterate(2))                                       # step-wise
    K.match_brackets(ls.axiom.ids, 0, 1)


class _ArrSeq:
    """Module access on the arrays of the current string."""

    def __init__(self, ids, ptr, args, objs=_EMPTY) -> None:
        self.ids, self.ptr, self.a, self.objs = ids, ptr, args, objs

    def __len__(self) -> int:
        return len(self.ids)

    def sid(self, k: int) -> int:
        return int(self.ids[k])

    def nargs(self, k: int) -> int:
        return int(self.ptr[k + 1] - self.ptr[k])

    def args(self, k: int) -> list:
        return _module_vals(self.ptr, self.a, self.objs, k)


class _ListSeq:
    """Module access on the new string being built (a list of ``(sid, params)``)."""

    def __init__(self, seq) -> None:
        self.seq = seq

    def __len__(self) -> int:
        return len(self.seq)

    def sid(self, k: int) -> int:
        return self.seq[k][0]

    def nargs(self, k: int) -> int:
        return len(self.seq[k][1])

    def args(self, k: int) -> list:
        return [_pyval(v) for v in self.seq[k][1]]


class _ToNumpy(ast.NodeTransformer):
    """``and/or/not``, comparison chains, ``a if c else b`` and math calls -> numpy, for parameter columns."""

    def visit_Constant(self, node):
        if type(node.value) is int:                           # float arithmetic, as the columns: no big integers
            return ast.copy_location(ast.Constant(float(node.value)), node)
        return node

    @staticmethod
    def _np(attr: str, args: list) -> ast.Call:
        return ast.Call(ast.Attribute(ast.Name("__np", ast.Load()), attr, ast.Load()), args, [])

    def visit_BoolOp(self, node):
        self.generic_visit(node)
        f = "logical_and" if isinstance(node.op, ast.And) else "logical_or"
        out = node.values[0]
        for v in node.values[1:]:
            out = self._np(f, [out, v])
        return out

    def visit_UnaryOp(self, node):
        self.generic_visit(node)
        if isinstance(node.op, ast.Not):
            return self._np("logical_not", [node.operand])
        return node

    def visit_Compare(self, node):
        self.generic_visit(node)
        parts, left = [], node.left
        for op, right in zip(node.ops, node.comparators):
            parts.append(ast.Compare(left, [op], [right]))
            left = right
        out = parts[0]
        for p in parts[1:]:
            out = self._np("logical_and", [out, p])
        return out

    def visit_IfExp(self, node):
        self.generic_visit(node)
        return self._np("where", [node.test, node.body, node.orelse])

    def visit_Call(self, node):
        self.generic_visit(node)
        node.func = ast.Name("__np_" + node.func.id, ast.Load())
        return node

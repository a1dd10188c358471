"""The grammar's Python side: its namespace, the code it runs, and the seeding and budget of that code.

:class:`_Namespace` (a base of :class:`~plantvr.lsystem.engine.LSystem`) builds the namespace a grammar's
code runs in (``math`` names, seeded ``random`` functions, ``extern``, ``context()``, ``forward()`` /
``backward()``, ``nproduce``, ``useGroup``, ``Stop()``; the restricted builtins of
:mod:`plantvr.lsystem.sandbox` when untrusted), parses, checks and compiles its code and expressions with errors
at their grammar line, runs the top-level code and the ``Start``/``End``/``StartEach``/``EndEach`` hooks, and
swaps the global ``random`` / ``numpy.random`` states in and out around them. It mirrors L-Py's ``LsysContext``
(``src/cpp/lsyscontext.cpp``).
"""
from __future__ import annotations

import ast
import inspect
import math
import random as _random
import sys
import time
from typing import Any

import numpy as np

from . import sandbox as SB
from .grammar import lstring_to_py
from .lexer import LSystemError, Token, lex
from .context import ParameterSet, _ContextStub, _ModuleClasses
from .modules import Kwds, LstringView, ModuleString
from .plantgl import not_here_hint

#: Most derivation steps one call may ask for (a grammar's ``derivation length`` included).
MAX_DERIVATION = 100_000

_RANDOM_FUNCS = ("random", "uniform", "gauss", "normalvariate", "randint", "choice", "expovariate",
                 "betavariate", "triangular", "lognormvariate", "shuffle", "sample", "randrange", "seed",
                 "vonmisesvariate", "gammavariate", "paretovariate", "weibullvariate", "getrandbits")
#: Those an untrusted grammar gets (the others can build large objects or reseed).
_SAFE_RANDOM = ("random", "uniform", "gauss", "normalvariate", "randint", "choice", "expovariate", "betavariate",
                "triangular", "lognormvariate", "randrange", "vonmisesvariate", "gammavariate", "paretovariate",
                "weibullvariate")


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


class _Namespace:
    """The grammar's namespace and the running of its code (a base of :class:`~plantvr.lsystem.engine.LSystem`)."""

    @property
    def materials(self) -> tuple[tuple[str, tuple[int, int, int], float], ...]:
        """L-Py's material table as the grammar leaves it: :data:`~plantvr.lsystem.shapes.DEFAULT_MATERIALS`
        with the entries ``context().turtle.setMaterial(i, Material(...))`` set (the editor's colour panel);
        indices in between keep PlantGL's first default."""
        from .shapes import DEFAULT_MATERIALS
        table = list(DEFAULT_MATERIALS)
        for i, entry in sorted(self._context.turtle.materials.items()):
            table.extend([DEFAULT_MATERIALS[0]] * (i + 1 - len(table)))
            table[i] = entry
        return tuple(table)

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
        ctx = self._context = _ContextStub(opts, ns if self.trusted else None, self._set_option)
        ns.update(
            extern=self._extern, context=lambda: ctx, execContext=lambda: ctx,
            forward=lambda: setattr(self, "_direction", 1), backward=lambda: setattr(self, "_direction", -1),
            isForward=lambda: self._direction == 1, getIterationNb=lambda: self._iteration,
            Stop=lambda: setattr(self, "_stopped", True), Vector3=lambda *v: tuple(float(x) for x in v),
            __lsys_produce__=lambda mods: mods, __lsys_nproduce__=self._nbuf_add, __lsys_kwds__=Kwds,
            nproduce=self._nbuf_add, nsproduce=self._nsproduce, useGroup=self._use_group,
            getGroup=lambda: self._next_group,              # LsysContext::getGroup: the last useGroup's
            frameDisplay=lambda *a: None, Lstring=self._lstring,
            setSelectionAlwaysRequired=lambda *a: None,     # the editor's selection check: no editor here
            isAnimationEnabled=lambda: False,               # L-Py's editor animation: never here
            ParameterSet=ParameterSet,                       # from openalea.lpy, as every L-Py namespace has it
            ModuleClass=_ModuleClasses(self._g),
            InLeftContext=lambda pattern, args=None: self._in_context(pattern, args, True),
            InRightContext=lambda pattern, args=None: self._in_context(pattern, args, False),
            inLeftContext=lambda pattern, args=None: self._in_context(pattern, args, True),
            inRightContext=lambda pattern, args=None: self._in_context(pattern, args, False),
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
            raise LSystemError(f"{what}: {type(e).__name__}: {e}"[:300] + not_here_hint(e),
                               self._tb_line(sys.exc_info()[2]) or line,
                               1) from None

    def _lstring(self, text) -> ModuleString:
        """L-Py's ``Lstring('A(1) [B]')``: the string of an L-string text in the grammar's module names (its
        parameters evaluated as the axiom's are)."""
        if not isinstance(text, str):
            raise LSystemError(f"Lstring needs a str, got {type(text).__name__}")
        line = self._where[0]
        return self._to_string(self._eval_lstring(lex(text, self._names, line=line), line, "Lstring"), line)

    def _use_group(self, n) -> None:
        """``useGroup(n)`` (L-Py): the steps after this one use the rules of group ``n``, then those of group 0."""
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or not 0 <= n <= MAX_DERIVATION:
            raise LSystemError(f"useGroup needs an integer group in [0, {MAX_DERIVATION}], got {n!r:.40}")
        self._next_group = int(n)

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

    def _nsproduce(self, lstring) -> None:
        """L-Py's ``nsproduce(lstring)``: ``nproduce`` the modules of an lstring (``Lstring(...)``, a hook's
        lstring, or its text)."""
        if isinstance(lstring, LstringView):
            lstring = lstring.string()
        elif isinstance(lstring, str):
            lstring = self._lstring(lstring)
        if not isinstance(lstring, ModuleString):
            raise LSystemError(f"nsproduce needs an lstring, got {type(lstring).__name__}")
        self._nbuf_add(lstring.modules())

    def _extern(self, **kw) -> None:
        for k, v in kw.items():
            value = self._overrides.get(k, v)
            self._ns[k] = value
            try:
                self._externs[k] = float(value)
            except (TypeError, ValueError, OverflowError):
                raise LSystemError(f"extern {k} must be a number, got {value!r:.40}") from None

    def _exec_python(self) -> None:
        """Run the editor's INITIALISATION block (trusted grammars: its ``__initialiseContext__(context)`` defines
        the curves, functions and scalars of the editor's panels, as ``LsysContext::__initialiseFrom`` does before
        the code; the caller's externs then win, as L-Py's ``updateNamespace(parameters)``), then the code."""
        if self.trusted and self._g.init.strip():
            what = "the INITIALISATION block"
            self._exec_block(self._g.init, what)
            init_fn = self._ns.pop("__initialiseContext__", None)
            if callable(init_fn):
                self._exec_code(lambda: init_fn(self._context), what)
                self._ns.update(self._overrides)
        self._exec_block(self._g.python, "the grammar's Python code")
        for name in _RANDOM_FUNCS if self.trusted else ():   # ``from random import *`` stays seeded
            if self._ns.get(name) is getattr(_random, name, None):
                self._ns[name] = getattr(self._rng, name)
        self._global_random = None
        self._global_random = self._uses_global_random()      # after the code ran: what it imported
        unknown = sorted(set(self._overrides) - set(self._externs))
        if unknown:
            raise ValueError(f"unknown extern {unknown[0]!r}: the grammar declares "
                             f"{sorted(self._externs) or 'none'}")

    def _exec_block(self, src: str, what: str) -> None:
        """Parse, check (untrusted) and run grammar code ``src`` whose line numbers are the file's."""
        tree = self._parse(src, "exec", 1, 1, what)
        self._restrict(tree, 1, 1)
        self._exec_code(self._compile_tree(tree, "exec", 1, 1, what), what)

    def _exec_code(self, code, what: str) -> None:
        """``exec(code)`` in the namespace (or call ``code``), seeded; its errors as LSystemError with the line."""
        self._reseed_globals(force=True)
        try:
            with self._seeded():
                code() if callable(code) else exec(code, self._ns)
        except LSystemError as e:
            raise LSystemError(e.detail, self._tb_line(sys.exc_info()[2]) or e.line or 1, 1) from None
        except _OverBudget:
            raise self._over_budget(self._tb_line(sys.exc_info()[2]), 1, f" running {what}") from None
        except Exception as e:                                # the grammar's own code failed
            raise LSystemError(f"{type(e).__name__}: {e}"[:300] + not_here_hint(e),
                               self._tb_line(sys.exc_info()[2]), 1) from None

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
                if nparams > (2 if name.startswith("End") else 1):
                    line = getattr(getattr(f, "__code__", None), "co_firstlineno", 0)
                    raise LSystemError(f"{name}() takes the lstring{' and the scene' if name.startswith('End') else ''}"
                                       f" at most, not {nparams} arguments", line, 1)
                hooks[name] = (f, nparams)
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
            raise LSystemError(f"{what}: {type(e).__name__}: {e}"[:300] + not_here_hint(e), line,
                               toks[0].col if toks else 1) \
                from None

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

    def _interpretation_hook(self, name: str) -> ModuleString | None:
        """The modules the grammar's ``StartInterpretation()`` / ``EndInterpretation()`` produce (``nproduce``
        and ``produce``, L-Py's ``LsysContext::startInterpretation``), None without such a function."""
        f = self._ns.get(name)
        if not callable(f):
            return None
        line = getattr(getattr(f, "__code__", None), "co_firstlineno", 0) or 1
        try:
            nparams = len(inspect.signature(f).parameters)
        except (TypeError, ValueError):
            nparams = 0
        if nparams:
            raise LSystemError(f"{name}(turtle), which drives PlantGL's turtle object, is not supported: "
                               "produce the turtle's modules instead", line, 1)
        self._nbuf.clear()
        try:
            res = f()
        except LSystemError:
            raise
        except _OverBudget:
            raise self._over_budget(self._tb_line(sys.exc_info()[2]), 1, f" in {name}()") from None
        except Exception as e:
            raise LSystemError(f"{name}() raised {type(e).__name__}: {e}{not_here_hint(e)}", self._tb_line(
                sys.exc_info()[2]) or line, 1) from None
        mods = list(self._nbuf) + (list(res) if isinstance(res, list) else [])
        self._nbuf.clear()
        return self._to_string(mods, line)

    def _hook(self, name: str, s: ModuleString) -> ModuleString:
        """Call the grammar's ``Start``/``StartEach``/``EndEach``/``End`` with what it takes, as L-Py's
        ``LsysContext::controlMethod``: nothing, the lstring, or the lstring and the scene L-Py's turtle draws
        from it (:func:`~plantvr.lsystem.scene.lsystem_scene`, built if the hook reads it); an lstring it returns
        replaces the string (the value ``End`` returns is not used: the derivation has ended)."""
        f, nparams = self._hooks.get(name, (None, 0))
        if f is not None:
            from .scene import LazyScene, lsystem_scene
            self._nbuf.clear()
            view = LstringView(s, self._lstring)
            try:
                out = f(*(view, LazyScene(lambda: lsystem_scene(self, s)))[:nparams])
            except LSystemError as e:
                if e.line:
                    raise
                raise LSystemError(e.detail, self._tb_line(sys.exc_info()[2]) or 1, 1) from None
            except _OverBudget:
                raise self._over_budget(self._tb_line(sys.exc_info()[2]), 1, f" in {name}()") from None
            except Exception as e:
                raise LSystemError(f"{name}() raised {type(e).__name__}: {e}{not_here_hint(e)}", self._tb_line(
                    sys.exc_info()[2]), 1) from None
            if isinstance(out, LstringView):
                out = out.string()
            if isinstance(out, ModuleString):
                return self._adopt(out)
            if out is None and view.edited:                # edited in place (lstring[0][0] = 2)
                return self._adopt(view.string())
            if out is not None:
                line = getattr(getattr(f, "__code__", None), "co_firstlineno", 0)
                raise LSystemError(f"{name}() must return None or an lstring, got {type(out).__name__}", line, 1)
        return s

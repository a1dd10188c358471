"""Rule compilation: each rule of a grammar made a Python function, with its vectorised or constant plan.

:class:`_Compiled` is a rule ready to run. :class:`_Rules` (a base of :class:`~plantvr.lsystem.engine.LSystem`)
compiles rules into it (untrusted ones checked by :mod:`plantvr.lsystem.sandbox`), plans one-line context-free
rules as numpy functions of the parameter columns (:class:`_ToNumpy`) or as constant successors, and calls a
rule on a module's parameters (``produce`` / ``nproduce``), reading its successor's parameters as L-Py's modules
hold them. It mirrors L-Py's ``LsysRule`` (``src/cpp/lsysrule.cpp``).
"""
from __future__ import annotations

import ast
import builtins
import math
import sys
import time
from typing import Any

import numpy as np

from . import sandbox as SB
from .grammar import Rule
from .lexer import GETMODULE, LSystemError, Token
from .modules import Kwds, _ModuleView, is_number
from .namespace import _OverBudget
from .nodes import NodeModule
from .plantgl import not_here_hint
from .patterns import MOD

_NP_FUNCS = {"sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
             "log10": np.log10, "floor": np.floor, "ceil": np.ceil, "fabs": np.abs, "abs": np.abs,
             "asin": np.arcsin, "acos": np.arccos, "atan": np.arctan, "atan2": np.arctan2, "radians": np.radians,
             "degrees": np.degrees, "pow": np.power, "min": np.minimum, "max": np.maximum, "int": np.trunc,
             "float": lambda a: a, "round": np.round, "hypot": np.hypot, "sinh": np.sinh, "cosh": np.cosh,
             "tanh": np.tanh}
_PURE = {name: getattr(math, name, None) for name in _NP_FUNCS} | {"abs": abs, "min": min, "max": max, "int": int,
                                                                  "float": float, "round": round, "pow": pow}
#: Successor modules made at run time: named by their first parameter, or a module object (:meth:`_produced`).
_MADE = frozenset({"new", "newmodule", GETMODULE})
_OK_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.IfExp, ast.Constant, ast.Name,
             ast.Load, ast.Call, ast.operator, ast.unaryop, ast.boolop, ast.cmpop)


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
        self.pats = rule.patterns
        #: whether the predecessor starts with a module name of fixed arity, found by its id ``sid``; else (a '*',
        #: a '*args'; ``sid`` -1) :meth:`~plantvr.lsystem.matching._Matching._bind` matches it
        self.plain = sid >= 0
        self.more = not self.plain or bool(self.rest)         # predecessor modules _bind matches
        self.query = any(tok.name in _query_modules() for p in self.pats.values() for tok in p.tokens())
        #: the body asks its contexts (``InLeftContext`` / ``InRightContext``): the matcher keeps its positions
        self.asks = any(q in src for _, src in rule.body for q in CONTEXT_QUERIES)
        self.vec = None          # (cond | None, [(sid, [fn, ...]), ...])
        self.batch = None        # (fn of the parameter columns, [(sid, arity), ...]): a loop in Python
        self.const = None        # [(sid, (floats...)), ...]
        self.static = None       # a static rule's successor, [(sid, params), ...]
        self.ignored = None      # its ignore: / consider: filter, (names, is_ignore) (set by the engine)
        # pattern constants (issue 33): every pattern parameter's index -> value, the variables' indices
        self.consts = list(rule.consts)
        n_all = len(rule.params) + len(self.consts)
        cidx = {k for k, _ in self.consts}
        self.keep = [k for k in range(n_all) if k not in cidx] if self.consts else None
        # the predecessor's own constants (position in its parameter list -> value) and variables' positions
        start = len(self.pats["left"].names) + len(self.pats["newleft"].names)
        self.pred_consts = [(k - start, v) for k, v in self.consts if start <= k < start + self.arity]
        self.pred_vars = [q for q in range(self.arity) if q + start not in cidx]


class _Rules:
    """Compiling and calling rules (a base of :class:`~plantvr.lsystem.engine.LSystem`)."""

    def _compile(self, rule: Rule) -> _Compiled:
        if time.monotonic() > self._deadline:
            raise LSystemError(f"time budget of {self.time_budget:g} s exceeded reading the rules", rule.line, 1)
        params = () if rule.static else rule.params          # L-Py unbinds a static rule's pattern variables
        func = self._function(params, rule.body, rule.line, f"rule {rule.header!r}",
                              None if self.trusted else lambda tree: self._restrict_rule(rule, tree))
        first = rule.patterns["pred"].mods[0]
        plain = first.kind == MOD and not (first.star or first.node or first.kwds)
        c = _Compiled(rule, func, self._sid(first.tok.name) if plain else -1)
        if rule.static:                                       # made once, now (``LsysRule::initStaticProduction``)
            c.static = self._call(c, [])
            if all(type(v) is float for _, vals in c.static for v in vals) and c.plain and \
                    not (c.contexts or c.newcontexts or c.rest or c.consts):
                c.const = c.static
            return c
        if rule.successor is not None and c.plain and not (c.contexts or c.newcontexts or c.rest) and \
                all(is_number(v) for _, v in c.pred_consts) and not any(t.name in _MADE for t in rule.successor):
            self._plan(c)
            c.const = None if c.consts else c.const           # the constant tables match names, not values
        return c

    def _function(self, params, body: list[tuple[int, str]], line: int, what: str, restrict=None):
        """A Python function of the grammar made from ``body`` (``(line, code)`` pairs, each at its grammar line,
        so tracebacks name the grammar's lines); ``restrict(tree)`` checks the parsed module first."""
        first = body[0][0] if body else line
        base = max(first - 2, 0)                              # the source starts at grammar line base + 1
        lines = [""] * (first - 2 - base) + [f"def __lsys_function__({', '.join(params)}):"]
        for ln, src in body:
            while len(lines) < ln - 1 - base:
                lines.append("")
            lines.append("    " + src)
        if not body:
            lines.append("    pass")
        tree = self._parse("\n".join(lines) + "\n", "exec", base + 1, 1, what)
        if restrict is not None:
            restrict(tree)
        local: dict = {}
        exec(self._compile_tree(tree, "exec", line, 1, what, shift=base), self._ns, local)
        return local["__lsys_function__"]

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
                star = len(a) - len(a.lstrip("*")) if a.startswith("*") else 0        # A(*p), A(**p)
                self._restrict(self._parse(a[star:], "eval", t.line, col + star, what), t.line, col)

    def _plan(self, c: _Compiled) -> None:
        """Vectorised and constant plans of a one-line context-free rule, else its batch plan (:meth:`_batch`)."""
        if not self._plan_vec(c):
            c.batch = self._batch(c)

    def _plan_vec(self, c: _Compiled) -> bool:
        """The vectorised (and constant) plan of a one-line context-free rule; False where numpy cannot run it."""
        params = c.rule.params
        cond = None
        if c.rule.condition is not None:
            cond = self._vectorize(c.rule.condition, params)
            if cond is None:
                return False
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
                    return False
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
        return True

    def _batch(self, c: _Compiled):
        """The batch plan of a one-line context-free rule numpy cannot evaluate (it calls a grammar function, say):
        one generated comprehension over the parameter columns, at the rule's grammar line, that evaluates the
        condition and the successor's parameters module after module as the rule's own function does, giving a
        flat tuple of parameters per module (None where the condition fails). The successor's modules and arities
        are the rule's. :meth:`_call_batch` runs it."""
        rule = c.rule
        succ = [t for t in rule.successor if not (t.name == "*" and len(rule.successor) == 1 and t.args is None)]
        vals = "".join(f"({a})," for t in succ for a in (t.args or ()))
        item = f"({vals})" if rule.condition is None else f"(({vals}) if ({rule.condition}) else None)"
        target = ", ".join(rule.params or ["__lsys_i__"]) + ","
        src = f"def __lsys_batch__(__lsys_cols__, __lsys_zip__): return [{item} for ({target}) in " \
              "__lsys_zip__(*__lsys_cols__)]\n"
        try:                                                  # the rule's own function compiled the same code
            tree = ast.parse(src, filename=self._filename)
            comp = tree.body[0].body[0].value
            comp.elt = SB.guard(ast.Expression(comp.elt), trusted=self.trusted).body   # not the loop over columns
            ast.increment_lineno(ast.fix_missing_locations(tree), rule.line - 1)
            code = compile(tree, self._filename, "exec")
        except (SyntaxError, ValueError, RecursionError, MemoryError):
            return None                                       # the per-module path reports it
        local: dict = {}
        exec(code, self._ns, local)
        return local["__lsys_batch__"], [(self._sid(t.name), len(t.args or ())) for t in succ]

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

    def _params(self, name: str, v, line: int) -> tuple:
        """The parameters of a produced module ``name(*v)``: numbers as floats, any other Python value (str,
        tuple, list, None, bool...) kept as it is, as L-Py's modules hold them (issue 33); a turtle module's
        numeric vectors (``SetHead(Vector3(...))``) and booleans are read as numbers, as its turtle does."""
        if not isinstance(v, (tuple, list)):
            v = (v,)
        out: list = []
        turtle = name in _turtle_modules()
        for k, x in enumerate(v):
            if is_number(x) or (turtle and isinstance(x, (bool, np.bool_))):
                try:
                    out.append(float(x))
                except OverflowError:
                    raise LSystemError(f"module {name}: parameter {SB._short(x)} is too large for a float", line,
                                       1) from None
            elif turtle and isinstance(x, (tuple, list, np.ndarray)):
                out.extend(self._params(name, np.asarray(x, dtype=object).ravel().tolist(), line))
            elif isinstance(x, Kwds):                        # A(1, **p): the rest by name, last
                if k != len(v) - 1:
                    raise LSystemError(f"module {name}: **keywords must come last", line, 1)
                return self._params(name, self._by_name(name, out, x, line), line)
            else:
                out.append(x)
        return tuple(out)

    def _rule_error(self, c: _Compiled, e: Exception) -> LSystemError:
        """What a rule's exception ``e`` (being handled) is reported as: an LSystemError at its grammar line."""
        line = self._tb_line(sys.exc_info()[2]) or c.rule.line
        if isinstance(e, LSystemError):
            return e if e.line else LSystemError(e.detail, line, 1)
        if isinstance(e, _OverBudget):
            return self._over_budget(line, 1, f" in rule {c.rule.header!r}")
        if isinstance(e, SB.SandboxError):
            return LSystemError(f"rule {c.rule.header!r}: {e}", line, 1)
        return LSystemError(f"rule {c.rule.header!r} raised {type(e).__name__}: {e}"[:300] + not_here_hint(e),
                            line, 1)

    def _call_batch(self, c: _Compiled, cols: list) -> list:
        """Rule ``c``'s batch plan on parameter columns ``cols`` (lists, as rule code sees the values)."""
        self._where = (c.rule.line, 1)
        try:
            return c.batch[0](cols, zip)                     # zip: untrusted namespaces have no builtins
        except (Exception, _OverBudget) as e:
            raise self._rule_error(c, e) from None

    def _call(self, c: _Compiled, vals: list) -> list | None:
        if c.static is not None:
            return c.static
        self._nbuf.clear()
        if time.monotonic() > self._deadline:
            raise self._over_budget(c.rule.line, 1, f" in rule {c.rule.header!r}")
        self._where = (c.rule.line, 1)
        try:
            res = c.func(*vals)
        except (Exception, _OverBudget) as e:
            raise self._rule_error(c, e) from None
        if res is None:
            if not self._nbuf:
                return None
            res = list(self._nbuf)
        elif self._nbuf:
            res = list(self._nbuf) + list(res)
        line, sid, params = c.rule.line, self._sid, self._params
        return [(sid(name), params(name, v, line) if v != () else ()) if name not in _MADE else
                self._produced(name, v, line) for name, v in res]

    def _produced(self, name: str, v, line: int) -> tuple[int, tuple]:
        """``(id, parameters)`` of a produced module ``name(*v)``; L-Py's ``new(name, *args)`` (``newmodule``) is
        the module its first argument names (``processConstruction``) and ``$a`` the module object ``a`` (a
        ``$A(a)`` pattern's :class:`~plantvr.lsystem.nodes.NodeModule`, or a module of a hook's lstring)."""
        if name in _MADE:
            v = tuple(v) if isinstance(v, (tuple, list)) else (v,)
            if name == GETMODULE:
                if len(v) != 1 or not isinstance(v[0], (NodeModule, _ModuleView)):
                    raise LSystemError("$a in a successor needs a module (bound by a $A(a) pattern), got "
                                       f"{type(v[0]).__name__ if len(v) == 1 else f'{len(v)} values'}", line, 1)
                name, v = v[0].name, tuple(v[0][k] for k in range(len(v[0])))
            else:
                if not v or not isinstance(v[0], str) or not v[0] or any(ch in v[0] for ch in " \t\n(),"):
                    raise LSystemError(f"{name}(name, *args) needs a module name (a str) first, got "
                                       f"{SB._short(v[0]) if v else 'nothing'}", line, 1)
                name, v = v[0], v[1:]
        return self._sid(name), self._params(name, v, line) if v != () else ()

    def _by_name(self, name: str, args: list, kw: Kwds, line: int) -> list:
        """``name(*args, **kw)``: the keywords placed at their positions in ``name``'s declaration
        (``processArgList`` of L-Py's ``module.cpp``), every declared parameter given once."""
        pnames = self._g.param_names.get(name, ())
        if len(args) + len(kw) < len(pnames):
            raise LSystemError(f"{name} takes exactly {len(pnames)} parameters ({len(args) + len(kw)} given)", line, 1)
        missing: set = set()
        for key, value in kw.items():
            if key not in pnames:
                raise LSystemError(f"invalid parameter name {key!r} for module {name!r} (declared: "
                                   f"{', '.join(pnames) or 'none'})", line, 1)
            at = pnames.index(key)
            if at < len(args) and at not in missing:
                raise LSystemError(f"{name} got multiple values for parameter {key!r}", line, 1)
            if at >= len(args):
                missing.update(range(len(args), at))
                args.extend([None] * (at + 1 - len(args)))
            args[at] = value
            missing.discard(at)
        if missing:
            raise LSystemError(f"{name} takes exactly {len(pnames)} parameters ({len(missing)} missing)", line, 1)
        return args


def _turtle_modules() -> frozenset:
    """The turtle's module names whose parameters are read as numbers (not the request modules, which hold
    the Vector3s of L-Py's query pass)."""
    if not _TURTLE:
        from .turtle import QUERY_MODULES, TURTLE_MODULES
        _TURTLE.append(frozenset(TURTLE_MODULES) - frozenset(QUERY_MODULES))
    return _TURTLE[0]


#: L-Py's context tests of a rule body (``LstringMatcher::inLeftContext`` / ``inRightContext``).
CONTEXT_QUERIES = ("InLeftContext", "InRightContext", "inLeftContext", "inRightContext")


def _query_modules() -> frozenset:
    """The request modules' names (:data:`~plantvr.lsystem.turtle.QUERY_MODULES`)."""
    from .turtle import QUERY_MODULES
    return frozenset(QUERY_MODULES)


_TURTLE: list = []


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

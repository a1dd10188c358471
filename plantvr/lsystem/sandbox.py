"""Grammars are code (issue 34): the restricted evaluator of untrusted grammars and the guards of every one.

An ``.lpy`` file is a Python program. PlantVR runs a grammar's Python only when its caller trusts it
(``LSystem(text, trusted=True)``, as Jupyter trusts a notebook); otherwise the grammar is read with a restricted
evaluator:

* one-line rules (``pred --> successor``, ``pred : condition --> successor``, ``pred : produce successor``),
  their conditions and parameter expressions, the axiom, ``derivation length`` / ``maximum depth`` and
  top-level assignments and calls (``extern(angle=20)``, ``n = 5``,
  ``execContext().turtle.setAngleIncrement(20)``) are Python *expressions* checked against a whitelist of AST
  nodes (:func:`restrict`): numbers, strings, arithmetic, comparisons, ``and/or/not``, ``a if c else b``,
  tuples, lists, subscripts and calls of names. No imports, no names or attributes starting with ``_``, no
  lambdas, comprehensions, f-strings, ``open``/``eval``/``exec``/``getattr``/``type``/``globals``...; builtins
  are :data:`SAFE_BUILTINS` only (math functions come from the grammar's namespace); an attribute is read only
  on the ``context()`` stubs (:class:`SafeAttrs`), checked when it runs;
* Python statements (``import``, ``def``, loops, ``if``, ``with``...) and indented rule bodies are refused with
  the line and column of the first one and a message saying to pass ``trusted=True``.

Every grammar, trusted or not, is rewritten by :func:`guard`: ``a ** b``, ``a << b`` and ``a * b`` go through
:func:`safe_pow`, :func:`safe_lshift` and :func:`safe_mul`, which refuse an integer result of more than
:data:`MAX_INT_BITS` bits or a repeated sequence longer than :data:`MAX_SEQUENCE` *before computing it*
(``9**9**9`` is refused at once, not computed; an untrusted grammar's ``+`` concatenates at most
:data:`MAX_SEQUENCE` items and its ``sum`` adds numbers only), and every ``while``/``for`` body and comprehension of trusted
code calls the L-system's budget tick, so a ``while True:`` loop stops at the time budget (signal-free, in any
thread). What the guards cannot stop is a single call into C that does not return (``time.sleep(1e9)``,
``sum(itertools.count())``): trusting a grammar means trusting its code.
"""
from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable

from .plantgl import Vector2, Vector3, Vector4

__all__ = [
    "MAX_INT_BITS",
    "MAX_RANGE",
    "MAX_SEQUENCE",
    "SAFE_BUILTINS",
    "TRUST_HINT",
    "Refused",
    "SafeAttrs",
    "SandboxError",
    "guard",
    "restrict",
    "safe_getattr",
    "safe_lshift",
    "safe_mul",
    "safe_pow",
]

#: Largest integer (in bits) a grammar expression may compute with ``**``, ``<<`` or ``*``.
MAX_INT_BITS = 100_000
#: Longest sequence ``s * n`` may build (characters or items).
MAX_SEQUENCE = 1_000_000
#: Longest ``range`` an untrusted grammar may build.
MAX_RANGE = 1_000_000

#: How a refusal of untrusted code ends.
TRUST_HINT = ("pass trusted=True (or tick 'Trust this grammar') if you trust this grammar to run its Python "
              "code")

_GENERATED = frozenset({"__lsys_produce__", "__lsys_nproduce__", "__lsys_kwds__"})
_FORBIDDEN = frozenset({
    "open", "eval", "exec", "compile", "getattr", "setattr", "delattr", "hasattr", "type", "globals", "locals",
    "vars", "dir", "input", "breakpoint", "help", "object", "super", "memoryview", "classmethod", "staticmethod",
    "property", "id", "exit", "quit", "print", "isinstance", "issubclass", "iter", "next", "map", "filter",
    "bytearray", "bytes", "frozenset", "set", "dict", "callable", "license", "copyright", "credits", "reload",
})
_EXPR_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.IfExp, ast.Call, ast.keyword,
               ast.Name, ast.Constant, ast.Attribute, ast.Subscript, ast.Slice, ast.Tuple, ast.List, ast.Load,
               ast.Store, ast.operator, ast.unaryop, ast.boolop, ast.cmpop)
_STMT_WORDS = {ast.Import: "import", ast.ImportFrom: "import", ast.FunctionDef: "a function definition",
               ast.AsyncFunctionDef: "a function definition", ast.ClassDef: "a class definition",
               ast.While: "a 'while' loop", ast.For: "a 'for' loop", ast.AsyncFor: "a 'for' loop",
               ast.If: "an 'if' statement", ast.With: "a 'with' statement", ast.AsyncWith: "a 'with' statement",
               ast.Try: "a 'try' statement", ast.Raise: "a 'raise' statement", ast.Global: "'global'",
               ast.Nonlocal: "'nonlocal'", ast.Delete: "'del'", ast.Assert: "'assert'", ast.Return: "'return'"}
_EXPR_WORDS = {ast.Lambda: "a lambda", ast.ListComp: "a comprehension", ast.SetComp: "a comprehension",
               ast.DictComp: "a comprehension", ast.GeneratorExp: "a generator expression",
               ast.JoinedStr: "an f-string", ast.NamedExpr: "':='", ast.Starred: "'*' unpacking",
               ast.Dict: "a dict", ast.Set: "a set", ast.Await: "'await'", ast.Yield: "'yield'",
               ast.YieldFrom: "'yield'"}


class SandboxError(ValueError):
    """A guard refused an operation while the grammar ran (too large a number, a forbidden attribute)."""


class Refused(ValueError):
    """:func:`restrict` refused a node; ``lineno``/``col_offset`` are the node's, relative to its source."""

    def __init__(self, message: str, node: ast.AST) -> None:
        super().__init__(message)
        self.lineno = getattr(node, "lineno", 1)
        self.col_offset = getattr(node, "col_offset", 0)


class SafeAttrs:
    """Marker base of the objects whose public attributes an untrusted grammar may read (``context()``)."""


# -- guards ------------------------------------------------------------------------------------------------------
def _bits(v) -> int:
    return v.bit_length() if isinstance(v, int) else 0


def safe_pow(a, b, mod=None):
    """``a ** b`` (``pow(a, b, mod)``), refused before computing an integer of more than MAX_INT_BITS bits."""
    if mod is None and isinstance(a, int) and isinstance(b, int) and b > 0 and abs(a) > 1:
        if b > MAX_INT_BITS or (a.bit_length() - 1) * b > MAX_INT_BITS:
            raise SandboxError(f"{_short(a)} ** {_short(b)} is too large (more than {MAX_INT_BITS:,} bits)")
    return a ** b if mod is None else pow(a, b, mod)


def safe_lshift(a, b):
    """``a << b``, refused before computing an integer of more than MAX_INT_BITS bits."""
    if isinstance(a, int) and isinstance(b, int) and a and b > 0 and a.bit_length() + b > MAX_INT_BITS:
        raise SandboxError(f"{_short(a)} << {_short(b)} is too large (more than {MAX_INT_BITS:,} bits)")
    return a << b


_SEQ = (str, bytes, bytearray, list, tuple)


def safe_mul(a, b):
    """``a * b``, refused for an integer of more than MAX_INT_BITS bits or a sequence longer than MAX_SEQUENCE."""
    ta = type(a)
    if ta is float or type(b) is float:
        return a * b
    if isinstance(a, int) and isinstance(b, int):
        if a.bit_length() + b.bit_length() > MAX_INT_BITS:
            raise SandboxError(f"{_short(a)} * {_short(b)} is too large (more than {MAX_INT_BITS:,} bits)")
        return a * b
    for s, k in ((a, b), (b, a)):
        if isinstance(s, _SEQ):
            try:
                n = operator.index(k)
            except TypeError:
                break
            if n > 0 and len(s) * n > MAX_SEQUENCE:
                raise SandboxError(f"a {type(s).__name__} of {len(s):,} repeated {_short(n)} times is longer "
                                   f"than {MAX_SEQUENCE:,}")
    return a * b


def safe_add(a, b):
    """``a + b`` of an untrusted grammar: concatenations of at most MAX_SEQUENCE items (``s = s + s`` does not
    double a string until memory runs out)."""
    if isinstance(a, _SEQ) and isinstance(b, _SEQ) and len(a) + len(b) > MAX_SEQUENCE:
        raise SandboxError(f"a {type(a).__name__} of {len(a):,} + {len(b):,} items is longer than {MAX_SEQUENCE:,}")
    return a + b


def _safe_sum(iterable, start=0):
    if not isinstance(start, (int, float, complex)) or isinstance(start, bool):
        raise SandboxError("sum(..., start) of an untrusted grammar adds numbers only")
    return sum(iterable, start)


def safe_mod(a, b):
    """``a % b`` of an untrusted grammar: no ``%`` string formatting."""
    if isinstance(a, (str, bytes)):
        raise SandboxError("'%' string formatting is not available to an untrusted grammar")
    return a % b


def safe_getattr(obj, name: str):
    """``obj.name`` of an untrusted grammar: public attributes of :class:`SafeAttrs` objects, and the coordinates
    ``x``, ``y``, ``z``, ``w`` of PlantGL vectors (the Vector3s request modules such as ``?P(p)`` hold)."""
    if isinstance(obj, SafeAttrs) and not name.startswith("_"):
        return getattr(obj, name)
    if isinstance(obj, (Vector2, Vector3, Vector4)) and name in ("x", "y", "z", "w"):
        return getattr(obj, name)
    raise SandboxError(f"attribute .{name} of a {type(obj).__name__} is not available to an untrusted grammar")


def _short(v) -> str:
    if isinstance(v, int) and v.bit_length() > 64:
        return f"<an integer of {v.bit_length():,} bits>"
    return repr(v)[:40]


def _safe_range(*args):
    r = range(*args)
    try:
        n = len(r)
    except OverflowError:
        n = MAX_RANGE + 1
    if n > MAX_RANGE:
        raise SandboxError(f"range of more than {MAX_RANGE:,} numbers")
    return r


def _safe_round(x, ndigits=None):
    if ndigits is not None and isinstance(ndigits, int) and abs(ndigits) > 1000:
        raise SandboxError(f"round(..., {_short(ndigits)}): ndigits must be within +-1000")
    return round(x) if ndigits is None else round(x, ndigits)


#: The builtins of an untrusted grammar.
SAFE_BUILTINS = {"abs": abs, "min": min, "max": max, "int": int, "float": float, "range": _safe_range,
                 "len": len, "round": _safe_round, "bool": bool, "pow": safe_pow, "sum": _safe_sum,
                 "True": True, "False": False, "None": None}

#: ``math`` names an untrusted grammar sees (functions of floats; the integer ones that can run long are left out).
SAFE_MATH = ("acos", "acosh", "asin", "asinh", "atan", "atan2", "atanh", "ceil", "copysign", "cos", "cosh",
             "degrees", "dist", "e", "erf", "erfc", "exp", "expm1", "fabs", "floor", "fmod", "frexp", "gamma",
             "hypot", "inf", "isclose", "isfinite", "isinf", "isnan", "ldexp", "lgamma", "log", "log10", "log1p",
             "log2", "modf", "nan", "pi", "pow", "radians", "remainder", "sin", "sinh", "sqrt", "tan", "tanh",
             "tau", "trunc", "cbrt", "exp2")


def math_names() -> dict:
    return {k: getattr(math, k) for k in SAFE_MATH if hasattr(math, k)}


# -- the restricted evaluator's check ----------------------------------------------------------------------------
def _check_name(name: str, node: ast.AST) -> None:
    if name in _GENERATED:
        return
    if name.startswith("_"):
        raise Refused(f"name {name!r} is not available to an untrusted grammar (names starting with '_'); "
                      + TRUST_HINT, node)
    if name in _FORBIDDEN:
        raise Refused(f"{name!r} is not available to an untrusted grammar; " + TRUST_HINT, node)


def _check_expr(tree: ast.AST) -> None:
    for node in ast.walk(tree):
        word = _EXPR_WORDS.get(type(node))
        if word is not None:
            raise Refused(f"{word} is not available to an untrusted grammar; " + TRUST_HINT, node)
        if not isinstance(node, _EXPR_NODES):
            raise Refused(f"{type(node).__name__} is not available to an untrusted grammar; " + TRUST_HINT, node)
        if isinstance(node, ast.Name):
            _check_name(node.id, node)
        elif isinstance(node, ast.Attribute):
            if node.attr.startswith("_"):
                raise Refused(f"attribute {node.attr!r} is not available to an untrusted grammar (names starting "
                              "with '_'); " + TRUST_HINT, node)
            if isinstance(node.ctx, ast.Store):
                raise Refused("setting an attribute is not available to an untrusted grammar; " + TRUST_HINT,
                              node)
        elif isinstance(node, ast.Constant):
            if not isinstance(node.value, (int, float, complex, str, bool, type(None))):
                raise Refused(f"constant {node.value!r:.20} is not available to an untrusted grammar", node)
        elif isinstance(node, ast.keyword) and node.arg is None:
            raise Refused("'**' unpacking is not available to an untrusted grammar; " + TRUST_HINT, node)
        elif isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Store):
            raise Refused("assigning to an item is not available to an untrusted grammar; " + TRUST_HINT, node)


def _check_target(t: ast.AST) -> None:
    if isinstance(t, ast.Name):
        _check_name(t.id, t)
    elif isinstance(t, (ast.Tuple, ast.List)):
        for e in t.elts:
            _check_target(e)
    else:
        raise Refused(f"assigning to {type(t).__name__.lower()} is not available to an untrusted grammar; "
                      + TRUST_HINT, t)


def restrict(tree: ast.AST) -> None:
    """Raise :class:`Refused` (with the node's position) unless ``tree`` stays within the restricted evaluator:
    an expression (``ast.Expression``) or a module of assignments to names, expression statements and
    ``pass`` (see the module docstring)."""
    if isinstance(tree, ast.Expression):
        _check_expr(tree)
        return
    if not isinstance(tree, ast.Module):
        raise Refused(f"{type(tree).__name__} is not available to an untrusted grammar", tree)
    for st in tree.body:
        if isinstance(st, ast.Expr):
            _check_expr(st.value)
        elif isinstance(st, ast.Assign):
            for t in st.targets:
                _check_target(t)
            _check_expr(st.value)
        elif isinstance(st, ast.AugAssign) or isinstance(st, ast.AnnAssign) and st.value is not None and st.simple:
            _check_target(st.target)
            _check_expr(st.value)
        elif isinstance(st, ast.Pass):
            continue
        else:
            word = _STMT_WORDS.get(type(st), f"a '{type(st).__name__}' statement")
            raise Refused(f"{word} runs Python code, which an untrusted grammar may not; " + TRUST_HINT, st)


# -- the guards, by rewriting -------------------------------------------------------------------------------------
_BINOP_GUARD = {ast.Pow: "__lsys_pow__", ast.LShift: "__lsys_lshift__", ast.Mult: "__lsys_mul__"}
_UNTRUSTED_GUARD = {ast.Mod: "__lsys_mod__", ast.Add: "__lsys_add__"}


def _float_constant(node: ast.AST) -> bool:
    """A float literal (``1.01``, ``-0.5``): an operation with one cannot build a huge integer or sequence (a
    float times a sequence is a TypeError), so it needs no guard."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        node = node.operand
    return isinstance(node, ast.Constant) and type(node.value) is float


class _Guard(ast.NodeTransformer):
    def __init__(self, trusted: bool) -> None:
        self.trusted = trusted

    def _call(self, fname: str, args: list, like: ast.AST) -> ast.Call:
        return ast.copy_location(ast.Call(ast.Name(fname, ast.Load()), args, []), like)

    def visit_BinOp(self, node):
        self.generic_visit(node)
        fname = self._guard_name(node.op)
        if fname is None or _float_constant(node.left) or _float_constant(node.right):
            return node
        return self._call(fname, [node.left, node.right], node)

    def _guard_name(self, op: ast.operator) -> str | None:
        fname = _BINOP_GUARD.get(type(op))
        if fname is None and not self.trusted:
            fname = _UNTRUSTED_GUARD.get(type(op))
        return fname

    def visit_AugAssign(self, node):
        self.generic_visit(node)
        fname = self._guard_name(node.op)
        if fname is None or not isinstance(node.target, ast.Name) or _float_constant(node.value):
            return node
        load = ast.copy_location(ast.Name(node.target.id, ast.Load()), node.target)
        return ast.copy_location(ast.Assign([node.target], self._call(fname, [load, node.value], node)), node)

    def visit_Attribute(self, node):
        self.generic_visit(node)
        if self.trusted or not isinstance(node.ctx, ast.Load):
            return node
        return self._call("__lsys_getattr__", [node.value, ast.copy_location(ast.Constant(node.attr), node)],
                          node)

    def _tick(self, like: ast.AST) -> ast.Expr:
        return ast.copy_location(ast.Expr(self._call("__lsys_tick__", [], like)), like)

    def visit_While(self, node):
        self.generic_visit(node)
        node.body.insert(0, self._tick(node.body[0]))
        return node

    visit_For = visit_While
    visit_AsyncFor = visit_While

    def visit_comprehension(self, node):
        self.generic_visit(node)
        node.iter = self._call("__lsys_iter__", [node.iter], node.iter)
        return node


def guard(tree: ast.AST, *, trusted: bool) -> ast.AST:
    """``tree`` with the guards in (see the module docstring); ``__lsys_pow__``, ``__lsys_lshift__``,
    ``__lsys_mul__``, ``__lsys_mod__``, ``__lsys_getattr__``, ``__lsys_tick__`` and ``__lsys_iter__`` must be
    in the namespace the code runs in (:func:`guard_names`)."""
    tree = _Guard(trusted).visit(tree)
    ast.fix_missing_locations(tree)
    return tree


def guard_names(tick: Callable[[], None]) -> dict:
    """The namespace entries :func:`guard` 's code calls; ``tick`` checks the time budget."""
    def lsys_iter(it):
        for x in it:
            tick()
            yield x
    return {"__lsys_pow__": safe_pow, "__lsys_lshift__": safe_lshift, "__lsys_mul__": safe_mul,
            "__lsys_mod__": safe_mod, "__lsys_add__": safe_add, "__lsys_getattr__": safe_getattr, "__lsys_tick__": tick,
            "__lsys_iter__": lsys_iter}

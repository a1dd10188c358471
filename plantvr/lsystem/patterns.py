"""Rule patterns (issue 33): a rule header's modules read as L-Py's ``PatternModule`` / ``PatternString``.

A pattern module is a module name with parameters (variable names, constants, a last ``*args`` taking the
remaining parameters as a list: ``A(x, *rest)``, and a very last ``**kwds`` the named ones as a dict), ``$A(a)``
(the module itself, :mod:`plantvr.lsystem.nodes`), the wildcard ``*`` (alias ``any``) matching any one module
(``*`` binds nothing; ``*(n)`` a module without parameters, binding its name; ``*(n, a, b)`` one with two,
binding its name and parameters; ``*(n, a, *rest)`` one with at least one; ``*(*args)`` any module, binding
``[name, *parameters]``), a bracket, or, in contexts, the alternatives ``or(p1, p2, None)`` (the first that
matches binds its variables, the others' are None) and the repetition ``x(pattern)`` (alias ``all``) matching the
pattern 0 to 1000 times in a row, ``x(pattern, n)`` n times, ``x(pattern, lo, hi)`` lo to hi times, greedily, each
variable of the pattern bound to the list of its values, one per repetition (empty lists when none), as L-Py's
``RegExpMatcher`` and ``ArgsCollector::fusion_args``. The matching itself is in
:mod:`plantvr.lsystem.matching`.
"""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass

from .lexer import GETMODULE, LSystemError, Token, split_top
from .modules import is_number

__all__ = ["ANY", "ERB", "LB", "MOD", "OR", "PATTERN_NAMES", "RB", "REP", "Pattern", "PatternModule",
           "read_pattern"]

MOD, ANY, REP, LB, RB, ERB, OR = range(7)
_ANY = frozenset({"*", "any"})
_REP = frozenset({"x", "all"})
_ITERATOR = frozenset({"?I", "GetIterator"})
#: Names L-Py's pattern parser knows beyond the turtle's, lexed as whole names in patterns.
PATTERN_NAMES = frozenset({"any", "all", "or", "None"})
_IDENT = re.compile(r"^[A-Za-z_]\w*$")
_MAX_REPEAT = 1000                                # L-Py's default most repetitions of ``x(pattern)``
_MAX_NESTING = 16                                 # repetitions inside repetitions (the matching recurses)


@dataclass(frozen=True, eq=False)
class PatternModule:
    """One module of a pattern.

    ``kind`` is ``MOD`` (a module name), ``ANY`` (``*``), ``REP`` (``x(...)``), ``LB`` or ``RB`` (brackets),
    ``ERB`` (``=]``, the exact closing bracket of a right context);
    ``nfixed`` the parameters matched one to one (for ``ANY``, after the name), ``star`` whether a last ``*args``
    takes the rest, ``name_var`` whether an ``ANY`` binds the module's name first (``*(*args)`` binds
    ``[name, *parameters]`` as its one value), ``sub``/``lo``/``hi`` a repetition's pattern and bounds,
    ``node`` whether a ``MOD`` is L-Py's ``$A(a)``: any module of the class, bound as one
    :class:`~plantvr.lsystem.nodes.NodeModule`, ``kwds`` whether a last ``**kwds`` takes the named parameters
    (those of the module's declaration, ``module A(x, t)``) as a dict."""

    tok: Token
    kind: int
    nfixed: int = 0
    star: bool = False
    name_var: bool = False
    sub: Pattern | None = None
    lo: int = 0
    hi: int = _MAX_REPEAT
    node: bool = False
    kwds: bool = False
    alts: tuple = ()


@dataclass(frozen=True, eq=False)
class Pattern:
    """A pattern string: its modules, the names of the values it binds (None for a constant, which is compared
    and dropped) and its constants ``(index among the values, value)``."""

    mods: tuple
    names: tuple
    consts: tuple
    conds: tuple = ()     # value constraints (Python expressions of the bound names) that must hold

    @property
    def variables(self) -> list[str]:
        return [n for n in self.names if n is not None]

    def filter(self, vals: list) -> list | None:
        """``vals`` (one per pattern parameter) without the constants, or None if one differs."""
        if not self.consts:
            return vals
        if not all(_same(vals[k], v) for k, v in self.consts):
            return None
        return [v for v, n in zip(vals, self.names) if n is not None]

    def tokens(self):
        """Every module token of the pattern, those inside repetitions included."""
        for m in self.mods:
            yield m.tok
            for sub in (m.sub, *m.alts):
                if sub is not None:
                    yield from sub.tokens()


def _same(value, const) -> bool:
    """Whether a module's parameter matches a pattern constant (``==``, without raising)."""
    try:
        return bool(type(value) is type(const) or (is_number(value) and is_number(const))) and value == const
    except (TypeError, ValueError, ArithmeticError):             # e.g. an array's ambiguous truth value
        return False


_CONSTRAINED = re.compile(r"^([A-Za-z_]\w*)\s*(.+)$", re.DOTALL)


def _param(a: str, tok: Token, line: int) -> tuple[str, object] | None:
    """``("var", name)``, ``("star", name)``, ``("const", value)`` or ``("cond", (name, expression))`` for pattern
    parameter ``a``. A value constraint (L-Py's ``LpyParsing::parse_variable``) binds the name its text starts
    with and must hold: ``x if x > 0`` the expression after ``if``, else the whole text (``n in 'SU'``,
    ``s == Any``)."""
    if a.startswith("**"):
        if _IDENT.match(a[2:].strip()):
            return "kwds", a[2:].strip()
        raise LSystemError(f"keyword pattern parameter {a!r} of {tok.name} must be '**name'", line, tok.col)
    if a.startswith("*") and _IDENT.match(a[1:].strip()):
        return "star", a[1:].strip()
    if _IDENT.match(a) and a not in ("None", "True", "False"):
        return "var", a
    try:
        value = ast.literal_eval(a)
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        value = None
    else:
        if len(a) <= 200:
            return "const", value
    m = _CONSTRAINED.match(a)
    if m and m.group(1) not in ("None", "True", "False", "not", "lambda") and len(a) <= 2000:
        cond = m.group(2)[3:] if re.match(r"if\b", m.group(2)) else a
        try:
            ast.parse(cond.strip(), mode="eval")
        except (SyntaxError, ValueError, MemoryError, RecursionError):
            pass
        else:
            return "cond", (m.group(1), cond.strip())
    raise LSystemError(f"pattern parameter {a!r} of {tok.name} must be a variable name, a constant or a value "
                       "constraint (a name, then a Python condition)", line, tok.col)


def _arg_cols(text: str, tok: Token) -> list[int]:
    """Grammar columns of the parameters of ``tok``, read in its line ``text``."""
    at = tok.col - 1 + len(tok.name)                  # the '(' after the name
    inner = text[at + 1:]
    cols, off = [], at + 1
    for part in split_top(inner)[:len(tok.args)]:
        cols.append(off + len(part) - len(part.lstrip()) + 1)
        off += len(part) + 1
    return cols


def read_pattern(toks: list[Token], text: str, lex, *, where: str, depth: int = 0) -> Pattern:
    """The :class:`Pattern` of header tokens ``toks`` (lexed from line ``text``; ``lex(src, line, col)`` lexes a
    repetition's pattern) in the header part ``where`` (``pred``, ``left``, ``right``, ``newleft``, ``newright``).

    Raises
    ------
    LSystemError
        For a construct PlantVR does not match (iterator requests, a repetition or an
        alternative in a predecessor, a ``*args`` not last...), at its line and column.
    """
    mods, names, consts, conds = [], [], [], []
    for t in toks:
        line = t.line
        if t.name in _ITERATOR:
            raise LSystemError(f"iterator request {t.name} in a pattern is not supported", line, t.col)
        if t.name == GETMODULE:              # ``$A(a)``: the module itself (L-Py's process_get_module)
            mods.append(_get_module(t, where))
            names.append(t.args[1])
            continue
        if t.name == "=]":                   # L-Py's ExactRightBracket: the branch closes right here
            if where not in ("right", "newright"):
                raise LSystemError("the exact closing bracket =] is supported in right contexts only", line, t.col)
            mods.append(PatternModule(t, ERB))
            continue
        if t.name == "or" and t.args is not None:
            m = _alternatives(t, text, lex, where, depth)
            mods.append(m)
            for alt in m.alts:
                names.extend(alt.variables)
            continue
        if t.name in ("or", "None"):
            what = {"or": "alternative pattern or with no patterns", "None": "the empty pattern None outside or(...)"}
            raise LSystemError(f"{what[t.name]} is not supported", line, t.col)
        if t.name == "all" and t.args is None:
            raise LSystemError("repetition pattern all has no pattern", line, t.col)
        if t.name in _REP and t.args is not None:
            m = _repetition(t, text, lex, where, depth)
            sub = m.sub.variables
            if m.sub.conds:
                raise LSystemError(f"value constraints inside a repetition {t.name}(...) are not supported", line,
                                   t.col)
            mods.append(m)
            names.extend(sub)
            continue
        if t.name in "[]":
            mods.append(PatternModule(t, LB if t.name == "[" else RB))
            continue
        params = [_param(a, t, line) for a in t.args or ()]
        kwds = bool(params) and params[-1][0] == "kwds"       # ``**kwds``: the named parameters, in a dict
        for q, (kind, v) in enumerate(params):
            if kind == "cond":
                v = v[0]
                conds.append(params[q][1][1])
                params[q] = ("var", v)
            if kind == "star" and q != len(params) - 1 - kwds:
                raise LSystemError(f"star parameter '*{v}' of {t.name} must be the last (before **kwds)", line,
                                   t.col)
            if kind == "kwds" and q != len(params) - 1:
                raise LSystemError(f"keyword parameter '**{v}' of {t.name} must be the last", line, t.col)
            if kind == "const":
                consts.append((len(names), v))
            names.append(None if kind == "const" else v)
        params = params[:len(params) - kwds]
        star = bool(params) and params[-1][0] == "star"
        if t.name in _ANY:
            name_var = bool(params) and not (star and len(params) == 1)
            mods.append(PatternModule(t, ANY, max(len(params) - name_var - star, 0), star, name_var, kwds=kwds))
        else:
            mods.append(PatternModule(t, MOD, len(params) - star, star, kwds=kwds))
    return Pattern(tuple(mods), tuple(names), tuple(consts), tuple(conds))


def _get_module(t: Token, where: str) -> PatternModule:
    if where in ("newleft", "newright"):
        raise LSystemError("$A(a) in a new context ('<<', '>>') is not supported", t.line, t.col)
    if t.args is None or len(t.args) != 2 or not _IDENT.match(t.args[1]) or t.args[0] in _ANY | _REP | {"[", "]"}:
        raise LSystemError("a $ pattern binds the module matched as $A(a): a module name and one variable",
                           t.line, t.col)
    return PatternModule(Token(t.args[0], None, t.line, t.col), MOD, node=True)


def _alternatives(t: Token, text: str, lex, where: str, depth: int) -> PatternModule:
    """``or(p1, p2, ...)``: the first alternative that matches binds its variables, the others' are None; an
    alternative ``None`` matches nothing (L-Py's ``RegExpMatcher``, ``isOr``)."""
    line = t.line
    if depth >= _MAX_NESTING:
        raise LSystemError(f"patterns nested more than {_MAX_NESTING} deep", line, t.col)
    if where == "pred":
        raise LSystemError("alternative pattern or(...) in a predecessor is not supported (it is in contexts)", line,
                           t.col)
    if not t.args:
        raise LSystemError("alternative pattern or() has no patterns", line, t.col)
    alts = []
    for a, col in zip(t.args, _arg_cols(text, t)):
        sub = Pattern((), (), ()) if a.strip() == "None" else \
            read_pattern(lex(a, line, col), text, lex, where=where, depth=depth + 1)
        if sub.conds:
            raise LSystemError("value constraints inside an alternative or(...) are not supported", line, col)
        alts.append(sub)
    return PatternModule(t, OR, alts=tuple(alts))


def _repetition(t: Token, text: str, lex, where: str, depth: int) -> PatternModule:
    line = t.line
    if depth >= _MAX_NESTING:
        raise LSystemError(f"repetition patterns nested more than {_MAX_NESTING} deep", line, t.col)
    if where == "pred":
        raise LSystemError(f"repetition pattern {t.name}(...) in a predecessor is not supported (it is in "
                           "contexts)", line, t.col)
    if not 1 <= len(t.args) <= 3:
        raise LSystemError(f"repetition pattern {t.name}(...) takes a pattern and at most two counts", line, t.col)
    cols = _arg_cols(text, t)
    sub = read_pattern(lex(t.args[0], line, cols[0]), text, lex, where=where, depth=depth + 1)
    if not sub.mods:
        raise LSystemError(f"repetition pattern {t.name}(...) has no pattern", line, t.col)
    bounds = []
    for a, col in zip(t.args[1:], cols[1:]):
        try:
            v = ast.literal_eval(a)
        except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
            v = None
        if type(v) is not int or v < 0:
            raise LSystemError(f"repetition count {a!r} must be an integer literal, at least 0", line, col)
        bounds.append(v)
    lo = bounds[0] if bounds else 0
    hi = bounds[-1] if bounds else _MAX_REPEAT                 # x(p, n): n times exactly (L-Py's maxiter = miniter)
    return PatternModule(t, REP, sub=sub, lo=lo, hi=hi)

"""L-string lexer (issue 23): module names and parameter expressions of L-Py strings (axiom, successors,
predecessor patterns).

A module name is the longest *known* name starting at the current character (declared with ``module``, a turtle
or L-Py predefined module such as ``@Tp`` or ``SetColor``); otherwise it is that single character, as L-Py reads
it (issue 33): ``FF(0.5)`` is ``F``, ``F(0.5)`` (issue 22), ``+(30)F`` is ``+(30)``, ``F``, ``IB(x)`` is ``I``,
``B(x)`` and an undeclared ``Apex(1)`` is ``A``, ``p``, ``e``, ``x(1)`` (declare it: ``module Apex``).
Parameters are kept as Python expression source; the engine evaluates them
in the grammar's namespace (angles stay in degrees: the engine never converts them).
"""
from __future__ import annotations

import functools
import re
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

__all__ = ["GETMODULE", "LPY_PREDEFINED", "LSystemError", "Token", "find_top", "lex", "split_top"]

#: Module names L-Py predefines (helpcard), matched as whole names before single characters; the turtle adds its
#: own (``TURTLE_MODULES``/``LPY_UNSUPPORTED``) at run time.
LPY_PREDEFINED = frozenset({
    "SB", "EB", "Pinpoint", "PinpointRel", "@R", "SetHead", "EulerAngles", "Left", "Right", "Up", "Down", "RollL",
    "RollR", "iRollL", "iRollR", "TurnAround", "@v", "RollToVert", "LeftReflection", "UpReflection",
    "HeadingReflection", "@M", "MoveTo", "MoveRel", "@2D", "StartScreenProjection", "@3D", "EndScreenProjection",
    "@Dd", "DivScale", "@Di", "MultScale", "@D", "SetScale", "nF", "@Gc", "StartGC", "@Ge", "EndGC", "BP", "EP",
    "PP", "LineTo", "OLineTo", "LineRel", "OLineRel", "@O", "Sphere", "@B", "Box", "@b", "Quad", "@o", "Circle",
    "@L", "Label", "surface", "~l", "@g", "PglShape", "Frame", "SetContour", "SectionResolution", "SetGuide",
    "EndGuide", "Sweep", "PositionOnGuide", "IncWidth", "DecWidth", "SetWidth", "IncColor", "DecColor", "SetColor",
    "InterpolateColors", "@Ts", "Elasticity", "@Tp", "Tropism", "?P", "GetPos", "?H", "GetHead", "?U", "GetUp",
    "?L", "GetLeft", "?R", "GetRight", "?F", "GetFrame", "TextureScale", "TextureUScale", "TextureVScale",
    "TextureVCoeff", "TextureTranslation", "TextureRotation", "TextureTransformation", "MouseIns", "Cut", "new",
    "newmodule", "=]", "?I", "GetIterator", "GetModule", "@Tr", "@Ms",
})

_SINGLE_TURTLE = frozenset("Ff+-&^/\\|$%[]_!;,~.{}")
#: L-Py's ``$`` (``GetModule``) followed by a name: ``$a`` in a successor, a token with args ``("a",)``, puts the
#: module object ``a`` in the string (``lpy_parser.cpp``, ``parseAModule``); a pattern's ``$A(a)`` (lexed ``$``,
#: ``A(a)``) is joined into a token with args ``("A", "a")`` by the rule reader. Otherwise ``$`` is the turtle's
#: roll to vertical (ABOP's ``$C(l, w)``, which L-Py cannot read, stays a roll and a module).
GETMODULE = "GetModule"
_IDENT = re.compile(r"[A-Za-z_]\w*")


class LSystemError(ValueError):
    """A grammar error (or a rule failing at run time) located in the grammar text.

    Attributes
    ----------
    line, column : int
        1-based position in the grammar text (0 where the position is unknown).
    """

    def __init__(self, message: str, line: int = 0, column: int = 0) -> None:
        self.line = int(line)
        self.column = int(column)
        self.detail = message
        super().__init__(f"line {self.line}, column {self.column}: {message}")


@dataclass(frozen=True)
class Token:
    """One module of an L-string: its name, its parameter expressions (source text; None without parentheses)
    and its 1-based line and column in the grammar."""

    name: str
    args: tuple[str, ...] | None
    line: int
    col: int

    @property
    def arity(self) -> int:
        return 0 if self.args is None else len(self.args)


def _skip_string(text: str, i: int, line: int, col0: int) -> int:
    q = text[i]
    j = i + 1
    while j < len(text) and text[j] != q:
        j += 2 if text[j] == "\\" else 1
    if j >= len(text):
        raise LSystemError(f"unterminated string {text[i:i + 12]!r}", line, col0 + i)
    return j + 1


def _depths(text: str, start: int = 0, line: int = 0, col0: int = 0,
            pairs: tuple[str, str] = ("([{", ")]}")) -> Iterator[tuple[int, str, int]]:
    """``(index, character, nesting depth after it)`` of every character from ``start`` on outside strings, the
    depth counting the opening and closing characters ``pairs``."""
    depth = 0
    i = start
    while i < len(text):
        c = text[i]
        if c in "\"'":
            i = _skip_string(text, i, line, col0)
            continue
        depth += (c in pairs[0]) - (c in pairs[1])
        yield i, c, depth
        i += 1


def _top_level(text: str, start: int = 0, pairs: tuple[str, str] = ("([{", ")]}")) -> Iterator[int]:
    """The indices from ``start`` on that lie at nesting depth 0 outside strings (brackets not included)."""
    return (i for i, c, d in _depths(text, start, pairs=pairs) if d == 0 and c not in "([{)]}")


def find_top(text: str, targets: Iterable[str], start: int = 0, *, modules: bool = False) -> tuple[int, str]:
    """First index (and which target) of one of ``targets`` at nesting depth 0 outside strings; (-1, "") if none.
    Longer targets are tried first at each position. ``modules``: ``text`` is an L-string (a rule header), whose
    ``[ ] { }`` are modules, only parentheses nesting."""
    order = sorted(targets, key=len, reverse=True)
    for i in _top_level(text, start, ("(", ")") if modules else ("([{", ")]}")):
        for t in order:
            if text.startswith(t, i):
                return i, t
    return -1, ""


def split_top(text: str, sep: str = ",") -> list[str]:
    """Split ``text`` at ``sep`` characters at nesting depth 0 outside strings."""
    if sep not in text:
        return [text]
    parts, beg = [], 0
    for i in _top_level(text):
        if text[i] == sep:
            parts.append(text[beg:i])
            beg = i + 1
    parts.append(text[beg:])
    return parts


def _close_paren(text: str, i: int, line: int, col0: int, name: str) -> int:
    """Index of the ``)`` matching the ``(`` at ``i``."""
    for j, c, d in _depths(text, i, line, col0):
        if d == 0:
            if c == ")":
                return j
            break
    raise LSystemError(f"unclosed '(' after module {name!r}", line, col0 + i)


def _module_at(text: str, i: int, by_first: dict, line: int, col: int) -> tuple[Token, int]:
    """The module starting at ``text[i]`` and the index after it."""
    c, n = text[i], len(text)
    cands = by_first.get(c)
    name = next((k for k in cands if text.startswith(k, i)), c) if cands else c
    j = i + len(name)
    args = None
    k = j
    while k < n and text[k] in " \t":          # L-Py's parseAModule: blanks may stand before the parameters
        k += 1
    if k < n and text[k] == "(":
        j = k
        k = _close_paren(text, j, line, col, name)
        inner = text[j + 1:k]
        args = () if not inner.strip() else tuple(a.strip() for a in split_top(inner))
        if any(not a for a in args):
            raise LSystemError(f"empty parameter in {text[i:k + 1]!r}", line, col + j)
        j = k + 1
    return Token(name, args, line, col + i), j


@functools.lru_cache(maxsize=64)
def _by_first(known: frozenset) -> dict[str, tuple[str, ...]]:
    """Multi-character names (``known`` and L-Py's predefined ones) by first character, longest first."""
    by_first: dict[str, list[str]] = {}
    for name in known | LPY_PREDEFINED:
        if len(name) > 1:
            by_first.setdefault(name[0], []).append(name)
    return {k: tuple(sorted(v, key=len, reverse=True)) for k, v in by_first.items()}


def lex(text: str, known: Iterable[str] = (), *, line: int = 1, col: int = 1,
        deadline: float | None = None) -> list[Token]:
    """Lex one line of L-string into :class:`Token` s.

    Parameters
    ----------
    text : str
        The L-string (one line; a ``#`` outside parentheses starts a comment).
    known : iterable of str
        Multi-character module names to match first (longest match wins).
    line, col : int
        Position of ``text[0]`` in the grammar, for tokens and error messages.
    deadline : float, optional
        ``time.monotonic()`` value after which lexing stops (a grammar's time budget).

    Raises
    ------
    LSystemError
        For an unbalanced parenthesis, an unterminated string or the deadline passed, with line and column.
    """
    if not isinstance(text, str):
        raise LSystemError(f"an L-string must be a str, got {type(text).__name__}", line, col)
    by_first = _by_first(known if isinstance(known, frozenset) else frozenset(known))
    out: list[Token] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
            continue
        if c == "#":
            break
        if c == ")" or c == "(":
            raise LSystemError(f"unexpected {c!r} (a parameter list must follow a module name)", line, col + i)
        k = i + 1
        while c == "$" and k < n and text[k] in " \t":
            k += 1
        ident = _IDENT.match(text, k) if c == "$" else None
        after = ident.end() if ident else 0
        while ident and after < n and text[after] in " \t":
            after += 1
        if ident and not (after < n and text[after] == "("):  # L-Py's GetModule ``$a`` (``$A(...)``: '$', A(...))
            out.append(Token(GETMODULE, (ident.group(),), line, col + i))
            j = ident.end()
        else:
            tok, j = _module_at(text, i, by_first, line, col)
            out.append(tok)
        i = j
        if deadline is not None and not len(out) & 4095 and time.monotonic() > deadline:
            raise LSystemError(f"time budget exceeded reading a string of {n:,} characters", line, col + i)
    return out

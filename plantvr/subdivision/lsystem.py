"""LST / bracketed turtle string → branch graph (spec 001_subdivision §1.4, §1.5, §7.1), read and drawn by the
L-system engine (issue 30: one front end).

Two notations are accepted, also mixed in one string:

* the report's LST operations ``SB() EB() MovRel3f(x,y,z) RotRel3f(angle,x,y,z) Cylinder(r0,r1,L)``
  (optional ``LST <version>`` header, several operations per line, empty lines ignored, names matched
  case-insensitively, spec §1.4 [INFERRED] 6);
* the classic bracketed turtle symbols ``[ ]`` (= ``SB()``/``EB()``), ``F`` / ``F(L)`` / ``F(L,r)`` (a
  cylinder followed by a move to its end), ``f`` / ``f(L)`` (a move without drawing: the next ``F`` starts a new
  root branch there, as L-Py's turtle does), ``+ -`` (turn about the local up axis), ``& ^`` (pitch, ``&`` down)
  and ``/ \\`` (roll about the heading) as L-Py's turtle turns, and ``|`` (turn around); a turn symbol takes its
  angle in degrees as L-Py does, ``+(30)``, else ``angle``.

The string is lexed by :func:`plantvr.lsystem.lexer.lex` (L-Py's reading: ``FF(0.5)`` is ``F``, ``F(0.5)``; an
unknown ``Foo(1)`` is ``F``, ``o``, ``o(1)``) and drawn by L-Py's turtle (:func:`plantvr.lsystem.turtle_nodes`);
this module only translates the LST operations into turtle modules and the turtle's nodes into branches.

Angles are in degrees everywhere (issue 23), ``RotRel3f`` included; ``angle_unit="radians"`` reads the
Yggdrasil report's LST sample, whose ``RotRel3f`` angles are radians (spec §1.4 [INFERRED] 5). The turtle
heads +Y (its up axis +Z), moves are in the local frame and rotations post-multiply (spec §1.4 [INFERRED] 2–4).
"""
from __future__ import annotations

import math
import re
import warnings

import numpy as np

from plantvr._validation import MAX_COORD, check_choice, check_range
from plantvr.lsystem import ModuleString, turtle_nodes
from plantvr.lsystem.lexer import LSystemError, lex

from .graph import _EPS, MIN_RADIUS, BranchGraph

__all__ = ["parse_lsystem"]

#: Longest L-system string accepted (characters).
MAX_TEXT = 10_000_000
#: The LST operations (spec §1.4 Table 4.2) -> their argument count.
_LST = {"SB": 0, "EB": 0, "MovRel3f": 3, "RotRel3f": 4, "Cylinder": 3}
_LST_NAME = re.compile(r"(?i)(sb|eb|movrel3f|rotrel3f|cylinder)(?=\s*\()")
_TURNS = frozenset("+-&^/\\")
#: The turtle symbols -> their most arguments and its wording in errors.
_ARITY = {"F": (2, "0-2 arguments (length, radius)"), "f": (1, "0-1 arguments (length)"), "|": (0, "no arguments"),
          "[": (0, "no arguments"), "]": (0, "no arguments"),
          **{t: (1, "0-1 arguments (angle in degrees)") for t in _TURNS}}
#: The turtle's start frame: heading +Y, up +Z (spec §1.4 [INFERRED] 2), L-Py's ``SetHead(h, u)``.
_START = ("SetHead", (0.0, 1.0, 0.0, 0.0, 0.0, 1.0))


def _canonical(text: str) -> str:
    """``text`` with the LST names in their canonical case and each ``(`` moved before the blanks that precede it
    (``F (1)`` is ``F(1)``, as the report's files may write it); the length and every symbol's position kept."""
    canon = {k.lower(): k for k in _LST}
    text = _LST_NAME.sub(lambda m: canon[m.group(1).lower()], text)
    return re.sub(r"(?<=\S)(\s+)\(", lambda m: "(" + m.group(1), text)


def _numbers(name: str, args: tuple[str, ...], at: int) -> list[float]:
    """A token's parameters as numbers: finite, within the coordinate bound."""
    src = f"{name}({', '.join(args)})"
    try:
        vals = [float(v) for v in args]
    except ValueError:
        raise ValueError(f"text: bad numeric argument in {src!r} at position {at}") from None
    if not all(map(math.isfinite, vals)):
        raise ValueError(f"text: non-finite argument in {src!r} at position {at}")
    if any(abs(v) > MAX_COORD for v in vals):
        raise ValueError(f"text: argument in {src!r} at position {at} must lie in [-{MAX_COORD:g}, {MAX_COORD:g}]")
    return vals


def _aligned(v, inner: list) -> list:
    """Turtle modules that turn the heading onto ``v`` (in the local frame: x = -left, y = heading, z = up), run
    ``inner`` and turn back: ``+(a) ^(b) inner ^(-b) +(-a)``, where ``Rz(a) Rx(b)`` maps y onto ``v``."""
    a = math.degrees(math.atan2(-v[0], v[1]))
    b = math.degrees(math.atan2(v[2], math.hypot(v[0], v[1])))
    turn = [(s, x) for s, x in (("+", a), ("^", b)) if x]
    return [(s, (x,)) for s, x in turn] + inner + [(s, (-x,)) for s, x in reversed(turn)]


def _move(d: np.ndarray) -> list:
    """Turtle modules of a move by ``d`` in the local frame (``MovRel3f``): an ``f`` along the heading, or one along
    ``d`` between turns that cancel."""
    if d[0] == 0 and d[2] == 0:
        return [("f", (float(d[1]),))]
    return _aligned(d, [("f", (float(np.linalg.norm(d)),))])


def _translate(text: str, at0: int, angle: float, step: float, radius: float, angle_unit: str):
    """Lex ``text[at0:]`` and translate it into turtle modules.

    Returns the modules and, per ``Cylinder``/``F`` (one turtle ``F(L, end radius)`` each, in order): its
    character position, start radius and LST parent (spec §1.4: the current branch; -1 at the start or after an
    ``f``).
    ``d`` is the LST position minus the turtle's in the local frame: a ``Cylinder`` draws without moving (the
    turtle's ``F`` moves) and ``MovRel3f`` moves without ending the branch (the turtle's ``f`` does); ``d`` is
    caught up before a turn or a branch, so a branch that starts away from its parent's end is a turtle root.
    """
    try:
        tokens = lex(_canonical(text[at0:]), frozenset(_LST), col=at0 + 1)
    except LSystemError as exc:
        raise ValueError(f"text: {exc.detail} at position {exc.column - 1}") from None
    out = [_START]
    where, r0, parent = [], [], []
    d = np.zeros(3)
    cur = -1
    stack: list[tuple[np.ndarray, int, int]] = []
    for tok in tokens:
        name, at, n = tok.name, tok.col - 1, tok.arity
        if name not in _LST and name not in _ARITY:
            raise ValueError(f"text: unknown symbol {text[at:at + 12]!r} at position {at}")
        vals = _numbers(name, tok.args or (), at)
        if name in _LST and n != _LST[name]:
            raise ValueError(f"text: {name} takes {_LST[name]} arguments, got {n} at position {at}")
        if name in _ARITY and n > _ARITY[name][0]:
            raise ValueError(f"text: {name} takes {_ARITY[name][1]}, got {n} at position {at}")
        if name in ("[", "SB"):
            stack.append((d.copy(), cur, at))
            out.append("[")
        elif name in ("]", "EB"):
            if not stack:
                raise ValueError(f"text: unbalanced brackets, ']' / EB() at position {at} has no matching '['")
            d, cur, _ = stack.pop()
            out.append("]")
        elif name == "MovRel3f":
            d = d + vals
        elif name == "f":
            out.append(("f", (vals[0] if vals else step,)))
            cur = -1        # the next branch is a root, not a §1.4 gap: §7.1 reads only F, + - and [ ], f is L-Py's
        elif name in ("F", "Cylinder"):
            if name == "Cylinder":
                a, b, L = vals
            else:
                a = b = vals[1] if n > 1 else radius
                L = vals[0] if vals else step
            if not (a > 0 and b > 0):
                raise ValueError(f"text: branch at position {at} has a non-positive radius ({a}, {b})")
            if not L > 0:
                raise ValueError(f"text: zero-length branch at position {at} (length {L})")
            if d.any():
                out += _move(d)
            out.append(("F", (L, b)))
            d = np.array([0.0, -L, 0.0]) if name == "Cylinder" else np.zeros(3)
            where.append(at)
            r0.append(a)
            parent.append(cur)
            cur = len(where) - 1
        else:                                           # a turn: the turtle first catches up with the position
            if d.any():
                out += _move(d)
                d = np.zeros(3)
            if name == "RotRel3f":
                if not any(vals[1:]):
                    raise ValueError(f"text: RotRel3f axis is zero at position {at}")
                deg = math.degrees(vals[0]) if angle_unit == "radians" else vals[0]
                out += _aligned(vals[1:], [("/", (math.remainder(deg, 360.0),))])
            else:
                out.append(name if name == "|" else (name, (vals[0] if vals else angle,)))
    if stack:
        raise ValueError(f"text: unbalanced brackets, '[' / SB() at position {stack[-1][2]} is never closed")
    return out, where, r0, parent


def parse_lsystem(text: str, *, angle: float = 25.0, step: float = 1.0, radius: float = 0.1,
                  angle_unit: str = "degrees", strict: bool = False) -> BranchGraph:
    """Parse an LST or bracketed turtle string into a :class:`~plantvr.subdivision.graph.BranchGraph`.

    Parameters
    ----------
    text : str
        The L-system string (spec §1.4 LST operations and/or turtle symbols, see the module docstring).
    angle : float
        Turn angle of the single-character turtle symbols without an argument, in degrees.
    step : float
        Length of ``F``/``f`` without an argument.
    radius : float
        Radius of ``F`` without a radius argument.
    angle_unit : {"degrees", "radians"}
        Unit of ``RotRel3f`` angles: degrees, as everywhere else (issue 23); ``"radians"`` for the report's LST
        sample (spec §1.4 [INFERRED] 5).
    strict : bool
        If True a branch that does not start at its parent's end (a ``MovRel3f`` gap) raises; otherwise its start
        is snapped to the parent's end (its tip stays put) with a warning (spec §1.4 last item, V1, ERRATUM A20).
        After an ``f`` the next branch is a root and has no parent end to meet (L-Py's turtle; spec §7.1 reads
        only ``F``, ``+ -`` and brackets, so ``f`` is the turtle's: a move that ends the branch).

    Returns
    -------
    BranchGraph
        Branches in depth-first order (the order of the ``Cylinder``/``F`` symbols); a forest when an ``f``
        precedes an ``F`` (``parent`` -1 for each root).

    Raises
    ------
    ValueError
        For an unknown symbol, a wrong argument count, unbalanced brackets, a zero-length or zero-radius
        branch, or (strict) a start/end gap; the message gives the character position in ``text``.

    References
    ----------
    .. [1] Pieterse, Yggdrasil report §4.1.5–4.1.6, Table 4.2, Fig. 4.6; spec 001 ERRATUM A20.

    Examples
    --------
    >>> g = parse_lsystem("F(2,0.2)[+F(1,0.1)][-F(1,0.1)]F(1,0.15)", angle=40)
    >>> len(g), g.parent.tolist()
    (4, [-1, 0, 0, 0])
    >>> parse_lsystem("F f(1) F").parent.tolist()
    [-1, -1]
    """
    if not isinstance(text, str):
        raise ValueError(f"text must be a str, got {type(text).__name__}")
    if len(text) > MAX_TEXT:
        raise ValueError(f"text must have at most {MAX_TEXT} characters, got {len(text)}")
    angle_unit = check_choice("angle_unit", angle_unit, ("degrees", "radians"))
    angle = check_range("angle", angle, -360.0, 360.0)
    step = check_range("step", step, _EPS, MAX_COORD, low_open=True)
    radius = check_range("radius", radius, MIN_RADIUS, MAX_COORD)
    if "#" in text:                                     # the lexer's comment: not an LST symbol
        at = text.index("#")
        raise ValueError(f"text: unknown symbol {text[at:at + 12]!r} at position {at}")
    head = re.match(r"\s*LST\s+[0-9.]+", text)
    modules, where, r0, parent = _translate(text, head.end() if head else 0, angle, step, radius, angle_unit)
    if not where:
        raise ValueError("text: the string contains no branch (no Cylinder or F symbol)")
    try:
        nodes = turtle_nodes(ModuleString.from_modules(modules))
    except ValueError as exc:                           # a node beyond the coordinate bound
        raise ValueError(f"text: the turtle's drawing is refused: {exc}") from None
    tree = nodes.tree
    node = np.flatnonzero(tree.parent >= 0)             # one node per drawn F, at its end, in string order
    if len(node) < len(where):
        f_at = np.flatnonzero([isinstance(m, tuple) and m[0] == "F" for m in modules])
        b = int(np.flatnonzero(~np.isin(f_at, nodes.module[node]))[0])
        raise ValueError(f"text: zero-length branch at position {where[b]} (too short for the turtle to draw)")
    start, end = tree.pos[tree.parent[node]], tree.pos[node]
    parent = np.array(parent, np.int64)
    child = np.flatnonzero(parent >= 0)                 # spec §1.4: start == the parent's end, or a gap
    gap = np.linalg.norm(start[child] - end[parent[child]], axis=1)
    away = gap > 1e-9 * np.maximum(1.0, np.abs(start[child]).max(axis=1))
    for b, dist in zip(child[away], gap[away]):
        msg = f"text: branch at position {where[b]} starts {dist:.6g} away from the end of its parent branch"
        if strict:
            raise ValueError(msg)
        warnings.warn(msg + "; start snapped to the parent's end (tip kept)", stacklevel=2)
    start[child] = end[parent[child]]
    short = child[np.linalg.norm(end[child] - start[child], axis=1) <= 1e-12]
    if short.size:
        raise ValueError(f"text: zero-length branch at position {where[short[0]]} after snapping to its parent")
    g = BranchGraph(start, end, np.array(r0, float), tree.radius[node].astype(float), parent)
    try:
        return g.validate()
    except ValueError as exc:
        raise ValueError(f"text: {exc}") from None

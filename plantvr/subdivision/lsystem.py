"""LST / bracketed turtle string → branch graph (spec 001_subdivision §1.4, §1.5, §7.1).

Two notations are accepted, also mixed in one string:

* the report's LST operations ``SB() EB() MovRel3f(x,y,z) RotRel3f(angle,x,y,z) Cylinder(r0,r1,L)``
  (optional ``LST <version>`` header, several operations per line, empty lines ignored);
* the classic bracketed turtle symbols ``[ ]`` (= ``SB()``/``EB()``), ``F`` / ``F(L)`` / ``F(L,r)`` (a
  cylinder followed by a move to its end), ``f`` / ``f(L)`` (a move without drawing: the next ``F`` starts a new
  root branch there, as L-Py's turtle does, :func:`plantvr.lsystem.turtle.turtle`), ``+ -`` (turn about the local
  z axis),
  ``& ^`` (pitch about local x), ``/ \\`` (roll about the local up axis y) and ``|`` (turn around); a turn
  symbol takes its angle in degrees as L-Py does, ``+(30)``, else ``angle``.

Angles are in degrees everywhere (issue 23), ``RotRel3f`` included; ``angle_unit="radians"`` reads the
Yggdrasil report's LST sample, whose ``RotRel3f`` angles are radians (spec §1.4 [INFERRED] 5).

This is the Yggdrasil turtle (up vector +Y, post-multiplied rotations, LST operations, gap snapping, character
positions in errors); L-Py's PlantGL turtle (heading +Z) is :func:`plantvr.lsystem.turtle.turtle`.

The turtle's up vector is +Y, moves are in the local frame and rotations post-multiply (spec §1.4
[INFERRED] items 2–4).
"""
from __future__ import annotations

import re
import warnings

import numpy as np

from plantvr._validation import MAX_COORD, check_choice, check_range

from .graph import _EPS, MIN_RADIUS, BranchGraph

__all__ = ["parse_lsystem"]

_TOKEN = re.compile(r"\s*(?:([A-Za-z_]\w*)\s*\(([^()]*)\)|([+\-&^/\\])\s*\(([^()]*)\)|([\[\]Ff+\-&^/\\|]))")
#: Longest L-system string accepted (characters).
MAX_TEXT = 10_000_000
_ARITY = {"sb": (0,), "eb": (0,), "movrel3f": (3,), "rotrel3f": (4,), "cylinder": (3,)}


def _glued_prefix(name: str) -> bool:
    """Whether ``name`` is single-character ``F``/``f`` symbols glued to a known module name (``FF``, ``fFCylinder``),
    so that ``name(...)`` reads as those symbols followed by the module."""
    low = name.lower()
    for key in (*_ARITY, "f"):
        if len(low) > len(key) and low.endswith(key) and all(c in "Ff" for c in name[:len(name) - len(key)]):
            return True
    return False


def _numbers(m: re.Match, args: str, at: int) -> list[float]:
    """The comma-separated numbers of a token's ``(args)``: finite, within the coordinate bound."""
    vals: list[float] = []
    if args.strip():
        try:
            vals = [float(v) for v in args.split(",")]
        except ValueError:
            raise ValueError(f"text: bad numeric argument in {m.group(0).strip()!r} at position {at}") from None
    if not all(np.isfinite(vals)):
        raise ValueError(f"text: non-finite argument in {m.group(0).strip()!r} at position {at}")
    if any(abs(v) > MAX_COORD for v in vals):
        raise ValueError(f"text: argument in {m.group(0).strip()!r} at position {at} must lie in "
                         f"[-{MAX_COORD:g}, {MAX_COORD:g}]")
    return vals


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    a = axis / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


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
        is snapped to the parent's end (its tip stays put) with a warning (spec V1, ERRATUM A20). After an ``f``
        the next branch is a root and has no parent end to meet.

    Returns
    -------
    BranchGraph
        Branches in depth-first order (the order of the ``Cylinder``/``F`` symbols).

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
    """
    if not isinstance(text, str):
        raise ValueError(f"text must be a str, got {type(text).__name__}")
    if len(text) > MAX_TEXT:
        raise ValueError(f"text must have at most {MAX_TEXT} characters, got {len(text)}")
    angle_unit = check_choice("angle_unit", angle_unit, ("degrees", "radians"))
    turn = np.deg2rad(check_range("angle", angle, -360.0, 360.0))
    step = check_range("step", step, _EPS, MAX_COORD, low_open=True)
    radius = check_range("radius", radius, MIN_RADIUS, MAX_COORD)
    body = text
    head = re.match(r"\s*LST\s+[0-9.]+", body)
    pos0 = head.end() if head else 0

    p = np.zeros(3)
    R = np.eye(3)
    cur = -1
    stack: list[tuple[np.ndarray, np.ndarray, int, int]] = []
    start, end, r0, r1, parent, where = [], [], [], [], [], []

    def cylinder(a: float, b: float, L: float, at: int) -> None:
        nonlocal cur
        if not (a > 0 and b > 0):
            raise ValueError(f"text: branch at position {at} has a non-positive radius ({a}, {b})")
        if np.abs(p).max() > MAX_COORD:
            raise ValueError(f"text: branch at position {at} starts at {p.tolist()}, outside "
                             f"[-{MAX_COORD:g}, {MAX_COORD:g}]")
        if not L > 0:
            raise ValueError(f"text: zero-length branch at position {at} (length {L})")
        s = p.copy()
        e = s + L * (R @ np.array([0.0, 1.0, 0.0]))
        if cur >= 0 and np.linalg.norm(s - end[cur]) > 1e-9 * max(1.0, np.abs(s).max()):
            msg = (f"text: branch at position {at} starts {np.linalg.norm(s - end[cur]):.6g} away from the end "
                   f"of its parent branch")
            if strict:
                raise ValueError(msg)
            warnings.warn(msg + "; start snapped to the parent's end (tip kept)", stacklevel=3)
            s = end[cur].copy()
            if np.linalg.norm(e - s) <= 1e-12:
                raise ValueError(f"text: zero-length branch at position {at} after snapping to its parent")
        start.append(s)
        end.append(e)
        r0.append(a)
        r1.append(b)
        parent.append(cur)
        where.append(at)
        cur = len(start) - 1

    i = pos0
    n = len(body)
    while i < n:
        m = _TOKEN.match(body, i)
        if m is None:
            j = i
            while j < n and body[j].isspace():
                j += 1
            if j >= n:
                break
            raise ValueError(f"text: unknown symbol {body[j:j + 12]!r} at position {j}")
        at = m.start(1) if m.group(1) else (m.start(3) if m.group(3) else m.start(5))
        name, args, ch = m.group(1), m.group(2), m.group(3) or m.group(5)
        i = m.end()
        turn_here = turn
        if m.group(3):  # "+(30)": a turn symbol takes its angle in degrees, as L-Py
            vals = _numbers(m, m.group(4), at)
            if len(vals) > 1:
                raise ValueError(f"text: {ch} takes 0-1 arguments (angle in degrees), got {len(vals)} at "
                                 f"position {at}")
            if vals:
                turn_here = np.deg2rad(vals[0])
        if name is not None and name.lower() not in _ARITY and name.lower() != "f" and _glued_prefix(name):
            # a module name followed by "(" is read as that module: "FF(0.5)" is F, F(0.5); the leading
            # single-character symbol is taken alone and the rest of the name is lexed again
            ch, name = name[0], None
            i = at + 1
        if name is not None:
            key = name.lower()
            vals = _numbers(m, args, at)
            if key in ("f",):
                if len(vals) not in (0, 1, 2):
                    raise ValueError(f"text: {name} takes 0-2 arguments (length, radius), got {len(vals)} at "
                                     f"position {at}")
                L = vals[0] if vals else step
                if name == "F":
                    rr = vals[1] if len(vals) > 1 else radius
                    cylinder(rr, rr, L, at)
                else:
                    cur = -1                                # a gap: the next branch is a root
                p = p + R @ np.array([0.0, L, 0.0])
                continue
            if key not in _ARITY:
                raise ValueError(f"text: unknown symbol {name!r} at position {at}")
            if len(vals) not in _ARITY[key]:
                raise ValueError(f"text: {name} takes {_ARITY[key][0]} arguments, got {len(vals)} at position {at}")
            if key == "sb":
                ch = "["
            elif key == "eb":
                ch = "]"
            elif key == "movrel3f":
                p = p + R @ np.array(vals)
                continue
            elif key == "rotrel3f":
                ax = np.array(vals[1:])
                if not np.linalg.norm(ax) > 0:
                    raise ValueError(f"text: RotRel3f axis is zero at position {at}")
                a = vals[0] if angle_unit == "radians" else np.deg2rad(vals[0])
                R = R @ _axis_angle(ax, a)
                continue
            else:  # cylinder
                cylinder(vals[0], vals[1], vals[2], at)
                continue
        if ch == "[":
            stack.append((p.copy(), R.copy(), cur, at))
        elif ch == "]":
            if not stack:
                raise ValueError(f"text: unbalanced brackets, ']' / EB() at position {at} has no matching '['")
            p, R, cur, _ = stack.pop()
        elif ch == "F" or ch == "f":
            if ch == "F":
                cylinder(radius, radius, step, at)
            else:
                cur = -1
            p = p + R @ np.array([0.0, step, 0.0])
        elif ch in "+-":
            R = R @ _axis_angle(np.array([0.0, 0.0, 1.0]), turn_here if ch == "+" else -turn_here)
        elif ch in "&^":
            R = R @ _axis_angle(np.array([1.0, 0.0, 0.0]), turn_here if ch == "&" else -turn_here)
        elif ch in "/\\":
            R = R @ _axis_angle(np.array([0.0, 1.0, 0.0]), turn_here if ch == "/" else -turn_here)
        elif ch == "|":
            R = R @ _axis_angle(np.array([0.0, 0.0, 1.0]), np.pi)
    if stack:
        raise ValueError(f"text: unbalanced brackets, '[' / SB() at position {stack[-1][3]} is never closed")
    if not start:
        raise ValueError("text: the string contains no branch (no Cylinder or F symbol)")
    g = BranchGraph(np.array(start), np.array(end), np.array(r0, float), np.array(r1, float),
                    np.array(parent, np.int64))
    try:
        return g.validate()
    except ValueError as exc:
        raise ValueError(f"text: {exc}") from None

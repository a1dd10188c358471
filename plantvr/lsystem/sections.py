"""Cross sections and sweeps (issue 33): ``SetContour``, ``Sweep`` and the tubes they shape, as PlantGL's turtle.

PlantGL's turtle keeps a cross section (``SetContour(curve[, ccw])``, a circle by default), saved by ``[`` and
restored by ``]`` with the rest of its state (``TurtleParam::copy``):

* a generalized cylinder (``@Gc`` / ``StartGC`` ... ``@Ge`` / ``EndGC``) is the section of the moment it started
  (``initial.crossSection``) swept along its points; its ``F`` draw no cylinder of their own (points of the tube);
* outside one, an ``F`` (or ``nF``) drawn with a section set is that section swept along the move
  (``PglTurtleDrawer::smallSweep``); PlantVR draws it as a tube of its own, ``@Gc F @Ge``;
* ``Sweep(path, section, length, dl, radius[, radiusvariation])`` is ``SetGuide(path, length)``,
  ``SetContour(section)`` and ``nF(length, dl, radius, radiusvariation)`` (``Turtle::sweep``).

:func:`apply_sections` reads the string once: the string the turtle kernel draws (tubes added, sweeps expanded;
with, per new module, the one it comes from), the section of every tube by the module that closes it, and whether
each module draws inside a tube.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .modules import ModuleString

__all__ = ["CONTOUR_POINTS", "Sections", "apply_sections"]

#: Points a section curve is sampled at (PlantGL's default section resolution is 8; a leaf profile needs more).
CONTOUR_POINTS = 33
_STARTS, _ENDS, _MOVES = ("@Gc", "StartGC"), ("@Ge", "EndGC"), ("F", "nF")


@dataclass(frozen=True)
class Sections:
    """What :func:`apply_sections` read.

    Attributes
    ----------
    string : ModuleString
        The string to draw (the one given when it has no section, sweep or tube).
    source : (n,) int64 ndarray or None
        Index in the given string of each module of :attr:`string` (None: the same string).
    contour : dict of int to ndarray
        The (CONTOUR_POINTS, 2) section of each tube, by the index (in the given string) of the module that closes
        it (its ``@Ge``, the ``]`` ending its branch, the ``F``/``nF``/``Sweep`` drawn as a tube, -1: the string's
        end); a tube of the default circle is not listed.
    in_tube : (n_given,) bool ndarray or None
        Per module of the given string: whether a move there is drawn by a tube, not as a cylinder.
    """

    string: ModuleString
    source: np.ndarray | None
    contour: dict
    in_tube: np.ndarray | None

    def tube_contours(self, kind: np.ndarray, closing: np.ndarray, tube_kind: int) -> tuple | None:
        """The section of each shape record (None for the circle and for other kinds), from the records' kinds and
        closing modules."""
        if not self.contour:
            return None
        return tuple(self.contour.get(int(m)) if k == tube_kind else None
                     for k, m in zip(kind.tolist(), closing.tolist()))


def apply_sections(string: ModuleString) -> Sections:
    """Read ``string``'s sections, sweeps and tubes (see the module docstring)."""
    names = string.names
    if not any(n in names for n in (*_STARTS, "SetContour", "Sweep")):
        return Sections(string, None, {}, None)
    sid = {n: k for k, n in enumerate(names)}
    kinds = {sid[n]: n for n in (*_STARTS, *_ENDS, *_MOVES, "SetContour", "Sweep", "[", "]") if n in sid}
    cur = init = None                          # the section now; the one of the running tube
    on = False
    stack: list = []
    contour: dict = {}
    in_tube = np.zeros(len(string), bool)
    out: list = []
    src: list = []
    changed = False
    for i, s in enumerate(string.ids.tolist()):
        kind = kinds.get(s)
        if kind is None:
            out.append(i)
            src.append(i)
            in_tube[i] = on
            continue
        name, vals = string.module(i)
        if kind == "SetContour":
            cur = _contour_points(vals, i)
        elif kind in _STARTS:
            on, init = True, cur
        elif kind in _ENDS:
            if on and init is not None:
                contour[i] = init
            on = False
        elif kind == "[":
            stack.append((cur, init, on))
        elif kind == "]":
            if on and init is not None:
                contour[i] = init
            if stack:
                cur, init, on = stack.pop()
        if kind == "Sweep":
            if len(vals) < 5:
                raise ValueError(f"string: Sweep at index {i} needs (path, section, length, dl, radius"
                                 f"[, radiusvariation]), got {len(vals)} parameters")
            cur = _contour_points(vals[1:2], i)
            nf = ("nF", tuple(vals[2:6]))
            body = [("SetGuide", (vals[0], vals[2])), ("SetContour", (vals[1],))]
            body += [nf] if on else [("@Gc", ()), nf, ("@Ge", ())]
            if not on:
                contour[i] = cur
            out.extend(body)
            src.extend([i] * len(body))
            in_tube[i] = True
            changed = True
        elif kind in _MOVES and cur is not None and not on:      # PlantGL's smallSweep: the section along the move
            contour[i] = cur
            out.extend([("@Gc", ()), i, ("@Ge", ())])
            src.extend([i, i, i])
            in_tube[i] = True
            changed = True
        else:
            out.append(i)
            src.append(i)
            in_tube[i] = in_tube[i] or (on and kind in _MOVES)
    if on and init is not None:
        contour[-1] = init
    if not changed:
        return Sections(string, None, contour, in_tube)
    mods = [string.module(m) if isinstance(m, int) else m for m in out]
    return Sections(ModuleString.from_modules(mods, names=names), np.asarray(src, np.int64), contour, in_tube)


def _contour_points(vals: tuple, i: int) -> np.ndarray:
    """(CONTOUR_POINTS, 2) points of a section curve (a PlantGL-like 2-D curve: ``getPointAt`` on its knots)."""
    curve = vals[0] if vals else None
    get = getattr(curve, "getPointAt", None)
    if get is None:
        raise ValueError(f"string: SetContour at index {i} needs a 2-D curve (NurbsCurve2D, Polyline2D, ...), got "
                         f"{type(curve).__name__}")
    lo = float(getattr(curve, "firstKnot", 0.0))
    hi = float(getattr(curve, "lastKnot", 1.0))
    pts = np.array([list(get(u))[:2] for u in np.linspace(lo, hi, CONTOUR_POINTS)], float)
    if pts.shape != (CONTOUR_POINTS, 2) or not np.all(np.isfinite(pts)):
        raise ValueError(f"string: SetContour at index {i}: the curve's points must be finite 2-D points")
    return pts

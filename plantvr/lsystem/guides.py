"""Turtle guides: ``SetGuide``, ``EndGuide`` and ``PositionOnGuide``, as PlantGL's turtle follows a path curve.

PlantGL's ``Turtle::_applyGuide`` (``src/cpp/plantgl/algo/modelling/turtle.cpp``, ``turtlepath.cpp``) turns the
turtle before each ``F``/``f`` of positive length so that it heads to the guide's point ``length`` further along
the curve (the curve scaled to the guide's total length, arc-length parametrised; past its end, along the end
tangent), sets that move's length to the distance between the two points, and after the move turns it to the
curve's local tangent. A 2-D curve lies in the turtle's heading/up plane (``yorientation``: heading/left plane;
``ccw`` mirrors it); a 3-D curve is followed in the turtle's frame, with the curve's own frame carried along.

Every turn depends only on the guide's state (position on the curve, last tangent and, in 3-D, the curve frame),
never on the turtle's frame, so :func:`apply_guides` runs before the turtle kernel: it walks the string with a
stack of guide states (``[``/``]`` copy and restore the guide, as ``TurtleParam::copy``), replaces each guided
move by its turns and its new length (``&`` about the left axis, ``+`` about up, ``/`` roll; ``nF`` is expanded
into its steps) and returns, with the new string, the index of the module each new module comes from.
"""
from __future__ import annotations

import math

import numpy as np

from plantvr._validation import MAX_COORD as _MAX_COORD

from .modules import ModuleString

__all__ = ["GUIDE_MODULES", "apply_guides"]

GUIDE_MODULES = ("SetGuide", "EndGuide", "PositionOnGuide")
_EPS = 1e-6                                           # PlantGL's GEOM_EPSILON
_STRIDE = 60
_MAX_STEPS = 10 ** 7                                   # the most steps an nF may take along a guide


def _knots(curve) -> tuple[float, float]:
    first = curve.getFirstKnot() if hasattr(curve, "getFirstKnot") else curve.firstKnot
    last = curve.getLastKnot() if hasattr(curve, "getLastKnot") else curve.lastKnot
    return float(first), float(last)


class _Guide:
    """One guide's state (PlantGL's ``Turtle2DPath`` / ``Turtle3DPath``): the curve, its arc-length table, the
    scale from curve length to the guide's ``length``, the position parameter ``t`` in [0, 1], the last point and
    tangent (and, in 3-D, the curve frame's left and up)."""

    def __init__(self, curve, length: float, yorientation: bool = False, ccw: bool = False) -> None:
        if not hasattr(curve, "getPointAt"):
            raise ValueError(f"SetGuide: the guide must be a PlantGL curve, got {type(curve).__name__}")
        self.curve = curve
        self.fk, self.lk = _knots(curve)
        stride = int(getattr(curve, "stride", _STRIDE) or _STRIDE)
        u = np.linspace(self.fk, self.lk, stride + 1)
        pts = np.array([self.point(x) for x in u])
        self.dim = pts.shape[1]
        if self.dim not in (2, 3) or not np.isfinite(pts).all():
            raise ValueError(f"SetGuide: the guide's points must be finite 2-D or 3-D points, got {pts[0]!r}")
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)   # LineicModel::getArcLengthToUMapping
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.actual = float(cum[-1])
        if not self.actual > 0 or not 0 < length <= _MAX_COORD:
            raise ValueError(f"SetGuide: the guide needs a curve and a length > 0, got curve length "
                             f"{self.actual!r} and length {length!r}")
        self.s, self.u = cum / self.actual, u
        self.total = float(length)
        self.scale = self.total / self.actual
        self.t = 0.0
        self.last = self.point(self.fk)
        self.yorient, self.ccw = bool(yorientation), bool(ccw)
        if self.dim == 2:
            h = (0.0, 1.0) if self.yorient else (1.0, 0.0)
            self.head = -np.array(h) if self.ccw else np.array(h)
        else:
            self.head, self.up, self.left = np.array([0.0, 0, 1]), np.array([1.0, 0, 0]), np.array([0.0, -1, 0])

    def copy(self) -> _Guide:
        g = object.__new__(_Guide)
        g.__dict__.update({k: (v.copy() if isinstance(v, np.ndarray) and k not in ("s", "u") else v)
                           for k, v in self.__dict__.items()})
        return g

    def point(self, u: float) -> np.ndarray:
        return np.asarray(list(self.curve.getPointAt(u)), float)

    def u_at(self, t: float) -> float:
        return float(np.interp(t, self.s, self.u))

    def tangent(self, u: float) -> np.ndarray:
        """The curve's derivative at ``u`` (central differences; one-sided at the ends)."""
        h = 1e-6 * (self.lk - self.fk)
        a, b = max(u - h, self.fk), min(u + h, self.lk)
        return (self.point(b) - self.point(a)) / (b - a)

    def set_position(self, t: float) -> None:
        """``PositionOnGuide(t)``: ``t`` along the guide's length (``TurtlePath::setPosition``)."""
        self.t = min(max(t / self.total, 0.0), 1.0)
        u = self.u_at(self.t)
        self.last = self.point(u)
        self.head = _unit(self.tangent(u))
        if self.dim == 3:
            d = self.tangent(min(u + 1e-4 * (self.lk - self.fk), self.lk)) - self.tangent(u)
            n = d - self.head * (d @ self.head)               # the curve's normal (getNormalAt)
            self.up = _unit(n) if np.linalg.norm(n) > 1e-12 else _perpendicular(self.head)
            self.left = _unit(np.cross(self.up, self.head))

    def step(self, length: float) -> tuple[list, float]:
        """``_applyGuide(length)``: the turns (as ``(module, degrees)``) and the move's new length; ``length`` 0:
        the local adjustment after a move (``_ajustToGuide``)."""
        if length == 0.0:
            tangent = self.tangent(self.u_at(self.t))
        else:
            nxt = self.t + length / self.total
            rest = nxt - 1.0
            if rest > _EPS:
                nxt = 1.0
            nu = self.u_at(nxt)
            npos = self.point(nu)
            offset = _unit(self.tangent(nu)) * (rest * self.actual) if rest > _EPS else 0.0
            tangent = npos + offset - self.last
            length = float(np.linalg.norm(tangent)) * self.scale
            self.last, self.t = npos, nxt
        turns = self._turn2d(tangent) if self.dim == 2 else self._turn3d(_unit(tangent))
        return turns, length

    def _turn2d(self, tangent: np.ndarray) -> list:
        h = self.head
        dev = math.atan2(h[0] * tangent[1] - h[1] * tangent[0], h[0] * tangent[0] + h[1] * tangent[1])
        if self.ccw:
            dev = -dev
        self.head = tangent
        if dev == 0.0:
            return []
        # yorientation False: axisRotation(left, -dev), i.e. & (down); True: axisRotation(up, dev), i.e. +
        return [("+", math.degrees(dev))] if self.yorient else [("&", -math.degrees(dev))]

    def _turn3d(self, tangent: np.ndarray) -> list:
        p = np.array([tangent @ self.head, tangent @ self.left, tangent @ self.up])   # in the turtle's frame
        p = _unit(p)
        sinus = math.hypot(p[1], p[2])
        turns: list = []
        if sinus > _EPS:
            ang = math.atan2(sinus, p[0])
            # axisRotation(axis, ang) with axis = H x p = (0, -p_U, p_L) in (H, L, U): a roll that brings the
            # left axis onto it, a turn about that left axis (&), the roll back
            phi = math.degrees(math.atan2(p[1], -p[2]))
            turns = [("/", phi), ("&", math.degrees(ang)), ("/", -phi)]
            axis = _unit(np.cross(self.head, tangent))
            self.left = _unit(_rotate(self.left, axis, ang))
            self.up = _unit(_rotate(self.up, axis, ang))
        self.head = tangent
        return turns


def _unit(v):
    n = float(np.linalg.norm(v))
    return v / n if n > 0 else v


def _perpendicular(v):
    a = np.array([1.0, 0, 0]) if abs(v[0]) < 0.9 else np.array([0.0, 1, 0])
    return _unit(np.cross(v, a))


def _rotate(v, k, ang):
    """``v`` rotated about the unit axis ``k`` by ``ang`` (Rodrigues; PlantGL's ``Matrix3::axisRotation``)."""
    c, s = math.cos(ang), math.sin(ang)
    return v * c + np.cross(k, v) * s + k * (k @ v) * (1 - c)


def apply_guides(string: ModuleString, step: float) -> tuple[ModuleString, np.ndarray | None]:
    """``string`` with every guided ``F``/``f``/``nF`` replaced by its turns and new length, and the guide modules
    dropped; ``(string, None)`` when it sets no guide. The second item maps each new module to its source."""
    if not isinstance(string, ModuleString):
        return string, None                               # the turtle's door check names it
    gids = [k for k, nm in enumerate(string.names) if nm in GUIDE_MODULES]
    if not gids or not np.isin(string.ids, gids).any():
        return string, None
    out: list = []
    src: list = []
    guide: _Guide | None = None
    stack: list = []

    def move(i: int, name: str, length: float, extra: tuple) -> None:
        nonlocal guide
        if guide is not None and length > 0 and guide.t >= 1.0:
            guide = None                                  # past the guide's end: it is dropped
        if guide is None or not length > 0:
            out.append((name, (length, *extra)))
            src.append(i)
            return
        turns, length = guide.step(length)
        after = guide.step(0.0)[0]
        out.extend([*((nm, (deg,)) for nm, deg in turns), (name, (length, *extra)),
                    *((nm, (deg,)) for nm, deg in after)])
        src.extend([i] * (len(turns) + 1 + len(after)))

    for i, (name, vals) in enumerate(string.modules()):
        if name == "[":
            stack.append(guide.copy() if guide is not None else None)
        elif name == "]" and stack:
            guide = stack.pop()
        if name in GUIDE_MODULES:
            if name == "EndGuide" or (name == "SetGuide" and not vals):
                guide = None
            elif name == "SetGuide" and len(vals) >= 2:
                guide = _Guide(vals[0], float(vals[1]), *(bool(v) for v in vals[2:4]))
            elif name == "PositionOnGuide" and guide is not None and vals:
                guide.set_position(float(vals[0]))
        elif guide is not None and name in ("F", "f"):
            move(i, name, float(vals[0]) if vals else step, tuple(vals[1:]))
        elif guide is not None and name == "nF":
            fn = vals[3] if len(vals) > 3 else None
            if len(vals) > 2 and not (callable(getattr(fn, "getValue", None)) and hasattr(fn, "firstx")):
                raise ValueError(f"string: module nF at index {i}: nF(length, dl, radius) along a guide needs a "
                                 "radius function (QuantisedFunction) as its 4th parameter here (without one its "
                                 "widths start from the turtle's)")
            total, dl = float(vals[0]), float(vals[1])
            if not (0 <= total <= _MAX_COORD and 0 < dl and total / dl <= _MAX_STEPS):
                raise ValueError(f"string: module nF at index {i}: nF(length, dl) along a guide needs 0 <= length"
                                 f" <= {_MAX_COORD:g}, dl > 0 and at most {_MAX_STEPS:,} steps, got length = "
                                 f"{total!r}, dl = {dl!r}")
            n = int(total / dl)
            if fn is None:
                for piece in [dl] * n + ([total - n * dl] if total - n * dl > _EPS else []):
                    move(i, "F", piece, ())               # Turtle::nF: int(length / dl) steps, then the rest
                continue
            radius, fx, lx = float(vals[2]), float(fn.firstx), float(fn.lastx)
            du, u = dl / total * (lx - fx) if total > 0 else 0.0, fx    # Turtle::nF with a radius variation
            out.append(("_", (float(fn.getValue(u)) * radius,)))
            src.append(i)
            for _ in range(n):
                u += du
                move(i, "F", dl, (float(fn.getValue(u)) * radius,))
            if total - n * dl > _EPS:
                move(i, "F", total - n * dl, (radius * float(fn.getValue(lx)),))
        else:
            out.append((name, vals))
            src.append(i)
    return ModuleString.from_modules(out, names=string.names), np.asarray(src, np.int64)

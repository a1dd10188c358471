"""Turtle guides (issue 33): ``SetGuide`` / ``EndGuide`` / ``PositionOnGuide`` follow PlantGL's
``Turtle::_applyGuide``. The oracle is an independent port of it that turns the turtle's frame vectors in world
space (``Matrix3::axisRotation``) and moves along the heading; our pass turns the guide into ``& + /`` modules for
the numba turtle. Positions agree to 1e-9 for 2-D guides (both orientations, ccw), 3-D guides, branches (a ``[``
copies the guide), the run past the guide's end and a position set on the guide."""
from __future__ import annotations

import math

import numpy as np
import pytest

from plantvr.lsystem.engine import LSystem
from plantvr.lsystem.modules import ModuleString
from plantvr.lsystem.plantgl import NurbsCurve, NurbsCurve2D, Polyline2D
from plantvr.lsystem.turtle import turtle_nodes

S_CURVE = NurbsCurve2D([(-0.5, 0, 1), (-0.192641, 0.281385, 1), (0.0238095, -0.177489, 1), (0.5, 0, 1)])
HELIX = NurbsCurve([(math.cos(a), math.sin(a), 0.3 * a, 1) for a in np.linspace(0, 3 * np.pi, 9)])


def rot(k, a):
    """Matrix3::axisRotation(k, a) (Rodrigues)."""
    k = np.asarray(k, float) / np.linalg.norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


class Path:
    """The guide as PlantGL's Turtle2DPath / Turtle3DPath (stride-60 arc-length table, central differences)."""

    def __init__(self, curve, total, yo=False, ccw=False):
        self.c, self.total, self.yo, self.ccw = curve, total, yo, ccw
        self.u = np.linspace(curve.firstKnot, curve.lastKnot, 61)
        p = np.array([self.at(u) for u in self.u])
        cum = np.r_[0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]
        self.actual, self.s = cum[-1], cum / cum[-1]
        self.t, self.last, self.is2d = 0.0, p[0], p.shape[1] == 2
        self.h = (-1 if ccw else 1) * (np.array([0.0, 1]) if yo else np.array([1.0, 0]))
        self.H3, self.L3, self.U3 = np.array([0.0, 0, 1]), np.array([0.0, -1, 0]), np.array([1.0, 0, 0])

    def at(self, u):
        return np.array(list(self.c.getPointAt(u)), float)

    def tan(self, u):
        e = 1e-6 * (self.c.lastKnot - self.c.firstKnot)
        a, b = max(u - e, self.c.firstKnot), min(u + e, self.c.lastKnot)
        return (self.at(b) - self.at(a)) / (b - a)

    def apply(self, T, length):
        """Turn the turtle frame T = [P, H, L, U] (world) and return the new length."""
        if length == 0:
            tg = self.tan(np.interp(self.t, self.s, self.u))
        else:
            nxt = self.t + length / self.total
            rest = nxt - 1
            nxt = 1.0 if rest > 1e-6 else nxt
            nu = np.interp(nxt, self.s, self.u)
            npos = self.at(nu)
            off = self.tan(nu) / np.linalg.norm(self.tan(nu)) * rest * self.actual if rest > 1e-6 else 0
            tg = npos + off - self.last
            length = np.linalg.norm(tg) * self.total / self.actual
            self.last, self.t = npos, nxt
        tg = tg / np.linalg.norm(tg)
        if self.is2d:
            dev = math.atan2(self.h[0] * tg[1] - self.h[1] * tg[0], self.h @ tg) * (-1 if self.ccw else 1)
            if self.yo:
                m = rot(T[3], dev)
                T[1], T[2] = m @ T[1], m @ T[2]
            else:
                m = rot(T[2], -dev)
                T[1], T[3] = m @ T[1], m @ T[3]
            self.h = tg
        else:
            M = np.column_stack([T[1], T[2], T[3]])
            pt = M @ np.array([tg @ self.H3, tg @ self.L3, tg @ self.U3])
            pt /= np.linalg.norm(pt)
            cp = np.cross(T[1], pt)
            if np.linalg.norm(cp) > 1e-6:
                ang = math.atan2(np.linalg.norm(cp), T[1] @ pt)
                m = rot(cp, ang)
                T[1], T[2], T[3] = m @ T[1], m @ T[2], m @ T[3]
                m2 = rot(np.cross(self.H3, tg), ang)
                self.L3, self.U3 = m2 @ self.L3, m2 @ self.U3
                self.L3, self.U3 = self.L3 / np.linalg.norm(self.L3), self.U3 / np.linalg.norm(self.U3)
            self.H3 = tg
        return length


def oracle(modules):
    """Segment end points of F under guides, PlantGL's way (world frame, +Z heading)."""
    import copy
    T = [np.zeros(3), np.array([0.0, 0, 1]), np.array([0.0, -1, 0]), np.array([1.0, 0, 0])]
    g, stack, ends = None, [], [T[0].copy()]
    for name, vals in modules:
        if name == "[":
            stack.append(([v.copy() for v in T], copy.deepcopy(g)))
        elif name == "]":
            T, g = stack.pop()
        elif name == "SetGuide":
            g = Path(*vals) if vals else None
        elif name == "EndGuide":
            g = None
        elif name == "+":
            m = rot(T[3], math.radians(vals[0]))
            T[1], T[2] = m @ T[1], m @ T[2]
        elif name in ("F", "f"):
            length = vals[0] if vals else 1.0
            if g is not None and g.t >= 1:
                g = None
            if g is not None:
                length = g.apply(T, length)
            T[0] = T[0] + T[1] * length
            if g is not None:
                g.apply(T, 0)
            if name == "F":
                ends.append(T[0].copy())
    return np.array(ends)


def ours(modules, *, tree=False):
    names = tuple(dict.fromkeys(["[", "]"] + [m[0] for m in modules]))
    s = ModuleString.from_modules([(nm, tuple(v)) for nm, v in modules], names=names)
    t = turtle_nodes(s).tree
    return t if tree else t.pos


CASES = {
    "2d": [("SetGuide", (S_CURVE, 10.0))] + [("F", (0.5,))] * 20,
    "2d_yorientation_ccw": [("SetGuide", (S_CURVE, 6.0, True, True))] + [("F", (0.4,))] * 15,
    "2d_past_the_end": [("SetGuide", (S_CURVE, 3.0))] + [("F", (0.7,))] * 8,
    "polyline": [("SetGuide", (Polyline2D([(0, 0), (1, 0), (1, 1), (2, 1)]), 4.0))] + [("F", (0.3,))] * 12,
    "3d_helix": [("SetGuide", (HELIX, 12.0))] + [("F", (0.5,))] * 24,
    "branch_copies_the_guide": [("SetGuide", (S_CURVE, 8.0)), ("F", (1.0,)), ("[", ()), ("+", (30.0,)),
                                ("F", (1.0,)), ("F", (1.0,)), ("]", ()), ("F", (1.0,)), ("F", (1.0,)),
                                ("EndGuide", ()), ("F", (1.0,))],
    "move_f_follows_too": [("SetGuide", (HELIX, 6.0)), ("F", (1.0,)), ("f", (1.0,)), ("F", (1.0,))],
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_guided_turtle_matches_plantgl_frame_by_frame(case):
    want = oracle(CASES[case])[1:]                    # the end of every F, in string order
    t = ours(CASES[case], tree=True)
    got = t.pos[t.parent >= 0]
    assert got.shape == want.shape and np.allclose(got, want, atol=1e-9), case


def test_guided_length_is_the_guide_length_and_shape_is_the_curve():
    pos = ours([("SetGuide", (S_CURVE, 10.0)), ("nF", (10.0, 0.1))])
    assert len(pos) == 101
    assert np.linalg.norm(np.diff(pos, axis=0), axis=1).sum() == pytest.approx(10.0, rel=1e-3)
    # the end point: the curve's chord, scaled by 10 / its length, along the initial heading (+Z)
    scale = 10.0 / Path(S_CURVE, 10.0).actual
    assert pos[-1] == pytest.approx([0.0, 0.0, 1.0 * scale], abs=1e-6)


def test_setguide_grammars_of_the_distribution_run():
    """L-Py's tutorial 01/06 (SetGuide and nF), written out here."""
    g = """
Axiom: SetGuide(path,10) nF(10, 0.1)
derivation length: 1
production:
endlsystem
###### INITIALISATION ######
def __initialiseContext__(context):
    import openalea.plantgl.all as pgl
    path = pgl.NurbsCurve2D(ctrlPointList = pgl.Point3Array([(-0.5, 0, 1),(-0.192641, 0.281385, 1),
                            (0.0238095, -0.177489, 1),(0.5, 0, 1)]))
    context["path"] = path
"""
    ls = LSystem(g, trusted=True)
    t = turtle_nodes(ls.interpret(ls.derive(1)))
    assert len(t.tree.pos) == 101 and abs(t.tree.pos[:, 0]).max() > 0.5       # it bends: the S-curve


@pytest.mark.parametrize(("mods", "match"), [
    ([("SetGuide", ("not a curve", 1.0)), ("F", ())], "must be a PlantGL curve"),
    ([("SetGuide", (S_CURVE, 0.0)), ("F", ())], "length > 0"),
    ([("SetGuide", (S_CURVE, 1.0)), ("nF", (1e9, 1e-6))], "at most"),
    ([("SetGuide", (S_CURVE, 1.0)), ("nF", (1.0, 0.1, 0.2))], "along a guide needs a radius function"),
])
def test_bad_guides_are_refused_by_name(mods, match):
    with pytest.raises(ValueError, match=match):
        ours(mods)

"""L-Py's turtle scene handed to ``End(lstring, lscene)`` / ``EndEach`` (issue 33): PlantGL's geometry and ids.

Expected values are PlantGL's ``PglTurtleDrawer`` rules worked by hand (frustum/cone/cylinder choice, the
``Translated(Oriented(U, -L, .))`` placement) and L-Py's own tests (test_shape_ids, test_consider_per_rule,
test_polygon), run verbatim.
"""
import math

import numpy as np
import pytest

from plantvr.lsystem import LSystem, LSystemError
from plantvr.lsystem.modules import ModuleString
from plantvr.lsystem.pglscene import (AxisRotated, Cone, Cylinder, Disc, Extrusion, Frustum, Oriented, Polyline,
                                      Scaled, Scene, Sphere, Translated, TriangleSet)
from plantvr.lsystem.scene import LazyScene, lsystem_scene, turtle_scene


def _scene(axiom: str, extra: str = "") -> Scene:
    ls = LSystem(f"Axiom: {axiom}\nderivation length: 0\nproduction:\n{extra}endlsystem\n", trusted=True)
    return lsystem_scene(ls, ls.derive())


def _vec(v) -> tuple:
    return tuple(round(float(c), 9) + 0.0 for c in v)


def test_segments_are_plantgl_primitives_placed_by_the_turtle_frame():
    sc = _scene("F(1,0) F(1) F(1,0.1) [ + _(0.2) F(2) ] F(1, 0.05)")
    g = [sh.geometry for sh in sc]
    assert [sh.id for sh in sc] == [0, 1, 2, 6, 8]
    # F(1,0) from the default width 0.1 at the origin, initial frame: a bare Cone (no transform)
    assert type(g[0]) is Cone and (g[0].radius, g[0].height, g[0].solid) == (0.1, 1.0, False)
    # both widths 0: a Polyline between the two positions
    assert type(g[1]) is Polyline and [_vec(p) for p in g[1].pointList] == [(0, 0, 1), (0, 0, 2)]
    # width 0 to 0.1: PlantGL's inverted cone, placed at the segment's top and turned by Oriented(L, -U)
    assert type(g[2]) is Translated and _vec(g[2].translation) == (0, 0, 3)
    o = g[2].geometry
    assert type(o) is Oriented and _vec(o.primary) == (0, -1, 0) and _vec(o.secondary) == (-1, 0, 0)
    assert type(o.geometry) is Cone and (o.geometry.radius, o.geometry.height) == (0.1, 1.0)
    # '+' turns about U by 60 degrees: Oriented(U, -L) with U = (1, 0, 0), L = (0, -cos 60, sin 60)
    assert type(g[3]) is Translated and _vec(g[3].translation) == (0, 0, 3)
    o = g[3].geometry
    assert _vec(o.primary) == (1, 0, 0) and _vec(o.secondary) == _vec((0, 0.5, math.sqrt(3) / 2))
    assert type(o.geometry) is Cylinder and o.geometry.radius == 0.2 and o.geometry.height == pytest.approx(2)
    # width 0.1 to 0.05 (the width after the bracket is the stacked 0.1): a Frustum of taper 0.5
    assert type(g[4].geometry) is Frustum and g[4].geometry.taper == pytest.approx(0.5)
    assert isinstance(g[4].geometry, Cone)                                      # PlantGL's class tree


def test_placed_shapes_polygons_and_tubes():
    sc = _scene(",(3) @O(0.5) @o(0.3) {.f.+f.+f.} @Gc F [ + F ] F @Ge")
    kinds = [type(sh.geometry).__name__ for sh in sc]
    assert kinds == ["Scaled", "AxisRotated", "TriangleSet", "Extrusion", "Extrusion"]
    sphere, disc, poly, tube = sc[0].geometry, sc[1].geometry, sc[2].geometry, sc[3].geometry
    assert type(sphere.geometry) is Sphere and _vec(sphere.scale) == (0.5, 0.5, 0.5)
    assert type(disc) is AxisRotated and disc.angle == pytest.approx(math.pi / 2) and _vec(disc.axis) == (0, 1, 0)
    assert type(disc.geometry) is Disc and disc.geometry.radius == pytest.approx(0.3)
    # a polygon's id is its '{' (Turtle::startPolygon takes the id), a tube's its '@Gc'; PlantGL's fan
    assert [sh.id for sh in sc] == [1, 2, 3, 14, 14]
    assert type(poly) is TriangleSet and poly.indexList == [(0, 1, 2), (0, 2, 3)]
    assert [_vec(p) for p in poly.pointList] == [(0, 0, 0), (0, 0, 1), _vec((0, -math.sqrt(3) / 2, 1.5)),
                                                 _vec((0, -math.sqrt(3), 1))]
    assert type(tube) is Extrusion and isinstance(tube.axis, Polyline)
    assert {sh.appearance.name for sh in sc} == {"Color_3"}


def test_ids_follow_the_recursive_interpretation():
    """L-Py's test/lpytest/test_shape_ids.lpy, verbatim: each shape's id is the lstring module it was
    interpreted from (three levels of interpretation rules, 'f' moves and '@O' spheres)."""
    g = """def End(lstring,lscene):
  lsceneids = list(lscene.todict().keys())
  lsceneids.sort()
  assert len(lsceneids) == lstring.count('A') + lstring.count('B') + lstring.count('C')
  assert lsceneids == [2,5,7,10,12,15]

Axiom: @Tp(0,0,1) [ A [ + B ] C  [- B ] A [+ B ] ]

derivation length: 1
production:


interpretation:
maximum depth: 3
A --> D
D --> E
E --> F @O(0.2) F
B --> H
H --> I
I --> fFfF
C --> J
J --> K
K --> f @O f @O

endlsystem
"""
    ls = LSystem(g, trusted=True)
    ls.derive()                                   # the grammar's own asserts run in End
    sc = lsystem_scene(ls, ls.derive())
    # A draws F, @O, F (3 shapes), B F, F; C two spheres
    assert sorted(len(v) for v in sc.todict().values()) == [2, 2, 2, 2, 3, 3]


def test_end_each_gets_the_scene_and_ignore_applies_per_rule():
    """L-Py's test/lpytest/test_consider_per_rule.lpy, verbatim (its EndEach asserts 4 shapes): each
    ``ignore:`` line holds for the rules after it (lpy_parser's ``currentConsider``)."""
    g = """def EndEach(lstring,lscene):
   assert len(lscene) == 4

Axiom: F[+A][A]-A

derivation length: 1
production:

ignore:+
F [ < A --> [;f@O]

ignore:-
F < A --> [;;f@O]

ignore:
T --> T

interpretation:


endlsystem"""
    assert str(LSystem(g, trusted=True).derive()) == "F[+[;f@O]][[;f@O]]-[;;f@O]"
    bad = g.replace("== 4", "== 5")
    with pytest.raises(LSystemError, match=r"EndEach\(\) raised AssertionError"):
        LSystem(bad, trusted=True).derive()


def test_polygon_grammar_of_lpy():
    """L-Py's test/lpytest/test_polygon.lpy shape: three cylinders and the polygon through their ends."""
    sc = _scene("{ .F(1) +(90) .F(1) +(90) .F(1) . }")
    assert [type(sh.geometry.geometry if isinstance(sh.geometry, Translated) else sh.geometry).__name__
            for sh in sc] == ["Cylinder", "Oriented", "Oriented", "TriangleSet"]
    assert sc[3].id == 0 and len(sc[3].geometry.pointList) == 7


def test_the_hook_scene_is_built_only_when_read():
    calls = []
    lazy = LazyScene(lambda: calls.append(1) or Scene([]))
    assert lazy and not calls                     # truthy (L-Py hands a scene, not None) and not built yet
    assert len(lazy) == 0 and len(lazy) == 0 and calls == [1]
    with pytest.raises(AttributeError):
        lazy._missing


def test_turtle_scene_checks_its_input():
    s = ModuleString.from_modules([("F", ())])
    with pytest.raises(ValueError, match="ids must have shape"):
        turtle_scene(s, np.zeros(2, int))
    with pytest.raises(TypeError, match="unknown turtle option"):
        turtle_scene(s, colour=3)
    with pytest.raises(ValueError, match="string must be a ModuleString"):
        turtle_scene("F")
    assert [type(sh.geometry) for sh in turtle_scene(s, step=2.0)] == [Cylinder]
    assert turtle_scene(s, step=2.0)[0].geometry.height == 2.0 and isinstance(Scaled(1, Sphere()), Scaled)


def test_scene_records_take_plantgl_signatures():
    from plantvr.lsystem.pglscene import Box
    assert tuple(Box(1, 2, 3).size) == (1, 2, 3) and tuple(Box().size) == (0.5, 0.5, 0.5)
    with pytest.raises(TypeError, match="Cone takes at most 4 arguments"):
        Cone(1, 2, True, 8, 9)
    with pytest.raises(TypeError, match=r"unknown argument\(s\) \['radiu'\]"):
        Sphere(radiu=2)


def test_start_and_end_interpretation_frame_the_drawing():
    """After L-Py's test_startendinterpretation.lpy: what ``StartInterpretation`` / ``EndInterpretation``
    produce is drawn before and after the string, with no id (PlantGL's ``setNoId``); the lstring is unchanged."""
    g = """def StartInterpretation():
  produce @O(0.2)+(90)

def EndInterpretation():
  nproduce ,(2)
  produce @O(0.3)

def End(lstring,lscene):
  assert len(lscene) == 3 and [sh.id for sh in lscene] == [-1, 0, -1]

Axiom: F

derivation length: 1
production:

endlsystem
"""
    ls = LSystem(g, trusted=True)
    s = ls.derive()
    assert str(s) == "F" and str(ls.interpret(s)) == "@O(0.2)+(90)F,(2)@O(0.3)"
    sc = lsystem_scene(ls, s)
    assert [type(sh.geometry).__name__ for sh in sc] == ["Scaled", "Oriented", "Translated"]
    assert sc[2].appearance.name == "Color_2" and _vec(sc[2].geometry.translation) == (0, -1, 0)
    assert len(ls.draw(s, shapes=True).shapes) == 2                  # the two spheres, in draw too
    bad = g.replace("def StartInterpretation():", "def StartInterpretation(turtle):")
    with pytest.raises(LSystemError, match=r"StartInterpretation\(turtle\).*not supported"):
        LSystem(bad, trusted=True).derive()

"""Issue 33: the small ``openalea.plantgl.all`` namespace of trusted grammars (vectors, materials, curves,
quantised functions) against scipy and closed forms."""
import numpy as np
import pytest

from plantvr.lsystem import plantgl as pgl
from plantvr.lsystem.engine import LSystem, LSystemError
from plantvr.lsystem.shapes import material_rgb


def test_vectors_and_helpers():
    v = pgl.Vector3(3, 0, 4)
    assert pgl.norm(v) == 5 and v.normalize() == 5 and v == [0.6, 0.0, 0.8]
    v.x = 1
    assert v.x == 1.0 and (v + pgl.Vector3.OZ) == [1, 0, 1.8] and (2 * v).z == pytest.approx(1.6)
    assert pgl.Vector3(1, 2, 3) * pgl.Vector3(1, 1, 1) == 6                   # PlantGL: * of vectors is dot
    assert pgl.cross(pgl.Vector3.OX, pgl.Vector3.OY) == pgl.Vector3.OZ
    assert pgl.Vector3.OX ^ pgl.Vector3.OY == pgl.Vector3.OZ                  # PlantGL: ^ is the cross product
    assert pgl.RealArray([1, 2.5]) == [1.0, 2.5] and type(pgl.RealArray([1])[0]) is float
    assert pgl.direction(pgl.Vector3(0, 0, 2)) == [0, 0, 1] and pgl.Vector3((1, 2)) == [1, 2, 0]
    with pytest.raises(ValueError, match="Vector3 takes at most 3 coordinates, got 4"):
        pgl.Vector3(1, 2, 3, 4)


def test_materials_match_the_turtle_table():
    assert pgl.Material("Color_2", (30, 60, 10), 3).rgb() == tuple(material_rgb(2))
    assert pgl.Material().rgb() == tuple(material_rgb(0))
    m = pgl.Material("Color_7", ambient=(0, 0, 0), diffuse=40)
    assert m.rgb() == (0, 0, 0) and m.as_entry() == ("Color_7", (0, 0, 0), 40.0)
    assert pgl.Color3(300, -2, 7.4) == [255, 0, 7]
    with pytest.raises(ValueError, match="unknown argument"):
        pgl.Material(colour=(1, 2, 3))


def test_nurbs_curve_against_scipy_bspline():
    from scipy.interpolate import BSpline
    ctrl = np.array([(-0.5, 0), (-0.2, 0.11), (0.12, 0.04), (0.47, -0.22), (0.6, 0.1)])
    c = pgl.NurbsCurve2D(pgl.Point3Array([(x, y, 1) for x, y in ctrl]))
    ref = BSpline(c.knotList, ctrl, 3)
    for u in np.linspace(0, 1, 23):
        np.testing.assert_allclose(c.getPointAt(u), ref(u), atol=1e-12)
    assert c.getPointAt(0) == pytest.approx(ctrl[0]) and c.getPointAt(1) == pytest.approx(ctrl[-1])
    # rational: the quarter circle (weights 1, sqrt(2)/2, 1) stays on the unit circle
    w = np.sqrt(0.5)
    arc = pgl.NurbsCurve2D([(1, 0, 1), (1, 1, w), (0, 1, 1)], degree=2)
    pts = arc.samples(50)
    np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 1.0, atol=1e-12)
    bez = pgl.BezierCurve2D([(0, 0, 1), (1, 2, 1), (2, 0, 1)])
    assert bez.getPointAt(0.5) == pytest.approx([1.0, 1.0])                # (1-t)^2 p0 + 2t(1-t) p1 + t^2 p2
    assert pgl.Polyline2D([(0, 0), (2, 2), (4, 0)]).getPointAt(1.5) == pytest.approx([3, 1])
    with pytest.raises(ValueError, match="ctrlPointList must hold at least 2 points"):
        pgl.NurbsCurve2D([(0, 0, 1)])


def test_quantised_function_reads_a_curve_as_y_of_x():
    line = pgl.NurbsCurve2D([(0, 1, 1), (0.5, 2, 1), (1, 3, 1)], degree=1)
    f = pgl.QuantisedFunction(line)
    assert (f.firstx, f.lastx) == (0.0, 1.0)
    for x in (0.0, 0.1, 0.37, 0.8, 1.0):
        assert f(x) == pytest.approx(1 + 2 * x) and f.getValue(x) == f(x)
    assert f(-1) == pytest.approx(1.0) and f(7) == pytest.approx(3.0)        # clamped
    assert f.inverse()(2.0) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="curve must be"):
        pgl.QuantisedFunction(3)


GRAMMAR = """\
import openalea.plantgl.all as pgl
from openalea.plantgl.all import *
from openalea.plantgl.all import Vector3 as V3
import math
width = pgl.QuantisedFunction(pgl.NurbsCurve2D(pgl.Point3Array([(0, 0.2, 1), (1, 0.0, 1)]), degree=1))
down = V3(0, 0, -2)
down.normalize()
leaf = Material("Color_7", ambient=(0, 0, 0), diffuse=40)
Axiom: A(0)
derivation length: 2
production:
A(t) --> F(1, width(t / 2)) @Tp(down) A(t + 1)
endlsystem
"""


def test_trusted_grammar_imports_resolve_here():
    s = LSystem(GRAMMAR, trusted=True).derive()
    mods = [(s.names[i], s.args[s.arg_ptr[k]:s.arg_ptr[k + 1]].round(9).tolist()) for k, i in enumerate(s.ids)]
    assert mods == [("F", [1.0, 0.2]), ("@Tp", [0.0, 0.0, -1.0]), ("F", [1.0, 0.1]), ("@Tp", [0.0, 0.0, -1.0]),
                    ("A", [2.0])]
    with pytest.raises(LSystemError, match="import runs Python code"):
        LSystem(GRAMMAR)
    with pytest.raises(LSystemError, match=r"openalea.plantgl.gui: PlantVR's PlantGL namespace has"):
        LSystem("import openalea.plantgl.gui\nAxiom: F\nendlsystem\n", trusted=True)
    with pytest.raises(LSystemError, match="ModuleNotFoundError"):
        LSystem("import no_such_module_here\nAxiom: F\nendlsystem\n", trusted=True)


# -- the editor's INITIALISATION block ------------------------------------------------------------------------------
EDITOR = '''Axiom: A(len(path.ctrlPointList))
derivation length: 1
production:
A(n) --> F(n * scale) ,(3) @O(0.5)
endlsystem
###### INITIALISATION ######

__lpy_code_version__ = 1.1

def __initialiseContext__(context):
\timport openalea.plantgl.all as pgl
\tcontext.turtle.setMaterial(3, pgl.Material('Red', pgl.Color3(60, 0, 0), 2, pgl.Color3(40, 40, 40), pgl.Color3(0, 0, 0), 1, 0))
\tpath = pgl.NurbsCurve2D(
\t    ctrlPointList = pgl.Point3Array([(-0.5, 0, 1),(-0.2, 0.3, 1),(0.0, -0.2, 1),(0.5, 0, 1)]) ,
\t    )
\tpath.name = "path"
\tcontext["path"] = path
\tcontext["scale"] = 2
'''


def test_initialisation_block_defines_curves_materials_and_scalars_as_lpy_does():
    """L-Py runs the editor's block and ``__initialiseContext__(context)`` before the code
    (``LsysContext::__initialiseFrom``): ``context[name] = value`` defines grammar names, ``setMaterial`` sets the
    colour table; the caller's externs win (``updateNamespace``)."""
    from plantvr.documents import LSystemDocument
    ls = LSystem(EDITOR, trusted=True)
    s = ls.derive()
    assert str(s) == "F(8),(3)@O(0.5)"                         # 4 control points x scale 2
    assert ls.materials[3] == ("Red", (60, 0, 0), 2.0) and len(ls.materials) >= 4
    doc = LSystemDocument(EDITOR, trusted=True)
    (mesh,) = doc.shapes.values()
    assert np.all(mesh.colors[:, :3] == (120, 0, 0))           # ambient x diffuse, as material_rgb
    with pytest.raises(LSystemError, match="line 1.*NameError.*path"):
        LSystem(EDITOR)                                        # untrusted: the block's code does not run
    with pytest.raises(LSystemError, match=r"line 18.*ZeroDivisionError"):
        LSystem(EDITOR.replace('context["scale"] = 2', 'context["scale"] = 1 / 0'), trusted=True)


def test_matrix3_angle_constants_and_curve_methods_as_plantgl():
    """PlantGL's Matrix3.axisRotation (Rodrigues), angle (signed in 2-D, by an axis in 3-D), fresh class constants,
    deepcopy and the LineicModel methods of the curves (issue 33: the bending and path grammars use them)."""
    import copy
    import math

    from plantvr.lsystem.plantgl import Matrix3, NurbsCurve2D, Polyline2D, Vector2, Vector3, angle

    r = Matrix3.axisRotation((0, 0, 1), math.pi / 2)
    assert np.allclose(r * Vector3(1, 0, 0), [0, 1, 0]) and np.allclose((r * r) * Vector3(1, 0, 0), [-1, 0, 0])
    assert np.allclose((r * r.transpose()) * Vector3(0.3, -2, 5), [0.3, -2, 5])
    assert angle(Vector3(1, 0, 0), Vector3(0, 1, 0)) == pytest.approx(math.pi / 2)
    assert angle(Vector3(1, 0, 0), Vector3(0, 1, 0), (0, 0, -1)) == pytest.approx(-math.pi / 2)
    assert angle(Vector2(1, 0), Vector2(0, -1)) == pytest.approx(-math.pi / 2)
    v = Vector3.OX
    v += Vector3(1, 1, 1)                                 # a constant is a fresh vector: OX is still (1, 0, 0)
    assert list(Vector3.OX) == [1, 0, 0] and list(Vector2.OY) == [0, 1]
    p = Polyline2D([(0, 0), (1, 0), (1, 1)])
    assert p.getLength() == pytest.approx(2.0) and list(p.getTangentAt(0.5)) == pytest.approx([1, 0])
    assert p.getArcLengthToUMapping()(0.75) == pytest.approx(1.5)       # 3/4 of the length: half-way up the 2nd
    c = NurbsCurve2D([(0, 0, 1), (1, 0, 1), (2, 0, 1)], degree=1)
    assert c.getLength() == pytest.approx(2.0) and c.getFirstKnot() == 0.0 and c.getLastKnot() == 1.0
    d = c.deepcopy()
    d.knotList[2] = 0.25
    assert c.knotList[2] == 0.5 and isinstance(copy.copy(d), NurbsCurve2D)
    pts = c.ctrlPointList                                 # PlantGL's Point3Array: rows with x, y, z (the weight)
    assert [p.x for p in pts] == [0, 1, 2] and pts[2].z == 1 and type(pts).__name__ == "Point3Array"
    with pytest.raises(ValueError, match="Matrix3 needs 9 finite numbers"):
        Matrix3(1, 2, 3)


def test_is_animation_enabled_is_false():
    g = "Axiom: A\nderivation length: 1\nproduction:\nA --> B(1 if isAnimationEnabled() else 2)\nendlsystem\n"
    assert LSystem(g).derive(1).modules() == [("B", (2.0,))]


def test_point3grid_queries_match_brute_force():
    """PlantGL's ``Point3Grid`` (the space-colonization tutorials): ball and cone queries give the enabled points a
    brute-force scan finds (the cone's full opening is ``angle``); disabled points leave every query."""
    import math

    from plantvr.lsystem.plantgl import Point3Array, Point3Grid, Vector3, pointset_mean_direction
    rng = np.random.default_rng(5)
    pts = rng.uniform(-2, 2, size=(400, 3))
    grid = Point3Grid(Point3Array(pts), 10)
    assert Point3Grid(Vector3(1, 1, 1), Point3Array(pts)).nbPoints() == 400
    o, d, r, a = np.array([0.1, -0.2, 0.3]), np.array([0.0, 0.0, 2.0]), 1.5, math.radians(90)
    dist = np.linalg.norm(pts - o, axis=1)
    assert grid.query_ball_point(Vector3(*o), r) == np.flatnonzero(dist <= r).tolist()
    cone = (dist <= r) & ((pts - o) @ (d / 2) > math.cos(a / 2) * dist)
    got = grid.query_points_in_cone(Vector3(*o), Vector3(*d), r, a)
    assert got == np.flatnonzero(cone).tolist() and got
    grid.disable_points(got[:3])
    assert not set(got[:3]) & set(grid.query_points_in_cone(Vector3(*o), Vector3(*d), r, a))
    assert not grid.is_point_enabled(got[0]) and len(grid.get_enabled_points()) == 397
    assert grid.enable_point(got[0]) and grid.is_point_enabled(got[0])
    with pytest.raises(IndexError, match=r"point index must be in \[0, 400\)"):
        grid.disable_point(400)
    m = pointset_mean_direction(Vector3(0, 0, 0), Point3Array([(1, 0, 0), (0, 2, 0), (5, 5, 5)]), [0, 1])
    assert np.allclose(list(m), np.array([1, 1, 0]) / math.sqrt(2))
    for v in [(0.0, 1.0, 2.0), (1.0, 0.0, 2.0), (1.0, 2.0, 0.0), (1.0, 2.0, 3.0)]:
        assert abs(float(np.dot(list(Vector3(*v).anOrthogonalVector()), v))) < 1e-12

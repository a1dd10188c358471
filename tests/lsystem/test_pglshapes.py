"""``@g`` (issue 33): PlantGL geometry, shapes, scenes and materials drawn at the turtle as L-Py's ``pglshape``
module draws them; meshes checked against hand-computed bounds and trimesh (watertight primitives)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from plantvr.lsystem import LSystem, LSystemError
from plantvr.lsystem import _turtle_kernels as K
from plantvr.lsystem.pglscene import (AxisRotated, Box, Cone, Cylinder, Disc, Extrusion, Frustum, Oriented, Polyline,
                                      Scaled, Sphere, Translated, TriangleSet)
from plantvr.lsystem.pglshapes import geometry_mesh
from plantvr.lsystem.shapes import register_surface, shape_meshes


@pytest.mark.parametrize("geom, lo, hi, faces", [
    (Box(1, 2, 3), (-1, -2, -3), (1, 2, 3), 12),
    (Cylinder(0.5, 2.0, True, 8), (-0.5, -0.5, 0), (0.5, 0.5, 2), 32),
    (Cone(1.0, 3.0, True, 6), (-1, -math.sin(math.pi / 3), 0), (1, math.sin(math.pi / 3), 3), 12),
    (Frustum(1.0, 1.0, 0.5, True, 4), (-1, -1, 0), (1, 1, 1), 16),
    (Sphere(2.0, 8, 8), (-2, -2, -2), (2, 2, 2), 112),
    (Translated((1, 2, 3), Scaled((2, 1, 1), Box())), (0, 1.5, 2.5), (2, 2.5, 3.5), 12),
])
def test_primitives_mesh_as_plantgl_defines_them(geom, lo, hi, faces):
    v, f = geometry_mesh(geom)
    assert np.allclose(v.min(0), lo, atol=1e-9) and np.allclose(v.max(0), hi, atol=1e-9) and len(f) == faces
    if not isinstance(geom, Sphere):
        m = trimesh.Trimesh(v, f, process=True)
        assert m.is_watertight and m.volume > 0          # closed, faces turned outward


def test_transforms_compose():
    """``AxisRotated(z, pi/2)`` turns x into y; ``Oriented(primary, secondary)`` maps x to primary and y to
    secondary (z to their cross product); a Disc lies in the xy plane; a Polyline meshes to nothing."""
    tri = TriangleSet([(1, 0, 0), (0, 1, 0), (0, 0, 1)], [(0, 1, 2)])
    v, _ = geometry_mesh(AxisRotated((0, 0, 1), math.pi / 2, tri))
    assert np.allclose(v, [(0, 1, 0), (-1, 0, 0), (0, 0, 1)], atol=1e-12)
    v, _ = geometry_mesh(Oriented((0, 1, 0), (0, 0, 1), tri))
    assert np.allclose(v, [(0, 1, 0), (0, 0, 1), (1, 0, 0)], atol=1e-12)
    v, f = geometry_mesh(Disc(2.0, 8))
    assert np.allclose(v[:, 2], 0) and len(f) == 8 and np.isclose(np.abs(v).max(), 2)
    assert len(geometry_mesh(Polyline([(0, 0, 0), (1, 0, 0)]))[1]) == 0
    with pytest.raises(ValueError, match="does not mesh Extrusion"):
        geometry_mesh(Extrusion())


def _meshes(axiom: str, **kw) -> dict:
    ls = LSystem(f"from openalea.plantgl.all import *\n{axiom}\n", trusted=True, **kw)
    return shape_meshes(ls.draw(ls.axiom, shapes=True).shapes, materials=ls.materials)


def test_l_py_test_pglshape():
    """L-Py's test_pglshape.lpy: ``@g(Translated((0,2,0), Box(1,2,3)))`` at the start, in colour 1."""
    m = _meshes("b = Translated((0,2,0),Box(1,2,3))\nAxiom: @g(b)")
    assert list(m) == [1] and np.allclose(m[1].vertices.min(0), (-1, 0, -3)) and \
        np.allclose(m[1].vertices.max(0), (1, 4, 3)) and m[1].n_faces == 12


def test_l_py_test_pglshapes_colours():
    """L-Py's test_pglshapes.lpy: a Shape in its own red, a Material turning what follows green (an F and a
    cone), a blue F then ``SetColor()`` back to the index, and a Scene (sphere, box 2 above) in colour 1."""
    ls = LSystem("from openalea.plantgl.all import *\nsc = Scene([Sphere(),Translated((0,0,2),Box())])\n"
                 "Axiom: ff[-f F @g(Shape(Cone(),Material((255,0,0))))][+f @g(Material((0,255,0))) F @g(Cone()) ]"
                 "  [^(90) @g(Material((0,0,255))) F SetColor() F ] [ &(90) F ]  f @g(sc)\n", trusted=True)
    nodes = ls.draw(ls.axiom, shapes=True)
    m = shape_meshes(nodes.shapes, materials=ls.materials)
    red, green, blue = (K.CUSTOM_COLOR + c for c in (0xFF0000, 0x00FF00, 0x0000FF))
    assert sorted(m) == [1, green, red] and m[red].n_faces == m[green].n_faces == 16       # 8 sides, 8 base
    assert np.allclose(m[1].vertices.min(0), (-0.5, -0.5, 2.5)) and np.allclose(m[1].vertices.max(0), (0.5, 0.5, 5.5))
    segs = nodes.tree.color[1:].tolist() if hasattr(nodes.tree, "color") else nodes.color[1:].tolist()
    assert green in segs and blue in segs and segs.count(1) >= 2


def test_geometry_is_placed_as_a_named_surface():
    """An ``@g`` of a TriangleSet lands where the same mesh registered as ``~name`` does, in a turned,
    scaled frame (PglTurtleDrawer places both with Oriented(U, -L) and the turtle scale)."""
    pts, idx = [(0, 0, 0), (1, 0, 0), (0, 2, 1)], [(0, 1, 2)]
    register_surface("tri_test", np.array(pts, float), np.array(idx))
    turn = "+(30) &(20) F(2) @D(1.5) /(45) "
    a = _meshes(f"t = TriangleSet({pts!r}, {idx!r})\nAxiom: {turn} @g(t, 2)")
    b = _meshes(f"Axiom: {turn} ~tri_test(2)")
    assert np.allclose(a[1].vertices, b[1].vertices, atol=1e-12)


def test_scene_ids_name_the_at_g_module():
    """The End hook's scene: the shapes an ``@g(Shape)`` makes carry the ``@g`` module's index."""
    g = """from openalea.plantgl.all import *
seen = []
def End(lstring, lscene):
  seen.extend(sh.id for sh in lscene)
Axiom: F @g(Shape(Sphere(), Material((9, 9, 9)))) F
derivation length: 1
endlsystem
"""
    ls = LSystem(g, trusted=True)
    ls.derive()
    assert ls._ns["seen"] == [0, 1, 2]


def test_what_is_not_drawn_is_refused_with_its_line_or_left_out():
    text = "from openalea.plantgl.all import *\nAxiom: F @g(Extrusion()) F\n"
    with pytest.raises(LSystemError, match=r"line 2, column 10: @g: .*does not mesh Extrusion"):
        LSystem(text, trusted=True).tree()
    with pytest.warns(UserWarning, match="not drawn: @g"):
        tree = LSystem(text, trusted=True).tree(unsupported="warn")
    assert np.allclose(tree.pos[-1], (0, 0, 2))
    assert _meshes("Axiom: F @g F") == {}                       # no parameter: nothing, as L-Py (a warning there)


def test_nurbs_patch_matches_scipy_and_the_weights():
    """A NurbsPatch with unit weights is scipy's tensor-product B-spline (``NdBSpline``) on the same knots; its
    corners are the net's (clamped knots); equal weights change nothing; normals are unit and turn with ``ccw``."""
    from scipy.interpolate import NdBSpline

    from plantvr.lsystem.plantgl import NurbsPatch, Point4Matrix
    rng = np.random.default_rng(3)
    net = rng.normal(size=(5, 4, 3))
    patch = NurbsPatch(Point4Matrix(np.concatenate([net, np.ones((5, 4, 1))], axis=2).tolist()), 3, 2)
    ref = NdBSpline((patch.uknotList, patch.vknotList), net, (3, 2))
    for u, v in [(0.0, 0.0), (0.3, 0.7), (0.99, 0.5), (1.0, 1.0)]:
        assert np.allclose(list(patch.getPointAt(u, v)), ref([[u, v]])[0], atol=1e-12)
    assert np.allclose(list(patch.getPointAt((1.0, 0.0))), net[-1, 0])
    heavy = NurbsPatch(Point4Matrix(np.concatenate([net * 1, np.full((5, 4, 1), 2.0)], axis=2).tolist()), 3, 2)
    assert np.allclose(list(heavy.getPointAt(0.4, 0.6)), list(patch.getPointAt(0.4, 0.6)))
    n = np.asarray(list(patch.getNormalAt(0.5, 0.5)))
    flipped = NurbsPatch(patch.ctrlPointMatrix, 3, 2, ccw=False)
    assert np.isclose(np.linalg.norm(n), 1) and np.allclose(list(flipped.getNormalAt(0.5, 0.5)), -n)
    v, f = geometry_mesh(NurbsPatch(patch.ctrlPointMatrix, 3, 2, ustride=6, vstride=4))
    assert v.shape == (7 * 5, 3) and f.shape == (2 * 6 * 4, 3) and f.max() == len(v) - 1


def test_l_py_test_patch():
    """L-Py's test_patch.lpy: ``F ,(2) &(90) @g(patch)``: a 4 x 4 patch on its 30 x 30 grid (1800 triangles) in
    colour 2, placed as its mesh registered as a surface is; a flat net stays a plane of its size."""
    from plantvr.lsystem.plantgl import NurbsPatch, Point4Matrix
    rows = [[(x, 0, z, 1) for x in (0.5, 1 / 6, -1 / 6, -0.5)] for z in (0, 1 / 3, 2 / 3, 1)]
    v0, f0 = geometry_mesh(NurbsPatch(Point4Matrix(rows)))
    assert np.allclose(v0[:, 1], 0) and np.allclose(v0.min(0), (-0.5, 0, 0)) and np.allclose(v0.max(0), (0.5, 0, 1))
    register_surface("flat_patch_test", v0, f0)
    a = _meshes(f"flat = NurbsPatch(Point4Matrix({rows!r}))\nAxiom: F ,(2) &(90) @g(flat)")
    b = _meshes("Axiom: F ,(2) &(90) ~flat_patch_test")
    assert list(a) == [2] and a[2].n_faces == 1800 and np.allclose(a[2].vertices, b[2].vertices, atol=1e-12)

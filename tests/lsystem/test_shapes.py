"""Issue 33 "a scene, not only a skeleton": the turtle's spheres, discs, ``~l`` leaves, polygons and generalized
cylinders against independent computations, the kernel twin, the document scene and the glTF / PLY export."""
import itertools
import warnings

import numpy as np
import pytest

from plantvr.lsystem import ModuleString
from plantvr.lsystem import _turtle_kernels as K
from plantvr.lsystem.engine import LSystem, LSystemError
from plantvr.lsystem.shapes import (
    SURFACES,
    ShapeMesh,
    material_rgb,
    polygon_faces,
    register_surface,
    shape_meshes,
    shape_name,
    sphere_mesh,
    tube_mesh,
)
from plantvr.lsystem.turtle import _TABLE, TURTLE_MODULES, _capacities, _ops, _options, turtle, turtle_nodes

GREEN, BROWN = (90, 180, 30), (195, 135, 45)      # PlantGL Color_2, Color_1: ambient times diffuse 3


def grammar(axiom: str, rules: str = "", n: int = 0) -> LSystem:
    return LSystem(f"Axiom: {axiom}\nderivation length: {n}\nproduction:\n{rules}\nendlsystem\n")


def scene_of(axiom: str, rules: str = "", n: int = 0):
    ls = grammar(axiom, rules, n)
    nodes = ls.draw(ls.derive(), shapes=True)
    return nodes, shape_meshes(nodes.shapes)


def polygon_area(p2: np.ndarray) -> float:
    x, y = p2[:, 0], p2[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def tri_area(v, f) -> float:
    return float(0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum())


# -- leaves -----------------------------------------------------------------------------------------------------
def test_leaf_grammar_exact_counts_bounds_and_area():
    """Two ``~l(2)`` leaves on a stem, turned +-90 degrees: PlantGL's 7-point blade placed by hand."""
    nodes, meshes = scene_of("F(1)[+(90);(2)~l(2)]F(1)[-(90);(2)~l(2)]")
    assert list(meshes) == [2] and nodes.tree.n_internodes == 2
    m = meshes[2]
    assert (m.n_vertices, m.n_faces) == (14, 12) and isinstance(m, ShapeMesh)
    assert m.colors.shape == (14, 3) and (m.colors == GREEN).all()
    # leaf 1 at (0, 0, 1): +90 turns H onto the old L (0, -1, 0); the blade's width runs along -L = +z
    # leaf 2 at (0, 0, 2): -90 turns H onto (0, 1, 0); -L = -z
    base1, h1, r1 = np.array([0, 0, 1.0]), np.array([0, -1.0, 0]), np.array([0, 0, 1.0])
    base2, h2, r2 = np.array([0, 0, 2.0]), np.array([0, 1.0, 0]), np.array([0, 0, -1.0])
    local = [(0.5, 0), (0, 0), (1 / 3, -0.25), (2 / 3, -0.25), (1, 0), (2 / 3, 0.25), (1 / 3, 0.25)]
    want = [b + 2 * (z * h + y * r) for b, h, r in ((base1, h1, r1), (base2, h2, r2)) for z, y in local]
    np.testing.assert_allclose(m.vertices, want, atol=1e-12)
    np.testing.assert_allclose(m.bounds, [[0, -2, 0.5], [0, 2, 2.5]], atol=1e-12)
    # each blade: a rectangle 0.5 x 1/3 plus two triangles (base 0.5, height 1/3), times 2^2
    assert m.area == pytest.approx(2 * 4 * (0.5 / 3 + 2 * 0.5 * 0.5 / 3))
    assert (m.faces < 14).all() and set(np.unique(m.faces)) == set(range(14))


# -- generalized cylinders --------------------------------------------------------------------------------------
def prism_area(radii, heights, slices=16) -> float:
    """Lateral area of a stack of regular ``slices``-gon frustums (radii at the ring vertices)."""
    total, half = 0.0, np.pi / slices
    for (r0, r1), h in zip(itertools.pairwise(radii), heights):
        a0, a1 = r0 * np.cos(half), r1 * np.cos(half)               # apothems
        e0, e1 = 2 * r0 * np.sin(half), 2 * r1 * np.sin(half)       # edges
        total += slices * 0.5 * (e0 + e1) * np.hypot(h, a1 - a0)
    return total


def test_gc_tube_exact_counts_radii_bounds_and_area():
    """``@Gc _(0.2) F F !(0.1) F @Ge``: points at z = 0..3, radii .2 .2 .1 .1 (``!`` sets the last point's)."""
    nodes, meshes = scene_of(";(1)@Gc_(0.2)F(1)F(1)!(0.1)F(1)@Ge")
    sh = nodes.shapes
    assert sh.kind.tolist() == [K.SH_TUBE] and sh.count.tolist() == [4]
    np.testing.assert_allclose(sh.points, [[0, 0, 0], [0, 0, 1], [0, 0, 2], [0, 0, 3]], atol=1e-12)
    np.testing.assert_allclose(sh.radius, [0.2, 0.2, 0.1, 0.1])
    m = meshes[1]
    assert (m.n_vertices, m.n_faces) == (4 * 16, 2 * 16 * 3) and (m.colors == BROWN).all()
    ring = m.vertices.reshape(4, 16, 3)
    np.testing.assert_allclose(np.hypot(ring[..., 0], ring[..., 1]), np.repeat([[0.2], [0.2], [0.1], [0.1]], 16, 1))
    np.testing.assert_allclose(ring[..., 2], np.repeat([[0.0], [1], [2], [3]], 16, 1), atol=1e-12)
    np.testing.assert_allclose(m.bounds, [[-0.2, -0.2, 0], [0.2, 0.2, 3]], atol=1e-12)
    assert m.area == pytest.approx(prism_area([0.2, 0.2, 0.1, 0.1], [1, 1, 1]), rel=1e-12)
    # the first ring starts along the turtle's left (0, -1, 0): PlantGL's initial normal
    np.testing.assert_allclose(ring[0, 0], [0, -0.2, 0], atol=1e-12)
    # outward faces: the normals point away from the axis
    fn, cen = m.face_normals, m.vertices[m.faces].mean(1)
    assert (np.einsum("ij,ij->i", fn[:, :2], cen[:, :2]) > 0).all()


def test_gc_branches_bends_and_end_of_string():
    """A branch starts its own tube at the parent's last point, drawn at ``]``; the parent's at ``@Ge``; an
    unclosed ``@Gc`` is drawn at the end of the string (PlantGL ``Turtle::stop``)."""
    nodes, meshes = scene_of("@GcF(1)[+(90)F(1)]F(1)@Ge")
    sh = nodes.shapes
    assert sh.kind.tolist() == [K.SH_TUBE, K.SH_TUBE] and sh.count.tolist() == [2, 3]
    np.testing.assert_allclose(sh.points[:2], [[0, 0, 1], [0, -1, 1]], atol=1e-12)
    np.testing.assert_allclose(sh.points[2:], [[0, 0, 0], [0, 0, 1], [0, 0, 2]], atol=1e-12)
    assert (meshes[1].n_vertices, meshes[1].n_faces) == (5 * 16, 2 * 16 * 3)
    # a bend: every ring stays at its radius from its point and perpendicular to the mean tangent
    nodes, meshes = scene_of("@Gc_(0.3)F(1)+(90)F(1)")
    assert nodes.shapes.module.tolist() == [-1]
    ring = meshes[1].vertices.reshape(3, 16, 3)
    pts = np.array([[0, 0, 0], [0, 0, 1], [0, -1, 1]])
    np.testing.assert_allclose(np.linalg.norm(ring - pts[:, None], axis=2), 0.3, atol=1e-12)
    t = np.array([[0, 0, 1], [0, -1, 1], [0, -1, 0]]) / np.array([1, np.sqrt(2), 1])[:, None]
    np.testing.assert_allclose(np.einsum("kjd,kd->kj", ring - pts[:, None], t), 0, atol=1e-12)
    # no tube from a single point; nothing without @Gc
    assert len(scene_of("@Gc+F(0)@Ge")[0].shapes) == 0


# -- spheres, discs, polygons -----------------------------------------------------------------------------------
def test_spheres_discs_and_a_polygon():
    nodes, meshes = scene_of("@O(0.5)f(2)_(0.3)@o[;(3)@O]{.f(1).+(90)f(1).+(90)f(1).}")
    sh = nodes.shapes
    assert sh.kind.tolist() == [K.SH_SPHERE, K.SH_CIRCLE, K.SH_SPHERE, K.SH_POLYGON]
    np.testing.assert_allclose(sh.size[:3], [0.5, 0.3, 0.3])        # @o and @O without a radius: the width
    assert sh.color.tolist() == [1, 1, 3, 1]
    sv, sf = sphere_mesh(16, 8)
    assert (len(sv), len(sf)) == (2 + 16 * 7, 2 * 16 * 7)
    m1, m3 = meshes[1], meshes[3]
    assert (m1.n_vertices, m1.n_faces) == (len(sv) + 17 + 4, len(sf) + 16 + 2)
    assert (m3.n_vertices, m3.n_faces) == (len(sv), len(sf)) and (m3.colors == (180, 0, 0)).all()
    big = m1.vertices[:len(sv)]
    np.testing.assert_allclose(np.linalg.norm(big, axis=1), 0.5)
    np.testing.assert_allclose([big.min(0), big.max(0)], [[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]], atol=1e-12)
    disc = m1.vertices[len(sv):len(sv) + 17]
    np.testing.assert_allclose(disc[0], [0, 0, 2])
    np.testing.assert_allclose(disc[:, 0], 0, atol=1e-12)                 # normal U = +x (PlantGL's Disc)
    np.testing.assert_allclose(np.linalg.norm(disc[1:] - disc[0], axis=1), 0.3)
    disc_area = tri_area(m1.vertices, m1.faces[len(sf):len(sf) + 16])
    assert disc_area == pytest.approx(0.5 * 16 * 0.3 ** 2 * np.sin(2 * np.pi / 16))
    sq = m1.vertices[-4:]
    np.testing.assert_allclose(sq, [[0, 0, 2], [0, 0, 3], [0, -1, 3], [0, -1, 2]], atol=1e-12)
    assert tri_area(m1.vertices, m1.faces[-2:]) == pytest.approx(1.0)
    assert m3.area == pytest.approx(tri_area(*sphere_mesh()) * 0.09)


def test_concave_polygon_ear_clipping_and_repeated_first_point():
    """An L-shaped hexagon (arms 3 x 1, area 5), outlined from the tip of one arm: ``}(1)`` (PlantGL's concave
    test) fills it exactly, the default fan from the first point does not; a closing point equal to the first
    is dropped."""
    path = "f(3)-(90)f(1){.-(90)f(2).+(90)f(2).-(90)f(1).-(90)f(3).-(90)f(3).-(90)f(1).}"
    concave = scene_of(path.replace(".}", ".}(1)"))[1][1]
    fan = scene_of(path)[1][1]
    outline = concave.vertices
    assert len(outline) == 6 and concave.n_faces == 4 and fan.n_faces == 4  # the 7th point closes the outline
    np.testing.assert_allclose(outline[:, 1:], [[1, 3], [1, 1], [3, 1], [3, 0], [0, 0], [0, 3]], atol=1e-12)
    assert polygon_area(outline[:, 1:]) == pytest.approx(5.0)
    assert concave.area == pytest.approx(5.0)
    assert fan.area > 5.5                                    # the fan's first triangle lies outside
    # ear clipping against an independent check: every triangle inside the outline (centroid test)
    from matplotlib.path import Path
    inside = Path(outline[:, 1:]).contains_points(outline[concave.faces].mean(1)[:, 1:])
    assert inside.all()
    np.testing.assert_array_equal(polygon_faces(np.eye(3)), [[0, 1, 2]])
    with pytest.raises(ValueError, match="points must hold at least 3 points, got 2"):
        polygon_faces(np.eye(3)[:2])


# -- named surfaces, materials, warnings ------------------------------------------------------------------------
@pytest.fixture
def blade():
    v = np.array([[0, -0.1, 0], [0, 0.1, 0], [0, 0, 1.0]])
    register_surface("blade", v, [[0, 1, 2]])
    yield v
    SURFACES.pop("blade")
    _TABLE.pop("~blade")
    TURTLE_MODULES.pop("~blade")


def test_user_surface_registry(blade):
    ls = grammar("F~blade(3)")
    assert ls.derive().names[-1] == "~blade"                          # one module, read as L-Py does
    nodes = ls.draw(ls.derive(), shapes=True)
    assert nodes.shapes.surface == ("blade",)
    m = shape_meshes(nodes.shapes)[1]
    np.testing.assert_allclose(m.vertices, [[0, -0.3, 1], [0, 0.3, 1], [0, 0, 4]], atol=1e-12)
    with pytest.raises(ValueError, match="name must be an identifier"):
        register_surface("a b", blade, [[0, 1, 2]])
    with pytest.raises(ValueError, match="faces must"):
        register_surface("bad", blade, [[0, 1, 5]])


def test_materials_and_ignored_sizes():
    assert tuple(material_rgb(0)) == (160, 160, 160) and tuple(material_rgb(99)) == (160, 160, 160)
    assert tuple(material_rgb(2)) == GREEN
    # SetColor: an index, an (r, g, b[, a]) colour of its own (L-Py's custom appearance), nothing: the index again
    # (PlantGL's setColor(getColor()) drops a custom appearance; ';' and ',' step from the index too)
    nodes = turtle_nodes(ModuleString.from_modules([
        ("SetColor", (3.0,)), "@O", ("SetColor", (255.0, 128.4, -3.0, 90.0)), "@O", "SetColor", "@O"]))
    assert nodes.shapes.color.tolist() == [3, K.CUSTOM_COLOR + 0xFF8000, 3]
    meshes = shape_meshes(nodes.shapes)
    assert [shape_name(k) for k in meshes] == ["shapes 3", "shapes #ff8000"]
    assert (meshes[K.CUSTOM_COLOR + 0xFF8000].colors == (255, 128, 0)).all()
    with pytest.warns(UserWarning, match=r"2 module\(s\) set a radius or scale below 0 .*first: @O at index 1"):
        nodes = turtle_nodes(ModuleString.from_modules(["F", ("@O", (-1.0,)), ("~l", (-2.0,)), ("@O", (0.0,))]))
    assert len(nodes.shapes) == 0 and shape_meshes(nodes.shapes) == {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert shape_meshes(turtle_nodes(ModuleString.from_modules(["F"])).shapes) == {}
    with pytest.raises(ValueError, match=r"module @O at index 0 takes 0 or 1 parameter\(s\), got 2"):
        turtle(ModuleString.from_modules([("@O", (1.0, 2.0))]))
    with pytest.raises(ValueError, match="slices must be"):
        shape_meshes(nodes.shapes, slices=2)


def test_engine_draws_the_flowers_it_used_to_refuse():
    """L-Py's training-model style grammar with ``;(4)@O`` flowers: drawn now, the skeleton unchanged."""
    from pathlib import Path
    text = (Path(__file__).parent / "grammars" / "continuous_growth.lpy").read_text()
    ls = LSystem(text, seed=2, trusted=True)
    s = ls.derive()
    nodes = ls.draw(s, shapes=True)
    n_flowers = int(np.count_nonzero(nodes.shapes.kind == K.SH_SPHERE))
    interp = ls.interpret(s)
    assert n_flowers == interp.count("@O") > 0 and set(nodes.shapes.color.tolist()) == {4}
    assert np.array_equal(nodes.tree.pos, ls.tree().pos)
    assert shape_meshes(nodes.shapes)[4].n_faces == n_flowers * 2 * 16 * 7
    with pytest.raises(LSystemError, match="unsupported module Arrow"):
        grammar("F Arrow").tree()


# -- the kernel and its twin ------------------------------------------------------------------------------------
def shape_string(rng: np.random.Generator, n: int) -> ModuleString:
    out, depth = [], 0
    kinds = ["F", "F", "f", "+", "-", "&", "/", "[", "]", "_", "!", ";", "%", "@Ts", "@O", "@o", "~l", "@Gc",
             "@Ge", "{", "}", ".", ".", "SetColor"]
    for _ in range(n):
        k = kinds[rng.integers(len(kinds))]
        if k == "]" and depth == 0:
            k = "F"
        depth += (k == "[") - (k == "]")
        counts = TURTLE_MODULES[k]
        c = counts[rng.integers(len(counts))]
        if k in ("_", "!", ";", "@O", "@o", "~l"):
            vals = tuple(rng.uniform(-0.3, 2, c))
        elif k == "SetColor":
            vals = tuple(rng.uniform(-20, 300, c))
        elif k == "}":
            vals = tuple(rng.integers(0, 2, c).astype(float))
        elif k == "@Ts":
            vals = tuple(rng.uniform(0, 0.5, c))
        else:
            vals = tuple(rng.uniform(-1, 2, c) if k in ("F", "f") else rng.uniform(-120, 120, c))
        out.append((k, vals))
    return ModuleString.from_modules(out)


@pytest.mark.filterwarnings("ignore:string. .* module.s. set")
def test_kernel_equals_python_twin_with_shapes():
    rng = np.random.default_rng(33)
    n_tubes = n_polys = 0
    for trial in range(40):
        s = shape_string(rng, int(rng.integers(1, 250)))
        op, depth, n_f = _ops(s)
        opts = _options(rng.uniform(5, 90), 1.0, 0.1, 0.5, (0.1, 0.2, 1.0), 0.2 * (trial % 2))
        out = K.turtle_kernel(op, s.arg_ptr, s.args, *opts, depth, 2 * n_f, *_capacities(op))
        twin = K.turtle_python(op, s.arg_ptr, s.args, *opts)
        nn, ns, nsp = out[7], out[13], out[14]
        for got, want in zip(out[:7], twin[:7]):
            np.testing.assert_allclose(got[:nn], want, atol=1e-9, err_msg=f"trial {trial}")
        assert out[8].tolist() == twin[7]
        np.testing.assert_array_equal(out[10][:ns], twin[8], err_msg=f"trial {trial}")
        np.testing.assert_allclose(out[11][:ns], twin[9], atol=1e-9, err_msg=f"trial {trial}")
        np.testing.assert_allclose(out[12][:nsp], twin[10], atol=1e-9, err_msg=f"trial {trial}")
        n_tubes += int(np.count_nonzero(twin[8][:, 0] == K.SH_TUBE))
        n_polys += int(np.count_nonzero(twin[8][:, 0] >= K.SH_POLYGON) - np.count_nonzero(twin[8][:, 0] == 6))
        shape_meshes(turtle_nodes(s).shapes)                        # every drawing meshes
    assert n_tubes > 15 and n_polys >= 3


def test_tube_mesh_and_polygon_checks():
    v, f = tube_mesh([[0, 0, 0], [0, 0, 0], [0, 0, 1]], [1, 1, 1], [0, -1, 0], slices=8)
    assert (len(v), len(f)) == (16, 16)                              # a repeated point is merged
    assert tube_mesh([[0, 0, 0]], [1], [0, -1, 0])[1].shape == (0, 3)
    with pytest.raises(ValueError, match="radius must have shape"):
        tube_mesh([[0, 0, 0], [0, 0, 1]], [1], [0, -1, 0])


# -- the document scene and the exporters -----------------------------------------------------------------------
LEAFY_TUBES = """\
Axiom: ;(1)@Gc_(0.08)A(4)
derivation length: 4
production:
A(n) --> F(0.5)[+(50);(2)~l(0.8)][-(50);(2)~l(0.8)]/(90)!(0.06)A(n-1)
endlsystem
"""


def test_document_scene_view_and_gltf_ply_export(tmp_path):
    import trimesh
    from pygltflib import GLTF2

    from plantvr.documents.lsystem import LSystemDocument
    from plantvr.io.scene import export_scene
    doc = LSystemDocument(LEAFY_TUBES)
    scene = doc.scene()
    assert sorted(scene) == ["shapes 1", "shapes 2", "tree"]
    tube, leaves = scene["shapes 1"], scene["shapes 2"]
    assert (tube.n_vertices, tube.n_faces) == (5 * 16, 2 * 16 * 4)     # @Gc + 4 F, drawn at the end
    assert (leaves.n_vertices, leaves.n_faces) == (8 * 7, 8 * 6)
    z_up = doc.shapes
    np.testing.assert_allclose(leaves.vertices, z_up[2].vertices[:, [0, 2, 1]] * [1, 1, -1])   # y-up
    assert scene["tree"].pos[:, 1].max() == pytest.approx(2.0) == tube.bounds[1, 1]
    glb = export_scene(doc, tmp_path / "leafy.glb")
    g = GLTF2().load(str(glb))
    assert [m.name for m in g.meshes] == ["shapes 1", "shapes 2"]   # F inside @Gc: the tube, no branch (L-Py)
    assert scene["tree"].n_internodes == 0 == int((scene["tree"].parent >= 0).sum())
    back = trimesh.load(glb, process=False)
    counts = {k: (len(m.vertices), len(m.faces)) for k, m in back.geometry.items()}
    assert counts["shapes 1"] == (80, 128) and counts["shapes 2"] == (56, 48)
    np.testing.assert_allclose(back.geometry["shapes 2"].vertices, leaves.vertices, atol=1e-6)
    mat = g.materials[g.meshes[1].primitives[0].material]
    np.testing.assert_allclose(mat.pbrMetallicRoughness.baseColorFactor[:3], np.array(GREEN) / 255, atol=1e-6)
    ply = trimesh.load(export_scene(doc, tmp_path / "leafy.ply"), process=False)
    assert (len(ply.vertices), len(ply.faces)) == (136, 176)
    assert (ply.visual.vertex_colors[80:, :3] == GREEN).all()
    with pytest.raises(ValueError, match=r"path suffix '.obj' is not a format written here"):
        export_scene(doc, tmp_path / "leafy.obj")
    # a step without leaves yet, and undo: the scene follows the document
    doc.set_step(0)
    assert sorted(doc.scene()) == ["tree"]
    doc.undo()
    assert sorted(doc.scene()) == ["shapes 1", "shapes 2", "tree"]


def test_view_draws_the_shapes_beside_the_tree():
    import os
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    pytest.importorskip("pyvista")
    import plantvr
    from plantvr.documents.lsystem import LSystemDocument
    doc = LSystemDocument(LEAFY_TUBES)
    view = plantvr.View(doc, window_size=(160, 160))
    try:
        assert {"tree", "shapes 1", "shapes 2"} <= set(view.layers)
        def greenish(img):
            r, g, b = (img[..., k].astype(int) for k in range(3))
            return int(((g - r > 40) & (g - b > 40)).sum())
        leafy = greenish(view.screenshot())
        doc.set_step(0)                                         # no leaves at step 0: their layer goes
        assert "shapes 2" not in view.layers
        assert leafy > 50 and greenish(view.screenshot()) == 0  # the leaves were on screen, in their colour
    finally:
        view.close()

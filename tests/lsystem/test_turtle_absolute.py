"""Issue 33 turtle parity: absolute moves and orientation (``@M``/``MoveTo``, ``MoveRel``, ``LineTo``, ``OLineTo``,
``LineRel``, ``OLineRel``, ``Pinpoint``, ``PinpointRel``, ``@R``/``SetHead``, ``EulerAngles``, ``iRollL``/``iRollR``),
``nF``, the turtle scale (``@D``, ``@Di``, ``@Dd``) and ``@L`` labels, against hand computations of PlantGL's
``turtle.cpp`` (``move``, ``shift``, ``lineTo``, ``oLineTo``, ``pinpoint``, ``setHead``, ``eulerAngles``, ``nF``,
``F``'s ``heading * length * scale.z``)."""
import numpy as np
import pytest

from plantvr.lsystem import LSystem, ModuleString
from plantvr.lsystem.turtle import LPY_UNSUPPORTED, TURTLE_MODULES, query_frames, turtle, turtle_nodes

S2 = np.sqrt(0.5)


def frame(mods):
    """Position, H, L, U at the end of ``mods`` (a ``?F`` appended)."""
    _, fr = query_frames(ModuleString.from_modules([*mods, "?F"]))
    return fr[-1]


def test_move_to_and_move_rel_start_new_roots():
    t = turtle(ModuleString.from_modules(["F", ("@M", (2.0, 3.0, 4.0)), "F", ("MoveRel", (1.0, -1.0)), "F"]))
    np.testing.assert_allclose(t.pos, [[0, 0, 0], [0, 0, 1], [2, 3, 4], [2, 3, 5], [3, 2, 5], [3, 2, 6]])
    assert t.parent.tolist() == [-1, 0, -1, 2, -1, 4]
    # L-Py's MoveTo(x) keeps y and z, MoveTo(None, y) keeps x, MoveTo() goes to the origin
    np.testing.assert_allclose(frame(["F", ("MoveTo", (5.0,))])[0], [5, 0, 1])
    np.testing.assert_allclose(frame(["F", ("MoveTo", (None, 7.0))])[0], [0, 7, 1])
    np.testing.assert_allclose(frame(["F", ("@M", ())])[0], [0, 0, 0])
    # a move to where the turtle stands does not break the axis
    t = turtle(ModuleString.from_modules([("@M", (0.0, 0.0, 0.0)), "F", ("MoveTo", (0.0, 0.0, 1.0)), "F"]))
    assert t.parent.tolist() == [-1, 0, 1]


def test_line_to_draws_to_the_point_and_keeps_or_takes_the_heading():
    s = ModuleString.from_modules([("LineTo", (1.0, 0.0, 1.0)), "F", ("OLineTo", (1.0, 1.0, 1.0)), "F",
                                   ("LineRel", (0.0, 0.0, 2.0, 0.5)), ("OLineRel", (3.0, 0.0, 0.0)), "F"])
    n = turtle_nodes(s)
    # LineTo: (1, 0, 1), heading still +Z, F to (1, 0, 2); OLineTo: to (1, 1, 1), heading (0, 1, -1)/sqrt 2;
    # F one step on; LineRel +2 z, top width 0.5, heading kept; OLineRel +3 x, heading +X; F one step on
    want = [[0, 0, 0], [1, 0, 1], [1, 0, 2], [1, 1, 1], [1, 1 + S2, 1 - S2], [1, 1 + S2, 3 - S2],
            [4, 1 + S2, 3 - S2], [5, 1 + S2, 3 - S2]]
    np.testing.assert_allclose(n.tree.pos, want, atol=1e-12)
    assert n.tree.parent.tolist() == [-1, 0, 1, 2, 3, 4, 5, 6]
    np.testing.assert_allclose(n.tree.radius, [0.1] * 5 + [0.5] * 3)
    assert n.module.tolist() == [0, 0, 1, 2, 3, 4, 5, 6]
    np.testing.assert_allclose(frame(s.modules())[1], [1, 0, 0], atol=1e-12)
    # a segment is drawn toward the point, then tropism bends it (F's _applyTropism), as in PlantGL
    bent = turtle(ModuleString.from_modules([("@Ts", (0.5,)), ("@Tp", (1.0, 0.0, 0.0)), ("LineTo", (0.0, 0.0, 2.0))]))
    np.testing.assert_allclose(bent.pos[1], [2 * np.sin(np.pi / 4), 0, 2 * np.cos(np.pi / 4)], atol=1e-12)
    # no point (or the turtle's own position) draws nothing
    assert len(turtle(ModuleString.from_modules([("LineTo", ()), ("OLineTo", (0.0, 0.0, 0.0))]))) == 0


def test_pinpoint_turns_the_frame_the_shortest_way():
    # H = +Z toward +X: a quarter turn about H x t = +Y: U = +X goes to -Z, L = -Y stays
    p, h, left, up = frame([("Pinpoint", (5.0, 0.0, 0.0))])
    np.testing.assert_allclose([p, h, left, up], [[0, 0, 0], [1, 0, 0], [0, -1, 0], [0, 0, -1]], atol=1e-12)
    p, h, left, up = frame(["F", ("Pinpoint", (0.0, 1.0, 1.0))])            # from (0, 0, 1): toward +Y
    np.testing.assert_allclose([h, left, up], [[0, 1, 0], [0, 0, 1], [1, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(frame(["F", ("PinpointRel", (0.0, 1.0, 0.0))])[1], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(frame([("Pinpoint", (0.0, 0.0, -1.0))])[1:], [[0, 0, -1], [0, 1, 0], [1, 0, 0]],
                               atol=1e-12)                                  # behind: half a turn about U
    assert len(turtle(ModuleString.from_modules([("Pinpoint", (1.0, 2.0, 3.0))]))) == 0


def test_set_head_euler_angles_and_intrinsic_rolls():
    # SetHead(h, u): L = u x h
    np.testing.assert_allclose(frame([("@R", (0.0, 1.0, 0.0, 0.0, 0.0, 1.0))])[1:],
                               [[0, 1, 0], [-1, 0, 0], [0, 0, 1]], atol=1e-12)
    # a non-orthogonal up vector is re-orthogonalised; no up vector: PinpointRel; no parameter: the initial frame
    np.testing.assert_allclose(frame([("SetHead", (0.0, 0.0, 2.0, 1.0, 0.0, 1.0))])[1:],
                               [[0, 0, 1], [0, -1, 0], [1, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(frame([("SetHead", (3.0, 0.0, 0.0))])[1:], frame([("PinpointRel", (1.0, 0.0, 0.0))])[1:])
    np.testing.assert_allclose(frame([("+", (40.0,)), ("@R", ())])[1:], [[0, 0, 1], [0, -1, 0], [1, 0, 0]], atol=1e-12)
    with pytest.raises(ValueError, match=r"SetHead at index 0: SetHead needs a non-null heading"):
        turtle(ModuleString.from_modules([("SetHead", (0.0, 0.0, 0.0))]))
    with pytest.raises(ValueError, match=r"@R at index 1: .* are colinear"):
        turtle(ModuleString.from_modules(["F", ("@R", (0.0, 0.0, 1.0, 0.0, 0.0, -2.0))]))
    # EulerAngles(azimuth, elevation, roll): H = Rz(a) Ry(-e) Rx(r) x, U = ... z; defaults: the initial frame
    np.testing.assert_allclose(frame([("EulerAngles", (90.0, 0.0, 0.0))])[1:], [[0, 1, 0], [-1, 0, 0], [0, 0, 1]],
                               atol=1e-12)
    c, s = np.cos(np.radians(30)), 0.5
    np.testing.assert_allclose(frame([("EulerAngles", (0.0, 30.0, 0.0))])[1:], [[c, 0, s], [0, 1, 0], [-s, 0, c]],
                               atol=1e-12)
    np.testing.assert_allclose(frame(["/", "&", ("EulerAngles", ())])[1:], [[0, 0, 1], [0, -1, 0], [1, 0, 0]],
                               atol=1e-12)
    # roll 90 about H = +X: U = +Z goes to Rx(90) z = -Y, L = U x H
    np.testing.assert_allclose(frame([("EulerAngles", (0.0, 0.0, 90.0))])[1:], [[1, 0, 0], [0, 0, 1], [0, -1, 0]],
                               atol=1e-12)
    # without a guide PlantGL's iRollL / iRollR are rollL / rollR
    np.testing.assert_allclose(frame(["&", ("iRollL", (30.0,)), "iRollR"]), frame(["&", ("/", (30.0,)), "\\"]))


def test_nf_draws_n_steps_and_the_rest_with_interpolated_widths():
    t = turtle(ModuleString.from_modules([("nF", (2.5, 1.0))]))
    np.testing.assert_allclose(t.pos[:, 2], [0, 1, 2, 2.5])
    assert t.parent.tolist() == [-1, 0, 1, 2]
    t = turtle(ModuleString.from_modules([("nF", (3.0, 1.0))]))              # no rest
    np.testing.assert_allclose(t.pos[:, 2], [0, 1, 2, 3])
    # nF(length, dl, radius): w += (radius - w) / length * dl each step, the rest ends at radius
    t = turtle(ModuleString.from_modules([("nF", (2.5, 1.0, 0.5)), "F"]))
    np.testing.assert_allclose(t.radius, [0.1, 0.26, 0.42, 0.5, 0.5])
    np.testing.assert_allclose(t.pos[-1], [0, 0, 3.5])
    sh = turtle_nodes(ModuleString.from_modules(["@Gc", ("nF", (10.0, 1.0)), ("LineRel", (1.0, 0.0, 0.0)),
                                                 "@Ge"])).shapes
    assert sh.count.tolist() == [12]                                        # one tube point per step
    with pytest.raises(ValueError, match=r"nF at index 1: nF\(length, dl\) needs length >= 0 and dl > 0"):
        turtle(ModuleString.from_modules(["F", ("nF", (1.0, 0.0))]))
    with pytest.raises(ValueError, match=r"past 100000000 segments"):
        turtle(ModuleString.from_modules([("nF", (1e6, 1e-3))]))


def test_scale_multiplies_steps_and_widths_and_is_pushed():
    t = turtle(ModuleString.from_modules([("@D", (2.0,)), "F", "[", ("@Di", ()), "F", "]", ("@Dd", ()), "F",
                                          ("SetScale", ()), "F", ("f", (1.0,)), ("MultScale", (3.0,)), "f", "F"]))
    # @D(2): F 2 long, width 0.2; [@Di: x 0.5, F 1 long]; @Dd: / 0.5 -> 4: F 4 long; @D(): 1; f 1; x 3: f, F 3 long
    np.testing.assert_allclose(t.pos[:, 2], [0, 2, 3, 6, 7, 11, 14])
    np.testing.assert_allclose(t.radius, [0.2, 0.2, 0.1, 0.4, 0.1, 0.3, 0.3])
    assert t.parent.tolist() == [-1, 0, 1, 1, 3, -1, 5]
    t = turtle(ModuleString.from_modules([("@D", (-2.0,)), "F", ("@B", (1.0,))]))   # a negative scale: backwards
    np.testing.assert_allclose(t.pos, [[0, 0, 0], [0, 0, -2]])
    np.testing.assert_allclose(t.radius, [0.2, 0.2])
    with pytest.warns(UserWarning, match=r"1 module\(s\) set a turtle scale beyond 1e6 \(or divided by 0\).*"
                                         r"DivScale at index 0"):
        t = turtle(ModuleString.from_modules([("DivScale", (0.0,)), "F"]))
    np.testing.assert_allclose(t.pos[-1], [0, 0, 1])


def test_labels_are_recorded_not_drawn():
    s = ModuleString.from_modules(["F", ("@L", ("top", 12)), ("+", (90.0,)), "F", ("Label", (3.0,))])
    n = turtle_nodes(s)
    assert len(n.tree) == 3 and len(n.shapes) == 0
    assert [(lb.text, lb.module, lb.size) for lb in n.labels] == [("top", 1, 12), ("3", 4, -1)]
    np.testing.assert_allclose([lb.position for lb in n.labels], [[0, 0, 1], [0, -1, 1]], atol=1e-12)
    ls = LSystem('Axiom: F(2) @L("hi") @M(1, 0, 0) F\n')
    got = ls.draw(ls.axiom, shapes=True)
    assert [lb.text for lb in got.labels] == ["hi"] and got.tree.parent.tolist() == [-1, 0, -1, 2]


def test_unsupported_list_is_honest():
    done = {"@M", "MoveTo", "MoveRel", "LineTo", "OLineTo", "LineRel", "OLineRel", "Pinpoint", "PinpointRel",
            "@R", "SetHead", "EulerAngles", "iRollL", "iRollR", "nF", "@D", "SetScale", "@Di", "MultScale",
            "@Dd", "DivScale", "@L", "Label", "@B", "Box", "@b", "Quad", "Frame", "surface", "~"}
    assert done <= set(TURTLE_MODULES) and not done & LPY_UNSUPPORTED


def test_box_and_quad_are_shapes_along_a_step():
    from plantvr.lsystem import _turtle_kernels as K
    from plantvr.lsystem.shapes import box_mesh, quad_mesh, shape_meshes
    s = ModuleString.from_modules([("_", (0.5,)), ("@B", (2.0,)), "F", ("+", (90.0,)), ("Quad", (1.0, 0.25)), "F",
                                   ("Box", (-1.0, 0.0))])
    n = turtle_nodes(s)
    # the box moves the turtle 2 up without a node; F from (0, 0, 2) to (0, 0, 3); + turns H to L = (0, -1, 0);
    # the quad moves 1 on and sets the width to 0.25; F from (0, -1, 3) a new root; Box(-1): drawn backwards
    np.testing.assert_allclose(n.tree.pos, [[0, 0, 2], [0, 0, 3], [0, -1, 3], [0, -2, 3]], atol=1e-12)
    assert n.tree.parent.tolist() == [-1, 0, -1, 2]
    np.testing.assert_allclose(n.tree.radius, [0.5, 0.5, 0.25, 0.25])
    sh = n.shapes
    assert sh.kind.tolist() == [K.SH_BOX, K.SH_QUAD, K.SH_BOX] and sh.module.tolist() == [1, 4, 6]
    np.testing.assert_allclose(sh.size, [2, 1, 1])
    np.testing.assert_allclose(sh.radii, [[0.5, 0.5], [0.5, 0.25], [0.25, 0.0]])
    np.testing.assert_allclose(sh.frame[2, :2], [[0, -2, 3], [0, 1, 0]], atol=1e-12)      # turned around
    # the box: corners +-0.5 U +-0.5 (-L) at z 0 and 2 (U = +X, -L = +Y): the square prism [-.5, .5]^2 x [0, 2]
    v, f = box_mesh(sh.frame[0], sh.size[0], *sh.radii[0])
    np.testing.assert_allclose(np.sort(v, axis=0)[[0, -1]], [[-0.5, -0.5, 0], [0.5, 0.5, 2]])
    e = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
    normals = np.cross(*e)
    assert np.all(np.einsum("ij,ij->i", normals, v[f].mean(axis=1) - [0, 0, 1]) > 0)   # outward
    assert abs(np.sum(np.einsum("ij,ij->i", v[f[:, 0]], normals)) / 6 - 2.0) < 1e-12    # volume 1 x 1 x 2
    # the quad: bottom (0, 0, 3) +- 0.5 L, top (0, -1, 3) -+ 0.25 L, with L = U x H = X x -Y = -Z after the +
    v, f = quad_mesh(sh.frame[1], sh.size[1], *sh.radii[1])
    np.testing.assert_allclose(v, [[0, 0, 2.5], [0, 0, 3.5], [0, -1, 3.25], [0, -1, 2.75]], atol=1e-12)
    assert f.tolist() == [[0, 1, 2], [0, 2, 3]]
    meshes = shape_meshes(sh)
    assert sum(m.n_faces for m in meshes.values()) == 12 + 2 + 12
    assert len(quad_mesh(sh.frame[1], 1.0, 0.0, 0.0)[1]) == 0 and len(quad_mesh(sh.frame[1], 1.0, 0.0, 1.0)[1]) == 1


def test_frame_is_recorded_not_meshed():
    n = turtle_nodes(ModuleString.from_modules(["F", "Frame", ("&", (90.0,)), ("Frame", (2.0, 0.5)),
                                                ("Frame", (1.0, 1.0))]))
    assert len(n.shapes) == 0 and n.frame_size.tolist() == [1.0, 2.0]                    # cap ratio 1: not drawn
    np.testing.assert_allclose(n.frames[1], [[0, 0, 1], [-1, 0, 0], [0, -1, 0], [0, 0, 1]], atol=1e-12)


def test_scale_sizes_spheres_discs_and_surfaces():
    from plantvr.lsystem.shapes import shape_meshes
    sh = turtle_nodes(ModuleString.from_modules([("@D", (2.0,)), ("@O", (1.0,)), ";", ("@Di", (1.5,)), ("@o", (0.5,)),
                                                 ";", ("~l", (1.0,)), ";", ("@D", ()), ("@O", (1.0,))])).shapes
    np.testing.assert_allclose(sh.scale, [[2, 2, 2], [3, 3, 3], [3, 3, 3], [1, 1, 1]])
    m = shape_meshes(sh)
    extent = {k: np.ptp(v.vertices, axis=0) for k, v in m.items()}
    np.testing.assert_allclose(extent[1], [4, 4, 4], atol=1e-9)            # sphere of radius 1 x 2
    assert abs(extent[2].max() - 3.0) < 1e-9                                 # disc of radius 0.5 x 3
    assert abs(extent[3][2] - 3.0) < 1e-9                                    # the leaf: 1 long along H, x 3
    np.testing.assert_allclose(extent[4], [2, 2, 2], atol=1e-9)


def test_surface_by_name():
    from plantvr.lsystem.shapes import shape_meshes
    s = ModuleString.from_modules([("surface", ("l", 2.0)), ("~", ("l",)), ("~l", (2.0,))])
    sh = turtle_nodes(s).shapes
    assert sh.surface == ("l", "l", "l") and sh.size.tolist() == [2.0, 1.0, 2.0]
    v = shape_meshes(sh)[1].vertices
    np.testing.assert_allclose(v[:7], v[14:21])                           # surface('l', 2) is ~l(2)
    with pytest.raises(ValueError, match=r"module surface at index 0: the surface name must be a non-empty str"):
        turtle(ModuleString.from_modules([("surface", (3.0,))]))
    with pytest.raises(ValueError, match=r"unknown surface\(s\) \['nope'\]"):
        shape_meshes(turtle_nodes(ModuleString.from_modules([("surface", ("nope",))])).shapes)

"""More of L-Py's grammar language (issue 33): value constraints in patterns (``LpyParsing::parse_variable``), blanks
before a module's parameters (``parseAModule``), the empty axiom, ``ParameterSet``, texture materials, and the hooks
that read L-Py's scene refused by name."""
import re

import numpy as np
import pytest

from plantvr.lsystem import LSystem, LSystemError


def _derive(text, n=None, **kw):
    ls = LSystem(text, **kw)
    return str(ls.derive(n) if n is not None else ls.derive())


CONSTRAINED = """Axiom: A(1) B(2) A(-3) C(5) C(1)
derivation length: 1
production:
*(n in 'AB', x) --> N(x)
*(n, x if x > 4) --> Big(n, x)
endlsystem
"""


@pytest.mark.parametrize("trusted", [False, True])
def test_value_constraints_bind_the_name_and_must_hold(trusted):
    """``*(n in 'SU', x)`` binds the module's name to ``n`` and matches only where ``n in 'SU'``; ``x if x > 4``
    binds ``x`` and tests what follows ``if``; a module no rule matches is copied (hand-derived)."""
    assert _derive(CONSTRAINED, trusted=trusted) == "N(1)N(2)N(-3)Big('C',5)C(1)"


def test_value_constraints_in_contexts_fall_through_to_the_next_rule():
    """decasteljau.lpy's rules (L-Py's tutorial 03): ``P(v, s == Any)`` / ``P(v, s != Any)`` in a context-sensitive
    rule, and a Python block whose constraint fails tries the next rule."""
    g = """Any = None
Axiom: E P(1, None) E P(2, 3) E
derivation length: 1
production:
E < P(v, s == Any) > E --> Q(v)
E < P(v, s != Any) > E --> I P(v, s) I
endlsystem
"""
    assert _derive(g, trusted=True) == "EQ(1)EIP(2,3)IE"
    block = """Axiom: A(1) A(7)
derivation length: 1
production:
A(x if x > 5) :
  y = 2 * x
  produce B(y)
A(x) --> C(x)
endlsystem
"""
    assert _derive(block, trusted=True) == "C(1)B(14)"


def test_value_constraints_take_the_vectorised_path_with_the_same_result():
    """A one-line rule with a constraint on numbers runs as a numpy condition over the parameter column; its string
    equals the per-module Python evaluation of the same rules (10,000 modules)."""
    g = "Axiom: " + " ".join(f"A({k})" for k in range(10_000)) + """
derivation length: 2
production:
A(x if x % 3 == 0) --> A(x + 1) B
A(x) --> A(x)
endlsystem
"""
    fast, slow = LSystem(g), LSystem(g, trusted=True)
    # step 1: A(k) with k % 3 == 0 gives A(k + 1) B; step 2 keeps A(k + 1), (k + 1) % 3 == 1, and B
    want = "".join(f"A({k + 1})B" if k % 3 == 0 else f"A({k})" for k in range(10_000))
    assert str(fast.derive()) == str(slow.derive()) == want


@pytest.mark.parametrize("bad, where", [("A(x if)", "pattern parameter 'x if'"),
                                        ("A(1 +)", "pattern parameter '1 +'"),
                                        ("x(A(y if y > 1))", "value constraints inside a repetition")])
def test_bad_pattern_parameters_are_refused_with_their_line(bad, where):
    g = f"Axiom: A(1)\nderivation length: 1\nproduction:\n{bad} < B --> B\nendlsystem\n" if bad.startswith("x(") \
        else f"Axiom: A(1)\nderivation length: 1\nproduction:\n{bad} --> B\nendlsystem\n"
    with pytest.raises(LSystemError, match=rf"line 4.*{re.escape(where)}") as err:
        LSystem(g)
    assert err.value.column >= 1


def test_blanks_may_stand_between_a_module_and_its_parameters():
    """orchidee.lpy writes ``MyGC (leafAxis, ...)``: L-Py's ``parseAModule`` skips blanks before the '('."""
    g = "Axiom: A (1) B\t(2, 3) C\nderivation length: 1\nproduction:\nA (x) --> D (x + 1)\nendlsystem\n"
    assert _derive(g) == "D(2)B(2,3)C"


def test_an_empty_axiom_is_the_empty_string():
    """An 'Axiom:' line with nothing after it, or none at all (L-Py's ``Lsystem::clear``: the composition
    tutorial's modules), is the empty L-string."""
    ls = LSystem("Axiom:\n\nderivation length: 2\nproduction:\nA --> B\nendlsystem\n")
    assert str(ls.derive()) == "" and ls.tree().n_internodes == 0
    assert str(LSystem("derivation length: 1\nproduction:\nF --> FF\n").derive()) == ""


def test_parameter_set_is_in_every_grammar_namespace():
    """``ParameterSet`` (``openalea.lpy.parameterset``), which L-Py grammars use without importing it."""
    g = """p = ParameterSet(length=2, angle=30)
p.setdefault('length', 9, 'width', 0.5)
p['angle'] += 15
Axiom: F(p.length) +(p.get('angle')) F(p.width) F(p.get('missing', 7))
derivation length: 0
production:
endlsystem
"""
    ls = LSystem(g, trusted=True)
    assert str(ls.axiom) == "F(2)+(45)F(0.5)F(7)"
    from plantvr.lsystem.context import ParameterSet
    p = ParameterSet(a=1)
    p.rename("a", "b")
    assert "b" in p and "a" not in p and p.parameter_names() == ["b"] and p.copy().b == 1
    with pytest.raises(ValueError, match="pairs"):
        p.setdefault("x")


def test_image_textures_draw_in_their_mean_colour(tmp_path):
    """``ImageTexture`` / ``Texture2D`` (the editor's texture materials) are materials of the image's mean colour
    (alpha-weighted); a missing file draws grey."""
    from PIL import Image

    from plantvr.lsystem.plantgl import ImageTexture, Texture2D
    img = np.zeros((4, 4, 4), np.uint8)
    img[:2] = (200, 40, 0, 255)
    img[2:] = (0, 0, 255, 0)                     # transparent: not counted
    Image.fromarray(img, "RGBA").save(tmp_path / "leaf.png")
    t = ImageTexture("T", str(tmp_path / "leaf.png"))
    assert t.rgb() == (200, 40, 0) and t.name == "T"
    assert Texture2D(image=t).rgb() == (200, 40, 0) and ImageTexture(str(tmp_path / "nope.png")).rgb() == (128,) * 3
    g = f"""Axiom: ,(9) F
derivation length: 0
production:
endlsystem
###### INITIALISATION ######
def __initialiseContext__(context):
\timport openalea.plantgl.all as pgl
\ttex = pgl.ImageTexture("PGL_1", {str(tmp_path / 'leaf.png')!r})
\tcontext.turtle.setMaterial(9, pgl.Texture2D(image = tex , ))
"""
    ls = LSystem(g, trusted=True)
    assert ls.materials[9][1] == (200, 40, 0)
    with pytest.raises(ValueError, match="Texture2D needs image"):
        Texture2D(image=3)


def test_context_tests_walk_along_the_string_and_bind_variables():
    """``InLeftContext(pattern, args)`` / ``InRightContext`` (L-Py's ``LstringMatcher``): a match moves the edge
    past what it matched, so calls in a row walk outward; ``args`` gets the pattern's values (L-Py's tests
    test_in_left_context, test_multiple_inleftcontext, test_in_right_context, rewritten; strings hand-derived)."""
    g = """Axiom: C B B B A(7) E(1) E(2) D
derivation length: 1
production:
A(x) :
  n = 0
  while InLeftContext(B):
    n += 1
  got = {}
  right = InRightContext(E(u) E(v), got)
  after = inRightContext('D')
  produce R(x, n, got['u'], got['v'], right and after, InLeftContext(C), InLeftContext(B))
endlsystem
"""
    assert _derive(g, trusted=True) == "CBBBR(7,3,1,2,True,True,False)E(1)E(2)D"
    left = """Axiom: D D A(1) B
derivation length: 1
production:
B :
  params = {}
  if inLeftContext('A(x)', params) and not InLeftContext(G) and InLeftContext(D):
    produce C(params['x'])
endlsystem
"""
    assert _derive(left, trusted=True) == "DDA(1)C(1)"
    with pytest.raises(LSystemError, match="line 6.*InLeftContext.s second argument must be a dict"):
        LSystem(left.replace("inLeftContext('A(x)', params)", "InLeftContext(A(x), 3)"), trusted=True).derive()
    with pytest.raises(LSystemError, match="InLeftContext is called outside a production rule"):
        LSystem("x = InLeftContext('A')\nAxiom: A\nproduction:\nendlsystem\n", trusted=True)


def _face_normals_point_out(v, f, axis_point, axis_dir):
    """Whether every face's normal points away from the axis (the line through ``axis_point`` along ``axis_dir``)."""
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    c = v[f].mean(1) - axis_point
    radial = c - np.outer(c @ axis_dir, axis_dir)
    return bool(np.all(np.einsum("ij,ij->i", n, radial) > 0))


@pytest.mark.parametrize("turn", [1, -1])
def test_tube_cross_section_is_the_contour_scaled_by_the_radius(turn):
    """PlantGL's extrusion of a ``SetContour`` section: the contour's x along the section's first direction (the
    turtle's left, projected), y along the second, times the radius; closed either way round, faces outward."""
    from plantvr.lsystem.shapes import tube_mesh
    square = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1], [1, 1]], float)[::turn]
    v, f = tube_mesh([[0, 0, 0], [0, 0, 2]], [0.5, 0.5], [1, 0, 0], contour=square)
    assert v.shape == (8, 3) and f.shape == (8, 3)
    np.testing.assert_allclose(np.abs(v[:, :2]), 0.5)                 # every corner at (±1, ±1) x 0.5
    assert _face_normals_point_out(v, f, np.zeros(3), np.array([0.0, 0, 1]))
    sheet = tube_mesh([[0, 0, 0], [0, 0, 1], [0, 0, 2]], [1, 1, 1], [1, 0, 0], contour=[[-1, 0], [0, 0.2], [1, 0]])
    assert sheet[0].shape == (9, 3) and sheet[1].shape == (2 * 2 * 2, 3)     # open: a sheet, no closing faces


def test_set_contour_applies_to_the_tubes_started_after_it():
    """``SetContour`` sets the section; ``@Gc`` takes the current one (PlantGL's ``initial.crossSection``); a
    branch restores it on ``]``; a contour set inside a running tube waits for the next tube."""
    from plantvr.lsystem.shapes import shape_meshes
    g = """import openalea.plantgl.all as pgl
sq = pgl.Polyline2D([(1, 1), (-1, 1), (-1, -1), (1, -1), (1, 1)])
tri = pgl.Polyline2D([(1, 0), (-0.5, 0.8), (-0.5, -0.8), (1, 0)])
Axiom: _(0.5) SetContour(sq) [ SetContour(tri) @Gc F F @Ge ] @Gc F SetContour(tri) F @Ge
derivation length: 0
production:
endlsystem
"""
    ls = LSystem(g, trusted=True)
    nodes = ls.draw(ls.derive(), shapes=True)
    tubes = [c for c in nodes.shapes.contour if c is not None]
    assert len(tubes) == 2
    assert len(tubes[0]) == len(tubes[1])
    first, second = tubes                                      # string order of closing: the branch's first
    assert np.allclose(first[0], [1, 0]) and np.allclose(second[0], [1, 1])   # triangle, then the square again
    (mesh,) = shape_meshes(nodes.shapes).values()
    assert np.isfinite(mesh.vertices).all() and len(mesh.faces) > 0
    bad = LSystem("Axiom: @Gc SetContour(3) @Gc F @Ge\nderivation length: 0\nproduction:\nendlsystem\n")
    with pytest.raises((LSystemError, ValueError), match="SetContour at index 1 needs a 2-D curve"):
        bad.draw(bad.derive(), shapes=True)


def test_hooks_get_an_lstring_they_can_index_edit_and_extend():
    """L-Py's hook API (its tests test_deflateargs, test_endeach_modif, test_lstring_change2, rewritten): a hook's
    ``lstring[i][k]`` reads a parameter, ``lstring[i][k] = v`` changes it in the string, ``lstring += 'B'`` returned
    replaces the string; ``==`` compares the text."""
    g = """def EndEach(lstring):
  lstring[0][1] = lstring[0][0] + 10
  assert lstring[0].name == 'A' and len(lstring[0]) == 2 and lstring == Lstring('A(1,11) B')

def End(lstring):
  global ended
  ended = str(lstring + 'C(3)')

Axiom: A(1, 0) B
derivation length: 1
production:
B --> B
endlsystem
"""
    ls = LSystem(g, trusted=True)
    assert str(ls.derive()) == "A(1,11)B" and ls._ns["ended"] == "A(1,11)BC(3)"
    grow = """def EndEach(lstring):
  assert len(lstring) == getIterationNb() + 1
  lstring += 'B'
  return lstring

Axiom: A
derivation length: 3
production:
A --> A
endlsystem
"""
    assert _derive(grow, trusted=True) == "ABBB"
    with pytest.raises(LSystemError, match="EndEach\\(\\) raised IndexError: lstring index 5 out of range"):
        LSystem("def EndEach(s):\n  s[5]\nAxiom: A\nderivation length: 1\nproduction:\nendlsystem\n",
                trusted=True).derive()


@pytest.mark.parametrize("text, what", [
    ("module B : scale = two\nAxiom: B\nproduction:\nendlsystem\n", r"line 1, column 20: a module scale must be an integer"),
    ("module B : colour = 2\nAxiom: B\nproduction:\nendlsystem\n", r"line 1, column 12: unknown module option"),
    ("module B : base = (A, 3)\nAxiom: B\nproduction:\nendlsystem\n", r"module base '3' is not a module name"),
    ("Axiom: A\nproduction:\n$A(a, b) :\n  produce B\nendlsystem\n", r"line 3, column 1: a \$ pattern binds"),
])
def test_module_options_and_getmodule_are_checked(text, what):
    """``: scale = n`` and ``: base = A`` are read (multiscale matching, :mod:`test_multiscale`); a bad option is
    refused with its column, and a ``$`` pattern or successor that is not ``$A(a)`` / ``$a``
    (:mod:`test_getmodule`)."""
    with pytest.raises(LSystemError, match=what):
        LSystem(text, trusted=True)


def test_nsproduce_puts_an_lstring_in_the_successor():
    """L-Py's tutorial ``02 - fractals/ifs.lpy``: ``StartEach`` keeps the string and replaces it by ``@Ls``, which
    the production turns into four copies and the decomposition back into the kept string (``nsproduce``):
    S(k+1) = @Di(1/3) S(k) + S(k) -- S(k) + S(k) @Di(3), so 1, 10, 46, 190, 766 modules (hand-derived)."""
    g = """module @Ls
previousString = None
def StartEach(lstring):
  global previousString
  previousString = lstring
  return Lstring('@Ls')

Axiom: F
derivation length: 2
production:
decomposition:
maximum depth: 1
@Ls : nsproduce(previousString)
production:
@Ls --> @Di(0.5) @Ls + @Ls -- @Ls + @Ls @Di(2)
endlsystem
"""
    ls = LSystem(g, trusted=True)
    assert str(ls.derive(1)) == "@Di(0.5)F+F--F+F@Di(2)"
    assert len(ls.derive(4)) == 766
    with pytest.raises(LSystemError, match="nsproduce needs an lstring, got int"):
        LSystem(g.replace("nsproduce(previousString)", "nsproduce(3)"), trusted=True).derive(1)


def test_internodes_inside_a_tube_are_drawn_by_the_tube_only():
    """PlantGL's turtle draws no cylinder for an ``F`` in a generalized cylinder (a point of the tube): the scene's
    tree keeps only the internodes outside ``@Gc`` ... ``@Ge`` (a branch ``[`` stays in the tube, ``]`` restores),
    while the document's skeleton (Yggdrasil, the step's TreeArrays) keeps every internode."""
    from plantvr.documents import LSystemDocument
    doc = LSystemDocument("Axiom: _(0.2) @Gc F F [ + F ] F @Ge F [ @Gc F ] F\nderivation length: 0\nproduction:\n"
                          "endlsystem\n")
    drawn = doc.scene()["tree"]
    assert doc.tree.n_internodes == 7
    assert int((drawn.parent >= 0).sum()) == 2                     # the F after @Ge and the last F
    np.testing.assert_array_equal(drawn.pos, doc.scene()["tree"].pos)
    assert len([k for k in doc.scene() if k.startswith("shapes")]) == 1 and len(doc.shapes) == 1
    plain = LSystemDocument("Axiom: F F\nderivation length: 0\nproduction:\nendlsystem\n")
    assert plain.scene()["tree"].n_internodes == 2


SWEEP = """import openalea.plantgl.all as pgl
path = pgl.Polyline2D([(0, 0), (1, 0)])
section = pgl.Polyline2D([(-1, 0), (1, 0)])
widths = pgl.QuantisedFunction([(0, 1), (1, 3)])
Axiom: Sweep(path, section, 1, 0.25, 2, widths)
derivation length: 0
production:
endlsystem
"""


def test_sweep_is_a_guide_a_section_and_nf_with_a_radius_function():
    """``Turtle::sweep``: ``SetGuide(path, length) SetContour(section) nF(length, dl, radius, radiusvariation)``;
    ``nF`` sets the width to radius * f(first x), then each of its int(length / dl) steps ends at
    radius * f(x + dl / length * (last x - first x)) (hand-derived: 2, 3, 4, 5, 6); the moves make one open sheet
    (the section is a segment) and no branch."""
    ls = LSystem(SWEEP, trusted=True)
    nodes = ls.draw(ls.derive(), shapes=True)
    (tube,) = np.flatnonzero(nodes.shapes.kind == 6)                       # K.SH_TUBE
    a, b = nodes.shapes.start[tube], nodes.shapes.start[tube] + nodes.shapes.count[tube]
    np.testing.assert_allclose(nodes.shapes.radius[a:b], [2, 3, 4, 5, 6], rtol=1e-9)
    np.testing.assert_allclose(nodes.shapes.points[b - 1], [0, 0, 1], atol=1e-9)    # 1 along the guide (heading)
    assert nodes.tube.all() and int((nodes.drawn_tree().parent >= 0).sum()) == 0
    assert nodes.shapes.contour[tube].shape == (33, 2)
    from plantvr.lsystem.shapes import shape_meshes
    (mesh,) = shape_meshes(nodes.shapes).values()
    assert len(mesh.faces) == 2 * 32 * 4                                    # open section: 32 strips x 4 steps
    with pytest.raises(ValueError, match="Sweep at index 0 needs"):              # as the turtle's other checks
        bad = LSystem("Axiom: Sweep(1, 2)\nderivation length: 0\nproduction:\nendlsystem\n")
        bad.draw(bad.derive(), shapes=True)


def test_a_move_with_a_section_outside_a_tube_is_a_tube_of_its_own():
    """PlantGL's ``smallSweep``: with a section set, an ``F`` outside ``@Gc`` draws the section along the move, not a
    cylinder; without one it stays a branch."""
    g = """import openalea.plantgl.all as pgl
sq = pgl.Polyline2D([(1, 1), (-1, 1), (-1, -1), (1, -1), (1, 1)])
Axiom: _(0.5) F [ SetContour(sq) + F ] F
derivation length: 0
production:
endlsystem
"""
    ls = LSystem(g, trusted=True)
    nodes = ls.draw(ls.derive(), shapes=True)
    assert nodes.tube.tolist() == [False, False, True, False]               # root, F, the branch's F, F
    assert int((nodes.drawn_tree().parent >= 0).sum()) == 2
    assert sum(c is not None for c in nodes.shapes.contour) == 1


def test_get_group_returns_the_group_use_group_set():
    """``LsysContext::getGroup`` returns what ``useGroup`` set, at once: a group chosen in ``EndEach`` is the one
    the next ``StartEach`` sees (the carbon tutorial globalpool.lpy alternates its groups so; before, StartEach saw
    the old group, reset the demands and divided by zero)."""
    g = """seen = []
def StartEach():
  seen.append(getGroup())
def EndEach():
  useGroup(2 if getGroup() != 2 else 1)

Axiom: A
derivation length: 3
production:
group 1:
C --> D
group 2:
A --> C
endgroup
endlsystem
"""
    ls = LSystem(g, trusted=True)
    assert str(ls.derive()) == "D" and ls._ns["seen"] == [0, 2, 1]


def test_triple_quoted_strings_in_the_python_code_hold_no_sections():
    """L-Py's parser skips strings while it looks for the sections (``lpy_parser.cpp``): recursiveproduce.lpy's
    ``lcode = \"\"\"Axiom: A ... production: ...\"\"\"`` is Python, and its grammar's own ``Axiom:`` is the one read."""
    g = '''lcode = """
Axiom: A
production:
A --> BCD
"""
other = \'\'\'derivation length: 5\'\'\' + "\'"
Axiom: E
derivation length: 1
production:
E --> G
endlsystem
'''
    ls = LSystem(g, trusted=True)
    assert str(ls.derive()) == "G"
    assert ls._ns["lcode"].split() == ["Axiom:", "A", "production:", "A", "-->", "BCD"]


def test_the_lsystem_class_from_grammar_code_is_refused_by_name():
    with pytest.raises(LSystemError, match=r"line 4, column 1: .*L-Py's own Lsystem class"):
        LSystem("Axiom: E\nproduction:\nE:\n  l = Lsystem()\n  produce F\n", trusted=True).derive(1)


def test_the_exact_closing_bracket_needs_the_branch_to_close_at_once():
    """``=]`` (L-Py's ExactRightBracket, ``matching_tmpl.h``): the next module of the right context, ignored ones
    skipped, is the ``]``; a plain ``]`` skips the rest of the branch first (hand-derived)."""
    g = """Axiom: [A F] g [A F F] g [A F [B]] g [A F] h [A F ; ] g
derivation length: 1
ignore: ;
production:
A > F=]g --> X
A > F]g --> Y
endlsystem
"""
    assert _derive(g) == "[XF]g[YFF]g[YF[B]]g[AF]h[XF;]g"
    with pytest.raises(LSystemError, match=r"line 3, column 2: the exact closing bracket =\] is supported in right"):
        LSystem("Axiom: A\nproduction:\nA=] --> B\n")


def test_l_strings_continue_over_lines_in_open_parentheses():
    """L-Py's test_multiline_produce.lpy and test_pproduce.lpy: ``produce (B\\n CA #test\\n D\\n )`` is one
    L-string, comments dropped; an ``nproduce ( ... )`` whose parameter raises inside ``try`` produces nothing;
    a ``-->`` successor and a module's parameters continue while a parenthesis is open (walnut4.lpy)."""
    g = ("module CA\nAxiom: A\nderivation length: 1\nproduction:\nA :\n    produce (B\n             CA #test\n"
         "             D \n             )\n    test = 3\nendlsystem\n")
    assert LSystem(g, trusted=True).derive().modules() == [("B", ()), ("CA", ()), ("D", ())]
    g = ("Axiom: B(1)\nderivation length: 1\nproduction:\nB(x) :\n  try:\n    nproduce (\n      C(3)\n"
         "      B(2/0)\n    )\n  except Exception as e:\n    pass\nendlsystem\n")
    assert str(LSystem(g, trusted=True).derive()) == "B(1)"
    g = "Axiom: S(1)\nderivation length: 1\nproduction:\nS(p) --> F(p,\n   2) A(3,\n  4)\nA --> B\nendlsystem\n"
    ls = LSystem(g)
    assert str(ls.derive()) == "F(1,2)A(3,4)" and ls._g.rules[1].line == 7        # line numbers kept


def test_module_alias_is_the_same_module():
    """L-Py's test/extension/alias.lpy: ``module A = F`` makes A another name of F (``ModuleClassTable``'s alias):
    A(1) grows to F(6) in five steps and is drawn as an F of length 6."""
    g = "module A = F\nAxiom: A(1)\nderivation length: 5\nproduction:\nA(x) --> A(x+1)\nendlsystem\n"
    ls = LSystem(g)
    s = ls.derive()
    assert str(s) == "F(6)" and np.allclose(ls.draw(s).pos, [(0, 0, 0), (0, 0, 6)])
    with pytest.raises(LSystemError, match=r"line 1, column 8: module alias 'A =' must be 'module A = B'"):
        LSystem("module A =\nAxiom: A\n")

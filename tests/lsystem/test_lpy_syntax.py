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
    ls = LSystem("Axiom:\n\nderivation length: 2\nproduction:\nA --> B\nendlsystem\n")
    assert str(ls.derive()) == "" and ls.tree().n_internodes == 0


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
    from plantvr.lsystem.namespace import ParameterSet
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


def test_hooks_reading_the_scene_are_refused_by_name():
    g = "def End(lstring, lscene):\n  assert len(lscene) == 3\nAxiom: F\nderivation length: 1\nproduction:\nendlsystem\n"
    with pytest.raises(LSystemError, match=r"line 2.*End\(\) raised TypeError.*PlantGL scene.*not supported"):
        LSystem(g, trusted=True).derive()


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

"""Issue 23 turtle: ABOP figures against an independent turtle, PlantGL's 3-D frame, tropism, the node model, the
kernel twin and the door checks."""
import time
import warnings

import numpy as np
import pytest

from plantvr.lsystem import ModuleString
from plantvr.lsystem import _turtle_kernels as K
from plantvr.lsystem.turtle import (
    LPY_UNSUPPORTED,
    TURTLE_MODULES,
    _ops,
    _options,
    bush_string,
    turtle,
    turtle_nodes,
)


def ms(text: str) -> ModuleString:
    """Single-character modules, plus ``X(a,b)`` parameters written inline, e.g. ``"F(2)+(30)F"``."""
    out, i = [], 0
    while i < len(text):
        size = 3 if text.startswith("@T", i) else 2 if text[i] == "@" else 1
        name, i = text[i:i + size], i + size
        if i < len(text) and text[i] == "(":
            j = text.index(")", i)
            out.append((name, tuple(float(v) for v in text[i + 1:j].split(",") if v.strip())))
            i = j + 1
        else:
            out.append(name)
    return ModuleString.from_modules(out)


def rewrite(axiom: str, rules: dict[str, str], n: int) -> str:
    """Parallel rewriting of single-character strings (the grammar, applied by hand)."""
    s = axiom
    for _ in range(n):
        s = "".join(rules.get(c, c) for c in s)
    return s


def planar_turtle(s: str, angle: float):
    """An independent 2-D turtle on complex numbers in L-Py's drawing plane (c = y + i z, heading i, '+' turns
    counter-clockwise toward L = -Y): node positions in F order and each node's parent."""
    turn = np.exp(1j * np.radians(angle))
    p, h, cur = 0j, 1j, 0
    nodes, parents, stack = [0j], [-1], []
    for c in s:
        if c == "F":
            p += h
            nodes.append(p)
            parents.append(cur)
            cur = len(nodes) - 1
        elif c == "+":
            h *= turn
        elif c == "-":
            h /= turn
        elif c == "[":
            stack.append((p, h, cur))
        elif c == "]":
            p, h, cur = stack.pop()
    return np.array(nodes), np.array(parents)


def branch_points(parent: np.ndarray) -> int:
    """Nodes with two or more children."""
    return int(np.count_nonzero(np.bincount(parent[parent >= 0], minlength=len(parent)) >= 2))


def f_count(n: int, f_per_x: int, x_per_x: int) -> int:
    """#F after n steps of X -> (f_per_x F, x_per_x X), F -> FF, axiom X (counted by hand: F' = 2F + a X)."""
    f, x = 0, 1
    for _ in range(n):
        f, x = 2 * f + f_per_x * x, x_per_x * x
    return f


# ABOP Fig. 1.24 a-f (n, delta, axiom, productions) with the segment count derived by hand from the grammar
ABOP_124 = {
    "a": (5, 25.7, "F", {"F": "F[+F]F[-F]F"}, 5 ** 5),
    "b": (5, 20.0, "F", {"F": "F[+F]F[-F][F]"}, 5 ** 5),
    "c": (4, 22.5, "F", {"F": "FF-[-F+F+F]+[+F-F-F]"}, 8 ** 4),
    "d": (7, 20.0, "X", {"X": "F[+X]F[-X]+X", "F": "FF"}, f_count(7, 2, 3)),
    "e": (7, 25.7, "X", {"X": "F[+X][-X]FX", "F": "FF"}, f_count(7, 2, 3)),
    "f": (5, 22.5, "X", {"X": "F-[[X]+X]+F[+FX]-X", "F": "FF"}, f_count(5, 3, 4)),
}


@pytest.mark.parametrize("fig", sorted(ABOP_124))
def test_abop_1_24_segments_branch_points_and_end_points(fig):
    n, delta, axiom, rules, segments = ABOP_124[fig]
    s = rewrite(axiom, rules, n)
    tree = turtle(ms(s), angle=delta)
    nodes, parents = planar_turtle(s, delta)
    assert tree.n_internodes == segments == s.count("F")
    assert len(tree) == segments + 1 and np.count_nonzero(tree.parent < 0) == 1
    np.testing.assert_array_equal(tree.parent, parents)
    assert branch_points(tree.parent) == branch_points(parents)
    np.testing.assert_allclose(tree.pos[:, 0], 0, atol=1e-9)                 # planar: the Y-Z plane
    np.testing.assert_allclose(tree.pos[:, 1] + 1j * tree.pos[:, 2], nodes, atol=1e-9)
    if fig == "a":   # every '[' opens on its own node and is followed by F: (5^n - 1) / 2 branch points
        assert branch_points(tree.parent) == (5 ** n - 1) // 2 == s.count("[")
    # the order counts branchings: a node's order = its parent's + 1 unless it continues the axis
    p = tree.parent
    kids = np.flatnonzero(p >= 0)
    np.testing.assert_array_equal(tree.order[kids], tree.order[p[kids]] + (tree.main_child[p[kids]] != kids))


def test_koch_island_closes_and_sierpinski_arrowhead_spans():
    # ABOP Fig. 1.6 quadratic Koch island: 4 * 8^n segments, a closed curve, no branching
    s = rewrite("F-F-F-F", {"F": "F-F+F+FF-F-F+F"}, 2)
    tree = turtle(ms(s), angle=90)
    nodes, _ = planar_turtle(s, 90)
    assert tree.n_internodes == 4 * 8 ** 2 and branch_points(tree.parent) == 0
    np.testing.assert_allclose(tree.pos[:, 1] + 1j * tree.pos[:, 2], nodes, atol=1e-9)
    np.testing.assert_allclose(tree.pos[-1], 0, atol=1e-9)
    # Koch snowflake: 3 * 4^n segments, closed
    s = rewrite("F--F--F", {"F": "F+F--F+F"}, 4)
    tree = turtle(ms(s), angle=60)
    assert tree.n_internodes == 3 * 4 ** 4
    np.testing.assert_allclose(tree.pos[-1], 0, atol=1e-9)
    np.testing.assert_allclose(tree.pos[:, 1] + 1j * tree.pos[:, 2], planar_turtle(s, 60)[0], atol=1e-9)
    # Sierpinski arrowhead (ABOP Fig. 1.10b, A and B both draw): 3^n segments, end 2^n along the heading
    n = 6
    s = rewrite("A", {"A": "B-A-B", "B": "A+B+A"}, n).replace("A", "F").replace("B", "F")
    tree = turtle(ms(s), angle=60)
    assert tree.n_internodes == 3 ** n and branch_points(tree.parent) == 0
    np.testing.assert_allclose(tree.pos[-1], [0, 0, 2 ** n], atol=1e-9)
    np.testing.assert_allclose(tree.pos[:, 1] + 1j * tree.pos[:, 2], planar_turtle(s, 60)[0], atol=1e-9)


@pytest.mark.parametrize("text, end", [
    ("F", [0, 0, 1]),                                   # heading +Z
    ("+(90)F", [0, -1, 0]), ("-(90)F", [0, 1, 0]),     # '+' turns toward L = -Y about U = +X
    ("&(90)F", [-1, 0, 0]), ("^(90)F", [1, 0, 0]),     # '&' pitches down, toward -U
    ("/(90)+(90)F", [1, 0, 0]), ("\\(90)+(90)F", [-1, 0, 0]),   # '/' = rollL: L and U turn about H
    ("|F", [0, 0, -1]),
    ("+F", [0, -np.sin(np.pi / 3), 0.5]),              # L-Py's default angle: 60 degrees
    ("F(-2)", [0, 0, -2]),                              # a negative length draws backwards (PlantGL)
])
def test_plantgl_frame_conventions(text, end):
    tree = turtle(ms(text))
    np.testing.assert_allclose(tree.pos[-1], end, atol=1e-12)


def test_roll_to_vertical_and_horizontal():
    for text in ("&(40)/(33)$", "+(70)&(20)\\(50)$", "^(10)/(120)-(35)$"):
        s = ms(text + "+(90)F")
        assert abs(turtle(s).pos[-1, 2]) < 1e-12           # L is horizontal: a 90 degree turn stays level
        u = turtle(ms(text + "&(90)F")).pos[-1]             # and U points up (pitching down goes below)
        assert u[2] < 0
    tree = turtle(ms("&(30)+(20)@hF"))                       # H into the horizontal plane
    assert abs(tree.pos[-1, 2]) < 1e-12 and np.linalg.norm(tree.pos[-1]) == pytest.approx(1)


def test_tropism_bends_heading_before_each_segment():
    # H antiparallel to the tropism: PlantGL turns about U by pi * elasticity
    np.testing.assert_allclose(turtle(ms("@Tp(0,0,-1)@Ts(0.5)F")).pos[-1], [0, -1, 0], atol=1e-12)
    # H horizontal, tropism down, e = 0.5: 45 degrees of the 90 degree gap, before the move
    np.testing.assert_allclose(turtle(ms("&(90)@Tp(0,0,-1)@Ts(0.5)F")).pos[-1], [-0.5 ** 0.5, 0, -0.5 ** 0.5],
                               atol=1e-12)
    # each F turns by e times the remaining angle: after k steps the angle to T is 90 * (1 - e)^k
    e, k = 0.2, 6
    tree = turtle(ms("&(90)@Tp(0,0,-1)" + f"@Ts({e})" + "F" * k))
    d = np.diff(tree.pos, axis=0)
    ang = np.degrees(np.arccos(np.clip(-d[:, 2], -1, 1)))
    np.testing.assert_allclose(ang, 90 * (1 - e) ** np.arange(1, k + 1), atol=1e-9)
    # the option is the initial tropism; '[ ]' keep it per branch
    a = turtle(ms("&(90)F"), tropism=(0, 0, -1), elasticity=0.5)
    np.testing.assert_allclose(a.pos[-1], [-0.5 ** 0.5, 0, -0.5 ** 0.5], atol=1e-12)
    b = turtle(ms("&(90)[@Ts(0.5)@Tp(0,0,-1)]F"))
    np.testing.assert_allclose(b.pos[-1], [-1, 0, 0], atol=1e-12)


def test_node_model_orders_main_children_widths_colours():
    t = turtle_nodes(ms("F[+F[-F]F]F"))
    assert t.tree.parent.tolist() == [-1, 0, 1, 2, 2, 1]
    assert t.tree.order.tolist() == [0, 0, 1, 2, 1, 0]
    assert t.tree.main_child.tolist() == [1, 5, 4, -1, -1, -1]
    assert t.module.tolist() == [0, 0, 3, 6, 8, 10]
    # f breaks the skeleton: the next F starts a new root where the turtle is
    t = turtle(ms("FfF"))
    assert t.parent.tolist() == [-1, 0, -1, 2]
    np.testing.assert_allclose(t.pos[2], [0, 0, 2])
    # a branch before the trunk's first F hangs on the same base node, and the base is order 0
    t = turtle(ms("[+F]F"))
    assert t.parent.tolist() == [-1, 0, 0] and t.order.tolist() == [0, 1, 0] and t.main_child[0] == 2
    # widths: default 0.1, _(w) sets, F(l, r) ends at r and keeps it, _ / ! step by the increment 1
    t = turtle(ms("F_(0.3)FF(1,0.05)F_F!F"))
    np.testing.assert_allclose(t.radius, [0.1, 0.1, 0.3, 0.05, 0.05, 1.05, 0.05])
    with pytest.warns(UserWarning, match=r"1 module\(s\) set a width below 0 .* \(first: ! at index 1\)"):
        t = turtle(ms("F!F"))                                # 0.1 - 1 < 0: ignored, as PlantGL
    np.testing.assert_allclose(t.radius, 0.1)
    # colours: 1 by default, ;/, step, ;(c) sets
    t = turtle_nodes(ms("F;F;(4)F,F"))
    assert t.color.tolist() == [1, 1, 2, 4, 3]
    # % cuts the rest of the branch (nested brackets included), ']' closes it as usual
    t = turtle(ms("F[+F%F[F]F]F%FF"))
    assert len(t) == 4 and t.parent.tolist() == [-1, 0, 1, 1]
    # non-drawing modules are skipped; F(0) draws nothing; an empty drawing is an empty tree
    assert len(turtle(ms("AF(0)BF"))) == 2 and len(turtle(ms("A+B"))) == 0


def random_string(rng: np.random.Generator, n: int) -> ModuleString:
    """A random turtle string with parameters (balanced pushes, unclosed ones allowed)."""
    out, depth = [], 0
    kinds = ["F", "f", "+", "-", "&", "^", "/", "\\", "|", "$", "@v", "@h", "[", "]", "_", "!", ";", ",", "%",
             "@Tp", "@Ts", "A"]
    for _ in range(n):
        k = kinds[rng.integers(len(kinds))]
        if k == "]" and depth == 0:
            k = "F"
        depth += (k == "[") - (k == "]")
        counts = TURTLE_MODULES.get(k, (0, 1, 2))
        c = counts[rng.integers(len(counts))]
        if k == "@Ts":
            vals = tuple(rng.uniform(-0.2, 1.2, c))
        elif k in ("@v", "@h"):
            vals = tuple(rng.uniform(-0.5, 1.5, c))
        elif k in ("_", "!", ";", ","):
            vals = tuple(rng.uniform(-0.5, 3, c))
        elif k == "@Tp":
            vals = tuple(rng.normal(size=c) + 0.1)
        else:
            vals = tuple(rng.uniform(-1, 2, c) if k in ("F", "f") else rng.uniform(-200, 200, c))
        out.append((k, vals))
    return ModuleString.from_modules(out)


def test_kernel_equals_python_twin_on_seeded_random_strings():
    rng = np.random.default_rng(0)
    for trial in range(40):
        s = random_string(rng, int(rng.integers(1, 300)))
        op, depth, n_f = _ops(s)
        opts = _options(rng.uniform(5, 90), rng.uniform(0.5, 2), 0.1, rng.uniform(0, 1),
                        rng.normal(size=3) + 0.1, rng.uniform(0, 0.5) * (trial % 2))
        pos, par, rad, order, main, color, module, nn, ignored, *_ = K.turtle_kernel(
            op, s.arg_ptr, s.args, *opts, depth, 2 * n_f)
        twin = K.turtle_python(op, s.arg_ptr, s.args, *opts)
        for got, want in zip((pos, par, rad, order, main, color, module), twin[:7]):
            assert got[:nn].shape == want.shape
            np.testing.assert_allclose(got[:nn], want, atol=1e-9, err_msg=f"trial {trial}")
        assert ignored.tolist() == twin[7]


@pytest.mark.parametrize("mods, match", [
    ([("F", (float("nan"),))], r"module F at index 0: parameter 0 = nan must be finite"),
    (["F", ("+", (1e300,))], r"module \+ at index 1: parameter 0 = 1e\+300 must be finite and within"),
    (["F", "F", ("&", (1.0, 2.0))], r"module & at index 2 takes 0 or 1 parameter\(s\), got 2"),
    ([("|", (1.0,))], r"module \| at index 0 takes 0 parameter\(s\), got 1"),
    ([("F", (1.0, 2.0, 3.0))], r"module F at index 0 takes 0 or 1 or 2 parameter\(s\), got 3"),
    (["F", "]", "F"], r"unbalanced brackets, \] at index 1 has no matching '\['"),
    ([("@Tp", (0.0, 0.0, 0.0)), "F"], r"module @Tp at index 0: the tropism direction must not be zero"),
])
def test_bad_strings_name_module_and_index(mods, match):
    with pytest.raises(ValueError, match=match):
        turtle(ModuleString.from_modules(mods))


def test_bad_options_and_plain_modules():
    s = ms("F+F")
    for kw, match in (({"angle": float("nan")}, "angle must be"), ({"step": 0}, "step must be"),
                      ({"width": -1}, "width must be"), ({"tropism": (0, 0, 0)}, "tropism must be a non-zero"),
                      ({"elasticity": 2}, "elasticity must be"), ({"tropism": (1, 2)}, "tropism must have shape")):
        with pytest.raises(ValueError, match=match):
            turtle(s, **kw)
    with pytest.raises(ValueError, match="string must be a ModuleString"):
        turtle("F+F")
    # a huge parameter of a module the turtle does not draw is not the turtle's business
    assert len(turtle(ModuleString.from_modules([("A", (1e300, float("nan"))), "F"]))) == 2
    assert not set(TURTLE_MODULES) & LPY_UNSUPPORTED and {"@2D", "Arrow"} <= LPY_UNSUPPORTED and "@g" not in LPY_UNSUPPORTED and not {"SetGuide", "SetContour", "Sweep"} & LPY_UNSUPPORTED
    assert {"@O", "@o", "~l", "@Gc", "@Ge", "{", "}", "."} <= set(TURTLE_MODULES)


def test_tree_feeds_the_mesher():
    from plantvr.subdivision import graph_from_arrays
    s = rewrite("X", {"X": "F[&+X]F[^-X]/X", "F": "FF"}, 3)
    tree = turtle(ms(s), angle=30)
    graph_from_arrays(tree.pos, tree.parent, tree.radius).validate()


def test_speed_bush_of_a_million_modules():
    s = bush_string(10 ** 6)
    assert len(s) == 10 ** 6
    turtle(bush_string(1000))                                    # compiled (cached)
    t0, c0 = time.perf_counter(), time.process_time()
    tree = turtle(s)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    assert tree.n_internodes == s.count("F")
    print(f"turtle: 10^6 modules -> {len(tree)} nodes in {wall:.3f} s wall, {cpu:.3f} s CPU")
    assert cpu < 3.0           # goal 1 s on a quiet machine (measured ~0.05 s); loose for the shared CI cores


def test_unclosed_bracket_and_warning_free_defaults():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tree = turtle(ms("F[+F[-F"))
    assert tree.parent.tolist() == [-1, 0, 1, 2]


def test_long_turn_sequences_keep_the_frame_orthonormal():
    # issue 30: the rotation axis is normalised at every turn; before, a frame vector's rounding grew
    # exponentially (``&+/F`` at 60 degrees went to NaN within 20000 repeats, at 25 degrees F shrank to 0)
    for a in (25.0, 60.0):
        t = turtle(ms("&+/F" * 20000), angle=a)
        seg = np.linalg.norm(t.pos[1:] - t.pos[t.parent[1:]], axis=1)
        np.testing.assert_allclose(seg, 1.0, atol=1e-10)

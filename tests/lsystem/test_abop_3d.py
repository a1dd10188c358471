"""ABOP Figs. 1.25 and 1.26, the three-dimensional plants (issue 23): every end point of the engine + turtle
against an independent turtle written here with scipy rotations about the turtle's current axes (PlantGL's
frame: heading H = +z, left L = -y, up U = +x; '+' turns H toward L about U, '&' pitches H toward -U about L,
'/' rolls L toward U about H; angles in degrees)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantvr.lsystem import LSystem

HERE = Path(__file__).parent / "grammars"


def independent_turtle(modules, angle: float) -> np.ndarray:
    """End point of every ``F`` (and the origin first), from ``[(name, params), ...]``."""
    frame = np.array([[0.0, 0, 1], [0, -1, 0], [1, 0, 0]])          # rows H, L, U
    pos, stack, out = np.zeros(3), [], [np.zeros(3)]

    def turn(axis_row: int, deg: float):
        nonlocal frame
        r = Rotation.from_rotvec(np.deg2rad(deg) * frame[axis_row])
        frame = r.apply(frame)

    for name, p in modules:
        a = p[0] if p else angle
        if name == "F":
            pos = pos + (p[0] if p else 1.0) * frame[0]
            out.append(pos)
        elif name == "f":
            pos = pos + (p[0] if p else 1.0) * frame[0]
        elif name in "+-":                     # about U: H toward L for '+'
            turn(2, a if name == "+" else -a)
        elif name in "&^":                     # about L: H toward -U for '&'
            turn(1, a if name == "&" else -a)
        elif name in "/\\":                    # about H: L toward U for '/'
            turn(0, a if name == "/" else -a)
        elif name == "|":
            turn(2, 180.0)
        elif name == "[":
            stack.append((pos, frame))
        elif name == "]":
            pos, frame = stack.pop()
    return np.array(out)


def _check_signs():
    """The independent turtle's conventions on one symbol each (the same table the turtle's own tests pin)."""
    for text, end in (("+(90)F", [0, -1, 0]), ("&(90)F", [-1, 0, 0]), ("/(90)+(90)F", [1, 0, 0])):
        mods = [(t, (90.0,)) for t in text.replace("(90)", " ").split()[:-1]] + [("F", ())]
        assert np.allclose(independent_turtle(mods, 90.0)[-1], end)


@pytest.mark.filterwarnings("ignore:.*width below 0")   # Fig. 1.25's '!' steps L-Py's default width below 0
@pytest.mark.parametrize("name", ["abop_1_25", "abop_1_26"])
def test_3d_abop_plants_end_points_match_an_independent_turtle(name):
    _check_signs()
    ls = LSystem.from_file(HERE / f"{name}.lpy")
    s = ls.interpret(ls.derive())
    tree = ls.tree()
    want = independent_turtle(s.modules(), ls.turtle_options["angle"])
    assert len(tree.pos) == len(want) == s.count("F") + 1
    np.testing.assert_allclose(tree.pos, want, atol=1e-9)
    # branch points: a node with more than one child is where a '[' opened a lateral axis
    kids = np.bincount(tree.parent[tree.parent >= 0], minlength=len(tree.pos))
    assert np.count_nonzero(kids > 1) > 0 and tree.n_internodes == s.count("F")

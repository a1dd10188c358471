"""The L-Py / PlantGL turtle (issue 23 "Turtle interpretation"): a :class:`ModuleString` into the shared tree arrays.

Conventions are PlantGL's ``Turtle`` (``turtle.cpp``, ``turtleparam.cpp``) as L-Py draws them:

* frame: heading H = +Z, left L = -Y, up U = +X; default angle 60 degrees, step 1, width 0.1, width
  increment 1; angles in DEGREES everywhere;
* ``+(a)``/``-(a)`` turn about U (``+`` turns H toward L), ``&(a)``/``^(a)`` pitch about L (``&`` down, toward
  -U), ``/(a)``/``\\(a)`` roll about H (``/`` is PlantGL's ``rollL``), ``|`` turns 180 degrees about U;
* ``$`` rolls about H so that L is horizontal (ABOP p. 57; PlantGL ``rollToVert``, L-Py's ``@v``; L-Py itself
  reserves ``$`` for pattern matching, where it never reaches the turtle), ``@h`` turns H into the horizontal
  plane (``rollToHorizontal``);
* ``F(l, r)`` draws ``l`` (default step; negative: drawn backwards, as PlantGL) and sets the width to ``r``;
  ``f(l)`` moves without drawing, and the next ``F`` starts a new root node there;
* ``_(w)``/``!(w)`` set the width (without a parameter: plus/minus the width increment); ``;(c)``/``,(c)`` set the
  colour index (without: plus/minus one), kept per node (:func:`turtle_nodes`), not in the tree arrays;
* ``%`` cuts the rest of the branch, ``[ ]`` push and pop the whole state;
* ``@Tp(x, y, z)`` sets the tropism direction (default +Z, normalised), ``@Ts(e)`` the elasticity; before every
  ``F`` and ``f`` the frame turns toward the tropism by ``e`` times its angle to H (PlantGL ``_tendTo``).

* request modules (issue 33, L-Py's ``?P``, ``?H``, ``?U``, ``?L``, ``?R``, ``?F``) draw nothing; their frames
  are :func:`query_frames`, which the engine writes into their parameters before a step that matches them;
* shapes (issue 33; :class:`TurtleShapes`, meshed by :mod:`plantvr.lsystem.shapes`): ``@O(r)`` spheres and
  ``@o(r)`` discs (radius default: the width), ``~l(s)`` and registered ``~name(s)`` surfaces, ``{ . }``
  polygons (``.`` and each ``F`` add a point; ``}(1)`` asks for PlantGL's concave fill), ``@Gc ... @Ge``
  generalized cylinders (``@Gc``, each ``F`` and ``.`` add a path point with the width, ``_``/``!`` reset the
  last point's radius, a ``[`` branch starts its own tube at its parent's last point and draws it at ``]``, an
  open one is drawn at the end of the string); each shape keeps its colour index (the one at ``{``/``@Gc`` for
  paths). The skeleton is unchanged by them (an ``F`` inside ``@Gc`` still makes its node).
* absolute moves and orientation (issue 33, PlantGL ``move``, ``shift``, ``lineTo``, ``oLineTo``, ``lineRel``,
  ``oLineRel``, ``pinpoint``, ``pinpointRel``, ``setHead``, ``eulerAngles``): ``@M``/``MoveTo(x, y, z)`` and
  ``MoveRel`` move without drawing (the next ``F`` starts a new root, as after ``f``, if the turtle moved;
  ``MoveTo(None, y)`` keeps x, as L-Py); ``LineTo``/``LineRel(x, y, z[, top])`` draw a segment (a node, like ``F``)
  to the point (relative: the offset) and keep the frame, ``OLineTo``/``OLineRel`` turn it toward the point first
  (``_tendTo``); ``Pinpoint``/``PinpointRel`` only turn; ``@R``/``SetHead(hx, hy, hz, ux, uy, uz)`` sets H and U
  (L = U x H; without an up vector: ``PinpointRel``), ``EulerAngles(azimuth, elevation, roll)`` the frame
  ``Rz(a) Ry(-e) Rx(r)`` (H its x, U its z); ``iRollL``/``iRollR`` are rolls (no guide here);
* ``nF(length, dl[, radius])``: ``int(length / dl)`` segments of ``dl`` and the rest, the width going linearly to
  ``radius``; the scale (``@D``/``SetScale(s)``, ``@Di``/``MultScale(s)``, ``@Dd``/``DivScale(s)``; 0.5 without a
  parameter, PlantGL's ``scale_multiplier``) multiplies the length of every ``F``/``f`` step (``scale.z``) and the
  width (``scale.x`` when x = y, ``PglTurtleDrawer::cylinder``), and sizes spheres, discs and surfaces
  (``PglTurtleDrawer::sphere``, ``circle``, ``customGeometry``); ``[ ]`` keep it;
* ``@L``/``Label(text[, size])`` texts are recorded (:class:`TurtleLabel`, ``TurtleNodes.labels``), not drawn.
* ``@B``/``Box(length, top)`` and ``@b``/``Quad(length, top)`` draw a box (square section) / a quad in the
  (H, L) plane along a step (PlantGL ``Turtle::box``, ``quad``; half-widths the width and ``top``, the width
  then set to ``top``), as shapes, moving like ``f`` (the next ``F`` starts a new root); ``Frame(size)`` is recorded
  (``TurtleNodes.frames``), not meshed; ``surface(name[, scale])`` / ``~(name[, scale])`` draw the named surface
  as ``~name(scale)`` (:func:`plantvr.lsystem.shapes.register_surface`).

A width below zero, a colour below zero, an elasticity outside [0, 1] or a negative sphere / disc radius or
surface scale is ignored with one warning, as PlantGL does (it warns and keeps the current value). Modules that are neither in :data:`TURTLE_MODULES` nor in
:data:`LPY_UNSUPPORTED` are plain non-drawing modules and are skipped.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_int, check_range
from plantvr.types import TreeArrays

from . import _turtle_kernels as K
from .guides import apply_guides
from .modules import ModuleString
from .sections import apply_sections

__all__ = ["LPY_UNSUPPORTED", "QUERY_MODULES", "TURTLE_MODULES", "TurtleLabel", "TurtleNodes", "TurtleShapes",
           "bush_string", "first_params",
           "query_frames", "turtle", "turtle_nodes"]

#: L-Py's defaults (PlantGL ``Turtle``): angle increment, step, width, width increment.
DEFAULT_ANGLE, DEFAULT_STEP, DEFAULT_WIDTH, DEFAULT_WIDTH_INCREMENT = 60.0, 1.0, 0.1, 1.0

#: L-Py's request modules (``predefinedmodules.cpp``) -> what they ask for: position ``P``, heading ``H``, up
#: ``U``, left ``L``, right ``R`` (minus left), frame ``F`` (position, heading, up, left).
QUERY_MODULES: dict[str, str] = {"?P": "P", "GetPos": "P", "?H": "H", "GetHead": "H", "?U": "U", "GetUp": "U",
                                 "?L": "L", "GetLeft": "L", "?R": "R", "GetRight": "R", "?F": "F", "GetFrame": "F"}

# name -> (op code, accepted parameter counts); L-Py's long names are aliases of the symbols
_TABLE: dict[str, tuple[int, tuple[int, ...]]] = {
    "F": (K.F, (0, 1, 2)), "f": (K.FMOVE, (0, 1)),
    "+": (K.LEFT, (0, 1)), "Left": (K.LEFT, (0, 1)), "-": (K.RIGHT, (0, 1)), "Right": (K.RIGHT, (0, 1)),
    "^": (K.UP, (0, 1)), "Up": (K.UP, (0, 1)), "&": (K.DOWN, (0, 1)), "Down": (K.DOWN, (0, 1)),
    "/": (K.ROLLL, (0, 1)), "RollL": (K.ROLLL, (0, 1)), "\\": (K.ROLLR, (0, 1)), "RollR": (K.ROLLR, (0, 1)),
    "|": (K.TURN, (0,)), "TurnAround": (K.TURN, (0,)),
    "$": (K.ROLLVERT, (0,)), "@v": (K.ROLLVERT, (0, 1)), "RollToVert": (K.ROLLVERT, (0, 1)),
    "@h": (K.ROLLHORIZ, (0, 1)), "RollToHorizontal": (K.ROLLHORIZ, (0, 1)),
    "[": (K.PUSH, (0,)), "SB": (K.PUSH, (0,)), "]": (K.POP, (0,)), "EB": (K.POP, (0,)),
    "_": (K.INCW, (0, 1)), "IncWidth": (K.INCW, (0, 1)), "!": (K.DECW, (0, 1)), "DecWidth": (K.DECW, (0, 1)),
    "SetWidth": (K.SETW, (1,)),
    ";": (K.INCC, (0, 1)), "IncColor": (K.INCC, (0, 1)), ",": (K.DECC, (0, 1)), "DecColor": (K.DECC, (0, 1)),
    "SetColor": (K.SETC, (0, 1, 3, 4)),
    "%": (K.CUT, (0,)), "Cut": (K.CUT, (0,)),
    "@Tp": (K.TROPISM, (0, 1, 2, 3)), "Tropism": (K.TROPISM, (0, 1, 2, 3)),
    "@Ts": (K.ELASTICITY, (0, 1)), "Elasticity": (K.ELASTICITY, (0, 1)),
    "@O": (K.SPHERE, (0, 1)), "Sphere": (K.SPHERE, (0, 1)), "@o": (K.CIRCLE, (0, 1)), "Circle": (K.CIRCLE, (0, 1)),
    "~l": (K.SURFACE, (0, 1)),
    "@Gc": (K.GC_START, (0,)), "StartGC": (K.GC_START, (0,)), "@Ge": (K.GC_END, (0,)), "EndGC": (K.GC_END, (0,)),
    "{": (K.POLY_START, (0,)), "BP": (K.POLY_START, (0,)), "}": (K.POLY_END, (0, 1)), "EP": (K.POLY_END, (0, 1)),
    ".": (K.POLY_POINT, (0,)), "PP": (K.POLY_POINT, (0,)),
    **{name: (K.QUERY, (0, 1, 2, 3, 4)) for name in QUERY_MODULES},
    "iRollL": (K.ROLLL, (0, 1)), "iRollR": (K.ROLLR, (0, 1)),       # intrinsic rolls: rolls without a guide
    "@M": (K.MOVETO, (0, 1, 2, 3)), "MoveTo": (K.MOVETO, (0, 1, 2, 3)), "MoveRel": (K.MOVEREL, (0, 1, 2, 3)),
    "LineTo": (K.LINETO, (0, 1, 2, 3, 4)), "OLineTo": (K.OLINETO, (0, 1, 2, 3, 4)),
    "LineRel": (K.LINEREL, (0, 1, 2, 3, 4)), "OLineRel": (K.OLINEREL, (0, 1, 2, 3, 4)),
    "Pinpoint": (K.PINPOINT, (0, 1, 2, 3)), "PinpointRel": (K.PINPOINTREL, (0, 1, 2, 3)),
    "@R": (K.SETHEAD, (0, 1, 2, 3, 4, 5, 6)), "SetHead": (K.SETHEAD, (0, 1, 2, 3, 4, 5, 6)),
    "EulerAngles": (K.EULER, (0, 1, 2, 3)), "nF": (K.NF, (2, 3)),
    "@D": (K.SETSCALE, (0, 1)), "SetScale": (K.SETSCALE, (0, 1)), "@Di": (K.MULTSCALE, (0, 1)),
    "MultScale": (K.MULTSCALE, (0, 1)), "@Dd": (K.DIVSCALE, (0, 1)), "DivScale": (K.DIVSCALE, (0, 1)),
    "@L": (K.LABEL, (1, 2)), "Label": (K.LABEL, (1, 2)),
    "@B": (K.BOX, (0, 1, 2)), "Box": (K.BOX, (0, 1, 2)), "@b": (K.QUAD, (0, 1, 2)), "Quad": (K.QUAD, (0, 1, 2)),
    "Frame": (K.FRAME, (0, 1, 2, 3, 4, 5)),
    "surface": (K.SURFACE_NAMED, (1, 2)), "~": (K.SURFACE_NAMED, (1, 2)),
}

#: Every module the turtle interprets -> its accepted parameter counts.
TURTLE_MODULES: dict[str, tuple[int, ...]] = {name: counts for name, (_, counts) in _TABLE.items()}


def first_params(s: ModuleString) -> ModuleString:
    """``s`` with each turtle module's extra parameters left out: L-Py's turtle reads the first ones
    (``-(a, t)`` turns by ``a``, ``F(1, 2, 3)`` is ``F(1, 2)``); object parameters kept stay."""
    most = np.array([max(TURTLE_MODULES[nm]) if nm in TURTLE_MODULES else np.iinfo(np.int64).max
                     for nm in s.names], np.int64)
    cnt = np.diff(s.arg_ptr)
    limit = most[s.ids] if len(s) else cnt
    if not len(s) or not np.any(cnt > limit):
        return s
    keep = np.minimum(cnt, limit)
    owner = np.repeat(np.arange(len(s)), cnt)
    kept = (np.arange(len(s.args)) - np.repeat(s.arg_ptr[:-1], cnt)) < keep[owner]
    ptr = np.zeros(len(s) + 1, np.int64)
    np.cumsum(keep, out=ptr[1:])
    at = np.cumsum(kept) - 1
    return ModuleString(s.names, s.ids, ptr, s.args[kept], {int(at[k]): v for k, v in s.objects.items() if kept[k]})

#: L-Py / PlantGL turtle modules that exist there but are not drawn here (arrows, colour interpolation,
#: reflections, screen projection); the engine refuses them with their line (``@g``'s PlantGL objects are read
#: into surfaces and colours first, :mod:`plantvr.lsystem.pglshapes`). Spheres, discs,
#: ``~name`` surfaces, polygons and generalized cylinders (with their ``SetContour`` sections, and ``Sweep``:
#: :mod:`plantvr.lsystem.sections`) are drawn (:mod:`plantvr.lsystem.shapes`). Texture coordinates
#: (``TextureScale``, ``TextureRotation``, ...) change nothing here, where a texture is drawn in its image's mean
#: colour, and ``SectionResolution`` only PlantGL's facet count (PlantVR meshes at ``shape_meshes(slices=)``):
#: both are read and left out.
LPY_UNSUPPORTED: frozenset[str] = frozenset({
    "Arrow", "TextureBaseColor", "InterpolateColors", "InterpolateTextureBaseColors",
    "LeftReflection", "UpReflection", "HeadingReflection", "@2D", "StartScreenProjection", "@3D",
    "EndScreenProjection",
})

_WARN = {K.IGNORED_WIDTH: "a width below 0", K.IGNORED_COLOR: "a colour index below 0",
         K.IGNORED_ELASTICITY: "an elasticity outside [0, 1]", K.IGNORED_SIZE: "a radius or scale below 0",
         K.IGNORED_SCALE: "a turtle scale beyond 1e6 (or divided by 0)"}


@dataclass(frozen=True, eq=False)
class TurtleShapes:
    """The shapes the turtle drew besides the skeleton, as records (meshed by
    :func:`plantvr.lsystem.shapes.shape_meshes`).

    Attributes
    ----------
    kind : (S,) int64 ndarray
        ``K.SH_SPHERE`` (``@O``), ``K.SH_CIRCLE`` (``@o``), ``K.SH_SURFACE`` (``~name``), ``K.SH_POLYGON`` /
        ``K.SH_POLYGON_CONCAVE`` (``{ . }``, ``}(1)``: concave test), ``K.SH_TUBE`` (``@Gc ... @Ge``), ``K.SH_BOX``
        (``@B``), ``K.SH_QUAD`` (``@b``).
    color : (S,) int64 ndarray
        Colour (material) index: the current one for placed shapes, the one at ``{`` / ``@Gc`` for paths
        (PlantGL's ``getCurrentInitialMaterial``).
    module : (S,) int64 ndarray
        Index of the module that drew it (-1: a tube closed by the end of the string).
    frame : (S, 4, 3) float64 ndarray
        Position, heading H, left L and up U of a placed shape (zero for paths).
    size : (S,) float64 ndarray
        Radius of a sphere or disc, scale of a surface, length of a box or quad (0 for paths).
    start, count : (S,) int64 ndarray
        A path's points are ``points[start:start + count]``.
    points, left : (P, 3) float64 ndarray
        Path points and the turtle's left vector there.
    radius : (P,) float64 ndarray
        The width at each path point (a tube's radius).
    surface : tuple of str
        Surface name of each shape (``"l"`` for ``~l``; ``""`` for other kinds).
    radii : (S, 2) float64 ndarray or None
        Bottom and top half-width of a box or quad (PlantGL: the width and the top width; 0 for other kinds).
    scale : (S, 3) float64 ndarray or None
        The turtle scale (``@D``...) of a sphere, disc or surface along its local (U, -L, H) axes, PlantGL's
        ``Scaled(scale * size)`` (a disc: the scale when isotropic, else 1); None: 1.
    """

    kind: np.ndarray
    color: np.ndarray
    module: np.ndarray
    frame: np.ndarray
    size: np.ndarray
    start: np.ndarray
    count: np.ndarray
    points: np.ndarray
    left: np.ndarray
    radius: np.ndarray
    surface: tuple = ()
    radii: np.ndarray | None = None
    scale: np.ndarray | None = None
    contour: tuple | None = None

    def __len__(self) -> int:
        return len(self.kind)


class TurtleLabel(NamedTuple):
    """A text label (L-Py's ``@L(text[, size])``, PlantGL ``Turtle::label``): not geometry, a record for
    viewers.

    Attributes
    ----------
    text : str
        The label (a parameter that is not a str is written with ``str``).
    position : (3,) float64 ndarray
        The turtle's position at the module.
    module : int
        Index of the module in the string.
    size : int
        The font size asked for (-1: the viewer's default, as PlantGL).
    color : int
        The turtle's colour index there.
    """

    text: str
    position: np.ndarray
    module: int
    size: int
    color: int


@dataclass(frozen=True, eq=False)
class TurtleNodes:
    """The turtle's drawing: the skeleton, what each node carries besides, and the shapes.

    Attributes
    ----------
    tree : TreeArrays
    color : (N,) int64 ndarray
        Colour (material) index of each node, L-Py's ``;``/``,`` (1 by default); ``SetColor(r, g, b)`` gives
        ``K.CUSTOM_COLOR + (r << 16 | g << 8 | b)``.
    module : (N,) int64 ndarray
        Index in the string of the ``F`` that made each node.
    shapes : TurtleShapes
        Spheres, discs, surfaces, polygons and generalized cylinders (none for a skeleton-only string); one
        mesh per material: :func:`plantvr.lsystem.shapes.shape_meshes`.
    labels : tuple of TurtleLabel
        The ``@L`` / ``Label`` texts in string order (issue 33), with the turtle's position there.
    frames : (R, 4, 3) float64 ndarray or None
        The turtle's frame (position, H, L, U) at each ``Frame`` module L-Py draws as three arrows (annotations,
        not meshed); ``frame_size`` their sizes (R,).
    tube : (N,) bool ndarray or None
        Whether each node's internode was drawn inside a generalized cylinder (``@Gc`` ... ``@Ge``): PlantGL makes
        it a point of the tube and draws no cylinder for it (None: no tube in the string).
    """

    tree: TreeArrays
    color: np.ndarray
    module: np.ndarray
    shapes: TurtleShapes | None = None
    labels: tuple[TurtleLabel, ...] = ()
    frames: np.ndarray | None = None
    frame_size: np.ndarray | None = None
    tube: np.ndarray | None = None

    def drawn_tree(self) -> TreeArrays:
        """The skeleton as L-Py draws it: an internode inside a generalized cylinder is part of the tube (a shape),
        not a branch, so its node becomes a root there (what grows after it still starts at its end)."""
        if self.tube is None or not self.tube.any():
            return self.tree
        t = self.tree
        mc = np.asarray(t.main_child)
        main = np.where((mc >= 0) & self.tube[np.maximum(mc, 0)], -1, mc)
        return TreeArrays.from_arrays(t.pos, np.where(self.tube, -1, t.parent), t.radius, t.order, main)


def _ops(string: ModuleString):
    """Op code per module, after the door checks: arity, finite and bounded parameters, brackets, tropism."""
    if not isinstance(string, ModuleString):
        raise ValueError(f"string must be a ModuleString, got {type(string).__name__}")  # noqa: TRY004
    names, ids, ptr, args = string.names, string.ids, string.arg_ptr, string.args
    n = len(ids)
    code = np.zeros(len(names), np.int8)
    allowed = np.ones((len(names), 5), bool)
    for k, name in enumerate(names):
        if name in _TABLE:
            code[k], counts = _TABLE[name]
            allowed[k] = [c in counts for c in range(5)]
    op = code[ids]
    cnt = np.diff(ptr)
    bad = np.flatnonzero(~allowed[ids, np.minimum(cnt, 4)])
    if bad.size:
        i = int(bad[0])
        name = names[ids[i]]
        raise ValueError(f"string: module {name} at index {i} takes {_counts(TURTLE_MODULES[name])} "
                         f"parameter(s), got {int(cnt[i])}")
    if args.size:
        owner = np.repeat(np.arange(n), cnt)
        vals = np.abs(args)
        free = (op[owner] == K.NOP) | (op[owner] == K.QUERY) | (op[owner] == K.LABEL)   # a label: any text
        first = ptr[:-1][(op == K.SURFACE_NAMED) & (cnt > 0)]
        free[first] = True                                # surface(name, scale): the name, checked below
        if string.objects:                                # MoveTo(None, y): L-Py keeps that coordinate
            none = np.array([j for j, v in string.objects.items() if v is None], np.int64)
            if none.size:
                free[none[op[owner[none]] == K.MOVETO]] = True
        bad = np.flatnonzero(~free & ~(vals <= MAX_COORD))
        if bad.size:
            j = int(bad[0])
            i = int(owner[j])
            raise ValueError(f"string: module {names[ids[i]]} at index {i}: parameter {j - int(ptr[i])} = "
                             f"{float(args[j])!r} must be finite and within [-{MAX_COORD:g}, {MAX_COORD:g}]")
    step = (op == K.PUSH).astype(np.int64) - (op == K.POP)
    depth = np.cumsum(step)
    if n and depth.min() < 0:
        i = int(np.flatnonzero(depth < 0)[0])
        raise ValueError(f"string: unbalanced brackets, {names[ids[i]]} at index {i} has no matching '['")
    for i in np.flatnonzero((op == K.TROPISM) & (cnt > 0)):
        if not np.any(args[ptr[i]:ptr[i + 1]] != 0):
            raise ValueError(f"string: module {names[ids[i]]} at index {int(i)}: the tropism direction must not "
                             f"be zero")
    for i in np.flatnonzero(op == K.SURFACE_NAMED):
        name = string.objects.get(int(ptr[i]))
        if not isinstance(name, str) or not name:
            raise ValueError(f"string: module {names[ids[i]]} at index {int(i)}: the surface name must be a "
                             f"non-empty str, got {name if name is not None else float(args[ptr[i]])!r:.60}")
    for i in np.flatnonzero(op == K.SETHEAD):
        _check_head(names[ids[i]], int(i), args[ptr[i]:ptr[i + 1]])
    n_seg = int(np.count_nonzero((op == K.F) | ((op >= K.LINETO) & (op <= K.OLINEREL))))
    for i in np.flatnonzero(op == K.NF):
        length, dl = float(args[ptr[i]]), float(args[ptr[i] + 1])
        if not (length >= 0 and dl > 0):
            raise ValueError(f"string: module {names[ids[i]]} at index {int(i)}: nF(length, dl) needs "
                             f"length >= 0 and dl > 0, got length = {length!r}, dl = {dl!r}")
        n_seg += int(length // dl) + 1
        if n_seg > _MAX_SEGMENTS:
            raise ValueError(f"string: module {names[ids[i]]} at index {int(i)}: nF({length!r}, {dl!r}) takes "
                             f"the string past {_MAX_SEGMENTS} segments")
    return op, int(depth.max()) if n else 0, n_seg


#: The most segments ``nF`` may make in one string.
_MAX_SEGMENTS = 100_000_000


def _check_head(name: str, i: int, v: np.ndarray) -> None:
    """L-Py's ``SetHead`` errors: a null heading, or (with an up vector) a heading colinear with it (PlantGL's
    ``Turtle::setHead`` error; a null up vector is L-Py's warning and a ``PinpointRel``)."""
    h = np.zeros(3) if v.size else np.array([0.0, 0.0, 1.0])
    h[:min(v.size, 3)] = v[:3]
    if np.linalg.norm(h) < K.EPS:
        raise ValueError(f"string: module {name} at index {i}: SetHead needs a non-null heading, got "
                         f"{h.tolist()}")
    if v.size > 3:
        u = np.zeros(3)
        u[:v.size - 3] = v[3:6]
        un = np.linalg.norm(u)
        if un >= K.EPS and np.linalg.norm(np.cross(u / un, h / np.linalg.norm(h))) < K.EPS:
            raise ValueError(f"string: module {name} at index {i}: SetHead's heading {h.tolist()} and up "
                             f"{u.tolist()} are colinear")


def _capacities(op: np.ndarray, n_seg: int | None = None) -> tuple[int, int]:
    """Shape records and path points the kernel may make for these op codes (0, 0 without shapes); ``n_seg``:
    the segments it may draw (``F`` count by default)."""
    cnt = np.bincount(op.astype(np.int64), minlength=K.SURFACE_NAMED + 1)
    n_seg = int(cnt[K.F]) if n_seg is None else n_seg
    paths = cnt[K.GC_START] + cnt[K.POLY_START]
    n_shapes = int(cnt[K.SPHERE] + cnt[K.CIRCLE] + cnt[K.SURFACE] + cnt[K.GC_END] + cnt[K.POLY_END]
                   + cnt[K.QUERY] + cnt[K.LABEL] + cnt[K.BOX] + cnt[K.QUAD] + cnt[K.FRAME] + cnt[K.SURFACE_NAMED])
    if not paths:
        return n_shapes, 0
    n_shapes += int(cnt[K.POP] + 1) if cnt[K.GC_START] else 0
    n_pool = int(n_seg * 2 + cnt[K.POLY_POINT] * 2 + cnt[K.GC_START] + cnt[K.INCW] + cnt[K.DECW]
                 + cnt[K.SETW] + cnt[K.BOX] + cnt[K.QUAD] + 1)
    return n_shapes, n_pool


def _counts(counts: tuple[int, ...]) -> str:
    return " or ".join(str(c) for c in counts)


def _options(angle, step, width, width_increment, tropism, elasticity):
    angle = abs(check_range("angle", angle, -360.0, 360.0))           # PlantGL keeps |increment|
    step = check_range("step", step, 0.0, MAX_COORD, low_open=True)
    width = check_range("width", width, 0.0, MAX_COORD)
    width_increment = check_range("width_increment", width_increment, 0.0, MAX_COORD)
    trop = check_array("tropism", tropism, shape=(3,), max_abs=MAX_COORD)
    norm = float(np.linalg.norm(trop))
    if not norm > 0:
        raise ValueError(f"tropism must be a non-zero 3-vector, got {trop.tolist()}")
    elasticity = check_range("elasticity", elasticity, 0.0, 1.0)
    return angle, step, width, width_increment, trop / norm, elasticity


def turtle_nodes(string: ModuleString, *, angle: float = DEFAULT_ANGLE, step: float = DEFAULT_STEP,
                 width: float = DEFAULT_WIDTH, width_increment: float = DEFAULT_WIDTH_INCREMENT,
                 tropism=(0.0, 0.0, 1.0), elasticity: float = 0.0) -> TurtleNodes:
    """Interpret ``string`` with the L-Py turtle: the tree plus each node's colour and module (see :func:`turtle`)."""
    pos, parent, radius, order, main, color, module, nn, sint, sflt, spts, sec, _ = _interpret(
        string, angle, step, width, width_increment, tropism, elasticity)
    tree = TreeArrays.from_arrays(pos[:nn], parent[:nn], radius[:nn], order[:nn], main[:nn])
    shape = (sint[:, 0] != K.SH_QUERY) & (sint[:, 0] != K.SH_LABEL) & (sint[:, 0] != K.SH_FRAME)
    fr = sint[:, 0] == K.SH_FRAME
    tube = None if sec is None else sec.in_tube
    mods = module[:nn]
    return TurtleNodes(tree, color[:nn].copy(), mods.copy(),
                       _shapes(string, sint[shape], sflt[shape], spts, sec), _labels(string, sint, sflt),
                       sflt[fr, :12].reshape(-1, 4, 3).copy(), sflt[fr, 12].copy(),
                       None if tube is None else (mods >= 0) & tube[np.maximum(mods, 0)])



def _labels(string: ModuleString, sint: np.ndarray, sflt: np.ndarray) -> tuple[TurtleLabel, ...]:
    """The kernel's label records with their texts (the module's first parameter)."""
    out = []
    for s in np.flatnonzero(sint[:, 0] == K.SH_LABEL):
        m = int(sint[s, 2])
        j = int(string.arg_ptr[m])
        text = string.objects.get(j, None) if np.isnan(string.args[j]) else f"{float(string.args[j]):g}"
        size = float(sflt[s, 12])
        out.append(TurtleLabel(str(text), sflt[s, :3].copy(), m, int(size) if size >= 0 else -1,
                               int(sint[s, 1])))
    return tuple(out)


def query_frames(string: ModuleString, *, angle: float = DEFAULT_ANGLE, step: float = DEFAULT_STEP,
                 width: float = DEFAULT_WIDTH, width_increment: float = DEFAULT_WIDTH_INCREMENT,
                 tropism=(0.0, 0.0, 1.0), elasticity: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The turtle's frame at each request module (``?P``, ``?H``, ``?U``, ``?L``, ``?R``, ``?F`` and their long
    names) of ``string``, as L-Py's query pass sees it (options as :func:`turtle`).

    Returns
    -------
    module : (Q,) int64 ndarray
        Index in the string of each request module the turtle reached (not those a ``%`` cut off).
    frame : (Q, 4, 3) float64 ndarray
        Position, heading H, left L and up U there.

    Examples
    --------
    >>> i, fr = query_frames(ModuleString.from_modules(["F", ("+", (90.0,)), "F", "?P"]))
    >>> i.tolist(), fr[0, 0].round(6).tolist(), fr[0, 1].round(6).tolist()
    ([3], [0.0, -1.0, 1.0], [0.0, -1.0, 0.0])
    """
    *_, sint, sflt, _, _, _ = _interpret(string, angle, step, width, width_increment, tropism, elasticity)
    query = sint[:, 0] == K.SH_QUERY
    return sint[query, 2].copy(), sflt[query, :12].reshape(-1, 4, 3).copy()


def _interpret(string: ModuleString, angle, step, width, width_increment, tropism, elasticity, *,
               with_frames: bool = False) -> tuple:
    """The kernel's drawing of ``string`` (used rows only), after the door checks, with PlantGL's warnings;
    the last item is each segment's turtle frame and base width with ``with_frames`` (see ``turtle_kernel``)."""
    opts = _options(angle, step, width, width_increment, tropism, elasticity)
    sec = apply_sections(string) if isinstance(string, ModuleString) else None   # sweeps, sections (sections.py)
    drawn, source = apply_guides(string if sec is None else sec.string, opts[1])   # guided moves (guides.py)
    if sec is not None and sec.source is not None:             # both maps: to the string given
        source = sec.source if source is None else sec.source[source]
    op, depth, n_f = _ops(drawn)
    pos, parent, radius, order, main, color, module, nn, ignored, at, sint, sflt, spts, ns, nsp, seg = K.turtle_kernel(
        op, drawn.arg_ptr, drawn.args, *opts, depth, 2 * n_f, *_capacities(op, n_f), with_frames)
    sint = sint[:ns]
    if source is not None:                                    # module indices of the string given
        def back(i):
            return np.where(i >= 0, source[np.maximum(i, 0)], i)
        module[:nn], sint[:, 2], at = back(module[:nn]), back(sint[:, 2]), back(at)
    for k, what in _WARN.items():
        if ignored[k]:
            i = int(at[k])
            warnings.warn(f"string: {int(ignored[k])} module(s) set {what} and were ignored, as in PlantGL (first: "
                          f"{string.names[string.ids[i]]} at index {i})", stacklevel=4)
    return pos, parent, radius, order, main, color, module, nn, sint, sflt[:ns], spts[:nsp], sec, seg[:nn]


def _shapes(string: ModuleString, sint: np.ndarray, sflt: np.ndarray, spts: np.ndarray, sec) -> TurtleShapes:
    """The kernel's shape records as :class:`TurtleShapes` (surface names from the module names)."""
    kind = sint[:, 0].copy()
    surf = tuple(_surface_name(string, int(m)) if k == K.SH_SURFACE else "" for k, m in zip(kind, sint[:, 2]))
    contour = None if sec is None else sec.tube_contours(kind, sint[:, 2], K.SH_TUBE)
    return TurtleShapes(kind, sint[:, 1].copy(), sint[:, 2].copy(), sflt[:, :12].reshape(-1, 4, 3).copy(),
                        sflt[:, 12].copy(), sint[:, 3].copy(), sint[:, 4].copy(), spts[:, :3].copy(),
                        spts[:, 3:6].copy(), spts[:, 6].copy(), surf, sflt[:, 13:15].copy(),
                        sflt[:, 15:18].copy(), contour)



def _surface_name(string: ModuleString, m: int) -> str:
    """The surface module ``m`` draws: ``~name``'s name, ``surface(name)``'s and ``~(name)``'s parameter."""
    name = string.names[string.ids[m]]
    return str(string.objects[int(string.arg_ptr[m])]) if name in ("surface", "~") else name[1:]


def turtle(string: ModuleString, *, angle: float = DEFAULT_ANGLE, step: float = DEFAULT_STEP,
           width: float = DEFAULT_WIDTH, width_increment: float = DEFAULT_WIDTH_INCREMENT,
           tropism=(0.0, 0.0, 1.0), elasticity: float = 0.0) -> TreeArrays:
    """Draw the skeleton of an L-system string as L-Py's turtle does.

    Parameters
    ----------
    string : ModuleString
        The derived (and interpreted) string; modules outside :data:`TURTLE_MODULES` are skipped.
    angle : float
        Turn angle of ``+ - & ^ / \\`` without a parameter, in degrees (L-Py's default 60).
    step : float
        Length of ``F`` and ``f`` without a parameter.
    width : float
        Initial width (internode radius), L-Py's 0.1.
    width_increment : float
        Change of ``_`` and ``!`` without a parameter (PlantGL's 1).
    tropism : (3,) float
        Initial tropism direction (normalised; PlantGL's +Z); ``@Tp`` changes it.
    elasticity : float
        Initial elasticity in [0, 1] (0: no tropism); ``@Ts`` changes it.

    Returns
    -------
    TreeArrays
        One node per drawn ``F`` at its end, plus a root node where the first ``F`` (and the first after each
        ``f``) starts; ``radius`` is the width at the node (an ``F(l, r)`` ends at ``r``), ``order`` counts the
        ``[`` branchings from the main axis, ``main_child`` is the child continuing the axis.

    Raises
    ------
    ValueError
        For a wrong parameter count, a non-finite or out-of-range parameter (``|v| > 1e6``), a ``]`` without its
        ``[``, a zero tropism direction (the message names the module and its index), or bad options. An
        unclosed ``[`` is accepted, as in L-Py.

    References
    ----------
    .. [1] PlantGL ``src/cpp/plantgl/algo/modelling/turtle.cpp`` (``F``, ``f``, ``left``, ``down``, ``rollL``,
       ``rollToVert``, ``rollToHorizontal``, ``_tendTo``); L-Py ``predefinedmodules.cpp`` (symbols, aliases).
    .. [2] Prusinkiewicz & Lindenmayer, The Algorithmic Beauty of Plants, §1.5 (turtle in 3-D, ``$``).

    Examples
    --------
    >>> t = turtle(ModuleString.from_modules(["F", "[", ("+", (90.0,)), "F", "]", "F"]))
    >>> t.parent.tolist(), t.order.tolist(), t.pos[2].round(6).tolist()
    ([-1, 0, 1, 1], [0, 0, 1, 0], [0.0, -1.0, 1.0])
    """
    return turtle_nodes(string, angle=angle, step=step, width=width, width_increment=width_increment,
                        tropism=tropism, elasticity=elasticity).tree


def bush_string(n: int) -> ModuleString:
    """A 3-D bush of exactly ``n`` non-parametric modules (a benchmark and test fixture).

    ``F -> F[&+F]F[^-F]/F`` rewritten until the string has at least ``n`` modules, then its first ``n`` (a prefix
    never closes a bracket it did not open; unclosed ``[`` are accepted, as in L-Py).
    """
    n = check_int("n", n, 1, 100_000_000)
    s = "F"
    while len(s) < n:
        s = s.replace("F", "F[&+F]F[^-F]/F")
    names = ("F", "[", "]", "&", "^", "+", "-", "/")
    lut = np.zeros(256, np.int32)
    for k, c in enumerate(names):
        lut[ord(c)] = k
    ids = lut[np.frombuffer(s[:n].encode("ascii"), np.uint8)]
    return ModuleString(names, ids, np.zeros(n + 1, np.int64), np.zeros(0))

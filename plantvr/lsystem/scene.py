"""L-Py's turtle scene, for the hooks that read it (issue 33): ``End(lstring, lscene)``, ``EndEach(lstring, lscene)``.

L-Py hands a hook with two parameters the PlantGL scene its turtle drew from the lstring
(``Lsystem::__apply_post_process``): one :class:`~plantvr.lsystem.pglscene.Shape` per thing drawn, in drawing
order, whose ``id`` is the index in the lstring of the module whose interpretation drew it (``turtle.setId`` in
L-Py's recursive interpretation). :func:`turtle_scene` builds that list from PlantVR's turtle, with the
geometry PlantGL's drawer builds (``PglTurtleDrawer``):

* a segment ``F`` of base width ``w0`` and top width ``w1`` is ``Cylinder(w0, l)`` (``w1 == w0``),
  ``Frustum(w0, l, w1 / w0)``, ``Cone(w0, l)`` (``w1 == 0``), an inverted ``Cone(w1, l)`` placed at its top
  (``w0 == 0``) or a ``Polyline`` (both 0);
* ``@O`` is ``Scaled(r, Sphere(1))``, ``@o`` ``AxisRotated(OY, pi/2, Disc(r))``, ``~name`` ``Scaled(s, surface)``;
* each placed primitive is ``Translated(position, Oriented(U, -L, geometry))``, each wrapper left out when the
  turtle is at the origin / in its initial frame (``PglTurtleDrawer::transform``);
* a polygon ``{ . }`` is a ``TriangleSet`` (fan) or, with the concave test, a ``FaceSet``; a tube ``@Gc ... @Ge``
  an ``Extrusion`` along its ``Polyline``; boxes ``@B`` and quads ``@b`` are ``TriangleSet``\\ s of their faces in
  world coordinates (PlantGL: ``Tapered`` boxes).

:class:`LazyScene` is what the hooks get: the scene built on first use, so a hook that never reads it costs
nothing.
"""
from __future__ import annotations

import math

import numpy as np

from . import _turtle_kernels as K
from .modules import ModuleString
from .pglscene import (AxisRotated, Disc, Extrusion, FaceSet, Frustum, Oriented, Polyline, Scaled, Scene, Shape,
                       Sphere, Translated, TriangleSet)
from .pglscene import Cone, Cylinder
from .plantgl import Material, Vector3

__all__ = ["LazyScene", "turtle_scene"]

_EPS = 1e-6           # PlantGL's GEOM_EPSILON
_TOL = 1e-10          # Vector3 equality (PlantGL's GEOM_TOLERANCE)


def _transform(frame: np.ndarray, geom):
    """``PglTurtleDrawer::transform``: ``Oriented(U, -L)`` unless the frame is the initial one, then
    ``Translated(position)`` unless at the origin; ``frame`` = (position, H, L, U)."""
    p, _, left, up = frame
    if np.abs(up - (1.0, 0.0, 0.0)).max() > _TOL or np.abs(left - (0.0, -1.0, 0.0)).max() > _TOL:
        geom = Oriented(up, -left, geom)
    if np.abs(p).max() > _TOL:
        geom = Translated(p, geom)
    return geom


def _segment(p0: np.ndarray, frame: np.ndarray, length: float, w0: float, w1: float):
    """``PglTurtleDrawer::frustum`` for a segment from ``p0``; ``frame`` = (H, L, U)."""
    h, left, up = frame
    if w0 > _EPS:
        taper = w1 / w0
        geom = Cone(w0, length, False) if abs(taper) < _EPS else (
            Cylinder(w0, length, False) if abs(taper - 1.0) < _EPS else Frustum(w0, length, taper, False))
        return _transform(np.stack([p0, h, left, up]), geom)
    if w1 < _EPS:
        return Polyline([Vector3(p0), Vector3(p0 + h * length)])
    geom = Cone(w1, length, False)
    if np.abs(left - (1.0, 0.0, 0.0)).max() > _TOL or np.abs(up - (0.0, -1.0, 0.0)).max() > _TOL:
        geom = Oriented(left, -up, geom)
    return Translated(p0 + h * length, geom)


def _mesh(cls, v: np.ndarray, f: np.ndarray):
    return cls([Vector3(p) for p in v], [tuple(int(k) for k in t) for t in f])


def _placed(shapes, s: int):
    """The geometry of placed shape ``s`` (sphere, disc, surface, box, quad) of :class:`TurtleShapes`."""
    from .shapes import SURFACES, box_mesh, quad_mesh
    kind, frame, size = int(shapes.kind[s]), shapes.frame[s], float(shapes.size[s])
    scale = np.ones(3) if shapes.scale is None else shapes.scale[s]
    if kind == K.SH_SPHERE:
        return _transform(frame, Scaled(scale * size, Sphere(1.0)))
    if kind == K.SH_CIRCLE:
        return _transform(frame, AxisRotated((0.0, 1.0, 0.0), math.pi / 2, Disc(float(size * scale[0]))))
    if kind == K.SH_SURFACE:
        return _transform(frame, Scaled(scale * size, _mesh(TriangleSet, *SURFACES[shapes.surface[s]])))
    mesh = box_mesh if kind == K.SH_BOX else quad_mesh
    return _mesh(TriangleSet, *mesh(frame, size, *shapes.radii[s]))


def _path(shapes, s: int):
    """A polygon's mesh or a tube's extrusion."""
    from .shapes import polygon_faces
    a, b = int(shapes.start[s]), int(shapes.start[s] + shapes.count[s])
    p = shapes.points[a:b]
    if shapes.kind[s] == K.SH_TUBE:
        if len(p) == 2 and np.linalg.norm(p[0] - p[1]) < _EPS:
            return None
        return Extrusion(Polyline([Vector3(q) for q in p]), None, [(float(r), float(r)) for r in shapes.radius[a:b]])
    if np.linalg.norm(p[0] - p[-1]) < _EPS:
        p = p[:-1]
    if len(p) < 3:
        return None
    concave = shapes.kind[s] == K.SH_POLYGON_CONCAVE
    return _mesh(FaceSet if concave else TriangleSet, p, polygon_faces(p, concave=bool(concave)))


def _openers(op: np.ndarray) -> dict[int, int]:
    """The module that opened each path shape, keyed by the module that drew it (``}``, ``@Ge``, the ``]`` that
    ends a branch's tube; -1 the string's end): PlantGL's shape id is the opener's (``Turtle::startPolygon`` and
    ``startGC`` take the id, ``popId()``); brackets save and restore what is open, as the turtle's stack."""
    out: dict[int, int] = {}
    poly = gc = -1
    stack = []
    for i in np.flatnonzero(np.isin(op, (K.PUSH, K.POP, K.POLY_START, K.POLY_END, K.GC_START, K.GC_END))).tolist():
        o = op[i]
        if o == K.PUSH:
            stack.append((poly, gc))
        elif o == K.POP:
            out[i] = gc
            poly, gc = stack.pop() if stack else (-1, -1)
        elif o == K.POLY_START:
            poly = i
        elif o == K.GC_START:
            gc = i
        else:
            out[i] = poly if o == K.POLY_END else gc
    out[-1] = gc
    return out


def _appearance(index: int, materials) -> Material:
    if index >= K.CUSTOM_COLOR:
        from .shapes import material_rgb
        return Material(f"Color_{index}", tuple(int(c) for c in material_rgb(index)), 1.0)
    name, ambient, diffuse = materials[index] if index < len(materials) else materials[0]
    return Material(name, ambient, diffuse)


def turtle_scene(string: ModuleString, ids=None, *, materials=None, **turtle_options) -> Scene:
    """The PlantGL scene L-Py's turtle draws from ``string`` (see the module docstring).

    Parameters
    ----------
    string : ModuleString
        The interpreted string, as :func:`~plantvr.lsystem.turtle.turtle` reads it.
    ids : (N,) int array, optional
        Each module's id (the index of the lstring module it was interpreted from); default its own index.
    materials : sequence of (name, (r, g, b), diffuse), optional
        The colour table of ``Shape.appearance`` (default :data:`~plantvr.lsystem.shapes.DEFAULT_MATERIALS`).
    **turtle_options
        As :func:`~plantvr.lsystem.turtle.turtle`'s.
    """
    from .shapes import DEFAULT_MATERIALS
    from .turtle import (DEFAULT_ANGLE, DEFAULT_STEP, DEFAULT_WIDTH, DEFAULT_WIDTH_INCREMENT, _interpret, _ops,
                         _shapes)
    materials = DEFAULT_MATERIALS if materials is None else materials
    ids = np.arange(len(string)) if ids is None else np.asarray(ids, np.int64)
    if ids.shape != (len(string),):
        raise ValueError(f"ids must have shape ({len(string)},), got {ids.shape}")
    unknown = set(turtle_options) - {"angle", "step", "width", "width_increment", "tropism", "elasticity"}
    if unknown:
        raise TypeError(f"turtle_scene: unknown turtle option(s) {sorted(unknown)}")
    opts = {"angle": DEFAULT_ANGLE, "step": DEFAULT_STEP, "width": DEFAULT_WIDTH,
            "width_increment": DEFAULT_WIDTH_INCREMENT, "tropism": (0.0, 0.0, 1.0), "elasticity": 0.0,
            **turtle_options}
    pos, parent, radius, _, _, color, module, nn, sint, sflt, spts, sec, seg = _interpret(
        string, opts["angle"], opts["step"], opts["width"], opts["width_increment"], opts["tropism"],
        opts["elasticity"], with_frames=True)
    items = []                                                       # (module, order, geometry, colour, id module)
    in_tube = None if sec is None else sec.in_tube
    for k in np.flatnonzero(parent[:nn] >= 0).tolist():
        m = int(module[k])
        if in_tube is not None and m >= 0 and in_tube[m]:
            continue                                                 # a point of its @Gc tube, not a cylinder
        p0 = pos[parent[k]]
        length = float(np.linalg.norm(pos[k] - p0))
        geom = _segment(p0, seg[k, :9].reshape(3, 3), length, float(seg[k, 9]), float(radius[k]))
        items.append((m, len(items), geom, int(color[k]), m))
    keep = (sint[:, 0] != K.SH_QUERY) & (sint[:, 0] != K.SH_LABEL) & (sint[:, 0] != K.SH_FRAME)
    shapes = _shapes(string, sint[keep], sflt[keep], spts, sec)
    paths = np.isin(shapes.kind, (K.SH_POLYGON, K.SH_POLYGON_CONCAVE, K.SH_TUBE))
    opener = _openers(_ops(string)[0]) if paths.any() else {}
    for s in range(len(shapes)):
        geom = _path(shapes, s) if paths[s] else _placed(shapes, s)
        if geom is not None:
            m = int(shapes.module[s])
            items.append((m if m >= 0 else len(string), len(items), geom, int(shapes.color[s]),
                          opener[m] if paths[s] else m))
    items.sort(key=lambda t: (t[0], t[1]))                           # drawing order: by the module that drew
    return Scene(Shape(g, _appearance(c, materials), int(ids[o]) if 0 <= o < len(ids) else -1)
                 for _, _, g, c, o in items)


class LazyScene:
    """A :class:`~plantvr.lsystem.pglscene.Scene` made by ``build()`` the first time it is read."""

    def __init__(self, build) -> None:
        self._build, self._scene = build, None

    def _get(self) -> Scene:
        if self._scene is None:
            self._scene = self._build()
        return self._scene

    def __len__(self) -> int:
        return len(self._get())

    def __bool__(self) -> bool:
        return True                                      # L-Py's scene is not None when it is handed over

    def __iter__(self):
        return iter(self._get())

    def __getitem__(self, k):
        return self._get()[k]

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self._get(), name)

    def __repr__(self) -> str:
        return repr(self._get())


def lsystem_scene(lsys, s: ModuleString) -> Scene:
    """The scene L-Py hands ``End(lstring, lscene)``: ``s`` interpreted module by module as L-Py's turtle does
    (``Lsystem::__recursiveInterpretation``, each shape's id the index in ``s`` of the module it came from), drawn
    with the grammar's turtle options and materials; modules the turtle does not draw are left out with a
    warning (``unsupported="warn"``)."""
    from .lexer import LSystemError
    s = lsys._adopt(s)
    depth = lsys._max_depth["homomorphism"]
    ids = None
    if lsys._rules["homomorphism"] and depth and len(s) == len(lsys._cut(s)):
        origin: list = []
        try:
            s = lsys._recursive(s, "homomorphism", depth, origin)[0]
        except RecursionError:
            raise LSystemError(f"homomorphism nested too deeply (maximum depth {depth})", *lsys._where) from None
        ids = np.asarray(origin, np.int64)
    elif lsys._rules["homomorphism"] and depth:           # a % cut: the ids of what is left are not the lstring's
        s = lsys._decompose(s, "homomorphism")
        ids = np.full(len(s), -1, np.int64)
    s, nhead, ntail = lsys._framed(s)                      # StartInterpretation's modules first, with no id
    if nhead or ntail:
        ids = np.concatenate([np.full(nhead, -1), np.arange(len(s) - nhead - ntail) if ids is None else ids,
                              np.full(ntail, -1)]).astype(np.int64)
    came: list = []
    drawable = lsys._drawable(s, "warn", came)
    if len(came) != len(s) or came != list(range(len(s))):   # an @g read into several modules: its id on each
        ids = (np.arange(len(s)) if ids is None else ids)[np.asarray(came, np.int64)]
    return lsys._turtle_call(lambda d, **o: turtle_scene(d, ids, materials=lsys.materials, **o), drawable,
                             dict(lsys._turtle))

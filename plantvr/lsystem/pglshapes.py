"""L-Py's ``@g`` (``PglShape``, issue 33): a PlantGL object drawn at the turtle, read into the modules PlantVR's
turtle draws.

L-Py's ``pglshape`` module (``predefinedmodules.cpp``) takes

* a geometry (``@g(geometry, scale=1)``): ``Scaled(turtle scale * scale, geometry)`` placed in the turtle's frame
  (``PglTurtleDrawer::customGeometry``), in the current colour: here a named surface ``surface(key, scale)`` of
  the geometry's mesh (:func:`geometry_mesh`), which the turtle places the same way (a curve, a line in PlantGL,
  draws nothing here);
* a material (``@g(Material(...))``): the turtle's custom appearance from then on: ``SetColor(r, g, b)``;
* a ``Shape``: its geometry in its appearance, then the colour index again (``removeCustomAppearance``:
  ``SetColor()``); a ``Scene``: each shape so.

Meshes follow PlantGL's primitives (``Sphere``, ``Cone``, ``Cylinder``, ``Frustum``, ``Disc``, ``Box``,
``TriangleSet``/``FaceSet``, ``NurbsPatch`` on its stride grid) and transforms (``Translated``, ``Scaled``, ``Oriented``, ``AxisRotated``) in the
geometry's own axes, which the turtle maps x to U, y to -L and z to H (``Oriented(U, -L)``).
"""
from __future__ import annotations

import hashlib
import math
import warnings

import numpy as np

from . import pglscene as G
from .lexer import LSystemError
from .modules import ModuleString
from .plantgl import Material, NurbsPatch, _Curve

__all__ = ["expand_pgl_shapes", "geometry_mesh"]

#: Most triangles one ``@g`` geometry may mesh to (a Sphere's slices are the grammar's to set).
MAX_FACES = 2_000_000


def _ring(r: float, z: float, n: int) -> np.ndarray:
    a = 2 * math.pi * np.arange(n) / n
    return np.column_stack([r * np.cos(a), r * np.sin(a), np.full(n, z)])


def _slices(v, what: str, lo: int = 3) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= 1024:
        raise ValueError(f"{what} must be an integer in [{lo}, 1024], got {v!r:.40}")
    return int(v)


def _frustum(r0: float, r1: float, h: float, solid: bool, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Rings of radius ``r0`` at z = 0 and ``r1`` at z = ``h`` (a cone's apex is a ring of radius 0), side
    quads as two triangles each, and with ``solid`` the discs closing them."""
    j = np.arange(n)
    jn = (j + 1) % n
    if r1 == 0:                                               # a cone: one apex
        v = np.vstack([_ring(r0, 0.0, n), [[0, 0, h], [0, 0, 0]]])
        f = [np.column_stack([j, jn, np.full(n, n)])]
        return v, np.vstack(f + ([np.column_stack([np.full(n, n + 1), jn, j])] if solid else []))
    v = np.vstack([_ring(r0, 0.0, n), _ring(r1, h, n), [[0, 0, 0], [0, 0, h]]])
    f = [np.column_stack([j, jn, n + jn]), np.column_stack([j, n + jn, n + j])]
    if solid:
        f += [np.column_stack([np.full(n, 2 * n), jn, j]), np.column_stack([np.full(n, 2 * n + 1), n + j, n + jn])]
    return v, np.vstack(f)


def _box(size) -> tuple[np.ndarray, np.ndarray]:
    s = np.asarray(tuple(size), float)
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * s
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return v, f


def _rotation(axis, angle: float) -> np.ndarray:
    k = np.asarray(tuple(axis), float)
    k = k / max(np.linalg.norm(k), 1e-300)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def geometry_mesh(geom, depth: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices, triangles)`` of a PlantGL geometry in its own axes (see the module docstring).

    Raises
    ------
    ValueError
        For a geometry PlantVR does not mesh (an ``Extrusion``, a curve), a bad resolution, or a mesh over
        :data:`MAX_FACES` triangles.
    """
    if depth > 64:
        raise ValueError("geometry transforms nested more than 64 deep")
    empty = (np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    if isinstance(geom, (G.Translated, G.Scaled, G.Oriented, G.AxisRotated)):
        v, f = geometry_mesh(geom.geometry, depth + 1)
        if isinstance(geom, G.Translated):
            return v + np.asarray(tuple(geom.translation), float), f
        if isinstance(geom, G.Scaled):
            return v * np.asarray(tuple(geom.scale), float), f
        if isinstance(geom, G.AxisRotated):
            return v @ _rotation(geom.axis, geom.angle).T, f
        p = np.asarray(tuple(geom.primary), float)
        p = p / max(np.linalg.norm(p), 1e-300)
        s = np.asarray(tuple(geom.secondary), float)
        s = s - p * (p @ s)
        s = s / max(np.linalg.norm(s), 1e-300)
        return v @ np.column_stack([p, s, np.cross(p, s)]).T, f
    if isinstance(geom, G.Sphere):
        from .shapes import sphere_mesh
        v, f = sphere_mesh(_slices(geom.slices, "Sphere slices"), _slices(geom.stacks, "Sphere stacks", 2))
        return v * float(geom.radius), f
    if isinstance(geom, G.Frustum):
        n = _slices(geom.slices, "Frustum slices")
        return _frustum(geom.radius, geom.radius * geom.taper, geom.height, bool(geom.solid), n)
    if isinstance(geom, G.Cylinder):
        return _frustum(geom.radius, geom.radius, geom.height, bool(geom.solid), _slices(geom.slices, "slices"))
    if isinstance(geom, G.Cone):
        return _frustum(geom.radius, 0.0, geom.height, bool(geom.solid), _slices(geom.slices, "Cone slices"))
    if isinstance(geom, G.Disc):
        n = _slices(geom.slices, "Disc slices")
        j = np.arange(n)
        return np.vstack([[0, 0, 0], _ring(geom.radius, 0.0, n)]), np.column_stack([np.zeros(n, int), 1 + j,
                                                                                     1 + (j + 1) % n])
    if isinstance(geom, G.Box):
        return _box(geom.size)
    if isinstance(geom, G.Mesh):
        v = np.asarray([tuple(p) for p in geom.pointList], float).reshape(-1, 3)
        tris = [(poly[0], poly[k], poly[k + 1]) for poly in geom.indexList for k in range(1, len(poly) - 1)]
        f = np.asarray(tris, np.int64).reshape(-1, 3)
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError(f"{type(geom).__name__} indexList refers to points outside its {len(v)} points")
        return v, f
    if isinstance(geom, NurbsPatch):                          # its ustride x vstride grid, two triangles a cell
        nu, nv = _slices(geom.ustride, "NurbsPatch ustride", 1), _slices(geom.vstride, "NurbsPatch vstride", 1)
        v = geom.grid().reshape(-1, 3)
        i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
        a = (i * (nv + 1) + j).ravel()
        b, c, d = a + nv + 1, a + nv + 2, a + 1
        f = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
        return v, (f if geom.ccw else f[:, ::-1])
    if isinstance(geom, (G.Polyline, G.PointSet, _Curve)):
        return empty                                          # lines and dots: nothing to mesh
    raise ValueError(f"PlantVR does not mesh {type(geom).__name__} (it draws PlantGL's primitives, meshes and "
                     "their transforms)")


def _surface_key(v: np.ndarray, f: np.ndarray) -> str:
    """The named surface of a mesh, registered once (its name hashes the arrays)."""
    from .shapes import SURFACES, register_surface
    key = "pgl_" + hashlib.sha1(v.tobytes() + f.tobytes()).hexdigest()[:16]
    if key not in SURFACES:
        register_surface(key, v, f)
    return key


def _rgb(app) -> tuple[float, float, float]:
    if not isinstance(app, Material):
        _not_drawable(app)
    return tuple(float(c) for c in app.rgb())


def _not_drawable(obj):
    raise ValueError(f"PlantVR draws a PlantGL geometry, Shape, Scene or Material here, got {type(obj).__name__}")


def expand_pgl_shapes(s: ModuleString, unsupported: str = "error") -> tuple[ModuleString, list[int] | None]:
    """``s`` with each ``@g`` / ``PglShape`` read into turtle modules (the module docstring), and for each
    module of the result the index in ``s`` it came from (None when ``s`` has none). An ``@g`` without
    parameters draws nothing (L-Py warns); one of something PlantVR does not draw (see :func:`geometry_mesh`) is
    left out with a warning when ``unsupported`` is ``"warn"``.

    Raises
    ------
    LSystemError
        For an ``@g`` of something PlantVR does not draw, when ``unsupported`` is ``"error"``.
    """
    pg = [k for k, nm in enumerate(s.names) if nm in ("@g", "PglShape")]
    if not pg or not np.isin(s.ids, pg).any():
        return s, None
    out: list = []
    origin: list[int] = []
    for i in range(len(s)):
        name, vals = s.module(i)
        if name not in ("@g", "PglShape"):
            out.append((name, vals))
            origin.append(i)
            continue
        try:
            mods = _drawn(vals) if vals else []
        except ValueError as e:
            if unsupported == "error":
                raise LSystemError(f"{name}: {e} (unsupported='warn' draws the rest without it)") from None
            warnings.warn(f"not drawn: {name} at module {i}: {e}", stacklevel=4)
            mods = []
        out += mods
        origin += [i] * len(mods)
    return ModuleString.from_modules(out, s.names), origin


def _drawn(vals: tuple) -> list:
    obj = vals[0] if vals else None
    if isinstance(obj, Material):
        return [("SetColor", _rgb(obj))]
    if isinstance(obj, (G.Scene, G.Shape)):
        mods = []
        for sh in obj if isinstance(obj, G.Scene) else [obj]:
            sh = sh if isinstance(sh, G.Shape) else G.Shape(sh)          # Scene([Sphere(), ...]): bare geometry
            mods.append(("SetColor", _rgb(sh.appearance) if sh.appearance is not None else ()))
            v, f = _checked(sh.geometry)
            if len(f):
                mods.append(("surface", (_surface_key(v, f), 1.0)))
        return mods + [("SetColor", ())]                     # removeCustomAppearance
    v, f = _checked(obj)
    scale = float(vals[1]) if len(vals) > 1 else 1.0
    if not math.isfinite(scale):
        raise ValueError(f"the scale must be finite, got {scale}")
    return [("surface", (_surface_key(v, f), scale))] if len(f) else []


def _checked(geom) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(geom, (G._Geometry, _Curve, NurbsPatch)):
        _not_drawable(geom)
    v, f = geometry_mesh(geom)
    if len(f) > MAX_FACES:
        raise ValueError(f"a {type(geom).__name__} of {len(f):,} triangles is over {MAX_FACES:,}")
    if not np.isfinite(v).all():
        raise ValueError(f"the {type(geom).__name__} has points that are not finite")
    return v, f

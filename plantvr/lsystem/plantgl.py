"""A small ``openalea.plantgl.all`` for L-Py grammars (issue 33): the vectors, colours, materials, curves and
functions the distribution's grammars use, in numpy.

A TRUSTED grammar's ``import openalea.plantgl.all as pgl`` and ``from openalea.plantgl.all import *`` resolve
here (:func:`grammar_builtins`, the builtins the engine gives a trusted grammar), whether or not PlantGL is
installed: PlantVR's turtle draws numbers, so these objects evaluate to numbers. An untrusted grammar cannot
import at all (the restricted evaluator).

* :class:`Vector2`, :class:`Vector3`, :class:`Vector4`: mutable float vectors (``x``, ``y``, ``z``,
  ``+ - * /``, ``normalize()`` in place, ``OX``/``OY``/``OZ``); lists underneath, so a module parameter written
  ``@Tp(Vector3(0, 0, -1))`` is its three numbers. :func:`norm`, :func:`dot`, :func:`cross`,
  :func:`direction` as PlantGL's (written in :mod:`~plantvr.lsystem.pglmath`).
* the scene graph the turtle's scene is made of (:mod:`~plantvr.lsystem.pglscene`): ``Scene``, ``Shape``,
  ``Cylinder``, ``Translated``, ...
* :class:`Color3`, :class:`Color4` (0-255), :class:`Material` (``ambient``, ``diffuse`` factor, ...;
  :meth:`Material.rgb` = ambient times diffuse, PlantGL's diffuse colour).
* :class:`Point2Array`, :class:`Point3Array`, :class:`Point4Array`, :class:`RealArray`; :class:`NurbsCurve2D`,
  :class:`NurbsCurve`, :class:`BezierCurve2D`, :class:`Polyline2D` with ``getPointAt(u)``;
  :class:`QuantisedFunction` (a curve read as ``y = f(x)``, ``f(x)`` / ``getValue(x)``), what ``nF`` and the
  editor's function panels hand a grammar.

References
----------
.. [1] PlantGL ``src/cpp/plantgl/scenegraph/geometry/nurbscurve.cpp`` (``getPointAt``: de Boor on homogeneous
   control points, clamped uniform knots by default), ``bezriercurve.cpp``, ``polyline.cpp``,
   ``algo/base/quantisedfunction.cpp``; ``appearance/material.cpp`` (defaults: ambient (80, 80, 80),
   diffuse 2).
"""
from __future__ import annotations

import builtins
import copy
import math
import re
import sys
import types
from typing import Any

import numpy as np

from . import pglscene as _pglscene
from .pglmath import Matrix3, Vector2, Vector3, Vector4, _Vector, angle, cross, direction, dot, norm
from .pglscene import *  # noqa: F403  the turtle's scene nodes: Scene, Shape, Cylinder, Translated, ...

__all__ = ["BezierCurve2D", "Color3", "Color4", "ImageTexture", "Material", "Matrix3", "Texture2D", "NurbsCurve",
           "NurbsCurve2D", "NurbsPatch", "Point2Array", "Point3Grid", "Point4Matrix", "pointset_mean_direction",
           "Point3Array", "Point4Array", "Polyline2D", "QuantisedFunction", "RealArray", "Vector2", "Vector3",
           "Vector4", "angle", "cross", "direction", "dot", "norm"]
__all__ += _pglscene.__all__


# -- colours and materials -----------------------------------------------------------------------------------
class Color3(_Vector):
    """PlantGL ``Color3``: red, green, blue in 0..255."""

    _N = 3

    def __init__(self, *v) -> None:
        super().__init__(*v)
        self[:] = [float(min(max(round(a), 0), 255)) for a in self]

    red, green, blue = _Vector.x, _Vector.y, _Vector.z


class Color4(Color3):
    """PlantGL ``Color4``: red, green, blue, alpha in 0..255."""

    _N = 4
    alpha = _Vector.w


class Material:
    """PlantGL ``Material``: ``Material(name="", ambient=(80, 80, 80), diffuse=2, specular=(40, 40, 40),
    emission=(0, 0, 0), shininess=1, transparency=0)``; ``Material(ambient, diffuse)`` too."""

    def __init__(self, *args, **kw) -> None:
        if args and not isinstance(args[0], str):
            args = ("",) + args
        keys = ("name", "ambient", "diffuse", "specular", "emission", "shininess", "transparency")
        vals = {"name": "", "ambient": (80, 80, 80), "diffuse": 2.0, "specular": (40, 40, 40),
                "emission": (0, 0, 0), "shininess": 1.0, "transparency": 0.0}
        for k, v in zip(keys, args):
            vals[k] = v
        unknown = set(kw) - set(keys)
        if unknown:
            raise ValueError(f"Material: unknown argument(s) {sorted(unknown)}; known: {list(keys)}")
        vals.update(kw)
        self.name = str(vals["name"])
        self.ambient, self.specular, self.emission = (Color3(vals[k]) for k in ("ambient", "specular", "emission"))
        self.diffuse, self.shininess = float(vals["diffuse"]), float(vals["shininess"])
        self.transparency = float(vals["transparency"])

    def rgb(self) -> tuple[int, int, int]:
        """The diffuse colour: ambient times the diffuse factor, clipped to 255."""
        return tuple(int(min(max(round(a * self.diffuse), 0), 255)) for a in self.ambient)

    def diffuseColor(self) -> Color3:
        return Color3(*self.rgb())

    def as_entry(self) -> tuple[str, tuple[int, int, int], float]:
        """``(name, ambient, diffuse)``, an entry of :data:`plantvr.lsystem.shapes.DEFAULT_MATERIALS`."""
        return self.name, tuple(int(a) for a in self.ambient), self.diffuse

    def __repr__(self) -> str:
        return f"Material({self.name!r}, ambient={tuple(int(a) for a in self.ambient)}, diffuse={self.diffuse:g})"


class ImageTexture(Material):
    """PlantGL ``ImageTexture([name,] filename, ...)``, drawn as a material of the image's mean colour: PlantVR's
    scene carries one colour per material, not the picture (the image is read when it can be: a missing or
    unreadable file draws grey)."""

    def __init__(self, *args, **kw) -> None:
        names = [a for a in args if isinstance(a, str)]
        if not names and not isinstance(kw.get("filename"), str):
            raise ValueError("ImageTexture needs a file name")
        filename = kw["filename"] if isinstance(kw.get("filename"), str) else names.pop()
        super().__init__(kw.get("name", names[0] if names else filename), _mean_rgb(filename), 1.0)
        self.filename = filename


class Texture2D(Material):
    """PlantGL ``Texture2D(image=ImageTexture(...), transformation=None, baseColor=None)`` (the editor's texture
    materials): drawn in the image's mean colour, as :class:`ImageTexture`."""

    def __init__(self, name: str = "", image: ImageTexture | None = None, transformation=None, baseColor=None,
                 **kw) -> None:
        if image is None and isinstance(name, ImageTexture):
            name, image = "", name
        if not isinstance(image, ImageTexture):
            raise ValueError(f"Texture2D needs image=ImageTexture(...), got {type(image).__name__}")
        super().__init__(str(name or image.name), tuple(int(a) for a in image.ambient), image.diffuse)
        self.image = image


def _mean_rgb(filename: str) -> tuple[int, int, int]:
    """The mean RGB of an image file (grey when it cannot be read; at most a 4096 x 4096 thumbnail is averaged)."""
    try:
        from PIL import Image  # noqa: PLC0415

        with Image.open(filename) as im:
            im.draft("RGB", (256, 256))
            im.thumbnail((4096, 4096))
            a = np.asarray(im.convert("RGBA"), np.float64).reshape(-1, 4)
        w = a[:, 3] / 255.0
        if w.sum() <= 0:
            return (128, 128, 128)
        return tuple(int(round(float(x))) for x in (a[:, :3] * w[:, None]).sum(0) / w.sum())
    except Exception:  # noqa: BLE001  any unreadable picture: a neutral colour, as a missing texture
        return (128, 128, 128)


# -- point arrays and curves ---------------------------------------------------------------------------------
class _PointArray(list):
    _V = Vector3

    def __init__(self, points=()) -> None:
        super().__init__(self._V(p) for p in points)


class Point2Array(_PointArray):
    """PlantGL ``Point2Array``."""

    _V = Vector2


class Point3Array(_PointArray):
    """PlantGL ``Point3Array``."""

    _V = Vector3


class Point4Array(_PointArray):
    """PlantGL ``Point4Array``."""

    _V = Vector4


class RealArray(list):
    """PlantGL ``RealArray``: a list of floats (knot vectors, widths)."""

    def __init__(self, values=()) -> None:
        super().__init__(float(v) for v in values)


def _clamped_knots(n: int, degree: int) -> np.ndarray:
    """PlantGL's default knot vector: clamped, uniform on [0, 1] (``NurbsCurve::defaultKnotList``)."""
    inner = np.linspace(0.0, 1.0, n - degree + 1)
    return np.concatenate([np.zeros(degree), inner, np.ones(degree)])


def _de_boor(ctrl: np.ndarray, knots: np.ndarray, degree: int, u: float) -> np.ndarray:
    """The B-spline of homogeneous control points ``ctrl`` (n, d) at ``u`` (de Boor's algorithm)."""
    n = len(ctrl)
    u = min(max(float(u), knots[degree]), knots[n])
    k = int(np.searchsorted(knots, u, side="right") - 1)
    k = min(max(k, degree), n - 1)
    d = [ctrl[j + k - degree].copy() for j in range(degree + 1)]
    for r in range(1, degree + 1):
        for j in range(degree, r - 1, -1):
            i = j + k - degree
            den = knots[i + degree - r + 1] - knots[i]
            a = 0.0 if den == 0 else (u - knots[i]) / den
            d[j] = (1 - a) * d[j - 1] + a * d[j]
    return d[degree]


class _Curve:
    """PlantGL's ``LineicModel`` methods of the curves below, from ``getPointAt``: the knot range, the tangent
    (central differences), the length and the arc-length to parameter mapping (``stride`` chords, as
    ``LineicModel::getArcLengthToUMapping``)."""

    stride = 60

    def getFirstKnot(self) -> float:
        return self.firstKnot

    def getLastKnot(self) -> float:
        return self.lastKnot

    def getTangentAt(self, u: float):
        h = 1e-6 * (self.lastKnot - self.firstKnot)
        a, b = max(float(u) - h, self.firstKnot), min(float(u) + h, self.lastKnot)
        d = (np.asarray(self.getPointAt(b), float) - np.asarray(self.getPointAt(a), float)) / (b - a)
        return type(self.getPointAt(a))(*d)

    def _arc(self) -> tuple[np.ndarray, np.ndarray]:
        u = np.linspace(self.firstKnot, self.lastKnot, int(self.stride) + 1)
        p = np.array([list(self.getPointAt(x)) for x in u], float)
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]), u

    def getLength(self) -> float:
        return float(self._arc()[0][-1])

    def deepcopy(self):
        """A copy sharing nothing (PlantGL's ``SceneObject.deepcopy``)."""
        return copy.deepcopy(self)

    def getArcLengthToUMapping(self) -> QuantisedFunction:
        """The parameter ``u`` at each fraction of the curve's length, as a function on [0, 1]."""
        s, u = self._arc()
        return QuantisedFunction(Polyline2D(np.column_stack([s / s[-1], u])))


class NurbsCurve2D(_Curve):
    """PlantGL ``NurbsCurve2D(ctrlPointList, knotList=None, degree=3)``: control points ``(x, y, w)``
    (homogeneous weight ``w``, PlantGL's convention: the point is ``(x, y)``, weighted by ``w``)."""

    _DIM = 2

    def __init__(self, ctrlPointList, knotList=None, degree: int = 3, stride: int = 60, **kw) -> None:
        pts = np.asarray([list(p) for p in ctrlPointList], float)
        if pts.ndim != 2 or pts.shape[1] not in (self._DIM, self._DIM + 1) or len(pts) < 2:
            raise ValueError(f"ctrlPointList must hold at least 2 points of {self._DIM} or {self._DIM + 1} "
                             f"coordinates, got shape {pts.shape}")
        if pts.shape[1] == self._DIM:
            pts = np.column_stack([pts, np.ones(len(pts))])
        self._ctrl = pts
        self.degree = int(min(max(int(degree), 1), len(pts) - 1))
        self.knotList = (np.asarray(knotList, float) if knotList is not None
                         else _clamped_knots(len(pts), self.degree))
        if len(self.knotList) != len(pts) + self.degree + 1:
            raise ValueError(f"knotList must hold {len(pts) + self.degree + 1} knots, got {len(self.knotList)}")
        self.stride = int(stride)
        self.name = str(kw.get("name", ""))

    @property
    def ctrlPointList(self) -> _PointArray:
        """The homogeneous control points as PlantGL hands them: vectors with ``x``, ``y``, ``z`` (``w``)."""
        return (Point3Array if self._DIM == 2 else Point4Array)(self._ctrl)

    @property
    def firstKnot(self) -> float:
        return float(self.knotList[self.degree])

    @property
    def lastKnot(self) -> float:
        return float(self.knotList[len(self._ctrl)])

    def getPointAt(self, u: float):
        """The curve point at parameter ``u`` (clamped to the knot range)."""
        w = self._ctrl[:, -1:]
        h = _de_boor(np.column_stack([self._ctrl[:, :-1] * w, w]), self.knotList, self.degree, u)
        p = h[:-1] / h[-1]
        return (Vector2 if self._DIM == 2 else Vector3)(*p)

    def samples(self, n: int = 200) -> np.ndarray:
        """(n, dim) points at evenly spaced parameters."""
        return np.array([self.getPointAt(u) for u in np.linspace(self.firstKnot, self.lastKnot, n)])


class NurbsCurve(NurbsCurve2D):
    """PlantGL ``NurbsCurve``: control points ``(x, y, z, w)``."""

    _DIM = 3


class BezierCurve2D(NurbsCurve2D):
    """PlantGL ``BezierCurve2D(ctrlPointList)``: one Bezier segment of degree n - 1, parameter in [0, 1]."""

    def __init__(self, ctrlPointList, stride: int = 60, **kw) -> None:
        n = len(list(ctrlPointList))
        super().__init__(ctrlPointList, np.r_[np.zeros(n), np.ones(n)], n - 1, stride, **kw)


class Polyline2D(_Curve):
    """PlantGL ``Polyline2D(pointList)``: parameter ``u`` in [0, n - 1], linear between points."""

    def __init__(self, pointList, **kw) -> None:
        self.pointList = np.asarray([list(p)[:2] for p in pointList], float)
        if len(self.pointList) < 2:
            raise ValueError(f"pointList must hold at least 2 points, got {len(self.pointList)}")
        self.name = str(kw.get("name", ""))

    firstKnot = 0.0

    @property
    def lastKnot(self) -> float:
        return float(len(self.pointList) - 1)

    def getPointAt(self, u: float) -> Vector2:
        u = min(max(float(u), 0.0), self.lastKnot)
        k = min(int(u), len(self.pointList) - 2)
        a = u - k
        return Vector2(*((1 - a) * self.pointList[k] + a * self.pointList[k + 1]))

    def samples(self, n: int = 200) -> np.ndarray:
        return np.array([self.getPointAt(u) for u in np.linspace(0, self.lastKnot, n)])

    @staticmethod
    def Circle(radius: float = 1.0, slices: int = 8) -> Polyline2D:
        a = np.linspace(0, 2 * np.pi, int(slices) + 1)
        return Polyline2D(np.column_stack([radius * np.cos(a), radius * np.sin(a)]))


class QuantisedFunction:
    """PlantGL ``QuantisedFunction(curve, sampling=100)``: a 2-D curve read as ``y = f(x)`` (the editor's
    function panels), sampled and linearly interpolated; ``f(x)``, ``getValue(x)``, ``firstx``, ``lastx``.

    ``x`` outside [firstx, lastx] is clamped (PlantGL's ``clamped`` default)."""

    def __init__(self, curve, sampling: int = 100, clamped: bool = True) -> None:
        if not hasattr(curve, "getPointAt") and isinstance(curve, (list, tuple)):
            curve = Polyline2D(curve)                     # QuantisedFunction(Point2Array): the points themselves
        if not hasattr(curve, "getPointAt"):
            raise ValueError(f"curve must be a PlantGL-like 2-D curve or a list of (x, y) points, got "
                             f"{type(curve).__name__}")
        pts = curve.samples(max(int(sampling), 2) * 10)
        order = np.argsort(pts[:, 0], kind="stable")
        self._x, self._y = pts[order, 0], pts[order, 1]
        self.sampling, self.clamped = int(sampling), bool(clamped)

    @property
    def firstx(self) -> float:
        return float(self._x[0])

    @property
    def lastx(self) -> float:
        return float(self._x[-1])

    def __call__(self, x: float) -> float:
        return float(np.interp(float(x), self._x, self._y))

    getValue = __call__

    def inverse(self) -> QuantisedFunction:
        """``x = f^-1(y)`` (a monotonic function)."""
        inv = QuantisedFunction.__new__(QuantisedFunction)
        order = np.argsort(self._y, kind="stable")
        inv._x, inv._y, inv.sampling, inv.clamped = self._y[order], self._x[order], self.sampling, self.clamped
        return inv


class Point4Matrix(list):
    """PlantGL ``Point4Matrix(rows)``: rows of ``(x, y, z, w)`` points (a patch's control net, rows along u)."""

    def __init__(self, rows=()) -> None:
        super().__init__([Vector4(*p) for p in row] for row in rows)


class NurbsPatch:
    """PlantGL ``NurbsPatch(ctrlPointMatrix, udegree=3, vdegree=3, uknotList=None, vknotList=None, ustride=30,
    vstride=30, ccw=True)``: the tensor-product NURBS surface of a net of homogeneous points ``(x, y, z, w)``
    (rows along u), clamped uniform knots by default; meshed on ``ustride`` x ``vstride`` cells where drawn."""

    def __init__(self, ctrlPointMatrix, udegree: int = 3, vdegree: int = 3, uknotList=None, vknotList=None,
                 ustride: int = 30, vstride: int = 30, ccw: bool = True, **kw) -> None:
        net = np.asarray([[list(p) for p in row] for row in ctrlPointMatrix], float)
        if net.ndim != 3 or net.shape[2] not in (3, 4) or min(net.shape[:2]) < 2 or not np.isfinite(net).all():
            raise ValueError(f"ctrlPointMatrix must be a finite net of at least 2 x 2 points (x, y, z[, w]), got "
                             f"shape {net.shape}")
        if net.shape[2] == 3:
            net = np.concatenate([net, np.ones(net.shape[:2] + (1,))], axis=2)
        self._net = net
        self.udegree = int(min(max(int(udegree), 1), net.shape[0] - 1))
        self.vdegree = int(min(max(int(vdegree), 1), net.shape[1] - 1))
        self.uknotList = np.asarray(uknotList, float) if uknotList is not None else \
            _clamped_knots(net.shape[0], self.udegree)
        self.vknotList = np.asarray(vknotList, float) if vknotList is not None else \
            _clamped_knots(net.shape[1], self.vdegree)
        for knots, n, d, what in ((self.uknotList, net.shape[0], self.udegree, "uknotList"),
                                  (self.vknotList, net.shape[1], self.vdegree, "vknotList")):
            if len(knots) != n + d + 1:
                raise ValueError(f"{what} must hold {n + d + 1} knots, got {len(knots)}")
        self.ustride, self.vstride, self.ccw = int(ustride), int(vstride), bool(ccw)
        self.name = str(kw.get("name", ""))

    @property
    def ctrlPointMatrix(self) -> Point4Matrix:
        return Point4Matrix(self._net)

    def _range(self, knots, n: int, d: int) -> tuple[float, float]:
        return float(knots[d]), float(knots[n])

    def getPointAt(self, u: float, v: float | None = None) -> Vector3:
        """The surface point at ``(u, v)`` (also as one pair ``getPointAt((u, v))``), clamped to the knots."""
        if v is None:
            u, v = u
        w = self._net[..., 3:]
        hom = np.concatenate([self._net[..., :3] * w, w], axis=2)
        rows = np.array([_de_boor(row, self.vknotList, self.vdegree, v) for row in hom])
        h = _de_boor(rows, self.uknotList, self.udegree, u)
        return Vector3(*(h[:3] / h[3]))

    def _diff(self, u: float, v: float, along: int) -> np.ndarray:
        knots, n, d = ((self.uknotList, self._net.shape[0], self.udegree) if along == 0 else
                       (self.vknotList, self._net.shape[1], self.vdegree))
        lo, hi = self._range(knots, n, d)
        h = 1e-6 * (hi - lo)
        x = (u, v)[along]
        a, b = max(x - h, lo), min(x + h, hi)
        pa = self.getPointAt(*((a, v) if along == 0 else (u, a)))
        pb = self.getPointAt(*((b, v) if along == 0 else (u, b)))
        return (np.asarray(pb, float) - np.asarray(pa, float)) / (b - a)

    def getUTangentAt(self, u: float, v: float | None = None) -> Vector3:
        if v is None:
            u, v = u
        return Vector3(*self._diff(float(u), float(v), 0))

    def getVTangentAt(self, u: float, v: float | None = None) -> Vector3:
        if v is None:
            u, v = u
        return Vector3(*self._diff(float(u), float(v), 1))

    def getNormalAt(self, u: float, v: float | None = None) -> Vector3:
        """The unit normal ``dP/du x dP/dv`` (its opposite when not ``ccw``)."""
        if v is None:
            u, v = u
        nrm = np.cross(self._diff(float(u), float(v), 0), self._diff(float(u), float(v), 1))
        nrm = nrm / max(np.linalg.norm(nrm), 1e-300)
        return Vector3(*(nrm if self.ccw else -nrm))

    def grid(self) -> np.ndarray:
        """``(ustride + 1, vstride + 1, 3)`` surface points on the knot ranges (what PlantGL's tessellation
        meshes)."""
        ul = self._range(self.uknotList, self._net.shape[0], self.udegree)
        vl = self._range(self.vknotList, self._net.shape[1], self.vdegree)
        return np.array([[list(self.getPointAt(u, v)) for v in np.linspace(*vl, self.vstride + 1)]
                         for u in np.linspace(*ul, self.ustride + 1)])


class Point3Grid:
    """PlantGL ``Point3Grid(points, maxpointsbyvoxel)`` / ``Point3Grid(voxelsize, points)``: points that can be
    disabled, queried in a ball or a cone (``regularpointgrid.h``); a ``scipy.spatial.cKDTree`` here, which gives
    the same points, in index order (PlantGL's come in voxel order)."""

    def __init__(self, a, b=None) -> None:
        from scipy.spatial import cKDTree  # noqa: PLC0415
        pts = b if isinstance(a, (int, float)) or _is_vector(a) else a     # (voxelsize, points) or (points, n)
        arr = np.asarray([list(p) for p in pts], float).reshape(-1, 3)
        if not np.isfinite(arr).all():
            raise ValueError("Point3Grid points must be finite")
        self._pts, self._tree = arr, cKDTree(arr)
        self._on = np.ones(len(arr), bool)

    def _ball(self, point, radius) -> np.ndarray:
        idx = np.asarray(self._tree.query_ball_point(np.asarray(point, float), float(radius), return_sorted=True),
                         np.int64)
        return idx[self._on[idx]]

    def query_ball_point(self, point, radius) -> list[int]:
        return self._ball(point, radius).tolist()

    def query_points_in_cone(self, origin, direction, radius, angle: float = math.pi / 2) -> list[int]:
        """Enabled points within ``radius`` of ``origin`` whose direction from it lies within ``angle / 2`` of
        ``direction`` (the cone's full opening is ``angle``, radians)."""
        o = np.asarray(origin, float)
        d = np.asarray(direction, float)
        d = d / max(float(np.sqrt(d @ d)), 1e-300)
        idx = self._ball(o, float(radius) + 1e-10)
        v = self._pts[idx] - o
        n = np.sqrt(np.einsum("ij,ij->i", v, v))
        inside = (v @ d) > (math.cos(float(angle) / 2) - 1e-10) * n           # the origin itself is inside
        return idx[inside].tolist()

    def _check(self, i) -> int:
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < len(self._pts):
            raise IndexError(f"point index must be in [0, {len(self._pts)}), got {i!r:.40}")
        return int(i)

    def disable_point(self, i) -> bool:
        was = bool(self._on[self._check(i)])
        self._on[int(i)] = False
        return was

    def enable_point(self, i) -> bool:
        was = bool(self._on[self._check(i)])
        self._on[int(i)] = True
        return not was

    def is_point_enabled(self, i) -> bool:
        return bool(self._on[self._check(i)])

    def disable_points(self, idx) -> None:
        for i in idx:
            self.disable_point(i)

    def enable_points(self, idx) -> None:
        for i in idx:
            self.enable_point(i)

    def get_enabled_points(self) -> Point3Array:
        return Point3Array(self._pts[self._on])

    def get_disabled_points(self) -> Point3Array:
        return Point3Array(self._pts[~self._on])

    def get_enabled_point_indices(self) -> list[int]:
        return np.flatnonzero(self._on).tolist()

    def nbPoints(self) -> int:
        return len(self._pts)


def pointset_mean_direction(origin, points, group=()) -> Vector3:
    """PlantGL's ``pointset_mean_direction``: the unit mean of the unit directions from ``origin`` to the points
    of ``group`` (indices; all points without one)."""
    p = np.asarray([points[i] for i in group] if len(group) else list(points), float).reshape(-1, 3)
    d = p - np.asarray(list(origin), float)
    d = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
    m = d.mean(axis=0) if len(d) else np.zeros(3)
    return Vector3(*(m / max(np.linalg.norm(m), 1e-300)))


def _is_vector(v) -> bool:
    return isinstance(v, (list, tuple)) and len(v) == 3 and all(isinstance(x, (int, float)) for x in v) and \
        not isinstance(v, _PointArray)


# -- what is not here ----------------------------------------------------------------------------------------
#: PlantGL names grammars use that this namespace does not have: the other scene-graph nodes and transforms,
#: patches (``NurbsPatch`` is here), grids and the viewer (a grammar naming one is refused with this said).
NOT_HERE = frozenset({
    "Group", "EulerRotated", "Tapered", "Paraboloid", "Swung", "QuadSet", "BezierPatch", "Point3Matrix",
    "Discretizer", "Tesselator", "BoundingBox", "Point2Grid", "Grid3Indexing", "Viewer",
    "eStatic", "eAnimatedScene", "eAnimatedPrimitives", "pgl_support_extension", "Text", "Font", "Texture2DTransformation",
})


def not_here_hint(e: BaseException) -> str:
    """A clause for an error that names a PlantGL name of :data:`NOT_HERE` (empty otherwise)."""
    if not isinstance(e, (NameError, AttributeError, ImportError)):
        return ""
    names = {getattr(e, "name", None)} | set(re.findall(r"'(\w+)'", str(e)))
    if isinstance(e, NameError) and "turtle" in names:
        return ("; rule code driving PlantGL's turtle object (turtle.left(...), turtle.sphere(...)) is not "
                "supported: produce turtle modules instead")
    if isinstance(e, NameError) and "Lsystem" in names:
        return "; L-Py's own Lsystem class (an L-system run from grammar code) is not supported"
    hit = sorted(n for n in names if n in NOT_HERE)
    if not hit:
        return ""
    return (f"; PlantGL's {hit[0]} is not in PlantVR's PlantGL namespace (scene-graph nodes, primitives, patches, "
            "grids and the viewer are not supported; the turtle's scene nodes are)")


# -- the import hook -----------------------------------------------------------------------------------------
_ALIASES = ("openalea.plantgl.all", "openalea.plantgl.math", "openalea.plantgl.scenegraph")


def _shim_modules() -> dict[str, types.ModuleType]:
    """``openalea``, ``openalea.plantgl`` and its ``all`` (this module) as module objects (not in sys.modules)."""
    this = sys.modules[__name__]
    top, pgl = types.ModuleType("openalea"), types.ModuleType("openalea.plantgl")
    top.plantgl = pgl
    mods = {"openalea": top, "openalea.plantgl": pgl}
    for name in _ALIASES:
        setattr(pgl, name.rsplit(".", 1)[1], this)
        mods[name] = this
    for k in __all__:
        setattr(pgl, k, getattr(this, k))
    return mods


def grammar_import(name, globals=None, locals=None, fromlist=(), level=0):
    """``__import__`` of a trusted grammar: ``openalea.plantgl[.all|.math]`` is this module, the rest Python's."""
    if level == 0 and (name == "openalea.lpy" or name.startswith("openalea.lpy.")):
        raise ImportError(f"{name}: L-Py's own package (the Lsystem class, __lpyfuture__, tableparameterset) is not "
                          "supported in PlantVR's grammars (ParameterSet, Lstring and the hooks are there without "
                          "an import)")
    if level == 0 and (name == "openalea" or name.startswith("openalea.plantgl")):
        mods = _shim_modules()
        if name not in mods:
            raise ImportError(f"{name}: PlantVR's PlantGL namespace has {', '.join(_ALIASES)} only")
        return mods[name] if fromlist else mods["openalea"]
    return builtins.__import__(name, globals, locals, fromlist, level)


def grammar_builtins() -> dict[str, Any]:
    """The builtins of a trusted grammar: Python's, with :func:`grammar_import` as ``__import__``."""
    out = dict(vars(builtins))
    out["__import__"] = grammar_import
    return out

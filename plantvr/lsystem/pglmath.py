"""PlantGL's vector math for L-Py grammars (issue 33): ``Vector2/3/4``, ``Matrix3``, ``norm``, ``dot``,
``cross``, ``angle``, ``direction``; what :mod:`~plantvr.lsystem.plantgl` and the scene graph
(:mod:`~plantvr.lsystem.pglscene`) are built on.

* :class:`Vector2`, :class:`Vector3`, :class:`Vector4`: mutable float vectors (``x``, ``y``, ``z``,
  ``+ - * /``, ``normalize()`` in place, ``OX``/``OY``/``OZ``); lists underneath, so a module parameter written
  ``@Tp(Vector3(0, 0, -1))`` is its three numbers.

References
----------
.. [1] PlantGL ``src/cpp/plantgl/math/util_vector.h`` (``norm``, ``dot``, ``cross``, ``angle``, ``direction``).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["Matrix3", "Vector2", "Vector3", "Vector4", "angle", "cross", "direction", "dot", "norm"]


# -- vectors -------------------------------------------------------------------------------------------------
class _Vector(list):
    """A mutable float vector of fixed size (a list, so module parameters flatten it)."""

    _N = 3

    def __init__(self, *v) -> None:
        if len(v) == 1 and hasattr(v[0], "__len__"):
            v = tuple(v[0])
        if len(v) > self._N:
            raise ValueError(f"{type(self).__name__} takes at most {self._N} coordinates, got {len(v)}")
        super().__init__([float(x) for x in v] + [0.0] * (self._N - len(v)))

    def _get(k):
        return property(lambda self: self[k], lambda self, val: self.__setitem__(k, float(val)))

    x, y, z, w = _get(0), _get(1), _get(2), _get(3)
    del _get

    def __add__(self, o):
        return type(self)(*(a + b for a, b in zip(self, o)))

    __radd__ = __add__

    def __sub__(self, o):
        return type(self)(*(a - b for a, b in zip(self, o)))

    def __rsub__(self, o):
        return type(self)(*(b - a for a, b in zip(self, o)))

    def __neg__(self):
        return type(self)(*(-a for a in self))

    def __mul__(self, s):
        if isinstance(s, _Vector):                         # PlantGL: v * v is the dot product
            return dot(self, s)
        return type(self)(*(a * float(s) for a in self))

    __rmul__ = __mul__

    def __truediv__(self, s):
        return type(self)(*(a / float(s) for a in self))

    def __iadd__(self, o):
        self[:] = self + o
        return self

    def __isub__(self, o):
        self[:] = self - o
        return self

    def __imul__(self, s):
        self[:] = self * s
        return self

    def __abs__(self):
        return norm(self)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{a:g}' for a in self)})"

    def __hash__(self):
        return hash(tuple(self))

    def normalize(self) -> float:
        """Scale to unit length in place; the length before (PlantGL's ``normalize``)."""
        n = norm(self)
        if n > 0:
            self[:] = [a / n for a in self]
        return n

    def normed(self):
        """A unit copy."""
        return direction(self)


class Vector2(_Vector):
    """PlantGL ``Vector2`` (``Vector2.OX``, ``OY``, ``ORIGIN``)."""

    _N = 2


class Vector3(_Vector):
    """PlantGL ``Vector3`` (``Vector3.OX``, ``OY``, ``OZ``, ``ORIGIN``); ``a ^ b`` is the cross product."""

    _N = 3

    def __xor__(self, o):
        return cross(self, o)

    def anOrthogonalVector(self) -> Vector3:
        """A vector orthogonal to this one, as PlantGL picks it (an axis where a coordinate is 0)."""
        x, y, z = self
        if abs(x) < 1e-10:
            return Vector3(1, 0, 0)
        if abs(y) < 1e-10:
            return Vector3(0, 1, 0)
        if abs(z) < 1e-10:
            return Vector3(0, 0, 1)
        n = math.sqrt(x * x + y * y + z * z)
        return Vector3(-y / n, x / n, 0)


class Vector4(_Vector):
    """PlantGL ``Vector4``."""

    _N = 4


class _Constant:
    """A class constant (``Vector3.OX``) given as a fresh vector each time: the vectors are mutable lists."""

    def __init__(self, *v) -> None:
        self.v = v

    def __get__(self, obj, cls):
        return cls(*self.v)


Vector2.OX, Vector2.OY, Vector2.ORIGIN = _Constant(1, 0), _Constant(0, 1), _Constant(0, 0)
Vector3.OX, Vector3.OY, Vector3.OZ, Vector3.ORIGIN = (_Constant(1, 0, 0), _Constant(0, 1, 0), _Constant(0, 0, 1),
                                                      _Constant(0, 0, 0))


def norm(v) -> float:
    """Euclidean length."""
    return float(math.sqrt(sum(float(a) * float(a) for a in v)))


def dot(a, b) -> float:
    """Dot product."""
    return float(sum(float(x) * float(y) for x, y in zip(a, b)))


def cross(a, b) -> Vector3 | float:
    """Cross product of two 3-vectors; of two 2-vectors, PlantGL's scalar ``a.x * b.y - a.y * b.x``."""
    if len(a) == 2 and len(b) == 2:
        return float(a[0]) * float(b[1]) - float(a[1]) * float(b[0])
    return Vector3(*np.cross(np.asarray(a, float)[:3], np.asarray(b, float)[:3]))


def angle(a, b, axis=None) -> float:
    """The angle from ``a`` to ``b`` in radians (PlantGL's ``angle``): signed for 2-vectors; for 3-vectors in
    [0, pi], or, with ``axis``, negative when ``a x b`` points against it."""
    if len(a) == 2 and len(b) == 2:
        return math.atan2(float(a[0]) * float(b[1]) - float(a[1]) * float(b[0]), dot(a, b))
    c = cross(a, b)
    s = norm(c)
    if axis is not None and dot(c, axis) < 0:
        s = -s
    return math.atan2(s, dot(a, b))


class Matrix3:
    """PlantGL's ``Matrix3``: a 3x3 matrix, ``Matrix3.axisRotation(axis, angle)`` (Rodrigues, the axis taken as
    given), ``m * v`` (a Vector3) and ``m * n``."""

    def __init__(self, *values) -> None:
        a = np.eye(3) if not values else np.asarray(values[0] if len(values) == 1 else values, float)
        if a.size != 9 or not np.isfinite(a).all():
            raise ValueError(f"Matrix3 needs 9 finite numbers (or 3 rows of 3), got {values!r:.80}")
        self._m = a.reshape(3, 3)

    @staticmethod
    def axisRotation(axis, angle: float) -> Matrix3:
        x, y, z = (float(v) for v in axis)
        c, s = math.cos(float(angle)), math.sin(float(angle))
        t = 1 - c
        return Matrix3(t * x * x + c, t * x * y - s * z, t * x * z + s * y,
                       t * x * y + s * z, t * y * y + c, t * y * z - s * x,
                       t * x * z - s * y, t * y * z + s * x, t * z * z + c)

    def __mul__(self, o):
        if isinstance(o, Matrix3):
            return Matrix3(self._m @ o._m)
        return Vector3(*(self._m @ np.asarray(o, float)[:3]))

    def transpose(self) -> Matrix3:
        return Matrix3(self._m.T)

    def __getitem__(self, ij):
        return float(self._m[ij])

    def __repr__(self) -> str:
        return "Matrix3(" + ", ".join(f"{v:g}" for v in self._m.ravel()) + ")"


def direction(v):
    """``v`` scaled to unit length (a zero vector stays zero)."""
    n = norm(v)
    out = (type(v) if isinstance(v, _Vector) else Vector3)(*v)
    return out / n if n > 0 else out

"""PlantGL's scene graph, the part L-Py grammars read (issue 33): shapes, primitives and transforms.

What a hook ``End(lstring, lscene)`` is handed (:mod:`plantvr.lsystem.scene` builds it from PlantVR's turtle)
and what ``from openalea.plantgl.all import *`` gives a trusted grammar: :class:`Scene` (a list of
:class:`Shape`, ``todict()`` by id), the primitives the turtle draws (:class:`Cylinder`, :class:`Frustum`,
:class:`Cone`, :class:`Sphere`, :class:`Disc`, :class:`Box`, :class:`Polyline`, the meshes
:class:`TriangleSet` / :class:`FaceSet`, :class:`Extrusion`) and the transforms that place them
(:class:`Translated`, :class:`Oriented`, :class:`Scaled`, :class:`AxisRotated`). They are records: they hold
PlantGL's fields under PlantGL's names (``shape.geometry.translation``, ``cone.radius``) and class tree
(``Cylinder`` and ``Frustum`` are ``Cone``\\ s, the sets are ``Mesh``\\ es), and draw nothing themselves.

References
----------
.. [1] PlantGL ``src/cpp/plantgl/scenegraph/geometry/{cone,cylinder,frustum,sphere,disc,polyline,triangleset,
   extrusion}.h`` (constructors and defaults), ``transformation/{translated,oriented,scaled,axisrotated}.h``,
   ``scene/scene.h`` (``todict``), ``scene/shape.h`` (``id``, ``parentId``).
"""
from __future__ import annotations

from .pglmath import Vector3

__all__ = ["AxisRotated", "Box", "Cone", "Cylinder", "Disc", "Extrusion", "FaceSet", "Frustum", "Mesh",
           "Oriented", "PointSet", "Polyline", "Scaled", "Scene", "Shape", "Sphere", "Translated", "TriangleSet"]


class _Geometry:
    """A scene-graph node: its fields as attributes, shown by ``repr``."""

    _FIELDS: tuple[str, ...] = ()

    def __init__(self, *args, **kw) -> None:
        if len(args) > len(self._FIELDS):
            raise TypeError(f"{type(self).__name__} takes at most {len(self._FIELDS)} arguments, got {len(args)}")
        unknown = set(kw) - set(self._FIELDS) - {"name"}
        if unknown:
            raise TypeError(f"{type(self).__name__}: unknown argument(s) {sorted(unknown)}")
        vals = {**self._defaults(), **dict(zip(self._FIELDS, args)), **kw}
        self.name = str(vals.pop("name", ""))
        for k in self._FIELDS:
            setattr(self, k, vals[k])

    def _defaults(self) -> dict:
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={getattr(self, k)!r}' for k in self._FIELDS)})"


class Cone(_Geometry):
    """``Cone(radius=0.5, height=1, solid=True, slices=8)``: base at the origin, apex on +z."""

    _FIELDS = ("radius", "height", "solid", "slices")

    def _defaults(self) -> dict:
        return {"radius": 0.5, "height": 1.0, "solid": True, "slices": 8}


class Cylinder(Cone):
    """``Cylinder(radius=0.5, height=1, solid=True, slices=8)`` along +z (a ``Cone`` in PlantGL's tree)."""


class Frustum(Cone):
    """``Frustum(radius=0.5, height=1, taper=0.5, solid=True, slices=8)``: top radius ``radius * taper``."""

    _FIELDS = ("radius", "height", "taper", "solid", "slices")

    def _defaults(self) -> dict:
        return {"radius": 0.5, "height": 1.0, "taper": 0.5, "solid": True, "slices": 8}


class Sphere(_Geometry):
    """``Sphere(radius=0.5, slices=8, stacks=8)`` at the origin."""

    _FIELDS = ("radius", "slices", "stacks")

    def _defaults(self) -> dict:
        return {"radius": 0.5, "slices": 8, "stacks": 8}


class Disc(_Geometry):
    """``Disc(radius=0.5, slices=8)`` in the xy plane."""

    _FIELDS = ("radius", "slices")

    def _defaults(self) -> dict:
        return {"radius": 0.5, "slices": 8}


class Box(_Geometry):
    """``Box(size=(0.5, 0.5, 0.5))`` or ``Box(x, y, z)``: half-extents, centred at the origin."""

    _FIELDS = ("size",)

    def __init__(self, *args, **kw) -> None:
        if len(args) == 3:                       # PlantGL's Box(x, y, z)
            args = (Vector3(*args),)
        super().__init__(*args, **kw)

    def _defaults(self) -> dict:
        return {"size": Vector3(0.5, 0.5, 0.5)}


class Polyline(_Geometry):
    """``Polyline(pointList)``: points in world coordinates (PlantGL draws a zero-width segment so)."""

    _FIELDS = ("pointList",)

    def _defaults(self) -> dict:
        return {"pointList": []}


class PointSet(_Geometry):
    """``PointSet(pointList, colorList=None, width=None)``: points (PlantGL draws them as dots; no mesh)."""

    _FIELDS = ("pointList", "colorList", "width")

    def _defaults(self) -> dict:
        return {"pointList": [], "colorList": None, "width": None}


class Mesh(_Geometry):
    """An indexed face set: ``pointList`` and ``indexList``."""

    _FIELDS = ("pointList", "indexList")

    def _defaults(self) -> dict:
        return {"pointList": [], "indexList": []}


class TriangleSet(Mesh):
    """``TriangleSet(pointList, indexList)``: triangles (a polygon's fan, a named surface)."""


class FaceSet(Mesh):
    """``FaceSet(pointList, indexList)``: faces of any size (PlantGL's concave polygon)."""


class Extrusion(_Geometry):
    """``Extrusion(axis, crossSection=None, scale=None)``: a generalized cylinder (``@Gc`` ... ``@Ge``) along the
    ``Polyline`` ``axis``, the cross section scaled by ``scale[k]`` = (r, r) at point ``k``."""

    _FIELDS = ("axis", "crossSection", "scale")

    def _defaults(self) -> dict:
        return {"axis": None, "crossSection": None, "scale": None}


class Translated(_Geometry):
    """``Translated(translation, geometry)``."""

    _FIELDS = ("translation", "geometry")

    def __init__(self, translation=(0.0, 0.0, 0.0), geometry=None, **kw) -> None:
        super().__init__(Vector3(translation), geometry, **kw)


class Oriented(_Geometry):
    """``Oriented(primary, secondary, geometry)``: the local x axis along ``primary``, y along ``secondary``."""

    _FIELDS = ("primary", "secondary", "geometry")

    def __init__(self, primary=(1.0, 0.0, 0.0), secondary=(0.0, 1.0, 0.0), geometry=None, **kw) -> None:
        super().__init__(Vector3(primary), Vector3(secondary), geometry, **kw)


class Scaled(_Geometry):
    """``Scaled(scale, geometry)``; a number scales all three axes."""

    _FIELDS = ("scale", "geometry")

    def __init__(self, scale=(1.0, 1.0, 1.0), geometry=None, **kw) -> None:
        s = (scale,) * 3 if isinstance(scale, (int, float)) else scale
        super().__init__(Vector3(s), geometry, **kw)


class AxisRotated(_Geometry):
    """``AxisRotated(axis, angle, geometry)``: a rotation by ``angle`` radians about ``axis``."""

    _FIELDS = ("axis", "angle", "geometry")

    def __init__(self, axis=(0.0, 0.0, 1.0), angle=0.0, geometry=None, **kw) -> None:
        super().__init__(Vector3(axis), float(angle), geometry, **kw)


class Shape:
    """``Shape(geometry, appearance=None, id=-1, parentId=-1)``: a geometry, its material and the index of the
    module that drew it (L-Py's turtle id)."""

    def __init__(self, geometry=None, appearance=None, id: int = -1, parentId: int = -1) -> None:  # noqa: A002
        self.geometry, self.appearance, self.id, self.parentId = geometry, appearance, int(id), int(parentId)
        self.name = ""

    def __repr__(self) -> str:
        return f"Shape({self.geometry!r}, {self.appearance!r}, id={self.id})"


class Scene(list):
    """``Scene(shapes)``: a list of :class:`Shape` in drawing order; ``add``, ``todict`` as PlantGL's."""

    def add(self, shape) -> None:
        self.append(shape)

    def todict(self) -> dict[int, list]:
        """``{id: [shapes with that id]}``, in drawing order."""
        out: dict[int, list] = {}
        for sh in self:
            out.setdefault(sh.id, []).append(sh)
        return out

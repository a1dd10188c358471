"""Skeletal primitives, affine transforms and the BlobTree (spec 003_implicit_sca §2.2, §2.4; C-2, C-3).

Every node evaluates a field that increases inward (inside is ``F > 0.5``) on an ``(N, 3)`` array of points and
carries an axis-aligned bounding box of its support (``F != 0`` only inside it); evaluation skips every node
outside its box. Affine transforms are pushed down to the leaves, so a deep summation blend of point and
segment primitives is evaluated by one numba kernel.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_choice, check_point, check_points, check_range

from . import _kernels
from .fields import ISO, wyvill_from_sq

__all__ = [
    "Node", "Primitive", "PointSkeleton", "SegmentSkeleton", "CircleSkeleton", "PolylineSkeleton",
    "Blend", "Union", "Intersection", "Difference", "Difference2", "TransformNode",
    "sphere", "segment", "torus", "polyline", "box_transform",
    "scale_matrix", "translate_matrix", "rotate_matrix",
]

BACKENDS = ("numba", "numpy")

#: Smallest radius of influence / length a primitive accepts: ``R**2`` stays a normal float, so the field
#: kernels never divide by zero (issue 20).
MIN_RADIUS = 1e-9
#: Largest magnitude of one scale factor (``scale s sx sy sz``), and of any coordinate of a node's support box.
MAX_SCALE = 1e9
MAX_BOX = 1e9


def _check_box(owner: str, box: np.ndarray) -> np.ndarray:
    """Refuse a support box that is not finite or reaches past ``±MAX_BOX`` (a runaway scale or radius)."""
    if not np.all(np.isfinite(box)) or np.abs(box).max() > MAX_BOX:
        raise ValueError(f"{owner} has a support box outside [-{MAX_BOX:g}, {MAX_BOX:g}] "
                         f"(got {np.asarray(box).tolist()}): scale or radius too large")
    return box


def box_transform(bbox: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """Conservative axis-aligned box of an affinely transformed box (its 8 corners mapped).

    Parameters
    ----------
    bbox : (2, 3) float64 ndarray
        ``[lo, hi]``.
    matrix : (4, 4) float64 ndarray
        Affine map.

    Returns
    -------
    (2, 3) float64 ndarray
        Box of the mapped corners.
    """
    lo, hi = bbox
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    mapped = corners @ matrix[:3, :3].T + matrix[:3, 3]
    return np.array([mapped.min(axis=0), mapped.max(axis=0)])


def scale_matrix(sx: float, sy: float, sz: float) -> np.ndarray:
    """4x4 non-uniform scale about the origin (factors must be non-zero)."""
    out = []
    for name, v in (("sx", sx), ("sy", sy), ("sz", sz)):
        f = check_range(name, v, -MAX_SCALE, MAX_SCALE)
        if abs(f) < 1.0 / MAX_SCALE:
            raise ValueError(f"{name} must be a non-zero number with {1.0 / MAX_SCALE:g} <= |{name}| <= "
                             f"{MAX_SCALE:g}, got {v!r}")
        out.append(f)
    return np.diag([*out, 1.0])


def translate_matrix(offset) -> np.ndarray:
    """4x4 translation by ``offset`` (3,)."""
    m = np.eye(4)
    m[:3, 3] = check_point("offset", offset)
    return m


def rotate_matrix(axis, angle_deg: float) -> np.ndarray:
    """4x4 rotation by ``angle_deg`` degrees about ``axis`` (3,) through the origin (Rodrigues)."""
    axis = check_point("axis", axis)
    n = np.linalg.norm(axis)
    if n == 0.0:
        raise ValueError("axis must be a non-zero vector, got (0, 0, 0)")
    k = axis / n
    a = np.deg2rad(check_range("angle_deg", angle_deg, -1e6, 1e6))
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + np.sin(a) * kx + (1 - np.cos(a)) * (kx @ kx)
    return m


def _check_matrix(matrix) -> np.ndarray:
    """A finite, invertible (4, 4) affine matrix with entries inside ``±MAX_SCALE``."""
    m = check_array("matrix", matrix, shape=(4, 4), max_abs=MAX_SCALE)
    if abs(np.linalg.det(m[:3, :3])) < 1e-300:
        raise ValueError("matrix must be invertible (its 3x3 part has zero determinant)")
    return m


class Node:
    """Base class of BlobTree nodes: ``field(points)`` and a support bounding box ``bbox`` (2, 3)."""

    bbox: np.ndarray

    def field(self, points, *, backend: str = "numba") -> np.ndarray:
        """Field values at ``points``.

        Parameters
        ----------
        points : (N, 3) float64 array_like
            Query points, in scene units.
        backend : {"numba", "numpy"}
            Kernel used for packed point/segment blends (the numpy twin gives the same values).

        Returns
        -------
        (N,) float64 ndarray
            Field values; inside is ``F > 0.5``.
        """
        p = check_points("points", points)
        check_choice("backend", backend, BACKENDS)
        return self._eval(p, backend)

    def inside(self, points, *, iso: float = ISO) -> np.ndarray:
        """Boolean mask ``F(points) > iso`` (spec §2.1 sign convention)."""
        iso = check_range("iso", iso, 0.0, np.inf, low_open=True)
        return self.field(points) > iso

    def _eval(self, p: np.ndarray, backend: str) -> np.ndarray:
        lo, hi = self.bbox
        out = np.zeros(len(p))
        if np.any(lo > hi) or len(p) == 0:
            return out
        m = np.all((p >= lo) & (p <= hi), axis=1)
        if m.all():
            return self._eval_inside(p, backend)
        if m.any():
            out[m] = self._eval_inside(p[m], backend)
        return out

    def _eval_inside(self, p: np.ndarray, backend: str) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def transformed(self, matrix) -> "Node":
        """Return this node under the affine map ``matrix`` (4, 4): ``F'(p) = F(M^-1 p)``."""
        m = _check_matrix(matrix)
        return self._transformed(m)

    def _transformed(self, m: np.ndarray) -> "Node":
        return TransformNode(self, m)

    def scaled(self, sx: float, sy: float, sz: float) -> "Node":
        """Scaled copy about the origin (command ``scale s sx sy sz``)."""
        return self.transformed(scale_matrix(sx, sy, sz))

    def translated(self, offset) -> "Node":
        """Translated copy (command ``translate s x y z``)."""
        return self.transformed(translate_matrix(offset))

    def rotated(self, axis, angle_deg: float) -> "Node":
        """Rotated copy about ``axis`` through the origin (command ``rotate s ax ay az deg``)."""
        return self.transformed(rotate_matrix(axis, angle_deg))

    def primitives(self) -> list:
        """All leaf nodes below this one (depth-first)."""
        return [self]


# --------------------------------------------------------------------------------------------- skeletons
class PointSkeleton:
    """Point skeleton at ``center`` (gives a sphere of radius R/2)."""

    def __init__(self, center=(0.0, 0.0, 0.0)):
        self.center = check_point("center", center)

    def distance_sq(self, q):
        d = q - self.center
        return np.einsum("ij,ij->i", d, d)

    def local_bbox(self):
        return np.array([self.center, self.center])

    def segment(self):
        return self.center, self.center


class SegmentSkeleton:
    """Line-segment skeleton from ``a`` to ``b`` (gives a capsule)."""

    def __init__(self, a, b):
        self.a, self.b = check_point("a", a), check_point("b", b)

    def distance_sq(self, q):
        e = self.b - self.a
        d = q - self.a
        ee = float(e @ e)
        t = np.clip(d @ e / ee, 0.0, 1.0) if ee > 0 else np.zeros(len(q))
        r = d - t[:, None] * e
        return np.einsum("ij,ij->i", r, r)

    def local_bbox(self):
        return np.array([np.minimum(self.a, self.b), np.maximum(self.a, self.b)])

    def segment(self):
        return self.a, self.b


class CircleSkeleton:
    """Circle skeleton (centre, unit normal, radius rho) giving a torus."""

    def __init__(self, center=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), rho: float = 1.0):
        self.center = check_point("center", center)
        n = check_point("normal", normal)
        if np.linalg.norm(n) == 0:
            raise ValueError("normal must be a non-zero vector, got (0, 0, 0)")
        self.normal = n / np.linalg.norm(n)
        self.rho = check_range("rho", rho, MIN_RADIUS, MAX_COORD)

    def distance_sq(self, q):
        d = q - self.center
        h = d @ self.normal
        inplane = d - h[:, None] * self.normal
        rad = np.sqrt(np.einsum("ij,ij->i", inplane, inplane))
        return (rad - self.rho) ** 2 + h**2

    def local_bbox(self):
        ext = self.rho * np.sqrt(np.clip(1.0 - self.normal**2, 0.0, 1.0))
        return np.array([self.center - ext, self.center + ext])


class PolylineSkeleton:
    """Polyline skeleton (M >= 2 vertices); distance is the minimum over its segments."""

    def __init__(self, vertices):
        self.vertices = check_points("vertices", vertices, min_rows=2)
        if len(self.vertices) > MAX_POLYLINE:
            raise ValueError(f"vertices must have at most {MAX_POLYLINE} rows, got {len(self.vertices)}")

    def distance_sq(self, q):
        best = np.full(len(q), np.inf)
        for a, b in zip(self.vertices[:-1], self.vertices[1:]):
            best = np.minimum(best, SegmentSkeleton(a, b).distance_sq(q))
        return best

    def local_bbox(self):
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])


#: Most vertices of one polyline skeleton (its distance is a Python loop over segments).
MAX_POLYLINE = 100_000


class Primitive(Node):
    """Distance-surface primitive ``F(p) = f_Wyvill(d(M^-1 p))`` (Eq. 3.2) with radius of influence R.

    Parameters
    ----------
    skeleton : PointSkeleton | SegmentSkeleton | CircleSkeleton | PolylineSkeleton
        The skeletal element.
    radius : float
        Radius of influence R > 0; the surface lies at distance R/2.
    matrix : (4, 4) float64 ndarray, optional
        Affine placement ``M`` (world = M local); identity by default.

    References
    ----------
    .. [1] Kochhar 2010, §3.2, Eq. 3.2; spec 003 §2.2 (transforms evaluated as f(d(M^-1 p))).
    """

    def __init__(self, skeleton, radius: float = 1.0, matrix=None):
        self.skeleton = skeleton
        if not isinstance(skeleton, (PointSkeleton, SegmentSkeleton, CircleSkeleton, PolylineSkeleton)):
            raise ValueError(f"skeleton must be a Point/Segment/Circle/PolylineSkeleton, got {type(skeleton).__name__}")
        self.skeleton = skeleton
        self.radius = check_range("radius", radius, MIN_RADIUS, MAX_COORD)
        self.matrix = np.eye(4) if matrix is None else _check_matrix(matrix)
        self.minv = np.linalg.inv(self.matrix)
        lo, hi = skeleton.local_bbox()
        self.bbox = _check_box("Primitive", box_transform(np.array([lo - self.radius, hi + self.radius]),
                                                          self.matrix))

    @property
    def packable(self) -> bool:
        return isinstance(self.skeleton, (PointSkeleton, SegmentSkeleton))

    def _eval_inside(self, p, backend):
        if self.packable:
            a, b = self.skeleton.segment()
            fn = _kernels.segment_blend_numba if backend == "numba" else _kernels.segment_blend_numpy
            return fn(p, a[None], b[None], np.array([self.radius]), np.ascontiguousarray(self.minv[None, :3]),
                      self.bbox[:1], self.bbox[1:])
        q = p @ self.minv[:3, :3].T + self.minv[:3, 3]
        return wyvill_from_sq(self.skeleton.distance_sq(q) / self.radius**2)

    def _transformed(self, m):
        return Primitive(self.skeleton, self.radius, m @ self.matrix)


def sphere(center=(0.0, 0.0, 0.0), radius: float = 1.0) -> Primitive:
    """Point primitive: a sphere of radius ``radius/2`` (command ``sphere``)."""
    return Primitive(PointSkeleton(center), radius)


def segment(a, b, radius: float = 1.0) -> Primitive:
    """Segment primitive: a capsule (command ``line``)."""
    return Primitive(SegmentSkeleton(a, b), radius)


def torus(center=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), rho: float = 1.0, radius: float = 1.0) -> Primitive:
    """Circle primitive: a torus of major radius ``rho`` and tube radius ``radius/2`` (Fig. 3.1)."""
    return Primitive(CircleSkeleton(center, normal, rho), radius)


def polyline(vertices, radius: float = 1.0) -> Primitive:
    """Polyline primitive (distance to the nearest of its segments)."""
    return Primitive(PolylineSkeleton(vertices), radius)


# --------------------------------------------------------------------------------------------- operators
def _check_nodes(name, nodes, min_count):
    nodes = list(nodes)
    if len(nodes) < min_count:
        raise ValueError(f"{name} needs at least {min_count} operands, got {len(nodes)}")
    for i, n in enumerate(nodes):
        if not isinstance(n, Node):
            raise ValueError(f"{name} operand {i} must be a BlobTree Node, got {type(n).__name__}")
    return nodes


def _union_box(boxes):
    return np.array([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])


class _Nary(Node):
    def __init__(self, *children):
        self.children = _check_nodes(type(self).__name__, children, 1)

    def _transformed(self, m):
        return type(self)(*[c._transformed(m) for c in self.children])

    def primitives(self):
        return [p for c in self.children for p in c.primitives()]


class Blend(_Nary):
    """Summation blend ``F = sum_i F_i`` (thesis §3.3). Point/segment leaves are packed into one kernel call."""

    def __init__(self, *children):
        super().__init__(*children)
        self.bbox = _union_box([c.bbox for c in self.children])
        packed = [c for c in self.children if isinstance(c, Primitive) and c.packable]
        self._others = [c for c in self.children if not (isinstance(c, Primitive) and c.packable)]
        if packed:
            self._pack = (
                np.array([c.skeleton.segment()[0] for c in packed]),
                np.array([c.skeleton.segment()[1] for c in packed]),
                np.array([c.radius for c in packed]),
                np.ascontiguousarray(np.array([c.minv[:3] for c in packed])),
                np.array([c.bbox[0] for c in packed]),
                np.array([c.bbox[1] for c in packed]),
            )
        else:
            self._pack = None

    def _eval_inside(self, p, backend):
        out = np.zeros(len(p))
        if self._pack is not None:
            fn = _kernels.segment_blend_numba if backend == "numba" else _kernels.segment_blend_numpy
            out += fn(p, *self._pack)
        for c in self._others:
            out += c._eval(p, backend)
        return out


class Union(_Nary):
    """CSG union ``F = max_i F_i`` ([EXT 102], spec §2.4)."""

    def __init__(self, *children):
        super().__init__(*children)
        self.bbox = _union_box([c.bbox for c in self.children])

    def _eval_inside(self, p, backend):
        return np.max([c._eval(p, backend) for c in self.children], axis=0)


class Intersection(_Nary):
    """CSG intersection ``F = min_i F_i`` ([EXT 102], spec §2.4); box = intersection of boxes."""

    def __init__(self, *children):
        super().__init__(*children)
        self.bbox = np.array([np.max([c.bbox[0] for c in self.children], axis=0),
                              np.min([c.bbox[1] for c in self.children], axis=0)])

    def _eval_inside(self, p, backend):
        return np.min([c._eval(p, backend) for c in self.children], axis=0)


class Difference(Node):
    """CSG difference A - B: ``F = min(F_A, 2 iso - F_B) = min(F_A, 1 - F_B)`` ([EXT 102]); box = box of A."""

    def __init__(self, a: Node, b: Node):
        self.a, self.b = _check_nodes(type(self).__name__, (a, b), 2)
        self.bbox = self._operands()[0].bbox.copy()

    def _operands(self) -> tuple[Node, Node]:
        """(kept, removed): A - B."""
        return self.a, self.b

    def _eval_inside(self, p, backend):
        kept, removed = self._operands()
        return np.minimum(kept._eval(p, backend), 2 * ISO - removed._eval(p, backend))

    def _transformed(self, m):
        return type(self)(self.a._transformed(m), self.b._transformed(m))

    def primitives(self):
        return self.a.primitives() + self.b.primitives()


class Difference2(Difference):
    """"Difference 2" of the Boolean dialog (Fig. 4.2): the reversed difference B - A (spec §2.4 [INFERRED])."""

    def _operands(self) -> tuple[Node, Node]:
        """(kept, removed): B - A."""
        return self.b, self.a


class TransformNode(Node):
    """Affine transform of a non-affine subtree (warps, skins): ``F(p) = F_child(M^-1 p)``."""

    def __init__(self, child: Node, matrix):
        self.child = _check_nodes("TransformNode", (child,), 1)[0]
        self.matrix = _check_matrix(matrix)
        self.minv = np.linalg.inv(self.matrix)
        self.bbox = _check_box("TransformNode", box_transform(child.bbox, self.matrix))

    def _eval_inside(self, p, backend):
        return self.child._eval(p @ self.minv[:3, :3].T + self.minv[:3, 3], backend)

    def _transformed(self, m):
        return TransformNode(self.child, m @ self.matrix)

    def primitives(self):
        return self.child.primitives()

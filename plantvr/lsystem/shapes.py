"""The turtle's shapes as meshes (issue 33 "a scene, not only a skeleton"; PlantGL ``PglTurtleDrawer``).

The turtle (:func:`plantvr.lsystem.turtle.turtle_nodes`) records, besides the skeleton, every sphere ``@O(r)``,
disc ``@o(r)``, named surface ``~name(scale)``, polygon ``{ . . }`` and generalized cylinder ``@Gc ... @Ge`` with
its frame and colour index. :func:`shape_meshes` turns them into one :class:`ShapeMesh` per material (a
:class:`~plantvr.types.TriMesh` with per-vertex colours), as PlantGL's drawer does:

* a placed shape's local axes are PlantGL's ``Oriented(up, -left)``: local x = U, y = -L, z = H;
* ``@O(r)``: a UV sphere of radius ``r`` (default: the width) with ``slices`` x ``stacks`` cells;
* ``@o(r)``: PlantGL's ``Disc`` turned about y by 90 degrees: a disc in the plane of H and L (normal U),
  ``slices`` triangles around its centre;
* ``~l(s)``: PlantGL's own default leaf (``PglTurtle::defaultValue``): a 7-point, 6-triangle rhombic blade of
  length ``s`` along H and width ``s / 2`` across L; other names come from :data:`SURFACES`
  (:func:`register_surface`);
* ``{ . }``: the points recorded by ``.`` (and by each ``F`` while the polygon is open), the last dropped when it
  repeats the first, filled as PlantGL does: a fan from the first point, or, after ``}(1)`` (PlantGL's concave
  test), ear clipping in the polygon's plane;
* ``@Gc ... @Ge``: a smooth tube through the path points (``@Gc``, each ``F``, ``.``), of the width at each
  point (``_``/``!``/``F(l, r)`` set the last point's radius, PlantGL's ``pushRadius``), a ``slices``-gon cross
  section carried along by parallel transport from the turtle's left vector at the start (PlantGL's
  ``Extrusion`` initial normal); open ends, as PlantGL's extrusion. A branch ``[`` starts its own tube at its
  parent's last point and draws it at ``]``.

Colours are L-Py's material table (:data:`DEFAULT_MATERIALS`, PlantGL's ``Color_0`` .. ``Color_6``, each the
ambient colour times the diffuse factor); an index past the table is PlantGL's default grey.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_int
from plantvr.types import TriMesh

from . import _turtle_kernels as K
from .turtle import _TABLE, TURTLE_MODULES, TurtleShapes

__all__ = ["DEFAULT_MATERIALS", "SURFACES", "ShapeMesh", "box_mesh", "disc_mesh", "leaf_surface", "material_rgb",
           "polygon_faces", "quad_mesh", "register_surface", "shape_meshes", "shape_name", "sphere_mesh", "tube_mesh"]

#: PlantGL's default turtle materials (``PglTurtle::defaultValue``): name, ambient RGB, diffuse factor.
DEFAULT_MATERIALS: tuple[tuple[str, tuple[int, int, int], float], ...] = (
    ("Color_0", (80, 80, 80), 2.0),            # PlantGL's default Material
    ("Color_1", (65, 45, 15), 3.0),            # brown
    ("Color_2", (30, 60, 10), 3.0),            # green
    ("Color_3", (60, 0, 0), 3.0),              # red
    ("Color_4", (60, 60, 15), 3.0),            # yellow
    ("Color_5", (0, 0, 60), 3.0),              # blue
    ("Color_6", (60, 0, 60), 3.0),             # purple
)


def material_rgb(index: int, materials=DEFAULT_MATERIALS) -> np.ndarray:
    """(3,) uint8 diffuse colour of material ``index``: ambient times diffuse, clipped to 255 (PlantGL's
    ``Material::getDiffuseColor``); PlantGL's default grey past the table; the colour itself for a
    ``SetColor(r, g, b)`` code (``K.CUSTOM_COLOR + (r << 16 | g << 8 | b)``)."""
    index = check_int("index", index, 0, 2 ** 62)
    if index >= K.CUSTOM_COLOR:
        code = index - K.CUSTOM_COLOR
        return np.array([(code >> 16) & 255, (code >> 8) & 255, code & 255], np.uint8)
    _, ambient, diffuse = materials[index] if index < len(materials) else DEFAULT_MATERIALS[0]
    return np.clip(np.round(np.asarray(ambient, float) * diffuse), 0, 255).astype(np.uint8)


def leaf_surface() -> tuple[np.ndarray, np.ndarray]:
    """PlantGL's default ``l`` surface: (7, 3) local vertices (x = U, y = -L, z = H) and (6, 3) faces."""
    v = np.array([[0, 0, 0.5], [0, 0, 0], [0, -0.25, 1 / 3], [0, -0.25, 2 / 3], [0, 0, 1], [0, 0.25, 2 / 3],
                  [0, 0.25, 1 / 3]], float)
    f = np.array([[0, 2, 1], [0, 3, 2], [0, 4, 3], [0, 5, 4], [0, 6, 5], [0, 1, 6]], np.int64)
    return v, f


#: Named surfaces ``~name`` draws: ``{name: (local vertices (V, 3), faces (F, 3))}``, local x = U, y = -L,
#: z = H, scaled by the module's parameter; ``l`` is PlantGL's leaf.
SURFACES: dict[str, tuple[np.ndarray, np.ndarray]] = {"l": leaf_surface()}


def register_surface(name: str, vertices, faces) -> None:
    """Make ``~name(scale)`` draw a mesh (the L-Py editor's surface list).

    Parameters
    ----------
    name : str
        An identifier (letters, digits, ``_``); grammars parsed afterwards read ``~name`` as one module.
    vertices : (V, 3) float array
        In the turtle's local frame: x along U, y along -L (right), z along H, for scale 1.
    faces : (F, 3) int array
        Triangles indexing ``vertices``.
    """
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"name must be an identifier, got {name!r:.60}")
    mesh = TriMesh.from_arrays(vertices, faces)
    if not mesh.n_faces:
        raise ValueError("faces must hold at least one triangle, got 0")
    SURFACES[name] = (np.asarray(mesh.vertices, float).copy(), mesh.faces.copy())
    _TABLE["~" + name] = (K.SURFACE, (0, 1))
    TURTLE_MODULES["~" + name] = (0, 1)


def shape_name(index: int) -> str:
    """The scene name of a material's shapes: ``"shapes 2"``, or ``"shapes #ff0000"`` for ``SetColor(255, 0, 0)``."""
    index = int(index)
    return f"shapes #{index - K.CUSTOM_COLOR:06x}" if index >= K.CUSTOM_COLOR else f"shapes {index}"


@dataclass(eq=False)
class ShapeMesh(TriMesh):
    """The turtle's shapes of one material, merged.

    Attributes
    ----------
    colors : (V, 3) uint8 ndarray
        The material's colour at every vertex (what :class:`plantvr.View` and the glTF / PLY writers read).
    material : int
        L-Py colour index.
    """

    colors: np.ndarray = None
    material: int = 0


def sphere_mesh(slices: int = 16, stacks: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Unit UV sphere about +z: ``2 + slices * (stacks - 1)`` vertices, ``2 * slices * (stacks - 1)`` faces
    (outward, counter-clockwise)."""
    slices, stacks = check_int("slices", slices, 3, 1024), check_int("stacks", stacks, 2, 1024)
    th = np.pi * np.arange(1, stacks) / stacks
    ph = 2 * np.pi * np.arange(slices) / slices
    ring = np.stack([np.outer(np.sin(th), np.cos(ph)), np.outer(np.sin(th), np.sin(ph)),
                     np.repeat(np.cos(th)[:, None], slices, 1)], -1).reshape(-1, 3)
    v = np.vstack([[0, 0, 1.0], ring, [0, 0, -1.0]])
    j = np.arange(slices)
    jn = (j + 1) % slices
    south = len(v) - 1
    faces = [np.column_stack([np.zeros(slices, np.int64), 1 + j, 1 + jn])]
    for k in range(stacks - 2):
        u, lo = 1 + k * slices, 1 + (k + 1) * slices
        faces += [np.column_stack([u + j, lo + j, lo + jn]), np.column_stack([u + j, lo + jn, u + jn])]
    last = 1 + (stacks - 2) * slices
    faces.append(np.column_stack([np.full(slices, south), last + jn, last + j]))
    return v, np.vstack(faces).astype(np.int64)


def disc_mesh(slices: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Unit disc in the local y-z plane (PlantGL's ``AxisRotated(OY, pi/2, Disc)``), normal +x:
    ``slices + 1`` vertices, ``slices`` faces."""
    slices = check_int("slices", slices, 3, 1024)
    a = 2 * np.pi * np.arange(slices) / slices
    v = np.vstack([[0, 0, 0.0], np.column_stack([np.zeros(slices), -np.sin(a), np.cos(a)])])
    j = np.arange(slices)
    return v, np.column_stack([np.zeros(slices, np.int64), 1 + j, 1 + (j + 1) % slices]).astype(np.int64)


def _plane_coords(p: np.ndarray) -> np.ndarray:
    """(n, 2) coordinates of polygon points in its plane (Newell normal), counter-clockwise about it."""
    nrm = np.cross(p, np.roll(p, -1, axis=0)).sum(0)
    ln = np.linalg.norm(nrm)
    if ln < K.EPS:
        nrm, ln = np.array([0.0, 0, 1]), 1.0
    nrm = nrm / ln
    a = np.cross(nrm, [1.0, 0, 0]) if abs(nrm[0]) < 0.9 else np.cross(nrm, [0, 1.0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(nrm, a)
    q = p - p[0]
    return np.column_stack([q @ a, q @ b])


def polygon_faces(points, *, concave: bool = False) -> np.ndarray:
    """Triangles filling a polygon of ``n`` points: ``n - 2`` of them.

    PlantGL's ``PglTurtleDrawer::polygon``: a fan ``(0, i + 1, i + 2)`` by default; with ``concave`` (L-Py's
    ``}(True)``) ear clipping in the polygon's plane, so a concave outline is filled inside only.

    Parameters
    ----------
    points : (n, 3) float array
        The outline, n >= 3 (a repeated first point already dropped).
    concave : bool
        Ear clipping instead of the fan.

    Returns
    -------
    (n - 2, 3) int64 ndarray
    """
    p = check_array("points", points, shape=(None, 3), max_abs=MAX_COORD)
    n = len(p)
    if n < 3:
        raise ValueError(f"points must hold at least 3 points, got {n}")
    if not concave:
        i = np.arange(n - 2)
        return np.column_stack([np.zeros(n - 2, np.int64), i + 1, i + 2])
    q = _plane_coords(p)
    idx = list(range(n))
    out = []

    def cross(o, a, b):
        return (q[a, 0] - q[o, 0]) * (q[b, 1] - q[o, 1]) - (q[a, 1] - q[o, 1]) * (q[b, 0] - q[o, 0])

    guard = 0
    while len(idx) > 3 and guard < 4 * n * n:
        guard += 1
        m = len(idx)
        for k in range(m):
            a, b, c = idx[k - 1], idx[k], idx[(k + 1) % m]
            if cross(a, b, c) <= 1e-14:
                continue                                   # reflex (or flat) corner
            inside = False
            for r in idx:
                if r in (a, b, c):
                    continue
                if cross(a, b, r) >= 0 and cross(b, c, r) >= 0 and cross(c, a, r) >= 0:
                    inside = True
                    break
            if not inside:
                out.append((a, b, c))
                idx.pop(k)
                break
        else:                                              # no ear (degenerate outline): fan the rest
            out += [(idx[0], idx[i], idx[i + 1]) for i in range(1, len(idx) - 1)]
            idx = idx[:0]
    if len(idx) == 3:
        out.append(tuple(idx))
    return np.array(out, np.int64).reshape(-1, 3)


def tube_mesh(points, radius, left, *, slices: int = 16, contour=None) -> tuple[np.ndarray, np.ndarray]:
    """A smooth open tube through ``points`` (generalized cylinder), of a circular cross section or ``contour``.

    Parameters
    ----------
    points : (n, 3) float array
        The path, n >= 2 consecutive distinct points (closer than 1e-6 are merged).
    radius : (n,) float array
        Radius at each point.
    left : (3,) float array
        The turtle's left vector at the start: the cross section's first direction (PlantGL's initial normal).
    slices : int
        Cross-section sides of a circle.
    contour : (m, 2) float array, optional
        The cross section (PlantGL's ``SetContour``): its x along the section's first direction, y along the
        second, scaled by the radius; a closed one (first point = last) makes a tube, faces outward whichever
        way it turns, an open one (a leaf profile) a sheet.

    Returns
    -------
    vertices : (n * m, 3) float64 ndarray
    faces : (2 * m * (n - 1), 3) int64 ndarray (m - 1 for an open contour; m: the section points)
        Outward, counter-clockwise.
    """
    slices = check_int("slices", slices, 3, 1024)
    p = check_array("points", points, shape=(None, 3), max_abs=MAX_COORD)
    r = check_array("radius", radius, shape=(len(p),), max_abs=MAX_COORD)
    keep = np.ones(len(p), bool)
    keep[1:] = np.linalg.norm(np.diff(p, axis=0), axis=1) > K.EPS
    p, r = p[keep], r[keep]
    n = len(p)
    if n < 2:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    seg = np.diff(p, axis=0)
    seg /= np.linalg.norm(seg, axis=1, keepdims=True)
    t = np.vstack([seg[:1], seg[:-1] + seg[1:], seg[-1:]])
    tl = np.linalg.norm(t, axis=1, keepdims=True)
    t = np.where(tl > K.EPS, t / np.where(tl > K.EPS, tl, 1), np.vstack([seg, seg[-1:]]))
    nrm = np.zeros((n, 3))
    v0 = np.asarray(left, float) - np.dot(left, t[0]) * t[0]
    if np.linalg.norm(v0) < K.EPS:
        v0 = np.cross(t[0], [1.0, 0, 0] if abs(t[0][0]) < 0.9 else [0, 1.0, 0])
    nrm[0] = v0 / np.linalg.norm(v0)
    for k in range(1, n):                                  # parallel transport (rotation taking t[k-1] to t[k])
        axis = np.cross(t[k - 1], t[k])
        s, c = np.linalg.norm(axis), float(np.dot(t[k - 1], t[k]))
        v = nrm[k - 1]
        if s > 1e-12:
            axis /= s
            v = v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1 - c)
        v = v - np.dot(v, t[k]) * t[k]
        nrm[k] = v / np.linalg.norm(v)
    bin_ = np.cross(t, nrm)
    closed = True
    if contour is None:
        a = 2 * np.pi * np.arange(slices) / slices
        cx, cy = np.cos(a), np.sin(a)
    else:
        cs = check_array("contour", contour, shape=(None, 2), min_rows=2, max_abs=MAX_COORD)
        closed = len(cs) > 2 and np.linalg.norm(cs[0] - cs[-1]) < K.EPS
        if closed:
            cs = cs[:-1]
            x, y = cs[:, 0], cs[:, 1]
            if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:   # clockwise: faces would look in
                cs = cs[::-1]
        cx, cy = cs[:, 0], cs[:, 1]
    m = len(cx)
    ring = cx[None, :, None] * nrm[:, None] + cy[None, :, None] * bin_[:, None]
    verts = (p[:, None] + r[:, None, None] * ring).reshape(-1, 3)
    k, j = np.meshgrid(np.arange(n - 1), np.arange(m if closed else m - 1), indexing="ij")
    a0, b0 = k * m + j, k * m + (j + 1) % m
    c0, d0 = a0 + m, b0 + m
    faces = np.stack([np.stack([a0, b0, d0], -1), np.stack([a0, d0, c0], -1)], 2).reshape(-1, 3)
    return verts, faces.astype(np.int64)


def _place(frame: np.ndarray, size: np.ndarray, local: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
    """(S, V, 3) world vertices of a local template placed at each frame (x = U, y = -L, z = H), scaled (per local
    axis by ``scale`` (S, 3) if given)."""
    pos, h, lft, up = frame[:, 0], frame[:, 1], frame[:, 2], frame[:, 3]
    axes = np.stack([up, -lft, h], 1)                      # (S, 3 local axes, 3)
    out = np.matmul(local[None] if scale is None else local[None] * scale[:, None, :], axes)   # (S, V, 3)
    out *= size[:, None, None]
    out += pos[:, None]
    return out


#: A box's faces (outward) on its corners ``bottom (-x -y, +x -y, +x +y, -x +y), then top`` in the local frame
#: x = U, y = -L, z = H.
_BOX_FACES = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5],
                       [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]], np.int64)


def box_mesh(frame, length: float, bottom: float, top: float) -> tuple[np.ndarray, np.ndarray]:
    """PlantGL's turtle box (``PglTurtleDrawer::box``): a square section of half-width ``bottom`` at the frame's
    position, ``top`` at ``length`` along H, tapered between (PlantGL ``Tapered`` of a ``Box``).

    Parameters
    ----------
    frame : (4, 3) float array
        Position, H, L, U.
    length, bottom, top : float
        Length along H and the half-widths (PlantGL: the width and the top width).

    Returns
    -------
    (8, 3) vertices and (12, 3) outward faces; no faces when both half-widths are 0 (PlantGL draws a line).
    """
    p, h, left, u = np.asarray(frame, float)
    sq = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    v = np.concatenate([p + r * (sq[:, :1] * u - sq[:, 1:] * left) + z * h
                        for r, z in ((bottom, 0.0), (top, length))])
    if bottom < K.EPS and top < K.EPS:
        return v, np.zeros((0, 3), np.int64)
    return v, _BOX_FACES.copy()


def quad_mesh(frame, length: float, bottom: float, top: float) -> tuple[np.ndarray, np.ndarray]:
    """PlantGL's turtle quad (``PglTurtleDrawer::quad``): ``position +- L bottom`` and ``top position -+ L top``
    (a triangle where a half-width is 0, nothing where both are: PlantGL draws a line).

    Returns
    -------
    (V, 3) vertices and (F, 3) faces.
    """
    p, h, left, _ = np.asarray(frame, float)
    q = p + h * length
    pts = [p] if bottom < K.EPS else [p + left * bottom, p - left * bottom]
    pts += [q] if top < K.EPS else [q - left * top, q + left * top]
    v = np.array(pts, float)
    if len(v) == 2:
        return v, np.zeros((0, 3), np.int64)
    return v, np.array([[0, 1, 2]] if len(v) == 3 else [[0, 1, 2], [0, 2, 3]], np.int64)


def shape_meshes(shapes, *, materials=DEFAULT_MATERIALS, slices: int = 16,
                 stacks: int = 8) -> dict[int, ShapeMesh]:
    """The turtle's shapes as one merged mesh per material (see the module docstring).

    Parameters
    ----------
    shapes : TurtleShapes
        ``turtle_nodes(string).shapes``.
    materials : sequence of (name, (r, g, b) ambient, diffuse)
        The colour table (default L-Py's, :data:`DEFAULT_MATERIALS`).
    slices, stacks : int
        Resolution of spheres (``slices`` around, ``stacks`` pole to pole), discs and tube cross sections.

    Returns
    -------
    dict of int to ShapeMesh
        Keyed by colour index, ascending; empty without shapes. Within a material the parts come in the order
        spheres, discs, surfaces, polygons, tubes, boxes and quads, each in string order.

    Raises
    ------
    ValueError
        For a surface name missing from :data:`SURFACES`, or a bad resolution.
    """
    if not isinstance(shapes, TurtleShapes):
        raise ValueError(f"shapes must be TurtleShapes, got {type(shapes).__name__}")  # noqa: TRY004
    slices, stacks = check_int("slices", slices, 3, 1024), check_int("stacks", stacks, 2, 1024)
    missing = sorted({s for s in shapes.surface if s and s not in SURFACES})
    if missing:
        raise ValueError(f"shapes: unknown surface(s) {missing}; known: {sorted(SURFACES)} (register_surface)")
    parts: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}

    def add(col, v, f):
        parts.setdefault(int(col), []).append((v, f))

    kind = shapes.kind
    surf = np.array(shapes.surface, dtype=object) if len(shapes) else np.zeros(0, object)
    placed = [(K.SH_SPHERE, "", sphere_mesh(slices, stacks)), (K.SH_CIRCLE, "", disc_mesh(slices))]
    placed += [(K.SH_SURFACE, name, SURFACES[name]) for name in dict.fromkeys(shapes.surface) if name]
    for kd, name, (tv, tf) in placed:                      # one block per kind, surface and colour
        is_kind = (kind == kd) & (surf == name) if name else kind == kd
        for col in np.unique(shapes.color[is_kind]):
            sel = np.flatnonzero(is_kind & (shapes.color == col))
            verts = _place(shapes.frame[sel], shapes.size[sel], tv,
                           None if shapes.scale is None else shapes.scale[sel]).reshape(-1, 3)
            faces = (tf[None] + (np.arange(len(sel)) * len(tv))[:, None, None]).reshape(-1, 3)
            add(col, verts, faces)
    for s in np.flatnonzero((kind == K.SH_POLYGON) | (kind == K.SH_POLYGON_CONCAVE)):
        p = shapes.points[shapes.start[s]:shapes.start[s] + shapes.count[s]]
        if np.linalg.norm(p[0] - p[-1]) < K.EPS:
            p = p[:-1]
        if len(p) > 2:
            add(shapes.color[s], p, polygon_faces(p, concave=bool(kind[s] == K.SH_POLYGON_CONCAVE)))
    for s in np.flatnonzero(kind == K.SH_TUBE):
        a, b = shapes.start[s], shapes.start[s] + shapes.count[s]
        v, f = tube_mesh(shapes.points[a:b], shapes.radius[a:b], shapes.left[a], slices=slices,
                         contour=None if shapes.contour is None else shapes.contour[s])
        if len(f):
            add(shapes.color[s], v, f)
    for s in np.flatnonzero((kind == K.SH_BOX) | (kind == K.SH_QUAD)):
        mesh = box_mesh if kind[s] == K.SH_BOX else quad_mesh
        v, f = mesh(shapes.frame[s], shapes.size[s], *shapes.radii[s])
        if len(f):
            add(shapes.color[s], v, f)
    out: dict[int, ShapeMesh] = {}
    for col in sorted(parts):
        offs = np.cumsum([0] + [len(v) for v, _ in parts[col]])
        v = parts[col][0][0] if len(parts[col]) == 1 else np.concatenate([v for v, _ in parts[col]])
        f = parts[col][0][1] if len(parts[col]) == 1 else np.concatenate(
            [f + o for (_, f), o in zip(parts[col], offs)])
        colors = np.empty((len(v), 3), np.uint8)
        colors[:] = material_rgb(col, materials)
        out[col] = ShapeMesh(v, f, colors=colors, material=col)
    return out

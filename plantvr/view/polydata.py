"""Triangle meshes as ``pyvista.PolyData``: the one mesh → VTK conversion of the view layer (issue 21).

Every actor layer of :class:`plantvr.View`, the billboard renderer and the LOD forest layer turn their meshes into
``PolyData`` here. A mesh is a :class:`plantvr.types.TriMesh` (or anything with ``vertices`` and ``faces``,
e.g. ``trimesh.Trimesh`` or a ``(vertices, faces)`` pair); its optional attributes are carried over:
``normals`` (V, 3) as point normals, ``colors`` (V, 3|4) uint8 as the ``"colors"`` RGB(A) point array, and
``uv`` as texture coordinates, per vertex (V, 2) or per face corner (F, 3, 2): then the corners are split into
their own points, for display only (spec 001_subdivision §1.6: "vertices split at UV seams for display only").

Every other ``PolyData`` of the package is built here too (issue 30): the internode tubes of the prune previews
(:func:`tube_polydata`), the ground and the brush the View and the headset both show (:func:`ground_disc`,
:func:`brush_sphere`), and the headset's overlays (:func:`window_quad`, :func:`segment_polydata`, the colour wheel
through :func:`mesh_polydata`); ``plantvr.vr`` and ``plantvr.ui`` only call these.
"""
from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

from .._validation import MAX_COORD, check_array  # noqa: E402

__all__ = ["GROUND_RADIUS", "brush_sphere", "checker_texture", "ground_disc", "mesh_arrays", "mesh_polydata",
           "points_polydata", "segment_polydata", "texture", "to_polydata", "tube_polydata", "window_quad"]

#: Radius of the ground disc at y = 0 (m).
GROUND_RADIUS = 8.0


def mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Checked ``(vertices (V, 3) float64, faces (F, 3) int64)`` of a mesh or a ``(vertices, faces)`` pair."""
    if isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        V, F = mesh
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        V, F = mesh.vertices, mesh.faces
    else:
        raise ValueError(f"mesh must have vertices and faces or be a (vertices, faces) pair, "
                         f"got {type(mesh).__name__}")
    V = check_array("vertices", V, shape=(None, 3), max_abs=MAX_COORD)
    F = check_array("faces", F, shape=(None, 3), dtype=np.int64)
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise ValueError(f"faces must index vertices in [0, {len(V) - 1}], got range [{F.min()}, {F.max()}]")
    return np.asarray(V, np.float64), F


def to_polydata(mesh) -> pv.PolyData:
    """A triangle mesh as ``pyvista.PolyData`` (vertex order kept, one triangle cell per face).

    Parameters
    ----------
    mesh : TriMesh or trimesh.Trimesh or tuple of ndarray
        Anything with ``vertices`` (V, 3) and ``faces`` (F, 3), or a ``(vertices, faces)`` pair; optional
        ``normals`` (V, 3), ``colors`` (V, 3|4) uint8 and ``uv`` (V, 2) or (F, 3, 2) attributes are kept.

    Returns
    -------
    pyvista.PolyData
        ``V`` points (``3 F`` when ``uv`` is per corner), ``F`` triangles.

    Raises
    ------
    ValueError
        If the vertices, faces or attributes are malformed.
    """
    V, F = mesh_arrays(mesh)
    n_v = len(V)
    attrs = {} if isinstance(mesh, (tuple, list)) else {k: getattr(mesh, k, None) for k in ("normals", "colors", "uv")}
    uv, point_of = attrs.get("uv"), None
    if uv is not None and np.ndim(uv) == 3:  # per corner: one point per face corner
        uv = check_array("uv", uv, shape=(len(F), 3, 2)).reshape(-1, 2)
        point_of = F.ravel()
        V, F = V[point_of], np.arange(3 * len(F), dtype=np.int64).reshape(-1, 3)
    elif uv is not None:
        uv = check_array("uv", uv, shape=(n_v, 2))
    poly = pv.PolyData(V, np.column_stack([np.full(len(F), 3, np.int64), F]).ravel())
    if attrs.get("normals") is not None:
        n = check_array("normals", attrs["normals"], shape=(n_v, 3))
        poly.point_data["Normals"] = n if point_of is None else n[point_of]
    if attrs.get("colors") is not None:
        c = np.asarray(attrs["colors"])
        if c.ndim != 2 or c.shape[1] not in (3, 4) or len(c) != n_v or c.dtype != np.uint8:
            raise ValueError(f"colors must be a ({n_v}, 3|4) uint8 array, got {c.dtype} {c.shape}")
        poly.point_data["colors"] = c if point_of is None else c[point_of]
    if uv is not None:
        poly.active_texture_coordinates = np.asarray(uv)
    return poly


def _set_rgb(data, rgb) -> None:
    data["rgb"] = np.ascontiguousarray(np.asarray(rgb)[:, :3], np.uint8)


def points_polydata(xyz=(), rgb=None) -> pv.PolyData:
    """Points with one vertex cell each, unchecked (the headset's point layers); no points: an empty mesh.

    Parameters
    ----------
    xyz : (N, 3) array_like, optional
        Point positions; default none (a placeholder input for an actor).
    rgb : (N, 3|4) array_like, optional
        Colours, kept as the uint8 RGB point array ``"rgb"``.

    Returns
    -------
    pyvista.PolyData
    """
    if not len(xyz):
        return pv.PolyData()
    poly = pv.PolyData(xyz)
    if rgb is not None:
        _set_rgb(poly.point_data, rgb)
    return poly


def mesh_polydata(vertices, faces, rgb=None, *, cells: bool = False) -> pv.PolyData:
    """A triangle mesh with float32 points, unchecked (the headset mesher's fast path; :func:`to_polydata`
    checks and keeps a mesh's attributes).

    Parameters
    ----------
    vertices : (V, 3) array_like
    faces : (F, 3) array_like of int
        No faces: the vertices as points.
    rgb : (V|F, 3|4) array_like, optional
        Colours, kept as the uint8 RGB array ``"rgb"`` of the points, or of the cells when ``cells``.
    cells : bool
        Whether ``rgb`` is per face.

    Returns
    -------
    pyvista.PolyData
    """
    f = np.asarray(faces, np.int64)
    v = np.asarray(vertices, np.float32)
    poly = pv.PolyData.from_regular_faces(v, f) if len(f) else pv.PolyData(v)
    if rgb is not None:
        _set_rgb(poly.cell_data if cells else poly.point_data, rgb)
    return poly


def tube_polydata(tree, nodes, radius, *, sides: int = 10, capping: bool = True) -> pv.PolyData:
    """VTK tube filter over the internodes ending at ``nodes`` (tree nodes with a parent), one radius each.

    Parameters
    ----------
    tree : TreeArrays
        Anything with ``pos`` (N, 3) and ``parent`` (N,).
    nodes : (K,) ndarray of int
    radius : (K,) ndarray of float
        Absolute tube radius per internode.
    sides : int
        Sides of each tube.
    capping : bool
        Close the tube ends.

    Returns
    -------
    pyvista.PolyData
        Empty when ``nodes`` is.
    """
    k = len(nodes)
    if not k:
        return pv.PolyData()
    pts = np.concatenate([tree.pos[tree.parent[nodes]], tree.pos[nodes]])
    poly = pv.PolyData(pts, lines=np.column_stack([np.full(k, 2), np.arange(k), np.arange(k) + k]).ravel())
    poly["radius"] = np.concatenate([radius, radius])
    return poly.tube(scalars="radius", absolute=True, n_sides=sides, capping=capping)


def ground_disc() -> pv.PolyData:
    """The ground: a disc of radius :data:`GROUND_RADIUS` at y = 0, facing +y."""
    return pv.Disc(inner=0, outer=GROUND_RADIUS, normal=(0, 1, 0), c_res=48)


def brush_sphere() -> pv.PolyData:
    """The brush: a unit sphere (the actor's matrix or the points' scale give its place and radius)."""
    return pv.Sphere(radius=1.0, theta_resolution=24, phi_resolution=16)


def window_quad(width: float = 0.6, height: float = 0.4) -> pv.PolyData:
    """A parameter window of the headset: a ``width`` x ``height`` quad centred in its own z = 0 plane (m)."""
    return pv.Plane(i_size=width, j_size=height, direction=(0, 0, 1), i_resolution=1, j_resolution=1)


def segment_polydata(a=(0.0, 0.0, 0.0), b=(0.0, 0.0, 1.0)) -> pv.PolyData:
    """One line segment from ``a`` to ``b`` (the headset's pointing ray; move it by setting its ``points``)."""
    return pv.Line(a, b)


def texture(image) -> pv.Texture:
    """A ``pyvista.Texture`` from an (H, W, 3|4) uint8 image whose first row is the top (PIL/numpy order), or
    a texture as it is."""
    if isinstance(image, pv.Texture):
        return image
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] not in (3, 4) or img.dtype != np.uint8:
        raise ValueError(f"texture must be an (H, W, 3|4) uint8 image, got {img.dtype} {img.shape}")
    return pv.Texture(np.ascontiguousarray(img[::-1]))


def checker_texture(n: int = 8, size: int = 256) -> pv.Texture:
    """A repeating ``n`` x ``n`` checkerboard (with a stripe along v, like bark) for looking at UV maps."""
    y, x = np.mgrid[0:size, 0:size] * n // size
    img = np.where((x + y) % 2 == 0, 205, 120).astype(np.uint8)
    img[:, : size // (4 * n)] = 40                        # a dark stripe marks u = 0 (the seam)
    rgb = np.stack([img, (img * 0.8).astype(np.uint8), (img * 0.55).astype(np.uint8)], axis=-1)
    return pv.Texture(rgb)

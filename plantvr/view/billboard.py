"""Billboard impostors and rendered-silhouette checks for the farthest LOD level (spec 000_treewand §3.5; issue 16).

A cross-quad billboard: the tree is rendered offscreen (orthographic, transparent background) from ``views``
horizontal directions spread over 180°; the images sit side by side in one RGBA atlas, and each is mapped onto a
vertical quad through the tree's axis, perpendicular to its view direction, so that seen from that direction the
quad shows exactly the rendered tree. :func:`silhouette_iou` compares two meshes' rendered masks, the check that an
LOD level keeps the silhouette of the full mesh at the distance it is meant for.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np

from .._validation import check_int, check_range
from ..types import TriMesh

__all__ = ["BILLBOARD_LEVEL", "LOD_SCREEN_PX", "Billboard", "export_billboard", "lod_by_distance", "make_billboard",
           "mask_iou", "render_views", "silhouette_iou", "silhouette_masks", "view_frames"]

LOD_SCREEN_PX = (384.0, 192.0, 96.0, 48.0)
"""Screen heights (pixels) down to which LOD levels 0, 1, 2, 3 are used; below the last, the billboard."""
BILLBOARD_LEVEL = len(LOD_SCREEN_PX)
"""Level number :func:`lod_by_distance` gives to the billboard."""

BARK_RGB = (0.55, 0.36, 0.17)
LEAF_RGB = (0.31, 0.54, 0.18)
_UP = np.array([0.0, 1.0, 0.0])


def _parts(meshes, colors):
    """Normalise ``meshes`` (one mesh or a list; objects with ``vertices`` and ``faces``) and their colours."""
    if hasattr(meshes, "vertices"):
        meshes = [meshes]
    meshes = [m for m in meshes if m is not None]
    if not meshes or not any(len(m.faces) for m in meshes):
        raise ValueError("meshes must contain at least one non-empty mesh (vertices and faces)")
    if colors is None:
        colors = [BARK_RGB] + [LEAF_RGB] * (len(meshes) - 1)
    if len(colors) != len(meshes):
        raise ValueError(f"colors must have one entry per mesh ({len(meshes)}), got {len(colors)}")
    return meshes, colors


def view_frames(views: int) -> tuple[np.ndarray, np.ndarray]:
    """Directions to the camera and image-right vectors of ``views`` horizontal views spread over 180°.

    Parameters
    ----------
    views : int
        In [1, 8].

    Returns
    -------
    toward, right : (views, 3) float64 ndarray
        ``toward[k] = (sin θ, 0, cos θ)`` with ``θ = k·180°/views``; ``right = -toward × up``.
    """
    views = check_int("views", views, 1, 8)
    th = np.pi * np.arange(views) / views
    toward = np.stack([np.sin(th), np.zeros(views), np.cos(th)], axis=1)
    right = np.stack([np.cos(th), np.zeros(views), -np.sin(th)], axis=1)
    return toward, right


def _frame_box(meshes):
    v = np.concatenate([np.asarray(m.vertices, float) for m in meshes])
    lo, hi = v.min(0), v.max(0)
    center = (lo + hi) / 2
    d = v - center
    half = max(float(np.abs(d[:, 1]).max()), float(np.hypot(d[:, 0], d[:, 2]).max()), 1e-9)
    return center, half


def render_views(meshes, *, views: int = 2, resolution: int = 256, center=None, half: float | None = None,
                 colors=None, margin: float = 1.02) -> tuple[np.ndarray, np.ndarray, float]:
    """Orthographic offscreen renders of meshes from horizontal directions, transparent background.

    Parameters
    ----------
    meshes : mesh or list of meshes
        Objects with ``vertices`` (V, 3) and ``faces`` (F, 3) (BranchMesh, LeafMesh, trimesh); None entries skipped.
    views : int
        Number of directions over 180° (see :func:`view_frames`).
    resolution : int
        Image side in pixels, in [16, 4096].
    center : (3,) array_like, optional
        Point on the view axis; default the centre of the meshes' bounding box.
    half : float, optional
        Half the side of the square viewed, in scene units; default the meshes' largest distance from the
        vertical axis through ``center`` (or half their height) times ``margin``.
    colors : list of RGB triples, optional
        One per mesh; default bark for the first, leaf green for the rest.
    margin : float
        Head room around the meshes, in [1, 2].

    Returns
    -------
    images : (views, resolution, resolution, 4) uint8 ndarray
        RGBA; alpha 0 where no mesh covers the pixel.
    center : (3,) float64 ndarray
    half : float
    """
    import pyvista as pv

    from .polydata import to_polydata

    meshes, colors = _parts(meshes, colors)
    resolution = check_int("resolution", resolution, 16, 4096)
    margin = check_range("margin", margin, 1.0, 2.0)
    toward, _ = view_frames(views)
    c0, h0 = _frame_box(meshes)
    center = c0 if center is None else np.asarray(center, float).reshape(3)
    half = h0 * margin if half is None else check_range("half", half, 0.0, np.inf, low_open=True)
    pl = pv.Plotter(off_screen=True, window_size=(resolution, resolution))
    try:
        for m, c in zip(meshes, colors):
            if len(m.faces):
                pl.add_mesh(to_polydata((m.vertices, m.faces)), color=c, smooth_shading=False, ambient=0.35,
                            diffuse=0.7, specular=0.0)
        pl.enable_parallel_projection()
        dist = 20.0 * half
        out = np.empty((len(toward), resolution, resolution, 4), np.uint8)
        for k, t in enumerate(toward):
            pl.camera_position = [tuple(center + dist * t), tuple(center), tuple(_UP)]   # marks the camera set
            cam = pl.camera
            cam.parallel_scale = half
            cam.clipping_range = (dist - 2 * half, dist + 2 * half)
            pl.render()                                  # else screenshot() returns the previous frame
            img = pl.screenshot(transparent_background=True, return_img=True)
            out[k] = img if img.shape[2] == 4 else np.dstack([img, np.full(img.shape[:2], 255, np.uint8)])
    finally:
        pl.close()
    for img in out:
        _unblend(img)
    return out, center, half


def _unblend(img: np.ndarray) -> None:
    """Undo the background blending of partly covered (multisampled edge) pixels and fill the uncovered ones with
    the mean covered colour, in place, so that a texture of the image has no pale fringes when filtered."""
    a = img[..., 3].astype(float) / 255.0
    empty, part = a == 0, (a > 0) & (a < 1)
    if not np.any(~empty):
        return
    rgb = img[..., :3].astype(float)
    bg = rgb[empty].mean(0) if np.any(empty) else np.zeros(3)
    fix = (rgb[part] - (1.0 - a[part, None]) * bg) / a[part, None]
    rgb[part] = fix
    rgb[empty] = rgb[~empty].mean(0)
    img[..., :3] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


@dataclass(eq=False)
class Billboard(TriMesh):
    """A cross-quad impostor, a :class:`~plantvr.types.TriMesh` of vertical quads showing an RGBA atlas.

    Attributes
    ----------
    atlas : (R, views·R, 4) uint8 ndarray
        The views side by side (view k in columns ``k·R`` to ``(k+1)·R``).
    vertices : (4·views, 3) float64 ndarray
    faces : (2·views, 3) int64 ndarray
    uv : (4·views, 2) float64 ndarray
        Atlas coordinates, origin at the bottom-left of the image (OBJ/trimesh convention).
    center : (3,) float64 ndarray
    half : float
        Half side of each quad, in scene units.
    """

    vertices: np.ndarray
    faces: np.ndarray
    atlas: np.ndarray
    uv: np.ndarray
    center: np.ndarray
    half: float

    @property
    def views(self) -> int:
        return len(self.faces) // 2

    def to_trimesh(self):
        """The quads as a ``trimesh.Trimesh`` textured with the atlas (alpha blended, double sided)."""
        import trimesh
        from PIL import Image

        mat = trimesh.visual.material.PBRMaterial(name="Billboard", baseColorTexture=Image.fromarray(self.atlas),
                                                  alphaMode="MASK", alphaCutoff=0.5, doubleSided=True,
                                                  metallicFactor=0.0, roughnessFactor=1.0)
        return trimesh.Trimesh(self.vertices, self.faces, process=False,
                               visual=trimesh.visual.TextureVisuals(uv=self.uv, material=mat))

    def save_atlas(self, path) -> Path:
        """Write the atlas as an RGBA PNG (atomically: a failed save leaves the old file)."""
        from .._fileio import write_png
        return write_png(Path(path), self.atlas)

    def export(self, path) -> Path:
        """Write the billboard as .glb (atlas embedded) or .obj (with ``<stem>.mtl`` and ``<stem>_Billboard.png``
        beside it), through the writer registry (:func:`plantvr.io.writers.save`): every file atomically."""
        from ..io.writers import save

        return save(_check_suffix(path), self.part(), normals=False, comment="PlantVR billboard")

    def part(self):
        """The quads as one :class:`plantvr.io.writers.Part`: UVs, the atlas as texture, an alpha-masked,
        double-sided, rough material."""
        from ..io.writers import Part

        return Part("Billboard", self.vertices, self.faces, uv=self.uv, image=self.atlas,
                    material={"alpha_mode": "MASK", "alpha_cutoff": 0.5, "double_sided": True, "metallic": 0.0,
                              "roughness": 1.0})


def _check_suffix(path) -> Path:
    """``path`` as a Path; a ValueError unless the writer registry writes it as .glb or .obj."""
    from ..io.writers import writer_for

    try:
        writer_for(path, allowed=("glb", "obj"))
    except ValueError:
        raise ValueError(f"path suffix must be '.glb' or '.obj' for the billboard, got "
                         f"{Path(path).suffix!r}") from None
    return Path(path)


def make_billboard(meshes, *, views: int = 2, resolution: int = 256, colors=None,
                   margin: float = 1.02) -> Billboard:
    """Cross-quad billboard of a tree: offscreen renders in an atlas and one textured quad per view.

    Parameters
    ----------
    meshes : mesh or list of meshes
        E.g. ``[branches, leaves]`` (see :func:`render_views`).
    views : int
        Quads (and atlas tiles), spread over 180° about the vertical axis; 2 gives the classic cross.
    resolution : int
        Pixels of each tile's side.
    colors, margin
        As in :func:`render_views`.

    Returns
    -------
    Billboard
    """
    images, center, half = render_views(meshes, views=views, resolution=resolution, colors=colors, margin=margin)
    _, right = view_frames(views)
    nv = len(images)
    atlas = np.concatenate(list(images), axis=1)
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)        # (right, up) signs
    verts, uvs, faces = [], [], []
    for k in range(nv):
        verts.append(center + half * (corners[:, :1] * right[k] + corners[:, 1:] * _UP))
        uvs.append(np.stack([(k + (corners[:, 0] + 1) / 2) / nv, (corners[:, 1] + 1) / 2], axis=1))
        faces.append(np.array([[0, 1, 2], [0, 2, 3]]) + 4 * k)
    return Billboard(np.concatenate(verts), np.concatenate(faces).astype(np.int64), atlas, np.concatenate(uvs),
                     center, float(half))


def export_billboard(tree, params: dict, path, *, leaves: bool = True, resolution: int = 256) -> Path:
    """Write the billboard impostor of a tree (``plantvr export --lod 4``): rendered offscreen from LOD level 1
    with its leaves, as .glb (atlas embedded) or .obj (with .mtl and PNG beside it).

    Parameters
    ----------
    tree : Snapshot
        Tree arrays and ``buds`` (see :func:`plantvr.io.tree.tree_geometry`).
    params : dict
        Appearance parameters.
    path : str or pathlib.Path
        Output file, .glb or .obj.
    leaves : bool
        Render the leaves too.
    resolution : int
        Pixels of each atlas tile's side.

    Returns
    -------
    pathlib.Path
    """
    from ..io.tree import tree_geometry

    path = _check_suffix(path)
    if len(tree.pos) < 2:
        raise ValueError("the tree is empty (no internodes): grow it before exporting")
    branches, leaf = tree_geometry(tree, params, leaves=leaves, level=1)
    return make_billboard([branches, leaf], views=2, resolution=resolution).export(path)


def silhouette_masks(meshes, *, views: int = 2, resolution: int = 256, center=None,
                     half: float | None = None) -> np.ndarray:
    """Boolean coverage masks of :func:`render_views` (alpha > 0).

    Returns
    -------
    (views, resolution, resolution) bool ndarray
    """
    images, _, _ = render_views(meshes, views=views, resolution=resolution, center=center, half=half)
    return images[..., 3] > 0


def mask_iou(a, b) -> float:
    """Intersection over union of two boolean masks of the same shape (1.0 when both are empty)."""
    a, b = np.asarray(a, bool), np.asarray(b, bool)
    if a.shape != b.shape:
        raise ValueError(f"masks must have the same shape, got {a.shape} and {b.shape}")
    union = np.count_nonzero(a | b)
    return 1.0 if union == 0 else np.count_nonzero(a & b) / union


def silhouette_iou(reference, other, *, views: int = 2, resolution: int = 256) -> np.ndarray:
    """Rendered-mask IoU of two meshes (e.g. LOD 0 and LOD k) seen in the same frame from each view.

    ``resolution`` sets the intended viewing distance: the reference spans about ``resolution`` pixels, as an
    orthographic stand-in for a tree of that height on screen.

    Parameters
    ----------
    reference, other : mesh or list of meshes
    views : int
    resolution : int

    Returns
    -------
    (views,) float64 ndarray
        IoU per view, in [0, 1].
    """
    ref, _ = _parts(reference, None)
    center, half = _frame_box(ref)
    half *= 1.02
    a = silhouette_masks(reference, views=views, resolution=resolution, center=center, half=half)
    b = silhouette_masks(other, views=views, resolution=resolution, center=center, half=half)
    return np.array([mask_iou(x, y) for x, y in zip(a, b)])


def lod_by_distance(heights, distances, *, fov_deg: float = 30.0, viewport_px: int = 1080,
                    thresholds=LOD_SCREEN_PX) -> np.ndarray:
    """LOD level of each tree of a forest from its on-screen height (pinhole camera).

    Parameters
    ----------
    heights : (T,) float64 array_like
        Tree heights, in scene units.
    distances : (T,) float64 array_like
        Camera-to-tree distances, in scene units (> 0).
    fov_deg : float
        Vertical field of view, in degrees, in (0, 180).
    viewport_px : int
        Viewport height in pixels.
    thresholds : sequence of float
        Decreasing screen heights down to which levels 0, 1, ... are used.

    Returns
    -------
    (T,) int64 ndarray
        0 (full mesh) to ``len(thresholds)`` (billboard, :data:`BILLBOARD_LEVEL` by default).
    """
    from .._validation import check_array

    heights = check_array("heights", heights, shape=(None,), dtype=np.float64)
    distances = check_array("distances", distances, shape=(len(heights),), dtype=np.float64)
    if np.any(~np.isfinite(distances)) or np.any(distances <= 0):
        raise ValueError("distances must be finite and > 0")
    fov = check_range("fov_deg", fov_deg, 0.0, 180.0, low_open=True, high_open=True)
    viewport_px = check_int("viewport_px", viewport_px, 1, 100_000)
    th = np.asarray(thresholds, float)
    if th.ndim != 1 or len(th) < 1 or np.any(np.diff(th) >= 0):
        raise ValueError(f"thresholds must be a non-empty strictly decreasing sequence, got {list(thresholds)!r}")
    px = viewport_px * heights / (2.0 * distances * np.tan(np.radians(fov) / 2))
    return np.searchsorted(-th, -px, side="right").astype(np.int64)

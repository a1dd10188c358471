"""Actor layers of :class:`plantvr.View`: one per kind of scene content (issue 21; spec 000_treewand §3, §4.12).

A document's ``scene()`` is ``{name: content}``; the view keeps one layer per name, of the class that draws the
content's type (:func:`layer_class`):

- :class:`~plantvr.types.TreeArrays` → :class:`TreeLayer`: generalized-cylinder branches (+ leaves at the buds),
  re-meshed incrementally; in a view with ``lod``, :class:`LodTreeLayer`: one actor per LOD level and a
  billboard, picked by camera distance (forests);
- :class:`~plantvr.types.TriMesh` → :class:`MeshLayer`: a surface (terrain, crown, floret, control mesh, the
  ViNE display proxy), with per-vertex ``colors`` (labelled meshes) or ``uv`` and a texture when it has them;
- :class:`~plantvr.types.Points` → :class:`PointsLayer`: points (screen sized) or spheres (``size`` > 0);
- :class:`~plantvr.types.Instances` → :class:`InstancesLayer`: the prototype mesh copied to every transform;
- the content types of :data:`LAYERS`, checked first: :mod:`plantvr.view.vine_layers` registers a labelled
  surface (:class:`~plantvr.types.LabelledSurface`, what a ViNE segmentation shows) and volume slices.

A layer owns its actors and nothing of the document: :meth:`Layer.update` compares the new content with the
one drawn and, only if it changed, edits its ``PolyData`` in place (actors are not re-added), so a live
JupyterLab view follows. Layers never import the documents; they take the content and the appearance
parameters the view passes.
"""
from __future__ import annotations

import functools
import os
import threading
from collections.abc import Mapping
from dataclasses import dataclass, fields, is_dataclass
from typing import Any

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

from .._validation import check_array, check_int  # noqa: E402
from ..geometry.lod import lod_chain  # noqa: E402
from ..geometry.textures import bark_texture  # noqa: E402
from ..io.tree import IncrementalTreeGeometry  # noqa: E402
from ..params import TREEWAND  # noqa: E402
from ..types import Instances, Points, TreeArrays, TriMesh  # noqa: E402
from .billboard import BARK_RGB, BILLBOARD_LEVEL, LOD_SCREEN_PX, make_billboard  # noqa: E402
from .polydata import mesh_arrays, texture, to_polydata  # noqa: E402

__all__ = ["LAYERS", "LOD", "InstancesLayer", "Layer", "LodTreeLayer", "MeshLayer", "PointsLayer", "TreeLayer",
           "check_content", "layer_class", "same_content", "scene_layers", "sync_layers", "tree_buds"]

LEAF = "#4f8a2f"
MARKER = "#f5d142"
SURFACE = "#a0703c"

#: Appearance parameters a tree layer reads (Tree Wand defaults where a document has no such parameter).
TREE_PARAMS = ("tip_radius", "bezier_weight", "bark_rate", "leaf_size", "petiole_length", "petiole_twist",
               "petiole_bend_up", "petiole_bend_right", "leaf_iterations", "leaf_texture")


@dataclass(frozen=True)
class LOD:
    """Level-of-detail options of a forest view: every tree drawn at the level its on-screen height asks for.

    Attributes
    ----------
    levels : int
        LOD levels per tree (:func:`plantvr.geometry.lod.lod_chain`), in [1, 4].
    billboard : bool
        Add a billboard impostor (level :data:`~plantvr.view.billboard.BILLBOARD_LEVEL`) for the farthest trees;
        without it the last mesh level is used beyond.
    billboard_px : int
        Atlas tile side of each billboard, in [8, 4096].
    thresholds : tuple of float
        Screen heights (px) at which levels switch (:func:`~plantvr.view.billboard.lod_by_distance`).
    """

    levels: int = 4
    billboard: bool = True
    billboard_px: int = 128
    thresholds: tuple = LOD_SCREEN_PX

    def __post_init__(self):
        object.__setattr__(self, "levels", check_int("levels", self.levels, 1, 4))
        if not isinstance(self.billboard, (bool, np.bool_)):
            raise ValueError(f"billboard must be True or False, got {self.billboard!r}")
        object.__setattr__(self, "billboard_px", check_int("billboard_px", self.billboard_px, 8, 4096))
        th = check_array("thresholds", self.thresholds, shape=(None,), min_rows=1)
        if np.any(th <= 0) or np.any(th > 1e6):
            raise ValueError(f"thresholds must be screen heights in (0, 1e6] px, got {th.tolist()}")
        object.__setattr__(self, "thresholds", tuple(float(t) for t in th))


def same_content(a: Any, b: Any) -> bool:
    """Whether two scene contents draw the same (identity, else field by field; cached data is ignored)."""
    if a is b:
        return True
    if type(a) is not type(b):
        return False
    if isinstance(a, np.ndarray):
        return a.shape == b.shape and a.dtype == b.dtype and bool(np.array_equal(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same_content(a[k], b[k]) for k in a)
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(same_content(x, y) for x, y in zip(a, b))
    if is_mesh(a) and not all(same_content(getattr(a, k, None), getattr(b, k, None)) for k in _DRAWN):
        return False  # drawn attributes may be set on an instance, outside the dataclass fields
    if is_dataclass(a):
        return all(same_content(getattr(a, f.name), getattr(b, f.name)) for f in fields(a)
                   if not f.name.startswith("_"))
    if is_mesh(a):
        return same_content(np.asarray(a.vertices), np.asarray(b.vertices)) and same_content(
            np.asarray(a.faces), np.asarray(b.faces))
    return bool(a == b)


_DRAWN = ("colors", "uv", "normals")


def is_tree(content: Any) -> bool:
    """A :class:`~plantvr.types.TreeArrays`, or a tree snapshot with the same arrays (and ``buds``)."""
    return isinstance(content, TreeArrays) or all(hasattr(content, k) for k in ("pos", "parent", "radius",
                                                                                 "main_child"))


def is_mesh(content: Any) -> bool:
    """A :class:`~plantvr.types.TriMesh`, or any mesh with ``vertices`` and ``faces`` (trimesh, BranchMesh)."""
    return isinstance(content, TriMesh) or (hasattr(content, "vertices") and hasattr(content, "faces"))


#: ``{content type: layer class}`` of the contents drawn by layers of other modules, checked before the rules
#: of :func:`layer_class` (:mod:`plantvr.view.vine_layers` fills it).
LAYERS: dict[type, type[Layer]] = {}


def layer_class(content: Any, *, lod: LOD | None = None) -> type[Layer]:
    """The layer class that draws ``content``; ``ValueError`` for anything that is not scene content."""
    for kind, cls in LAYERS.items():
        if isinstance(content, kind):
            return cls
    if isinstance(content, Points):
        return PointsLayer
    if isinstance(content, Instances):
        return InstancesLayer
    if is_tree(content):
        return TreeLayer if lod is None else LodTreeLayer
    if is_mesh(content):
        return MeshLayer
    more = "".join(f", {k.__name__}" for k in LAYERS)
    raise ValueError(f"scene content must be TreeArrays, TriMesh, Points or Instances{more}, got "
                     f"{type(content).__name__}")


def check_content(content: Any) -> None:
    """Raise ``ValueError`` naming the array unless ``content``'s arrays can be drawn (shapes, finite values,
    face indices)."""
    if isinstance(content, tuple(LAYERS)):
        return  # checked when it was made (or a document's own arrays)
    if isinstance(content, Points):
        if np.size(content.xyz):
            check_array("xyz", content.xyz, shape=(None, 3))
    elif isinstance(content, Instances):
        mesh_arrays(content.mesh)
        check_array("transforms", content.transforms, shape=(None, 4, 4))
    elif isinstance(content, TreeArrays):
        return  # checked when it was made (TreeArrays.from_arrays)
    elif is_tree(content):
        check_array("pos", content.pos, shape=(None, 3))
    else:
        mesh_arrays(content)


class Layer:
    """Base of the actor layers: one scene entry ``name`` drawn in ``plotter``.

    Parameters
    ----------
    plotter : pyvista.Plotter
    name : str
        The scene name; the layer's main actor has this name in ``plotter.actors``.
    style : dict, optional
        ``add_mesh`` options over the layer's defaults (``color``, ``show_edges``, ``opacity``, ...); a
        ``texture`` may be an (H, W, 3|4) uint8 image.
    """

    #: Point arrays the layer edits in place after drawing them (:meth:`snapshot` copies these; a draw replaces
    #: every other array, so a snapshot shares them).
    in_place: tuple[str, ...] = ()

    def __init__(self, plotter: pv.Plotter, name: str, style: dict | None = None, **options: Any):
        self.plotter, self.name = plotter, name
        #: held while the layer's arrays change off its owner's thread (a document observer) and by :meth:`snapshot`
        self.lock = threading.RLock()
        self.style = dict(style or {})
        if "texture" in self.style and self.style["texture"] is not None:
            self.style["texture"] = texture(self.style["texture"])
        self.content: Any = None
        self.visible = True
        self.pose: np.ndarray | None = None
        self.actors: dict[str, Any] = {}
        self._modes: dict[str, tuple] = {}
        self.polys: dict[str, pv.PolyData] = {}

    def update(self, content: Any, **context: Any) -> bool:
        """Draw ``content`` unless it is what is drawn already; returns whether anything was redrawn."""
        if self.content is not None and same_content(content, self.content) and not self._stale(context):
            return False
        self.draw(content, **context)
        self.content = content
        return True

    def _stale(self, context: dict) -> bool:
        """Whether the drawing context (e.g. appearance parameters) changed since the last draw."""
        return False

    def draw(self, content: Any, **context: Any) -> None:
        raise NotImplementedError

    def _show(self, part: str, poly: pv.PolyData | None, mode: tuple = (), **defaults: Any) -> None:
        """Put ``poly`` into the actor ``part`` in place (added on first use, re-added when ``mode`` — which
        arrays colour it — changes); ``None`` or an empty mesh hides the actor."""
        actor = self.actors.get(part)
        if poly is None or poly.n_points == 0:
            if actor is not None:
                actor.SetVisibility(False)
            return
        if actor is not None and self._modes.get(part) != mode:
            self.plotter.remove_actor(actor)
            actor = None
        if actor is None:
            target = pv.PolyData()
            target.copy_from(poly)
            self.polys[part] = target
            kw = {**defaults, **(self.style if part == "main" else {})}
            self.actors[part] = actor = self.plotter.add_mesh(target, name=self._actor_name(part), **kw)
            self._modes[part] = mode
            if self.pose is not None:
                actor.user_matrix = self.pose
        else:
            self.polys[part].copy_from(poly)
        actor.SetVisibility(self.visible)

    def _actor_name(self, part: str) -> str:
        return self.name if part == "main" else f"{self.name}.{part}"

    @property
    def actor(self):
        """The main actor (None until something is drawn)."""
        return self.actors.get("main")

    def set_visible(self, visible: bool) -> None:
        """Show or hide the layer (an empty part stays hidden)."""
        self.visible = bool(visible)
        for part, a in self.actors.items():
            a.SetVisibility(self.visible and self.polys[part].n_points > 0 and self._part_on(part))

    def _part_on(self, part: str) -> bool:
        return True

    def set_pose(self, matrix: np.ndarray) -> None:
        """Put every actor of the layer at the (4, 4) model transform ``matrix`` (the view's model pose)."""
        self.pose = np.asarray(matrix, np.float64)
        for a in self.actors.values():
            a.user_matrix = self.pose

    def refresh(self) -> bool:
        """Bring what depends on the camera or on followed data up to date before a still; returns whether
        anything changed (nothing here)."""
        return False

    def close(self) -> None:
        """Stop following anything the layer observes (nothing here); its actors stay."""

    def snapshot(self) -> dict[str, tuple[pv.PolyData, Any]]:
        """``{actor name: (PolyData, actor)}`` of what the layer shows, for a renderer on another thread and GL
        context (the headset, :meth:`plantvr.View.snapshot`): each PolyData a shallow copy that the
        layer's later draws leave as it is (they replace arrays; those of :attr:`in_place` are copied here)."""
        out = {}
        with self.lock:
            for part, poly in self.polys.items():
                snap = pv.PolyData()
                snap.shallow_copy(poly)
                for key in self.in_place:
                    if key in poly.point_data:
                        snap.point_data[key] = np.array(poly.point_data[key])
                out[self._actor_name(part)] = (snap, self.actors[part])
        return out

    def points(self) -> np.ndarray:
        """(N, 3) points the camera frames."""
        pts = [np.asarray(p.points) for k, p in self.polys.items() if p.n_points and self.actors[k].GetVisibility()]
        return np.concatenate(pts) if pts else np.zeros((0, 3))

    def remove(self) -> None:
        """Stop following (:meth:`close`) and take the layer's actors out of the plotter."""
        self.close()
        for a in self.actors.values():
            self.plotter.remove_actor(a)
        self.actors.clear()
        self.polys.clear()
        self._modes.clear()


class _TreeSnap:
    """The arrays :class:`~plantvr.io.tree.IncrementalTreeGeometry` reads, from a tree and its buds."""

    def __init__(self, tree, buds):
        self.pos, self.parent, self.radius, self.main_child = tree.pos, tree.parent, tree.radius, tree.main_child
        self.buds = buds


def tree_params(params: dict | None) -> dict[str, Any]:
    """The appearance parameters of :data:`TREE_PARAMS` from a document's ``params`` (Tree Wand defaults for the
    ones it lacks)."""
    base = TREEWAND.defaults()
    params = params or {}
    return {k: params.get(k, base[k]) for k in TREE_PARAMS}


class TreeLayer(Layer):
    """Generalized-cylinder branches and leaves of a tree (spec 000_treewand §3), re-meshed incrementally.

    The one tree → mesh path of the view and the headset (``sides``: cross-section sides at the tips and at the
    base, the LOD of §3.3): :class:`~plantvr.io.tree.IncrementalTreeGeometry` re-evaluates only the
    segments and buds a change touched (§3.5, item 20). Leaves are drawn when ``leaves`` is on, the tree comes
    with its bud slots (``buds``: ``"pos"``, ``"dir"``, ``"radius"``, ``"up"``) and ``leaf_size`` > 0.
    """

    def __init__(self, plotter, name, style=None, *, leaves: bool = True, sides: tuple[int, int] = (6, 32),
                 **options):
        super().__init__(plotter, name, style)
        self.leaves, self.sides = leaves, sides
        self.geometry: IncrementalTreeGeometry | None = None
        self._params: dict | None = None
        self._buds = None

    @property
    def tree(self):
        """The tree drawn (a TreeArrays or a snapshot with its arrays), or None."""
        return self.content

    def update(self, content, *, params=None, buds=None, **context) -> bool:
        if buds is None:
            buds = getattr(content, "buds", None)
        return super().update(content, params=tree_params(params), buds=buds)

    def _stale(self, context) -> bool:
        return context["params"] != self._params or not same_content(context["buds"], self._buds)

    def draw(self, tree, *, params, buds) -> None:
        self._params, self._buds = params, buds
        with_leaves = self.leaves and buds is not None
        if (self.geometry is None or self.geometry.leaves != with_leaves
                or int(np.count_nonzero(np.asarray(tree.parent) >= 0)) == 0):
            self.geometry = IncrementalTreeGeometry(lod=self.sides, leaves=with_leaves)
        if int(np.count_nonzero(np.asarray(tree.parent) >= 0)) == 0:
            self._show("main", None)
            self._show("leaves", None)
            return
        g = self.geometry
        g.update(_TreeSnap(tree, buds), params)
        b = g.branches
        poly = to_polydata((b.vertices, b.faces))
        poly.point_data["Normals"] = b.normals
        poly.active_texture_coordinates = b.uv                # the bark coordinates: bark_rate along, as exported
        self._show("main", poly, smooth_shading=True, texture=_bark())
        lm = g.leaf_mesh
        self._show("leaves", to_polydata((lm.vertices, lm.faces)) if lm is not None and len(lm.faces) else None,
                   color=LEAF, smooth_shading=True)

    def points(self) -> np.ndarray:
        return np.zeros((0, 3)) if self.content is None else np.asarray(self.content.pos, float)


@functools.cache
def _bark() -> pv.Texture:
    """The exporters' default bark image (:func:`~plantvr.geometry.textures.bark_texture`), repeating."""
    tex = texture(bark_texture("furrowed", 256))
    tex.repeat = True
    return tex


class LodTreeLayer(Layer):
    """One tree of a forest view: its LOD chain meshed once, one actor per level, plus a cross-quad billboard
    for the farthest (issue 16); only the actor of :attr:`level` is visible (:class:`plantvr.View` sets it by
    camera distance)."""

    def __init__(self, plotter, name, style=None, *, lod: LOD, **options):
        super().__init__(plotter, name, style)
        self.lod = lod
        self.chain: list = []
        self.tris: list[int] = []
        self.level = -1
        self.center = np.zeros(3)
        self.height = 1e-6

    def draw(self, tree, **context) -> None:
        self.remove()
        radius = np.maximum(np.asarray(tree.radius, float), 1e-6)
        self.chain = lod_chain(np.asarray(tree.pos, float), np.asarray(tree.parent, np.int64), radius,
                               main_child=np.asarray(tree.main_child, np.int64), levels=self.lod.levels)
        self.tris = []
        for k, lv in enumerate(self.chain):
            self._show(f"lod{k}", to_polydata(lv.mesh), color=BARK_RGB)
            self.tris.append(int(lv.triangles))
        v = self.chain[0].mesh.vertices
        lo, hi = v.min(0), v.max(0)
        self.center, self.height = (lo + hi) / 2, max(float(hi[1] - lo[1]), 1e-6)
        if self.lod.billboard:
            bb = make_billboard(self.chain[0].mesh, views=2, resolution=self.lod.billboard_px)
            self._show("billboard", to_polydata(bb), texture=texture(bb.atlas), lighting=False)
            self.tris.append(len(bb.faces))
        self.level = -1
        for a in self.actors.values():
            a.SetVisibility(False)

    def _part_index(self, level: int) -> int:
        """Index into the parts (levels, then the billboard) of the actor a level shows."""
        n_mesh = len(self.chain)
        if level >= BILLBOARD_LEVEL or level >= n_mesh:
            return n_mesh if (self.lod.billboard and level >= BILLBOARD_LEVEL) else n_mesh - 1
        return level

    def set_level(self, level: int) -> bool:
        """Show the actor of ``level``; returns whether the level changed."""
        if level == self.level:
            return False
        shown = self._part_index(int(level))
        for i, a in enumerate(self.actors.values()):
            a.SetVisibility(self.visible and i == shown)
        self.level = int(level)
        return True

    def _part_on(self, part: str) -> bool:
        return list(self.actors).index(part) == self._part_index(self.level)

    @property
    def triangles(self) -> int:
        """Triangles of the actor now visible."""
        return self.tris[self._part_index(self.level)] if self.tris else 0

    def points(self) -> np.ndarray:
        return np.asarray(self.chain[0].mesh.vertices, float) if self.chain else np.zeros((0, 3))


class MeshLayer(Layer):
    """A triangle surface: per-vertex ``colors`` (V, 3|4) uint8 when the mesh has them (labelled meshes), else
    ``uv`` texture coordinates with the style's ``texture``, else one colour."""

    def mesh(self, content):
        """The mesh to draw for ``content``."""
        return content

    def draw(self, content, **context) -> None:
        poly = to_polydata(self.mesh(content))
        colored = "colors" in poly.point_data
        defaults = {"smooth_shading": True, "specular": 0.2}
        if colored:
            defaults.update(scalars="colors", rgb=True)
        elif "texture" not in self.style:
            defaults["color"] = SURFACE
        self._show("main", poly, mode=(colored,), **defaults)


class InstancesLayer(MeshLayer):
    """One prototype mesh at many places (forest trees, leaves): the copies are merged into one mesh."""

    def mesh(self, content: Instances):
        v, f = mesh_arrays(content.mesh)
        T = check_array("transforms", content.transforms, shape=(None, 4, 4))
        k = len(T)
        vh = np.concatenate([v, np.ones((len(v), 1))], axis=1)
        world = np.einsum("kij,vj->kvi", T, vh)
        world = world[..., :3] / world[..., 3:]
        faces = (f[None] + (np.arange(k) * len(v))[:, None, None]).reshape(-1, 3)
        merged = TriMesh(world.reshape(-1, 3), faces)
        colors = getattr(content.mesh, "colors", None)
        if colors is not None:
            merged.colors = np.tile(np.asarray(colors), (k, 1))
        return merged


class PointsLayer(Layer):
    """A point set: screen-sized points (``size`` 0), or spheres of radius ``size``; one colour or per point."""

    def draw(self, pts: Points, **context) -> None:
        xyz = check_array("xyz", pts.xyz, shape=(None, 3)) if np.size(pts.xyz) else np.zeros((0, 3))
        if not len(xyz):
            self._show("main", None)
            return
        poly = pv.PolyData(np.asarray(xyz, float))
        c = None if pts.colors is None else np.asarray(pts.colors)
        per_point = c is not None and c.ndim == 2
        if per_point:
            if c.shape != (len(xyz), c.shape[1]) or c.shape[1] not in (3, 4) or c.dtype != np.uint8:
                raise ValueError(f"colors must be a ({len(xyz)}, 3|4) uint8 array, got {c.dtype} {c.shape}")
            poly.point_data["colors"] = c
        spheres = float(pts.size) > 0
        if spheres:
            poly = poly.glyph(geom=pv.Sphere(radius=float(pts.size), theta_resolution=12, phi_resolution=8),
                              scale=False, orient=False)
        kw: dict[str, Any] = {"pickable": False}
        if per_point:
            kw.update(scalars="colors", rgb=True)
        else:
            kw["color"] = MARKER if c is None else (tuple(c / 255.0) if c.dtype == np.uint8 else tuple(c))
        if not spheres:
            kw.update(point_size=4, render_points_as_spheres=True)
        self._show("main", poly, mode=(per_point, spheres, kw.get("color")), **kw)

    def points(self) -> np.ndarray:
        return np.zeros((0, 3)) if self.content is None or not self.visible else np.asarray(self.content.xyz, float)


def scene_layers(scene, lod, *, arrays: bool = False) -> dict[str, type[Layer]]:
    """The layer class of every entry of ``scene``; with ``arrays``, the content's arrays are checked too (a
    static scene given by a caller), so a bad entry is refused before anything is drawn."""
    if not isinstance(scene, Mapping) or not all(isinstance(k, str) for k in scene):
        raise ValueError(f"scene must be a {{name: content}} mapping with str names, got {type(scene).__name__}")
    out = {}
    for name, content in scene.items():
        try:
            out[name] = layer_class(content, lod=lod)
            if arrays:
                check_content(content)
        except ValueError as exc:
            raise ValueError(f"scene[{name!r}]: {exc}") from None
    return out


def tree_buds(doc, content) -> dict | None:
    """Bud slots of a document's tree: the snapshot the tree arrays came from carries them (Tree Wand, TreeSketch)."""
    if isinstance(content, TreeArrays):
        for snap in (getattr(doc, "latest", None), getattr(doc, "snapshot", None)):
            if getattr(snap, "tree", None) is content:
                return getattr(snap, "buds", None)
    return None


def sync_layers(layers: dict[str, Layer], scene: Mapping[str, Any], classes: dict[str, type[Layer]], make, *,
                params: dict, buds, before=None) -> list[str]:
    """Bring ``layers`` (``{name: Layer}``, edited in place) to ``scene``: the layers of names gone are removed,
    ``make(name, cls)`` makes the missing ones and those of another class (``classes``, :func:`scene_layers`), and
    each draws its content (``buds(content)``: the tree's bud slots). ``before(name)`` runs before a layer is
    made or drawn (a view's panel). Returns the names redrawn."""
    redrawn = []
    for name in [n for n in layers if n not in scene]:
        layers.pop(name).remove()
        redrawn.append(name)
    for name, content in scene.items():
        if before is not None:
            before(name)
        layer = layers.get(name)
        if layer is None or type(layer) is not classes[name]:
            if layer is not None:
                layer.remove()
            layer = layers[name] = make(name, classes[name])
        if layer.update(content, params=params, buds=buds(content)):
            redrawn.append(name)
    return redrawn

"""The shared data types every part speaks: tree arrays and the triangle mesh (DESIGN "Documents", issue 21).

:class:`TreeArrays` is the one skeleton type (positions, parents, radii, orders) that Tree Wand, TreeSketch,
L-systems, QSM imports, forests and every tree→mesh entry point take, in place of dicts and duck typing.
:class:`TriMesh` is the one triangle mesh: vertices and faces, with derived data (face and vertex normals,
edges, bounds, area, watertightness) computed once and cached, as in trimesh. Every mesh class of the package
(branch, leaf, control, floret, crown, terrain meshes) is a :class:`TriMesh`, so the writers of
:mod:`plantvr.io` and the actor layers of :class:`plantvr.View` take any of them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._validation import MAX_COORD, check_array

__all__ = ["BufferMesh", "Instances", "LabelledSurface", "Points", "TreeArrays", "TriMesh"]


def _frozen(a, dtype=None) -> np.ndarray:
    a = np.array(a, dtype=dtype, copy=True)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class TreeArrays:
    """A tree skeleton as parallel arrays (struct of arrays), node 0 the base point.

    Attributes
    ----------
    pos : (N, 3) float64 ndarray
        Node positions; the internode of node ``i`` runs from ``pos[parent[i]]`` to ``pos[i]``.
    parent : (N,) int64 ndarray
        Parent node, ``-1`` for roots; every parent precedes its child (``parent[i] < i``).
    radius : (N,) float64 ndarray
        Radius of the internode ending at each node (pipe model, spec 000_treewand Eq. 9.15).
    order : (N,) int64 ndarray
        Branch order (0 for the trunk).
    main_child : (N,) int64 ndarray
        Continuing (slot 0) child of each node, ``-1`` if none; derived from ``order`` when not given.

    The arrays are read-only copies; build one with :meth:`from_arrays` (checked) or :meth:`from_tree`.
    """

    pos: np.ndarray
    parent: np.ndarray
    radius: np.ndarray
    order: np.ndarray
    main_child: np.ndarray

    @classmethod
    def from_arrays(cls, pos, parent, radius=None, order=None, main_child=None) -> "TreeArrays":
        """Checked arrays as a :class:`TreeArrays`; a bad shape, a non-finite value or a parent that does not
        precede its child raises ``ValueError`` naming the array. ``radius`` defaults to 1, ``order`` to the
        number of non-main steps from the root, ``main_child`` to each node's first child of the same order."""
        pos = check_array("pos", pos, shape=(None, 3), dtype=np.float64, max_abs=MAX_COORD)
        n = len(pos)
        par = np.asarray(parent)
        if par.shape != (n,) or (par.size and par.dtype.kind not in "iu"):
            raise ValueError(f"parent must be an integer array of shape ({n},), got {par.dtype} {par.shape}")
        par = par.astype(np.int64)
        if n and (np.any(par >= np.arange(n)) or np.any(par < -1)):
            bad = int(np.flatnonzero((par >= np.arange(n)) | (par < -1))[0])
            raise ValueError(f"parent[{bad}] = {par[bad]} must be -1 or a node before {bad}")
        rad = (np.ones(n) if radius is None
               else check_array("radius", radius, shape=(n,), dtype=np.float64, max_abs=MAX_COORD))
        if np.any(rad < 0):
            raise ValueError("radius must be >= 0 everywhere")
        if order is None:
            order = _orders(par, main_child)
        order = np.asarray(order)
        if order.shape != (n,) or (order.size and order.dtype.kind not in "iu"):
            raise ValueError(f"order must be an integer array of shape ({n},), got {order.dtype} {order.shape}")
        if main_child is None:
            main_child = _main_children(par, order)
        main_child = np.asarray(main_child)
        if main_child.shape != (n,) or (main_child.size and main_child.dtype.kind not in "iu"):
            raise ValueError(f"main_child must be an integer array of shape ({n},), got {main_child.dtype} "
                             f"{main_child.shape}")
        if n and (np.any(main_child < -1) or np.any(main_child >= n)):
            raise ValueError(f"main_child must be -1 or a node id in [0, {n - 1}]")
        return cls(_frozen(pos, np.float64), _frozen(par, np.int64), _frozen(rad, np.float64),
                   _frozen(order, np.int64), _frozen(main_child, np.int64))

    @classmethod
    def from_tree(cls, tree: Any) -> "TreeArrays":
        """The live nodes of a growth :class:`~plantvr.growth.tree.Tree` (``alive``, ``child`` slots), compacted
        with parents and main children remapped; a :class:`TreeArrays` is returned as it is."""
        if isinstance(tree, TreeArrays):
            return tree
        alive, child = tree.alive, tree.child
        live = np.flatnonzero(alive)
        remap = np.full(len(alive), -1, np.int64)
        remap[live] = np.arange(len(live))
        par, main = tree.parent[live], child[live, 0]
        par = np.where(par >= 0, remap[np.maximum(par, 0)], -1)
        main = np.where(main >= 0, remap[np.maximum(main, 0)], -1)
        return cls(_frozen(tree.pos[live], np.float64), _frozen(par, np.int64), _frozen(tree.radius[live], np.float64),
                   _frozen(tree.order[live], np.int64), _frozen(main, np.int64))

    def __len__(self) -> int:
        return int(self.pos.shape[0])

    @property
    def n_internodes(self) -> int:
        """Internodes: nodes with a parent."""
        return int(np.count_nonzero(self.parent >= 0))

    def as_dict(self) -> dict[str, np.ndarray]:
        """``{"pos", "parent", "radius", "order", "main_child"}``."""
        return {"pos": self.pos, "parent": self.parent, "radius": self.radius, "order": self.order,
                "main_child": self.main_child}


def _orders(parent: np.ndarray, main_child) -> np.ndarray:
    """Branch orders: a node's order is its parent's, +1 unless it is the parent's main (first) child."""
    n = len(parent)
    order = np.zeros(n, np.int64)
    main = _main_children(parent, None) if main_child is None else np.asarray(main_child, np.int64)
    for i in range(n):  # parents precede children
        p = parent[i]
        if p >= 0:
            order[i] = order[p] + (0 if main[p] == i else 1)
    return order


def _main_children(parent: np.ndarray, order) -> np.ndarray:
    """Each node's first child (of the same order, when orders are given), or -1."""
    n = len(parent)
    main = np.full(n, -1, np.int64)
    for i in range(n - 1, -1, -1):  # the lowest-id qualifying child wins
        p = parent[i]
        if p >= 0 and (order is None or order[i] == order[p]):
            main[p] = i
    return main


@dataclass(eq=False)
class TriMesh:
    """A triangle mesh with cached derived data; the base of every mesh class in the package.

    Attributes
    ----------
    vertices : (V, 3) float ndarray
    faces : (F, 3) integer ndarray
        Counter-clockwise seen from outside.

    Derived data (:attr:`face_normals`, :attr:`vertex_normals`, :attr:`edges`, :attr:`bounds`, :attr:`area`,
    :attr:`is_watertight`) is computed on first use and cached; after editing ``vertices`` or ``faces`` in
    place, call :meth:`invalidate`. Subclasses add their own fields (``normals``, ``uv``, ``colors``, ...).
    """

    vertices: np.ndarray
    faces: np.ndarray
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def from_arrays(cls, vertices, faces) -> "TriMesh":
        """A checked mesh: finite (V, 3) vertices and (F, 3) faces indexing them."""
        v = check_array("vertices", vertices, shape=(None, 3), max_abs=MAX_COORD)
        f = np.asarray(faces)
        if f.ndim != 2 or f.shape[1] != 3 or (f.size and f.dtype.kind not in "iu"):
            raise ValueError(f"faces must be an integer array of shape (F, 3), got {f.dtype} {f.shape}")
        if f.size and (int(f.min()) < 0 or int(f.max()) >= len(v)):
            raise ValueError(f"faces must index vertices in [0, {len(v) - 1}], got [{f.min()}, {f.max()}]")
        return TriMesh(v, f.astype(np.int64))

    def invalidate(self) -> None:
        """Drop cached derived data (after editing the arrays in place)."""
        self._cache.clear()

    def _cached(self, key: str, make):
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]

    @property
    def n_vertices(self) -> int:
        return int(len(self.vertices))

    @property
    def n_faces(self) -> int:
        return int(len(self.faces))

    @property
    def face_normals(self) -> np.ndarray:
        """(F, 3) unit face normals (zero for degenerate faces)."""
        def make():
            v, f = np.asarray(self.vertices, np.float64), np.asarray(self.faces, np.int64)
            n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
            ln = np.linalg.norm(n, axis=1, keepdims=True)
            return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)
        return self._cached("face_normals", make)

    @property
    def vertex_normals(self) -> np.ndarray:
        """(V, 3) unit vertex normals: the mesh's own ``normals`` when it has them, else area-weighted."""
        own = getattr(self, "normals", None)
        if own is not None:
            return own

        def make():
            v, f = np.asarray(self.vertices, np.float64), np.asarray(self.faces, np.int64)
            n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
            acc = np.zeros((len(v), 3))
            for k in range(3):
                np.add.at(acc, f[:, k], n)
            ln = np.linalg.norm(acc, axis=1, keepdims=True)
            return np.divide(acc, ln, out=np.zeros_like(acc), where=ln > 0)
        return self._cached("vertex_normals", make)

    @property
    def edges(self) -> np.ndarray:
        """(E, 2) int64 unique undirected edges, each sorted (low, high)."""
        def make():
            f = np.asarray(self.faces, np.int64)
            e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
            return np.unique(e, axis=0) if len(e) else np.zeros((0, 2), np.int64)
        return self._cached("edges", make)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) lower and upper corner."""
        return self._cached("bounds", lambda: np.array([self.vertices.min(0), self.vertices.max(0)], np.float64)
                            if len(self.vertices) else np.zeros((2, 3)))

    @property
    def area(self) -> float:
        """Total surface area."""
        def make():
            v, f = np.asarray(self.vertices, np.float64), np.asarray(self.faces, np.int64)
            return float(0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]),
                                              axis=1).sum())
        return self._cached("area", make)

    @property
    def is_watertight(self) -> bool:
        """Every undirected edge is shared by exactly two faces, each way once (closed, consistently wound)."""
        def make():
            f = np.asarray(self.faces, np.int64)
            if not len(f):
                return False
            d = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
            _, cnt = np.unique(d, axis=0, return_counts=True)
            if np.any(cnt != 1):
                return False  # an edge used twice in the same direction: inconsistent winding
            u, cu = np.unique(np.sort(d, axis=1), axis=0, return_counts=True)
            return bool(np.all(cu == 2))
        return self._cached("is_watertight", make)

    def to_trimesh(self):
        """A ``trimesh.Trimesh`` (``process=False``) with this mesh's vertex normals."""
        import trimesh  # noqa: PLC0415  (heavy, optional at this layer)
        kw = {"vertex_normals": self.normals} if getattr(self, "normals", None) is not None else {}
        return trimesh.Trimesh(self.vertices, self.faces, process=False, **kw)


class BufferMesh(TriMesh):
    """A :class:`TriMesh` whose ``vertices`` and ``faces`` are views of buffers that an incremental mesher
    updates in place (the branch and leaf meshes kept across growth steps): derived data is computed on every
    access instead of cached. A subclass provides ``vertices`` and ``faces`` as properties and calls
    ``BufferMesh.__init__`` (no arguments) before filling its buffers."""

    def __init__(self) -> None:
        self._cache = {}

    def _cached(self, key: str, make):
        return make()


class LabelledSurface(TriMesh):
    """The visible triangles of a labels document in their label colours, with the document itself.

    What a ViNE segmentation (or its display proxy) shows: its vertices, visible faces, per-vertex ``colors``
    through the colour table and ``normals``, so writers and the headset take it as any coloured mesh, while a
    :class:`plantvr.View` draws it with the layer that follows ``source``'s changes in place
    (:class:`plantvr.view.vine_layers.LabelledSurfaceLayer`).

    Parameters
    ----------
    source : Segmentation or DisplayProxy
        Anything with ``vertices``, ``normals``, ``labels``, ``colors``, ``visible_faces()``,
        ``vertex_colors()`` and a ``change`` trait.
    """

    def __init__(self, source):
        missing = [k for k in ("vertices", "normals", "labels", "colors", "visible_faces", "vertex_colors",
                               "observe") if not hasattr(source, k)]
        if missing:
            raise ValueError(f"source must be a labels document (a Segmentation or DisplayProxy), got "
                             f"{type(source).__name__} without {', '.join(missing)}")
        super().__init__(source.vertices, source.visible_faces())
        self.colors = source.vertex_colors()
        self.normals = source.normals
        self.source = source


@dataclass(frozen=True, eq=False)
class Points:
    """A point set to draw or export (markers, attractors, point clouds).

    Attributes
    ----------
    xyz : (M, 3) float64 ndarray
    colors : (M, 3) uint8 ndarray or (3,) RGB tuple, optional
    size : float
        Point size in world units (0: screen pixels chosen by the view).
    """

    xyz: np.ndarray
    colors: Any = None
    size: float = 0.0


@dataclass(frozen=True, eq=False)
class Instances:
    """One prototype mesh drawn at many places (forest trees, leaves).

    Attributes
    ----------
    mesh : TriMesh
    transforms : (K, 4, 4) float64 ndarray
        Model-to-world matrix of each instance.
    """

    mesh: TriMesh
    transforms: np.ndarray

"""Trees as meshes and files: the tree→mesh entry points and every tree exporter (spec 000_treewand §3, §3.5;
§8.1 items 16–22; issue 16; issue 21).

One entry point per output kind, each taking the tree arrays (a :class:`plantvr.types.TreeArrays`, or a
snapshot with the same fields and its ``buds``) and the appearance parameters:

* branch mesh (generalized cylinders, at full detail or at an LOD level) and leaf mesh: :func:`tree_geometry`
  (:func:`branch_mesh`, :func:`leaf_mesh`), kept across snapshots by :class:`IncrementalTreeGeometry`;
* skinned: :func:`tree_skeleton` and :func:`export_skinned_glb`;
* instanced: :func:`plantvr.io.usd.leaf_instances` (leaves) and :func:`plantvr.io.landscape.export_landscape`
  (trees).

Files: :func:`export_tree` (PLY, OBJ with its .mtl and textures, textured glTF), :func:`export_skinned_glb`,
:func:`plantvr.io.usd.export_usd`, and :func:`snapshot_export` / :func:`export_model_as` that pick one by suffix
and LOD level. Every file goes through the writer registry (:mod:`plantvr.io.writers`: the one writer of each
format, every file of a save atomic).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from plantvr._validation import (
    check_array,
    check_choice,
    check_index,
    check_int,
    check_range,
    check_tree_arrays,
)
from plantvr.geometry.leaves import IncrementalLeafMesh, LeafMesh, build_leaves
from plantvr.geometry.lod import axis_start, lod_chain
from plantvr.geometry.mesh import BranchMesh, IncrementalBranchMesh, build_branch_mesh
from plantvr.geometry.textures import BARK_TEXTURES, LEAF_TEXTURES, bark_texture, leaf_texture

from ._checks import check_tree_meshes
from .gltf import Gltf, check_glb_path
from .usd import export_usd
from .writers import SUFFIXES, Part, save, writer_for

__all__ = ["BILLBOARD_LOD", "EXPORT_FORMATS", "FORMATS", "SUFFIX_FORMAT", "IncrementalTreeGeometry", "Skeleton",
           "branch_mesh", "bud_nodes", "export_model", "export_model_as", "export_skinned_glb", "export_tree",
           "leaf_mesh", "snapshot_export", "tree_geometry", "tree_skeleton"]

FORMATS = (".ply", ".obj", ".glb")
"""Suffixes :func:`export_tree` writes."""

EXPORT_FORMATS = {"usd": ".usd", "glb": ".glb", "ply": ".ply", "obj": ".obj"}
"""``plantvr export --format`` choices and the suffix each writes (.usda/.usdc also pick USD)."""

BILLBOARD_LOD = 4
"""``lod`` value that exports the billboard impostor instead of a mesh level (written by the view layer:
:func:`plantvr.view.billboard.export_billboard`)."""

SUFFIX_FORMAT = {s: f for s, f in SUFFIXES.items() if f in EXPORT_FORMATS}
"""Output suffix → format of :func:`snapshot_export` (the writer registry's, :data:`plantvr.io.writers.SUFFIXES`)."""

_BARK_RGB = (96, 66, 40)
_LEAF_RGB = (70, 140, 45)
_BARK_RGBA = [96 / 255, 66 / 255, 40 / 255, 1.0]
_LEAF_RGBA = [70 / 255, 140 / 255, 45 / 255, 1.0]


# -- tree → mesh ------------------------------------------------------------------------------------------------
def branch_mesh(tree, params: dict[str, Any], *, lod: tuple[int, int] = (6, 32)) -> BranchMesh:
    """Generalized-cylinder branch mesh of a tree at full detail, with the appearance parameters of ``params``
    (``bezier_weight``, ``tip_radius``, ``bark_rate``; §3, B.2).

    Parameters
    ----------
    tree : TreeArrays or Snapshot
        Anything with ``pos``, ``parent``, ``radius`` and ``main_child`` node arrays.
    params : dict
    lod : (int, int)
        Ring subdivisions (minimum, maximum), as in :func:`plantvr.geometry.build_branch_mesh`.

    Returns
    -------
    BranchMesh
    """
    return build_branch_mesh(tree.pos, tree.parent, tree.radius, main_child=tree.main_child,
                             bezier_w=params["bezier_weight"], lod=lod, tip_radius=params["tip_radius"],
                             bark_rate=params["bark_rate"])


def leaf_mesh(buds: dict[str, np.ndarray], params: dict[str, Any]) -> LeafMesh | None:
    """Leaves and petioles at the bud slots ``buds`` (``pos``, ``dir``, ``radius``, ``up``), placed as §10.2 with
    the leaf parameters of ``params``; None when ``leaf_size`` is 0 or there are no buds.

    Returns
    -------
    LeafMesh or None
    """
    if params["leaf_size"] <= 0 or not len(buds["pos"]):
        return None
    return build_leaves(buds["pos"], buds["dir"], buds["radius"], bud_up=buds["up"], leaf_size=params["leaf_size"],
                        radius_threshold=3 * params["tip_radius"], petiole_length=params["petiole_length"],
                        e_twist=params["petiole_twist"], e_up=params["petiole_bend_up"],
                        e_right=params["petiole_bend_right"], iterations=params["leaf_iterations"],
                        leaf_shape=params["leaf_texture"], rng=0)


def bud_nodes(snap) -> np.ndarray:
    """Node each bud sits on (buds are at their node's position); -1 where no node matches."""
    from scipy.spatial import cKDTree

    bp = np.asarray(snap.buds["pos"], float)
    if not len(bp) or not len(snap.pos):
        return np.zeros(len(bp), np.int64)
    d, i = cKDTree(np.asarray(snap.pos, float)).query(bp)
    return np.where(d <= 1e-9 * max(1.0, float(np.abs(snap.pos).max())), i, -1).astype(np.int64)


def _level_geometry(snap, params: dict[str, Any], level: int, leaves: bool):
    """Branch mesh of LOD level ``level`` (:func:`plantvr.geometry.lod.lod_chain`), the leaves of the buds on the
    nodes it keeps, and the node of each of those buds."""
    chain = lod_chain(snap.pos, snap.parent, snap.radius, main_child=snap.main_child, levels=level + 1,
                      tip_radius=params["tip_radius"], bezier_w=params["bezier_weight"],
                      bark_rate=params["bark_rate"])
    lv = chain[level]
    leaf = None
    bud_node = bud_nodes(snap)
    if leaves and params["leaf_size"] > 0 and len(bud_node):
        keep = (bud_node >= 0) & lv.alive[np.maximum(bud_node, 0)]
        bud_node = bud_node[keep]
        if len(bud_node):
            leaf = leaf_mesh({k: np.asarray(v)[keep] for k, v in snap.buds.items()}, params)
            if not len(leaf.faces):
                leaf = None
    return lv.mesh, leaf, bud_node


def tree_geometry(snap, params: dict[str, Any], *, leaves: bool = True, lod: tuple[int, int] = (6, 32),
                  level: int | None = None) -> tuple[BranchMesh, LeafMesh | None]:
    """Branch mesh and leaf mesh of a tree, with the appearance parameters of ``params`` (§4.11 B.2).

    Parameters
    ----------
    snap : Snapshot
        Tree arrays (``pos``, ``parent``, ``radius``, ``main_child``) and ``buds``.
    params : dict
    leaves : bool
        Build the leaves.
    lod : (int, int)
        Ring subdivisions at full detail (``level`` None).
    level : int, optional
        LOD level of :func:`plantvr.geometry.lod.lod_chain` in [0, 3] instead of full detail: fewer sides,
        twigs pruned to the level's budget, leaves only on the nodes kept.

    Returns
    -------
    branches : BranchMesh
    leaves : LeafMesh or None
    """
    if level is not None:
        level = check_int("level", level, 0, BILLBOARD_LOD - 1)
        branches, leaf, _ = _level_geometry(snap, params, level, leaves)
        return branches, leaf
    return branch_mesh(snap, params, lod=lod), leaf_mesh(snap.buds, params) if leaves else None


_GEOMETRY_PARAMS = ("tip_radius", "bezier_weight", "bark_rate", "leaf_size", "petiole_length", "petiole_twist",
                    "petiole_bend_up", "petiole_bend_right", "leaf_iterations", "leaf_texture")


class IncrementalTreeGeometry:
    """Branch and leaf meshes kept across snapshots: each update re-meshes only what changed (spec §3.5, item 20).

    Views call :meth:`update` with every new snapshot; a change of an appearance parameter rebuilds.
    Buffers may hold degenerate rows (free blocks); use :func:`tree_geometry` for export.
    """

    def __init__(self, *, lod: tuple[int, int] = (6, 32), leaves: bool = True):
        self.lod, self.leaves = lod, leaves
        self._key: tuple | None = None
        self.branches: IncrementalBranchMesh | None = None
        self.leaf_mesh: IncrementalLeafMesh | None = None

    def update(self, snap, params: dict[str, Any]) -> None:
        """Bring the meshes to ``snap`` (the first call, or new appearance parameters, build from scratch)."""
        key = tuple(params[k] for k in _GEOMETRY_PARAMS)
        tip = params["tip_radius"]
        if key != self._key or self.branches is None:
            self._key = key
            self.branches = IncrementalBranchMesh(snap.pos, snap.parent, snap.radius, main_child=snap.main_child,
                                                  lod=self.lod, tip_radius=tip, bezier_w=params["bezier_weight"],
                                                  bark_rate=params["bark_rate"])
            self.leaf_mesh = IncrementalLeafMesh(
                radius_threshold=3 * tip, petiole_radius=0.3 * tip, leaf_size=params["leaf_size"],
                petiole_length=params["petiole_length"], e_twist=params["petiole_twist"],
                e_up=params["petiole_bend_up"], e_right=params["petiole_bend_right"],
                iterations=params["leaf_iterations"], leaf_shape=params["leaf_texture"]) if self.leaves else None
        else:
            self.branches.update(snap.pos, snap.parent, snap.radius, main_child=snap.main_child)
        if self.leaf_mesh is not None:
            b = snap.buds
            self.leaf_mesh.update(b["pos"], b["dir"], b["radius"], b["up"])


# -- PLY, OBJ, textured glTF -----------------------------------------------------------------------------------
def export_tree(path, branches: BranchMesh, leaves: LeafMesh | None = None, *, bark: str = "furrowed",
                leaf: str = "ovate") -> Path:
    """Write a tree mesh to ``path``; the format follows the suffix (.ply, .obj or .glb).

    glTF carries UVs, vertex normals and two PBR materials with the procedural bark and leaf textures (meshes
    and nodes ``"bark"`` and ``"leaves"``); OBJ writes ``<stem>.mtl`` and the texture PNGs beside the .obj; PLY
    carries positions, normals and per-vertex RGBA colours.

    Parameters
    ----------
    path : str or pathlib.Path
        Output file.
    branches : BranchMesh
    leaves : LeafMesh, optional
    bark : {"furrowed", "birch"}
        Bark texture (B.2 "Bark texture select").
    leaf : {"ovate", "lobed"}
        Leaf texture (B.2 "Leaf texture select").

    Returns
    -------
    pathlib.Path
        The written file.
    """
    path = Path(path)
    check_choice("path suffix", path.suffix.lower(), FORMATS)
    check_tree_meshes(branches, leaves)
    check_choice("bark", bark, BARK_TEXTURES)
    check_choice("leaf", leaf, LEAF_TEXTURES)
    meshes = [branches] + ([leaves] if leaves is not None and len(leaves.faces) else [])
    looks = (("bark", bark_texture(bark), _BARK_RGB, {"alpha_mode": "OPAQUE"}),
             ("leaves", leaf_texture(leaf), _LEAF_RGB, {"double_sided": True, "alpha_mode": "MASK", "alpha_cutoff": 0.5}))
    parts = [Part(name, m.vertices, m.faces, normals=np.asarray(m.normals, np.float64),
                  uv=np.asarray(m.uv, np.float64), colors=np.tile(np.array([*rgb, 255], np.uint8), (len(m.vertices), 1)),
                  image=img, material=mat)
             for m, (name, img, rgb, mat) in zip(meshes, looks)]
    return save(path, parts, double=True, group="tree", per_format={"ply": {"comment": "PlantVR tree"},
                                                                   "obj": {"comment": "PlantVR tree mesh"}})


# -- skinned glTF ----------------------------------------------------------------------------------------------
@dataclass
class Skeleton:
    """Joints of a tree.

    Attributes
    ----------
    joint_of_node : (N,) int64 ndarray
        Joint each node is bound to (node 0: the trunk's joint).
    start : (J,) int64 ndarray
        First node of the axis each joint stands for (joint 0: the trunk, node 1).
    parent : (J,) int64 ndarray
        Parent joint, -1 for joint 0; ``parent[j] < j``.
    base : (J, 3) float64 ndarray
        Joint position: the start of its axis's first internode.
    """

    joint_of_node: np.ndarray
    start: np.ndarray
    parent: np.ndarray
    base: np.ndarray

    def __len__(self) -> int:
        return len(self.start)


def tree_skeleton(pos, parent, radius, *, main_child=None, max_joints: int = 64) -> Skeleton:
    """Joints of a tree: one per axis, the thinnest axes merged until at most ``max_joints`` remain.

    Parameters
    ----------
    pos : (N, 3) float64 ndarray
    parent : (N,) int64 ndarray
        ``parent[0] = -1``, ``parent[i] < i``.
    radius : (N,) float64 ndarray
        Axes are ranked by the radius of their first internode.
    main_child : (N,) int64 ndarray, optional
        Default the lowest child index.
    max_joints : int
        In [1, 65535].

    Returns
    -------
    Skeleton
        Joints in increasing order of their start node, so parents come first.
    """
    pos, parent, radius = check_tree_arrays(pos, parent, radius)
    n = len(pos)
    if main_child is not None:
        main_child = check_index("main_child", main_child, shape=(n,), low=-1, high=n - 1)
    max_joints = check_int("max_joints", max_joints, 1, 65535)
    st = axis_start(parent, main_child)
    st[0] = 1
    axes = np.unique(st[1:])                                   # sorted; axes[0] == 1 (trunk)
    order = np.lexsort((axes, -radius[axes]))                  # thickest first, ties by index
    order = order[axes[order] != 1]
    kept = np.zeros(n, bool)
    kept[1] = True
    kept[axes[order[:max_joints - 1]]] = True
    owner = np.zeros(n, np.int64)                              # kept axis each axis is merged into
    for a in axes.tolist():
        owner[a] = a if kept[a] else owner[st[parent[a]]]
    start = np.flatnonzero(kept)
    jid = np.full(n, -1, np.int64)
    jid[start] = np.arange(len(start))
    joint_of_node = jid[owner[st]]
    jpar = np.array([-1] + [joint_of_node[parent[a]] for a in start[1:].tolist()], np.int64)
    return Skeleton(joint_of_node=joint_of_node, start=start, parent=jpar, base=pos[parent[start]].copy())


def export_skinned_glb(path, branches: BranchMesh, pos, parent, radius, *, main_child=None,
                       leaves: LeafMesh | None = None, leaf_node=None, max_joints: int = 64, birth=None,
                       animate: bool = True, duration: float = 5.0, steps: int = 20) -> Path:
    """Write a skinned, optionally growth-animated tree to a binary glTF 2.0 file.

    One joint per axis (chain of main children), the thinnest axes merged when there are more than
    ``max_joints`` (:func:`tree_skeleton`). Every branch vertex is bound rigidly (weight 1) to the joint of its
    node's axis, so an engine can bend or sway the tree by rotating joints. The joints sit at the base of their
    axis with identity rotation; the inverse bind matrices are the inverse translations. The optional growth
    animation scales every joint from 0 to 1 around its base, in the order the axes appeared (node birth order).

    Parameters
    ----------
    path : str or pathlib.Path
        Output ``.glb`` file.
    branches : BranchMesh
        Mesh of the tree given by ``pos``, ``parent``, ``radius``; ``branches.node_id`` picks each vertex's joint.
    pos, parent, radius, main_child
        The tree, as in :func:`tree_skeleton`.
    leaves : LeafMesh, optional
        Skinned to the joint of ``leaf_node[bud_id]`` (or to the trunk joint when ``leaf_node`` is None).
    leaf_node : (B,) int ndarray, optional
        Node each bud (row of the bud arrays given to :func:`plantvr.geometry.leaves.build_leaves`) sits on.
    max_joints : int
        Joint budget, in [1, 65535].
    birth : (N,) float64 ndarray, optional
        Appearance time of each node (e.g. growth step); default the node index.
    animate : bool
        Add the growth animation ("growth": per-joint scale keys).
    duration : float
        Animation length in seconds.
    steps : int
        Key frames after t = 0, in [1, 1000].

    Returns
    -------
    pathlib.Path
    """
    path = check_glb_path(path)
    sk = tree_skeleton(pos, parent, radius, main_child=main_child, max_joints=max_joints)
    n = len(sk.joint_of_node)
    check_tree_meshes(branches, leaves)
    V = len(branches.vertices)
    node_id = check_index("branches.node_id", branches.node_id, shape=(V,), low=0, high=max(n - 1, 0))
    if len(node_id) and int(node_id.max()) >= n:
        raise ValueError(f"branches.node_id refers to node {int(node_id.max())}, but the tree has {n}")
    birth = np.arange(n, dtype=float) if birth is None else check_array("birth", birth, shape=(n,))
    duration = check_range("duration", duration, 0.0, 1e6, low_open=True)
    steps = check_int("steps", steps, 1, 1000)
    if leaves is not None and leaf_node is not None:
        leaf_node = check_index("leaf_node", leaf_node, shape=(None,), low=0, high=n - 1)
        bud_id = check_index("leaves.bud_id", leaves.bud_id, shape=(len(leaves.vertices),), low=0, high=2**62)
        if len(bud_id) and bud_id.max() >= len(leaf_node):
            raise ValueError("leaf_node must give a node index in [0, N) for every bud_id of the leaves")

    J = len(sk)
    g = Gltf()
    g.add_material("Bark", rgba=_BARK_RGBA, roughness=0.9)
    g.add_material("Leaf", rgba=_LEAF_RGBA, roughness=0.8, double_sided=True)

    def prim(m, joints, material):
        jt = np.uint8 if joints.max(initial=0) < 256 else np.uint16
        j4 = np.zeros((len(joints), 4), jt)
        j4[:, 0] = joints
        w4 = np.zeros((len(joints), 4), np.float32)
        w4[:, 0] = 1.0
        return g.primitive(m.vertices, m.faces, normals=m.normals, uv=m.uv, joints=j4, weights=w4,
                           material=material)

    prims = [prim(branches, sk.joint_of_node[node_id], 0)]
    if leaves is not None and len(leaves.faces):
        lj = (sk.joint_of_node[leaf_node[bud_id]] if leaf_node is not None
              else np.zeros(len(leaves.vertices), np.int64))
        prims.append(prim(leaves, lj, 1))
    g.add_mesh("tree", prims)

    local = sk.base - np.where(sk.parent[:, None] >= 0, sk.base[np.maximum(sk.parent, 0)], 0.0)
    kids = [[] for _ in range(J)]
    for j, p in enumerate(sk.parent.tolist()):
        if p >= 0:
            kids[p].append(j + 1)
    g.add_node(name="tree", mesh=0, skin=0)
    for j in range(J):
        g.add_node(name=f"joint_{j}", translation=local[j].tolist(), children=kids[j] or None)
    ibm = np.tile(np.eye(4, dtype=np.float32), (J, 1, 1))
    ibm[:, 3, :3] = -sk.base                                   # column-major: the translation is row 3
    g.skins.append({"name": "skeleton", "joints": list(range(1, J + 1)), "skeleton": 1,
                    "inverseBindMatrices": g.buffer.add(ibm, "MAT4")})
    g.add_scene([0, 1])

    if animate:
        jb = np.full(J, np.inf)
        np.minimum.at(jb, sk.joint_of_node[1:], birth[1:])
        lo, hi = jb.min(), jb.max()
        dt = duration / steps
        tj = (jb - lo) / (hi - lo) * (duration - dt) if hi > lo else np.zeros(J)
        times = np.linspace(0.0, duration, steps + 1).astype(np.float32)
        scale = np.clip((times[None, :] - tj[:, None]) / dt, 0.0, 1.0).astype(np.float32)
        t_acc = g.buffer.add(times, "SCALAR", minmax=True)
        samplers, channels = [], []
        for j in range(J):
            out = g.buffer.add(np.repeat(scale[j][:, None], 3, axis=1), "VEC3")
            samplers.append({"input": t_acc, "output": out, "interpolation": "LINEAR"})
            channels.append({"sampler": j, "target": {"node": j + 1, "path": "scale"}})
        g.animations.append({"name": "growth", "samplers": samplers, "channels": channels})
    return g.write(path)                               # a failed save leaves the old file (issue 20)


# -- one call per format and LOD level -------------------------------------------------------------------------
def snapshot_export(snap, params: dict[str, Any], path: str | Path, *, lod: int = 0, leaves: bool = True,
                    skinned: bool = True) -> Path:
    """Write a snapshot's tree at one LOD level to USD, skinned glTF (.glb), PLY or OBJ (issue 16).

    Parameters
    ----------
    snap : Snapshot
    params : dict
        Appearance parameters (``bezier_weight``, ``tip_radius``, ``bark_rate``, leaf and texture settings).
    path : str or pathlib.Path
        Output file; its suffix (.usd/.usda/.usdc, .glb, .ply, .obj) picks the format.
    lod : int
        Level of :func:`plantvr.geometry.lod.lod_chain`, in [0, 3]: fewer cylinder sides and, from level 1 on,
        twigs pruned to the level's triangle budget; leaves stay only on the nodes kept. The billboard impostor
        (``BILLBOARD_LOD``) is rendered offscreen, in the view layer: :func:`plantvr.view.billboard.export_billboard`.
    leaves : bool
        Include the leaves.
    skinned : bool
        For .glb: a skeleton with skin weights and the growth animation (:func:`export_skinned_glb`);
        otherwise the textured meshes (:func:`export_tree`).

    Returns
    -------
    pathlib.Path
    """
    path = Path(path)
    fmt = writer_for(path, allowed=tuple(EXPORT_FORMATS)).format
    lod = check_int("lod", lod, 0, BILLBOARD_LOD)
    if lod == BILLBOARD_LOD:
        raise ValueError(f"lod {BILLBOARD_LOD} (the billboard) is rendered by the view: write it as .glb or .obj "
                         f"with plantvr.view.billboard.export_billboard")
    if len(snap.pos) < 2:
        raise ValueError("the tree is empty (no internodes): grow it before exporting")
    branches, leaf, bud_node = _level_geometry(snap, params, lod, leaves)
    return _SNAPSHOT_EXPORTS[fmt, bool(skinned)](path, snap, params, branches, leaf, bud_node)


def _usd_export(path, snap, params, branches, leaf, bud_node) -> Path:
    return export_usd(path, branches, leaf, order=np.asarray(snap.order, np.int64), bark=params["bark_texture"],
                      leaf=params["leaf_texture"])


def _skinned_export(path, snap, params, branches, leaf, bud_node) -> Path:
    return export_skinned_glb(path, branches, snap.pos, snap.parent, snap.radius, main_child=snap.main_child,
                              leaves=leaf, leaf_node=bud_node if leaf is not None else None)


def _mesh_export(path, snap, params, branches, leaf, bud_node) -> Path:
    return export_tree(path, branches, leaf, bark=params["bark_texture"], leaf=params["leaf_texture"])


#: What :func:`snapshot_export` writes for each (format of :data:`EXPORT_FORMATS`, ``skinned``); the file itself
#: goes through the writer registry.
_SNAPSHOT_EXPORTS = {**{(f, s): _mesh_export for f in ("ply", "obj", "glb") for s in (False, True)},
                     ("glb", True): _skinned_export, ("usd", False): _usd_export, ("usd", True): _usd_export}


def export_model(model, path: str | Path) -> Path:
    """Write the model's tree (branches, leaves, textures where the format has them) to .ply, .obj or .glb."""
    branches, leaf = tree_geometry(model.snapshot, model.params)
    return export_tree(path, branches, leaf, bark=model.bark_texture, leaf=model.leaf_texture)


def export_model_as(model, path: str | Path, *, lod: int = 0, leaves: bool = True, skinned: bool = True) -> Path:
    """:func:`export_model` for every format and LOD level: USD, skinned .glb, PLY or OBJ by suffix.

    Parameters
    ----------
    model : plantvr.Model
    path : str or pathlib.Path
        Output file (.usd/.usda/.usdc, .glb, .ply, .obj).
    lod : int
        LOD level in [0, 3] (see :func:`snapshot_export`).
    leaves, skinned : bool
        As in :func:`snapshot_export`.

    Returns
    -------
    pathlib.Path
    """
    return snapshot_export(model.snapshot, model.params, path, lod=lod, leaves=leaves, skinned=skinned)

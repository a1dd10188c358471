"""Landscapes and forests as one binary glTF 2.0 scene with instancing (spec 004_treesketch §4.6 item 4, §3.10).

A landscape is written as one ``.glb``: the terrain height field as a mesh, and one node per tree with its
translation, rotation (about the vertical axis) and scale. Trees whose meshes are identical (the same
species shape placed many times, [INFERRED] compared on their float32 bytes) share one glTF mesh that many
nodes reference, so an instanced tree library costs one mesh per shape. Written by the one glTF writer,
:func:`plantvr.io.gltf.write_glb`, through the writer registry (:mod:`plantvr.io.writers`); read the file back
with ``trimesh.load(path, force="scene")``.
"""
from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from plantvr._validation import MAX_COORD, check_array
from plantvr.landscape.distribution import Distribution
from plantvr.landscape.forest import Forest, terrain_mesh, tree_mesh_task
from plantvr.landscape.terrain import sample_height
from plantvr.params import defaults, validate

from .gltf import MAX_GLB_COORD, _check_mesh, write_glb
from .tree import leaf_mesh

__all__ = ["BARK_RGBA", "LEAF_RGBA", "TERRAIN_RGBA", "export_distribution", "export_forest", "export_landscape",
]

BARK_RGBA = (0.38, 0.26, 0.16, 1.0)
TERRAIN_RGBA = (0.55, 0.53, 0.33, 1.0)
LEAF_RGBA = (0.27, 0.55, 0.18, 1.0)


def _mesh_key(v: np.ndarray, f: np.ndarray) -> bytes:
    h = hashlib.sha1(np.round(v, 5).astype(np.float32).tobytes())
    h.update(np.ascontiguousarray(f, np.int64).tobytes())
    return h.digest()


def export_landscape(path, trees: list[tuple[np.ndarray, np.ndarray]], positions: np.ndarray, *,
                     yaw: np.ndarray | None = None, scale: np.ndarray | None = None,
                     terrain: tuple[np.ndarray, tuple[float, float]] | None = None, names: list[str] | None = None,
                     instancing: bool = True, leaves: list | None = None) -> Path:
    """Write trees placed on a landscape, and the terrain, as one glTF scene with instancing.

    Parameters
    ----------
    path : str or pathlib.Path
        Output ``.glb``.
    trees : list of (vertices (V, 3), faces (F, 3))
        One mesh per tree in its own frame (base at the origin, y up). Trees whose meshes are identical share
        one glTF mesh when ``instancing``.
    positions : (N, 3) float64 array
        World base of each tree (node translation).
    yaw : (N,) float64 array, optional
        Rotation about +y, radians (node rotation quaternion).
    scale : (N,) float64 array, optional
        Uniform scale (> 0) of each tree (node scale).
    terrain : (heights (ny, nx), size (W, D)), optional
        Height field written as the mesh "terrain" (one more node, identity transform).
    names : list of str, optional
        Node names (default ``tree_<i>``); a shared mesh is named after its first tree.
    instancing : bool
        Share identical meshes; False writes one mesh per tree.
    leaves : list of (vertices, faces) or None, optional
        Leaf mesh of each tree in the same frame (None: no leaves); written as a second, double-sided primitive
        of the tree's mesh.

    Returns
    -------
    pathlib.Path

    References
    ----------
    .. [1] Spec 004 §4.6 (4): "per-tree meshes plus an instance list (position, rotation, scale, species), plus
       the terrain height field as a mesh" [INFERRED]; glTF 2.0 nodes share meshes.
    """
    if not isinstance(trees, (list, tuple)):
        raise ValueError(f"trees must be a list of (vertices, faces), got {type(trees).__name__}")
    n = len(trees)
    pos = check_array("positions", positions, shape=(n, 3), max_abs=MAX_GLB_COORD)
    yaw = np.zeros(n) if yaw is None else check_array("yaw", yaw, shape=(n,), max_abs=1e6)
    sc = np.ones(n) if scale is None else check_array("scale", scale, shape=(n,), max_abs=1e6)
    if not np.all(sc > 0):
        raise ValueError(f"scale must be positive, got min {sc.min()!r}")
    if names is not None and (not isinstance(names, (list, tuple)) or not all(isinstance(x, str) for x in names)):
        raise ValueError("names must be a list of str")
    if names is not None and len(names) != n:
        raise ValueError(f"names must have one entry per tree ({n}), got {len(names)}")
    if terrain is not None and (not isinstance(terrain, (tuple, list)) or len(terrain) != 2):
        raise ValueError("terrain must be (heights, size)")
    checked = [_check_mesh(f"trees[{i}]", t) for i, t in enumerate(trees)]
    if leaves is not None and len(leaves) != n:
        raise ValueError(f"leaves must have one entry (or None) per tree ({n}), got {len(leaves)}")
    lv = [None if leaves is None or leaves[i] is None else _check_mesh(f"leaves[{i}]", leaves[i]) for i in range(n)]
    ter = None if terrain is None else terrain_mesh(*terrain)
    meshes: list[dict[str, Any]] = []
    nodes: list[dict[str, Any]] = []
    seen: dict[bytes, int] = {}
    for i, (v, f) in enumerate(checked):
        name = names[i] if names is not None else f"tree_{i}"
        key = (_mesh_key(v, f) + (b"" if lv[i] is None else _mesh_key(*lv[i]))) if instancing else i
        if key not in seen:
            seen[key] = len(meshes)
            part = [{"vertices": v, "faces": f, "color": BARK_RGBA}]
            if lv[i] is not None:
                part.append({"vertices": lv[i][0], "faces": lv[i][1], "color": LEAF_RGBA, "double_sided": True})
            meshes.append({"name": name, "parts": part})
        q = [0.0, float(np.sin(yaw[i] / 2)), 0.0, float(np.cos(yaw[i] / 2))]
        nodes.append({"mesh": seen[key], "name": name, "translation": pos[i], "rotation": np.array(q),
                      "scale": np.full(3, sc[i])})
    if ter is not None:
        meshes.append({"vertices": ter[0], "faces": ter[1], "name": "terrain", "color": TERRAIN_RGBA})
        nodes.append({"mesh": len(meshes) - 1, "name": "terrain"})
    return write_glb(path, meshes, nodes)


def _tree_leaves(tree: dict[str, np.ndarray], p: dict[str, Any]) -> tuple[np.ndarray, np.ndarray] | None:
    """Leaf mesh of a tree's arrays at its free bud slots (:func:`plantvr.io.tree.leaf_mesh`)."""
    node, _ = np.nonzero((tree["child"] == -1) & tree["alive"][:, None])
    if p["leaf_size"] <= 0 or not len(node):
        return None
    leaf = leaf_mesh({"pos": tree["pos"][node], "dir": tree["head"][node], "radius": tree["radius"][node],
                      "up": tree["lat"][node]}, p)
    return (leaf.vertices, leaf.faces) if len(leaf.faces) else None


def export_forest(path, forest, *, instancing: bool = True, terrain: bool = True, leaves: bool = False,
                  params: dict[str, Any] | None = None) -> Path:
    """Write a :class:`~plantvr.landscape.forest.Forest` as one glTF scene: every tree's branch mesh (its
    ``meshes``, built now when the forest was grown without geometry) in its own frame, placed at its base;
    identical trees share a mesh. ``terrain`` adds the height field. ``leaves`` builds each tree's leaves
    (as :func:`plantvr.io.tree.leaf_mesh` places them, with ``params`` over the defaults) as a second primitive."""
    if not isinstance(forest, Forest):
        raise ValueError(f"forest must be a Forest, got {type(forest).__name__}")
    if len(forest.trees) != len(forest.bases) or (forest.meshes is not None and len(forest.meshes) != len(forest.trees)):
        raise ValueError("forest trees, bases and meshes must have one entry per tree")
    if params is not None and not isinstance(params, dict):
        raise ValueError(f"params must be a dict or None, got {type(params).__name__}")
    meshes = forest.meshes if forest.meshes is not None else [tree_mesh_task(t) for t in forest.trees]
    local = [(np.asarray(v, float) - b if len(v) else np.zeros((0, 3)), f) for (v, f), b in zip(meshes, forest.bases)]
    lv = None
    if leaves:
        p = {**defaults(), **validate(params or {})}
        lv = [_tree_leaves({**t, "pos": t["pos"] - b}, p) for t, b in zip(forest.trees, forest.bases)]
    ter = (forest.heights, forest.size) if terrain else None
    return export_landscape(path, local, forest.bases, terrain=ter, instancing=instancing, leaves=lv)


def export_distribution(path, distribution, prototypes: list[tuple[np.ndarray, np.ndarray]], *,
                        heights: np.ndarray | None = None, size: tuple[float, float] = (30.0, 30.0),
                        rng: int | np.random.Generator | None = None) -> Path:
    """Write a :class:`~plantvr.landscape.distribution.Distribution` as an instanced tree library: one
    prototype mesh per species (its representative tree, base at the origin), one node per placed tree with
    its scale S_i and a random yaw; bases on ``heights`` (sampled bilinearly) when given, else y = 0."""
    if not isinstance(distribution, Distribution):
        raise ValueError(f"distribution must be a Distribution, got {type(distribution).__name__}")
    if not isinstance(prototypes, (list, tuple)):
        raise ValueError(f"prototypes must be a list of (vertices, faces), got {type(prototypes).__name__}")
    xz = check_array("distribution xy", distribution.xy, shape=(None, 2), max_abs=MAX_COORD)
    sp = check_array("distribution species", distribution.species, shape=(len(xz),), dtype=np.int64)
    if len(sp) and (sp.min() < 0 or sp.max() >= len(prototypes)):
        raise ValueError(f"prototypes must give a mesh for each of the {int(sp.max()) + 1} species, got "
                         f"{len(prototypes)}")
    y = np.zeros(len(xz)) if heights is None else sample_height(heights, size, xz)
    pos = np.column_stack([xz[:, 0], y, xz[:, 1]])
    yaw = np.random.default_rng(rng).uniform(0.0, 2 * np.pi, len(xz))
    ter = None if heights is None else (heights, size)
    return export_landscape(path, [prototypes[s] for s in sp], pos, yaw=yaw, scale=distribution.scale,
                            terrain=ter, names=[f"species{s}_{i}" for i, s in enumerate(sp)])

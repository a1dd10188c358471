"""Landscape export as one binary glTF 2.0 scene with instancing (spec 004_treesketch §4.6 item 4, §3.10).

A landscape is written as one ``.glb``: the terrain height field as a mesh, and one node per tree with its
translation, rotation (about the vertical axis) and scale. Trees whose meshes are identical (the same
species shape placed many times, [INFERRED] compared on their float32 bytes) share one glTF mesh that many
nodes reference, so an instanced tree library costs one mesh per shape. The writer uses numpy, json and struct
only; read the file back with ``trimesh.load(path, force="scene")``.
"""
from __future__ import annotations

import hashlib
import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

from .._fileio import atomic_write
from .._validation import MAX_COORD, MAX_COUNT, check_array
from ..geometry._gltf import ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, GltfBuffer, check_glb_path

__all__ = ["export_distribution", "export_forest", "export_landscape", "terrain_mesh", "write_glb"]

BARK_RGBA = (0.38, 0.26, 0.16, 1.0)
TERRAIN_RGBA = (0.55, 0.53, 0.33, 1.0)
LEAF_RGBA = (0.27, 0.55, 0.18, 1.0)


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (unit; +y where a vertex has no face)."""
    n = np.zeros_like(v)
    if len(f):
        fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        for k in range(3):
            np.add.at(n, f[:, k], fn)
    ln = np.linalg.norm(n, axis=1)
    out = np.tile([0.0, 1.0, 0.0], (len(v), 1))
    ok = ln > 0
    out[ok] = n[ok] / ln[ok, None]
    return out


#: Largest coordinate written (float32 positions and transforms stay exact enough and finite).
MAX_GLB_COORD = 1e12


def _check_mesh(name: str, mesh) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(mesh, (str, bytes, dict)) or not hasattr(mesh, "__len__") or len(mesh) != 2:
        raise ValueError(f"{name} must be (vertices, faces), got {type(mesh).__name__}")
    v, f = mesh
    v = check_array(f"{name} vertices", v, shape=(None, 3), max_abs=MAX_GLB_COORD)
    if len(v) >= 2 ** 32 or len(v) > MAX_COUNT:
        raise ValueError(f"{name} vertices must be fewer than {MAX_COUNT}, got {len(v)}")
    try:
        f = np.asarray(f)
    except (TypeError, ValueError):
        raise ValueError(f"{name} faces must be an (F, 3) int array, got {type(f).__name__}") from None
    if f.size == 0:
        f = np.zeros((0, 3), np.int64)
    if f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu" or len(f) > MAX_COUNT or \
            (len(f) and (f.min() < 0 or f.max() >= len(v))):
        raise ValueError(f"{name} faces must be (F, 3) integer indices into its {len(v)} vertices, got "
                         f"{f.dtype} {f.shape}")
    return v, f.astype(np.int64)


def _check_rgba(name: str, c) -> tuple[float, ...]:
    rgba = check_array(name, c, shape=(4,))
    if np.any(rgba < 0) or np.any(rgba > 1):
        raise ValueError(f"{name} must be RGBA values in [0, 1], got {rgba.tolist()}")
    return tuple(float(x) for x in rgba)


def write_glb(path, meshes: list[dict[str, Any]], nodes: list[dict[str, Any]]) -> Path:
    """Write meshes and the nodes that place them as one binary glTF 2.0 file.

    Parameters
    ----------
    path : str or pathlib.Path
        Output file, ``.glb``.
    meshes : list of dict
        ``{"vertices": (V, 3) float, "faces": (F, 3) int, "name": str, "color": (4,) RGBA in [0, 1],
        "double_sided": bool}``, or ``{"name": str, "parts": [such dicts]}`` for a mesh of several primitives
        (e.g. bark and leaves); one glTF mesh each, with float32 positions, vertex normals and uint32 indices,
        and one material per distinct colour.
    nodes : list of dict
        ``{"mesh": int, "name": str, "translation": (3,), "rotation": (4,) quaternion (x, y, z, w),
        "scale": (3,)}`` (transform entries optional); all are roots of the one scene.

    Returns
    -------
    pathlib.Path
    """
    path = check_glb_path(path)
    if not isinstance(meshes, (list, tuple)) or not all(isinstance(m, dict) for m in meshes):
        raise ValueError("meshes must be a list of dicts")
    if not isinstance(nodes, (list, tuple)) or not all(isinstance(nd, dict) for nd in nodes):
        raise ValueError("nodes must be a list of dicts")
    for k, nd in enumerate(nodes):
        m = nd.get("mesh")
        if isinstance(m, (bool, np.bool_)) or not isinstance(m, (int, np.integer)) or not 0 <= m < len(meshes):
            raise ValueError(f"nodes[{k}] mesh must be an index in [0, {len(meshes)}), got {m!r}")
        if not isinstance(nd.get("name", ""), str):
            raise ValueError(f"nodes[{k}] name must be a str, got {nd.get('name')!r}")
    parts = []
    for i, m in enumerate(meshes):
        ps = m.get("parts", [m])
        if not isinstance(ps, (list, tuple)) or not ps or not all(isinstance(q, dict) for q in ps):
            raise ValueError(f"meshes[{i}] parts must be a non-empty list of dicts")
        if not isinstance(m.get("name", ""), str):
            raise ValueError(f"meshes[{i}] name must be a str, got {m.get('name')!r}")
        for j, q in enumerate(ps):
            if "vertices" not in q or "faces" not in q:
                raise ValueError(f"meshes[{i}] part {j} must have vertices and faces")
            _check_rgba(f"meshes[{i}] part {j} color", q.get("color", BARK_RGBA))
        parts.append(ps)
    checked = [[_check_mesh(f"meshes[{i}] part {j}", (q["vertices"], q["faces"])) for j, q in enumerate(ps)]
               for i, ps in enumerate(parts)]
    transforms = []
    for k, nd in enumerate(nodes):  # every transform checked before anything is written
        transforms.append({key: check_array(f"nodes[{k}] {key}", nd[key], shape=(n,), max_abs=MAX_GLB_COORD).tolist()
                           for key, n in (("translation", 3), ("rotation", 4), ("scale", 3))
                           if nd.get(key) is not None})
    buf = GltfBuffer()
    gl_meshes, materials, mat_index = [], [], {}
    for i, (cm, ps, m) in enumerate(zip(checked, parts, meshes)):
        prims = []
        for (v, f), q in zip(cm, ps):
            rgba = tuple(float(c) for c in q.get("color", BARK_RGBA))
            key = (rgba, bool(q.get("double_sided", False)))
            if key not in mat_index:  # one material per colour, shared by the meshes
                mat_index[key] = len(materials)
                materials.append({"name": f"material_{len(materials)}", "doubleSided": key[1],
                                  "pbrMetallicRoughness": {"baseColorFactor": list(rgba), "metallicFactor": 0.0,
                                                           "roughnessFactor": 0.9}})
            prim: dict[str, Any] = {"material": mat_index[key], "mode": 4, "attributes": {}}
            if len(f):
                prim["attributes"]["POSITION"] = buf.add(v.astype(np.float32), "VEC3", target=ARRAY_BUFFER,
                                                           minmax=True)
                prim["attributes"]["NORMAL"] = buf.add(_vertex_normals(v, f).astype(np.float32), "VEC3",
                                                         target=ARRAY_BUFFER)
                prim["indices"] = buf.add(f.astype(np.uint32).ravel(), "SCALAR", target=ELEMENT_ARRAY_BUFFER)
            else:  # glTF needs POSITION: an empty part becomes one degenerate (zero-area) triangle
                prim["attributes"]["POSITION"] = buf.add(np.zeros((3, 3), np.float32), "VEC3",
                                                           target=ARRAY_BUFFER, minmax=True)
            prims.append(prim)
        gl_meshes.append({"name": m.get("name", f"mesh_{i}"), "primitives": prims})
    gl_nodes = []
    for k, nd in enumerate(nodes):
        out: dict[str, Any] = {"name": nd.get("name", f"node_{k}"), "mesh": int(nd["mesh"])}
        out.update(transforms[k])
        gl_nodes.append(out)
    blob = buf.blob()
    doc = {"asset": {"version": "2.0", "generator": "PlantVR landscape"}, "scene": 0,
           "scenes": [{"name": "landscape", "nodes": list(range(len(gl_nodes)))}], "nodes": gl_nodes,
           "meshes": gl_meshes, "materials": materials, "accessors": buf.accessors, "bufferViews": buf.views,
           "buffers": [{"byteLength": len(blob)}]}
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * ((-len(js)) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    with atomic_write(path) as fh:  # a failed write leaves any previous file intact
        fh.write(struct.pack("<4sII", b"glTF", 2, total))
        fh.write(struct.pack("<I4s", len(js), b"JSON") + js)
        fh.write(struct.pack("<I4s", len(blob), b"BIN\0") + blob)
    return path


def terrain_mesh(heights: np.ndarray, size: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Height field (ny, nx) over [0, size[0]] x [0, size[1]] (x columns, z rows, y up) as a triangle mesh
    (vertices (ny nx, 3), faces (2 (ny-1)(nx-1), 3), normals up); the grid nodes are those of
    :func:`~plantvr.landscape.terrain.sample_height`."""
    from .terrain import check_field, pair

    h = check_field("heights", heights)
    ny, nx = h.shape
    if ny < 2 or nx < 2:
        raise ValueError(f"heights must be at least 2 x 2, got {h.shape}")
    W, D = pair("size", size)
    X, Z = np.meshgrid(np.linspace(0.0, W, nx), np.linspace(0.0, D, ny))
    v = np.column_stack([X.ravel(), h.ravel(), Z.ravel()])
    idx = np.arange(ny * nx).reshape(ny, nx)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([c, b, d])])
    return v, f


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
    """Leaf mesh of a tree's arrays at its free bud slots (the leaf placement of ``plantvr.export.tree_geometry``,
    called through :func:`plantvr.geometry.leaves.build_leaves`)."""
    from ..geometry.leaves import build_leaves

    node, _ = np.nonzero((tree["child"] == -1) & tree["alive"][:, None])
    if p["leaf_size"] <= 0 or not len(node):
        return None
    leaf = build_leaves(tree["pos"][node], tree["head"][node], tree["radius"][node], bud_up=tree["lat"][node],
                        leaf_size=p["leaf_size"], radius_threshold=3 * p["tip_radius"],
                        petiole_length=p["petiole_length"], e_twist=p["petiole_twist"], e_up=p["petiole_bend_up"],
                        e_right=p["petiole_bend_right"], iterations=p["leaf_iterations"],
                        leaf_shape=p["leaf_texture"], rng=0)
    return (leaf.vertices, leaf.faces) if len(leaf.faces) else None


def export_forest(path, forest, *, instancing: bool = True, terrain: bool = True, leaves: bool = False,
                  params: dict[str, Any] | None = None) -> Path:
    """Write a :class:`~plantvr.landscape.forest.Forest` as one glTF scene: every tree's branch mesh (its
    ``meshes``, built now when the forest was grown without geometry) in its own frame, placed at its base;
    identical trees share a mesh. ``terrain`` adds the height field. ``leaves`` builds each tree's leaves
    (as ``plantvr.export.tree_geometry`` places them, with ``params`` over the defaults) as a second primitive."""
    from .forest import Forest, tree_mesh_task

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
        from ..params import defaults

        from ..params import validate

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
    from .terrain import sample_height

    from .distribution import Distribution

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

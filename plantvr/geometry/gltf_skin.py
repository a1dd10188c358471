"""glTF 2.0 (.glb) export of a tree with a skeleton and a growth animation (spec 000_treewand §3; issue 16).

One joint per axis (chain of main children); when there are more axes than ``max_joints`` the thinnest axes are
merged into the joint of the axis they grow from. Every branch vertex is bound rigidly (weight 1) to the joint
of its node's axis, so an engine can bend or sway the tree by rotating joints. The joints sit at the base of
their axis with identity rotation; the inverse bind matrices are the inverse translations. The optional growth
animation scales every joint from 0 to 1 around its base, in the order the axes appeared (node birth order).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plantvr._fileio import write_atomic
from plantvr._validation import MAX_COORD, check_array, check_index, check_int, check_points, check_range

from ._gltf import GltfBuffer, check_glb_path
from .leaves import LeafMesh
from .lod import axis_start
from .mesh import BranchMesh

__all__ = ["Skeleton", "tree_skeleton", "export_skinned_glb"]

_BARK_RGBA = [96 / 255, 66 / 255, 40 / 255, 1.0]
_LEAF_RGBA = [70 / 255, 140 / 255, 45 / 255, 1.0]


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
    pos = check_points("pos", pos, min_rows=2)
    n = len(pos)
    parent = check_index("parent", parent, shape=(n,), low=-1, high=n - 1)
    radius = check_array("radius", radius, shape=(n,), dtype=np.float64, max_abs=MAX_COORD)
    if parent[0] != -1 or np.any(parent[1:] < 0) or np.any(parent[1:] >= np.arange(1, n)):
        raise ValueError("parent must be -1 for node 0 and satisfy 0 <= parent[i] < i for i > 0")
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


def _primitive(b: GltfBuffer, m, joints, material: int):
    import pygltflib as G

    jt = np.uint8 if joints.max(initial=0) < 256 else np.uint16
    j4 = np.zeros((len(joints), 4), jt)
    j4[:, 0] = joints
    w4 = np.zeros((len(joints), 4), np.float32)
    w4[:, 0] = 1.0
    attrs = G.Attributes(
        POSITION=b.add(m.vertices.astype(np.float32), "VEC3", target=G.ARRAY_BUFFER, minmax=True),
        NORMAL=b.add(m.normals.astype(np.float32), "VEC3", target=G.ARRAY_BUFFER),
        TEXCOORD_0=b.add(m.uv.astype(np.float32), "VEC2", target=G.ARRAY_BUFFER),
        JOINTS_0=b.add(j4, "VEC4", target=G.ARRAY_BUFFER),
        WEIGHTS_0=b.add(w4, "VEC4", target=G.ARRAY_BUFFER))
    idx = b.add(m.faces.astype(np.uint32).ravel(), "SCALAR", target=G.ELEMENT_ARRAY_BUFFER)
    return G.Primitive(attributes=attrs, indices=idx, material=material, mode=G.TRIANGLES)


def export_skinned_glb(path, branches: BranchMesh, pos, parent, radius, *, main_child=None,
                       leaves: LeafMesh | None = None, leaf_node=None, max_joints: int = 64, birth=None,
                       animate: bool = True, duration: float = 5.0, steps: int = 20) -> Path:
    """Write a skinned, optionally growth-animated tree to a binary glTF 2.0 file.

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
    import pygltflib as G

    path = check_glb_path(path)
    sk = tree_skeleton(pos, parent, radius, main_child=main_child, max_joints=max_joints)
    n = len(sk.joint_of_node)
    from .export import _check_meshes
    _check_meshes(branches, leaves)
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
    g = G.GLTF2(asset=G.Asset(generator="PlantVR", version="2.0"))
    b = GltfBuffer()
    g.materials = [
        G.Material(name="Bark", pbrMetallicRoughness=G.PbrMetallicRoughness(
            baseColorFactor=_BARK_RGBA, metallicFactor=0.0, roughnessFactor=0.9)),
        G.Material(name="Leaf", doubleSided=True, pbrMetallicRoughness=G.PbrMetallicRoughness(
            baseColorFactor=_LEAF_RGBA, metallicFactor=0.0, roughnessFactor=0.8))]
    prims = [_primitive(b, branches, sk.joint_of_node[node_id], 0)]
    if leaves is not None and len(leaves.faces):
        lj = (sk.joint_of_node[leaf_node[bud_id]] if leaf_node is not None
              else np.zeros(len(leaves.vertices), np.int64))
        prims.append(_primitive(b, leaves, lj, 1))
    g.meshes = [G.Mesh(name="tree", primitives=prims)]

    local = sk.base - np.where(sk.parent[:, None] >= 0, sk.base[np.maximum(sk.parent, 0)], 0.0)
    kids = [[] for _ in range(J)]
    for j, p in enumerate(sk.parent.tolist()):
        if p >= 0:
            kids[p].append(j + 1)
    g.nodes = [G.Node(name="tree", mesh=0, skin=0)]
    g.nodes += [G.Node(name=f"joint_{j}", translation=local[j].tolist(), children=kids[j] or None)
                for j in range(J)]
    ibm = np.tile(np.eye(4, dtype=np.float32), (J, 1, 1))
    ibm[:, 3, :3] = -sk.base                                   # column-major: the translation is row 3
    g.skins = [G.Skin(name="skeleton", joints=list(range(1, J + 1)), skeleton=1,
                      inverseBindMatrices=b.add(ibm, "MAT4"))]
    g.scenes = [G.Scene(nodes=[0, 1])]
    g.scene = 0

    if animate:
        jb = np.full(J, np.inf)
        np.minimum.at(jb, sk.joint_of_node[1:], birth[1:])
        lo, hi = jb.min(), jb.max()
        dt = duration / steps
        tj = (jb - lo) / (hi - lo) * (duration - dt) if hi > lo else np.zeros(J)
        times = np.linspace(0.0, duration, steps + 1).astype(np.float32)
        scale = np.clip((times[None, :] - tj[:, None]) / dt, 0.0, 1.0).astype(np.float32)
        t_acc = b.add(times, "SCALAR", minmax=True)
        samplers, channels = [], []
        for j in range(J):
            out = b.add(np.repeat(scale[j][:, None], 3, axis=1), "VEC3")
            samplers.append(G.AnimationSampler(input=t_acc, output=out, interpolation="LINEAR"))
            channels.append(G.AnimationChannel(sampler=j, target=G.AnimationChannelTarget(node=j + 1,
                                                                                          path="scale")))
        g.animations = [G.Animation(name="growth", samplers=samplers, channels=channels)]

    g.bufferViews = [G.BufferView(**v) for v in b.views]
    g.accessors = [G.Accessor(**a) for a in b.accessors]
    blob = b.blob()
    g.buffers = [G.Buffer(byteLength=len(blob))]
    g.set_binary_blob(blob)
    chunks = g.save_to_bytes()
    if not chunks:                                      # pragma: no cover - pygltflib refuses the document
        raise ValueError(f"cannot write {str(path)!r}: pygltflib produced no .glb data")
    write_atomic(path, b"".join(chunks))               # a failed save leaves the old file (issue 20)
    return path

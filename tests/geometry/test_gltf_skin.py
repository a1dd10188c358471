"""Skinned glTF export: joints, weights, inverse bind matrices, growth animation (issue 16)."""
import numpy as np
import pygltflib
import pytest
import trimesh

from plantvr.geometry.lod import axis_start
from plantvr.io.tree import export_skinned_glb, tree_skeleton

from ._trees import leafy_tree

_NP = {pygltflib.FLOAT: np.float32, pygltflib.UNSIGNED_INT: np.uint32, pygltflib.UNSIGNED_SHORT: np.uint16,
       pygltflib.UNSIGNED_BYTE: np.uint8}
_NC = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def _read(g, i):
    acc = g.accessors[i]
    bv = g.bufferViews[acc.bufferView]
    blob = g.binary_blob()
    a = np.frombuffer(blob, _NP[acc.componentType], acc.count * _NC[acc.type],
                      bv.byteOffset + (acc.byteOffset or 0))
    return a.reshape(acc.count, _NC[acc.type]) if _NC[acc.type] > 1 else a


@pytest.fixture(scope="module")
def tree():
    return leafy_tree(150, seed=11)


def test_skeleton_one_joint_per_axis(tree):
    pos, parent, radius, mc, *_ = tree
    st = axis_start(parent, mc)
    sk = tree_skeleton(pos, parent, radius, main_child=mc, max_joints=10**4)
    assert len(sk) == len(np.unique(st[1:]))
    np.testing.assert_array_equal(sk.start, np.unique(st[1:]))
    np.testing.assert_array_equal(sk.start[sk.joint_of_node[1:]], st[1:])
    assert sk.parent[0] == -1 and np.all(sk.parent[1:] < np.arange(1, len(sk)))
    np.testing.assert_allclose(sk.base, pos[parent[sk.start]])


@pytest.mark.parametrize("max_joints", [1, 5, 24])
def test_skeleton_merges_thin_axes(tree, max_joints):
    pos, parent, radius, mc, *_ = tree
    sk = tree_skeleton(pos, parent, radius, main_child=mc, max_joints=max_joints)
    assert len(sk) == max_joints
    assert sk.start[0] == 1
    # kept axes are the thickest ones
    st = axis_start(parent, mc)
    axes = np.unique(st[1:])
    dropped = np.setdiff1d(axes, sk.start)
    if len(dropped) and max_joints > 1:
        assert radius[dropped].max() <= radius[sk.start[1:]].min()
    # a merged node is bound to the joint of an ancestor's axis
    for i in range(2, len(pos), 7):
        j = sk.joint_of_node[i]
        a = i
        while a > 0 and st[a] != sk.start[j]:
            a = parent[a]
        assert st[a] == sk.start[j]


def test_glb_round_trip(tree, tmp_path):
    pos, parent, radius, mc, m, lv, tips = tree
    p = export_skinned_glb(tmp_path / "t.glb", m, pos, parent, radius, main_child=mc, leaves=lv,
                           leaf_node=tips, max_joints=16)
    g = pygltflib.GLTF2().load(str(p))
    assert len(g.skins) == 1 and len(g.skins[0].joints) == 16
    assert {mt.name for mt in g.materials} == {"Bark", "Leaf"}
    sk = tree_skeleton(pos, parent, radius, main_child=mc, max_joints=16)
    prim = g.meshes[0].primitives[0]
    v = _read(g, prim.attributes.POSITION)
    assert len(v) == len(m.vertices)
    np.testing.assert_allclose(v, m.vertices, atol=1e-5)
    acc = g.accessors[prim.attributes.POSITION]
    np.testing.assert_allclose(acc.min, m.vertices.min(0), atol=1e-5)
    np.testing.assert_allclose(acc.max, m.vertices.max(0), atol=1e-5)
    for pr in g.meshes[0].primitives:
        w = _read(g, pr.attributes.WEIGHTS_0)
        np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-6)
        jt = _read(g, pr.attributes.JOINTS_0)
        assert jt.max() < 16
    np.testing.assert_array_equal(_read(g, prim.attributes.JOINTS_0)[:, 0], sk.joint_of_node[m.node_id])
    lj = _read(g, g.meshes[0].primitives[1].attributes.JOINTS_0)[:, 0]
    np.testing.assert_array_equal(lj, sk.joint_of_node[tips[lv.bud_id]])
    # rest pose: world matrix of every joint times its inverse bind matrix is the identity
    ibm = _read(g, g.skins[0].inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
    world = {}

    def walk(node, parent_m):
        t = np.eye(4)
        t[:3, 3] = g.nodes[node].translation or (0, 0, 0)
        world[node] = parent_m @ t
        for c in g.nodes[node].children or []:
            walk(c, world[node])

    walk(g.skins[0].skeleton, np.eye(4))
    for k, node in enumerate(g.skins[0].joints):
        np.testing.assert_allclose(world[node] @ ibm[k], np.eye(4), atol=1e-5)
    # trimesh reads it too
    sc = trimesh.load(p, process=False)
    assert sum(len(gm.vertices) for gm in sc.geometry.values()) == len(m.vertices) + len(lv.vertices)


def test_growth_animation(tree, tmp_path):
    pos, parent, radius, mc, m, *_ = tree
    p = export_skinned_glb(tmp_path / "a.glb", m, pos, parent, radius, main_child=mc, max_joints=12,
                           duration=4.0, steps=8)
    g = pygltflib.GLTF2().load(str(p))
    an = g.animations[0]
    assert an.name == "growth" and len(an.channels) == 12
    assert {c.target.path for c in an.channels} == {"scale"}
    t = _read(g, an.samplers[0].input)
    np.testing.assert_allclose(t, np.linspace(0, 4, 9))
    sk = tree_skeleton(pos, parent, radius, main_child=mc, max_joints=12)
    first = []
    for c in an.channels:
        s = _read(g, an.samplers[c.sampler].output)
        assert np.all((s >= 0) & (s <= 1)) and np.all(np.diff(s[:, 0]) >= 0)
        assert s[-1, 0] == 1.0
        first.append(np.argmax(s[:, 0] > 0))
    assert first[0] == 1                                       # trunk grows first
    assert np.all(np.diff(np.array(first)[np.argsort(sk.start)]) >= 0)   # joints appear in birth order
    p2 = export_skinned_glb(tmp_path / "b.glb", m, pos, parent, radius, main_child=mc, animate=False)
    assert not pygltflib.GLTF2().load(str(p2)).animations


def test_validation(tree, tmp_path):
    pos, parent, radius, mc, m, lv, tips = tree
    with pytest.raises(ValueError, match="glb"):
        export_skinned_glb(tmp_path / "t.gltf", m, pos, parent, radius)
    with pytest.raises(ValueError, match="max_joints"):
        export_skinned_glb(tmp_path / "t.glb", m, pos, parent, radius, max_joints=0)
    with pytest.raises(ValueError, match="node_id"):
        export_skinned_glb(tmp_path / "t.glb", m, pos[:20], parent[:20], radius[:20])
    with pytest.raises(ValueError, match="leaf_node"):
        export_skinned_glb(tmp_path / "t.glb", m, pos, parent, radius, leaves=lv, leaf_node=tips[:1])
    assert not (tmp_path / "t.glb").exists()

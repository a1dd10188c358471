"""Landscape export: one glTF scene with instancing, read back with trimesh (spec 004 §4.6 item 4)."""
import struct

import numpy as np
import pytest
import trimesh

from plantvr.io.gltf import write_glb
from plantvr.io.landscape import export_distribution, export_forest, export_landscape
from plantvr.landscape import terrain_mesh
from plantvr.landscape import grow_forest
from plantvr.landscape.distribution import Species, distribute


def _yaw(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def test_instanced_landscape_reads_back(tmp_path):
    box = trimesh.creation.box((1.0, 2.0, 1.0))
    cone = trimesh.creation.cone(0.8, 3.0)
    rng = np.random.default_rng(0)
    trees = [(box.vertices, box.faces)] * 6 + [(cone.vertices.copy(), cone.faces)] * 4
    pos, yaw, sc = rng.uniform(0, 20, (10, 3)), rng.uniform(0, 6, 10), rng.uniform(0.5, 2.0, 10)
    hf = rng.uniform(0, 1, (9, 11))
    path = export_landscape(tmp_path / "scene.glb", trees, pos, yaw=yaw, scale=sc, terrain=(hf, (20.0, 20.0)))
    raw = path.read_bytes()
    magic, version, length = struct.unpack("<4sII", raw[:12])
    assert magic == b"glTF" and version == 2 and length == len(raw)
    s = trimesh.load(path, force="scene")
    assert len(s.graph.nodes_geometry) == 11  # 10 trees + terrain
    assert len(s.geometry) == 3 < len(s.graph.nodes_geometry)  # box, cone, terrain: instancing
    expect = [(v * k) @ _yaw(a).T + p for (v, _), p, a, k in zip(trees, pos, yaw, sc)]
    tv, _ = terrain_mesh(hf, (20.0, 20.0))
    allv = np.concatenate(expect + [tv])
    np.testing.assert_allclose(s.bounds, [allv.min(0), allv.max(0)], atol=1e-4)
    for name in ("tree_0", "tree_7"):  # each node's transform = translation * yaw * scale
        T, _ = s.graph[name]
        i = int(name.split("_")[1])
        np.testing.assert_allclose(T[:3, :3], _yaw(yaw[i]) * sc[i], atol=1e-6)
        np.testing.assert_allclose(T[:3, 3], pos[i], atol=1e-9)
    flat = export_landscape(tmp_path / "flat.glb", trees, pos, instancing=False)
    assert len(trimesh.load(flat, force="scene").geometry) == 10


def test_forest_export_one_scene(tmp_path):
    f = grow_forest(4, size=(24.0, 24.0), min_dist=6.0, rounds=1, steps_per_round=4, crown_height=4.0,
                    crown_radius=3.0, seed=5, client="sync", geometry=True, regions="voxels",
                    voxel_shape=(8, 48, 48), sketch={"n_max": 2, "bud_lifetime": 6},
                    params={"activation_threshold": 0.0, "length_mode": "constant"})
    path = export_forest(tmp_path / "forest.glb", f)
    s = trimesh.load(path, force="scene")
    assert len(s.graph.nodes_geometry) == len(f.trees) + 1
    assert len(s.geometry) == len(f.trees) + 1  # grown trees differ: no sharing
    tv, tf = terrain_mesh(f.heights, f.size)
    allv = np.concatenate([m[0] for m in f.meshes] + [tv])
    np.testing.assert_allclose(s.bounds, [allv.min(0), allv.max(0)], atol=1e-4)
    terrain = s.geometry["terrain"]
    assert len(terrain.faces) == len(tf) and terrain.face_normals[:, 1].min() > 0  # up-facing height field
    # the same forest twice in the scene shares meshes; the default tree meshes come from f.meshes
    f2 = type(f)(np.concatenate([f.bases, f.bases + [30.0, 0, 0]]), f.trees * 2, f.heights, f.size,
                 meshes=f.meshes + [(v + [30.0, 0, 0], fc) for v, fc in f.meshes])
    s2 = trimesh.load(export_forest(tmp_path / "twice.glb", f2, terrain=False), force="scene")
    assert len(s2.graph.nodes_geometry) == 2 * len(f.trees) and len(s2.geometry) == len(f.trees)


def test_distribution_export_instances_species(tmp_path):
    sp = [Species(1.0, 0.5, (0.8, 1.2)), Species(0.5, 0.8, (1.0, 1.5))]
    d = distribute(40, sp, {(0, 0): ("cluster", 3.0, 5.0)}, rng=1)
    protos = [(trimesh.creation.cone(1.0, 4.0).vertices, trimesh.creation.cone(1.0, 4.0).faces),
              (trimesh.creation.icosphere(1).vertices + [0, 2, 0], trimesh.creation.icosphere(1).faces)]
    hf = np.zeros((16, 16))
    s = trimesh.load(export_distribution(tmp_path / "d.glb", d, protos, heights=hf, rng=0), force="scene")
    assert len(s.graph.nodes_geometry) == 41 and len(s.geometry) == 3
    with pytest.raises(ValueError, match="prototypes"):
        export_distribution(tmp_path / "e.glb", d, protos[:1])


def test_gltf_validation(tmp_path):
    v, f = np.eye(3), np.array([[0, 1, 2]])
    with pytest.raises(ValueError, match="glb"):
        write_glb(tmp_path / "a.gltf", [{"vertices": v, "faces": f}], [{"mesh": 0}])
    with pytest.raises(ValueError, match="mesh must be an index"):
        write_glb(tmp_path / "a.glb", [{"vertices": v, "faces": f}], [{"mesh": 1}])
    with pytest.raises(ValueError, match="faces"):
        write_glb(tmp_path / "a.glb", [{"vertices": v, "faces": f + 1}], [{"mesh": 0}])
    with pytest.raises(ValueError, match="scale"):
        export_landscape(tmp_path / "a.glb", [(v, f)], np.zeros((1, 3)), scale=np.array([0.0]))
    with pytest.raises(ValueError, match="heights"):
        terrain_mesh(np.zeros((1, 5)), (1.0, 1.0))
    assert not (tmp_path / "a.glb").exists()


def test_forest_export_with_leaves(tmp_path):
    f = grow_forest(3, size=(24.0, 24.0), min_dist=6.0, rounds=1, steps_per_round=4, crown_height=4.0,
                    crown_radius=3.0, seed=6, client="sync", geometry=True, sketch={"n_max": 2, "bud_lifetime": 6},
                    params={"activation_threshold": 0.0, "length_mode": "constant", "tip_radius": 0.03})
    path = export_forest(tmp_path / "leafy.glb", f, leaves=True, params={"tip_radius": 0.03, "leaf_size": 0.5})
    s = trimesh.load(path, force="scene")
    # one node per tree primitive (trimesh splits a mesh's primitives into geometries): bark + leaves + terrain
    assert len(s.graph.nodes_geometry) == 2 * len(f.trees) + 1
    leafy = [g for name, g in s.geometry.items() if len(g.faces) and np.allclose(g.visual.material.baseColorFactor[:3],
                                                                                 [70, 140, 46], atol=2)]
    assert len(leafy) == len(f.trees)
    plain = trimesh.load(export_forest(tmp_path / "bare.glb", f), force="scene")
    assert np.all(s.bounds[1] >= plain.bounds[1] - 1e-9)

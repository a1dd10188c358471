"""``plantvr export TREE_FILE --format usd|glb|ply|obj [--lod N]`` and the model variant (issue 16)."""
import dataclasses

import numpy as np
import pygltflib
import pytest
import trimesh

from plantvr import Model
from plantvr.cli import export_main
from plantvr.geometry.lod import lod_chain
from plantvr.growth.scenarios import demo_session, run
from plantvr.io.tree import bud_nodes, export_model_as, snapshot_export
from plantvr.types import TreeArrays


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = tmp_path_factory.mktemp("tree")
    model = Model(seed=1)
    run(model, demo_session(), 20, range(20))
    return model, model.save(d / "t.tree")


def _chain(model, lod):
    s, p = model.snapshot, model.params
    return lod_chain(s.pos, s.parent, s.radius, main_child=s.main_child, levels=lod + 1, tip_radius=p["tip_radius"],
                     bezier_w=p["bezier_weight"], bark_rate=p["bark_rate"])[lod]


def test_buds_sit_on_nodes(saved):
    model, _ = saved
    nodes = bud_nodes(model.snapshot)
    assert len(nodes) > 0 and (nodes >= 0).all()
    np.testing.assert_array_equal(model.snapshot.pos[nodes], model.snapshot.buds["pos"])


def test_usd_from_tree_file(saved, tmp_path, capsys):
    from pxr import Usd, UsdGeom
    model, src = saved
    out = tmp_path / "t.usdc"
    assert export_main([str(src), "--format", "usd", "-o", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    stage = Usd.Stage.Open(str(out))
    br = UsdGeom.Mesh(stage.GetPrimAtPath("/Tree/Branches"))
    lv = _chain(model, 0)
    assert len(br.GetPointsAttr().Get()) == len(lv.mesh.vertices)
    assert UsdGeom.PointInstancer(stage.GetPrimAtPath("/Tree/Leaves"))
    subsets = UsdGeom.Subset.GetGeomSubsets(br, "face", "branchOrder")
    assert len(subsets) >= 2


@pytest.mark.parametrize("lod", [0, 2])
def test_skinned_glb_at_lod(saved, tmp_path, lod):
    model, src = saved
    out = tmp_path / "t.glb"
    assert export_main([str(src), "--format", "glb", "--lod", str(lod), "-o", str(out)]) == 0
    g = pygltflib.GLTF2().load(str(out))
    assert len(g.skins) == 1 and len(g.skins[0].joints) >= 1
    assert g.animations and g.animations[0].name == "growth"
    assert g.accessors[g.meshes[0].primitives[0].attributes.POSITION].count == len(_chain(model, lod).mesh.vertices)
    names = [m.name for m in g.materials]
    assert names == ["Bark", "Leaf"]


def test_lod_levels_reduce_triangles(saved, tmp_path):
    model, src = saved
    tris = []
    for lod in (0, 1, 3):
        out = tmp_path / f"t{lod}.ply"
        assert export_main([str(src), "--format", "ply", "--lod", str(lod), "-o", str(out), "--no-leaves"]) == 0
        mesh = trimesh.load(out, process=False)
        assert len(mesh.faces) == _chain(model, lod).triangles
        tris.append(len(mesh.faces))
    assert tris[0] > tris[1] > tris[2]


def test_obj_and_default_output(saved, tmp_path):
    _, src = saved
    copy = tmp_path / "tree.tree"
    copy.write_text(src.read_text())
    assert export_main([str(copy), "--format", "obj"]) == 0
    assert (tmp_path / "tree.obj").exists() and (tmp_path / "tree.mtl").exists()
    assert export_main([str(copy)]) == 0                      # default glb beside the tree file
    assert (tmp_path / "tree.glb").stat().st_size > 1000


def test_model_variant_matches_cli(saved, tmp_path):
    model, src = saved
    a = export_model_as(Model.load(src), tmp_path / "a.ply", lod=1)   # .tree reloads nodes in depth-first order
    assert export_main([str(src), "-o", str(tmp_path / "b.ply"), "--lod", "1"]) == 0
    ma, mb = trimesh.load(a, process=False), trimesh.load(tmp_path / "b.ply", process=False)
    np.testing.assert_array_equal(ma.faces, mb.faces)
    np.testing.assert_allclose(ma.vertices, mb.vertices, atol=1e-6)
    c = trimesh.load(export_model_as(model, tmp_path / "c.ply", lod=1), process=False)
    assert len(c.faces) == len(ma.faces)                              # same tree, numbered differently
    np.testing.assert_allclose(c.bounds, ma.bounds, atol=1e-6)


def test_rejections(saved, tmp_path, capsys):
    model, src = saved
    assert export_main([str(tmp_path / "missing.tree"), "--format", "ply"]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert export_main([str(src), "--lod", "7", "-o", str(tmp_path / "x.ply")]) == 2
    assert "lod must be" in capsys.readouterr().err
    assert export_main([str(src), "--lod", "4", "-o", str(tmp_path / "x.ply")]) == 2
    assert "billboard" in capsys.readouterr().err
    assert export_main([str(src), "--lod", "-1", "-o", str(tmp_path / "x.ply")]) == 2
    assert "lod must be" in capsys.readouterr().err
    assert not (tmp_path / "x.ply").exists()
    assert export_main([str(src), "--format", "usd", "-o", str(tmp_path / "x.ply")]) == 2
    assert "does not match" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        export_main([str(src), "--format", "fbx"])
    with pytest.raises(ValueError, match="suffix"):
        snapshot_export(model.snapshot, model.params, tmp_path / "x.stl")
    with pytest.raises(ValueError, match="empty"):
        snapshot_export(dataclasses.replace(model.snapshot, tree=TreeArrays.from_arrays(np.zeros((1, 3)), [-1])),
                        model.params, tmp_path / "x.ply")


def test_billboard_level(saved, tmp_path):
    """--lod 4 writes the billboard impostor: crossed quads with an RGBA atlas."""
    model, src = saved
    out = tmp_path / "bb.glb"
    assert export_main([str(src), "--format", "glb", "--lod", "4", "-o", str(out)]) == 0
    mesh = trimesh.load(out, force="mesh", process=False)
    assert len(mesh.faces) == 4
    atlas = np.asarray(mesh.visual.material.baseColorTexture)
    assert atlas.shape == (256, 512, 4) and atlas[..., 3].min() == 0 and atlas[..., 3].max() == 255
    lo, hi = _chain(model, 0).mesh.vertices.min(0), _chain(model, 0).mesh.vertices.max(0)
    assert mesh.bounds[1][1] >= hi[1] - 1e-6 and mesh.bounds[0][1] <= lo[1] + 1e-6

"""Export to PLY, OBJ and glTF, and the procedural textures (spec 000_treewand §3.3, §3.4; issue 4)."""
import numpy as np
import pytest
import trimesh

from plantvr.geometry.textures import BARK_TEXTURES, LEAF_TEXTURES, bark_texture, leaf_texture
from plantvr.io.tree import export_tree

from ._trees import leafy_tree


@pytest.fixture(scope="module")
def meshes():
    *_, m, lv, _ = leafy_tree(60, seed=5)
    return m, lv


def test_glb_round_trip_has_uv_normals_and_textures(meshes, tmp_path):
    m, lv = meshes
    p = export_tree(tmp_path / "tree.glb", m, lv, bark="birch", leaf="lobed")
    sc = trimesh.load(p, process=False)
    assert set(sc.geometry) == {"bark", "leaves"}
    bark = sc.geometry["bark"]
    assert len(bark.vertices) == len(m.vertices) and len(bark.faces) == len(m.faces)
    np.testing.assert_allclose(bark.vertices, m.vertices, atol=1e-5)
    np.testing.assert_allclose(bark.visual.uv, m.uv, atol=1e-5)
    np.testing.assert_allclose(bark.vertex_normals, m.normals, atol=1e-3)
    assert bark.visual.material.baseColorTexture.size == (256, 256)
    assert sc.geometry["leaves"].visual.material.doubleSided


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
def test_ply_obj_round_trip(meshes, tmp_path, suffix):
    m, lv = meshes
    p = export_tree(tmp_path / ("tree" + suffix), m, lv)
    back = trimesh.load(p, process=False, force="mesh")
    assert len(back.faces) == len(m.faces) + len(lv.faces)
    assert np.isfinite(back.vertices).all()


def test_textures_are_distinct_and_tileable():
    for name in BARK_TEXTURES:
        img = bark_texture(name, 64)
        assert img.shape == (64, 64, 4) and img.dtype == np.uint8 and (img[..., 3] == 255).all()
        assert abs(int(img[0, :, :3].mean()) - int(img[-1, :, :3].mean())) < 40    # wraps top/bottom
    assert not np.array_equal(bark_texture("furrowed"), bark_texture("birch"))
    for name in LEAF_TEXTURES:
        img = leaf_texture(name, 128)
        assert 0.2 < (img[..., 3] > 0).mean() < 0.9
        assert img[-1, 64, 3] == 255 and img[-1, 0, 3] == 0                       # stem texel, clear corner
    with pytest.raises(ValueError, match="name must be one of"):
        bark_texture("oak")


def test_export_rejects_unknown_format(meshes, tmp_path):
    m, _ = meshes
    with pytest.raises(ValueError, match="path suffix must be one of"):
        export_tree(tmp_path / "tree.stl", m)
    with pytest.raises(ValueError, match="bark must be one of"):
        export_tree(tmp_path / "tree.glb", m, bark="oak")

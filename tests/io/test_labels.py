"""plantvr.io.labels: segmentation PLY/glTF, per-label meshes and the label table on the one writers (issue 21)."""
import json

import numpy as np
import pandas as pd
import pygltflib
import pytest
import trimesh

from plantvr.documents.labels import Segmentation
from plantvr.io import labels as IO


@pytest.fixture()
def seg():
    s = trimesh.creation.icosphere(2)
    lab = np.where(s.vertices[:, 2] > 0.2, 2, np.where(s.vertices[:, 0] > 0, 1, 0)).astype(np.uint8)
    return Segmentation(s.vertices, s.faces, labels=lab)


def test_export_ply_colours_and_labels(seg, tmp_path):
    IO.export_ply(seg, tmp_path / "s.ply")
    m = trimesh.load(tmp_path / "s.ply", process=False)
    np.testing.assert_array_equal(m.faces, seg.faces)
    np.testing.assert_allclose(m.vertices, seg.vertices, atol=1e-6)
    np.testing.assert_array_equal(np.asarray(m.visual.vertex_colors), seg.vertex_colors())
    raw = m.metadata["_ply_raw"]["vertex"]["data"]
    np.testing.assert_array_equal(raw["label"].ravel(), seg.labels)
    IO.export_ply(seg, tmp_path / "n.ply", with_labels=False)
    assert "label" not in trimesh.load(tmp_path / "n.ply", process=False).metadata["_ply_raw"]["vertex"]["data"].dtype.names


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_export_gltf_colours_read_by_trimesh_and_pygltflib(seg, tmp_path, suffix):
    p = tmp_path / f"s{suffix}"
    IO.export_gltf(seg, p)
    m = trimesh.load(p, force="mesh", process=False)
    assert len(m.vertices) == seg.n_vertices and len(m.faces) == len(seg.faces)
    np.testing.assert_array_equal(np.asarray(m.visual.vertex_colors), seg.vertex_colors())
    g = pygltflib.GLTF2().load(str(p))
    acc = g.accessors[g.meshes[0].primitives[0].attributes.COLOR_0]
    assert acc.normalized and acc.componentType == pygltflib.UNSIGNED_BYTE and acc.type == "VEC4"
    if suffix == ".gltf":
        assert json.loads(p.read_text())["buffers"][0]["uri"] == "s.bin" and (tmp_path / "s.bin").exists()
    with pytest.raises(ValueError, match="glb"):
        IO.export_gltf(seg, tmp_path / "s.obj")


@pytest.mark.parametrize("fmt", ["ply", "obj", "glb"])
def test_export_label_meshes(seg, tmp_path, fmt):
    out = IO.export_label_meshes(seg, tmp_path, fmt=fmt)
    assert sorted(out) == [0, 1, 2]
    for k, p in out.items():
        m = trimesh.load(p, force="mesh", process=False)
        full = np.all(seg.labels[seg.faces] == k, axis=1)
        assert len(m.faces) == full.sum()
        np.testing.assert_array_equal(np.asarray(m.visual.vertex_colors)[:, :3],
                                      np.repeat(seg.colors.rgba[k][None, :3], len(m.vertices), axis=0))
    assert IO.export_label_meshes(seg, tmp_path, which=[2], prefix="part") == {2: str(tmp_path / "part_002.ply")}


def test_export_label_table(seg, tmp_path):
    IO.export_label_table(seg, tmp_path / "t.csv", names={1: "ray"})
    t = pd.read_csv(tmp_path / "t.csv", keep_default_na=False)
    assert t["label"].tolist() == [0, 1, 2] and t["name"].tolist() == ["", "ray", ""]
    assert int(t["vertices"].sum()) == seg.n_vertices


def test_uint16_labels_write_a_ushort_label_property(tmp_path):
    import trimesh

    from plantvr.io.ply import write_ply
    m = trimesh.creation.icosphere(1)
    labels = (np.arange(len(m.vertices)) * 97 % 918).astype(np.uint16)
    p = tmp_path / "wide.ply"
    write_ply(p, m.vertices.astype(np.float32), m.faces, labels=labels)
    head = p.read_bytes().split(b"end_header")[0]
    assert b"property ushort label" in head
    back = trimesh.load(p, process=False)
    np.testing.assert_array_equal(np.asarray(back.metadata["_ply_raw"]["vertex"]["data"]["label"]), labels)

"""plantvr.io.obj: the one OBJ writer (materials, vertex colours, sequences), read back by trimesh (issue 21)."""
from pathlib import Path

import numpy as np
import pytest
import trimesh

from plantvr.io.obj import write_obj, write_obj_sequence
from plantvr.subdivision import read_obj


def test_materials_write_mtl_and_textures_first(tmp_path):
    box = trimesh.creation.box()
    uv = np.random.default_rng(0).uniform(0, 1, (len(box.vertices), 2))
    img = np.zeros((4, 4, 4), np.uint8)
    p = write_obj(tmp_path / "b.obj", box.vertices, box.faces, uv, normals=box.vertex_normals, name="box",
                  materials=[("a", 4, img), ("b", len(box.faces) - 4, img[..., :3])])
    assert sorted(x.name for x in tmp_path.iterdir()) == ["b.mtl", "b.obj", "b_a.png", "b_b.png"]
    text = p.read_text()
    assert "mtllib b.mtl" in text and text.count("usemtl") == 2
    back = trimesh.load(p, force="mesh", process=False)
    assert len(back.faces) == len(box.faces)
    V, _, T = read_obj(p)
    np.testing.assert_array_equal(V, box.vertices)
    np.testing.assert_array_equal(T, uv[box.faces])
    with pytest.raises(ValueError, match="add up"):
        write_obj(tmp_path / "c.obj", box.vertices, box.faces, materials=[("a", 1, img)])
    assert not (tmp_path / "c.obj").exists()


def test_vertex_colours_read_by_trimesh(tmp_path):
    box = trimesh.creation.box()
    c = np.tile(np.array([[255, 0, 128, 255]], np.uint8), (len(box.vertices), 1))
    back = trimesh.load(write_obj(tmp_path / "c.obj", box.vertices, box.faces, normals=False, colors=c),
                        force="mesh", process=False)
    np.testing.assert_array_equal(np.asarray(back.visual.vertex_colors), c)


def test_sequence_bytes_and_stale_frames(tmp_path):
    faces = np.array([[0, 1, 2]])
    frames = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 0.1, 0]], [[0.0, 0, 1], [1, 0, 1], [0, 0.1, 1]]])
    paths = write_obj_sequence(str(tmp_path), faces, frames, fixed=np.array([0]))
    assert Path(paths[1]).read_text() == "v 0.0 0.0 1.0\nv 1.0 0.0 1.0\nv 0.0 0.1 1.0\nf 1 2 3\n"
    assert (tmp_path / "weight.txt").read_text() == "0\n"
    write_obj_sequence(str(tmp_path), faces, frames[:1])
    assert sorted(x.name for x in tmp_path.iterdir()) == ["frame_0000.obj", "weight.txt"]
    with pytest.raises(ValueError, match="prefix"):
        write_obj_sequence(str(tmp_path), faces, frames, prefix="a1")

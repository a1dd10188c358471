import numpy as np
import pytest
import trimesh

from plantvr.io.ply import write_ply


def test_chunked_writer_is_byte_identical_and_read_by_trimesh(surface, tmp_path):
    rng = np.random.default_rng(0)
    cols = rng.integers(0, 256, (len(surface.vertices), 3)).astype(np.uint8)
    lab = rng.integers(0, 9, len(surface.vertices)).astype(np.uint8)
    write_ply(tmp_path / "a.ply", surface.vertices, surface.faces, colors=cols, labels=lab, normals=surface.normals)
    write_ply(tmp_path / "b.ply", surface.vertices, surface.faces, colors=cols, labels=lab, normals=surface.normals,
              chunk=777)
    assert (tmp_path / "a.ply").read_bytes() == (tmp_path / "b.ply").read_bytes()
    m = trimesh.load(tmp_path / "b.ply", process=False)
    assert np.array_equal(np.asarray(m.vertices, np.float32), surface.vertices)
    assert np.array_equal(m.faces, surface.faces.astype(np.int64))
    assert np.array_equal(m.visual.vertex_colors[:, :3], cols)


def test_write_ply_rejects_bad_input(tmp_path):
    v = np.zeros((3, 3), np.float32)
    with pytest.raises(ValueError, match="faces must index"):
        write_ply(tmp_path / "x.ply", v, np.array([[0, 1, 3]]))
    with pytest.raises(ValueError, match="colors must be uint8"):
        write_ply(tmp_path / "x.ply", v, np.array([[0, 1, 2]]), colors=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="chunk"):
        write_ply(tmp_path / "x.ply", v, np.array([[0, 1, 2]]), chunk=0)

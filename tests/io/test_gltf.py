"""plantvr.io.gltf: the one glTF buffer packer and document builder behind every .glb PlantVR writes."""
import numpy as np
import pytest

from plantvr.io.gltf import ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, GltfBuffer, check_glb_path


def test_views_are_4_byte_aligned_and_round_trip():
    b = GltfBuffer()
    j = np.arange(12, dtype=np.uint8).reshape(3, 4)                  # 12 bytes
    s = np.array([1, 2, 3], np.uint16)                                # 6 bytes: next view is padded
    v = np.array([[0.5, -1.0, 2.0], [3.0, 4.0, -5.0]], np.float32)
    idx = [b.add(j, "VEC4", target=ARRAY_BUFFER), b.add(s, "SCALAR", target=ELEMENT_ARRAY_BUFFER),
           b.add(v, "VEC3", target=ARRAY_BUFFER, minmax=True), b.add(np.eye(4, dtype=np.float32), "MAT4")]
    assert idx == [0, 1, 2, 3]
    blob = b.blob()
    assert len(blob) % 4 == 0 and all(view["byteOffset"] % 4 == 0 for view in b.views)
    assert [a["componentType"] for a in b.accessors] == [5121, 5123, 5126, 5126]
    assert [a["count"] for a in b.accessors] == [3, 3, 2, 1]
    assert "target" not in b.views[3] and b.views[1]["target"] == ELEMENT_ARRAY_BUFFER
    assert b.accessors[2]["min"] == [0.5, -1.0, -5.0] and b.accessors[2]["max"] == [3.0, 4.0, 2.0]
    for arr, view in zip((j, s, v), b.views):
        got = np.frombuffer(blob, arr.dtype, arr.size, view["byteOffset"]).reshape(arr.shape)
        np.testing.assert_array_equal(got, arr)
        assert view["byteLength"] == arr.nbytes


def test_rejects_unsupported_dtype_and_type():
    b = GltfBuffer()
    with pytest.raises(ValueError, match="arr must be float32, uint32, uint16 or uint8, got float64"):
        b.add(np.zeros(3), "SCALAR")
    with pytest.raises(ValueError, match="atype must be one of"):
        b.add(np.zeros(3, np.float32), "VEC5")
    assert b.views == [] and b.accessors == [] and b.blob() == b""


def test_check_glb_path(tmp_path):
    assert check_glb_path(str(tmp_path / "a.GLB")) == tmp_path / "a.GLB"
    with pytest.raises(ValueError, match=r"path must end in .glb, got '.gltf'"):
        check_glb_path(tmp_path / "a.gltf")

"""Point-cloud readers (issue 22): .xyz/.txt/.csv columns, .ply (written by trimesh), .las (written by laspy)."""
import numpy as np
import pytest
import trimesh

from plantvr.io.points import points_as_markers, read_points


@pytest.fixture
def cloud():
    return np.random.default_rng(0).normal(size=(500, 3)) * [2.0, 2.0, 1.0] + [0, 0, 5.0]


def test_text_flavours(tmp_path, cloud):
    np.savetxt(tmp_path / "a.xyz", cloud)
    np.savetxt(tmp_path / "b.txt", np.column_stack([cloud, np.arange(500)]), header="x y z intensity", comments="")
    np.savetxt(tmp_path / "c.csv", cloud, delimiter=",", header="X,Y,Z", comments="")
    np.savetxt(tmp_path / "d.txt", np.column_stack([np.arange(500), cloud]))
    for name in ("a.xyz", "b.txt", "c.csv"):
        np.testing.assert_allclose(read_points(tmp_path / name), cloud, rtol=1e-15)
    np.testing.assert_allclose(read_points(tmp_path / "d.txt", columns=(1, 2, 3)), cloud, rtol=1e-15)


def test_ply_written_by_trimesh(tmp_path, cloud):
    trimesh.PointCloud(cloud).export(tmp_path / "p.ply")
    trimesh.PointCloud(cloud).export(tmp_path / "q.ply", encoding="ascii")
    np.testing.assert_allclose(read_points(tmp_path / "p.ply"), cloud)
    np.testing.assert_allclose(read_points(tmp_path / "q.ply"), cloud, atol=1e-7)  # ascii: 8 digits


def test_las_written_by_laspy(tmp_path, cloud):
    laspy = pytest.importorskip("laspy")
    for fmt in (0, 3, 6):
        h = laspy.LasHeader(point_format=fmt, version="1.4" if fmt >= 6 else "1.2")
        h.scales = np.array([0.001, 0.001, 0.001])
        h.offsets = cloud.min(axis=0)
        las = laspy.LasData(h)
        las.x, las.y, las.z = cloud[:, 0], cloud[:, 1], cloud[:, 2]
        las.write(tmp_path / f"s{fmt}.las")
        np.testing.assert_allclose(read_points(tmp_path / f"s{fmt}.las"), cloud, atol=6e-4)


def test_bad_point_files(tmp_path):
    with pytest.raises(ValueError, match="must end in"):
        read_points(tmp_path / "a.obj")
    with pytest.raises(ValueError, match="does not exist"):
        read_points(tmp_path / "a.xyz")
    (tmp_path / "b.xyz").write_text("1 2 3\n4 5 nan\n")
    with pytest.raises(ValueError, match="finite|NaN"):
        read_points(tmp_path / "b.xyz")
    (tmp_path / "c.xyz").write_text("1 2\n")
    with pytest.raises(ValueError, match="cannot read"):
        read_points(tmp_path / "c.xyz")
    (tmp_path / "d.las").write_bytes(b"LASF" + b"\0" * 50)
    pytest.importorskip("laspy")
    with pytest.raises(ValueError, match="cannot read"):
        read_points(tmp_path / "d.las")
    np.savetxt(tmp_path / "e.xyz", np.zeros((10, 3)))
    with pytest.raises(ValueError, match="max_points"):
        read_points(tmp_path / "e.xyz", max_points=5)


def test_points_as_markers(tmp_path, cloud):
    import plantvr

    m = plantvr.Model(seed=0)
    np.savetxt(tmp_path / "crown.xyz", cloud[:, [0, 2, 1]])  # y up
    assert points_as_markers(m, tmp_path / "crown.xyz") == 500
    assert m.latest.markers.shape[0] >= 500 or m.n_markers >= 500
    m.undo()


def test_laz_written_by_laspy_with_lazrs(tmp_path, cloud):
    laspy = pytest.importorskip("laspy")
    pytest.importorskip("lazrs")
    h = laspy.LasHeader(point_format=3, version="1.2")
    h.scales = np.array([0.001, 0.001, 0.001])
    h.offsets = cloud.min(axis=0)
    las = laspy.LasData(h)
    las.x, las.y, las.z = cloud[:, 0], cloud[:, 1], cloud[:, 2]
    las.write(tmp_path / "s.laz", laz_backend=laspy.LazBackend.Lazrs)
    back = laspy.read(tmp_path / "s.laz")
    assert back.header.point_format.id == 3 and back.header.are_points_compressed
    pts = read_points(tmp_path / "s.laz")
    np.testing.assert_array_equal(pts, np.column_stack([back.x, back.y, back.z]))
    np.testing.assert_allclose(pts, cloud, atol=6e-4)

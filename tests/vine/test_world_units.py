"""World units in ViNE (issue 22): a volume's spacing and origin carry into the surface, the brush, the review
app's re-meshing, bundles and ``plantvr segment``; VTK's own contour of the same image data is the oracle."""
import json
import os
import zipfile

import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantvr.documents import labels_bundle as B
from plantvr.documents.labels import Segmentation

SPACING, ORIGIN = (0.5, 0.5, 2.0), (10.0, -3.0, 5.0)


@pytest.fixture(scope="module")
def box():
    """A uint8 box of voxels [4, 19] x [6, 13] x [3, 8] (value 200) in a 24 x 20 x 12 grid."""
    vol = np.zeros((24, 20, 12), np.uint8)
    vol[4:20, 6:14, 3:9] = 200
    return vol


def test_anisotropic_volume_gives_surface_in_physical_extent(box):
    seg = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    # the iso-surface crosses half-way between the last inside voxel and the first outside one
    lo_idx, hi_idx = np.array([3.5, 5.5, 2.5]), np.array([19.5, 13.5, 8.5])
    sp, org = np.array(SPACING), np.array(ORIGIN)
    assert np.allclose(seg.vertices.min(0), org + sp * lo_idx, atol=1e-5)
    assert np.allclose(seg.vertices.max(0), org + sp * hi_idx, atol=1e-5)
    assert seg.spacing == SPACING and seg.origin == ORIGIN
    vox = Segmentation.from_volume(box, 100.0)               # same topology, voxel units
    assert np.array_equal(vox.faces, seg.faces) and vox.spacing == (1.0, 1.0, 1.0)
    assert np.allclose(vox.vertices * sp + org, seg.vertices, atol=1e-5)


def test_surface_matches_vtk_contour_of_the_image_data():
    pv = pytest.importorskip("pyvista")
    x, y, z = np.meshgrid(np.arange(30), np.arange(26), np.arange(14), indexing="ij")
    field = (np.sqrt(((x - 15) * SPACING[0]) ** 2 + ((y - 12) * SPACING[1]) ** 2 + ((z - 7) * SPACING[2]) ** 2)
             ).astype(np.float32)
    seg = Segmentation.from_volume(field, 5.0, spacing=SPACING, origin=ORIGIN)
    grid = pv.ImageData(dimensions=field.shape, spacing=SPACING, origin=ORIGIN)
    grid.point_data["f"] = field.ravel(order="F")
    ref = grid.contour([5.0], scalars="f")
    assert np.allclose(np.reshape(ref.bounds, (3, 2)).T, [seg.vertices.min(0), seg.vertices.max(0)], atol=1e-4)
    d, _ = cKDTree(seg.vertices).query(np.asarray(ref.points))
    assert d.max() < 1e-4                                    # the same vertices, in the same world frame
    r = np.linalg.norm(seg.vertices - (np.array(ORIGIN) + np.array(SPACING) * [15, 12, 7]), axis=1)
    assert abs(np.median(r) - 5.0) < 0.1                     # a sphere of radius 5 in physical units


def test_frog_tissue_surface_in_millimetres():
    pv = pytest.importorskip("pyvista")
    from pyvista import examples

    from plantvr.io.volume import read_volume
    vol = read_volume(os.path.join(os.path.dirname(examples.__file__), "frog_tissues.vti"))
    assert tuple(vol.spacing) == (1.0, 1.0, 1.5)
    crop = (vol.array[200:280, 200:280, 40:90] == 1).astype(np.uint8) * 255    # one tissue, a small block
    org = vol.to_physical(np.array([[200, 200, 40]]))[0]
    seg = Segmentation.from_volume(crop, 127.5, spacing=vol.spacing, origin=org)
    grid = pv.ImageData(dimensions=crop.shape, spacing=vol.spacing, origin=org)
    grid.point_data["t"] = crop.ravel(order="F")
    ref = grid.contour([127.5], scalars="t")
    assert np.allclose(np.reshape(ref.bounds, (3, 2)).T, [seg.vertices.min(0), seg.vertices.max(0)], atol=1e-4)


def test_downsampled_surface_stays_in_place(box):
    full = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    half = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN, downsample=True)
    assert half.spacing == (1.0, 1.0, 4.0)
    assert half.origin == (10.25, -2.75, 6.0)
    # the box's faces lie on even voxel boundaries, so the coarse surface is where the fine one is
    assert np.allclose(half.vertices.min(0), full.vertices.min(0), atol=1e-5)
    assert np.allclose(half.vertices.max(0), full.vertices.max(0), atol=1e-5)


def test_painting_by_world_position(box):
    seg = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    c = np.array([10.0 + 0.5 * 12, -3.0 + 0.5 * 13.5, 5.0 + 2.0 * 6])   # on the box's +y face
    r = 1.5                                                                # physical units, as the spacing
    n = seg.paint(c, r, 3)
    want = np.linalg.norm(seg.vertices.astype(np.float64) - c, axis=1) <= r
    assert n == want.sum() > 0 and np.array_equal(seg.labels == 3, want)
    # anisotropic: the ball is 3 voxels across in x and y but under one voxel in z
    idx = (seg.vertices[seg.labels == 3] - np.array(ORIGIN)) / np.array(SPACING)
    assert np.ptp(idx[:, 0]) > 4 and np.ptp(idx[:, 2]) <= 1.5


def test_grid_is_checked_before_meshing(box):
    for kw, match in [({"spacing": (1, 0, 1)}, "spacing must be positive"),
                      ({"spacing": (1, 1)}, "spacing must have shape"),
                      ({"origin": (0, np.nan, 0)}, "origin"), ({"origin": (0, 0, 1e9)}, "origin"),
                      ({"downsample": 1}, "downsample must be True or False")]:
        with pytest.raises(ValueError, match=match):
            Segmentation.from_volume(box, 100.0, **kw)


def test_bundle_remeshes_in_world_units(tmp_path, box):
    seg = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    seg.paint(seg.vertices[0].astype(np.float64), 1.0, 2)
    p = tmp_path / "w.vine.zip"
    B.save_bundle(p, seg, volume=box, level=100.0, include_mesh=False)     # the grid comes from the document
    b = B.load_bundle(p, volume=box)
    assert b.spacing == SPACING and b.origin == ORIGIN
    assert b.segmentation.spacing == SPACING and b.segmentation.origin == ORIGIN
    assert np.array_equal(b.segmentation.vertices, seg.vertices)
    assert np.array_equal(b.segmentation.labels, seg.labels)
    with pytest.raises(ValueError, match="origin"):
        B.save_bundle(tmp_path / "x.zip", seg, volume=box, level=100.0, origin=(0, 0, np.inf))
    target = Segmentation.from_volume(box, 100.0)                          # restore takes the grid too
    B.restore_bundle(target, p, volume=box)
    assert target.origin == ORIGIN and np.array_equal(target.vertices, seg.vertices)


def _rewrite_without_origin(src, dst):
    """A bundle as saved before origins were recorded: the manifest without ``origin``, checksum redone."""
    with zipfile.ZipFile(src) as z:
        members = [(n, z.read(n)) for n in z.namelist()]
    man = json.loads(members[0][1])
    del man["origin"]
    members[0] = ("manifest.json", json.dumps(man, sort_keys=True, indent=1).encode())
    with zipfile.ZipFile(dst, "w") as z:
        for n, data in members:
            z.writestr(n, data)
        z.comment = f"{B._MAGIC} sha256={B._digest(members)}".encode()


def test_older_bundle_without_origin_loads_as_before(tmp_path, box):
    seg = Segmentation.from_volume(box, 100.0)
    B.save_bundle(tmp_path / "new.zip", seg, volume=box, level=100.0, include_mesh=False)
    _rewrite_without_origin(tmp_path / "new.zip", tmp_path / "old.zip")
    b = B.load_bundle(tmp_path / "old.zip", volume=box)
    assert b.origin == (0.0, 0.0, 0.0) and b.spacing == (1.0, 1.0, 1.0)
    assert np.array_equal(b.segmentation.vertices, seg.vertices)


def test_plantvr_segment_reads_spacing_and_origin(tmp_path, box):
    nrrd = pytest.importorskip("nrrd")
    from plantvr.io.source import open_source
    nrrd.write(str(tmp_path / "b.nrrd"), box, {"space": "left-posterior-superior",
                                              "space directions": np.diag(SPACING),
                                              "space origin": np.array(ORIGIN)})
    src = open_source(str(tmp_path / "b.nrrd"), level=100.0)
    want = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    assert src.seg.spacing == SPACING and src.seg.origin == ORIGIN
    assert np.allclose(src.seg.vertices.min(0), want.vertices.min(0), atol=1e-5)
    assert np.allclose(src.seg.vertices.max(0), want.vertices.max(0), atol=1e-5)
    ds = open_source(str(tmp_path / "b.nrrd"), level=100.0, downsample=True)
    assert ds.seg.spacing == (1.0, 1.0, 4.0) and ds.volume.shape == (12, 10, 6)
    assert np.allclose(ds.seg.vertices.min(0), want.vertices.min(0), atol=1e-5)


def test_review_app_remeshes_on_the_same_grid(box):
    pytest.importorskip("trame")
    from plantvr.view.vine_app import VineReviewApp
    app = VineReviewApp(volume=box, level=100.0, spacing=SPACING, origin=ORIGIN, target_faces=10_000,
                        interactive_faces=None)
    try:
        assert app.seg.origin == ORIGIN
        assert np.allclose(app.seg.vertices.min(0), np.array(ORIGIN) + np.array(SPACING) * [3.5, 5.5, 2.5],
                           atol=1e-5)
        app.state.level = 150.0
        app.apply_level()                                    # the slider re-meshes in the same units
        assert app.seg.spacing == SPACING and app.seg.origin == ORIGIN
        assert np.allclose(app.seg.vertices.max(0), np.array(ORIGIN) + np.array(SPACING) * [19.25, 13.25, 8.25],
                           atol=1e-5)
        c = app.seg.vertices[0].astype(np.float64)
        n = app.paint_world(c, radius=0.6, label=2)          # the brush radius in physical units
        want = np.linalg.norm(app.seg.vertices.astype(np.float64) - c, axis=1) <= 0.6
        assert n == want.sum() > 0 and np.array_equal(app.seg.labels == 2, want)
        assert 0 < app.state.radius_step <= 0.01
    finally:
        app.view.close()


def test_session_file_keeps_spacing_and_origin(box, tmp_path):
    seg = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    seg.paint(seg.vertices[0], 2.0, 3)
    back = Segmentation.load(seg.save(tmp_path / "s.npz"))
    assert back.spacing == SPACING and back.origin == ORIGIN
    assert np.array_equal(back.labels, seg.labels) and np.array_equal(back.vertices, seg.vertices)
    other = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    other.restore(seg.save(tmp_path / "l.npz", include_mesh=False))
    assert other.spacing == SPACING and np.array_equal(other.labels, seg.labels)


@pytest.mark.parametrize("grid", [np.array([0.5, 0.5, -2.0, 0, 0, 0]), np.array([1.0, 1, 1, np.nan, 0, 0]),
                                  np.zeros(5), np.ones(6, np.float32)])
def test_crafted_grid_in_session_file_is_refused_and_changes_nothing(box, tmp_path, grid):
    seg = Segmentation.from_volume(box, 100.0, spacing=SPACING, origin=ORIGIN)
    d = dict(np.load(seg.save(tmp_path / "s.npz")))
    d["grid"] = grid
    np.savez(tmp_path / "bad.npz", **d)
    before = seg.labels.copy()
    with pytest.raises(ValueError, match="grid|spacing|origin"):
        seg.restore(tmp_path / "bad.npz")
    with pytest.raises(ValueError, match="grid|spacing|origin"):
        Segmentation.load(tmp_path / "bad.npz")
    assert seg.spacing == SPACING and np.array_equal(seg.labels, before)


def test_session_file_without_grid_loads_in_voxel_units(box, tmp_path):
    seg = Segmentation.from_volume(box, 100.0)
    d = dict(np.load(seg.save(tmp_path / "s.npz")))
    del d["grid"]
    np.savez(tmp_path / "old.npz", **d)
    assert Segmentation.load(tmp_path / "old.npz").spacing == (1.0, 1.0, 1.0)

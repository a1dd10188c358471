"""Label volumes (issue 22): one watertight surface per cell with shared walls and the voxel count's volume,
painted labels back to voxels (parity kernel = numpy twin = trimesh's oracle), and the round trip
volume -> surfaces -> paint -> label volume -> .tif/.nrrd/.nii.gz -> read back by each format's own library,
on pyvista's frog tissue labels (shipped in the pip package) and on a 918-cell uint16 volume."""
import os

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from plantvr.documents.labels import Segmentation
from plantvr.io.label_volume import write_label_volume
from plantvr.vine import label_volumes as LV
from plantvr.vine.colors import ColorTable

SPACING, ORIGIN = (0.5, 0.7, 1.1), (3.0, -2.0, 1.0)


def _cells(n=40, k=16, first=1, rng=0, dtype=np.uint16):
    """Voronoi cells of k seeds in an n^3 box with a background rim (every cell interior)."""
    rng = np.random.default_rng(rng)
    seeds = rng.uniform(2, n - 2, (k, 3))
    g = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    _, lab = cKDTree(seeds).query(g)
    vol = (lab + first).reshape(n, n, n).astype(dtype)
    vol[[0, -1]] = 0
    vol[:, [0, -1]] = 0
    vol[:, :, [0, -1]] = 0
    return vol


@pytest.fixture(scope="module")
def cells():
    return _cells()


@pytest.fixture(scope="module")
def surfaces(cells):
    return LV.surfaces_from_labels(cells, spacing=SPACING, origin=ORIGIN)


def test_one_watertight_surface_per_cell_with_the_voxel_volume(cells, surfaces):
    assert sorted(surfaces) == sorted(set(np.unique(cells)) - {0})
    voxel = float(np.prod(SPACING))
    for lab, s in surfaces.items():
        m = trimesh.Trimesh(s.vertices, s.faces, process=False)
        assert m.is_watertight and m.is_winding_consistent, lab
        assert abs(m.volume / (np.sum(cells == lab) * voxel) - 1) < 0.01, lab      # positive: wound outward
        assert np.mean(np.einsum("ij,ij->i", s.normals, m.vertex_normals) > 0) > 0.99   # normals point out
    # upsample=1: a quarter of the vertices, the volume still within 2.5 %
    coarse = LV.surfaces_from_labels(cells, spacing=SPACING, origin=ORIGIN, upsample=1)
    for lab, s in coarse.items():
        m = trimesh.Trimesh(s.vertices, s.faces, process=False)
        assert m.is_watertight and abs(m.volume / (np.sum(cells == lab) * voxel) - 1) < 0.025


def test_neighbouring_cells_share_their_walls(cells, surfaces):
    keys = {lab: set(map(bytes, s.vertices)) for lab, s in surfaces.items()}
    s, o = np.array(SPACING), np.array(ORIGIN)
    shared = 0
    for lab, srf in surfaces.items():
        idx = (srf.vertices.astype(np.float64) - o) / s
        half = np.isclose(idx % 1.0, 0.5, atol=1e-4)
        on_wall = half.sum(1) == 1                       # on one voxel edge's midpoint plane
        for v, i, h in zip(srf.vertices[on_wall], idx[on_wall], half[on_wall]):
            a = np.rint(np.where(h, i - 0.5, i)).astype(int)
            b = a + h
            other = int(cells[tuple(b)]) if cells[tuple(a)] == lab else int(cells[tuple(a)])
            if other and other != lab:
                assert bytes(v) in keys[other], (lab, other)
                shared += 1
    assert shared > 1000


def test_labels_subset_and_door_checks(cells):
    two = LV.surfaces_from_labels(cells, labels=[3, 5])
    assert sorted(two) == [3, 5]
    with pytest.raises(ValueError, match="not in the volume"):
        LV.surfaces_from_labels(cells, labels=[999])
    with pytest.raises(ValueError, match="volume must be a 3-D integer"):
        LV.surfaces_from_labels(cells.astype(np.float32))
    with pytest.raises(ValueError, match="spacing must be"):
        LV.surfaces_from_labels(cells, spacing=(1, 0, 1))
    with pytest.raises(ValueError, match="upsample must be"):
        LV.surfaces_from_labels(cells, upsample=0)


def test_parity_kernel_twin_and_trimesh_oracle():
    vol = _cells(n=16, k=3)
    srf = LV.surfaces_from_labels(vol, spacing=SPACING, origin=ORIGIN, labels=[1], upsample=1)[1]
    a = LV.inside_mask(srf, vol.shape, spacing=SPACING, origin=ORIGIN)
    b = LV.inside_mask(srf, vol.shape, spacing=SPACING, origin=ORIGIN, kernel=False)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, vol == 1)
    pv = pytest.importorskip("pyvista")                 # VTK's enclosed-points filter as the library oracle
    g = np.stack(np.meshgrid(*[np.arange(n) for n in vol.shape], indexing="ij"), -1).reshape(-1, 3)
    pts = pv.PolyData(g * np.array(SPACING) + np.array(ORIGIN))
    faces = np.hstack([np.full((len(srf.faces), 1), 3), srf.faces]).astype(np.int64).ravel()
    sel = pts.select_enclosed_points(pv.PolyData(srf.vertices, faces), check_surface=True)
    oracle = np.asarray(sel.point_data["SelectedPoints"]).astype(bool)
    assert np.mean(oracle == a.ravel()) > 0.999


def _painted(surfaces, labels_dtype=None):
    v, f, lab, n = LV.merge_surfaces(surfaces)
    seg = Segmentation(v, f, normals=n, colors=ColorTable.with_size(int(lab.max()) + 1),
                       labels=np.zeros(len(v), lab.dtype))
    while np.any(seg.labels != lab):                    # fill each cell's surface pieces (mesh components)
        vid = int(np.flatnonzero(seg.labels != lab)[0])
        seg.fill(vid, int(lab[vid]))
    return seg, lab


def test_round_trip_frog_tissues_through_every_format(tmp_path):
    pv = pytest.importorskip("pyvista")
    tifffile = pytest.importorskip("tifffile")
    nrrd = pytest.importorskip("nrrd")
    nib = pytest.importorskip("nibabel")
    grid = pv.read(os.path.join(os.path.dirname(pv.__file__), "examples", "frog_tissues.vti"))
    full = np.asarray(grid.point_data[grid.array_names[0]]).reshape(grid.dimensions, order="F")
    vol = np.ascontiguousarray(full[200:260, 180:240, 60:90])
    spacing, origin = np.array(grid.spacing), np.array(grid.origin) + np.array([200, 180, 60]) * grid.spacing
    surfaces = LV.surfaces_from_labels(vol, spacing=spacing, origin=origin)
    assert len(surfaces) >= 3
    seg, _ = _painted(surfaces)
    # unpaint one tissue again: its voxels come back as 0, the others equal where painted
    gone = min(surfaces)
    seg.merge_labels(0, gone)
    out = LV.labels_to_volume(seg, vol.shape, spacing=spacing, origin=origin)
    assert out.dtype == np.uint8 and not np.any(out == gone)
    painted = out > 0
    np.testing.assert_array_equal(out[painted], vol[painted])
    want = (vol > 0) & (vol != gone)
    assert np.mean(painted[want]) > 0.999
    for name in ("labels.tif", "labels.nrrd", "labels.nii.gz"):
        p = write_label_volume(tmp_path / name, out, spacing=spacing, origin=origin)
        if name.endswith(".tif"):
            with tifffile.TiffFile(p) as tf:
                back = tf.asarray().transpose(2, 1, 0)
                ij = tf.imagej_metadata
                x_res = tf.pages[0].tags["XResolution"].value
            assert ij["spacing"] == pytest.approx(spacing[2])
            assert x_res[1] / x_res[0] == pytest.approx(spacing[0], rel=1e-6)
            assert -ij["xorigin"] * spacing[0] == pytest.approx(origin[0])
        elif name.endswith(".nrrd"):
            back, hdr = nrrd.read(str(p))
            np.testing.assert_allclose(np.diag(hdr["space directions"]), spacing)
            np.testing.assert_allclose(hdr["space origin"], origin)
        else:
            img = nib.load(p)
            back = np.asarray(img.dataobj)
            np.testing.assert_allclose(img.affine[:3, :3], np.diag(spacing))
            np.testing.assert_allclose(img.affine[:3, 3], origin)
        assert back.dtype == np.uint8
        np.testing.assert_array_equal(back, out)


def test_918_cells_round_trip_as_uint16(tmp_path):
    nib = pytest.importorskip("nibabel")
    tifffile = pytest.importorskip("tifffile")
    vol = _cells(n=24, k=8, first=911)                 # ids 911..918: a table of 919 colours
    surfaces = LV.surfaces_from_labels(vol, upsample=1)
    seg, _ = _painted(surfaces)
    assert seg.labels.dtype == np.uint16 and len(seg.colors) == 919
    out = LV.labels_to_volume(seg, vol.shape)
    assert out.dtype == np.uint16
    np.testing.assert_array_equal(out[out > 0], vol[out > 0])
    assert np.mean((out > 0)[vol > 0]) > 0.999
    p = write_label_volume(tmp_path / "cells.nii", out)
    np.testing.assert_array_equal(np.asarray(nib.load(p).dataobj), out)
    p = write_label_volume(tmp_path / "cells.tiff", out)
    back = tifffile.imread(p)
    assert back.dtype == np.uint16
    np.testing.assert_array_equal(back.transpose(2, 1, 0), out)


def test_labels_to_volume_outside_and_door_checks(surfaces, cells):
    seg, _ = _painted({k: surfaces[k] for k in list(surfaces)[:2]})
    out = LV.labels_to_volume(seg, cells.shape, spacing=SPACING, origin=ORIGIN, max_distance=0.01)
    assert not out.any()                                # every voxel centre is farther than 0.01 from a vertex
    with pytest.raises(ValueError, match="shape must be"):
        LV.labels_to_volume(seg, (0, 4, 4))
    with pytest.raises(ValueError, match="seg must have vertices"):
        LV.labels_to_volume(object(), (4, 4, 4))
    with pytest.raises(ValueError, match="path must end in"):
        write_label_volume("labels.png", cells)
    with pytest.raises(ValueError, match="uint8 or uint16"):
        write_label_volume("labels.tif", cells.astype(np.int32))
    with pytest.raises(ValueError, match="does not exist"):
        write_label_volume("/no/such/folder/labels.nrrd", cells)

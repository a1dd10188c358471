"""Labels land on the source's physical points in every label format (issue 32 "data out exactly").

A source is read by read_volume, labels are painted on its own grid (its axis order), written with
``geometry=volume.geometry``, and read back by SimpleITK (NRRD, NIfTI, MetaImage) or through ImageJ's calibration
parsed with tifffile (TIFF). Every labelled voxel must map to the physical point of the source voxel that holds
the same label, to 1e-6 voxel; the source's own points come from SimpleITK (or ImageJ's calibration for a TIFF
source), not from PlantVR. Sources: nibabel's test files, pydicom's CT_small.dcm as an oblique series, and files
written by tifffile, pynrrd and SimpleITK with flipped and rotated directions. NIfTI holds its affine in float32,
so its outputs are checked to float32 precision of the coordinates where that is coarser than 1e-6 voxel.
"""
import os

import numpy as np
import pytest
import SimpleITK as sitk
import tifffile

from plantvr.io.label_volume import write_label_volume
from plantvr.io.volume import VolumeGeometry, read_volume

OUT = (".nrrd", ".seg.nrrd", ".nii", ".nii.gz", ".mha", ".mhd", ".tif")


def _rotation(ax, ay, az):
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _labels(shape, seed=0):
    rng = np.random.default_rng(seed)
    lab = np.zeros(shape, np.uint8)
    lab[1:4, 2:5, 1:3] = 3
    idx = rng.integers(0, shape, size=(40, 3))
    lab[tuple(idx.T)] = rng.integers(1, 6, 40)
    lab[0, 0, 0], lab[-1, -1, -1], lab[-1, 0, -1] = 7, 8, 9          # the corners pin every axis's direction
    return lab


def _sitk_points(img):
    """(index -> world) of an image as SimpleITK defines it, for ITK-order indices (vectorised, spot-checked)."""
    d = np.array(img.GetDirection()).reshape(3, 3)
    sp, o = np.array(img.GetSpacing()), np.array(img.GetOrigin())

    def world(itk_idx):
        w = o + (np.asarray(itk_idx, float) * sp) @ d.T
        k = np.asarray(itk_idx)[0].tolist()
        np.testing.assert_allclose(w[0], img.TransformIndexToPhysicalPoint([int(x) for x in k]), atol=1e-9)
        return w

    def index(w):
        return np.linalg.solve(d * sp, (np.asarray(w) - o).T).T
    return world, index


def _imagej_points(path):
    """ImageJ's calibration of a TIFF (world = (pixel - origin) * pixel size, per axis), parsed with tifffile."""
    with tifffile.TiffFile(path) as tf:
        ij = tf.imagej_metadata
        xr, yr = tf.pages[0].tags["XResolution"].value, tf.pages[0].tags["YResolution"].value
        arr = tf.asarray()
    size = np.array([xr[1] / xr[0], yr[1] / yr[0], float(ij.get("spacing", 1.0))])        # x, y, z
    org = np.array([ij.get("xorigin", 0.0), ij.get("yorigin", 0.0), ij.get("zorigin", 0.0)], float)

    def world(zyx_idx):
        return (np.asarray(zyx_idx, float)[:, ::-1] - org) * size

    def index(w):
        return (np.asarray(w) / size + org)[:, ::-1]
    return arr, world, index


def _read_labels(path):
    """(array in its reader's order, labelled indices, their world points) read by SimpleITK or tifffile."""
    if str(path).endswith(".tif"):
        arr, world, _ = _imagej_points(path)
        nz = np.argwhere(arr)
        return arr, nz, world(nz)
    img = sitk.ReadImage(str(path))
    arr = sitk.GetArrayFromImage(img)
    nz = np.argwhere(arr)
    world, _ = _sitk_points(img)
    scale = 1.0
    if str(path).endswith((".nii", ".nii.gz")):    # ITK reads NIfTI in mm: a micron file comes back scaled by 1e-3
        import nibabel as nib
        scale = {"micron": 1e3, "meter": 1e-3}.get(nib.load(path).header.get_xyzt_units()[0], 1.0)
    return arr, nz, world(nz[:, ::-1]) * scale


def _assert_same_points(src_index, lab, path, tol=1e-6):
    """Every labelled voxel of ``path`` is at the physical point of the source voxel holding its label."""
    arr, nz, world = _read_labels(path)
    assert len(nz) == np.count_nonzero(lab), path
    got = src_index(world)                                       # fractional source indices, source order
    err = np.abs(got - np.round(got)).max()
    assert err < tol, f"{path}: {err:.3g} voxel off the source grid"
    r = np.round(got).astype(int)
    assert np.array_equal(lab[tuple(r.T)], arr[tuple(nz.T)]), path
    return err


def _sources(tmp_path):
    """(name, path, read_volume kwargs, source index function from world points, rotated?)."""
    from nibabel.testing import data_path
    out = []

    def sitk_src(p, zyx, extract=False):
        img = sitk.ReadImage(str(p))
        if extract:
            e = sitk.ExtractImageFilter()
            e.SetSize(list(img.GetSize()[:3]) + [0])
            img = e.Execute(img)
        _, index = _sitk_points(img)
        return (lambda w: index(w)[:, ::-1]) if zyx else index

    anat = os.path.join(data_path, "anatomical.nii")            # direction diag(-1, 1, 1) RAS, origin (-32, -40, -16)
    out.append(("nibabel anatomical.nii", anat, {}, sitk_src(anat, False), False))
    ex4 = os.path.join(data_path, "example4d.nii.gz")            # oblique and flipped, 4-D
    out.append(("nibabel example4d.nii.gz", ex4, {"time": 0}, sitk_src(ex4, False, True), True))

    a = np.zeros((5, 6, 7), np.uint16)                           # ImageJ: Z, Y, X with calibration and origin
    tif = tmp_path / "src_ij.tif"
    tifffile.imwrite(tif, a, imagej=True, resolution=(1 / 0.3, 1 / 0.4),
                     metadata={"axes": "ZYX", "spacing": 2.5, "unit": "micron", "xorigin": 3.0, "yorigin": -2.0,
                               "zorigin": 1.5})
    out.append(("tifffile ImageJ", tif, {}, _imagej_points(tif)[2], False))

    import nrrd                                                  # pynrrd: RAS space, rotated and flipped axes
    rot = _rotation(0.3, -0.5, 1.1) @ np.diag([-1.0, 1.0, 1.0])
    nr = tmp_path / "src_rot.nrrd"
    nrrd.write(str(nr), np.zeros((6, 5, 4), np.int16), {"space": "right-anterior-superior",
                                                         "space directions": (rot * [0.7, 1.1, 2.3]).T,
                                                         "space origin": [10.0, -20.0, 30.5]})
    out.append(("pynrrd rotated RAS", nr, {}, sitk_src(nr, False), True))

    img = sitk.GetImageFromArray(np.zeros((4, 6, 5), np.uint8))    # SimpleITK: (z, y, x) array, rotated
    img.SetSpacing([0.5, 0.8, 1.7])
    img.SetOrigin([-5.0, 7.0, 2.0])
    img.SetDirection(_rotation(-0.7, 0.2, 0.4).ravel().tolist())
    mha = tmp_path / "src_rot.mha"
    sitk.WriteImage(img, str(mha))
    out.append(("SimpleITK rotated .mha", mha, {}, sitk_src(mha, True), True))

    dcm = tmp_path / "dicom"                                     # pydicom's CT_small.dcm as an oblique series
    _oblique_series(dcm)
    reader = sitk.ImageSeriesReader()
    reader.SetFileNames(reader.GetGDCMSeriesFileNames(str(dcm)))
    _, index = _sitk_points(reader.Execute())
    out.append(("pydicom CT_small oblique series", dcm, {}, lambda w: index(w)[:, ::-1], True))
    return out


def _oblique_series(folder, n=4, dz=5.0):
    import pydicom
    from pydicom.data import get_testdata_file
    from pydicom.uid import generate_uid
    folder.mkdir()
    a, b = 0.35, -0.2
    row = np.array([np.cos(a), np.sin(a), 0.0])
    col = np.array([-np.sin(a) * np.cos(b), np.cos(a) * np.cos(b), np.sin(b)])
    normal = np.cross(row, col)
    series = generate_uid()
    for k in range(n):
        ds = pydicom.dcmread(get_testdata_file("CT_small.dcm"))
        ds.SeriesInstanceUID = series
        ds.SOPInstanceUID = ds.file_meta.MediaStorageSOPInstanceUID = generate_uid()
        ds.ImageOrientationPatient = [float(x) for x in (*row, *col)]
        ds.ImagePositionPatient = [float(x) for x in np.array([-158.1, -179.0, -75.7]) + k * dz * normal]
        ds.InstanceNumber = k + 1
        ds.save_as(folder / f"slice_{(k * 7) % n}.dcm")           # names not in slice order


def test_labels_land_on_the_source_points_in_every_format(tmp_path):
    worst = {}
    for name, path, kw, src_index, rotated in _sources(tmp_path):
        v = read_volume(path, **kw)
        lab = _labels(v.shape, seed=len(name))
        tol = 1e-5 if "example4d" in name else 1e-6   # its qform and sform disagree by 9e-8 mm (float32)
        for suffix in OUT:
            out = tmp_path / f"{name.replace(' ', '_')}_labels{suffix}"
            if suffix == ".tif" and rotated:
                with pytest.raises(ValueError, match="rotated against the world axes"):
                    write_label_volume(out, lab, geometry=v.geometry)
                assert not out.exists()
                continue
            write_label_volume(out, lab, geometry=v)
            t = tol
            if ".nii" in suffix:       # NIfTI holds its affine in float32: 2**-24 of the largest coordinate
                far = np.abs(v.geometry.index_to_world(np.argwhere(np.ones(v.shape, bool))[[0, -1]])).max()
                t = max(tol, 4 * 2.0 ** -24 * (far + np.abs(v.geometry.origin).max()) / v.spacing.min())
            worst[(name, suffix)] = _assert_same_points(src_index, lab, out, t)
            back = read_volume(out)                               # and PlantVR's own reader agrees
            ours = back.geometry.index_to_world(np.argwhere(np.asarray(back.array)))
            theirs = _read_labels(out)[2]
            np.testing.assert_allclose(ours[np.lexsort(np.round(ours, 4).T)],
                                       theirs[np.lexsort(np.round(theirs, 4).T)], atol=1e-6, err_msg=str(out))
    assert len(worst) == 6 * 7 - 4                              # four rotated sources have no TIFF
    exact = [e for (n, sfx), e in worst.items() if "example4d" not in n and ".nii" not in sfx]
    print(f"\nlabel geometry: {len(worst)} source/format pairs, worst {max(worst.values()):.2g} voxel; "
          f"NRRD/MetaImage/TIFF outputs of exact sources {max(exact):.2g} voxel")


def test_tiff_paint_tiff_is_not_transposed(tmp_path):
    """The issue's case: TIFF -> labels on its (Z, Y, X) grid -> TIFF comes back in the same order and place."""
    a = np.zeros((3, 5, 7), np.uint8)
    src = tmp_path / "stack.tif"
    tifffile.imwrite(src, a, imagej=True, resolution=(2.0, 4.0), metadata={"axes": "ZYX", "spacing": 3.0})
    v = read_volume(src)
    lab = _labels(v.shape)
    write_label_volume(tmp_path / "labels.tif", lab, geometry=v.geometry)
    back = read_volume(tmp_path / "labels.tif")
    assert back.shape == v.shape and np.array_equal(back.array, lab)
    np.testing.assert_allclose(back.spacing, v.spacing)
    np.testing.assert_allclose(back.origin, v.origin, atol=1e-12)


def test_anatomical_nii_keeps_its_direction(tmp_path):
    """nibabel's anatomical.nii (direction diag(-1, 1, 1), origin (-32, -40, -16)) was written as diag(2, 2, 2)."""
    import nibabel as nib
    from nibabel.testing import data_path
    src = os.path.join(data_path, "anatomical.nii")
    v = read_volume(src)
    out = write_label_volume(tmp_path / "l.nii.gz", _labels(v.shape), geometry=v)
    img = nib.load(out)
    np.testing.assert_allclose(img.affine, nib.load(src).affine, atol=1e-6)
    assert int(img.header["qform_code"]) == 1 and int(img.header["sform_code"]) == 1


def test_flipped_geometry_to_tiff_reverses_the_axis(tmp_path):
    g = VolumeGeometry((4, 5, 6), np.array([1.0, 2.0, 3.0]), np.array([10.0, 20.0, 30.0]),
                       np.array([[-1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]]), "xyz")
    lab = _labels(g.shape)
    out = write_label_volume(tmp_path / "f.tif", lab, geometry=g)
    arr, nz, world = _read_labels(out)
    got = g.world_to_index(world)
    np.testing.assert_allclose(got, np.round(got), atol=1e-9)
    assert np.array_equal(lab[tuple(np.round(got).astype(int).T)], arr[tuple(nz.T)])


def test_geometry_door_checks(tmp_path):
    lab = np.zeros((3, 4, 5), np.uint8)
    v = VolumeGeometry.from_grid((3, 4, 5), (1, 1, 1), (0, 0, 0), axes="zyx")
    with pytest.raises(ValueError, match="either geometry .* or spacing/origin"):
        write_label_volume(tmp_path / "a.nrrd", lab, geometry=v, spacing=(1, 1, 1))
    with pytest.raises(ValueError, match=r"geometry is for a volume of shape \(5, 4, 3\)"):
        write_label_volume(tmp_path / "a.nrrd", lab, geometry=VolumeGeometry.from_grid((5, 4, 3)))
    with pytest.raises(ValueError, match="geometry must be a VolumeGeometry"):
        write_label_volume(tmp_path / "a.nrrd", lab, geometry=np.eye(4))
    bad = VolumeGeometry((3, 4, 5), np.ones(3), np.zeros(3), np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 0, 1.0]]))
    with pytest.raises(ValueError, match="orthonormal"):
        write_label_volume(tmp_path / "a.nrrd", lab, geometry=bad)
    assert not list(tmp_path.iterdir())


def test_geometry_of_every_reader_matches_simpleitk(tmp_path):
    """read_volume's geometry is SimpleITK's for the formats both read (LPS, ITK index order reversed or not)."""
    for name, path, kw, src_index, _ in _sources(tmp_path):
        if name.startswith("tifffile"):
            continue
        g = read_volume(path, **kw).geometry
        idx = np.argwhere(np.ones(g.shape, bool))[::7]
        tol = 1e-5 if "example4d" in name else 1e-9
        np.testing.assert_allclose(src_index(g.index_to_world(idx)), idx, atol=tol, err_msg=name)


@pytest.mark.parametrize("downsample", [False, True])
def test_open_source_carries_the_geometry_to_the_label_writer(tmp_path, downsample):
    """plantvr segment's source: labels_to_volume on its grid, written with its geometry, land on its points."""
    from plantvr.io.source import open_source
    from plantvr.vine.label_volumes import labels_to_volume
    img = sitk.GetImageFromArray((np.indices((12, 14, 16)).sum(0) % 7 > 2).astype(np.uint8) * 200)
    img.SetSpacing([0.5, 0.8, 1.7])
    img.SetOrigin([-5.0, 7.0, 2.0])
    img.SetDirection(_rotation(-0.7, 0.2, 0.4).ravel().tolist())
    sitk.WriteImage(img, str(tmp_path / "scan.mha"))
    src = open_source(tmp_path / "scan.mha", downsample=downsample)
    assert src.geometry.shape == src.volume.shape
    src.seg.paint(src.seg.vertices[0], 6.0, 3)
    lab = labels_to_volume(src.seg, src.volume.shape, spacing=src.seg.spacing, origin=src.seg.origin)
    assert np.count_nonzero(lab)
    out = write_label_volume(tmp_path / "labels.mha", lab, geometry=src.geometry)
    _, index = _sitk_points(img)
    if downsample:                       # coarse voxel k covers fine voxels 2k, 2k + 1: its centre is at 2k + 0.5
        def index(w, _index=index):  # noqa: E306
            return (_index(w)[:, ::-1] - 0.5) / 2.0
        _assert_same_points(index, lab, out)
    else:
        _assert_same_points(lambda w: index(w)[:, ::-1], lab, out)


def test_slicer_seg_nrrd(tmp_path):
    """3D Slicer's segmentation file: the grid in LPS plus the Segment<k>_* keys Slicer writes, read by pynrrd."""
    import nrrd
    from nibabel.testing import data_path
    v = read_volume(os.path.join(data_path, "anatomical.nii"))
    lab = np.zeros(v.shape, np.uint8)
    lab[2:6, 3:9, 4:7] = 1
    lab[10:12, 0:2, 20:25] = 4
    out = write_label_volume(tmp_path / "l.seg.nrrd", lab, geometry=v, names={1: "stem", 4: "leaf 2"},
                             colors={4: (255, 128, 0)})
    data, h = nrrd.read(str(out))
    assert np.array_equal(data, lab) and h["space"] == "left-posterior-superior"
    assert h["Segmentation_MasterRepresentation"] == "Binary labelmap"
    assert [h[f"Segment{k}_{key}"] for k in (0, 1) for key in ("ID", "Name", "LabelValue", "Layer")] == \
        ["Segment_1", "stem", "1", "0", "Segment_4", "leaf 2", "4", "0"]
    assert h["Segment0_Extent"] == "2 5 3 8 4 6" and h["Segment1_Extent"] == "10 11 0 1 20 24"
    np.testing.assert_allclose([float(x) for x in h["Segment1_Color"].split()], [1.0, 128 / 255, 0.0], atol=1e-6)
    _, index = _sitk_points(sitk.ReadImage(os.path.join(data_path, "anatomical.nii")))
    _assert_same_points(index, lab, out)
    with pytest.raises(ValueError, match=r"names labels \[2\] that are not in volume"):
        write_label_volume(tmp_path / "m.seg.nrrd", lab, names={2: "x"})
    with pytest.raises(ValueError, match=r"colors\[1\] must be 3 values"):
        write_label_volume(tmp_path / "m.seg.nrrd", lab, colors={1: (1, 2)})
    assert not (tmp_path / "m.seg.nrrd").exists() and not (tmp_path / "l.nrrd").exists()


@pytest.mark.parametrize("suffix", [".nii.gz", ".tif", ".nrrd", ".mha"])
def test_label_table_beside_a_plain_label_image(tmp_path, suffix):
    """Issue 32: a NIfTI/TIFF/NRRD/MetaImage label image with names or colours gets its label table beside it,
    as ITK-SNAP's label description file and a 3D Slicer colour table; without them nothing else is written."""
    lab = np.zeros((6, 7, 8), np.uint8)
    lab[1:3, 1:3, 1:3] = 1
    lab[4:6, 4:6, 5:8] = 7
    write_label_volume(tmp_path / f"plain{suffix}", lab)
    assert sorted(os.listdir(tmp_path)) == [f"plain{suffix}"]
    write_label_volume(tmp_path / f"seg{suffix}", lab, names={1: "stem", 7: 'leaf "two"'}, colors={7: (255, 128, 0)})
    assert sorted(os.listdir(tmp_path)) == sorted([f"plain{suffix}", f"seg{suffix}", "seg_labels.txt", "seg.ctbl"])
    rows = [r for r in (tmp_path / "seg_labels.txt").read_text().splitlines() if not r.startswith("#")]
    parsed = [(r.split('"')[0].split(), r.split('"')[1]) for r in rows]
    assert parsed[0] == (["0", "0", "0", "0", "0", "0", "0"], "Clear Label")
    assert parsed[1][1] == "stem" and parsed[1][0][0] == "1" and parsed[1][0][4:] == ["1", "1", "1"]
    assert parsed[2] == (["7", "255", "128", "0", "1", "1", "1"], "leaf 'two'")
    ctbl = [r.split() for r in (tmp_path / "seg.ctbl").read_text().splitlines() if not r.startswith("#")]
    assert ctbl[0] == ["0", "Background", "0", "0", "0", "0"] and ctbl[2] == ["7", 'leaf_"two"', "255", "128", "0", "255"]
    assert ctbl[1][:2] == ["1", "stem"] and ctbl[1][5] == "255"


# ------------------------------------------------------------------------------------------------ OME-Zarr labels


def _ome_zarr_image(path, a, *, zarr_format=2):
    """An OME-Zarr image written by ome-zarr-py (NGFF 0.4 in Zarr v2, 0.5 in v3): 2 levels, micrometre axes,
    scale (2, 0.5, 0.25) and a translation at level 0."""
    zarr = pytest.importorskip("zarr")
    writer = pytest.importorskip("ome_zarr.writer")
    from ome_zarr.format import FormatV04, FormatV05
    g = zarr.open_group(str(path), mode="w", zarr_format=zarr_format)
    axes = [{"name": n, "type": "space", "unit": "micrometer"} for n in "zyx"]
    writer.write_image(a, g, axes=axes, fmt=FormatV04() if zarr_format == 2 else FormatV05(),
                       scale_factors=[{"z": 1, "y": 2, "x": 2}], scale={"z": 2.0, "y": 0.5, "x": 0.25})
    attrs = dict(g.attrs)                     # the stage position: every level moved by (1, -2, 3) micrometres
    ms = (attrs["ome"] if zarr_format == 3 else attrs)["multiscales"]
    for ds in ms[0]["datasets"]:
        ct = ds["coordinateTransformations"]
        if len(ct) == 1:
            ct.append({"type": "translation", "translation": [0.0, 0.0, 0.0]})
        ct[1]["translation"] = [t + d for t, d in zip(ct[1]["translation"], (1.0, -2.0, 3.0))]
    g.attrs.update(attrs)
    return path


def _check_ngff_label_metadata(label_attrs: dict, labels_attrs: dict, name: str, values, version: str):
    """The NGFF image-label spec's rules (https://ngff.openmicroscopy.org/0.4/#label-md), checked by hand."""
    ome = label_attrs.get("ome", label_attrs)
    assert name in (labels_attrs.get("ome", labels_attrs))["labels"]
    il = ome["image-label"]
    if version == "0.4":
        assert il["version"] == "0.4" and ome["multiscales"][0]["version"] == "0.4"
    else:
        assert ome["version"] == "0.5"
    assert il["source"] == {"image": "../../"}
    lv = [c["label-value"] for c in il["colors"]]
    assert lv == sorted(set(lv)) and set(lv) == set(values)           # unique, one per label present
    for c in il["colors"]:
        assert isinstance(c["label-value"], int)
        assert len(c["rgba"]) == 4 and all(isinstance(x, int) and 0 <= x <= 255 for x in c["rgba"])
    assert {p["label-value"] for p in il["properties"]} <= set(lv)
    ms = ome["multiscales"]
    assert isinstance(ms, list) and len(ms) >= 1
    axes = ms[0]["axes"]
    assert 2 <= len(axes) <= 5 and sum(a["type"] == "space" for a in axes) in (2, 3)
    for ds in ms[0]["datasets"]:
        ct = ds["coordinateTransformations"]
        assert ct[0]["type"] == "scale" and len(ct[0]["scale"]) == len(axes)
        assert all(t["type"] == "translation" and len(t["translation"]) == len(axes) for t in ct[1:]) and len(ct) <= 2


@pytest.mark.parametrize("zarr_format, version", [(2, "0.4"), (3, "0.5")])
def test_ome_zarr_labels_beside_the_image(tmp_path, zarr_format, version):
    zarr = pytest.importorskip("zarr")
    rng = np.random.default_rng(4)
    img = rng.integers(0, 1000, (6, 16, 20)).astype(np.uint16)
    p = _ome_zarr_image(tmp_path / "img.zarr", img, zarr_format=zarr_format)
    src = read_volume(p)
    np.testing.assert_allclose(src.spacing, (2.0, 0.5, 0.25))
    np.testing.assert_allclose(src.origin, (1.0, -2.0, 3.0))
    lab = np.zeros(src.shape, np.uint8)
    lab[1:4, 2:9, 3:15] = 1
    lab[2:5, 10:14, 5:8] = 3
    out = write_label_volume(p, lab, geometry=src.geometry, names={1: "stem", 3: "xylem"},
                             colors={1: (255, 0, 0)}, name="cells")
    assert out == p / "labels" / "cells"
    root = zarr.open_group(str(p), mode="r")
    _check_ngff_label_metadata(dict(root["labels/cells"].attrs), dict(root["labels"].attrs), "cells", {1, 3},
                               version)
    il = dict(root["labels/cells"].attrs)
    il = il.get("ome", il)["image-label"]
    assert il["colors"][0] == {"label-value": 1, "rgba": [255, 0, 0, 255]}
    assert [pr["name"] for pr in il["properties"]] == ["stem", "xylem"]
    back = read_volume(out)                           # level 0, on the image's grid
    assert np.array_equal(back.array, lab)
    for k in ("spacing", "origin", "direction"):
        np.testing.assert_allclose(getattr(back.geometry, k), getattr(src.geometry, k), atol=1e-12)
    low = read_volume(out, dataset=root["labels/cells"].attrs.get("ome", dict(root["labels/cells"].attrs))
                      ["multiscales"][0]["datasets"][1]["path"])
    assert low.shape == (6, 8, 10)
    # each level-1 voxel holds the level-0 label nearest its centre
    w = low.geometry.index_to_world(np.argwhere(np.ones(low.shape, bool)))
    i0 = np.rint(src.geometry.world_to_index(w)).astype(int)
    assert np.array_equal(low.array.ravel(), lab[tuple(i0.T)])
    # ome-zarr-models validates the NGFF metadata (pydantic models of the spec's JSON schemas)
    models = pytest.importorskip("ome_zarr_models")
    group = models.open_ome_zarr(root["labels/cells"], version=version)
    assert type(group).__name__ == "ImageLabel"
    assert type(models.open_ome_zarr(root["labels"], version=version)).__name__ == "Labels"
    # ome-zarr-py finds them as the image's labels
    from ome_zarr.io import parse_url
    from ome_zarr.reader import Label, Reader
    nodes = list(Reader(parse_url(str(p)))())
    lab_nodes = [n for n in nodes if any(isinstance(s, Label) for s in n.specs)]
    assert len(lab_nodes) == 1
    assert np.array_equal(np.asarray(lab_nodes[0].data[0]), lab)
    assert lab_nodes[0].metadata["name"] == "cells"
    # a second label volume joins the list; rewriting one replaces it
    write_label_volume(p, (lab > 0).astype(np.uint8), name="mask")
    write_label_volume(p, lab, name="cells")
    lattrs = dict(zarr.open_group(str(p / "labels"), mode="r").attrs)
    assert lattrs.get("ome", lattrs)["labels"] == ["mask", "cells"]
    assert not [f for f in os.listdir(p / "labels") if f.startswith(".") and (p / "labels" / f).is_dir()]


def test_ome_zarr_labels_refused_before_writing(tmp_path):
    pytest.importorskip("zarr")
    img = np.zeros((4, 8, 8), np.uint16)
    p = _ome_zarr_image(tmp_path / "img.zarr", img)
    before = sorted(os.listdir(p))
    lab = np.zeros((4, 8, 8), np.uint8)
    with pytest.raises(ValueError, match="level-0 space axes of shape"):
        write_label_volume(p, np.zeros((4, 8, 9), np.uint8))
    with pytest.raises(ValueError, match="not the level-0 grid"):
        write_label_volume(p, lab, geometry=VolumeGeometry.from_grid((4, 8, 8), axes="zyx"))
    with pytest.raises(ValueError, match="name must be"):
        write_label_volume(p, lab, name="../x")
    with pytest.raises(ValueError, match="spacing and origin do not apply"):
        write_label_volume(p, lab, spacing=(1, 1, 1))
    with pytest.raises(ValueError, match="existing OME-Zarr image folder"):
        write_label_volume(tmp_path / "none.zarr", lab)
    (tmp_path / "plain.zarr").mkdir()
    with pytest.raises(ValueError, match="OME-Zarr image"):
        write_label_volume(tmp_path / "plain.zarr", lab)
    with pytest.raises(ValueError, match="applies to .zarr only"):
        write_label_volume(tmp_path / "l.nrrd", lab, name="x")
    assert sorted(os.listdir(p)) == before                             # no labels/ group left behind

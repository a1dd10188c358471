"""plantvr.io.volume.read_volume on files written by each format's own library (issue 22, "Volume readers")."""
import os
from pathlib import Path

import numpy as np
import pytest
import tifffile

from plantvr.io.volume import Volume, read_volume

from ._dicom import dicom_series

DTYPES = [np.uint8, np.uint16, np.int16, np.float32]


def _vol(dtype, shape=(5, 6, 7), seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return (rng.standard_normal(shape) * 100).astype(dtype)
    info = np.iinfo(dtype)
    return rng.integers(max(info.min, -30000), min(info.max, 60000), shape, endpoint=True).astype(dtype)


def _check(v: Volume, array, spacing, origin, *, fmt=None):
    assert isinstance(v, Volume)
    got = np.asarray(v.array)
    assert got.dtype.isnative and got.dtype == np.dtype(array.dtype).newbyteorder("=")
    assert got.shape == array.shape and np.array_equal(got, array)
    np.testing.assert_allclose(v.spacing, spacing, rtol=1e-6)
    np.testing.assert_allclose(v.origin, origin, rtol=1e-6, atol=1e-9)
    if fmt:
        assert v.format == fmt and v.meta["format"] == fmt


# ------------------------------------------------------------------------------------------------ TIFF

@pytest.mark.parametrize("byteorder", ["<", ">"])
@pytest.mark.parametrize("dtype", DTYPES)
def test_tiff_imagej_both_byte_orders(tmp_path, byteorder, dtype):
    if dtype == np.int16:
        pytest.skip("ImageJ hyperstacks hold uint8/uint16/float32 only")
    a = _vol(dtype)
    p = tmp_path / "ij.tif"
    tifffile.imwrite(p, a, imagej=True, byteorder=byteorder, resolution=(1 / 0.25, 1 / 0.5),
                     metadata={"spacing": 2.0, "unit": "um", "axes": "ZYX"})
    v = read_volume(p)
    _check(v, a, (2.0, 0.5, 0.25), (0, 0, 0), fmt="TIFF")
    assert v.meta["axes"] == "zyx" and v.meta["unit"] == "um" and v.meta["byteorder"] == byteorder


def test_tiff_imagej_hyperstack_drops_singleton_time_and_channel(tmp_path):
    a = _vol(np.uint16, (1, 4, 1, 6, 7))                       # TZCYX
    p = tmp_path / "hyper.tif"
    tifffile.imwrite(p, a, imagej=True, byteorder=">", metadata={"axes": "TZCYX", "spacing": 3.0})
    _check(read_volume(p), a[0, :, 0], (3.0, 1, 1), (0, 0, 0))
    two = tmp_path / "two_channels.tif"
    tifffile.imwrite(two, _vol(np.uint16, (4, 2, 6, 7)), imagej=True, metadata={"axes": "ZCYX"})
    with pytest.raises(ValueError, match=r"3-D after dropping singleton.*ZCYX"):
        read_volume(two)


@pytest.mark.parametrize("byteorder", ["<", ">"])
@pytest.mark.parametrize("dtype", DTYPES)
def test_tiff_ome_physical_size(tmp_path, byteorder, dtype):
    a = _vol(dtype)
    p = tmp_path / "x.ome.tif"
    tifffile.imwrite(p, a, ome=True, byteorder=byteorder,
                     metadata={"axes": "ZYX", "PhysicalSizeX": 0.3, "PhysicalSizeY": 0.4, "PhysicalSizeZ": 1.5})
    v = read_volume(p)
    _check(v, a, (1.5, 0.4, 0.3), (0, 0, 0), fmt="TIFF")
    assert v.meta["unit"] == "µm"


@pytest.mark.parametrize("byteorder", ["<", ">"])
@pytest.mark.parametrize("dtype", DTYPES)
def test_tiff_plain_multipage(tmp_path, byteorder, dtype):
    a = _vol(dtype)
    p = tmp_path / "plain.tif"
    tifffile.imwrite(p, a, byteorder=byteorder, photometric="minisblack", resolution=(2.0, 4.0))
    _check(read_volume(p), a, (1.0, 0.25, 0.5), (0, 0, 0))


def test_tiff_folder_of_slices_and_lazy(tmp_path):
    a = _vol(np.uint16, (4, 6, 5))
    for i, plane in enumerate(a):
        tifffile.imwrite(tmp_path / f"s{i:03d}.tif", plane, byteorder=">")
    _check(read_volume(tmp_path), a, (1, 1, 1), (0, 0, 0))
    da = pytest.importorskip("dask.array")
    pytest.importorskip("zarr")
    p = tmp_path / "big.tif"
    b = _vol(np.float32, (6, 8, 9))
    tifffile.imwrite(p, b, byteorder=">", photometric="minisblack")
    lz = read_volume(p, lazy=True)
    assert isinstance(lz.array, da.Array) and np.array_equal(lz.array.compute(), b)


def test_tiff_rgb_refused(tmp_path):
    p = tmp_path / "rgb.tif"
    tifffile.imwrite(p, np.zeros((4, 5, 6, 3), np.uint8), photometric="rgb")
    with pytest.raises(ValueError, match=r"3-D after dropping singleton.*ZYXS|axes"):
        read_volume(p)


# ------------------------------------------------------------------------------------------------ NRRD

@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("endian", ["little", "big"])
def test_nrrd_round_trip(tmp_path, dtype, endian):
    nrrd = pytest.importorskip("nrrd")
    a = _vol(dtype)
    p = tmp_path / "v.nrrd"
    nrrd.write(str(p), a, {"space": "left-posterior-superior", "endian": endian,
                           "space directions": np.diag([0.5, 0.75, 2.0]), "space origin": [1.0, -2.0, 3.0]},
               index_order="F")
    v = read_volume(p)
    _check(v, a, (0.5, 0.75, 2.0), (1.0, -2.0, 3.0), fmt="NRRD")
    assert v.meta["axes"] == "xyz"


def test_nrrd_spacings_and_channel_axis(tmp_path):
    nrrd = pytest.importorskip("nrrd")
    a = _vol(np.uint8, (1, 5, 6, 7))
    p = tmp_path / "c.nrrd"
    nrrd.write(str(p), a, {"kinds": ["vector", "domain", "domain", "domain"],
                           "spacings": [np.nan, 1.0, 2.0, 3.0]}, index_order="F")
    _check(read_volume(p), a[0], (1.0, 2.0, 3.0), (0, 0, 0))


# ------------------------------------------------------------------------------------------------ NIfTI

@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_nifti_round_trip(tmp_path, dtype, suffix):
    nib = pytest.importorskip("nibabel")
    a = _vol(dtype)
    aff = np.diag([0.5, 0.6, 2.5, 1.0])
    aff[:3, 3] = [10.0, -20.0, 5.0]
    p = tmp_path / f"v{suffix}"
    nib.save(nib.Nifti1Image(a, aff), str(p))
    v = read_volume(p)
    _check(v, a, (0.5, 0.6, 2.5), (10.0, -20.0, 5.0), fmt="NIfTI")
    np.testing.assert_allclose(v.meta["affine"], aff)


def _nib_data(name):
    nib = pytest.importorskip("nibabel")
    return Path(os.path.dirname(nib.__file__)) / "tests" / "data" / name


@pytest.mark.parametrize("name", ["anatomical.nii", "standard.nii.gz", "example4d.nii.gz"])
def test_nifti_nibabels_own_images(name):
    nib = pytest.importorskip("nibabel")
    p = _nib_data(name)
    img = nib.load(str(p))
    if len(img.shape) > 3 and img.shape[3] > 1:
        with pytest.raises(ValueError, match=r"3-D after dropping singleton.*XYZT"):
            read_volume(p)
        return
    v = read_volume(p)
    raw = np.asanyarray(img.dataobj.get_unscaled())
    aff = img.affine
    _check(v, raw, img.header.get_zooms()[:3], v.meta["direction"] @ aff[:3, 3])
    ijk = np.array([[0, 0, 0], [3, 1, 2], [s - 1 for s in v.shape]], float)   # world = direction.T @ physical
    world = (v.meta["direction"].T @ v.to_physical(ijk).T).T
    np.testing.assert_allclose(world, nib.affines.apply_affine(aff, ijk), atol=1e-4)
    assert np.array_equal(img.get_fdata(), v.array * v.meta["scl_slope"] + v.meta["scl_inter"])


def test_nifti_big_endian_anatomical_is_native():
    v = read_volume(_nib_data("anatomical.nii"))                     # stored '>i2'
    assert v.array.dtype == np.int16 and v.array.dtype.isnative and v.shape == (33, 41, 25)


# ------------------------------------------------------------------------------------------------ MetaImage

@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("suffix", [".mha", ".mhd"])
def test_metaimage_round_trip(tmp_path, dtype, suffix):
    sitk = pytest.importorskip("SimpleITK")
    a = _vol(dtype)                                            # (z, y, x)
    img = sitk.GetImageFromArray(a)
    img.SetSpacing((0.3, 0.4, 1.2))                            # (x, y, z)
    img.SetOrigin((1.0, 2.0, 3.0))
    p = tmp_path / f"v{suffix}"
    sitk.WriteImage(img, str(p))
    v = read_volume(p)
    _check(v, a, (1.2, 0.4, 0.3), (3.0, 2.0, 1.0), fmt="MetaImage")
    assert v.meta["axes"] == "zyx"


def test_metaimage_vector_pixels_refused(tmp_path):
    sitk = pytest.importorskip("SimpleITK")
    p = tmp_path / "rgb.mha"
    sitk.WriteImage(sitk.GetImageFromArray(np.zeros((4, 5, 6, 3), np.uint8), isVector=True), str(p))
    with pytest.raises(ValueError, match="one number per voxel"):
        read_volume(p)


# ------------------------------------------------------------------------------------------------ VTI

def test_vti_frog_tissues_from_pyvista_examples():
    import pyvista as pv
    p = Path(os.path.dirname(pv.__file__)) / "examples" / "frog_tissues.vti"
    v = read_volume(p)
    grid = pv.read(p)
    assert v.shape == grid.dimensions and v.dtype == np.uint8 and v.meta["axes"] == "xyz"
    np.testing.assert_allclose(v.spacing, grid.spacing)
    np.testing.assert_allclose(v.origin, grid.origin)
    flat = np.asarray(grid.point_data["MetaImage"])
    assert np.array_equal(v.array.ravel(order="F"), flat)
    assert np.array_equal(np.unique(v.array), np.unique(flat))


@pytest.mark.parametrize("dtype", DTYPES)
def test_vti_round_trip(tmp_path, dtype):
    import pyvista as pv
    a = _vol(dtype)                                             # (x, y, z)
    g = pv.ImageData(dimensions=a.shape, spacing=(0.5, 1.5, 2.0), origin=(1.0, 2.0, -3.0))
    g.point_data["v"] = a.ravel(order="F")
    p = tmp_path / "v.vti"
    g.save(p)
    _check(read_volume(p), a, (0.5, 1.5, 2.0), (1.0, 2.0, -3.0), fmt="VTI")


# ------------------------------------------------------------------------------------------------ HDF5

@pytest.mark.parametrize("dtype", DTYPES)
def test_hdf5_round_trip(tmp_path, dtype):
    h5py = pytest.importorskip("h5py")
    a = _vol(dtype)
    p = tmp_path / "v.h5"
    with h5py.File(p, "w") as f:
        d = f.create_dataset("data/raw", data=a.astype(np.dtype(a.dtype).newbyteorder(">")))
        d.attrs["element_size_um"] = [2.0, 0.5, 0.5]
        f.create_dataset("other", data=np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="dataset must name"):
        read_volume(p)
    v = read_volume(p, dataset="data/raw")
    _check(v, a, (2.0, 0.5, 0.5), (0, 0, 0), fmt="HDF5")
    with pytest.raises(ValueError, match="dataset must name a dataset"):
        read_volume(p, dataset="nope")


def test_hdf5_singleton_channel_dropped(tmp_path):
    h5py = pytest.importorskip("h5py")
    a = _vol(np.uint16, (1, 5, 6, 7))
    p = tmp_path / "c.hdf5"
    with h5py.File(p, "w") as f:
        f["vol"] = a
    _check(read_volume(p), a[0], (1, 1, 1), (0, 0, 0))


# ------------------------------------------------------------------------------------------------ Zarr

def _ome_zarr(p, a, scale, translation, *, unit="micrometer"):
    zarr = pytest.importorskip("zarr")
    g = zarr.open_group(str(p), mode="w", zarr_format=2)
    g.create_array("0", data=a, chunks=(1, 1, 2, 3, 4))
    g.create_array("1", data=a[:, :, ::2, ::2, ::2], chunks=(1, 1, 2, 3, 4))
    axes = [{"name": "t", "type": "time"}, {"name": "c", "type": "channel"}] + [
        {"name": n, "type": "space", "unit": unit} for n in "zyx"]
    g.attrs["multiscales"] = [{
        "version": "0.4", "axes": axes,
        "datasets": [{"path": "0", "coordinateTransformations": [
                         {"type": "scale", "scale": [1, 1, *scale]},
                         {"type": "translation", "translation": [0, 0, *translation]}]},
                     {"path": "1", "coordinateTransformations": [
                         {"type": "scale", "scale": [1, 1, *(2 * np.asarray(scale))]}]}]}]


@pytest.mark.parametrize("dtype", DTYPES)
def test_ome_zarr_level0_scale_translation(tmp_path, dtype):
    a = _vol(dtype, (1, 1, 6, 7, 8))
    p = tmp_path / "v.zarr"
    _ome_zarr(p, a, (2.0, 0.5, 0.25), (10.0, 20.0, 30.0))
    v = read_volume(p)
    _check(v, a[0, 0], (2.0, 0.5, 0.25), (10.0, 20.0, 30.0), fmt="Zarr")
    assert v.meta["axes"] == "zyx" and v.meta["unit"] == "micrometer"
    v1 = read_volume(p, dataset="1")
    _check(v1, a[0, 0, ::2, ::2, ::2], (4.0, 1.0, 0.5), (0, 0, 0))


def test_zarr_lazy_dask_equals_eager(tmp_path):
    da = pytest.importorskip("dask.array")
    a = _vol(np.float32, (1, 1, 6, 7, 8))
    p = tmp_path / "v.zarr"
    _ome_zarr(p, a, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    lz = read_volume(p, lazy=True)
    assert isinstance(lz.array, da.Array)
    assert np.array_equal(lz.array.compute(), read_volume(p).array)


def test_plain_zarr_array(tmp_path):
    zarr = pytest.importorskip("zarr")
    a = _vol(np.int16, (5, 6, 7)).astype(">i2")
    p = tmp_path / "plain.zarr"
    z = zarr.create_array(str(p), shape=a.shape, dtype=a.dtype, chunks=(2, 3, 4), zarr_format=2)
    z[:] = a
    _check(read_volume(p), a, (1, 1, 1), (0, 0, 0))


# ------------------------------------------------------------------------------------------------ DICOM

@pytest.mark.parametrize("dtype", [np.uint16, np.int16])
def test_dicom_series_sorted_by_position(tmp_path, dtype):
    a = _vol(dtype, (5, 6, 7))
    dicom_series(tmp_path, a)
    v = read_volume(tmp_path)
    _check(v, a, (2.5, 0.7, 0.8), (100.0, 5.0, -10.0), fmt="DICOM")      # (z, y, x) of ImagePositionPatient
    assert v.meta["rescale_intercept"] == -1024 and v.meta["unit"] == "mm"


def test_dicom_duplicate_positions_refused(tmp_path):
    a = _vol(np.uint16, (3, 4, 5))
    dicom_series(tmp_path, a, dz=0.0)
    with pytest.raises(ValueError, match="same position"):
        read_volume(tmp_path)


# ------------------------------------------------------------------------------------------------ door checks

def test_refused_inputs_give_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        read_volume(tmp_path / "nope.nii")
    (tmp_path / "x.raw").write_bytes(b"\0" * 8)
    with pytest.raises(ValueError, match="must end in one of"):
        read_volume(tmp_path / "x.raw")
    (tmp_path / "bad.nrrd").write_bytes(b"not nrrd at all")
    with pytest.raises(ValueError, match="could not read .* as NRRD"):
        read_volume(tmp_path / "bad.nrrd")
    (tmp_path / "bad.tif").write_bytes(b"II*\0garbage")
    with pytest.raises(ValueError, match="could not read .* as TIFF"):
        read_volume(tmp_path / "bad.tif")
    tifffile.imwrite(tmp_path / "flat.tif", np.zeros((6, 7), np.uint8))
    with pytest.raises(ValueError, match="3-D"):
        read_volume(tmp_path / "flat.tif")
    np.save(tmp_path / "c.npy", np.zeros((3, 4, 5), np.complex64))
    with pytest.raises(ValueError, match="one number per voxel"):
        read_volume(tmp_path / "c.npy")
    np.save(tmp_path / "thin.npy", np.zeros((1, 4, 5), np.uint8))
    with pytest.raises(ValueError, match="at least 2 voxels"):
        read_volume(tmp_path / "thin.npy")
    with pytest.raises(ValueError, match="lazy=True reads Zarr and TIFF"):
        read_volume(tmp_path / "thin.npy", lazy=True)
    with pytest.raises(ValueError, match="lazy must be"):
        read_volume(tmp_path / "thin.npy", lazy="yes")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="no TIFF or DICOM slices"):
        read_volume(empty)


def test_bad_spacing_refused(tmp_path):
    p = tmp_path / "zero.tif"
    tifffile.imwrite(p, _vol(np.uint8), imagej=True, metadata={"spacing": 0.0, "axes": "ZYX"})
    with pytest.raises(ValueError, match="spacing .* finite and > 0"):
        read_volume(p)
    h5py = pytest.importorskip("h5py")
    q = tmp_path / "nan.h5"
    with h5py.File(q, "w") as f:
        f["v"] = _vol(np.uint8)
        f["v"].attrs["element_size_um"] = [1.0, np.nan, 1.0]
    with pytest.raises(ValueError, match="spacing .* finite and > 0"):
        read_volume(q)


def test_declared_size_cap_checked_before_reading(tmp_path, monkeypatch):
    import plantvr.io.volume as iov
    monkeypatch.setattr(iov, "MAX_VOLUME_BYTES", 100)
    p = tmp_path / "v.tif"
    tifffile.imwrite(p, _vol(np.uint16), photometric="minisblack")
    with pytest.raises(ValueError, match="more than the 100 bytes"):
        read_volume(p)


def test_npy_npz(tmp_path):
    a = _vol(np.float32).astype(">f4")
    np.save(tmp_path / "v.npy", a)
    _check(read_volume(tmp_path / "v.npy"), a, (1, 1, 1), (0, 0, 0), fmt="NumPy")
    np.savez(tmp_path / "v.npz", volume=a, other=np.zeros(3))
    _check(read_volume(tmp_path / "v.npz"), a, (1, 1, 1), (0, 0, 0))


# ------------------------------------------------------------------------------------------------ plantvr segment

def test_segment_reads_big_endian_imagej_and_nrrd_sources(tmp_path, capsys):
    """Issue 22: ``plantvr segment`` refused a big-endian ImageJ stack (">u2") and every advertised .nrrd."""
    pytest.importorskip("trame")
    nrrd = pytest.importorskip("nrrd")
    from plantvr.io.source import open_source
    from plantvr.view.vine_cli import main_segment
    from plantvr.vine.synth import synth_flowerhead
    head = synth_flowerhead(32, rng=0)
    vol16 = head.volume.astype(np.uint16) * 200
    np.save(tmp_path / "ref.npy", vol16)
    ref = open_source(tmp_path / "ref.npy", level=head.level * 200)
    tifffile.imwrite(tmp_path / "ij.tif", vol16, imagej=True, byteorder=">", metadata={"axes": "ZYX"})
    nrrd.write(str(tmp_path / "v.nrrd"), vol16, {"endian": "big"}, index_order="F")
    for name in ("ij.tif", "v.nrrd"):
        src = open_source(str(tmp_path / name), level=head.level * 200)
        assert src.volume.dtype == np.uint16 and np.array_equal(src.volume, vol16)
        assert np.array_equal(src.seg.vertices, ref.seg.vertices) and np.array_equal(src.seg.faces, ref.seg.faces)
    assert "NRRD uint16 32x32x32" in src.description
    assert main_segment([str(tmp_path / "ij.tif"), "--out", str(tmp_path / "out"), "--stamps", "3"]) == 0
    assert (tmp_path / "out" / "segment.ply").stat().st_size > 1000
    assert main_segment([str(tmp_path / "missing.nii"), "--out", str(tmp_path)]) == 2
    (tmp_path / "bad.nii").write_bytes(b"nope")
    assert main_segment([str(tmp_path / "bad.nii"), "--out", str(tmp_path)]) == 2
    assert "could not read" in capsys.readouterr().err


@pytest.mark.parametrize("suffix", [".tif", ".nrrd", ".nii.gz"])
def test_label_volumes_round_trip_array_spacing_and_origin(tmp_path, suffix):
    """write_label_volume then read_volume: the same voxels at the same world positions (TIFF keeps ImageJ's z, y, x
    axis order, so it comes back transposed with spacing and origin in that order)."""
    pytest.importorskip("nrrd")
    pytest.importorskip("nibabel")
    from plantvr.io.label_volume import write_label_volume
    vol = (np.arange(4 * 5 * 6).reshape(4, 5, 6) % 7).astype(np.uint16)
    sp, org = np.array([0.5, 0.7, 1.5]), np.array([3.0, -2.0, 10.0])
    write_label_volume(tmp_path / f"v{suffix}", vol, spacing=sp, origin=org)
    v = read_volume(tmp_path / f"v{suffix}")
    flip = suffix == ".tif"
    np.testing.assert_array_equal(v.array, vol.transpose(2, 1, 0) if flip else vol)
    np.testing.assert_allclose(v.spacing, sp[::-1] if flip else sp, rtol=1e-6)
    np.testing.assert_allclose(v.origin, org[::-1] if flip else org, rtol=1e-6)


# ------------------------------------------------------------------------------------------------ issue 32

def test_tiff_folder_in_natural_order_and_explicit_file_list(tmp_path):
    """img_0 ... img_19 stack as 0, 1, 2, ..., 10 (not name order 0, 1, 10, 11, ...); a list keeps its order."""
    from plantvr.io.volume import load_volume
    a = _vol(np.uint16, (20, 5, 6))
    for k in range(20):
        tifffile.imwrite(tmp_path / f"img_{k}.tif", a[k])
    v = read_volume(tmp_path)
    assert np.array_equal(v.array, a) and v.meta["slices"][:3] == ["img_0.tif", "img_1.tif", "img_2.tif"]
    assert np.array_equal(load_volume(tmp_path), a)
    files = [tmp_path / f"img_{k}.tif" for k in (19, 3, 7)]
    got = read_volume(files)
    assert np.array_equal(got.array, a[[19, 3, 7]]) and got.source == str(files[0])
    assert np.array_equal(read_volume([str(f) for f in files]).array, a[[19, 3, 7]])
    with pytest.raises(ValueError, match="at least 2"):
        read_volume(files[:1])
    with pytest.raises(ValueError, match=r"path\[1\] is not an existing file"):
        read_volume([files[0], tmp_path / "nope.tif"])
    with pytest.raises(ValueError, match="TIFF slices only"):
        read_volume([files[0], tmp_path / "x.dcm"] if (tmp_path / "x.dcm").write_bytes(b"x") else [])


def test_dicom_file_list(tmp_path):
    a = _vol(np.uint16, (5, 6, 7))
    dicom_series(tmp_path, a)
    files = sorted(tmp_path.glob("*.dcm"))[::-1]
    v = read_volume(files)
    assert np.array_equal(v.array, a)                         # ordered by slice position, not by the list


def test_channel_and_time(tmp_path):
    h = _vol(np.uint16, (3, 4, 2, 6, 7))                       # TZCYX
    p = tmp_path / "hyper.tif"
    tifffile.imwrite(p, h, imagej=True, metadata={"axes": "TZCYX", "spacing": 3.0})
    for t in range(3):
        for c in range(2):
            _check(read_volume(p, time=t, channel=c), h[t, :, c], (3.0, 1, 1), (0, 0, 0))
    with pytest.raises(ValueError, match="pick one with channel= or time="):
        read_volume(p, time=1)
    with pytest.raises(ValueError, match=r"time must be in \[0, 2\]"):
        read_volume(p, time=3, channel=0)
    rgb = _vol(np.uint8, (4, 6, 7, 3))
    tifffile.imwrite(tmp_path / "rgb.tif", rgb, photometric="rgb")
    for c in range(3):
        assert np.array_equal(read_volume(tmp_path / "rgb.tif", channel=c).array, rgb[..., c])
    with pytest.raises(ValueError, match="time=0 does not apply"):
        read_volume(tmp_path / "rgb.tif", time=0, channel=0)
    import nibabel as nib
    x4 = _vol(np.int16, (5, 6, 7, 3))
    nib.save(nib.Nifti1Image(x4, np.eye(4)), tmp_path / "t.nii.gz")
    assert np.array_equal(read_volume(tmp_path / "t.nii.gz", time=2).array, x4[..., 2])
    import SimpleITK as sitk
    vec = _vol(np.uint8, (4, 5, 6, 3))
    sitk.WriteImage(sitk.GetImageFromArray(vec, isVector=True), str(tmp_path / "rgb.mha"))
    assert np.array_equal(read_volume(tmp_path / "rgb.mha", channel=1).array, vec[..., 1])
    m4 = _vol(np.int16, (3, 4, 5, 6))                          # (t, z, y, x)
    sitk.WriteImage(sitk.GetImageFromArray(m4, isVector=False), str(tmp_path / "t4.mha"))
    assert np.array_equal(read_volume(tmp_path / "t4.mha", time=2).array, m4[2])
    np.save(tmp_path / "c.npy", vec.transpose(3, 0, 1, 2))
    assert np.array_equal(read_volume(tmp_path / "c.npy", channel=2).array, vec[..., 2])
    for bad in (-1, 1.5, True, "0"):
        with pytest.raises(ValueError, match="channel must be an integer"):
            read_volume(tmp_path / "c.npy", channel=bad)
    three = tmp_path / "three.npy"
    np.save(three, _vol(np.uint8))
    with pytest.raises(ValueError, match="channel=0 does not apply"):
        read_volume(three, channel=0)
    with pytest.raises(ValueError, match="time=0 does not apply .* slice stack"):
        read_volume([tmp_path / "hyper.tif", tmp_path / "rgb.tif"], time=0)


# ------------------------------------------------------------------------------------------------ issue 32: more readers


def _lps_affine(ras_affine):
    """nibabel's RAS+ affine in LPS (VolumeGeometry's frame)."""
    return np.diag([-1.0, -1.0, 1.0, 1.0]) @ np.asarray(ras_affine, np.float64)


@pytest.mark.parametrize("compression, predictor", [("lzw", False), ("lzw", True), ("zlib", True),
                                                    ("zlib", False)])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_tiff_lzw_and_deflate_with_predictor(tmp_path, compression, predictor, dtype):
    pytest.importorskip("imagecodecs")
    a = _vol(dtype)
    p = tmp_path / "c.tif"
    tifffile.imwrite(p, a, imagej=True, resolution=(2.0, 4.0), metadata={"spacing": 3.0, "axes": "ZYX"},
                     compression=compression, predictor=predictor)
    with tifffile.TiffFile(p) as tf:
        assert tf.pages[0].compression.name == {"lzw": "LZW", "zlib": "ADOBE_DEFLATE"}[compression]
        assert (tf.pages[0].predictor > 1) == predictor
    _check(read_volume(p), a, (3.0, 0.25, 0.5), (0, 0, 0), fmt="TIFF")
    lazy = read_volume(p, lazy=True)
    assert np.array_equal(lazy.array.compute(), a)


@pytest.mark.parametrize("suffix", [".mgh", ".mgz"])
@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.int32, np.float32])
def test_mgh_written_by_nibabel(tmp_path, suffix, dtype):
    import nibabel as nib
    a = _vol(dtype, (6, 7, 8))
    aff = np.array([[-0.5, 0.0, 0.1, 10.0], [0.0, 0.0, 1.5, -4.0], [0.0, 0.8, 0.0, 2.5], [0, 0, 0, 1]])
    p = tmp_path / f"v{suffix}"
    nib.MGHImage(a, aff).to_filename(p)
    v = read_volume(p)
    img = nib.load(p)
    assert v.format == "MGH" and v.meta["axes"] == "xyz" and v.shape == a.shape
    assert np.array_equal(np.asarray(v.array), a) and v.array.dtype == a.dtype
    np.testing.assert_allclose(v.geometry.affine, _lps_affine(img.affine), atol=1e-6)
    np.testing.assert_allclose(v.spacing, img.header.get_zooms()[:3], rtol=1e-6)
    frames = np.stack([a, a + 1], axis=-1).astype(dtype)                        # x, y, z, frames
    nib.MGHImage(frames, aff).to_filename(tmp_path / f"f{suffix}")
    assert np.array_equal(read_volume(tmp_path / f"f{suffix}", time=1).array, a + 1)
    with pytest.raises(ValueError, match="pick one with channel= or time="):
        read_volume(tmp_path / f"f{suffix}")


def test_freesurfer_test_mgz_from_nibabel():
    import nibabel as nib
    from nibabel.testing import data_path
    p = Path(data_path) / "test.mgz"
    img = nib.load(p)
    v = read_volume(p, time=0) if len(img.shape) > 3 and img.shape[3] > 1 else read_volume(p)
    assert v.format == "MGH" and v.shape == img.shape[:3]
    np.testing.assert_allclose(v.geometry.affine, _lps_affine(img.affine), atol=1e-5)
    np.testing.assert_array_equal(np.asarray(v.array), np.asanyarray(img.dataobj)[..., 0] if img.ndim > 3
                                  else np.asanyarray(img.dataobj))


@pytest.mark.parametrize("name", ["tiny.mnc", "minc1_1_scale.mnc", "minc2_1_scale.mnc", "small.mnc",
                                  "minc1-no-att.mnc", "minc2-no-att.mnc"])
def test_minc_files_nibabel_ships(name):
    """MINC 1 (netCDF) and MINC 2 (HDF5) test files from nibabel.testing: voxels and affine as nibabel gives them."""
    import nibabel as nib
    from nibabel.testing import data_path
    p = Path(data_path) / name
    img = nib.load(p)
    v = read_volume(p)
    assert v.format == "MINC" and v.shape == img.shape
    np.testing.assert_allclose(np.asarray(v.array), np.asarray(img.dataobj), rtol=1e-12)
    np.testing.assert_allclose(v.geometry.affine, _lps_affine(img.affine), atol=1e-9)
    np.testing.assert_allclose(v.spacing, np.abs(img.header.get_zooms()), rtol=1e-12)
    assert v.meta["axes"] == "zyx"                       # MINC's usual zspace, yspace, xspace order
    corner = v.geometry.index_to_world([[1, 2, 3]])[0]   # one voxel through both affines
    np.testing.assert_allclose(corner * [-1, -1, 1], nib.affines.apply_affine(img.affine, [1, 2, 3]), atol=1e-9)


@pytest.mark.parametrize("name", ["minc1_4d.mnc", "minc2_4d.mnc"])
def test_minc_4d_time(name):
    import nibabel as nib
    from nibabel.testing import data_path
    p = Path(data_path) / name
    img = nib.load(p)
    with pytest.raises(ValueError, match="pick one with channel= or time="):
        read_volume(p)
    v = read_volume(p, time=1)
    assert v.shape == img.shape[1:]
    np.testing.assert_allclose(np.asarray(v.array), np.asarray(img.dataobj)[1], rtol=1e-12)
    np.testing.assert_allclose(v.geometry.affine, _lps_affine(img.affine), atol=1e-9)


def test_vti_cell_data_lies_on_cell_centres(tmp_path):
    """pyvista's uniform example holds point and cell data; a cell array's voxels are the cells, at their
    centres (pyvista's cell_centers), rotated grids included."""
    import pyvista as pv
    from pyvista import examples
    g = examples.load_uniform()
    g.spacing = (0.5, 1.0, 2.0)
    g.origin = (1.0, -2.0, 3.0)
    g.direction_matrix = pv.Transform().rotate_z(30).rotate_x(10).matrix[:3, :3]
    p = tmp_path / "u.vti"
    g.save(p)
    grid = pv.read(p)
    v = read_volume(p, dataset="Spatial Cell Data")
    assert v.meta["on_cells"] and v.shape == tuple(n - 1 for n in grid.dimensions)
    assert np.array_equal(v.array.ravel(order="F"), np.asarray(grid.cell_data["Spatial Cell Data"]))
    idx = np.stack(np.unravel_index(np.arange(np.prod(v.shape)), v.shape, order="F"), axis=1)
    np.testing.assert_allclose(v.geometry.index_to_world(idx), grid.cell_centers().points, atol=1e-9)
    np.testing.assert_allclose(v.spacing, grid.spacing)
    pts = read_volume(p, dataset="Spatial Point Data")
    assert not pts.meta["on_cells"] and pts.shape == grid.dimensions
    pidx = np.stack(np.unravel_index(np.arange(grid.n_points), grid.dimensions, order="F"), axis=1)
    np.testing.assert_allclose(pts.geometry.index_to_world(pidx), grid.points, atol=1e-9)
    only = pv.ImageData(dimensions=(5, 6, 7), spacing=(0.2, 0.3, 0.4), origin=(1, 1, 1))
    only.cell_data["c"] = np.arange(only.n_cells, dtype=np.int16)
    only.save(tmp_path / "c.vti")
    v = read_volume(tmp_path / "c.vti")                   # the only array is a cell array: read by default
    assert v.shape == (4, 5, 6) and v.array.dtype == np.int16
    np.testing.assert_allclose(v.origin, (1.1, 1.15, 1.2))
    with pytest.raises(ValueError, match="cell-data arrays"):
        read_volume(p, dataset="nope")


def test_lazy_reads_raise_the_read_error_when_a_damaged_chunk_is_computed(tmp_path):
    """Issue 32 item 4: lazy=True opens a file whose voxel data is damaged (only its header is read); computing the
    damaged chunk raises a ValueError naming the file, not the codec's own error; healthy chunks still compute."""
    pytest.importorskip("dask.array")
    zarr = pytest.importorskip("zarr")
    a = _vol(np.uint16, (6, 8, 10))
    p = tmp_path / "v.zarr"
    z = zarr.create_array(str(p), shape=a.shape, dtype=a.dtype, chunks=(3, 8, 10))
    z[:] = a
    chunk = p / "c" / "1" / "0" / "0"
    chunk.write_bytes(chunk.read_bytes()[:-7])                 # a truncated zstd chunk
    lz = read_volume(p, lazy=True)
    assert np.array_equal(lz.array[:3].compute(), a[:3])
    with pytest.raises(ValueError, match=r"could not read '.*v\.zarr' as Zarr"):
        lz.array.compute()
    pytest.importorskip("imagecodecs")
    t = tmp_path / "c.tif"
    tifffile.imwrite(t, a, compression="zlib", predictor=True)
    with tifffile.TiffFile(t) as tf:
        off, n = tf.pages[4].dataoffsets[0], tf.pages[4].databytecounts[0]
    raw = bytearray(t.read_bytes())
    raw[off:off + n] = b"\xff" * n                             # page 4's deflate stream is garbage
    t.write_bytes(bytes(raw))
    lt = read_volume(t, lazy=True)
    assert np.array_equal(lt.array[:4].compute(), a[:4])
    with pytest.raises(ValueError, match=r"could not read '.*c\.tif' as TIFF"):
        lt.array.compute()
    with pytest.raises(ValueError, match=r"c\.tif"):           # the eager read says the same
        read_volume(t)
    (tmp_path / "s").mkdir()
    for k in range(a.shape[0]):
        tifffile.imwrite(tmp_path / "s" / f"img_{k}.tif", a[k], compression="zlib")
    raw = bytearray((tmp_path / "s" / "img_3.tif").read_bytes())
    with tifffile.TiffFile(tmp_path / "s" / "img_3.tif") as tf:
        off, n = tf.pages[0].dataoffsets[0], tf.pages[0].databytecounts[0]
    raw[off:off + n] = b"\x00" * n
    (tmp_path / "s" / "img_3.tif").write_bytes(bytes(raw))
    ls = read_volume(tmp_path / "s", lazy=True)
    with pytest.raises(ValueError, match=r"could not read '.*s' as TIFF"):
        ls.array.compute()


def test_mmap_maps_npy_and_plain_tiff_and_load_volume_is_read_volume(tmp_path):
    """Issue 30: one reader per format; load_volume (ViNE's input) is read_volume's voxels, memory-mapped where
    the file allows it."""
    from plantvr.io.volume import load_volume
    a = _vol(np.uint16, (5, 6, 7))
    np.save(tmp_path / "v.npy", a)
    tifffile.imwrite(tmp_path / "v.tif", a, photometric="minisblack")
    tifffile.imwrite(tmp_path / "z.tif", a, compression="zlib")
    for name, mapped in (("v.npy", True), ("v.tif", True), ("z.tif", False)):
        v = read_volume(tmp_path / name, mmap=True)
        assert isinstance(v.array, np.memmap) == mapped and np.array_equal(v.array, a)
        lv = load_volume(tmp_path / name)
        assert isinstance(lv, np.memmap) == mapped and np.array_equal(lv, read_volume(tmp_path / name).array)
    with pytest.raises(ValueError, match="not both"):
        read_volume(tmp_path / "v.tif", mmap=True, lazy=True)
    with pytest.raises(ValueError, match="key=.* does not apply"):
        load_volume(tmp_path / "v.npy", key="volume")
    nib = pytest.importorskip("nibabel")
    nib.save(nib.Nifti1Image(a, np.eye(4)), tmp_path / "v.nii")
    with pytest.raises(ValueError, match=r"must end in \.tif, \.tiff, \.npy or \.npz"):
        load_volume(tmp_path / "v.nii")

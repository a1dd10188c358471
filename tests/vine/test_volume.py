import numpy as np
import pytest
import tifffile
from skimage.transform import downscale_local_mean

from plantvr.io.volume import load_volume
from plantvr.vine.volume import downsample2, histogram, save_volume


@pytest.mark.parametrize("suffix", [".tif", ".npy", ".npz"])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_volume_round_trip(tmp_path, suffix, dtype):
    vol = (np.random.default_rng(0).integers(0, 200, (7, 9, 11))).astype(dtype)
    p = tmp_path / f"v{suffix}"
    save_volume(p, vol)
    got = load_volume(p)
    assert got.dtype == dtype and np.array_equal(np.asarray(got), vol)


def test_load_folder_of_tiff_slices(tmp_path):
    vol = np.random.default_rng(1).integers(0, 255, (5, 8, 6)).astype(np.uint8)
    for i, plane in enumerate(vol):
        tifffile.imwrite(tmp_path / f"slice_{i:03d}.tif", plane)
    assert np.array_equal(load_volume(tmp_path), vol)


def test_load_rejects_bad_files(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        load_volume(tmp_path / "nope.tif")
    np.save(tmp_path / "f.npy", np.zeros((4, 4, 4), np.float16))          # float32 is read since issue 22
    with pytest.raises(ValueError, match="must have dtype uint8, uint16, uint32, int8, int16, int32, float32"):
        load_volume(tmp_path / "f.npy")
    np.save(tmp_path / "two.npy", np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match="3-D"):
        load_volume(tmp_path / "two.npy")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="could not read"):
        load_volume(tmp_path / "bad.npz")
    (tmp_path / "x.raw").write_bytes(b"")
    with pytest.raises(ValueError, match="must end in"):
        load_volume(tmp_path / "x.raw")


def test_downsample2_mean_and_max_match_skimage():
    vol = np.random.default_rng(2).integers(0, 65535, (9, 10, 12)).astype(np.uint16)
    mean = downsample2(vol, slab=2)
    ref = downscale_local_mean(vol[:8].astype(np.float64), (2, 2, 2))
    assert mean.dtype == np.uint16 and mean.shape == (4, 5, 6)
    assert np.abs(mean.astype(np.float64) - ref).max() <= 0.5
    mx = downsample2(vol, method="max")
    assert np.array_equal(mx, vol[:8].reshape(4, 2, 5, 2, 6, 2).max(axis=(1, 3, 5)))
    with pytest.raises(ValueError, match="method"):
        downsample2(vol, method="median")


def test_histogram_counts_all_voxels(head):
    counts, edges = histogram(head.volume, bins=64, slab=7)
    assert counts.sum() == head.volume.size and len(edges) == 65
    ref, _ = np.histogram(head.volume, bins=64, range=(0, 256))
    assert np.array_equal(counts, ref)


def test_suggest_level_separates_structure_from_background(head):
    from plantvr.vine.volume import suggest_level
    lvl = suggest_level(head.volume)
    assert lvl % 1 == 0.5
    assert 20 < lvl < 200
    inside = head.volume > lvl
    assert (inside & (head.labels > 0)).sum() / inside.sum() > 0.9


@pytest.mark.parametrize("byteorder", ["<", ">"])
@pytest.mark.parametrize("mmap", [True, False])
def test_load_big_endian_imagej_stack_is_native_uint16(tmp_path, byteorder, mmap):
    """Issue 22: an ImageJ light-sheet stack (uint16, big-endian) failed with 'uint8 or uint16, got >u2'."""
    vol = np.random.default_rng(3).integers(0, 65535, (6, 7, 8)).astype(np.uint16)
    p = tmp_path / "ij.tif"
    tifffile.imwrite(p, vol, imagej=True, byteorder=byteorder, metadata={"spacing": 2.0, "axes": "ZYX"})
    got = load_volume(p, mmap=mmap)
    assert got.dtype == np.uint16 and got.dtype.isnative and np.array_equal(got, vol)
    plain = tmp_path / "plain.tif"
    tifffile.imwrite(plain, vol, byteorder=byteorder, photometric="minisblack")
    assert np.array_equal(load_volume(plain, mmap=mmap), vol)


@pytest.mark.parametrize("suffix", [".npy", ".npz"])
def test_load_big_endian_npy_npz(tmp_path, suffix):
    vol = np.random.default_rng(4).integers(0, 65535, (4, 5, 6)).astype(">u2")
    p = tmp_path / f"be{suffix}"
    (np.save if suffix == ".npy" else lambda f, a: np.savez(f, volume=a))(p, vol)
    got = load_volume(p)
    assert got.dtype == np.uint16 and got.dtype.isnative and np.array_equal(got, vol)


def test_cores_accept_big_endian_arrays():
    vol = np.random.default_rng(5).integers(0, 200, (6, 6, 6)).astype(">u2")
    counts, _ = histogram(vol, bins=16)
    assert counts.sum() == vol.size
    assert np.array_equal(downsample2(vol, method="max"), downsample2(vol.astype(np.uint16), method="max"))

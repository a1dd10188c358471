"""Float, signed and 8/16/32-bit volumes through the ViNE pipeline, the iso-level in the data's units (issue 22).

scikit-image's ``marching_cubes`` on the whole volume at the same level is the oracle for both slab meshers.
"""
import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree
from skimage.measure import marching_cubes

from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.documents import labels_bundle as B
from plantvr.documents.labels import Segmentation
from plantvr.vine import isosurface as core
from plantvr.io.volume import load_volume
from plantvr.vine.volume import downsample2, histogram, save_volume, suggest_level

CENTRE, RADIUS, N = np.array([23.37, 24.11, 22.83]), 15.3, 48
METHODS = ["flying_edges", "skimage"]


def _distance():
    g = np.indices((N, N, N)).astype(np.float64)
    return np.sqrt(((g - CENTRE[:, None, None, None]) ** 2).sum(axis=0))


@pytest.fixture(scope="module")
def sdf():
    """A float32 signed-distance sphere (voxel units, positive inside): a CT-style level set, level 0."""
    return (RADIUS - _distance()).astype(np.float32)


@pytest.fixture(scope="module")
def ct():
    """int16 CT-like data in Hounsfield units: a +400 HU ball with a smooth rim in -1000 HU air, noise +-20."""
    rng = np.random.default_rng(5)
    hu = -300.0 + 700.0 * np.clip(RADIUS - _distance(), -1.0, 1.0)
    return np.rint(hu + rng.uniform(-20, 20, hu.shape)).astype(np.int16)


def _oracle_gap(surface, vol, level) -> float:
    """Largest distance (voxels) from a vertex to the nearest scikit-image oracle vertex, both ways."""
    ref = marching_cubes(vol.astype(np.float32), level, allow_degenerate=False)[0]
    a = cKDTree(ref).query(surface.vertices)[0].max()
    b = cKDTree(surface.vertices).query(ref)[0].max()
    return float(max(a, b))


def _closed(surface, volume_voxels=None):
    m = trimesh.Trimesh(surface.vertices, surface.faces, process=False)
    assert m.is_watertight and core.signed_volume(surface.vertices, surface.faces) > 0
    if volume_voxels is not None:
        assert abs(m.volume - volume_voxels) < 0.01 * volume_voxels, (m.volume, volume_voxels)


@pytest.mark.parametrize("method", METHODS)
def test_float32_signed_distance_sphere_matches_the_oracle_and_the_sphere(sdf, method):
    s = extract_isosurface(sdf, 0.0, slab=8, method=method)
    assert _oracle_gap(s, sdf, 0.0) < 1e-3                          # measured ~4e-6 voxel (float32 rounding)
    _closed(s, 4 / 3 * np.pi * RADIUS ** 3)
    err = np.abs(np.linalg.norm(s.vertices - CENTRE, axis=1) - RADIUS)
    # linear interpolation of the sampled distance along voxel edges: <= h^2 / (8 r |cos|), 0.008 voxel measured
    assert err.mean() < 3e-3 and err.max() < 1e-2, (err.mean(), err.max())


def test_float_level_beats_a_hand_made_uint16_mapping(sdf):
    """The issue's workaround: the float data mapped to uint16 by hand lies further from the float oracle."""
    lo, hi = float(sdf.min()), float(sdf.max())
    u16 = np.rint((sdf - lo) / (hi - lo) * 65535).astype(np.uint16)
    level16 = (0.0 - lo) / (hi - lo) * 65535
    scale = (hi - lo) / 65535
    mapped = extract_isosurface(u16, level16, slab=8)
    direct = extract_isosurface(sdf, 0.0, slab=8)
    ref = marching_cubes(sdf, 0.0, allow_degenerate=False)[0]
    gap_mapped = cKDTree(ref).query(mapped.vertices)[0].max()
    gap_direct = cKDTree(ref).query(direct.vertices)[0].max()
    assert gap_direct < 1e-4 < gap_mapped and scale > 0, (gap_direct, gap_mapped)


@pytest.mark.parametrize("method", METHODS)
def test_float64_and_big_endian_float_volumes(sdf, method):
    a = extract_isosurface(sdf.astype(np.float64), 0.0, slab=8, method=method)
    b = extract_isosurface(sdf.astype(">f4"), 0.0, slab=8, method=method)
    c = extract_isosurface(sdf, 0.0, slab=8, method=method)
    assert np.array_equal(b.vertices, c.vertices) and np.array_equal(b.faces, c.faces)
    assert len(a.vertices) == len(c.vertices) and np.abs(a.vertices - c.vertices).max() < 1e-4


@pytest.mark.parametrize("method", METHODS)
def test_int16_ct_with_a_negative_level(ct, method):
    level = -300.5
    s = extract_isosurface(ct, level, slab=8, method=method)
    assert _oracle_gap(s, ct, level) < 1e-3
    _closed(s)
    r = np.linalg.norm(s.vertices - CENTRE, axis=1)
    assert np.abs(r - RADIUS).max() < 0.1                             # noise +-20 HU over a 700 HU/voxel rim
    whole = extract_isosurface(ct, level, slab=64, method=method)
    assert len(whole.vertices) == len(s.vertices)                     # seams merged: no duplicated vertex
    assert cKDTree(whole.vertices).query(s.vertices)[0].max() < 1e-4  # up to float32 rounding of the offset


@pytest.mark.parametrize("dtype,scale,offset", [(np.uint32, 1000.0, 70_000.0), (np.int32, 1000.0, -50_000.0),
                                                (np.int8, 8.0, 0.0)])
@pytest.mark.parametrize("method", METHODS)
def test_other_integer_volumes_mesh_at_levels_in_their_units(sdf, dtype, scale, offset, method):
    vol = np.rint(sdf * scale + offset).clip(np.iinfo(dtype).min, np.iinfo(dtype).max).astype(dtype)
    level = offset + 0.5
    s = extract_isosurface(vol, level, slab=8, method=method)
    assert _oracle_gap(s, vol, level) < 1e-3
    _closed(s)


def test_level_outside_the_data_range_is_refused_with_the_range(sdf, ct):
    lo, hi = float(sdf.min()), float(sdf.max())
    for vol, level in ((sdf, hi), (sdf, lo), (sdf, 100.0), (ct, 500.0), (ct, -2000.0)):
        for f in (extract_isosurface, core.extract_isosurface):
            with pytest.raises(ValueError, match=r"level must lie strictly inside the volume's data range"):
                f(vol, level)
    with pytest.raises(ValueError, match="level must be"):
        extract_isosurface(sdf, float("nan"))
    with pytest.raises(ValueError, match=r"\(-1030, 430\)|data range"):
        extract_isosurface(ct, 1e9)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_float_volumes_are_refused_naming_the_volume(tmp_path, sdf, bad):
    vol = sdf.copy()
    vol[40, 3, 5] = bad
    for call in (lambda: extract_isosurface(vol, 0.0), lambda: core.extract_isosurface(vol, 0.0),
                 lambda: histogram(vol), lambda: suggest_level(vol), lambda: downsample2(vol),
                 lambda: Segmentation.from_volume(vol, 0.0)):
        with pytest.raises(ValueError, match=r"volume must hold finite values only, got .*inf|volume must hold "
                                             r"finite values only, got nan"):
            call()
    np.save(tmp_path / "bad.npy", vol)
    with pytest.raises(ValueError, match="finite"):
        load_volume(tmp_path / "bad.npy")
    for dtype in (np.float16, np.int64, np.uint64, np.complex64, bool):
        with pytest.raises(ValueError, match="volume must have dtype uint8, uint16, uint32, int8, int16, int32, "
                                             "float32 or float64"):
            extract_isosurface(np.zeros((4, 4, 4), dtype), 0.5)


def test_memmapped_float_volume_is_meshed_slab_by_slab_without_a_copy(tmp_path):
    """A volume bigger than memory goes through the slab-wise isosurface: a memory map is read plane by plane."""
    import tracemalloc
    n = 160
    mm = np.lib.format.open_memmap(tmp_path / "big.npy", mode="w+", dtype=np.float32, shape=(n, n, n))
    g = np.indices((n, n)).astype(np.float32)
    for i in range(n):                                   # written plane by plane: a cube of half-size 10
        d = np.maximum(np.abs(g[0] - 80), np.abs(g[1] - 80))
        mm[i] = 10.3 - np.maximum(d, abs(i - 80.0))
    mm.flush()
    del mm
    vol = load_volume(tmp_path / "big.npy")
    assert isinstance(vol, np.memmap) and vol.dtype == np.float32
    for method in METHODS:
        tracemalloc.start()
        s = extract_isosurface(vol, 0.0, slab=8, method=method)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert len(s.faces) > 0 and peak < 0.2 * vol.nbytes, peak / 2 ** 20      # the volume is 15.6 MiB
        _closed(s, 20.6 ** 3)


def test_histogram_and_suggest_level_in_data_units(sdf, ct):
    counts, edges = histogram(sdf, bins=64, slab=5)
    ref, ref_edges = np.histogram(sdf, bins=64, range=(float(sdf.min()), float(sdf.max())))
    assert np.array_equal(counts, ref) and np.allclose(edges, ref_edges) and counts.sum() == sdf.size
    counts, edges = histogram(ct, bins=100, slab=7)
    lo, hi = int(ct.min()), int(ct.max())
    ref, ref_edges = np.histogram(ct, bins=100, range=(lo, hi + 1.0))
    assert np.array_equal(counts, ref) and edges[0] == lo and edges[-1] == hi + 1
    const = np.full((4, 4, 4), -2.5, np.float32)
    c, e = histogram(const, bins=4)
    assert c.sum() == 64 and e[0] == -3.0 and e[-1] == -2.0
    with pytest.raises(ValueError, match="constant"):
        suggest_level(const)
    t = suggest_level(ct)
    assert t % 1 == 0.5 and -1000 < t < 400                        # separates air from the ball, off-grid
    s = extract_isosurface(ct, t)
    assert np.abs(np.linalg.norm(s.vertices - CENTRE, axis=1) - RADIUS).max() < 1.1
    from skimage.filters import threshold_otsu
    t = suggest_level(sdf)
    width = (float(sdf.max()) - float(sdf.min())) / 256
    assert float(sdf.min()) < t < float(sdf.max()) and abs(t - threshold_otsu(sdf)) <= width


def test_uint8_and_uint16_keep_their_dtype_range_behaviour():
    vol = np.random.default_rng(1).integers(0, 200, (6, 7, 8)).astype(np.uint8)
    counts, edges = histogram(vol, bins=64)
    assert edges[0] == 0 and edges[-1] == 256 and np.array_equal(counts, np.histogram(vol, 64, (0, 256))[0])
    assert histogram(vol.astype(np.uint16), bins=64)[1][-1] == 65536
    assert suggest_level(vol) % 1 == 0.5
    with pytest.raises(ValueError, match=r"level must be in \(0.0, 255.0\)"):
        extract_isosurface(vol, 255)


def test_downsample2_keeps_the_dtype_and_rounds_half_up():
    from skimage.transform import downscale_local_mean
    rng = np.random.default_rng(3)
    i16 = rng.integers(-32768, 32767, (9, 10, 12)).astype(np.int16)
    s = i16[:8].astype(np.int64).reshape(4, 2, 5, 2, 6, 2).sum(axis=(1, 3, 5))
    got = downsample2(i16, slab=3)
    assert got.dtype == np.int16 and np.array_equal(got, np.floor((s + 4) / 8).astype(np.int16))
    u32 = np.full((4, 4, 4), 2 ** 32 - 1, np.uint32)                   # the sum of 8 overflows uint32
    assert downsample2(u32).dtype == np.uint32 and (downsample2(u32) == 2 ** 32 - 1).all()
    f = rng.normal(0, 100, (8, 10, 12)).astype(np.float32)
    got = downsample2(f)
    assert got.dtype == np.float32 and np.allclose(got, downscale_local_mean(f.astype(np.float64), (2, 2, 2)),
                                                   rtol=0, atol=1e-4)
    assert np.array_equal(downsample2(f, method="max"), f.reshape(4, 2, 5, 2, 6, 2).max(axis=(1, 3, 5)))


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.int16, np.int8, np.uint32, np.int32])
def test_volume_files_keep_the_dtype(tmp_path, dtype, suffix=(".tif", ".npy", ".npz")):
    vol = (np.random.default_rng(0).integers(-100, 100, (5, 6, 7)) + 0.25).astype(dtype)
    if np.dtype(dtype).kind == "u":
        vol = vol + np.asarray(3_000_000_000, dtype)
    for suf in suffix:
        save_volume(tmp_path / f"v{suf}", vol)
        got = np.asarray(load_volume(tmp_path / f"v{suf}"))
        assert got.dtype == dtype and np.array_equal(got, vol), suf


@pytest.mark.parametrize("kind", ["float32", "int16", "uint32"])
def test_segmentation_from_volume_end_to_end(sdf, ct, kind):
    vol, level = {"float32": (sdf, 0.0), "int16": (ct, -300.5),
                  "uint32": (np.rint(sdf * 1000 + 70_000).astype(np.uint32), 70_000.5)}[kind]
    seg = Segmentation.from_volume(vol, level)
    s = extract_isosurface(vol, level, slab=64)
    assert np.array_equal(seg.vertices, s.vertices) and np.array_equal(seg.faces, s.faces)
    n = seg.paint(seg.vertices[0].astype(np.float64), 3.0, 2)
    assert n > 0 and (seg.labels == 2).sum() == n
    seg.undo()
    assert not seg.labels.any()
    small = Segmentation.from_volume(vol, level, downsample=True)
    assert 0 < small.n_vertices < seg.n_vertices


def test_open_source_reads_float_and_signed_files(tmp_path, sdf, ct):
    from plantvr.io.source import open_source
    np.save(tmp_path / "sdf.npy", sdf)
    np.save(tmp_path / "ct.npy", ct)
    src = open_source(tmp_path / "sdf.npy", level=0.0)
    assert src.level == 0.0 and src.volume.dtype == np.float32 and src.seg.n_vertices > 1000
    src = open_source(tmp_path / "ct.npy")                                  # Otsu in Hounsfield units
    assert -1000 < src.level < 400 and src.seg.n_vertices > 1000
    src = open_source(tmp_path / "ct.npy", level=-300.5)
    assert src.level == -300.5
    with pytest.raises(ValueError, match="level must be in"):
        open_source(tmp_path / "ct.npy", level=-5000)


@pytest.mark.parametrize("embed", [True, False])
def test_bundles_keep_float_and_signed_volumes(tmp_path, sdf, ct, embed):
    for name, vol, level in (("f", sdf, 0.0), ("i", ct, -300.5)):
        seg = Segmentation.from_volume(vol, level, slab=16)
        seg.paint(seg.vertices[5].astype(np.float64), 3.0, 4)
        p = tmp_path / f"{name}.zip"
        B.save_bundle(p, seg, volume=vol, level=level, include_mesh=False, embed_volume=embed, slab=16)
        b = B.load_bundle(p) if embed else B.load_bundle(p, volume=vol)
        assert b.level == level and b.volume.dtype == vol.dtype and np.array_equal(b.volume, vol)
        assert np.array_equal(b.segmentation.vertices, seg.vertices)
        assert np.array_equal(b.segmentation.labels, seg.labels)
        assert b.volume_sha256 == B.volume_sha256(vol)
        if not embed:
            with pytest.raises(ValueError, match="made from a volume with sha256"):
                B.load_bundle(p, volume=vol.astype(np.float64 if name == "f" else np.int32))


def test_review_app_level_slider_spans_the_data(sdf, ct):
    pytest.importorskip("trame_vtk")
    from plantvr.view.vine_app import VineReviewApp, histogram_svg
    from plantvr.view.vine_svg import _level_slider
    sl = _level_slider(ct)
    assert sl == {"min": float(ct.min()) + 0.5, "max": float(ct.max()) - 0.5, "step": 1}
    sl = _level_slider(sdf)
    lo, hi = float(sdf.min()), float(sdf.max())
    assert lo < sl["min"] < sl["max"] < hi and np.isclose(sl["step"], (hi - lo) / 1000)
    assert _level_slider(np.arange(8, dtype=np.uint8).reshape(2, 2, 2))["min"] == 0.5
    svg = histogram_svg(ct, -300.5)
    assert svg.count("<rect") == 64 and "<line" in svg
    app = VineReviewApp(volume=sdf, level=0.0, target_faces=2000)
    assert app.state.level == 0.0 and app.seg.n_vertices > 1000
    app.state.level = 5.0                                    # a smaller sphere, in the data's units
    n0 = app.seg.n_vertices
    app.apply_level()
    assert 0 < app.seg.n_vertices < n0

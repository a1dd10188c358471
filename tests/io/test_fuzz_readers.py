"""Every reader and writer of plantvr.io under damaged input (issue 34): seeded byte mutations of files written by
each format's own library.

Each reader gets its valid source file plus: an empty file, random garbage, truncations, random bit flips in the
header and in the body, a byte-swapped magic, a valid file of another format under its suffix, a folder under
its name and a missing path. Every outcome must be a read (the format may hold damaged voxels, e.g. a flipped
pixel) or a ``ValueError``/``OSError`` that names the file; no other exception type may escape, no case may take
longer than a few seconds, and a parameter that does not apply to the format is refused by name. Each writer
must refuse a missing folder, a folder as target and a bad value, leaving the previous file as it was.

Counts per reader (cases, refused, read) are printed at the end (``pytest -s``) for the closing note.
"""
from __future__ import annotations

import csv
import os
import shutil
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from ._dicom import dicom_series

pytestmark = pytest.mark.timeout(120)

#: reader name -> Counter(cases, refused, read)
COUNTS: dict[str, Counter] = {}

#: Longest any one case may take (s): a hang or a runaway allocation shows as a failure, not a stuck run.
MAX_CASE_S = 5.0


@pytest.fixture(scope="module", autouse=True)
def _report():
    yield
    if COUNTS:
        print("\nfuzz counts per reader (cases, refused, read):")
        total = Counter()
        for name, c in COUNTS.items():
            print(f"  {name:28s} {c['cases']:4d} {c['refused']:4d} {c['read']:4d}")
            total.update(c)
        print(f"  {'all':28s} {total['cases']:4d} {total['refused']:4d} {total['read']:4d}")


# --------------------------------------------------------------------------------------------- mutations


def _mutations(raw: bytes, seed: int, *, flips: int = 24):
    """(label, bytes) pairs: empty, garbage, truncations, header and body bit flips, a byte-swapped magic."""
    rng = np.random.default_rng(seed)
    n = len(raw)
    yield "empty", b""
    yield "garbage", rng.integers(0, 256, max(64, min(n, 2048)), dtype=np.uint8).tobytes()
    yield "text garbage", b"hello, this is not that format\n" * 8
    for cut in sorted({1, 4, 8, 16, 64, n // 4, n // 2, 3 * n // 4, n - 16, n - 1}):
        if 0 < cut < n:
            yield f"truncated at {cut}", raw[:cut]
    head = min(n, 512)
    for k in range(flips):
        pos = int(rng.integers(0, head)) if k < 2 * flips // 3 or head == n else int(rng.integers(head, n))
        b = bytearray(raw)
        b[pos] ^= 1 << int(rng.integers(0, 8))
        yield f"bit flip at {pos}", bytes(b)
    if n >= 4:
        yield "swapped magic", raw[:4][::-1] + raw[4:]


def _classify(name: str, path: Path, call, failures: list, label: str, member: str = "") -> str:
    t0 = time.perf_counter()
    try:
        call(path)
        outcome = "read"
    except (ValueError, OSError) as exc:
        msg = str(exc)
        if path.name not in msg and os.fspath(path) not in msg and not (member and member in msg):
            failures.append(f"{name} / {label}: {type(exc).__name__} does not name the file: {msg[:200]}")
        if len(msg) > 1200:
            failures.append(f"{name} / {label}: message of {len(msg)} characters")
        outcome = "refused"
    except Exception as exc:  # noqa: BLE001 - the point of the suite
        failures.append(f"{name} / {label}: {type(exc).__module__}.{type(exc).__name__}: {str(exc)[:200]}")
        outcome = "escaped"
    dt = time.perf_counter() - t0
    if dt > MAX_CASE_S:
        failures.append(f"{name} / {label}: took {dt:.1f} s")
    c = COUNTS.setdefault(name, Counter())
    c["cases"] += 1
    c[outcome] += 1
    return outcome


def _fuzz_file(name: str, src: Path, call, tmp: Path, *, seed: int, others: list[Path] = (),
               flips: int = 24, member: Path | None = None) -> list[str]:
    """Fuzz the reader ``call`` on mutations of ``src``. ``member`` (a file inside the folder ``src``) is the
    file mutated when the source is a folder (a slice stack, a DICOM series, a Zarr store, a detached header)."""
    failures: list[str] = []
    assert _classify(name, src, call, failures, "valid source") == "read", failures
    target = member if member is not None else src
    raw = target.read_bytes()
    for k, (label, data) in enumerate(_mutations(raw, seed, flips=flips)):
        p = tmp / f"m{k}_{src.name}"
        if member is None:
            p.write_bytes(data)
        else:
            shutil.copytree(src, p)
            (p / member.relative_to(src)).write_bytes(data)
        _classify(name, p, call, failures, label, member.name if member is not None else "")
        if p.is_dir():
            shutil.rmtree(p)
    suffix = "".join(src.suffixes[-2:]) if src.name.endswith(".nii.gz") else src.suffix
    for o in others:                                          # a valid file of another format under this suffix
        p = tmp / f"wrong_{o.stem}{suffix}"
        shutil.copytree(o, p) if o.is_dir() else shutil.copy(o, p)
        _classify(name, p, call, failures, f"a {o.suffix} file named {suffix}")
    d = tmp / f"folder{suffix}"
    d.mkdir(exist_ok=True)
    _classify(name, d, call, failures, "an empty folder")
    _classify(name, tmp / f"missing{suffix}", call, failures, "a missing path")
    return failures


# --------------------------------------------------------------------------------------------- sources


def _vol(dtype=np.uint16, shape=(6, 7, 8), seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.standard_normal(shape).astype(dtype)
    return rng.integers(0, 200, shape).astype(dtype)


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    """One valid file per volume flavour, each written by the format's own library."""
    import h5py
    import nibabel as nib
    import nrrd
    import pyvista as pv
    import SimpleITK as sitk
    import tifffile
    import zarr

    d = tmp_path_factory.mktemp("src")
    a = _vol()
    out: dict[str, tuple[Path, Path | None]] = {}
    tifffile.imwrite(d / "plain.tif", a)
    tifffile.imwrite(d / "big.tif", a, byteorder=">")
    tifffile.imwrite(d / "imagej.tif", a, imagej=True, resolution=(2.0, 2.0),
                     metadata={"spacing": 3.0, "axes": "ZYX"})
    tifffile.imwrite(d / "ome.ome.tif", a, ome=True, metadata={"axes": "ZYX", "PhysicalSizeX": 0.5})
    (d / "slices").mkdir()
    for k in range(a.shape[0]):
        tifffile.imwrite(d / "slices" / f"img_{k}.tif", a[k])
    nrrd.write(str(d / "raw.nrrd"), a, {"encoding": "raw", "space directions": np.eye(3), "space": "RAS"})
    nrrd.write(str(d / "gz.nrrd"), a, {"encoding": "gzip"})
    (d / "det").mkdir()
    nrrd.write(str(d / "det" / "v.nhdr"), a, {"encoding": "raw"}, detached_header=True)
    img = nib.Nifti1Image(a, np.diag([0.5, 0.6, 0.7, 1.0]))
    nib.save(img, d / "v.nii")
    nib.save(img, d / "v.nii.gz")
    sitk.WriteImage(sitk.GetImageFromArray(a), str(d / "v.mha"))
    (d / "mhd").mkdir()
    sitk.WriteImage(sitk.GetImageFromArray(a), str(d / "mhd" / "v.mhd"))
    g = pv.ImageData(dimensions=a.shape)
    g.point_data["v"] = a.ravel(order="F")
    g.save(d / "v.vti")
    with h5py.File(d / "v.h5", "w") as f:
        f["vol"] = a
        f["vol"].attrs["element_size_um"] = [1.0, 0.5, 0.5]
    z = zarr.create_array(str(d / "v.zarr"), shape=a.shape, dtype=a.dtype, chunks=(3, 7, 8))
    z[:] = a
    (d / "dicom").mkdir()
    dicom_series(d / "dicom", a, spacing=(0.5, 0.5), dz=2.0, origin=(0.0, 0.0, 0.0), shuffle=False, intercept=None)
    np.save(d / "v.npy", a)
    np.savez(d / "v.npz", volume=a)
    tifffile.imwrite(d / "lzw.tif", a, compression="lzw", predictor=True)
    tifffile.imwrite(d / "deflate.tif", a, compression="zlib", predictor=True)
    nib.MGHImage(a.astype(np.int16), np.diag([0.5, 0.6, 0.7, 1.0])).to_filename(d / "v.mgh")
    nib.MGHImage(a.astype(np.int16), np.diag([0.5, 0.6, 0.7, 1.0])).to_filename(d / "v.mgz")
    from nibabel.testing import data_path
    shutil.copy(Path(data_path) / "minc1_1_scale.mnc", d / "minc1.mnc")
    shutil.copy(Path(data_path) / "small.mnc", d / "minc2.mnc")
    cg = pv.ImageData(dimensions=np.add(a.shape, 1))
    cg.cell_data["c"] = a.ravel(order="F")
    cg.save(d / "cells.vti")
    out = {
        "TIFF plain": (d / "plain.tif", None), "TIFF big-endian": (d / "big.tif", None),
        "TIFF ImageJ": (d / "imagej.tif", None), "TIFF OME": (d / "ome.ome.tif", None),
        "TIFF slice folder": (d / "slices", d / "slices" / "img_3.tif"),
        "NRRD raw": (d / "raw.nrrd", None), "NRRD gzip": (d / "gz.nrrd", None),
        "NRRD detached header": (d / "det", d / "det" / "v.nhdr"),
        "NRRD detached data": (d / "det", d / "det" / "v.raw"),
        "NIfTI .nii": (d / "v.nii", None), "NIfTI .nii.gz": (d / "v.nii.gz", None),
        "MetaImage .mha": (d / "v.mha", None), "MetaImage .mhd": (d / "mhd", d / "mhd" / "v.mhd"),
        "VTI": (d / "v.vti", None), "HDF5": (d / "v.h5", None),
        "Zarr metadata": (d / "v.zarr", d / "v.zarr" / "zarr.json"),
        "Zarr chunk": (d / "v.zarr", d / "v.zarr" / "c" / "0" / "0" / "0"),
        "DICOM series": (d / "dicom", d / "dicom" / "IM0002.dcm"),
        "NumPy .npy": (d / "v.npy", None), "NumPy .npz": (d / "v.npz", None),
        "TIFF LZW predictor": (d / "lzw.tif", None), "TIFF deflate predictor": (d / "deflate.tif", None),
        "MGH .mgh": (d / "v.mgh", None), "MGH .mgz": (d / "v.mgz", None),
        "MINC 1": (d / "minc1.mnc", None), "MINC 2": (d / "minc2.mnc", None), "VTI cell data": (d / "cells.vti", None),
    }
    return out


def _folder_reader(read, inner: str | None):
    """For a source held in a folder: read the folder (slices, DICOM, Zarr) or the named file inside it."""
    def call(p: Path):
        return read(p / inner if inner is not None and p.is_dir() else p)
    return call


# --------------------------------------------------------------------------------------------- volume readers

_FOLDER_INNER = {"NRRD detached header": "v.nhdr", "NRRD detached data": "v.nhdr", "MetaImage .mhd": "v.mhd"}
_OTHERS = ["TIFF plain", "NRRD raw", "NIfTI .nii", "MetaImage .mha", "HDF5", "NumPy .npy"]


@pytest.mark.parametrize("name", ["TIFF plain", "TIFF big-endian", "TIFF ImageJ", "TIFF OME", "TIFF slice folder",
                                  "NRRD raw", "NRRD gzip", "NRRD detached header", "NRRD detached data",
                                  "NIfTI .nii", "NIfTI .nii.gz", "MetaImage .mha", "MetaImage .mhd", "VTI", "HDF5",
                                  "Zarr metadata", "Zarr chunk", "DICOM series", "NumPy .npy", "NumPy .npz",
                                  "TIFF LZW predictor", "TIFF deflate predictor", "MGH .mgh", "MGH .mgz", "MINC 1",
                                  "MINC 2", "VTI cell data"])
def test_fuzz_read_volume(sources, tmp_path, name):
    from plantvr.io.volume import read_volume
    src, member = sources[name]
    call = _folder_reader(read_volume, _FOLDER_INNER.get(name))
    others = [] if member is not None else [sources[o][0] for o in _OTHERS if sources[o][0].suffix != src.suffix]
    failures = _fuzz_file(f"read_volume {name}", src, call, tmp_path, seed=sum(map(ord, name)), others=others,
                          member=member)
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("suffix", [".tif", ".nrrd", ".seg.nrrd", ".nii.gz", ".mha"])
def test_fuzz_label_volume_files(tmp_path, suffix):
    """Label files as write_label_volume writes them, read back by read_volume."""
    from plantvr.io.label_volume import write_label_volume
    from plantvr.io.volume import read_volume
    lab = (_vol(np.uint8) % 4).astype(np.uint8)
    src = write_label_volume(tmp_path / f"labels{suffix}", lab, spacing=(0.5, 0.5, 2.0), origin=(1.0, 2.0, 3.0))
    failures = _fuzz_file(f"label file {suffix}", src, read_volume, tmp_path, seed=len(suffix))
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("suffix", [".tif", ".npy", ".npz"])
def test_fuzz_load_volume(tmp_path, suffix):
    from plantvr.io.volume import load_volume
    from plantvr.vine.volume import save_volume
    save_volume(tmp_path / f"v{suffix}", _vol(np.uint8))
    failures = _fuzz_file(f"load_volume {suffix}", tmp_path / f"v{suffix}", lambda p: load_volume(p, mmap=False),
                          tmp_path, seed=7 + len(suffix))
    assert not failures, "\n".join(failures)


def test_read_volume_refuses_parameters_that_do_not_apply(sources):
    """dataset picks an array inside a container (HDF5, Zarr, .npz, .vti); lazy reads Zarr and TIFF only."""
    from plantvr.io.volume import read_volume
    for name in ("TIFF plain", "NRRD raw", "NIfTI .nii", "MetaImage .mha", "DICOM series", "NumPy .npy"):
        src = sources[name][0]
        with pytest.raises(ValueError, match=r"dataset='nope' does not apply"):
            read_volume(src, dataset="nope")
    for name in ("HDF5", "NumPy .npz", "VTI"):
        with pytest.raises(ValueError, match="dataset must name"):
            read_volume(sources[name][0], dataset="nope")
    for name in ("NRRD raw", "NIfTI .nii", "MetaImage .mha", "HDF5", "NumPy .npy"):
        with pytest.raises(ValueError, match="lazy=True reads"):
            read_volume(sources[name][0], lazy=True)
    for name, (src, _member) in sources.items():              # every source here is 3-D: no channel, no time
        if "detached" in name or name == "MetaImage .mhd":
            src = src / ("v.nhdr" if "NRRD" in name else "v.mhd")
        for kw in ({"channel": 0}, {"time": 0}):
            with pytest.raises(ValueError, match=f"{next(iter(kw))}=0 does not apply"):
                read_volume(src, **kw)


# --------------------------------------------------------------------------------------------- other readers


@pytest.fixture(scope="module")
def others(tmp_path_factory):
    import laspy
    import scipy.io
    import trimesh
    d = tmp_path_factory.mktemp("other")
    rng = np.random.default_rng(1)
    cloud = rng.normal(size=(200, 3))
    np.savetxt(d / "p.xyz", cloud)
    np.savetxt(d / "p.csv", cloud, delimiter=",", header="X,Y,Z", comments="")
    trimesh.PointCloud(cloud).export(d / "p.ply")
    hdr = laspy.LasHeader(point_format=3, version="1.2")
    hdr.scales = [0.001] * 3
    las = laspy.LasData(hdr)
    las.x, las.y, las.z = cloud.T
    las.write(str(d / "p.las"))
    las.write(str(d / "p.laz"), laz_backend=laspy.LazBackend.Lazrs)
    box = trimesh.creation.icosphere(subdivisions=2)
    for ext in ("ply", "obj", "stl", "glb"):
        box.export(d / f"m.{ext}")
    # a QSM: a stem of 4 cylinders and one branch
    start = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 2], [0, 0, 3], [0, 0, 1.5]], float)
    end = np.array([[0, 0, 1], [0, 0, 2], [0, 0, 3], [0, 0, 4], [0.8, 0, 2.2]], float)
    radius = np.array([0.2, 0.18, 0.15, 0.1, 0.05])
    parent = np.array([-1, 0, 1, 2, 1])
    axis = end - start
    length = np.linalg.norm(axis, axis=1)
    ext = np.array([2, 3, 4, 0, 0], float)
    cyl = {"radius": radius[:, None], "length": length[:, None], "start": start, "axis": axis / length[:, None],
           "parent": (parent + 1)[:, None].astype(float), "extension": ext[:, None]}
    scipy.io.savemat(d / "q.mat", {"QSM": {"cylinder": cyl}})
    boc = np.column_stack([[1, 1, 1, 1, 2], [0, 0, 0, 0, 1], [1, 2, 3, 4, 1]]).astype(float)
    scipy.io.savemat(d / "q20.mat", {"Rad": cyl["radius"], "Len": cyl["length"], "Sta": start, "Axe": cyl["axis"],
                                     "CPar": cyl["parent"], "CExt": cyl["extension"], "BoC": boc})
    ids = np.arange(5) + 1
    with open(d / "sf.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["ID", "parentID", "startX", "startY", "startZ", "endX", "endY", "endZ", "radius"])
        w.writerows([[ids[i], ids[parent[i]] if parent[i] >= 0 else -1, *start[i], *end[i], radius[i]]
                     for i in range(5)])
    with open(d / "archi.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["cyl_ID", "parent_ID", "startX", "startY", "startZ", "endX", "endY", "endZ", "radius_cyl"])
        w.writerows([[ids[i], ids[parent[i]] if parent[i] >= 0 else 0, *start[i], *end[i], radius[i]]
                     for i in range(5)])
    return d


def _points(p):
    from plantvr.io.points import read_points
    return read_points(p)


def _qsm(p):
    from plantvr.io.qsm import read_qsm
    return read_qsm(p)


def _mesh(p):
    from plantvr.io.source import open_source
    return open_source(p)


def _model(p):
    from plantvr import Model
    return Model.load(p)


def _sketch(p):
    from plantvr.documents.treesketch import SketchDocument
    return SketchDocument.load(p)


@pytest.mark.parametrize("name, reader", [
    ("p.xyz", _points), ("p.csv", _points), ("p.ply", _points), ("p.las", _points), ("p.laz", _points),
    ("q.mat", _qsm), ("q20.mat", _qsm), ("sf.csv", _qsm), ("archi.csv", _qsm),
    ("m.ply", _mesh), ("m.obj", _mesh), ("m.stl", _mesh), ("m.glb", _mesh),
])
def test_fuzz_other_readers(others, tmp_path, name, reader):
    src = others / name
    pool = [others / n for n in ("p.las", "q.mat", "m.glb", "m.stl") if n.split(".")[-1] != name.split(".")[-1]]
    failures = _fuzz_file(f"{reader.__name__.lstrip('_')} {name}", src, reader, tmp_path, seed=sum(map(ord, name)),
                          others=pool[:2], flips=16)
    assert not failures, "\n".join(failures)


def test_fuzz_tree_files(tmp_path):
    """Tree Wand ``.tree``/``.npz`` files (Model.load) and TreeSketch library entries (SketchDocument.load)."""
    from plantvr import Model
    from plantvr.documents.treesketch import SketchDocument
    m = Model(seed=1)
    m.save(tmp_path / "w.tree")
    m.save(tmp_path / "w.npz")
    failures = []
    for src in (tmp_path / "w.tree", tmp_path / "w.npz"):
        failures += _fuzz_file(f"Model.load {src.suffix}", src, _model, tmp_path, seed=len(src.suffix), flips=12)
    lib = tmp_path / "lib"
    lib.mkdir()
    SketchDocument().save(lib / "s.tree")
    for member in (lib / "s.tree", lib / "s.json"):
        failures += _fuzz_file(f"SketchDocument.load {member.suffix}", lib, lambda p: _sketch(p / "s.tree"),
                               tmp_path, seed=3 + len(member.suffix), member=member, flips=12)
    assert not failures, "\n".join(failures)


def test_read_points_refuses_columns_for_binary_formats(others):
    from plantvr.io.points import read_points
    for name in ("p.ply", "p.las"):
        with pytest.raises(ValueError, match="columns .* does not apply"):
            read_points(others / name, columns=(1, 2, 3))
    assert read_points(others / "p.ply").shape == (200, 3)


# --------------------------------------------------------------------------------------------- writers


def _writers():
    import trimesh

    from plantvr import Model
    from plantvr._fileio import write_atomic, write_npz
    from plantvr.documents.treesketch import SketchDocument
    from plantvr.io.gltf import write_mesh
    from plantvr.io.label_volume import write_label_volume
    from plantvr.io.mesh import export_mesh
    from plantvr.io.obj import write_obj
    from plantvr.io.ply import write_ply
    from plantvr.vine.volume import save_volume
    lab = np.zeros((4, 5, 6), np.uint8)
    lab[1:3, 1:4, 2:5] = 2
    box = trimesh.creation.box()
    v, f = np.asarray(box.vertices), np.asarray(box.faces)
    bad_v = v.copy()
    bad_v[0, 0] = np.nan
    return [
        ("write_label_volume .tif", ".tif", lambda p: write_label_volume(p, lab),
         lambda p: write_label_volume(p, lab.astype(np.float32))),
        ("write_label_volume .nrrd", ".nrrd", lambda p: write_label_volume(p, lab),
         lambda p: write_label_volume(p, lab, spacing=(0, 1, 1))),
        ("write_label_volume .nii.gz", ".nii.gz", lambda p: write_label_volume(p, lab),
         lambda p: write_label_volume(p, lab, origin=(np.inf, 0, 0))),
        ("write_label_volume .mha", ".mha", lambda p: write_label_volume(p, lab),
         lambda p: write_label_volume(p, lab, geometry=np.eye(4))),
        ("write_label_volume .seg.nrrd", ".seg.nrrd", lambda p: write_label_volume(p, lab, names={2: "cell"}),
         lambda p: write_label_volume(p, lab, names={3: "absent"})),
        ("save_volume .tif", ".tif", lambda p: save_volume(p, lab), lambda p: save_volume(p, lab[0])),
        ("save_volume .npz", ".npz", lambda p: save_volume(p, lab), lambda p: save_volume(p, lab.astype(bool))),
        ("write_ply", ".ply", lambda p: write_ply(p, v, f), lambda p: write_ply(p, bad_v, f)),
        ("write_obj", ".obj", lambda p: write_obj(p, v, f), lambda p: write_obj(p, bad_v, f)),
        ("write_mesh .glb", ".glb", lambda p: write_mesh(p, v, f), lambda p: write_mesh(p, bad_v, f)),
        ("export_mesh .ply", ".ply", lambda p: export_mesh(box, p), lambda p: export_mesh(object(), p)),
        ("write_atomic", ".txt", lambda p: write_atomic(p, "x"), lambda p: write_atomic(p, 3)),
        ("write_npz", ".npz", lambda p: write_npz(p, {"a": lab}), lambda p: write_npz(p, {"a": object()})),
        ("Model.save", ".tree", lambda p: Model(seed=0).save(p), lambda p: Model(seed=0).save(str(p) + ".x")),
        ("SketchDocument.save", ".tree", lambda p: SketchDocument().save(p),
         lambda p: SketchDocument().save(os.path.splitext(p)[0] + ".trees")),
    ]


def test_every_writer_refuses_a_missing_folder_a_folder_target_and_bad_values(tmp_path):
    failures = []
    for name, suffix, good, bad in _writers():
        d = tmp_path / name.replace(" ", "_")
        d.mkdir()
        c = COUNTS.setdefault(f"writer {name}", Counter())
        target = d / f"out{suffix}"
        good(target)
        before = target.read_bytes()
        cases = [("missing folder", d / "missing" / "dir" / f"x{suffix}", good),
                 ("a folder as target", d / f"dir{suffix}", good),
                 ("a file as folder", target / f"x{suffix}", good),
                 ("a bad value", target, bad)]
        (d / f"dir{suffix}").mkdir()
        for label, p, fn in cases:
            c["cases"] += 1
            try:
                fn(p)
            except (ValueError, OSError, TypeError) as exc:
                c["refused"] += 1
                if label != "a bad value" and p.name not in str(exc) and p.parent.name not in str(exc):
                    failures.append(f"{name} / {label}: the error does not name the path: {exc}")
            except Exception as exc:  # noqa: BLE001
                failures.append(f"{name} / {label}: {type(exc).__name__}: {exc}")
            else:
                c["read"] += 1
                failures.append(f"{name} / {label}: accepted")
        if (d / "missing").exists():
            failures.append(f"{name}: created the missing folder")
        if target.read_bytes() != before:
            failures.append(f"{name}: a refused write changed the previous file")
        leftovers = [q.name for q in d.iterdir() if q.name.startswith(".")]
        if leftovers:
            failures.append(f"{name}: temporary files left behind: {leftovers}")
    assert not failures, "\n".join(failures)


def test_folder_writers_create_one_level_only(tmp_path):
    """Writers of several files (frame sequences, a tree library) create their own folder, never its parents."""
    from plantvr.growth.sketch_tools import TreeLibrary
    from plantvr.io.obj import write_obj_sequence
    faces = np.array([[0, 1, 2]])
    frames = np.zeros((2, 3, 3))
    assert len(write_obj_sequence(str(tmp_path / "seq"), faces, frames)) == 2
    with pytest.raises(ValueError, match="does not exist"):
        write_obj_sequence(str(tmp_path / "no" / "seq"), faces, frames)
    from plantvr.documents.treesketch import SketchDocument
    doc = SketchDocument()
    with pytest.raises(ValueError, match="cannot read library tree"):   # a failed load creates nothing
        doc.restore(tmp_path / "lib" / "t.tree")
    assert TreeLibrary(tmp_path / "lib").trees() == [] and not (tmp_path / "lib").exists()
    TreeLibrary(tmp_path / "lib").save("t", doc._engine)          # the first save creates the library folder
    with pytest.raises(ValueError, match="does not exist"):
        TreeLibrary(tmp_path / "no" / "lib").save("t", doc._engine)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lib", "seq"]


def test_hypothesis_random_bytes_under_every_suffix(tmp_path_factory):
    """Property: any bytes under any suffix read_volume, read_points or read_qsm take give a read or a ValueError/
    OSError naming the file (hypothesis, on top of the seeded mutations above)."""
    pytest.importorskip("hypothesis")
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from plantvr.io.points import read_points
    from plantvr.io.qsm import read_qsm
    from plantvr.io.volume import read_volume
    readers = [(sfx, read_volume) for sfx in (".tif", ".nrrd", ".nii", ".nii.gz", ".mgh", ".mgz", ".mnc", ".mha",
                                              ".vti", ".h5", ".npy", ".npz")]
    readers += [(sfx, read_points) for sfx in (".xyz", ".csv", ".ply", ".las", ".laz")]
    readers += [(sfx, read_qsm) for sfx in (".mat", ".csv")]
    d = tmp_path_factory.mktemp("hyp")
    failures: list[str] = []
    magic = st.sampled_from([b"", b"II*\x00", b"MM\x00*", b"NRRD0004\n", b"\x93NUMPY", b"\x89HDF\r\n\x1a\n",
                             b"ply\nformat binary_little_endian 1.0\n", b"LASF", b"ObjectType = Image\n",
                             b"PK\x03\x04", b"\x1f\x8b", b"MATLAB 5.0 MAT-file", b"CDF\x01",
                             b"\x00\x00\x00\x01"])

    @settings(max_examples=120, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(k=st.integers(0, len(readers) - 1), head=magic, body=st.binary(max_size=600))
    def run(k, head, body):
        sfx, read = readers[k]
        p = d / f"h{sfx}"
        p.write_bytes(head + body)
        _classify(f"hypothesis {read.__name__}", p, read, failures, f"{sfx} {len(head + body)} bytes")

    run()
    assert not failures, "\n".join(failures[:20])


def _ome_image_v2(path: Path, a: np.ndarray) -> Path:
    """A minimal NGFF 0.4 image (Zarr v2) written with zarr itself: one level, micrometre z, y, x axes."""
    import zarr
    g = zarr.open_group(str(path), mode="w", zarr_format=2)
    g.create_array("0", shape=a.shape, dtype=a.dtype, chunks=(3, 4, 4))[...] = a
    g.attrs.update({"multiscales": [{"version": "0.4", "name": "img", "axes": [
        {"name": n, "type": "space", "unit": "micrometer"} for n in "zyx"], "datasets": [
        {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [2.0, 0.5, 0.5]}]}]}]})
    return path


def test_fuzz_ome_zarr_labels(tmp_path, monkeypatch):
    """OME-Zarr labels as write_label_volume writes them, read back by read_volume under damage (their metadata,
    a chunk); a write that fails part-way leaves the previous labels and the image's label list as they were."""
    pytest.importorskip("zarr")
    from plantvr.io import label_volume as LV
    from plantvr.io.volume import read_volume
    a = _vol()
    img = _ome_image_v2(tmp_path / "img.zarr", a)
    lab = (a % 3).astype(np.uint8)
    out = LV.write_label_volume(img, lab, name="cells")
    failures = []
    for k, member in enumerate((out / ".zattrs", out / "0" / "0.0.0")):
        work = tmp_path / f"m{k}"
        work.mkdir()
        failures += _fuzz_file(f"OME-Zarr labels {member.name}", out, read_volume, work, seed=11 + k,
                               member=member, flips=12)
    assert not failures, "\n".join(failures)
    before = {q.relative_to(img).as_posix(): q.read_bytes() for q in img.rglob("*") if q.is_file()}

    def boom(*args, **kwargs):
        raise OSError("disk full")
    import zarr
    monkeypatch.setattr(zarr.Group, "create_array", boom)
    with pytest.raises(OSError, match="disk full"):
        LV.write_label_volume(img, np.zeros_like(lab), name="cells")
    with pytest.raises(OSError, match="disk full"):
        LV.write_label_volume(img, np.zeros_like(lab), name="other")
    monkeypatch.undo()
    after = {q.relative_to(img).as_posix(): q.read_bytes() for q in img.rglob("*") if q.is_file()}
    assert after == before                                     # no temporary folder, nothing changed
    assert np.array_equal(read_volume(out).array, lab)

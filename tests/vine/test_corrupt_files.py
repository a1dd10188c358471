"""Corrupt files for every format ViNE reads (issue 20): session ``.npz`` (full and labels-only), bundles,
volumes (``.npy``/``.npz``/``.tif``), meshes. Truncations, bit flips, wrong versions, zip bombs, lying headers
and out-of-range indices are refused with a clear ``ValueError``; the segmentation is left unchanged; a bomb
is refused from its headers, before anything is inflated (memory bounded)."""
import io
import json
import re
import tracemalloc
import zipfile

import numpy as np
import pytest

from plantvr._fileio import digest_arrays
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.documents import labels_bundle as B
from plantvr.documents.labels import Segmentation
from plantvr.io import labels as io_labels
from plantvr.io.source import open_source
from plantvr.vine.synth import synth_balls
from plantvr.vine.views import SavedView
from plantvr.io.volume import load_volume
from plantvr.vine.volume import save_volume

BOMB = 256 * 2 ** 20          # inflated size of the bombs below (a few hundred kB on disk)


@pytest.fixture(scope="module")
def surf():
    return extract_isosurface(synth_balls(), 100.0)


def _seg(surf):
    s = Segmentation(surf.vertices, surf.faces, normals=surf.normals)
    s.paint(s.vertices[0], 3.0, 2)
    s.paint(s.vertices[40], 3.0, 5)
    s.undo()
    s.add_view(SavedView(np.zeros(3), np.eye(3), 1.5))
    return s


def _state(seg):
    return digest_arrays(seg._state_arrays(include_mesh=True)), len(seg.log), seg.version


def _npy(a) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.ascontiguousarray(a), allow_pickle=False)
    return buf.getvalue()


def _rezip(src, dst, *, replace=None, add=None, drop=(), comment=None):
    """Copy a zip, replacing/adding members (bytes, or ("bomb", header) for BOMB zero bytes after a header)."""
    with zipfile.ZipFile(src) as z:
        members = {i.filename: z.read(i) for i in z.infolist()}
        old_comment = z.comment
    members.update(replace or {})
    members.update(add or {})
    with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            if name in drop:
                continue
            if isinstance(data, tuple):
                with z.open(name, "w", force_zip64=True) as fh:
                    head = io.BytesIO()
                    np.lib.format.write_array_header_1_0(head, data[1])
                    fh.write(head.getvalue())
                    chunk = bytes(2 ** 20)
                    for _ in range(BOMB // 2 ** 20):
                        fh.write(chunk)
            else:
                z.writestr(name, data)
        z.comment = old_comment if comment is None else comment
    return dst


def _refused(fn, match=None):
    """fn raises a clear ValueError while allocating little (tracemalloc peak under 32 MB)."""
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=match) as e:
            fn()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 32 * 2 ** 20, f"refusing took {peak / 2 ** 20:.0f} MB: {e.value}"
    return e.value


# ------------------------------------------------------------------ session files
def _session_cases(good, tmp, *, labels_only):
    raw = good.read_bytes()
    yield "empty", tmp / "empty.npz", None
    (tmp / "empty.npz").write_bytes(b"")
    for k, cut in enumerate((10, len(raw) // 3, len(raw) // 2, len(raw) - 30, len(raw) - 1)):
        (tmp / f"trunc{k}.npz").write_bytes(raw[:cut])
        yield f"truncated at {cut}", tmp / f"trunc{k}.npz", None
    (tmp / "text.npz").write_text("not a zip")
    yield "text", tmp / "text.npz", None
    yield "wrong version", _rezip(good, tmp / "v.npz", replace={"format.npy": _npy(np.array([2]))}), "format"
    yield "float version", _rezip(good, tmp / "vf.npz", replace={"format.npy": _npy(np.array([1.0]))}), "format"
    yield "missing labels", _rezip(good, tmp / "m.npz", drop=("labels.npy",)), "missing"
    yield "unknown member", _rezip(good, tmp / "u.npz", add={"evil.npy": _npy(np.zeros(3))}), "unexpected"
    yield "bomb member", _rezip(good, tmp / "b.npz", add={"evil.npy": ("bomb", {"descr": "|u1",
                                "fortran_order": False, "shape": (BOMB,)})}), "unexpected"
    yield "bomb labels", _rezip(good, tmp / "bl.npz", replace={"labels.npy": ("bomb", {
        "descr": "|u1", "fortran_order": False, "shape": (BOMB,)})}), "mesh"
    yield "bomb views", _rezip(good, tmp / "bv.npz", replace={"views.npy": ("bomb", {
        "descr": "<f8", "fortran_order": False, "shape": (BOMB // 104, 13)})}), "views"
    yield "lying header", _rezip(good, tmp / "lh.npz", replace={"rgba.npy": _npy(np.zeros((13, 4), np.uint8))[:-20]}), \
        None
    yield "8 TB header", _rezip(good, tmp / "tb.npz", replace={"undo_idx.npy": _npy(np.zeros(0, np.int64)).replace(
        b"(0,)", b"(1099511627776,)")}), None
    yield "pickle", _rezip(good, tmp / "p.npz", replace={"views.npy": _pickled()}), "object"
    n = good_n = _seg_n(good)
    yield "labels past table", _rezip(good, tmp / "lt.npz", replace={"labels.npy": _npy(np.full(n, 200, np.uint8))}), \
        "colour table"
    yield "undo index out of range", _rezip(good, tmp / "ui.npz", replace={
        "undo_idx.npy": _npy(np.array([10 ** 9], np.int64)), "undo_old.npy": _npy(np.zeros(1, np.uint8)),
        "undo_new.npy": _npy(np.ones(1, np.uint8)), "undo_off.npy": _npy(np.array([0, 1]))}), "out of range"
    yield "negative undo index", _rezip(good, tmp / "un.npz", replace={
        "undo_idx.npy": _npy(np.array([-7], np.int64)), "undo_old.npy": _npy(np.zeros(1, np.uint8)),
        "undo_new.npy": _npy(np.ones(1, np.uint8)), "undo_off.npy": _npy(np.array([0, 1]))}), "out of range"
    yield "inconsistent offsets", _rezip(good, tmp / "io.npz", replace={"redo_off.npy": _npy(np.array([0, 5]))}), \
        "inconsistent"
    yield "history label past table", _rezip(good, tmp / "hl.npz", replace={
        "redo_new.npy": _npy(np.full(_len(good, "redo_new"), 250, np.uint8))}), "colour table"
    yield "bad history limits", _rezip(good, tmp / "hlim.npz", replace={
        "history_limits.npy": _npy(np.array([0, -1]))}), "history_limits"
    yield "NaN view", _rezip(good, tmp / "nv.npz", replace={"views.npy": _npy(np.full((1, 13), np.nan))}), "view"
    yield "rgba shape", _rezip(good, tmp / "rs.npz", replace={"rgba.npy": _npy(np.zeros((13, 3), np.uint8))}), \
        "colour table"
    yield "empty colour table", _rezip(good, tmp / "ect.npz", replace={
        "rgba.npy": _npy(np.zeros((0, 4), np.uint8)), "visible.npy": _npy(np.zeros(0, bool))}), "colour table"
    if labels_only:
        yield "other mesh", _rezip(good, tmp / "om.npz", replace={"mesh.npy": _npy(np.array([n, 1, 2]))}), \
            "another mesh"
        yield "labels of another size", _rezip(good, tmp / "ls.npz", replace={
            "labels.npy": _npy(np.zeros(good_n + 1, np.uint8))}), "another mesh"
    else:
        yield "face index out of range", _rezip(good, tmp / "fi.npz", replace={
            "faces.npy": _npy(np.array([[0, 1, 10 ** 9]], np.uint32))}), "faces"
        yield "NaN vertex", _rezip(good, tmp / "nan.npz", replace={
            "vertices.npy": _npy(np.full((n, 3), np.nan, np.float32))}), "finite"
        yield "huge vertex", _rezip(good, tmp / "hv.npz", replace={
            "vertices.npy": _npy(np.full((n, 3), 1e19, np.float32))}), "within"
        yield "normals shape", _rezip(good, tmp / "ns.npz", replace={"normals.npy": _npy(np.zeros((2, 3), np.float32))}), \
            "normals"


def _pickled():
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    return buf.getvalue()


def _seg_n(path):
    with np.load(path) as z:
        return len(z["labels"])


def _len(path, name):
    with np.load(path) as z:
        return len(z[name])


@pytest.mark.parametrize("labels_only", [False, True])
def test_corrupt_session_files_are_refused_and_change_nothing(surf, tmp_path, labels_only):
    seg = _seg(surf)
    good = tmp_path / "good.npz"
    seg.save(good, include_mesh=not labels_only)
    target = _seg(surf)
    target.paint(target.vertices[9], 2.0, 7)
    before = _state(target)
    seen = []
    target.observe(lambda ch: seen.append(ch["new"].kind), names="change")
    n = 0
    for name, path, match in _session_cases(good, tmp_path, labels_only=labels_only):
        if not labels_only:
            _refused(lambda path=path: Segmentation.load(path), match)
        _refused(lambda path=path: target.restore(path), match)
        assert _state(target) == before and not seen, name
        n += 1
    assert n >= 25
    target.restore(good)                                     # the good file still loads
    assert np.array_equal(target.labels, seg.labels) and seen == ["all"]


@pytest.mark.parametrize("labels_only", [False, True])
def test_session_bit_flips_never_load_damaged_data(surf, tmp_path, labels_only):
    seg = _seg(surf)
    good = tmp_path / "good.npz"
    seg.save(good, include_mesh=not labels_only, compress=True)
    raw = good.read_bytes()
    rng = np.random.default_rng(0)
    refused = sum(_flip_refused(surf, seg, raw, int(pos), 1 << int(rng.integers(8)), tmp_path / f"f{k}.npz")
                  for k, pos in enumerate(rng.choice(len(raw), 60, replace=False)))
    assert refused >= 30                              # the rest hit zip time stamps and attributes


def _flip_refused(surf, seg, raw: bytes, pos: int, bit: int, path) -> bool:
    """Restore ``raw`` with ``bit`` flipped at ``pos`` onto a fresh segmentation: True when refused (and nothing
    changed); accepted only where the flip hit bytes that carry no data (a time stamp, padding)."""
    flipped = bytearray(raw)
    flipped[pos] ^= bit
    path.write_bytes(bytes(flipped))
    target = _seg(surf)
    before = _state(target)
    try:
        target.restore(path)
    except ValueError:
        assert _state(target) == before
        return True
    assert digest_arrays(target._state_arrays(include_mesh=False)) == \
        digest_arrays(seg._state_arrays(include_mesh=False)), f"flip at {pos} loaded damaged data"
    return False


def test_every_bit_of_every_npy_header_is_checked(surf, tmp_path):
    """A flipped bit in any ``.npy`` header of an uncompressed session (numpy parses the header dict as Python:
    a damaged one raised SyntaxError or tokenize.TokenError past the door) is refused or changes nothing."""
    seg = _seg(surf)
    good = seg.save(tmp_path / "good.npz", include_mesh=False)
    raw = good.read_bytes()
    heads = [m.start() for m in re.finditer(re.escape(b"\x93NUMPY"), raw)]
    assert len(heads) >= 10
    refused = sum(_flip_refused(surf, seg, raw, pos, 1 << (pos % 8), tmp_path / "f.npz")
                  for h in heads for pos in range(h + 8, h + 8 + 2 + 118, 3))   # header length and dict
    assert refused > 0
    # the header of a member bigger than zipfile's read block: no CRC check at its end catches the damage first
    full = seg.save(tmp_path / "full.npz").read_bytes()
    big = full.index(b"\x93NUMPY", full.index(b"vertices.npy"))
    for a, b in ((b"{", b"N"), (b")", b" "), (b"}", b")"), (b"'", b"(")):   # unmatched or unclosed brackets
        i = full.index(a, big + 10)
        (tmp_path / "g.npz").write_bytes(full[:i] + b + full[i + 1:])
        with pytest.raises(ValueError, match="header"):
            Segmentation.load(tmp_path / "g.npz")


# ------------------------------------------------------------------ bundles
def test_corrupt_bundles_are_refused_and_change_nothing(surf, tmp_path):
    seg = _seg(surf)
    good = tmp_path / "good.vine.zip"
    B.save_bundle(good, seg)
    raw = good.read_bytes()
    target = _seg(surf)
    before = _state(target)
    seen = []
    target.observe(lambda ch: seen.append(ch["new"].kind), names="change")
    with zipfile.ZipFile(good) as z:
        man = json.loads(z.read("manifest.json"))
    cases = [("empty", b""), ("truncated", raw[: len(raw) // 2]), ("tail cut", raw[:-5]), ("text", b"hello")]
    files = []
    for name, data in cases:
        (tmp_path / f"{name}.zip").write_bytes(data)
        files.append((name, tmp_path / f"{name}.zip", None))
    refused = 0
    for k in range(40):                     # bit flips: the checksum or the zip refuses, or no data was hit
        flipped = bytearray(raw)
        flipped[(k * 7919) % len(raw)] ^= 1 << (k % 8)
        (tmp_path / "flip.zip").write_bytes(bytes(flipped))
        other = _seg(surf)
        try:
            B.restore_bundle(other, tmp_path / "flip.zip")
        except ValueError:
            refused += 1
            continue
        assert _state(other)[0] == _state(seg)[0], f"flip {k} loaded damaged data"
    assert refused >= 25
    files += [
        ("unknown member", _rezip(good, tmp_path / "u.zip", add={"evil.txt": b"x"}), "unexpected"),
        ("bomb member", _rezip(good, tmp_path / "b.zip", add={"arrays/evil.npy": ("bomb", {
            "descr": "|u1", "fortran_order": False, "shape": (BOMB,)})}), "unexpected"),
        ("bomb labels", _rezip(good, tmp_path / "bl.zip", replace={"arrays/labels.npy": ("bomb", {
            "descr": "|u1", "fortran_order": False, "shape": (BOMB,)})}), "mesh allows"),
        ("bomb volume", _rezip(good, tmp_path / "bv.zip", add={"arrays/volume.npy": ("bomb", {
            "descr": "|u1", "fortran_order": False, "shape": (4096, 4096, 4096)})}), "bundle"),
        ("no checksum", _rezip(good, tmp_path / "nc.zip", comment=b""), "checksum"),
    ]
    for field, value in (("format", 1), ("include_mesh", "yes"), ("slab", -1), ("level", "x"),
                         ("spacing", [1, 1]), ("event_log", {"a": 1}), ("preserve", "all"), ("mesh", [1])):
        m = dict(man, **{field: value})
        files.append((f"manifest {field}", _forge(good, tmp_path / f"m_{field}.zip", m), field))
    for name, path, match in files:
        try:
            _refused(lambda path=path: B.restore_bundle(target, path), match)
        except AssertionError:
            raise
        assert _state(target) == before and not seen, name
    B.restore_bundle(target, good)
    assert np.array_equal(target.labels, seg.labels) and seen == ["all"]


def _forge(good, dst, manifest):
    """A bundle with another manifest and a recomputed (valid) checksum: only the field checks can refuse it."""
    with zipfile.ZipFile(good) as z:
        members = {n: z.read(n) for n in z.namelist()}
    members["manifest.json"] = json.dumps(manifest, sort_keys=True, indent=1).encode()
    order = ["manifest.json"] + sorted(n for n in members if n != "manifest.json")
    digest = B._digest([(n, members[n]) for n in order])
    with zipfile.ZipFile(dst, "w") as z:
        for n in order:
            z.writestr(n, members[n])
        z.comment = f"{B._MAGIC} sha256={digest}".encode()
    return dst


# ------------------------------------------------------------------ volumes and meshes
def test_corrupt_volumes_are_refused(tmp_path, monkeypatch):
    vol = synth_balls(12)
    for suffix in (".npy", ".npz", ".tif"):
        save_volume(tmp_path / f"v{suffix}", vol)
    cases = []
    for suffix in (".npy", ".npz", ".tif"):
        raw = (tmp_path / f"v{suffix}").read_bytes()
        for k, cut in enumerate((0, 8, len(raw) // 2, len(raw) - 3)):
            (tmp_path / f"t{k}{suffix}").write_bytes(raw[:cut])
            try:
                got = load_volume(tmp_path / f"t{k}{suffix}")
            except ValueError:
                continue
            # only a TIFF cut inside its trailing tag data may still load, and then with every voxel intact
            assert suffix == ".tif" and cut > len(raw) // 2 and np.array_equal(got, vol), (suffix, cut)
        for k, pos in enumerate(range(0, len(raw), max(1, len(raw) // 40))):     # bit flips
            flipped = bytearray(raw)
            flipped[pos] ^= 0x10
            (tmp_path / f"flip{suffix}").write_bytes(bytes(flipped))
            try:
                got = load_volume(tmp_path / f"flip{suffix}", mmap=False)
            except ValueError:
                continue
            assert got.shape == vol.shape and got.dtype == vol.dtype, (suffix, pos)   # never another shape
    npy = (tmp_path / "v.npy").read_bytes()
    (tmp_path / "tb.npy").write_bytes(npy.replace(b"(12, 12, 12)", b"(99999, 99999, 9999)"))
    (tmp_path / "obj.npy").write_bytes(_pickled())
    (tmp_path / "f8.npy").write_bytes(_npy(np.zeros((4, 4, 4), np.float16)))
    cases += [tmp_path / "tb.npy", tmp_path / "obj.npy", tmp_path / "f8.npy"]
    cases.append(_rezip(tmp_path / "v.npz", tmp_path / "bomb.npz", replace={"volume.npy": ("bomb", {
        "descr": "|u1", "fortran_order": False, "shape": (BOMB // 4096, 64, 64)})}))
    cases.append(_rezip(tmp_path / "v.npz", tmp_path / "tbz.npz", replace={"volume.npy": _npy(
        np.zeros((2, 2, 2), np.uint8)).replace(b"(2, 2, 2)", b"(20000, 20000, 20000)")}))
    (tmp_path / "junk.tif").write_bytes(b"II*\x00" + b"\xff" * 64)
    cases.append(tmp_path / "junk.tif")
    import plantvr.io.volume as V
    assert V.MAX_VOLUME_BYTES >= 2 ** 30
    monkeypatch.setattr(V, "MAX_VOLUME_BYTES", BOMB // 4)          # the 256 MB zero volume is over this cap
    for p in cases:
        for mmap in (True, False):
            _refused(lambda p=p, mmap=mmap: load_volume(p, mmap=mmap))
    for suffix in (".npy", ".npz", ".tif"):                       # the good ones still load
        assert np.array_equal(load_volume(tmp_path / f"v{suffix}"), vol)


def test_corrupt_meshes_are_refused(tmp_path):
    s = extract_isosurface(synth_balls(), 100.0)
    seg = Segmentation(s.vertices, s.faces)
    io_labels.export_ply(seg, tmp_path / "m.ply")
    raw = (tmp_path / "m.ply").read_bytes()
    (tmp_path / "t.ply").write_bytes(raw[: len(raw) // 2])
    (tmp_path / "h.ply").write_bytes(raw[:200])
    (tmp_path / "g.obj").write_bytes(b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "e.stl").write_bytes(b"")
    (tmp_path / "x.off").write_bytes(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 99\n")
    for name in ("t.ply", "h.ply", "g.obj", "e.stl", "x.off"):
        with pytest.raises(ValueError):
            open_source(tmp_path / name)
    assert open_source(tmp_path / "m.ply").seg.n_vertices == seg.n_vertices


def test_a_damaged_npy_volume_header_is_refused(tmp_path):
    from plantvr.io.volume import load_volume, read_volume
    np.save(tmp_path / "v.npy", synth_balls(8))
    raw = (tmp_path / "v.npy").read_bytes()
    for a, b in ((b"{", b"N"), (b")", b" "), (b"}", b")")):
        i = raw.index(a, 10)
        (tmp_path / "bad.npy").write_bytes(raw[:i] + b + raw[i + 1:])
        for reader in (load_volume, read_volume):
            with pytest.raises(ValueError, match="as .npy"):
                reader(tmp_path / "bad.npy")

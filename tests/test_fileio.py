"""The one atomic writer and the bounded zip/npz reader every PlantVR format uses (issue 20)."""
import io
import os
import resource
import zipfile
from pathlib import Path

import numpy as np
import pytest

from plantvr._fileio import atomic_write, digest_arrays, read_npz, read_zip, write_atomic, write_npz


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_atomic_write_replaces_and_leaves_nothing(tmp_path):
    p = tmp_path / "a.txt"
    write_atomic(p, "one")
    write_atomic(p, "two")
    assert p.read_text() == "two" and _leftovers(tmp_path) == []


def test_failed_write_keeps_the_old_file_and_no_temp(tmp_path):
    p = tmp_path / "a.bin"
    write_atomic(p, b"old contents")
    with pytest.raises(OSError, match="disk full"):
        with atomic_write(p) as fh:
            fh.write(b"half of the new")
            raise OSError(28, "disk full")
    assert p.read_bytes() == b"old contents" and _leftovers(tmp_path) == []


def test_failed_npz_write_keeps_the_old_file(tmp_path, monkeypatch):
    p = tmp_path / "s.npz"
    write_npz(p, {"a": np.arange(10)})
    before = p.read_bytes()

    def boom(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(np, "savez_compressed", boom)
    with pytest.raises(OSError, match="No space"):
        write_npz(p, {"a": np.arange(20)})
    assert p.read_bytes() == before and _leftovers(tmp_path) == []


def test_atomic_write_names_a_missing_folder(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        write_atomic(tmp_path / "missing" / "a.txt", "x")


def test_atomic_write_keeps_permissions(tmp_path):
    p = tmp_path / "a.txt"
    write_atomic(p, "x")
    os.chmod(p, 0o600)
    write_atomic(p, "y")
    assert (os.stat(p).st_mode & 0o777) == 0o600


def test_read_npz_round_trip_and_allowed(tmp_path):
    arrays = {"a": np.arange(12.0).reshape(3, 4), "b": np.array("text"), "c": np.zeros((0, 3), np.int64),
              "f": np.asfortranarray(np.arange(6).reshape(2, 3))}
    write_npz(tmp_path / "x.npz", arrays)
    back = read_npz(tmp_path / "x.npz", allowed=arrays)
    for k, v in arrays.items():
        assert back[k].dtype == v.dtype and np.array_equal(back[k], v)
    assert digest_arrays(back) == digest_arrays(arrays)
    with pytest.raises(ValueError, match="unexpected members"):
        read_npz(tmp_path / "x.npz", allowed=["a"])


def _bomb(path, n_bytes):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        buf = io.BytesIO()
        np.lib.format.write_array(buf, np.zeros(n_bytes, np.uint8))
        z.writestr("a.npy", buf.getvalue())


def test_read_npz_refuses_a_bomb_before_inflating(tmp_path):
    _bomb(tmp_path / "bomb.npz", 300_000_000)
    assert (tmp_path / "bomb.npz").stat().st_size < 1_000_000
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(ValueError, match="cap"):
        read_npz(tmp_path / "bomb.npz", what="state", max_bytes=10_000_000)
    with pytest.raises(ValueError, match="cap"):
        read_zip(tmp_path / "bomb.npz", max_bytes=10_000_000)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0 < 50_000  # KiB: nothing inflated


def test_read_npz_refuses_a_header_that_lies(tmp_path):
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.zeros(10))
    raw = buf.getvalue().replace(b"(10,)", b"(99,)")  # same header length, 89 elements missing
    with zipfile.ZipFile(tmp_path / "lie.npz", "w") as z:
        z.writestr("a.npy", raw)
    with pytest.raises(ValueError, match="declares"):
        read_npz(tmp_path / "lie.npz")
    # 8 TB declared in the header: refused, no MemoryError
    h = b"{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000,), }"
    hdr = b"\x93NUMPY\x01\x00" + len(h.ljust(118) + b"\n").to_bytes(2, "little") + h.ljust(118) + b"\n"
    with zipfile.ZipFile(tmp_path / "tb.npz", "w") as z:
        z.writestr("a.npy", hdr + b"\0" * 80)
    with pytest.raises(ValueError, match="declares"):
        read_npz(tmp_path / "tb.npz")


def test_read_npz_refuses_pickles_truncations_and_flips(tmp_path):
    np.savez(tmp_path / "obj.npz", a=np.array([{"x": 1}], dtype=object))
    with pytest.raises(ValueError, match="objects"):
        read_npz(tmp_path / "obj.npz")
    write_npz(tmp_path / "ok.npz", {"a": np.arange(1000)}, compress=False)
    data = (tmp_path / "ok.npz").read_bytes()
    for cut in range(0, len(data), max(1, len(data) // 40)):
        (tmp_path / "t.npz").write_bytes(data[:cut])
        with pytest.raises(ValueError, match="cannot read"):
            read_npz(tmp_path / "t.npz")
    flipped = bytearray(data)
    flipped[len(data) // 2] ^= 0x10  # inside the array data: the member's CRC catches it
    (tmp_path / "f.npz").write_bytes(bytes(flipped))
    with pytest.raises(ValueError, match="cannot read"):
        read_npz(tmp_path / "f.npz")


def test_read_npz_names_a_missing_file(tmp_path):
    with pytest.raises(ValueError, match="tree file .*missing.npz"):
        read_npz(tmp_path / "missing.npz", what="tree file")


def test_one_folder_rule_for_every_writer(tmp_path):
    """No writer creates folders: a file's folder must exist; a multi-file writer creates its own folder, one level."""
    from plantvr._fileio import check_target, make_folder
    assert check_target(tmp_path / "a.txt") == tmp_path
    with pytest.raises(ValueError, match=r"folder .*missing.* does not exist"):
        check_target(tmp_path / "missing" / "a.txt")
    with pytest.raises(ValueError, match="is a folder"):
        check_target(tmp_path)
    (tmp_path / "f").write_text("x")
    with pytest.raises(ValueError, match="is not a folder"):
        check_target(tmp_path / "f" / "a.txt")
    assert make_folder(tmp_path / "seq").is_dir()
    with pytest.raises(ValueError, match="does not exist"):
        make_folder(tmp_path / "no" / "seq")
    with pytest.raises(ValueError, match="exists and is not a folder"):
        make_folder(tmp_path / "f")
    assert not (tmp_path / "missing").exists() and not (tmp_path / "no").exists()


def test_read_text_is_the_one_text_reader(tmp_path):
    """Issue 30: one reader for text files (scripts, grammars, point, props, SCN/RBA, OBJ UV and JSON files); every
    failure a ValueError naming what was read, a bad byte located by line and column."""
    import ast

    from plantvr._fileio import TextDecodeError, read_text

    p = tmp_path / "a.txt"
    p.write_bytes("x\nab\xe9\n".encode("latin-1"))
    with pytest.raises(TextDecodeError, match=r"script '.*a.txt' is not UTF-8 text \(byte 0xe9 at offset 4\)") as e:
        read_text(p, what="script")
    assert (e.value.line, e.value.column) == (2, 3)
    p.write_text("héllo\n")
    assert read_text(p) == "héllo\n"
    with pytest.raises(ValueError, match="more than the 3 allowed"):
        read_text(p, max_bytes=3)
    with pytest.raises(ValueError, match="grammar .* does not exist"):
        read_text(tmp_path / "nope.lpy", what="grammar")
    with pytest.raises(ValueError, match="is not a file"):
        read_text(tmp_path)
    with pytest.raises(ValueError, match="path must be a path"):
        read_text(3.5)
    root = Path(__file__).resolve().parent.parent / "plantvr"
    readers = []
    for path in root.rglob("*.py"):
        if path.name == "_fileio.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            f = node.func if isinstance(node, ast.Call) else None
            pathlib_read = isinstance(f, ast.Attribute) and f.attr == "read_text"          # path.read_text()
            decoded = isinstance(f, ast.Attribute) and f.attr == "decode" and isinstance(f.value, ast.Call) and (
                getattr(f.value.func, "attr", None) == "read_bytes")                      # read_bytes().decode()
            if pathlib_read or decoded:
                readers.append(f"{path.relative_to(root)}:{node.lineno}")
    assert readers == [], readers

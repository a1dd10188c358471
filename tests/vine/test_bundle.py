"""Session bundles (issue 15): byte-identical round trips; truncated, tampered or foreign files load nothing."""
import json
import zipfile

import numpy as np
import pytest

from plantvr.documents import labels_bundle as B
from plantvr.documents.labels import Segmentation
from plantvr.vine.synth import synth_flowerhead
from plantvr.vine.views import SavedView


@pytest.fixture(scope="module")
def small():
    return synth_flowerhead(40, rng=2)


@pytest.fixture
def seg(small):
    s = Segmentation.from_volume(small.volume, small.level, slab=16)
    s.paint(s.vertices[10], 4.0, 3)
    s.fill(500, 5)
    s.merge_labels(3, 5)
    s.undo()
    s.paint(s.vertices[900], 3.0, 6, True)
    s.set_color(6, (10, 20, 30))
    s.hide(2)
    s.add_view(SavedView.from_array(np.r_[1.0, 2.0, 3.0, np.eye(3).ravel(), 0.5]))
    s.preserve = (0, 4)
    return s


def _same_state(a, b):
    for k in ("vertices", "faces", "labels", "normals"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    np.testing.assert_array_equal(a.colors.rgba, b.colors.rgba)
    np.testing.assert_array_equal(a.colors.visible, b.colors.visible)
    assert [v.to_array().tolist() for v in a.views] == [v.to_array().tolist() for v in b.views]
    for sa, sb in ((a.history.undo_stack, b.history.undo_stack), (a.history.redo_stack, b.history.redo_stack)):
        assert len(sa) == len(sb)
        for ea, eb in zip(sa, sb):
            np.testing.assert_array_equal(ea.indices, eb.indices)
            np.testing.assert_array_equal(ea.old, eb.old)
            np.testing.assert_array_equal(ea.new, eb.new)
    assert a.log.events == b.log.events
    assert a.preserve == b.preserve


@pytest.mark.parametrize("mode", ["mesh", "embedded", "hash"])
def test_round_trip_byte_identical(tmp_path, small, seg, mode):
    kw = {"volume": small.volume, "level": small.level, "slab": 16, "volume_path": "scans/head.tif"}
    if mode == "embedded":
        kw |= {"include_mesh": False, "embed_volume": True}
    elif mode == "hash":
        kw |= {"include_mesh": False}
    d1 = B.save_bundle(tmp_path / "a.zip", seg, **kw, meta={"user": "x"})
    b = B.load_bundle(tmp_path / "a.zip", volume=small.volume if mode == "hash" else None)
    _same_state(seg, b.segmentation)
    assert b.level == small.level and b.volume_path == "scans/head.tif" and b.meta == {"user": "x"}
    assert b.volume_sha256 == B.volume_sha256(small.volume)
    if mode == "embedded":
        np.testing.assert_array_equal(b.volume, small.volume)
    d2 = B.save_bundle(tmp_path / "b.zip", b.segmentation, **kw, meta={"user": "x"})
    assert d1 == d2
    assert (tmp_path / "a.zip").read_bytes() == (tmp_path / "b.zip").read_bytes()
    # undo/redo continue identically after the round trip
    seg.undo()
    b.segmentation.undo()
    np.testing.assert_array_equal(seg.labels, b.segmentation.labels)


def test_wrong_volume_refused(tmp_path, small, seg):
    B.save_bundle(tmp_path / "a.zip", seg, volume=small.volume, level=small.level, slab=16, include_mesh=False)
    other = small.volume.copy()
    other[0, 0, 0] ^= 1
    with pytest.raises(ValueError, match="was made from a volume with sha256"):
        B.load_bundle(tmp_path / "a.zip", volume=other)
    with pytest.raises(ValueError, match="holds no mesh and no volume; pass volume="):
        B.load_bundle(tmp_path / "a.zip")


def _corruptions(raw: bytes):
    yield "truncated", raw[: len(raw) // 2], "truncated or not a zip file"
    yield "empty", b"", "truncated or not a zip file"
    flipped = bytearray(raw)
    flipped[len(raw) // 3] ^= 0xFF
    yield "flipped byte", bytes(flipped), "bundle"


def test_truncated_or_corrupt_bundle_restores_nothing(tmp_path, small, seg):
    B.save_bundle(tmp_path / "a.zip", seg, volume=small.volume, level=small.level, slab=16)
    raw = (tmp_path / "a.zip").read_bytes()
    target = Segmentation.from_volume(small.volume, small.level, slab=16)
    target.paint(target.vertices[3], 5.0, 9)
    before = (target.labels.copy(), target.colors.rgba.copy(), len(target.history.undo_stack),
              list(target.log))
    seen = []
    target.observe(lambda ch: seen.append(ch["new"].kind), names="change")
    for name, data, match in _corruptions(raw):
        p = tmp_path / f"{name}.zip"
        p.write_bytes(data)
        with pytest.raises(ValueError, match=match):
            B.restore_bundle(target, p)
        assert np.array_equal(target.labels, before[0]) and np.array_equal(target.colors.rgba, before[1])
        assert len(target.history.undo_stack) == before[2] and list(target.log) == before[3]
    assert not seen
    B.restore_bundle(target, tmp_path / "a.zip")
    _same_state(seg, target)
    assert seen == ["all"]


def test_tampered_member_refused(tmp_path, small, seg):
    B.save_bundle(tmp_path / "a.zip", seg, volume=small.volume, level=small.level, slab=16)
    with zipfile.ZipFile(tmp_path / "a.zip") as z:
        members = {n: z.read(n) for n in z.namelist()}
        comment = z.comment
    man = json.loads(members["manifest.json"])
    man["level"] = 1.0
    members["manifest.json"] = json.dumps(man).encode()
    with zipfile.ZipFile(tmp_path / "t.zip", "w") as z:
        for n, data in members.items():
            z.writestr(n, data)
        z.comment = comment
    with pytest.raises(ValueError, match="was modified after saving"):
        B.load_bundle(tmp_path / "t.zip")
    with zipfile.ZipFile(tmp_path / "n.zip", "w") as z:
        z.writestr("x.txt", b"hello")
    with pytest.raises(ValueError, match="has no manifest.json"):
        B.load_bundle(tmp_path / "n.zip")


def test_save_rejects_bad_input(tmp_path, small, seg):
    p = tmp_path / "a.zip"
    for kw, match in [({"include_mesh": False}, "include_mesh=False needs the volume and level"),
                      ({"embed_volume": True}, "embed_volume=True needs volume"),
                      ({"volume": small.volume.astype(np.float16)}, "volume must have dtype"),
                      ({"slab": 1}, "slab must be an integer in"), ({"level": float("nan")}, "level must be"),
                      ({"spacing": (1, 0, 1)}, "spacing must be positive"),
                      ({"meta": {"x": object()}}, "must be JSON-serialisable")]:
        with pytest.raises(ValueError, match=match):
            B.save_bundle(p, seg, **kw)
    with pytest.raises(ValueError, match="seg must be a Segmentation"):
        B.save_bundle(p, object())
    assert not p.exists()

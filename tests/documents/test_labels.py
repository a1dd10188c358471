"""The ViNE labels document on the document base (issue 21): a session of commands recorded through
``seg.log`` replays into a fresh document with identical state bytes (directly and through the log's text),
undo to the start and redo to the end give identical bytes at each end under the byte budget, and observers
get :class:`~plantvr.document.Change` events through ``observe(fn, names="change")``."""
import numpy as np
import pytest

from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.commandlog import CommandLog
from plantvr.document import Change
from plantvr.documents.labels import Segmentation
from plantvr.history import ArrayEdit
from plantvr.vine.colors import ColorTable
from plantvr.vine.proxy import DisplayProxy
from plantvr.vine.synth import synth_balls
from plantvr.vine.views import SavedView


def _blobs(n=20):
    """Two separate balls: a mesh with two connected components."""
    return synth_balls(n, [(5, 10, 10), (14, 10, 10)], 4)


@pytest.fixture(scope="module")
def mesh():
    return extract_isosurface(_blobs(), 100.0)


def _seg(mesh, **kw):
    return Segmentation(mesh.vertices, mesh.faces, normals=mesh.normals, **kw)


def _session(s):
    """Paint, strokes (committed and aborted), fill, split, merge, colours, visibility, undo and redo."""
    left = s.vertices[s.vertices[:, 0] < 10]
    right = s.vertices[s.vertices[:, 0] >= 10]
    s.paint(left[0], 2.0, 2)
    s.paint(right[0], 2.0, 2)
    with s.stroke():
        s.paint(left[5], 2.5, 3)
        s.paint(left[9], 2.5, 3)
    s.begin_stroke()
    s.paint(right[3], 3.0, 4)
    s.abort_stroke()
    s.paint_stroke([right[7], right[11]], 1.5, 5, preserve=True)
    s.fill(int(np.flatnonzero(s.labels == 0)[0]), 6)
    s.split_label(2)
    s.merge_labels(3, 5)
    s.set_color(1, (10, 20, 30))
    k = s.add_color((40, 50, 60))
    s.paint(left[2], 1.0, k)
    s.hide(4)
    s.undo()
    s.undo()
    s.redo()
    s.show(4)
    s.paint(right[1], 2.0, 7, preserve=(0, 6))


def test_labels_replay_gives_identical_state_bytes(mesh):
    a = _seg(mesh)
    _session(a)
    assert a.log.document == "vine" and {e.command for e in a.log} >= {
        "paint", "begin_stroke", "end_stroke", "abort_stroke", "fill", "split_label", "merge_labels", "set_color",
        "add_color", "set_visible", "undo", "redo"}
    b = _seg(mesh)
    b.replay(a.log)
    assert b.state_bytes() == a.state_bytes() and np.array_equal(b.labels, a.labels)
    c = _seg(mesh)
    text = a.log.to_text()
    c.replay(CommandLog.from_text(text, commands=Segmentation.COMMANDS, document=Segmentation.KIND))
    assert c.state_bytes() == a.state_bytes()
    assert c.log.to_text().count("\n") == text.count("\n")         # the replay is logged as it ran
    with pytest.raises(ValueError, match="'vine' session, not a 'treewand'"):
        CommandLog.from_text(text, document="treewand")


def test_labels_undo_to_start_and_redo_to_end_under_budget(mesh):
    s = _seg(mesh, max_undo=100, max_undo_bytes=200_000)
    start = s.state_bytes()
    _session(s)
    while s.can_redo:                       # the session ends with undone items: apply them first
        s.redo()
    end = s.state_bytes()
    assert end != start
    n = 0
    while s.undo() is not None:
        n += 1
        assert s.history.nbytes <= s.history.max_bytes
    labels = slice(8 * 3, 8 * 3 + s.n_vertices)                      # colour edits are not undo items
    assert s.state_bytes()[labels] == start[labels] and np.count_nonzero(s.labels) == 0
    for _ in range(n):
        assert s.redo() is not None
        assert s.history.nbytes <= s.history.max_bytes
    assert s.state_bytes() == end
    # every undo item is one record sized to its change: 6 bytes per changed vertex (int32 id, old, new)
    assert all(isinstance(e, ArrayEdit) and e.nbytes == 6 * len(e) for e in s.history.undo_stack)
    assert s.labels.nbytes == s.n_vertices                            # 1 byte per vertex


def test_undo_redo_bytes_from_a_fresh_document(mesh):
    """Undo everything back to a fresh document's bytes (colours added by split stay, as the spec says:
    compare against a fresh document that made the same colours)."""
    s = _seg(mesh)
    fresh = _seg(mesh)
    s.paint(s.vertices[0], 2.0, 2)
    s.paint(s.vertices[40], 3.0, 3)
    with s.stroke():
        s.paint(s.vertices[80], 2.0, 4)
        s.paint(s.vertices[90], 2.0, 4)
    s.fill(int(np.flatnonzero(s.labels == 0)[0]), 5)
    end = s.state_bytes()
    while s.undo() is not None:
        pass
    assert s.state_bytes() == fresh.state_bytes()
    while s.redo() is not None:
        pass
    assert s.state_bytes() == end and s.history.nbytes <= s.history.max_bytes


def test_replay_is_all_or_nothing(mesh):
    s = _seg(mesh)
    s.paint(s.vertices[0], 2.0, 2)
    before, n_log, version = s.state_bytes(), len(s.log), s.version
    seen = []
    s.observe(lambda ch: seen.append(ch["new"]), names="change")
    log = CommandLog(Segmentation.COMMANDS, document="vine")
    log.record("paint", center=s.vertices[3].tolist(), radius=2.0, label=3)
    log.record("set_visible", label=3, visible=False)
    log.record("paint", center=s.vertices[5].tolist(), radius=2.0, label=3)   # hidden by then: refused
    with pytest.raises(ValueError, match=r"event 2 \(paint\).*label 3 is hidden"):
        s.replay(log)
    assert (s.state_bytes(), len(s.log), s.version) == (before, n_log, version) and not seen
    log.events.pop()
    s.replay(log)                           # one "all" change for the whole replay
    assert [c.kind for c in seen] == ["all"] and seen[0].command == "replay" and not s.colors.visible[3]


def test_changes_carry_kind_ids_and_command(mesh):
    s = _seg(mesh)
    proxy = DisplayProxy(s, target_faces=len(s.faces) // 4)
    seen, shown = [], []
    s.observe(lambda ch: seen.append(ch["new"]), names="change")
    proxy.observe(lambda ch: shown.append(ch["new"]), names="change")
    n = s.paint(s.vertices[0], 2.0, 2)
    c = seen[-1]
    assert isinstance(c, Change) and c.kind == "labels" and c.command == "paint" and len(c.ids) == n
    assert c.version == s.version and s.can_undo and not s.can_redo
    assert shown[-1].kind == "labels" and np.array_equal(shown[-1].ids, np.flatnonzero(proxy.labels == 2))
    with s.stroke():
        s.paint(s.vertices[40], 2.0, 3)
    assert seen[-1].command == "end_stroke" and seen[-1].ids.size == 0
    s.hide(3)
    assert seen[-1].kind == shown[-1].kind == "visibility"
    s.add_view(SavedView(np.zeros(3), np.eye(3), 2.0))
    assert seen[-1].kind == "views"
    s.undo()
    assert seen[-1].command == "undo" and s.can_redo
    proxy.close()
    scene = s.scene()
    assert list(scene) == ["surface"] and scene["surface"].colors.shape == (s.n_vertices, 4)


# ---------------------------------------------------------------- uint16 labels (issue 22)
def test_labels_are_uint8_by_default_and_save_as_format_1(mesh, tmp_path):
    s = _seg(mesh)
    _session(s)
    assert s.labels.dtype == np.uint8 and not s.colors.wide
    s.save(tmp_path / "a.npz")
    with np.load(tmp_path / "a.npz") as z:
        assert z["format"].tolist() == [1] and z["labels"].dtype == np.uint8 and z["undo_old"].dtype == np.uint8


def test_uint16_session_matches_the_uint8_one(mesh, tmp_path):
    """The same commands on uint16 labels give the same label values, undo, redo, save and load (format 2)."""
    a, b = _seg(mesh), _seg(mesh, labels=np.zeros(len(mesh.vertices), np.uint16))
    assert b.labels.dtype == np.uint16 and b.colors.wide and len(b.colors) == len(a.colors)
    _session(a)
    _session(b)
    assert b.labels.dtype == np.uint16
    np.testing.assert_array_equal(a.labels, b.labels)
    for s in (a, b):
        while s.history.undo_stack:
            s.undo()
    np.testing.assert_array_equal(a.labels, b.labels)
    for s in (a, b):
        while s.history.redo_stack:
            s.redo()
    np.testing.assert_array_equal(a.labels, b.labels)
    b.save(tmp_path / "w.npz")
    with np.load(tmp_path / "w.npz") as z:
        assert z["format"].tolist() == [2] and z["labels"].dtype == np.uint16
    back = Segmentation.load(tmp_path / "w.npz")
    assert back.labels.dtype == np.uint16 and back.state_bytes() == b.state_bytes()
    b.save(tmp_path / "l.npz", include_mesh=False)
    c = _seg(mesh, labels=np.zeros(len(mesh.vertices), np.uint16))
    c.restore(tmp_path / "l.npz")
    assert c.state_bytes() == b.state_bytes()
    c.undo()
    back.undo()
    np.testing.assert_array_equal(c.labels, back.labels)
    d = _seg(mesh, labels=np.zeros(len(mesh.vertices), np.uint16))
    d.replay(b.log)
    assert d.state_bytes() == b.state_bytes()


def test_918_labels_get_a_colour_table_and_paint(mesh):
    lab = np.zeros(len(mesh.vertices), np.uint16)
    lab[::7] = 918
    s = _seg(mesh, labels=lab)
    assert len(s.colors) == 919 and s.colors.capacity == 65536 and len(s.colors.paintable_lut()) == 65536
    v = s.vertices[0]
    assert s.paint(v, 3.0, 917) > 0 and np.any(s.labels == 917)
    with s.stroke():
        s.paint(v, 2.0, 900)
        s.paint(v, 3.5, 901)
    s.undo()
    assert np.any(s.labels == 917) and not np.any(s.labels == 901)
    with pytest.raises(ValueError, match="labels must be < 13"):
        _seg(mesh, labels=lab, colors=ColorTable())
    with pytest.raises(ValueError, match="uint8 or uint16"):
        _seg(mesh, labels=lab.astype(np.int32))


def test_add_color_past_256_widens_once(mesh, tmp_path):
    s = _seg(mesh)
    s.paint(s.vertices[0], 3.0, 2)
    before = s.labels.copy()
    seen = []
    s.observe(lambda ch: seen.append(ch["new"].kind), names="change")
    while len(s.colors) < 256:
        s.add_color((1, 2, 3))
    assert s.labels.dtype == np.uint8 and "all" not in seen
    k = s.add_color((4, 5, 6))
    assert k == 256 and s.labels.dtype == np.uint16 and seen[-1] == "all"
    np.testing.assert_array_equal(s.labels, before)
    assert s.paint(s.vertices[0], 5.0, 256) > 0
    s.undo()
    s.undo()                                           # the uint8-era paint undoes on the uint16 labels
    assert not s.labels.any()
    s.redo()
    np.testing.assert_array_equal(s.labels, before)
    s.add_color((7, 8, 9))
    assert s.labels.dtype == np.uint16 and seen.count("all") == 1
    s.save(tmp_path / "p.npz")
    assert Segmentation.load(tmp_path / "p.npz").state_bytes() == s.state_bytes()
    fresh = _seg(mesh)
    fresh.replay(s.log)
    assert fresh.labels.dtype == np.uint16 and fresh.state_bytes() == s.state_bytes()


def test_session_format_must_match_the_label_dtype(mesh, tmp_path):
    s = _seg(mesh, labels=np.zeros(len(mesh.vertices), np.uint16))
    s.paint(s.vertices[0], 3.0, 2)
    arrays = s._state_arrays()
    bad = dict(arrays, format=np.array([1], np.int64))
    np.savez(tmp_path / "b1.npz", **bad)
    with pytest.raises(ValueError, match="labels must be uint8"):
        Segmentation.load(tmp_path / "b1.npz")
    bad = dict(arrays, labels=arrays["labels"].astype(np.uint8))
    np.savez(tmp_path / "b2.npz", **bad)
    with pytest.raises(ValueError, match="labels must be uint16"):
        Segmentation.load(tmp_path / "b2.npz")
    bad = dict(arrays, undo_old=arrays["undo_old"].astype(np.uint8))
    np.savez(tmp_path / "b3.npz", **bad)
    with pytest.raises(ValueError, match="history arrays have the wrong dtypes"):
        Segmentation.load(tmp_path / "b3.npz")
    np.savez(tmp_path / "b4.npz", **dict(arrays, format=np.array([3], np.int64)))
    with pytest.raises(ValueError, match=r"format must be \[1\] or \[2\]"):
        Segmentation.load(tmp_path / "b4.npz")

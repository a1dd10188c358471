"""The ViNE labels document on the document base (issue 21): a session of commands recorded through
``seg.log`` replays into a fresh document with identical state bytes (directly and through the log's text),
undo to the start and redo to the end give identical bytes at each end under the byte budget, and observers
get :class:`~plantvr.document.Change` events through ``observe(fn, names="change")``."""
import numpy as np
import pytest

from plantvr.commandlog import CommandLog
from plantvr.document import Change
from plantvr.documents.labels import Segmentation
from plantvr.history import ArrayEdit
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.vine.proxy import DisplayProxy
from plantvr.vine.views import SavedView


def _blobs(n=20):
    """Two separate balls: a mesh with two connected components."""
    g = np.mgrid[:n, :n, :n].astype(np.float32)
    a = np.sqrt(((g - np.array([5, 10, 10])[:, None, None, None]) ** 2).sum(0)) < 4
    b = np.sqrt(((g - np.array([14, 10, 10])[:, None, None, None]) ** 2).sum(0)) < 4
    return ((a | b) * 200).astype(np.uint8)


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

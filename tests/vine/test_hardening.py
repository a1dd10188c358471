"""Issue 20 for ViNE: atomic saves, autosave after every state change, validation at the door, replay checked
before applying, bounded volume reads, one-line CLI errors."""
import inspect
import os
import zipfile

import numpy as np
import pytest

from plantvr._fileio import digest_arrays
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.commandlog import CommandLog, Event
from plantvr.documents import labels_bundle as B
from plantvr.documents.labels import Segmentation
from plantvr.io import labels as io_labels
from plantvr.vine.synth import synth_balls
from plantvr.vine.views import SavedView
from plantvr.io.volume import load_volume
from plantvr.vine.volume import save_volume


def _blobs(n=20):
    """Two separate balls: a mesh with two connected components."""
    return synth_balls(n, [(5, 10, 10), (14, 10, 10)], 4)


@pytest.fixture(scope="module")
def mesh():
    return extract_isosurface(_blobs(), 100.0)


def _seg(mesh):
    return Segmentation(mesh.vertices, mesh.faces, normals=mesh.normals)


def _state(seg):
    return digest_arrays(seg._state_arrays(include_mesh=False))


def _left(a, b):
    """Vertices of ball a (x < 10) and ball b."""
    return a.vertices[a.vertices[:, 0] < 10][0].astype(float), a.vertices[a.vertices[:, 0] >= 10][0].astype(float)


# ------------------------------------------------------------------ autosave (item 7)
def _painted(s):
    pa, pb = _left(s, s)
    s.paint(pa, 2.0, 2)
    s.paint(pb, 2.0, 2)
    return s


MUTATING = {   # every public command that changes saved state, with a call that changes it
    "paint": lambda s: s.paint(s.vertices[0], 2.0, 3),
    "paint_stroke": lambda s: s.paint_stroke([s.vertices[0], s.vertices[5]], 2.0, 3),
    "begin_stroke": lambda s: (s.begin_stroke(), s.paint(s.vertices[0], 2.0, 3), s.end_stroke()),
    "end_stroke": lambda s: (s.begin_stroke(), s.paint(s.vertices[0], 2.0, 3), s.end_stroke()),
    "stroke": lambda s: _with_stroke(s),
    "abort_stroke": lambda s: (s.begin_stroke(), s.paint(s.vertices[0], 3.0, 4), s.abort_stroke()),
    "undo": lambda s: s.undo(),
    "redo": lambda s: s.redo(),
    "fill": lambda s: s.fill(0, 5),
    "split_label": lambda s: s.split_label(2),
    "merge_labels": lambda s: s.merge_labels(4, 2),
    "set_color": lambda s: s.set_color(1, (1, 2, 3)),
    "add_color": lambda s: s.add_color((9, 9, 9)),
    "set_visible": lambda s: s.set_visible(2, False),
    "hide": lambda s: s.hide(2),
    "show": lambda s: s.show(2),
    "toggle_visible": lambda s: s.toggle_visible(2),
    "add_view": lambda s: s.add_view(SavedView(np.zeros(3), np.eye(3), 2.0)),
    "replay": lambda s: s.replay(_log(("paint", {"center": s.vertices[0].tolist(), "radius": 2.0, "label": 6}),
                                      ("set_color", {"label": 6, "rgb": (5, 5, 5)}))),
    "restore": lambda s: s.restore(s._other),
    "enable_autosave": lambda s: None,              # saves at once: checked by the fixture below
}
SETUP = {  # state a command needs first, set up without autosave
    "abort_stroke": lambda s: _painted(s), "undo": lambda s: _painted(s),
    "redo": lambda s: (_painted(s), s.undo()), "split_label": lambda s: _painted(s),
    "merge_labels": lambda s: _painted(s), "show": lambda s: s.colors.set_visible(2, False),
}
# public members that change no saved state (queries, exports, loaders, observers); `preserve` is a brush
# setting of the live session (saved in bundles, not in the labels-only autosave file)
READ_ONLY = {"check_preserve",
             "from_volume", "graph", "index", "label_components", "label_table", "load", "mesh_fingerprint",
             "n_vertices", "observe", "unobserve", "save", "smoothed_colors", "vertex_colors", "vertex_visible",
             "visible_faces", "preserve"}


def _log(*events):
    """A command log of ``(command, kwargs)`` pairs, unchecked (replay must check it)."""
    log = CommandLog()
    log.events = [Event(c, kw) for c, kw in events]
    return log


def _with_stroke(s):
    with s.stroke():
        s.paint(s.vertices[0], 2.0, 3)
        s.paint(s.vertices[3], 2.0, 3)


def _public(cls):
    return {n for n, v in inspect.getmembers(cls) if not n.startswith("_") and (callable(v) or isinstance(v, property))}


def test_every_public_member_is_classified():
    from plantvr.document import Document  # the document base's members are classified there
    base = _public(Document) - set(MUTATING) - READ_ONLY
    assert _public(Segmentation) - base == set(MUTATING) | READ_ONLY


@pytest.mark.parametrize("name", sorted(MUTATING))
def test_every_state_change_autosaves(name, mesh, tmp_path):
    s = _seg(mesh)
    other = _seg(mesh)
    other.paint(other.vertices[7], 3.0, 8)
    other.save(tmp_path / "other.npz", include_mesh=False)
    s._other = tmp_path / "other.npz"
    SETUP.get(name, lambda s: None)(s)
    auto = tmp_path / "auto.npz"
    s.enable_autosave(auto)
    assert auto.exists()
    if name != "enable_autosave":
        auto.unlink()                                    # the command itself must write it
    before = _state(s)
    MUTATING[name](s)
    if name not in ("enable_autosave", "abort_stroke"):          # an aborted stroke writes labels back
        assert _state(s) != before, name
    fresh = _seg(mesh)
    fresh.restore(auto)                                  # the autosave file holds the state after the command
    assert _state(fresh) == _state(s), name
    assert sorted(os.listdir(tmp_path)) == ["auto.npz", "other.npz"]


@pytest.mark.parametrize("name", sorted(READ_ONLY - {"from_volume", "load", "graph", "index", "n_vertices",
                                                      "preserve"}))
def test_read_only_members_change_no_state(name, mesh, tmp_path):
    s = _painted(_seg(mesh))
    before = _state(s), list(s.log)
    calls = {
        "check_preserve": lambda: s.check_preserve((1, 2)), "label_components": lambda: s.label_components(2),
        "label_table": lambda: s.label_table(), "mesh_fingerprint": s.mesh_fingerprint,
        "observe": lambda: s.observe(print, names="change"),
        "unobserve": lambda: s.unobserve(print, names="change"),
        "save": lambda: s.save(tmp_path / "s.npz"), "smoothed_colors": lambda: s.smoothed_colors(2),
        "vertex_colors": s.vertex_colors, "vertex_visible": s.vertex_visible, "visible_faces": s.visible_faces,
    }
    calls[name]()
    assert (_state(s), list(s.log)) == before


def test_split_and_replay_autosave_once(mesh, tmp_path, monkeypatch):
    s = _painted(_seg(mesh))
    s.enable_autosave(tmp_path / "auto.npz")
    saves = []
    real = Segmentation.save
    monkeypatch.setattr(Segmentation, "save", lambda self, *a, **k: (saves.append(1), real(self, *a, **k)))
    s.split_label(2)
    assert len(saves) == 1
    s.replay(_log(*[("paint", {"center": tuple(map(float, s.vertices[0])), "radius": 2.0, "label": 6})] * 3))
    assert len(saves) == 2


# ------------------------------------------------------------------ atomic saves (item 3)
def _boom(*_a, **_k):
    raise OSError(28, "No space left on device")


def _writers(s, tmp_path):
    vol = _blobs(12)
    return {
        "session.npz": lambda p: s.save(p),
        "labels.npz": lambda p: s.save(p, include_mesh=False, compress=True),
        "b.vine.zip": lambda p: B.save_bundle(p, s),
        "m.ply": lambda p: io_labels.export_ply(s, p),
        "m.glb": lambda p: io_labels.export_gltf(s, p),
        "t.csv": lambda p: io_labels.export_label_table(s, p),
        "v.npy": lambda p: save_volume(p, vol),
        "v.npz": lambda p: save_volume(p, vol),
        "v.tif": lambda p: save_volume(p, vol),
    }


def _half_way(real):
    """atomic_write whose file object writes half of the first chunk, then fails (disk full)."""
    import contextlib

    @contextlib.contextmanager
    def cm(path, mode="wb"):
        with real(path, mode) as fh:
            class Half:
                def write(self, data):
                    fh.write(data[:len(data) // 2])
                    _boom()

                def __getattr__(self, k):
                    return getattr(fh, k)
            yield Half()
    return cm


@pytest.mark.parametrize("fail", ["fsync", "half way"])
def test_failed_save_keeps_the_old_file_and_leaves_nothing(fail, mesh, tmp_path, monkeypatch):
    s = _painted(_seg(mesh))
    writers = _writers(s, tmp_path)
    for name, write in writers.items():
        p = tmp_path / name
        write(p)
        old = p.read_bytes()
        s.paint(s.vertices[11], 4.0, 7)                       # the next save would write other bytes
        with monkeypatch.context() as m:
            if fail == "fsync":
                m.setattr(os, "fsync", _boom)
            else:                                           # the writer dies after writing part of the file
                import plantvr._fileio as F
                m.setattr(F, "atomic_write", _half_way(F.atomic_write))
                for mod in ("documents.labels_file", "documents.labels_bundle", "io.ply", "io.gltf", "io.labels", "vine.volume"):
                    m.setattr(f"plantvr.{mod}.atomic_write", F.atomic_write)
            with pytest.raises(OSError):
                write(p)
        assert p.read_bytes() == old, name
        s.undo()
    assert sorted(os.listdir(tmp_path)) == sorted(writers), os.listdir(tmp_path)


def test_save_into_a_missing_folder_is_a_clear_error(mesh, tmp_path):
    s = _seg(mesh)
    with pytest.raises(ValueError, match="does not exist"):
        s.save(tmp_path / "nope" / "s.npz")
    with pytest.raises(ValueError, match="does not exist"):
        save_volume(tmp_path / "nope" / "v.npy", _blobs(8))


# ------------------------------------------------------------------ validation (item 9)
def test_set_visible_needs_a_real_bool(mesh):
    s = _seg(mesh)
    for bad in ("no", "", 1, 0, None, 2.0, [True]):
        with pytest.raises(ValueError, match="visible must be True or False"):
            s.set_visible(1, bad)
    assert s.colors.visible.all() and not s.log.events and s.version == 0
    s.set_visible(1, np.False_)
    assert not s.colors.visible[1]


def test_set_color_rejects_out_of_range_and_fractional_components(mesh):
    s = _seg(mesh)
    rgba = s.colors.rgba.copy()
    for bad in ((0.5, 200.7, 3.2), (0, 256, 0), (-1, 0, 0), (0, 0, np.nan), (1, 2), (1, 2, 3, 4, 5), "red",
                (0, 1e300, 0), None):
        with pytest.raises(ValueError, match="rgb"):
            s.set_color(1, bad)
        with pytest.raises(ValueError, match="rgb"):
            s.add_color(bad)
    assert np.array_equal(s.colors.rgba, rgba) and not s.log.events
    s.set_color(1, (0.0, 200.0, 3.0))                    # integral floats are fine
    assert s.colors.rgba[1, :3].tolist() == [0, 200, 3]


def test_replay_checks_every_event_before_applying_any(mesh):
    s = _seg(mesh)
    s.paint(s.vertices[0], 2.0, 4)
    before = _state(s), list(s.log), s.version
    seen = []
    s.observe(lambda ch: seen.append(ch["new"].kind), names="change")
    v = tuple(map(float, s.vertices[3]))
    paint = ("paint", {"center": v, "radius": 2.0, "label": 3})
    for bad in ([paint, ("set_color", {"label": 1, "rgb": (0.5, 200.7, 3.2)})],
                [paint, ("paint", {"center": v, "radius": 2.0})],
                [paint, ("set_visible", {"label": 1, "visible": "no"})],
                [paint, ("fill", {"vertex": 10 ** 12, "label": 2, "radius": None})],
                [paint, ("explode", {})], [paint, ("paint", [v, 2.0, 3])]):
        with pytest.raises(ValueError, match="event"):
            s.replay(_log(*bad))
        assert (_state(s), list(s.log), s.version) == before and not seen
    for bad in ("paint", 7, [None], [paint]):
        with pytest.raises(ValueError, match="CommandLog"):
            s.replay(bad)
    good = [paint, ("undo", {}), ("redo", {}), ("set_color", {"label": 3, "rgb": (1, 2, 3)})]
    a, b = _seg(mesh), _seg(mesh)
    for op, kw in good:
        getattr(a, op)(**kw)
    b.replay(_log(*good))
    assert _state(a) == _state(b) and [(e.command, e.kwargs) for e in a.log] == [(e.command, e.kwargs) for e in b.log]


def test_volume_headers_are_checked_before_allocating(tmp_path, monkeypatch):
    import plantvr.io.volume as V
    # .npy whose header declares 8 TB over a tiny file
    hdr = {"descr": "|u1", "fortran_order": False, "shape": (20000, 20000, 20000)}
    with open(tmp_path / "huge.npy", "wb") as fh:
        np.lib.format.write_array_header_1_0(fh, hdr)
        fh.write(b"\0" * 64)
    for mmap in (True, False):
        with pytest.raises(ValueError, match="huge.npy"):
            load_volume(tmp_path / "huge.npy", mmap=mmap)
    # .npz whose member header declares 8 TB
    with zipfile.ZipFile(tmp_path / "huge.npz", "w") as z:
        import io
        buf = io.BytesIO()
        np.lib.format.write_array_header_1_0(buf, hdr)
        z.writestr("volume.npy", buf.getvalue() + b"\0" * 64)
    with pytest.raises(ValueError, match="more than"):
        load_volume(tmp_path / "huge.npz")
    # a real volume over the stated cap is refused from its header (.npy read, .npz, .tif)
    vol = _blobs(16)
    for suffix in (".npy", ".npz", ".tif"):
        save_volume(tmp_path / f"v{suffix}", vol)
    monkeypatch.setattr(V, "MAX_VOLUME_BYTES", vol.nbytes - 1)
    for name in ("v.npz", "v.tif"):
        with pytest.raises(ValueError, match="more than"):
            load_volume(tmp_path / name, mmap=False)
    with pytest.raises(ValueError, match="more than"):
        load_volume(tmp_path / "v.npy", mmap=False)
    assert np.array_equal(load_volume(tmp_path / "v.npy"), vol)      # a memory map needs no memory
    # truncated .npy
    raw = (tmp_path / "v.npy").read_bytes()
    (tmp_path / "t.npy").write_bytes(raw[:-10])
    with pytest.raises(ValueError, match="truncated"):
        load_volume(tmp_path / "t.npy")


# ------------------------------------------------------------------ CLI (item 10)
def _cli(capsys, argv):
    from plantvr import cli
    try:
        rc = cli.main(argv)
    except SystemExit as exc:
        rc = exc.code
    err = capsys.readouterr().err
    return rc, err


@pytest.mark.parametrize("args", [
    ["synth:16", "--faces", "-1"], ["synth:16", "--stamps", "0"], ["synth:16", "--lod", "3"],
    ["synth:16", "--port", "70000"], ["synth:16", "--level", "inf"], ["synth:16", "--out", ""],
    ["EMPTY"], ["FLAT"], ["synth:16", "--level", "300"],
])
def test_segment_cli_bad_arguments_are_one_line_and_exit_2(args, capsys, tmp_path):
    np.save(tmp_path / "empty.npy", np.zeros((0, 0, 0), np.uint8))
    np.save(tmp_path / "flat.npy", np.full((8, 8, 8), 7, np.uint8))
    args = [str(tmp_path / "empty.npy") if a == "EMPTY" else str(tmp_path / "flat.npy") if a == "FLAT" else a
            for a in args]
    out = tmp_path / "out"
    rc, err = _cli(capsys, ["segment", *args, *([] if "--out" in args else ["--out", str(out)])])
    assert rc == 2 and "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("plantvr segment: error: "), err
    assert not out.exists()                                   # checked before anything is written


def test_segment_cli_flat_volume_message(capsys, tmp_path):
    np.save(tmp_path / "flat.npy", np.full((8, 8, 8), 7, np.uint8))
    rc, err = _cli(capsys, ["segment", str(tmp_path / "flat.npy"), "--out", str(tmp_path / "o")])
    assert rc == 2 and "constant" in err

"""Model files (issue 20): round trips of every growth variant, atomic saves, and a corrupt-file suite for
``.tree``, ``.npz`` and event logs (truncations, bit flips, versions, bombs, out-of-range arrays): every bad file
is refused with a clear ``ValueError`` and leaves the model as it was."""
import hashlib
import io
import json
import os
import tracemalloc
import zipfile

import numpy as np
import pytest

import plantvr
from plantvr import _fileio
from plantvr.commandlog import CommandLog as EventLog
from plantvr.growth import treefile
from plantvr.growth.tree import Tree, check_tree_arrays
from plantvr.params import PARAMS


def _grow(seed=0, steps=12, **params):
    m = plantvr.Model(seed=seed, **params)
    m.paint_stroke([[0, y, 0] for y in range(2, 9)], radius=2.5, n_darts=40)
    m.step(steps)
    m.prune([0, 6, 0], 1.0)
    m.paint([1.5, 7, 0], 1.5, 30)
    m.step(2)
    return m


def _state(m, tmp_path) -> bytes:
    """The model's full state as bytes (the deterministic ``.npz``)."""
    return m.save(tmp_path / "_state.npz").read_bytes()


def _variants():
    out = [{}]
    for p in PARAMS:
        for c in p.choices:
            if c != p.default:
                out.append({p.name: c, **({"branching": "opposite"} if p.name == "opposite_main" else {})})
        if p.kind is bool:
            out.append({p.name: not p.default})
    return out


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    d = tmp_path_factory.mktemp("small")
    m = plantvr.Model(seed=0)
    m.step(1)
    return m, m.save(d / "s.tree"), m.save(d / "s.npz")


@pytest.fixture(scope="module")
def grown():
    return _grow()


# -- round trips -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kw", _variants(), ids=lambda kw: ",".join(f"{k}={v}" for k, v in kw.items()) or "default")
def test_every_growth_variant_round_trips_byte_identically(tmp_path, kw):
    m = _grow(**kw)
    for suffix in (".tree", ".npz"):
        a = m.save(tmp_path / f"a{suffix}")
        b = plantvr.Model.load(a)
        assert b.n_internodes == m.n_internodes > 1
        assert b.params == m.params
        assert b.save(tmp_path / f"b{suffix}").read_bytes() == a.read_bytes()
    c = plantvr.Model.load(tmp_path / "a.npz")
    for k, v in m.tree.arrays().items():
        np.testing.assert_array_equal(c.tree.arrays()[k], v, err_msg=k)
    np.testing.assert_array_equal(c.snapshot.markers, m.snapshot.markers)
    assert c.steps_done == m.steps_done


def test_opposite_tree_survives_load_and_export(tmp_path, capsys):
    """Issue 20 item 2: an opposite-branching tree loaded back as a single internode."""
    m = plantvr.Model(seed=0, branching="opposite")
    m.paint_stroke([[0, y, 0] for y in range(2, 10)], radius=2.5)
    m.step(20)
    n = m.n_internodes
    assert n > 20
    for suffix in (".tree", ".npz"):
        loaded = plantvr.Model.load(m.save(tmp_path / f"o{suffix}"))
        assert loaded.n_internodes == n and loaded.branching == "opposite" and loaded.tree.nslots == 3
    from plantvr.cli import main
    assert main(["export", str(tmp_path / "o.tree"), "--format", "obj", "-o", str(tmp_path / "o.obj")]) == 0
    assert f"({n} internodes" in capsys.readouterr().out


def test_npz_resume_continues_like_the_original(tmp_path, grown):
    a = plantvr.Model.load(grown.save(tmp_path / "g.npz"))
    b = plantvr.Model.load(tmp_path / "g.npz")
    for m in (a, b):
        m.paint([0, 10, 0], 2.0, 40)
        m.step(3)
    assert a.save(tmp_path / "a.npz").read_bytes() == b.save(tmp_path / "b.npz").read_bytes()
    assert a.n_internodes > grown.n_internodes


# -- atomic saves ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".tree", ".npz"])
def test_failed_save_keeps_the_previous_file_and_leaves_no_temp(tmp_path, monkeypatch, grown, suffix):
    path = grown.save(tmp_path / f"t{suffix}")
    before = path.read_bytes()
    other = plantvr.Model(seed=5)

    def full_disk(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(_fileio.os, "fsync", full_disk)  # the data went to the temp file; then the disk is full
    with pytest.raises(OSError, match="No space"):
        other.save(path)
    monkeypatch.undo()

    def half_then_fail(p, data):
        with _fileio.atomic_write(p, "w" if isinstance(data, str) else "wb") as fh:
            fh.write(data[: len(data) // 2])
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(plantvr.documents.treewand, "write_atomic", half_then_fail)
    with pytest.raises(OSError, match="No space"):
        other.save(path)
    assert path.read_bytes() == before and os.listdir(tmp_path) == [path.name]


def test_save_rejects_bad_paths_clearly(tmp_path, grown):
    for bad, match in [(tmp_path / "t.txt", "must end in .tree or .npz"), (None, "path must be"),
                       (3, "path must be"), (tmp_path / "missing" / "t.tree", "does not exist")]:
        with pytest.raises(ValueError, match=match):
            grown.save(bad)
    assert os.listdir(tmp_path) == []


# -- corrupt .tree ---------------------------------------------------------------------------------------------
def _restore_rejected(m, path, tmp_path, before=None):
    before = before if before is not None else _state(m, tmp_path)
    with pytest.raises(ValueError) as e:
        m.restore(path)
    assert _state(m, tmp_path) == before
    return str(e.value)


def test_every_single_bit_flip_of_a_tree_file_is_refused(tmp_path, small):
    """Issue 20 item 8: 6 of 12 single-bit flips loaded damaged data. Every flip is refused by the parser
    Model.restore runs (or is not UTF-8); every 17th goes through Model.restore itself."""
    m0, tree_path, _ = small
    good = tree_path.read_bytes()
    m = plantvr.Model(seed=3)
    before = _state(m, tmp_path)
    bad = tmp_path / "flip.tree"
    for i in range(len(good) * 8):
        data = bytearray(good)
        data[i // 8] ^= 1 << (i % 8)
        try:
            text = bytes(data).decode("utf-8")
        except UnicodeDecodeError:
            text = None
        if text is not None:
            with pytest.raises(ValueError):
                treefile.tree_from_text(text)
        if i % 17 == 0:
            bad.write_bytes(bytes(data))
            with pytest.raises(ValueError, match="cannot load"):
                m.restore(bad)
    assert _state(m, tmp_path) == before


def test_tree_truncations_versions_and_caps_are_refused(tmp_path, small, monkeypatch):
    _, tree_path, _ = small
    good = tree_path.read_text()
    m = plantvr.Model(seed=3)
    before = _state(m, tmp_path)
    bad = tmp_path / "bad.tree"
    for cut in sorted({*range(0, len(good), 7), len(good) - 1, len(good) - 2}):
        bad.write_text(good[:cut])
        _restore_rejected(m, bad, tmp_path, before)
    for version, match in [("99", "version '99' is not supported"), ("1", "version '1' is not supported")]:
        bad.write_text(good.replace("# plantvr-tree 2", f"# plantvr-tree {version}", 1))
        assert match in _restore_rejected(m, bad, tmp_path, before)
    bad.write_text(good.rsplit("# sha256=", 1)[0])
    assert "no checksum" in _restore_rejected(m, bad, tmp_path, before)
    bad.write_text(good.replace("tree=N(0.0", "tree=N(0.5", 1))
    assert "checksum mismatch" in _restore_rejected(m, bad, tmp_path, before)
    monkeypatch.setattr(plantvr.documents.treewand, "MAX_TREE_BYTES", 100)
    bad.write_text(good)
    assert "more than the 100 allowed" in _restore_rejected(m, bad, tmp_path, before)


def _sign(text: str) -> str:
    text = text.rsplit("# sha256=", 1)[0] if "# sha256=" in text else text
    return text + f"# sha256={hashlib.sha256(text.encode()).hexdigest()}\n"


@pytest.mark.parametrize("x", ["1e19", "1e300", "-9.3e18", "nan", "inf"])
def test_tree_node_out_of_range_is_refused_at_parse(x, small):
    good = small[1].read_text()
    bad = _sign(good.replace("tree=N(0.0,", f"tree=N({x},", 1))
    with pytest.raises(ValueError, match="node at character 0"):
        treefile.tree_from_text(bad)


@pytest.mark.parametrize("body,match", [
    ("N(0,0,0,0,1,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)BB]B-", "has more than|slots|first internode"),
    ("N(0,0,0,0,1,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)BBB]--", "more than 2 slots"),
    ("N(0,0,0,0,1,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)B]--", "1 of 2 slots"),
    ("N(0,0,0,0,2,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)BB]-", "unit vectors"),
    ("N(0,0,0,0,1,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)BB]-N(0,0,0,0,1,0,1,0,0)", "more than 2 slots"),
    ("N(0,0,0,0,1,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)BB]-]", "unbalanced"),
    ("N(0,0,0,0,1,0,1,0,0)B-", "first internode"),
])
def test_malformed_tree_bodies_are_refused(body, match):
    text = _sign("# plantvr-tree 2\ntree=" + body + "\n")
    with pytest.raises(ValueError, match=match):
        treefile.tree_from_text(text)


# -- corrupt .npz ----------------------------------------------------------------------------------------------
def _arrays(path):
    return dict(_fileio.read_npz(path))


def _forge(path, arrays, *, resign=True):
    arrays = dict(arrays)
    if resign:
        arrays.pop("checksum", None)
        arrays["checksum"] = np.array(_fileio.digest_arrays(arrays))
    _fileio.write_npz(path, arrays)
    return path


def _bad_arrays(good):
    n = len(good["tree_pos"])
    child = good["tree_child"]
    cases = {}

    def case(name, **changes):
        cases[name] = {**good, **changes}

    for v in (-7, 10**9, n):
        c = child.copy()
        c[1, 0] = v
        case(f"child={v}", tree_child=c)
    p = good["tree_parent"].copy()
    p[2] = 10**9
    case("parent=1e9", tree_parent=p)
    p = good["tree_parent"].copy()
    p[-1] = 0
    case("parent-child-mismatch", tree_parent=p)
    c = child.copy()
    c[0, 1] = 1
    case("node-in-two-slots", tree_child=c)
    for v in (np.nan, 1e19, -9.3e18, np.inf):
        pos = good["tree_pos"].copy()
        pos[1, 1] = v
        case(f"pos={v}", tree_pos=pos)
    case("pos-float32", tree_pos=good["tree_pos"].astype(np.float32))
    case("parent-int32", tree_parent=good["tree_parent"].astype(np.int32))
    case("alive-int", tree_alive=good["tree_alive"].astype(np.int64))
    case("short-radius", tree_radius=good["tree_radius"][:-1])
    case("markers-(5,2)", markers=np.zeros((5, 2)), marker_age=np.zeros(5, np.int64))
    case("markers-nan", markers=np.full((2, 3), np.nan), marker_age=np.zeros(2, np.int64))
    case("markers-1e100", markers=np.full((2, 3), 1e100), marker_age=np.zeros(2, np.int64))
    case("marker_age-length", marker_age=np.zeros(len(good["markers"]) + 1, np.int64))
    case("new_nodes-out", new_nodes=np.array([n + 5]))
    case("nslots-mismatch", nslots=np.array(3, np.int64))
    case("nslots-7", nslots=np.array(7, np.int64))
    case("version-99", version=np.array(99, np.int64))
    cases["version-missing"] = {k: v for k, v in good.items() if k != "version"}
    cases["no-markers"] = {k: v for k, v in good.items() if k != "markers"}
    case("params-not-json", params=np.array("{oops"))
    case("params-list", params=np.array("[1, 2]"))
    case("params-deep", params=np.array("[" * 100_000 + "]" * 100_000))
    case("params-bad-value", params=np.array(json.dumps({"view_radius": -3})))
    case("rng-garbage", rng_state=np.array('{"bit_generator": "PCG64", "state": 5}'))
    case("rng-list", rng_state=np.array("[1]"))
    case("step-negative", step_count=np.array(-1, np.int64))
    case("format-other", format=np.array("something"))
    lat = good["tree_lat"].copy()
    lat[1] = 0
    case("zero-lat", tree_lat=lat)
    return cases


def test_npz_out_of_range_arrays_are_refused(tmp_path, grown):
    good = _arrays(grown.save(tmp_path / "g.npz"))
    m = plantvr.Model(seed=3)
    before = _state(m, tmp_path)
    for name, arrays in _bad_arrays(good).items():
        path = _forge(tmp_path / f"{name}.npz", arrays)
        msg = _restore_rejected(m, path, tmp_path, before)
        assert "PlantVR state" in msg and str(path) in msg, (name, msg)
    path = _forge(tmp_path / "ok.npz", good)
    assert plantvr.Model.load(path).n_internodes == grown.n_internodes  # the forger itself is fine


def test_tree_check_is_the_one_validation(grown):
    t = grown.tree
    a = t.arrays()
    check_tree_arrays(a, t.nslots)
    assert Tree.from_arrays(a, t.nslots).n == t.n
    for bad, match in [({**a, "child": a["child"][:, :2]}, "child"),
                       ({k: v for k, v in a.items() if k != "L"}, "missing"),
                       ({**a, "extra": a["L"]}, "unknown")]:
        with pytest.raises(ValueError, match=match):
            check_tree_arrays(bad, t.nslots)
    with pytest.raises(ValueError, match="nslots"):
        check_tree_arrays(a, 4)


def test_npz_checksum_truncation_flips_and_members(tmp_path, small):
    _, _, npz = small
    good = npz.read_bytes()
    m = plantvr.Model(seed=3)
    before = _state(m, tmp_path)
    ref = plantvr.Model.load(npz)
    ref_state = _state(ref, tmp_path)
    bad = tmp_path / "bad.npz"
    for cut in range(0, len(good), max(len(good) // 80, 1)):
        bad.write_bytes(good[:cut])
        _restore_rejected(m, bad, tmp_path, before)
    rng = np.random.default_rng(0)
    accepted = 0
    for i in rng.choice(len(good) * 8, 160, replace=False):
        data = bytearray(good)
        data[i // 8] ^= 1 << (i % 8)
        bad.write_bytes(bytes(data))
        try:
            m2 = plantvr.Model.load(bad)
        except ValueError:
            continue
        accepted += 1  # a flip in a zip timestamp or similar: the data must then be exactly the saved data
        assert _state(m2, tmp_path) == ref_state
    assert accepted < 80  # zip header fields no reader checks (timestamps, versions); never the data
    arrays = _arrays(npz)
    _forge(bad, {**arrays, "tree_pos": arrays["tree_pos"] + 1e-9}, resign=False)
    assert "checksum mismatch" in _restore_rejected(m, bad, tmp_path, before)
    _forge(bad, {**arrays, "evil": np.zeros(3)})
    assert "unexpected members" in _restore_rejected(m, bad, tmp_path, before)
    _forge(bad, {k: v for k, v in arrays.items() if k != "checksum"}, resign=False)
    assert "no checksum" in _restore_rejected(m, bad, tmp_path, before)
    with zipfile.ZipFile(bad, "w") as z:  # a pickled object array
        buf = io.BytesIO()
        np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
        z.writestr("params.npy", buf.getvalue())
    assert "Python objects" in _restore_rejected(m, bad, tmp_path, before)


def test_npz_bomb_is_refused_before_inflating(tmp_path, monkeypatch, small):
    m = plantvr.Model(seed=3)
    before = _state(m, tmp_path)
    bomb = tmp_path / "bomb.npz"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("tree_pos.npy", "w", force_zip64=True) as fh:
            np.lib.format.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False,
                                                      "shape": (8 * 2**20,)})
            chunk = bytes(2**20)
            for _ in range(64):
                fh.write(chunk)
    assert bomb.stat().st_size < 2**20
    monkeypatch.setattr(treefile, "MAX_TREE_BYTES", 8 * 2**20)
    tracemalloc.start()
    msg = _restore_rejected(m, bomb, tmp_path, before)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert "cap" in msg and peak < 16 * 2**20
    monkeypatch.undo()
    arrays = _arrays(small[2])  # a header declaring 8 TB (stored uncompressed, header edited in place)
    path = tmp_path / "huge.npz"
    _fileio.write_npz(path, arrays, compress=False)
    raw = path.read_bytes()
    old = f"'shape': ({len(arrays['tree_pos'])}, 3), }}".encode()
    new = f"'shape': ({2**40}, 3), }}".encode()
    at = raw.index(old)
    pad = raw.index(b"\n", at) - (at + len(old))
    assert pad > len(new) - len(old)
    raw = raw[:at] + new + raw[at + len(old): raw.index(b"\n", at) - (len(new) - len(old))] + raw[raw.index(b"\n", at):]
    path.write_bytes(raw)
    tracemalloc.start()
    _restore_rejected(m, path, tmp_path, before)
    assert tracemalloc.get_traced_memory()[1] < 16 * 2**20
    tracemalloc.stop()


# -- corrupt event logs ----------------------------------------------------------------------------------------
def test_event_log_round_trip_truncations_flips_and_versions(tmp_path):
    a = plantvr.Model(seed=2)
    a.paint([0, 3, 0], 1.5, 20)
    a.step(3)
    a.set_params(apical_dominance=0.6)
    a.prune([0, 2, 0], 0.5)
    path = a.log.save(tmp_path / "log.jsonl")
    log = EventLog.load(path)
    assert [(e.command, e.kwargs) for e in log.events] == [(e.command, e.kwargs) for e in a.log.events]
    good = path.read_bytes()
    bad = tmp_path / "bad.jsonl"
    for cut in range(0, len(good) - 1, 5):
        bad.write_bytes(good[:cut])
        with pytest.raises(ValueError, match="event log"):
            EventLog.load(bad)
    for i in range(0, len(good) * 8, 7):
        data = bytearray(good)
        data[i // 8] ^= 1 << (i % 8)
        bad.write_bytes(bytes(data))
        with pytest.raises(ValueError, match="event log"):
            EventLog.load(bad)
    text = good.decode()
    bad.write_text(text.replace('"plantvr_events": 1', '"plantvr_events": 99'))
    with pytest.raises(ValueError, match="version 99 is not supported"):
        EventLog.load(bad)
    body = '{"command": "os.system", "kwargs": {}, "t": 0}\n'
    bad.write_text(body + json.dumps({"plantvr_events": 1, "count": 1,
                                      "sha256": hashlib.sha256(body.encode()).hexdigest()}) + "\n")
    with pytest.raises(ValueError, match="event command must be one of"):
        EventLog.load(bad, plantvr.Model.COMMANDS)


def test_replay_checks_every_event_before_issuing_any(tmp_path):
    log = EventLog()
    log.record("paint", center=[0, 3, 0], radius=1.0, n_darts=10)
    log.record("step", steps=2)
    log.record("step", steps=-1)
    m = plantvr.Model(seed=0)
    before = _state(m, tmp_path)
    with pytest.raises(ValueError, match=r"event 2 \(step\): steps must be an integer"):
        log.replay(m)
    log.events[2] = type(log.events[2])("paint", {"centre": [0, 1, 0]})
    with pytest.raises(ValueError, match="paint arguments do not fit"):
        log.replay(m)
    assert _state(m, tmp_path) == before and len(m.log) == 0

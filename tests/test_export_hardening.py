"""Issue 20: ``plantvr export`` ends in one line and exit code 2 for every bad argument or file; presets, stroke
files, headset recordings and billboard atlases are saved atomically, re-saved byte-identically and refused
clearly when corrupt (the model left unchanged)."""
import json
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr import Model
from plantvr.cli import main as cli_main
from plantvr.commandlog import CommandLog, Event
from plantvr.growth.scenarios import demo_session, run
from plantvr.params import TREEWAND
from plantvr.documents.scenarios import read_scenario, record_scenario, save_scenario
from plantvr.vr.frames import ControllerState, InputFrame, load_recording, save_recording

FUZZ = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = tmp_path_factory.mktemp("tree")
    model = Model(seed=1)
    run(model, demo_session(), 12, range(12))
    return model, model.save(d / "t.tree")


def _cli(capsys, *argv):
    rc = cli_main(["export", *map(str, argv)])
    err = capsys.readouterr().err
    return rc, err


def test_cli_rejections_are_one_line(saved, tmp_path, capsys):
    _, src = saved
    bad = tmp_path / "bad.tree"
    bad.write_bytes(src.read_bytes()[:200])
    junk = tmp_path / "junk.npz"
    junk.write_bytes(os.urandom(300))
    cases = [
        ((src, "-o", "/missing/o.ply"), "does not exist"),
        ((src, "-o", tmp_path / "no" / "o.glb"), "does not exist"),
        ((tmp_path / "missing.tree", "--format", "ply"), "does not exist"),
        ((bad, "-o", tmp_path / "o.ply"), "bad.tree"),
        ((junk, "-o", tmp_path / "o.ply"), "junk.npz"),
        ((src, "--lod", "9", "-o", tmp_path / "o.ply"), "lod"),
        ((src, "--lod", "-3", "-o", tmp_path / "o.ply"), "lod"),
        ((src, "-o", tmp_path / "o.stl"), "suffix"),
        ((src, "--format", "usd", "-o", tmp_path / "o.ply"), "does not match"),
        ((src, "--lod", "4", "-o", tmp_path / "o.usda"), "billboard"),
    ]
    for argv, what in cases:
        rc, err = _cli(capsys, *argv)
        assert rc == 2, argv
        assert err.startswith("plantvr export: error:") and what in err, (argv, err)
        assert err.count("\n") == 1 and "Traceback" not in err, err
    for argv in (("--format", "fbx"), ("--lod", "x")):         # argparse's own usage errors: exit code 2
        with pytest.raises(SystemExit) as e:
            cli_main(["export", str(src), *argv])
        assert e.value.code == 2
    assert not [p for p in os.listdir(tmp_path) if p.startswith("o.") or p.startswith(".o.")]


def test_cli_export_byte_identical_and_failed_export_keeps_old(saved, tmp_path, capsys, monkeypatch):
    _, src = saved
    out = tmp_path / "o.ply"
    assert cli_main(["export", str(src), "-o", str(out)]) == 0
    first = out.read_bytes()
    assert cli_main(["export", str(src), "-o", str(out)]) == 0
    assert out.read_bytes() == first
    import plantvr._fileio as fio

    def full(fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(fio.os, "fsync", full)
    rc, err = _cli(capsys, src, "-o", out)
    assert rc == 2 and "No space left" in err
    assert out.read_bytes() == first and sorted(os.listdir(tmp_path)) == ["o.ply"]


# -- presets -------------------------------------------------------------------------------------------------
def test_preset_round_trip_atomic_and_corrupt(tmp_path):
    m = Model(seed=0)
    p = m.save_preset(tmp_path / "p.json")
    first = p.read_bytes()
    m2 = Model(seed=0)
    m2.load_preset(p)
    assert m2.save_preset(tmp_path / "q.json").read_bytes() == first
    good = json.loads(first)
    bad_docs = {
        "truncated": first[: len(first) // 2],
        "binary": bytes(range(256)),
        "nan": first.replace(b'"w_heading": 0.4', b'"w_heading": NaN'),
        "version": json.dumps({**good, "plantvr_preset": 99}).encode(),
        "type": json.dumps({**good, "params": {"w_heading": "high"}}).encode(),
        "list": json.dumps([1, 2]).encode(),
        "unknown": json.dumps({**good, "params": {"nope": 1}}).encode(),
        "deep": b"[" * 100_000 + b"]" * 100_000,
        "range": json.dumps({**good, "params": {"w_heading": 1e300}}).encode(),
    }
    state = json.dumps({k: getattr(m2, k) for k in good["params"]}, sort_keys=True)
    for what, data in bad_docs.items():
        (tmp_path / "bad.json").write_bytes(data)
        with pytest.raises(ValueError, match="preset"):
            m2.load_preset(tmp_path / "bad.json")
        assert json.dumps({k: getattr(m2, k) for k in good["params"]}, sort_keys=True) == state, what
    with pytest.raises(ValueError, match="preset"):
        TREEWAND.read_preset(tmp_path / "missing.json")
    with pytest.raises(ValueError, match="does not exist"):
        m.save_preset(tmp_path / "nowhere" / "p.json")
    assert p.read_bytes() == first


def test_panel_load_rejects_corrupt_preset(tmp_path):
    from plantvr.ui.panels import ParameterPanels
    m = Model(seed=0)
    panel = ParameterPanels(m)
    (tmp_path / "bad.json").write_bytes(b'{"plantvr_preset": 1, "params": {"w_heading": NaN}}')
    before = m.w_heading
    with pytest.raises(ValueError):
        panel.load(tmp_path / "bad.json")
    assert m.w_heading == before and "preset" in panel.message.value
    panel.close()


# -- stroke files ----------------------------------------------------------------------------------------------
def test_scenario_round_trip_and_corrupt(tmp_path):
    sc = record_scenario("fig12_3")
    p = save_scenario(sc, tmp_path / "s.jsonl")
    first = p.read_bytes()
    assert save_scenario(read_scenario(p), tmp_path / "t.jsonl").read_bytes() == first
    lines = first.decode().splitlines()
    paint = next(i for i, ln in enumerate(lines) if '"paint"' in ln)

    def log(*events):
        out = CommandLog(Model.COMMANDS, document="treewand")
        for cmd, kw in events:
            out.record(cmd, **kw)
        return out.to_text().encode()

    head = (("set_params", sc.params), ("reset", {"seed": 0}))
    bads = {
        "truncated": first[:-40],
        "edited": first.replace(b'"seed": 0', b'"seed": 1'),
        "version": first.replace(b'"plantvr_events": 1', b'"plantvr_events": 2'),
        "seed": log(head[0], ("reset", {"seed": -1})),
        "center": log(*head, ("paint", {"center": [1e300, 0, 0]})),
        "darts": log(*head, ("paint", {"center": [0, 1, 0], "n_darts": 10**12})),
        "steps": log(*head, ("step", {"steps": "many"})),
        "header": log(("step", {"steps": 1})),
        "other": log(*head).replace(b'"treewand"', b'"labels"'),
        "nan": first.replace(lines[paint].encode(), lines[paint].replace("2.0", "NaN", 1).encode()),
    }
    for what, data in bads.items():
        (tmp_path / "bad.jsonl").write_bytes(data)
        with pytest.raises(ValueError, match="scenario"):
            read_scenario(tmp_path / "bad.jsonl")
    with pytest.raises(ValueError, match="does not exist"):
        save_scenario(sc, tmp_path / "nowhere" / "s.jsonl")


# -- headset recordings -----------------------------------------------------------------------------------------
def _frames(n=5):
    out = []
    for i in range(n):
        pose = np.eye(4)
        pose[:3, 3] = (0.1 * i, 1.2, -0.3)
        out.append(InputFrame(t=i / 90, right=ControllerState(pose=pose, trigger=min(1.0, 0.25 * i),
                                                              pad=(0.5, -0.5), pad_touched=True)))
    return out


def test_recording_round_trip_atomic_and_corrupt(tmp_path):
    p = save_recording(_frames(), tmp_path / "r.jsonl")
    first = p.read_bytes()
    assert save_recording(load_recording(p), tmp_path / "s.jsonl").read_bytes() == first
    line = json.loads(first.splitlines()[0])["kwargs"]      # the first frame event's frame

    def doc(**patch):
        d = json.loads(json.dumps(line))
        for k, v in patch.items():
            tgt = d
            *path, last = k.split("__")
            for q in path:
                tgt = tgt[q]
            tgt[last] = v
        log = CommandLog(("frame",), document="headset")    # a well-formed log holding a bad frame
        log.events.append(Event("frame", d, 0.0))
        return log.to_text().encode()
    bads = {
        "truncated": first[:-30],
        "binary": bytes(range(256)),
        "nan": first.replace(b'"t": 0.0', b'"t": NaN', 1),
        "trigger": doc(right__trigger=7.0),
        "pad": doc(left__pad=[0.0]),
        "pose": doc(right__pose=[[1e300] * 4] * 4),
        "pose shape": doc(hmd=[[1, 0], [0, 1]]),
        "bool": doc(right__grip="yes"),
        "missing": doc(left={}),
        "t type": doc(t="now"),
        "extra": doc(extra=1),
        "deep": b"[" * 100_000 + b"]" * 100_000 + b"\n",
    }
    for what, data in bads.items():
        (tmp_path / "bad.jsonl").write_bytes(data)
        # damaged bytes fail the log's checksum trailer, crafted frames their door check, naming the file
        with pytest.raises(ValueError, match="(recording|event log) .*bad.jsonl"):
            load_recording(tmp_path / "bad.jsonl")
    with pytest.raises(ValueError, match="missing.jsonl. does not exist"):
        load_recording(tmp_path / "missing.jsonl")
    with pytest.raises(ValueError, match="trigger"):
        save_recording([InputFrame(t=0.0, right=ControllerState(trigger=np.nan))], p)
    assert p.read_bytes() == first and sorted(os.listdir(tmp_path)) == ["bad.jsonl", "r.jsonl", "s.jsonl"]


@FUZZ
@given(key=st.sampled_from(["t", "right.trigger", "left.pad0", "hmd"]),
       v=st.sampled_from([np.nan, np.inf, -1.0, 2.0, 1e300, 0.5, "x", None]))
def test_fuzz_save_recording(fuzz, tmp_path, key, v):
    f = _frames(1)[0]
    try:
        if key == "t":
            f = InputFrame(t=v, right=f.right)
        elif key == "right.trigger":
            f = InputFrame(t=0.0, right=ControllerState(trigger=v))
        elif key == "left.pad0":
            f = InputFrame(t=0.0, left=ControllerState(pad=(v, 0.0)))
        else:
            f = InputFrame(t=0.0, hmd=np.full((4, 4), v, dtype=object))
    except (TypeError, ValueError):
        return
    r = fuzz.call("save_recording", save_recording, [f], tmp_path / "f.jsonl",
                  param=("t", "trigger", "pad", "hmd"))
    if not isinstance(r, Exception):
        assert len(load_recording(r)) == 1


# -- billboard atlas ------------------------------------------------------------------------------------------------
def test_billboard_atlas_and_export_atomic(tmp_path, monkeypatch):
    from plantvr.view.billboard import Billboard
    atlas = np.zeros((8, 16, 4), np.uint8)
    atlas[2:6, 3:12] = (10, 200, 30, 255)
    bb = Billboard(np.array([[-1, 0, 0], [1, 0, 0], [1, 2, 0], [-1, 2, 0.0]]), np.array([[0, 1, 2], [0, 2, 3]]),
                   atlas, np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]]), np.zeros(3), 1.0)
    png = bb.save_atlas(tmp_path / "a.png")
    first = png.read_bytes()
    assert bb.save_atlas(tmp_path / "a.png").read_bytes() == first
    glb = bb.export(tmp_path / "b.glb")
    g1 = glb.read_bytes()
    assert bb.export(tmp_path / "b.glb").read_bytes() == g1
    obj = bb.export(tmp_path / "c.obj")
    assert obj.stat().st_size > 0
    with pytest.raises(ValueError, match="does not exist"):
        bb.export(tmp_path / "missing" / "b.glb")
    import plantvr._fileio as fio
    monkeypatch.setattr(fio.os, "fsync", lambda fd: (_ for _ in ()).throw(OSError(28, "No space left")))
    with pytest.raises(OSError):
        bb.save_atlas(tmp_path / "a.png")
    with pytest.raises(OSError):
        bb.export(tmp_path / "b.glb")
    assert png.read_bytes() == first and glb.read_bytes() == g1
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]

"""The inflorescence document (issue 21): the floret state taken out of the editor widget. A session of commands
recorded through the log replays to identical state bytes, undo to the start and redo to the end are
bit-identical under the byte budget, presets are the one JSON format, the scene is the floret as a TriMesh."""
import numpy as np
import pytest

from plantvr.commandlog import CommandLog
from plantvr.documents.inflorescence import PRESETS, InflorescenceDocument
from plantvr.flowers.floret import FLORET, build_floret
from plantvr.types import TriMesh

from ._history import undo_all_redo_all


def _session(doc: InflorescenceDocument) -> None:
    doc.set_params(n_fold=6, growth="power", warp=1.5)
    doc.set_pose(2, opening_deg=65.0, curl_deg=35.0)
    doc.nu = 7                                             # a direct trait set (a slider) is logged too
    doc.fused_rows = 12                                    # a bad combination: kept with a message
    doc.fused_rows = 2
    doc.time = 0.4
    doc.load_preset("fused tube (3 poses)")
    doc.set_pose(1, length=0.7)
    doc.undo()
    doc.redo()


def test_replay_of_the_log_gives_identical_state_bytes():
    doc = InflorescenceDocument()
    _session(doc)
    assert {e.command for e in doc.log} == {"set_params", "undo", "redo"}
    fresh = InflorescenceDocument()
    fresh.replay(doc.log)
    assert fresh.state_bytes() == doc.state_bytes()
    log = CommandLog.from_text(doc.log.to_text(), commands=InflorescenceDocument.COMMANDS, document="inflorescence")
    again = InflorescenceDocument()
    again.replay(log)
    assert again.state_bytes() == doc.state_bytes()


def test_undo_to_the_start_and_redo_to_the_end_are_bit_identical():
    doc = InflorescenceDocument(preset="ray floret")
    start = doc.state_bytes()
    _session(doc)
    assert undo_all_redo_all(doc, start, doc.state_bytes()) == 8


def test_set_params_is_one_rebuild_one_undo_step_and_bad_combinations_keep_the_floret():
    doc = InflorescenceDocument()
    good = doc.floret
    doc.set_params(n_fold=3, nu=7, nv=8, fused_rows=2, n_frames=5)
    assert len(doc.history.undo_stack) == 1 and doc.floret is not good
    ref = build_floret(doc.corollas(), n_frames=5, growth=doc.growth_knots(), lam=doc.lam, eta=doc.eta)
    np.testing.assert_array_equal(ref.frames, doc.floret.frames)
    good = doc.floret
    doc.fused_rows = 12
    assert "fused rows (12)" in doc.message and doc.floret is good
    doc.undo()
    assert doc.fused_rows == 2 and doc.message == "" and doc.floret.frames.tobytes() == good.frames.tobytes()
    before = doc.state_bytes()
    with pytest.raises(ValueError, match="n_fold"):
        doc.set_params(n_fold=0, nu=7)
    with pytest.raises(ValueError, match="pose settings"):
        doc.set_pose(0, colour=1.0)
    with pytest.raises(ValueError, match="preset"):
        doc.load_preset("tulip")
    assert doc.state_bytes() == before


def test_presets_are_table_rows_and_round_trip_as_json(tmp_path):
    for name, values in PRESETS.items():
        assert set(values) == set(FLORET.names) - {"time"}, name
        assert InflorescenceDocument(preset=name).message == ""
    doc = InflorescenceDocument(preset="dahlia ray")
    path = doc.save_preset(tmp_path / "dahlia.json")
    other = InflorescenceDocument()
    other.load_preset(path)
    assert other.state_bytes() == doc.state_bytes()
    assert InflorescenceDocument().params == {**FLORET.defaults()}
    assert "| `open_roll_deg` |" in FLORET.reference()


def test_scene_is_the_floret_at_the_growth_time():
    doc = InflorescenceDocument()
    changes = []
    doc.observe(lambda ch: changes.append(ch["new"]), names="change")
    doc.time = 0.0
    mesh = doc.scene()["floret"]
    assert isinstance(mesh, TriMesh) and np.array_equal(mesh.vertices, doc.floret.frames[0])
    assert np.array_equal(mesh.faces, doc.floret.faces) and changes[-1].command == "set_params"
    assert np.array_equal(doc.floret.vertices, doc.floret.frames[-1])       # a FloretMesh is a TriMesh
    assert isinstance(doc.floret, TriMesh) and doc.floret.area > 0

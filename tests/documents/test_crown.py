"""The implicit-crown document (issue 21): a session of commands recorded through the log replays to identical
state bytes, undo to the start and redo to the end are bit-identical under the byte budget, the scene holds the
crown surface, points and trees."""
import numpy as np
import pytest

from plantvr.commandlog import CommandLog
from plantvr.documents.crown import CrownDocument
from plantvr.types import Points, TreeArrays, TriMesh

from ._history import undo_all_redo_all

SESSION = ["sphere crown 10 0 8 0\nscale crown 1 1.2 1\n",
           "sphere lobe 5 4 10 0\nblend crown lobe body\n",
           "point_set_gen body uniform num_points=300\n",
           "sphere hole 4 0 8 0\npoint_set_thin body hole 50\n",
           "seed 3\npoint_set_densify hole 20 min_distance=0.5\n",
           "grow step=0.8 kill=1.6 max_steps=200\n"]


def _session(tmp_path) -> CrownDocument:
    doc = CrownDocument(base_dir=tmp_path, seed=4)
    for text in SESSION:
        doc.run(text)
    doc.undo()                                     # undo and redo are logged commands too
    doc.redo()
    return doc


def test_replay_of_the_log_gives_identical_state_bytes(tmp_path):
    doc = _session(tmp_path)
    assert [e.command for e in doc.log] == ["run"] * len(SESSION) + ["undo", "redo"]
    fresh = CrownDocument(base_dir=tmp_path, seed=4)
    fresh.replay(doc.log)
    assert fresh.state_bytes() == doc.state_bytes()
    text = CommandLog.from_text(doc.log.to_text(), commands=CrownDocument.COMMANDS, document="crown")
    again = CrownDocument(base_dir=tmp_path, seed=4)
    again.replay(text)
    assert again.state_bytes() == doc.state_bytes()


def test_undo_to_the_start_and_redo_to_the_end_are_bit_identical(tmp_path):
    doc = CrownDocument(base_dir=tmp_path, seed=4)
    start = doc.state_bytes()
    for text in SESSION:
        doc.run(text)
    assert undo_all_redo_all(doc, start, doc.state_bytes()) == len(SESSION)
    while doc.can_undo:
        doc.undo()
    assert doc.lines == []


def test_rejected_run_changes_nothing_and_logs_nothing(tmp_path):
    doc = CrownDocument(base_dir=tmp_path, seed=1)
    doc.run(SESSION[0])
    before, log, version = doc.state_bytes(), doc.log.to_text(), doc.version
    with pytest.raises(ValueError, match="line 2: token 'x'"):
        doc.run("sphere b\nscale b 1 x 2\n")
    with pytest.raises(ValueError, match="unknown command"):
        doc.check_command("run", {"text": "sphre q"})          # the door check parses the script
    assert (doc.state_bytes(), doc.log.to_text(), doc.version) == (before, log, version)
    bad = CommandLog(CrownDocument.COMMANDS, document="crown")
    bad.record("run", text="sphere a\n")
    bad.record("run", text="bogus 1\n")
    fresh = CrownDocument(base_dir=tmp_path)
    with pytest.raises(ValueError, match="event 1"):          # the whole log is checked before anything runs
        fresh.replay(bad)
    assert fresh.surfaces == {} and len(fresh.log) == 0


def test_scene_holds_the_crown_points_and_trees(tmp_path):
    doc = _session(tmp_path)
    seen = []
    doc.observe(lambda ch: seen.append(ch["new"]), names="change")
    scene = doc.scene(resolution=24)
    surf = scene[f"surface {list(doc.surfaces)[-1]}"]
    assert isinstance(surf, TriMesh) and surf.n_faces > 0 and surf.is_watertight
    pts = scene["points"]
    assert isinstance(pts, Points) and np.array_equal(pts.xyz, doc.points.points)
    assert pts.colors.shape == (len(doc.points), 3) and pts.colors.dtype == np.uint8
    tree = scene["tree 0"]
    assert isinstance(tree, TreeArrays) and len(tree) == len(doc.trees[0].nodes) and np.all(tree.radius > 0)
    doc.run("sphere extra 2\n")
    assert seen and seen[-1].kind == "crown" and seen[-1].command == "run"
    doc.run("diff extra extra hole2\n")                         # an empty envelope draws no surface
    assert not any(k.startswith("surface") for k in doc.scene(resolution=16))

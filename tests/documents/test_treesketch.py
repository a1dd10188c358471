"""The TreeSketch document: a session replays to identical bytes, undo to the start and redo to the end are exact
under the byte budget, grow / ungrow / regrow (V17), strokes as undo items, door checks (spec 004 §2.4–2.11)."""
import numpy as np
import pytest

from plantvr.commandlog import CommandLog
from plantvr.documents.treesketch import SketchDocument
from plantvr.types import Points, TreeArrays

OPTS = dict(activation_threshold=0.0, stroke_tropism=True, deflection=10.0, ellipse_sv=0.8, ellipse_ev=0.3)


def _session(doc):
    doc.begin_stroke([0.0, 1.0, 0.0])                       # a sketched trunk (radius 0), growing while brushing
    doc.move_stroke([0.0, 7.0, 0.0], 0.0)
    doc.grow(2)
    doc.move_stroke([1.5, 10.0, 0.5], 0.0)
    doc.end_stroke()
    doc.grow(3)
    doc.begin_stroke([-4.0, 7.0, 0.0])                      # a brushed crown, radius growing mid-stroke
    for k, x in enumerate(np.linspace(-4.0, 4.0, 5)):
        doc.move_stroke([x, 8.0 + 1.5 * np.sin(x), 0.6 * x], 0.5 + 0.25 * k, dt=0.2)
    doc.end_stroke()
    doc.set_params(branch_angle=55.0, n_max=2)
    a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    doc.lasso(np.column_stack([3.0 * np.cos(a), 11.0 + 2.0 * np.sin(a)]), n_points=150, seed=3)
    doc.grow(3)
    doc.ungrow(2)
    doc.grow(1)
    doc.prune_at(doc.tree.pos[4])
    doc.set_width(1, 0.5)
    doc.undo()
    doc.redo()
    doc.set_influence(2.0, 1.0, 1.0)
    doc.paint([0.0, 9.0, 0.0], 2.0, 30)
    t = doc.tree
    doc.select(t.pos[int(np.flatnonzero(t.alive & (t.child[:, 0] == -1))[-1])], [1.0, 0.5, 0.0])
    doc.advance(4.0, 0.6)
    doc.select(None)
    t = doc.tree
    tip = int(np.flatnonzero(t.alive & (t.child[:, 0] == -1))[-1])
    doc.bend(int(t.parent[t.parent[tip]]), tip, t.pos[tip] + [0.3, 0.0, 0.2])
    doc.prune([0.0, 12.0, 0.0], 0.5)


def test_replay_gives_identical_bytes():
    doc = SketchDocument(seed=1, **OPTS)
    _session(doc)
    assert doc.n_internodes > 10 and doc.steps_done > 5
    end = doc.state_bytes()
    fresh = SketchDocument(seed=1, **OPTS)
    fresh.replay(doc.log)
    assert fresh.state_bytes() == end
    text = CommandLog.from_text(doc.log.to_text(), commands=SketchDocument.COMMANDS, document="treesketch")
    again = SketchDocument(seed=1, **OPTS)
    again.replay(text)
    assert again.state_bytes() == end


def test_undo_to_start_and_redo_to_end_under_the_budget():
    doc = SketchDocument(seed=1, max_undo_bytes=64 * 2 ** 20, **OPTS)
    start = doc.state_bytes()
    _session(doc)
    end = doc.state_bytes()
    assert doc.history.nbytes <= doc.history.max_bytes
    while doc.undo() is not None:
        pass
    assert doc.state_bytes() == start and not doc.can_undo
    while doc.redo() is not None:
        pass
    assert doc.state_bytes() == end and not doc.can_redo
    assert doc.history.nbytes <= doc.history.max_bytes


def test_ts_v17_grow_ungrow_regrow_identical():
    doc = SketchDocument(seed=7, mode="autonomous")
    doc.grow(6)
    ref = doc.tree.arrays()
    assert doc.ungrow(4) == 4 and doc.steps_done == 2
    doc.grow(4)                                             # the undone steps, applied again
    assert all(ref[k].tobytes() == v.tobytes() for k, v in doc.tree.arrays().items())
    doc.ungrow(3)
    doc.history.redo_stack.clear()                          # recomputed from the restored state: the same arrays
    doc.grow(3)
    assert all(ref[k].tobytes() == v.tobytes() for k, v in doc.tree.arrays().items())


def test_ts_v17_advance_speed_and_stroke_undo():
    doc = SketchDocument(seed=7, mode="autonomous")
    assert doc.advance(4.0, 0.6) == 2 and doc.advance(4.0, 0.2) == 1  # 2.4 -> 2, then 0.4 + 0.8 -> 1 (carry)
    assert doc.steps_done == 3
    assert doc.advance(-10.0, 0.2) == -2 and doc.steps_done == 1
    doc.grow(2)
    before, n_markers = doc.tree.arrays(), doc.n_markers
    doc.set_params(mode="directed")
    doc.begin_stroke([0.0, 5.0, 0.0])                       # a stroke with growth while brushing: one undo item
    doc.move_stroke([3.0, 6.0, 0.0], 1.5, dt=1.0)
    doc.grow(2)
    doc.end_stroke()
    after = doc.tree.arrays()
    assert len(after["pos"]) > len(before["pos"])
    assert doc.ungrow(5) == 0                               # the stroke is an edit: ungrow stops there
    doc.undo()
    assert all(before[k].tobytes() == v.tobytes() for k, v in doc.tree.arrays().items())
    assert doc.n_markers == n_markers and doc.mode == "directed"  # parameters are not undo items
    doc.redo()
    assert all(after[k].tobytes() == v.tobytes() for k, v in doc.tree.arrays().items())
    doc.begin_stroke([0.0, 4.0, 0.0])
    doc.move_stroke([1.0, 4.0, 0.0], 1.0, dt=1.0)
    doc.undo()                                              # an open stroke is ended, then undone
    assert not doc.stroking
    assert all(after[k].tobytes() == v.tobytes() for k, v in doc.tree.arrays().items())


def test_history_byte_budget_drops_the_oldest_steps():
    doc = SketchDocument(seed=7, mode="autonomous", max_undo_bytes=8_000_000)
    doc.grow(12)
    assert doc.history.nbytes <= 8_000_000
    kept = len(doc.history.undo_stack)
    assert 1 < kept < 12
    assert doc.ungrow(100) == kept and doc.steps_done == 12 - kept


def test_scene_and_traits_follow():
    doc = SketchDocument(seed=2, **OPTS)
    seen = []
    doc.observe(lambda ch: seen.append(ch["new"].command), names="change")
    doc.begin_stroke([0.0, 1.0, 0.0])
    doc.move_stroke([0.0, 5.0, 0.0], 0.0)
    doc.end_stroke()
    doc.grow(3)
    sc = doc.scene()
    assert set(sc) == {"tree", "markers", "sketch"}
    assert isinstance(sc["tree"], TreeArrays) and len(sc["tree"]) == doc.n_internodes + 1
    assert isinstance(sc["markers"], Points) and len(sc["markers"].xyz) == doc.n_markers
    np.testing.assert_array_equal(sc["sketch"].xyz, [[0.0, 1.0, 0.0], [0.0, 5.0, 0.0]])
    assert seen == ["begin_stroke", "move_stroke", "end_stroke", "grow"] and doc.can_undo
    assert doc.latest.tree.n_internodes == doc.n_internodes and len(doc.latest.buds["pos"]) > 0   # leaves grow there


@pytest.mark.parametrize("call, match", [
    (lambda d: d.set_params(deflection=95.0), r"deflection must be in \[0.0, 90.0\]"),
    (lambda d: d.set_params(w_heading=0.0, w_tropism=0.0, w_env=0.0), "must not all be zero"),
    (lambda d: setattr(d, "n_max", 0), "n_max must be"),
    (lambda d: d.set_params(ellipse_sv=0.0), "ellipse_sv must be in"),
    (lambda d: d.set_params(branching="opposite"), "branching cannot change"),
    (lambda d: d.set_params(leaf_sizes=1.0), "unknown parameter 'leaf_sizes'"),
    (lambda d: d.move_stroke([0, 1, 0], 0.5), "before begin_stroke"),
    (lambda d: d.grow(-1), "steps"),
    (lambda d: d.paint([np.nan, 0, 0], 1.0), "center"),
    (lambda d: d.set_width(10 ** 6, 0.1), "node"),
    (lambda d: d.lasso([[0, 0], [1, 0], [2, 0]]), "polygon"),
    (lambda d: d.advance(1e6, 1e6), "speed"),
])
def test_rejected_commands_change_nothing(call, match):
    doc = SketchDocument(seed=3, **OPTS)
    doc.paint([0.0, 4.0, 0.0], 2.0, 40)
    doc.grow(2)
    before, params, n_log = doc.state_bytes(), doc.params, len(doc.log)
    with pytest.raises(ValueError, match=match):
        call(doc)
    assert doc.state_bytes() == before and doc.params == params and len(doc.log) == n_log


def test_replay_checks_every_event_first():
    doc = SketchDocument(seed=3)
    doc.grow(1)
    log = CommandLog(SketchDocument.COMMANDS, document="treesketch")
    log.record("grow", steps=2)
    log.record("paint", center=[0, "x", 0])
    with pytest.raises(ValueError, match="event 1"):
        doc.replay(log)
    assert doc.steps_done == 1


def test_save_restore_and_preset(tmp_path):
    doc = SketchDocument(seed=4, **OPTS)
    _session(doc)
    path = doc.save(tmp_path / "oak.tree")
    other = SketchDocument.load(path)
    assert other.params == doc.params and other.steps_done == doc.steps_done
    doc.grow(2)
    other.grow(2)
    a, b = doc.tree.arrays(), other.tree.arrays()
    for k in ("pos", "radius", "order"):
        np.testing.assert_array_equal(a[k][a["alive"]], b[k][b["alive"]])
    with pytest.raises(ValueError, match="cannot read"):
        other.restore(tmp_path / "missing.tree")
    doc.save_preset(tmp_path / "p.json", names=["n_max", "ellipse_sv", "tropism_angle"])
    fresh = SketchDocument(seed=0)
    assert fresh.load_preset(tmp_path / "p.json") == {"n_max": 2, "ellipse_sv": 0.8, "tropism_angle": 0.0}
    assert fresh.engine.sketch["ellipse"] == (0.8, 1.0, 0.0) and fresh.engine.sketch["n_max"] == 2

"""The Tree Wand document on the shared base: replay by the one command log gives the same state bytes, undo
and redo of paint, strokes, markers, prune, growth steps and reset (issue 21)."""
import numpy as np
import pytest

from plantvr.commandlog import CommandLog
from plantvr.documents.treewand import Model, Snapshot
from plantvr.growth.scenarios import demo_session, run
from plantvr.types import Points, TreeArrays

CLOUD = np.random.default_rng(0).uniform([-3, 2, -3], [3, 9, 3], (300, 3))


def _session(m: Model) -> None:
    """Every kind of command, undo and redo included."""
    m.paint([0, 3, 0], radius=2.0, n_darts=80)
    m.paint_stroke([[0, y, 0] for y in (4, 5, 6)], radius=1.5, n_darts=40)
    m.add_markers(CLOUD)
    m.step(6)
    m.set_params(apical_dominance=0.6, tropism_angle=20.0)
    m.branch_angle = 50.0                       # a slider: logged as set_params
    m.set_influence(2, 1, 1)
    m.set_prune_mode(True)
    m.step(4)
    m.prune([0, 5, 0], 1.0)
    m.undo()
    m.undo()
    m.redo()
    m.reset(seed=11)
    run(m, demo_session(), 5)
    m.undo()


def test_replay_of_the_log_gives_identical_state_bytes():
    a = Model(seed=3)
    _session(a)
    used = {e.command for e in a.log}
    assert {"undo", "redo", "set_params", "set_prune_mode", "reset", "prune", "paint_stroke"} <= used
    assert [e.command for e in a.log].count("step") >= 3
    fresh = Model(seed=3)
    fresh.replay(a.log)
    assert fresh.state_bytes() == a.state_bytes()
    again = Model(seed=3)
    again.replay(CommandLog.from_text(a.log.to_text(), commands=Model.COMMANDS, document="treewand"))
    assert again.state_bytes() == a.state_bytes() and again.prune_mode
    assert again.n_internodes == a.n_internodes and again.steps_done == a.steps_done


def test_undo_to_the_start_and_redo_to_the_end_under_the_byte_budget():
    m = Model(seed=5, max_undo=100)
    start = m.state_bytes()
    m.paint([0, 3, 0], radius=2.0)
    m.paint_stroke([[0, 4, 0], [0, 6, 0]], radius=2.0)
    m.add_markers(CLOUD)
    m.step(5)
    m.grow(3)                                    # one item per step
    m.prune([0, 4, 0], 0.8)
    m.reset()
    m.paint([1, 3, 0], radius=2.0)
    m.step(2)
    end = m.state_bytes()
    n = len(m.history.undo_stack)
    assert n == 11 and m.can_undo and not m.can_redo
    assert m.history.nbytes <= m.history.max_bytes
    for _ in range(n):
        assert m.undo() is not None
    assert m.undo() is None and not m.can_undo and m.can_redo
    assert m.state_bytes() == start and m.n_internodes == 1 and m.steps_done == 0 and m.n_markers == 0
    for _ in range(n):
        assert m.redo() is not None
    assert m.redo() is None
    assert m.state_bytes() == end and m.history.nbytes <= m.history.max_bytes
    m.step(1)                                    # growth goes on from the redone state as it did the first time
    ref = Model(seed=5)
    ref.replay(m.log)
    assert ref.state_bytes() == m.state_bytes()


def test_one_step_call_is_one_item_and_the_budget_drops_the_oldest():
    m = Model(seed=1, max_undo=3)
    m.add_markers(CLOUD)
    m.step(7)
    assert len(m.history.undo_stack) == 2
    m.undo()
    assert m.steps_done == 0 and m.n_markers == len(CLOUD)
    m.redo()
    for _ in range(3):
        m.step(1)
    assert len(m.history.undo_stack) == 3 and m.steps_done == 10
    small = Model(seed=1, max_undo_bytes=10_000)
    small.add_markers(CLOUD)
    small.step(3)
    assert small.history.nbytes <= 10_000 and not small.can_undo   # a state is bigger than the budget


def test_a_parameter_change_is_one_undo_item_with_what_it_changed():
    """Issue 31/30: set_params and a slider (a trait set) are one undo item each, restoring the parameter and the
    light, vigor and radius it recomputed; a branching change (a new tree) undoes back to the old tree."""
    m = Model(seed=2)
    run(m, demo_session(), 8)
    m.paint([0, 8, 0], radius=2.0)
    painted = m.state_bytes()
    n = len(m.history.undo_stack)
    m.set_params(tip_radius=0.05, shadow_intensity=0.4)
    assert len(m.history.undo_stack) == n + 1
    m.undo()                                     # the parameter change, with the radii it recomputed
    assert m.tip_radius == 0.02 and m._engine.params["shadow_intensity"] != 0.4
    assert m.state_bytes() == painted
    m.redo()
    assert m.tip_radius == 0.05 and m._engine.params["shadow_intensity"] == 0.4
    radius = m.tree.radius.copy()
    m._engine.rebuild_light()
    np.testing.assert_allclose(m.tree.radius, radius, rtol=1e-12)
    m.undo()
    m.tip_radius = 0.07                          # a slider
    assert m.log.events[-1].command == "set_params" and len(m.history.undo_stack) == n + 1
    m.undo()
    assert m.tip_radius == 0.02 and m.state_bytes() == painted
    grown = m.state_bytes()
    m.branching = "opposite"                     # a new tree of another kind: one item back to the old tree
    assert m.tree.nslots == 3 and len(m.history.undo_stack) == 1
    m.undo()
    assert m.branching != "opposite" and m.tree.nslots == 2 and m.state_bytes() == grown
    ref = Model(seed=2)
    ref.replay(m.log)
    assert ref.state_bytes() == m.state_bytes()


def test_nothing_changed_is_no_item_and_background_growth_is_one_item_per_step():
    m = Model(seed=4, max_undo=50)
    m.add_markers(CLOUD)
    n = len(m.history.undo_stack)
    m.prune([50, 50, 50], 1.0)                   # removes nothing
    assert len(m.history.undo_stack) == n
    start = m.state_bytes()
    m.grow(4, background=True)
    m.wait()
    assert len(m.history.undo_stack) == n + 4 and m.steps_done == 4
    assert sum(e.kwargs["steps"] for e in m.log if e.command == "grow") == 4
    for _ in range(4):
        m.undo()
    assert m.state_bytes() == start and m.steps_done == 0


def test_snapshot_and_scene_share_one_tree_arrays():
    m = Model(seed=0)
    run(m, demo_session(), 6)
    snap = m.snapshot
    assert isinstance(snap, Snapshot) and isinstance(snap.tree, TreeArrays)
    assert snap.pos is snap.tree.pos and snap.main_child is snap.tree.main_child
    assert snap.n_internodes == m.n_internodes == len(snap.tree) - 1
    scene = m.scene()
    assert set(scene) == {"tree", "markers"} and scene["tree"] is m.latest.tree
    assert isinstance(scene["markers"], Points) and len(scene["markers"].xyz) == m.n_markers
    seen = []
    m.observe(lambda ch: seen.append(ch["new"]), names="change")
    m.paint([0, 3, 0], radius=1.0)
    m.undo()
    assert [(c.kind, c.command) for c in seen] == [("markers", "paint"), ("markers", "undo")]


def test_state_bytes_leave_out_step_timings():
    a, b = Model(seed=9), Model(seed=9)
    for m in (a, b):
        m.add_markers(CLOUD)
        m.step(2)
    assert a.state_bytes() == b.state_bytes()     # the two runs' step durations differ
    with pytest.raises(ValueError, match="steps must be an integer"):
        a.step(-1)

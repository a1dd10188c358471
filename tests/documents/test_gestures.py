"""Undo by gesture on the document base (issues 31/30): a parameter change is one undo item restoring the parameter
and what it changed, and ``history_block()`` makes whatever is inside one undo item (and one logged command), for
every document kind (the L-system document is tested by its own suite)."""
import numpy as np
import pytest
import trimesh

from plantvr.commandlog import CommandLog
from plantvr.documents import CrownDocument, InflorescenceDocument, Model, Segmentation, SketchDocument
from plantvr.documents.forest import ForestDocument
from plantvr.growth.scenarios import demo_session, run


def _replays(doc, make):
    for log in (doc.log, CommandLog.from_text(doc.log.to_text(), commands=type(doc).COMMANDS,
                                              document=type(doc).KIND)):
        fresh = make()
        fresh.replay(log)
        assert fresh.state_bytes() == doc.state_bytes()


def test_treewand_slider_regrow_is_one_undo_item_with_its_parameter():
    m = Model(seed=2)
    run(m, demo_session(), 6)
    grown, n = m.state_bytes(), len(m.history)
    m.apical_dominance = 0.8                                  # a slider ...
    with m.history_block(amend=True):                         # ... and the regrow it caused (as Workbench.regrow)
        m.reset(seed=m.seed)
        run(m, demo_session(), 6)
    assert len(m.history) == n + 1 and m.log.events[-1].command == "block"
    regrown = m.state_bytes()
    assert regrown != grown
    m.undo()                                                  # one undo: the parameter and the tree it regrew
    assert m.apical_dominance == 0.55 and m.state_bytes() == grown
    m.redo()
    assert m.apical_dominance == 0.8 and m.state_bytes() == regrown
    m.undo()
    m.set_params(tip_radius=0.04)
    m.undo()
    assert m.tip_radius == 0.02 and m.state_bytes() == grown
    _replays(m, lambda: Model(seed=2))


def test_treesketch_parameter_change_is_its_own_item_not_the_sketch():
    doc = SketchDocument(seed=1, activation_threshold=0.0, stroke_tropism=True)
    doc.begin_stroke([0.0, 1.0, 0.0])
    doc.move_stroke([0.0, 6.0, 0.0], 0.0)
    doc.end_stroke()
    doc.grow(8)
    doc.flush()
    sketched, internodes = doc.state_bytes(), doc.n_internodes
    assert internodes > 1
    doc.set_params(branch_angle=30.0)
    doc.undo()                                                # the parameter only: the sketch stays
    doc.flush()
    assert doc.branch_angle != 30.0 and doc.n_internodes == internodes and doc.state_bytes() == sketched
    doc.redo()
    assert doc.branch_angle == 30.0
    doc.tropism_angle = 12.0                                  # a slider
    doc.undo()
    assert doc.tropism_angle != 12.0 and doc.branch_angle == 30.0
    _replays(doc, lambda: SketchDocument(seed=1, activation_threshold=0.0, stroke_tropism=True))


def test_forest_slider_then_undo_keeps_the_forest():
    kw = {"n_trees": 2, "width": 16.0, "depth": 16.0, "min_dist": 3.0, "rounds": 1, "steps_per_round": 2,
          "n_darts": 30, "compete": False, "crown_height": 3.0, "crown_radius": 2.0}
    doc = ForestDocument(**kw)
    doc.grow()
    grown = doc.state_bytes()
    doc.n_trees = 3                                           # a slider: one item, the forest untouched
    doc.undo()
    assert doc.forest is not None and doc.n_trees == 2 and doc.state_bytes() == grown
    doc.redo()
    with doc.history_block(amend=True):                       # regrow after the slider: one item with it
        doc.grow()
    assert len(doc.forest.trees) == 3
    doc.undo()
    assert doc.n_trees == 2 and doc.state_bytes() == grown
    _replays(doc, lambda: ForestDocument(**kw))


def test_inflorescence_slider_is_one_item_restoring_the_floret():
    doc = InflorescenceDocument()
    start = doc.state_bytes()
    doc.open_length = 1.5
    assert doc.state_bytes() != start
    doc.undo()
    assert doc.open_length == 0.8 and doc.state_bytes() == start
    with doc.history_block():
        doc.set_params(nu=6)
        doc.set_pose(2, width=0.6)
    doc.undo()
    assert doc.state_bytes() == start
    _replays(doc, InflorescenceDocument)


def test_crown_history_block_is_one_item_and_undo_never_crosses_it():
    doc = CrownDocument(seed=0)
    doc.run("sphere a 1")
    one = doc.state_bytes()
    with doc.history_block():
        doc.run("sphere b 0.5 1 0 0")
        doc.run("union a b u")
        with doc.history_block():                             # nested: joins the outer block
            doc.run("translate u 0 1 0")
    assert sorted(doc.surfaces) == ["a", "b", "u"] and len(doc.history) == 2
    doc.undo()
    assert doc.state_bytes() == one
    doc.undo()
    assert not doc.surfaces
    doc.redo()
    doc.redo()
    _replays(doc, lambda: CrownDocument(seed=0))
    with doc.history_block(), pytest.raises(ValueError, match="inside a history block"):
        doc.undo()


def test_labels_history_block_is_one_edit_and_saves(tmp_path):
    s = trimesh.creation.icosphere(2)
    seg = Segmentation(s.vertices, s.faces)
    seg.paint([0, 0, 1], 0.5, 1)
    one = seg.state_bytes()
    with seg.history_block():
        seg.paint([0, 0, -1], 0.5, 2)
        with seg.stroke():
            seg.paint([1, 0, 0], 0.4, 3)
            seg.paint([0, 1, 0], 0.4, 3)
        seg.fill(0, 4)
    assert len(seg.history) == 2
    two = seg.state_bytes()
    seg.undo()
    assert seg.state_bytes() == one
    seg.redo()
    assert seg.state_bytes() == two
    seg.save(tmp_path / "s.npz")
    loaded = Segmentation.load(tmp_path / "s.npz")
    loaded.undo()
    assert loaded.state_bytes() == one
    _replays(seg, lambda: Segmentation(s.vertices, s.faces))


def test_unrecorded_commands_make_no_items_and_a_failed_block_rolls_back():
    m = Model(seed=0)
    m.add_markers(np.random.default_rng(0).uniform([-3, 2, -3], [3, 9, 3], (200, 3)))
    n = len(m.history)
    with m.unrecorded():
        m.step(2)
        m.paint([0, 4, 0], 1.0, 10)
    assert len(m.history) == n and m.log.events[-1].command == "paint"
    before = m.state_bytes(), len(m.log), len(m.history)
    with pytest.raises(ValueError, match="steps"):
        m.block([["step", {"steps": 1}], ["step", {"steps": -1}]])
    assert (m.state_bytes(), len(m.log), len(m.history)) == before
    m.block([["step", {"steps": 1}], ["paint", {"center": [0, 5, 0], "radius": 1.0}]])
    assert len(m.history) == n + 1


def test_treewand_workbench_slider_undo_restores_parameter_and_tree():
    """The reported bug: after a slider regrow in the workbench, undo took the tree back and left the parameter
    at its new value. Now one undo restores both, redo applies both again, and an undo regrows nothing."""
    from plantvr.ui import workbench

    m = Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(6)
    grown, n = m.state_bytes(), len(m.history)
    wb = workbench(m, live=False, window_size=(160, 120))
    try:
        m.tropism_angle = 120.0                               # the slider: a regrow (no kernel loop: at once)
        assert wb.regrows == 1 and len(m.history) == n + 1
        regrown = m.state_bytes()
        m.undo()
        assert m.tropism_angle == 0.0 and m.state_bytes() == grown and wb.regrows == 1
        m.redo()
        assert m.tropism_angle == 120.0 and m.state_bytes() == regrown and wb.regrows == 1
    finally:
        wb.close()

"""The forest document (issue 21): a landscape on the document base; replay and undo give identical bytes."""
import numpy as np
import pytest

from plantvr.commandlog import CommandLog
from plantvr.documents.forest import ForestDocument
from plantvr.landscape import FOREST, grow_forest
from plantvr.types import TreeArrays, TriMesh

SMALL = {"n_trees": 3, "width": 30.0, "depth": 30.0, "rounds": 2, "steps_per_round": 3, "n_darts": 150,
         "compete": False}


def _session(d: ForestDocument) -> None:
    d.grow()
    d.regrow_tree(1, params={"branch_angle": 30.0})
    d.set_params(seed=4, n_trees=2)
    d.crown_radius = 4.0                              # a direct trait set (a slider) is logged too
    d.grow(params={"apical_dominance": 0.6})
    d.regrow_tree(0, params={"tip_radius": 0.03})
    d.undo()
    d.redo()
    d.regrow_tree(1)


def test_replay_of_the_log_gives_identical_state_bytes():
    a = ForestDocument(**SMALL)
    _session(a)
    assert [e.command for e in a.log].count("set_params") == 2
    fresh = ForestDocument(**SMALL)
    fresh.replay(a.log)
    assert fresh.state_bytes() == a.state_bytes()
    again = ForestDocument(**SMALL)
    again.replay(CommandLog.from_text(a.log.to_text(), commands=ForestDocument.COMMANDS, document="forest"))
    assert again.state_bytes() == a.state_bytes() and again.n_trees == 2 and again.crown_radius == 4.0


def test_undo_to_the_start_and_redo_to_the_end_under_the_byte_budget():
    d = ForestDocument(**SMALL, max_undo=50)
    start = d.state_bytes()
    d.grow()
    d.regrow_tree(2, params={"branch_angle": 20.0})
    d.grow(params={"apical_dominance": 0.7})
    d.regrow_tree(0, params={"tip_radius": 0.05})
    end = d.state_bytes()
    n = len(d.history.undo_stack)
    assert n == 4 and d.can_undo and not d.can_redo
    assert 0 < d.history.nbytes <= d.history.max_bytes
    for _ in range(n):
        assert d.undo() is not None
    assert d.undo() is None and d.forest is None and d.state_bytes() == start and not d.can_undo
    for _ in range(n):
        assert d.redo() is not None
    assert d.redo() is None and d.state_bytes() == end and d.history.nbytes <= d.history.max_bytes


def test_grow_is_the_core_forest_and_regrow_keeps_the_other_trees():
    d = ForestDocument(**SMALL)
    f = d.grow()
    p = d.params
    ref = grow_forest(p["n_trees"], size=(p["width"], p["depth"]), min_dist=p["min_dist"], rounds=p["rounds"],
                      steps_per_round=p["steps_per_round"], n_darts=p["n_darts"], seed=p["seed"], compete=False,
                      client="sync")
    for t, u in zip(f.trees, ref.trees):
        assert t.keys() == u.keys() and all(np.array_equal(t[k], u[k]) for k in t)
    g = d.regrow_tree(1, params={"branch_angle": 25.0})
    assert g.trees[0] is f.trees[0] and g.trees[2] is f.trees[2] and g.trees[1] is not f.trees[1]
    seen = []
    d.observe(lambda ch: seen.append(ch["new"]), names="change")
    d.regrow_tree(2)
    assert seen[-1].kind == "forest" and seen[-1].ids.tolist() == [2] and seen[-1].command == "regrow_tree"


def test_scene_is_terrain_mesh_and_tree_arrays():
    d = ForestDocument(**SMALL)
    assert d.scene() == {}
    d.grow()
    s = d.scene()
    assert isinstance(s["terrain"], TriMesh) and s["terrain"].n_vertices == d.forest.heights.size
    trees = [v for k, v in s.items() if k.startswith("tree")]
    assert len(trees) == len(d.forest.trees) and all(isinstance(t, TreeArrays) for t in trees)
    for t, raw in zip(trees, d.forest.trees):
        assert len(t) == int(raw["alive"].sum()) and t.n_internodes == int(raw["alive"][1:].sum())
        np.testing.assert_array_equal(t.pos, raw["pos"][raw["alive"]])     # world coordinates, live nodes
    assert d.latest is d.forest


def test_parameters_come_from_one_table_and_bad_commands_change_nothing():
    assert FOREST.name == "forest" and set(ForestDocument.PARAMS.names) >= {"n_trees", "seed", "regions"}
    d = ForestDocument(**SMALL)
    with pytest.raises(ValueError, match="n_trees"):
        d.set_params(n_trees=0)
    with pytest.raises(ValueError, match="regions"):
        ForestDocument(regions="hexagons")
    with pytest.raises(ValueError, match="grown forest"):
        d.regrow_tree(0)
    d.grow()
    before, n_log = d.state_bytes(), len(d.log)
    for bad in ({"tree": 7}, {"tree": 0, "params": {"w_env": np.nan}}, {"tree": 0, "params": "x"}):
        with pytest.raises(ValueError, match="tree|w_env|params"):
            d.regrow_tree(**bad)
    with pytest.raises(ValueError, match="sketch"):
        d.grow(sketch={"region": None})
    with pytest.raises(ValueError, match="min_dist"):
        grow_forest(2, min_dist=0.0, client="sync")                        # the core checks the same rows
    assert d.state_bytes() == before and len(d.log) == n_log and len(d.history.undo_stack) == 1
    with pytest.raises(ValueError, match="client"):
        ForestDocument(client=5)


def test_saved_session_reopens_with_the_same_bytes(tmp_path):
    d = ForestDocument(**SMALL)
    d.grow()
    d.regrow_tree(2, params={"branch_angle": 35.0})
    path = d.save(tmp_path / "forest.log")
    again = ForestDocument.from_log(path, **SMALL)
    assert again.state_bytes() == d.state_bytes()

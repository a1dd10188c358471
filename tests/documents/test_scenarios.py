"""Stroke files of the thesis scenarios (Figs. 12.1–12.7; checklist item 32, TW-V23); the dropdown is tested in tests/ui/test_strokes.py."""
import dataclasses

import numpy as np
import pytest

import plantvr
from plantvr.commandlog import CommandLog
from plantvr.params import defaults
from plantvr.documents.scenarios import (
    SCENARIO_DIR,
    SCENARIOS,
    list_scenarios,
    load_scenario,
    read_scenario,
    record_scenario,
    replay_scenario,
    save_scenario,
)


def _state(model):
    s = model.snapshot
    return s.pos.copy(), s.parent.copy(), s.markers.copy(), model.params


def test_shipped_files_match_their_sessions():
    """The files on disk are what the session functions record (no drift), and every figure is there."""
    shipped = {s.name: s for s in list_scenarios()}
    assert set(shipped) == set(SCENARIOS)
    for name in SCENARIOS:
        assert shipped[name] == record_scenario(name), name
    figures = {s.figure for s in shipped.values()}
    assert figures == {"12.1", "12.2", "12.3", "12.4", "12.5", "12.6", "12.7"}


def test_stated_parameters_are_in_the_files():
    assert load_scenario("fig12_6").params["branching"] == "opposite"
    assert load_scenario("fig12_6").params["main_branch_angle"] == 12.0
    assert load_scenario("fig12_4").params["view_angle"] == 180.0
    assert load_scenario("fig12_1").params["tropism_min_order"] == 1
    assert {load_scenario(f"fig12_7_{m}").params["length_mode"] for m in ("constant", "vigor", "order")} == \
        {"constant", "vigor", "order"}
    # Fig. 12.6: λ lowered from 0.6 to 0.4 during the session
    sc = load_scenario("fig12_6")
    assert sc.params["apical_dominance"] == 0.6
    assert ("set_params", {"apical_dominance": 0.4}) in sc.events


def test_replay_is_deterministic_and_equals_a_fresh_model():
    sc = load_scenario("fig12_2")
    a = plantvr.Model(seed=7, tropism_angle=33.0)
    a.paint([1, 5, 1], 2.0)
    a.step(3)  # whatever state the model was in
    replay_scenario(a, sc)
    b = plantvr.Model(seed=1)
    replay_scenario(b, sc)
    c = plantvr.Model(seed=sc.seed, **{**defaults(), **sc.params})  # the same commands issued by hand
    for cmd, kw in sc.events:
        getattr(c, cmd)(**kw)
    for other in (b, c):
        for x, y in zip(_state(a)[:3], _state(other)[:3]):
            np.testing.assert_array_equal(x, y)
        assert _state(a)[3] == _state(other)[3]
    assert a.steps_done == sc.n_steps == 40 and a.n_internodes > 50
    assert a.tropism_angle == defaults()["tropism_angle"]  # the old setting does not leak in
    # the model's own event log holds the scenario's commands
    logged = [(e.command, e.kwargs) for e in a.log.events if e.command in ("paint", "step")]
    assert len(logged) >= len(sc.events)


def test_param_change_mid_session_is_replayed():
    m = plantvr.Model(seed=0)
    replay_scenario(m, "fig12_6", steps=20)
    assert m.apical_dominance == 0.6 and m.branching == "opposite" and m.steps_done == 20
    replay_scenario(m, "fig12_6")
    assert m.apical_dominance == 0.4


def test_fig12_7_constant_trunk_is_not_taller():
    """TW-V23a on the shipped files: vigor/order trunks reach at least as high as the constant one."""
    def trunk_fraction(name):
        m = plantvr.Model(seed=0)
        replay_scenario(m, name)
        t = m.tree
        n = 1
        while t.child[n, 0] >= 0 and t.alive[t.child[n, 0]]:
            n = t.child[n, 0]
        return t.pos[n, 1] / t.pos[t.alive, 1].max()
    const = trunk_fraction("fig12_7_constant")
    assert trunk_fraction("fig12_7_vigor") >= const - 1e-9 and trunk_fraction("fig12_7_order") >= const - 1e-9


def test_round_trip_and_bad_files(tmp_path):
    sc = record_scenario("fig12_4", seed=3)
    p = save_scenario(sc, tmp_path / "fig12_4.jsonl")
    assert read_scenario(p) == sc
    mine = read_scenario(save_scenario(sc, tmp_path / "mine.jsonl"))  # a name SCENARIOS does not describe
    assert (mine.name, mine.label, mine.events) == ("mine", "mine", sc.events)
    assert CommandLog.load(p, plantvr.Model.COMMANDS, document="treewand").events[1].kwargs == {"seed": 3}
    with pytest.raises(ValueError, match="must end in .jsonl"):
        save_scenario(sc, tmp_path / "s.txt")
    with pytest.raises(ValueError, match="nope.jsonl. does not exist"):
        read_scenario(tmp_path / "nope.jsonl")
    (tmp_path / "bad.jsonl").write_text("{not json")
    with pytest.raises(ValueError, match="no trailer line"):
        read_scenario(tmp_path / "bad.jsonl")
    (tmp_path / "edited.jsonl").write_text(p.read_text().replace('"radius": 3.5', '"radius": 3.6', 1))
    with pytest.raises(ValueError, match="checksum mismatch"):
        read_scenario(tmp_path / "edited.jsonl")

    def write(name, events):
        log = CommandLog(plantvr.Model.COMMANDS, document="treewand")
        for cmd, kw in events:
            log.record(cmd, **kw)
        return log.save(tmp_path / name)

    head = list(sc.log)[:2]
    events = [(e.command, e.kwargs) for e in head] + list(sc.events)
    with pytest.raises(ValueError, match="must start with set_params"):
        read_scenario(write("nohead.jsonl", events[2:]))
    neg = [*events[:2], ("paint", {**events[2][1], "radius": -1}), *events[3:]]
    with pytest.raises(ValueError, match=r"event 2 \(paint\): radius must be in"):
        read_scenario(write("neg.jsonl", neg))
    with pytest.raises(ValueError, match="view_angle"):
        read_scenario(write("par.jsonl", [("set_params", {"view_angle": 999}), *events[1:]]))
    (tmp_path / "other.jsonl").write_text(CommandLog(document="toy").to_text())
    with pytest.raises(ValueError, match="records a 'toy' session"):
        read_scenario(tmp_path / "other.jsonl")
    with pytest.raises(ValueError, match="name must be one of"):
        load_scenario("fig12_99")
    with pytest.raises(ValueError, match="steps must be an integer in"):
        replay_scenario(plantvr.Model(seed=0), sc, steps=10_000)


def test_a_stroke_file_is_a_model_session():
    """Replaying a stroke file's log into a fresh model is what replay_scenario does (one log format)."""
    sc = load_scenario("fig12_7_vigor")
    a, b = plantvr.Model(seed=5), plantvr.Model()
    replay_scenario(a, sc, steps=6)
    short = dataclasses.replace(sc, events=sc.events[:[c for c, _ in sc.events].index("step") + 1])
    b.replay(short.log)
    replay_scenario(a, short)
    assert a.state_bytes() == b.state_bytes()


def test_files_live_in_the_package():
    assert SCENARIO_DIR.parent.name == "documents" and len(list(SCENARIO_DIR.glob("*.jsonl"))) == len(SCENARIOS)
    assert not list(SCENARIO_DIR.glob("*.json"))

"""The shared model: validation, rejected commands leave it unchanged, snapshots, worker thread, TW-V17b, TW-V24."""
import threading
import time

import numpy as np
import pytest

import plantvr
from plantvr.growth.scenarios import demo_session, run
from plantvr.params import PARAMS


@pytest.fixture(scope="module")
def grown_model():
    m = plantvr.Model(seed=0)
    run(m, demo_session(), 50)
    return m


def test_every_table_parameter_is_a_validated_trait():
    m = plantvr.Model()
    assert {p.name for p in PARAMS} <= set(m.trait_names())
    for p in PARAMS:
        assert m.traits()[p.name].metadata["param"] is p
        assert getattr(m, p.name) == p.default


@pytest.mark.parametrize("name,value,match", [
    ("view_radius", -1.0, r"view_radius must be in \(0.0, 100.0\], got -1.0"),
    ("apical_dominance", float("nan"), r"apical_dominance must be in \[0.0, 1.0\]"),
    ("shadow_depth", 2.5, r"shadow_depth must be an integer in \[1, 32\]"),
    ("length_mode", "spiral", r"length_mode must be one of \['vigor', 'order', 'constant'\]"),
])
def test_bad_parameter_names_range_and_leaves_model_unchanged(name, value, match):
    m = plantvr.Model()
    before = m.params
    with pytest.raises(ValueError, match=match):
        setattr(m, name, value)
    with pytest.raises(ValueError, match=match):
        m.set_params(w_heading=0.3, **{name: value})
    assert m.params == before
    with pytest.raises(ValueError, match="unknown parameter 'colour'"):
        plantvr.Model(colour=1)


def test_bad_command_input_is_rejected_before_any_change(grown_model):
    m = grown_model
    v, n_events = m.version, len(m.log)
    with pytest.raises(ValueError, match=r"center must have shape \(3,\)"):
        m.paint([0, 1])
    with pytest.raises(ValueError, match="center must contain only finite values"):
        m.paint([0, np.nan, 0])
    with pytest.raises(ValueError, match=r"points must have shape \(N, 3\)"):
        m.paint_stroke(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"radius must be in \(0.0, 1000000.0\]"):
        m.paint([0, 1, 0], radius=0)
    with pytest.raises(ValueError, match=r"steps must be an integer"):
        m.step(-1)
    assert m.version == v and len(m.log) == n_events


def test_set_influence_normalises():
    m = plantvr.Model()
    m.set_influence(2, 1, 1)
    assert np.allclose(m.influence, (0.5, 0.25, 0.25))
    with pytest.raises(ValueError, match="must not all be 0"):
        m.set_influence(0, 0, 0)


def test_snapshots_are_immutable_and_versioned(grown_model):
    snap = grown_model.snapshot
    with pytest.raises(ValueError, match="read-only"):
        snap.pos[0, 0] = 1.0
    assert np.all(snap.parent[1:] < np.arange(1, len(snap.pos))) and snap.parent[0] == -1
    assert snap.n_internodes == grown_model.n_internodes


def test_tw_v17b_prune_preview_equals_removal():
    m = plantvr.Model(seed=0)
    run(m, demo_session(), 40)
    c, r = np.array([0.0, 8.0, 0.0]), 1.5
    preview = m.prune_preview(c, r)
    before = m.snapshot
    assert len(preview) > 0
    removed = m.prune(c, r)
    assert removed == len(preview)
    kept = np.setdiff1d(np.arange(len(before.pos)), preview)
    assert np.array_equal(m.snapshot.pos, before.pos[kept])
    mid = 0.5 * (m.snapshot.pos[1:] + m.snapshot.pos[m.snapshot.parent[1:]])
    assert np.all(np.linalg.norm(mid[1:] - c, axis=1) > r)


def test_tw_v24_save_load_tree_and_npz(tmp_path, grown_model):
    m = grown_model
    for suffix in (".tree", ".npz"):
        path = m.save(tmp_path / f"t{suffix}")
        m2 = plantvr.Model.load(path)
        assert m2.params == m.params
        if suffix == ".npz":
            assert np.array_equal(m2.snapshot.pos, m.snapshot.pos)
            assert np.array_equal(m2.snapshot.markers, m.snapshot.markers)
            assert np.allclose(m2.snapshot.radius, m.snapshot.radius, rtol=1e-12)
        t, t2 = m.tree, m2.tree
        order = t.preorder()
        sub = order if suffix == ".tree" else np.flatnonzero(t.alive)
        assert np.array_equal(t2.pos[t2.alive], t.pos[sub])
        assert np.array_equal(t2.order[t2.alive], t.order[sub])
        assert np.allclose(t2.radius[t2.alive], t.radius[sub], rtol=1e-9)
        assert np.allclose(t2.vigor[t2.alive], t.vigor[sub], rtol=1e-9, atol=1e-12)


def test_npz_resume_grows_identically(tmp_path, grown_model):
    m = grown_model
    m.save(tmp_path / "s.npz")
    a, b = plantvr.Model.load(tmp_path / "s.npz"), plantvr.Model.load(tmp_path / "s.npz")
    run(a, demo_session(), 5)
    run(b, demo_session(), 5)
    assert np.array_equal(a.snapshot.pos, b.snapshot.pos)


def _signed(content: str) -> str:
    """``content`` with the version-2 header and its checksum line (plantvr.growth.treefile)."""
    import hashlib
    text = "# plantvr-tree 2\n" + content.rstrip("\n") + "\n"
    return text + f"# sha256={hashlib.sha256(text.encode()).hexdigest()}\n"


@pytest.mark.parametrize("content,match", [
    ("w_heading=0.3\ntree=N(0,0,0", "malformed node"),
    ("view_radius=-3\ntree=N(0,0,0,0,1,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)BB]--", "view_radius must be in"),
    ("w_heading=0.3\n", "no 'tree=' line"),
    ("tree=N(0,0,0,0,1,0,1,0,0)[N(0,1,0,0,1,0,1,0,0)BB", "truncated"),
])
def test_failed_load_raises_and_leaves_model_unchanged(tmp_path, content, match, grown_model):
    bad = tmp_path / "bad.tree"
    bad.write_text(_signed(content))  # a well-formed envelope, so the parser meets the damage inside
    m = grown_model
    before, params = m.snapshot, m.params
    with pytest.raises(ValueError, match=match):
        m.restore(bad)
    junk = tmp_path / "bad.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="cannot read PlantVR state"):
        m.restore(junk)
    assert m.snapshot is before and m.params == params


def test_background_growth_publishes_snapshots_and_stops():
    m = plantvr.Model(seed=1)
    m.add_markers(np.random.default_rng(0).uniform([-4, 1, -4], [4, 12, 4], (4000, 3)))
    seen = []
    m.observe(lambda ch: seen.append(ch["new"]), names=["version"])
    th = m.grow(200, background=True)
    assert isinstance(th, threading.Thread)
    time.sleep(0.3)
    m.stop()
    assert not m.growing and len(seen) > 1 and seen == sorted(seen)
    with pytest.raises(ValueError, match="steps must be an integer"):
        m.grow(-2, background=True)


def test_view_never_waits_for_a_slow_step(monkeypatch):
    """A 1 s growth step holds the engine, not the snapshot: reading the model stays instant (§2.11)."""
    m = plantvr.Model(seed=0)
    real = m._engine.step

    def slow():
        time.sleep(1.0)
        return real()

    monkeypatch.setattr(m._engine, "step", slow)
    m.grow(1, background=True)
    time.sleep(0.1)
    t0 = time.perf_counter()
    snap = m.snapshot
    assert snap.pos.shape[1] == 3 and time.perf_counter() - t0 < 0.01
    m.wait()


def test_event_log_replays_identically(tmp_path):
    a = plantvr.Model(seed=3)
    run(a, demo_session(), 20)
    a.prune([0, 6, 0], 1.0)
    a.log.save(tmp_path / "log.jsonl")
    b = plantvr.Model(seed=3)
    type(a.log).load(tmp_path / "log.jsonl").replay(b)
    assert np.array_equal(a.snapshot.pos, b.snapshot.pos)


def test_prune_mode_is_a_logged_command():
    m = plantvr.Model()
    m.set_prune_mode(True)
    assert m.prune_mode and m.log.events[-1].command == "set_prune_mode"
    with pytest.raises(ValueError, match="on must be True or False"):
        m.set_prune_mode("yes")
    other = plantvr.Model()
    m.log.replay(other)
    assert other.prune_mode


def test_reset_with_seed_regrows_identically():
    m = plantvr.Model(seed=1)
    run(m, demo_session(), 10)
    first = m.snapshot.pos.copy()
    m.reset(seed=1)
    assert m.n_internodes == 1
    run(m, demo_session(), 10)
    assert np.array_equal(m.snapshot.pos, first)
    with pytest.raises(ValueError, match=r"seed must be an integer"):
        m.reset(seed=-1)


def test_consecutive_steps_share_one_state_copy_and_undo_exactly():
    """Issue 24: a run of growth steps copies the whole state once per step (a step's ``before`` is the previous
    step's ``after``); anything that changes the document in between makes the next step copy afresh."""
    m = plantvr.Model(seed=3)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    start = m.state_bytes()
    m.step(1)
    one = m.state_bytes()
    m.step(1)
    m.grow(2)
    paint, s1, s2, g1, g2 = m.history.undo_stack
    assert s2.before is s1.after and g1.before is s2.after and g2.before is g1.after
    assert s1.before is not paint.after                         # the stroke's change came after its block
    for _ in range(3):
        m.undo()
    assert m.state_bytes() == one
    m.undo()
    assert m.state_bytes() == start
    m.redo()
    m.set_params(apical_dominance=0.7)                           # a change between two steps: an item of its own
    m.step(1)
    par, step = m.history.undo_stack[-2], m.history.undo_stack[-1]
    assert par.after["params"]["apical_dominance"] == 0.7 and step.before is par.after
    assert par.before is not s1.after

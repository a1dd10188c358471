"""Model hardening (issue 20): door checks on every entry point (rejected = unchanged), a hypothesis fuzz over
the constructor, traits, commands, readers and the event log, replay in applied order with background growth,
and autosave after every state-changing command."""
import threading
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import plantvr
from plantvr.commandlog import CommandLog as EventLog, Event
from plantvr.params import PARAMS

NASTY = [float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 1e19, -9.3e18, 10**12, 2**63, 2**64, 1e-20,
         -1e-20, 5e-324, -1, -5, 0, 0.0, 1, 2.5, True, None, "x", "", [], [1, 2], [[0, 1, 0]], {"a": 1},
         np.zeros((5, 2)), np.zeros((0, 3)), np.array([1, 2, 3], dtype=object), np.float32(0.5), np.int64(3)]
nasty = st.sampled_from(NASTY) | st.floats(allow_nan=True, allow_infinity=True) | st.integers(-10**20, 10**20)
points = (st.sampled_from(NASTY)
          | st.integers(0, 5).flatmap(lambda n: st.lists(st.lists(st.floats(-1e7, 1e7) | st.sampled_from(NASTY[:9]),
                                                                min_size=3, max_size=3), min_size=n, max_size=n)))
#: Dart counts: the nasty ones, and integers outside the accepted-but-slow band (10**7 darts are allowed).
darts = st.sampled_from(NASTY) | st.integers(-10**20, 10**20).filter(lambda v: not 200 < v <= 10**7)
FUZZ = settings(max_examples=30, deadline=None, suppress_health_check=list(HealthCheck))


def _state(m, tmp_path) -> bytes:
    return m.save(tmp_path / "_state.npz").read_bytes()


@pytest.fixture(scope="module")
def base():
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 7)], radius=2.0, n_darts=30)
    m.step(4)
    return m


def _fresh(base):
    m = plantvr.Model(seed=0)
    base.log.replay(m)
    return m


def _still_sane(m, tmp_path):
    """After an accepted call the model keeps working: a step succeeds, the snapshot is finite, it reloads."""
    m.step(1)
    s = m.snapshot
    assert np.isfinite(s.pos).all() and np.isfinite(s.radius).all() and np.isfinite(s.markers).all()
    assert plantvr.Model.load(m.save(tmp_path / "sane.npz")).n_internodes == m.n_internodes


# -- item 9 door checks ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("n_darts", [0, -5, 10**12, 1.5, "x", [3]])
def test_paint_stroke_n_darts_is_checked(tmp_path, base, n_darts):
    m = _fresh(base)
    before, n_ev = _state(m, tmp_path), len(m.log)
    with pytest.raises(ValueError, match="n_darts"):
        m.paint_stroke([[0, 3, 0], [0, 4, 0]], radius=1.0, n_darts=n_darts)
    with pytest.raises(ValueError, match="n_darts"):
        m.paint([0, 3, 0], 1.0, n_darts)
    assert _state(m, tmp_path) == before and len(m.log) == n_ev


@pytest.mark.parametrize("seed", [-1, 1.5, "a", True, 2**64, [1], np.random.default_rng(0)])
def test_model_seed_is_checked(seed):
    with pytest.raises(ValueError, match="seed must be an integer in"):
        plantvr.Model(seed=seed)


def test_every_command_rejects_bad_input_unchanged(tmp_path, base):
    m = _fresh(base)
    before, n_ev = _state(m, tmp_path), len(m.log)
    bad = [
        (m.set_prune_mode, ("yes",), {}, "on must be True or False"), (m.set_prune_mode, (1,), {}, "on must be"),
        (m.set_prune_mode, (None,), {}, "on must be"), (m.reset, (), {"seed": -1}, "seed"),
        (m.step, (1.5,), {}, "steps"), (m.step, (10**12,), {}, "steps"),
        (m.grow, (3,), {"background": "no"}, "background"), (m.grow, (3,), {"on_step": 5}, "on_step"),
        (m.grow, (-1,), {}, "steps"), (m.wait, (float("nan"),), {}, "timeout"),
        (m.paint, ([0, 1e6, 0], 5.0), {}, "radius"), (m.paint, ([0, 1e7, 0], 1.0), {}, "center"),
        (m.paint_stroke, (np.zeros((3, 2)),), {}, "points"), (m.add_markers, ([[0, 1e100, 0]],), {}, "points"),
        (m.add_markers, ([[0, np.nan, 0]],), {}, "points"), (m.prune, ([0, 1, 0], -1.0), {}, "radius"),
        (m.prune_preview, ([0, 1], 1.0), {}, "center"), (m.set_params, (), {"view_radius": 0}, "view_radius"),
        (m.set_params, (), {"colour": 1}, "colour"), (m.set_influence, (np.nan, 1, 1), {}, "H"),
        (m.set_influence, (0, 0, 0), {}, "must not all be 0"), (m.set_influence, (1, -1, 1), {}, "T"),
        (m.save, (tmp_path / "x.txt",), {}, "path"), (m.restore, (tmp_path / "missing.tree",), {}, "cannot load"),
        (m.restore, (tmp_path / "missing.npz",), {}, "cannot read PlantVR state"), (m.restore, (None,), {}, "path"),
        (m.enable_autosave, (tmp_path / "no" / "a.npz",), {}, "does not exist"),
    ]
    for fn, args, kw, match in bad:
        with pytest.raises(ValueError, match=match):
            fn(*args, **kw)
    for name, value in [("view_radius", -1), ("shadow_depth", 2.5), ("branching", "spiral"), ("base_length", np.inf)]:
        with pytest.raises(ValueError, match=name):
            setattr(m, name, value)
    assert _state(m, tmp_path) == before and len(m.log) == n_ev and m.autosave_path is None


def test_set_influence_does_not_overflow():
    """Issue 20 item 5: set_influence(1e308, 1e308, 1e308) stored zeros."""
    m = plantvr.Model()
    m.set_influence(1e308, 1e308, 1e308)
    assert m.influence == pytest.approx((1 / 3, 1 / 3, 1 / 3))
    m.set_influence(1e308, 0, 1e300)
    assert sum(m.influence) == pytest.approx(1.0) and m.influence[0] > 0.99
    m.set_influence(2, 1, 1)
    assert m.influence == (0.5, 0.25, 0.25)  # unchanged arithmetic on ordinary weights


# -- item 6: replay in applied order ---------------------------------------------------------------------------
def test_replay_after_edits_during_background_growth_is_identical(tmp_path):
    a = plantvr.Model(seed=1)
    a.add_markers(np.random.default_rng(0).uniform([-4, 1, -4], [4, 12, 4], (2500, 3)))
    gate = threading.Event()

    def slow(_):  # outside the lock: gives the main thread room between steps
        gate.set()
        time.sleep(0.01)

    a.grow(40, background=True, on_step=slow)
    gate.wait(5)
    for k in range(6):
        a.paint([0.5 * k, 4 + k, 0], 1.5, 20)
        time.sleep(0.02)
        a.prune([0, 3 + k, 0], 0.4)
        time.sleep(0.02)
    a.wait()
    cmds = [e.command for e in a.log.events]
    first_paint = cmds.index("paint")
    assert "grow" in cmds[first_paint:] and "grow" in cmds[:first_paint]  # edits landed between growth steps
    assert sum(e.kwargs["steps"] for e in a.log.events if e.command == "grow") == a.steps_done == 40
    assert len(a.log) < 40  # consecutive steps merged
    path = a.log.save(tmp_path / "log.jsonl")
    b = plantvr.Model(seed=1)
    EventLog.load(path).replay(b)
    assert _state(b, tmp_path) == _state(a, tmp_path)


def test_direct_trait_sets_are_logged_and_replayed(tmp_path):
    a = plantvr.Model(seed=2)
    a.paint_stroke([[0, y, 0] for y in range(2, 7)], radius=2.0)
    a.step(3)
    a.apical_dominance = 0.7  # a slider sets the trait itself
    a.set_params(view_radius=3.0, tip_radius=0.03)
    a.step(3)
    assert [e.command for e in a.log.events].count("set_params") == 2
    b = plantvr.Model(seed=2)
    a.log.replay(b)
    assert _state(b, tmp_path) == _state(a, tmp_path)


# -- item 7: autosave ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".npz", ".tree"])
def test_autosave_after_every_state_changing_command(tmp_path, base, suffix):
    m = plantvr.Model(seed=4)
    auto = m.enable_autosave(tmp_path / f"auto{suffix}")
    other = base.save(tmp_path / "other.npz")
    cmds = [lambda: m.paint([0, 3, 0], 1.5, 20), lambda: m.paint_stroke([[0, 4, 0], [0, 5, 0]], 1.0, 10),
            lambda: m.add_markers([[0.5, 6, 0]]), lambda: m.step(2), lambda: m.grow(2),
            lambda: m.prune([0, 2.5, 0], 0.6), lambda: m.set_params(tip_radius=0.03),
            lambda: setattr(m, "apical_dominance", 0.6), lambda: m.set_influence(1, 1, 2),
            lambda: m.restore(other), lambda: (m.grow(3, background=True), m.wait()), lambda: m.reset(seed=9)]
    for cmd in cmds:
        cmd()
        now = m.save(tmp_path / f"now{suffix}")
        assert auto.read_bytes() == now.read_bytes()
    m.enable_autosave(None)
    m.step(1)
    assert auto.read_bytes() == now.read_bytes()


def test_failed_autosave_warns_and_keeps_working(tmp_path):
    d = tmp_path / "gone"
    d.mkdir()
    m = plantvr.Model(seed=0)
    m.enable_autosave(d / "a.npz")
    (d / "a.npz").unlink()
    d.rmdir()
    with pytest.warns(RuntimeWarning, match="autosave"):
        m.paint([0, 3, 0], 1.5, 10)
    assert m.n_markers > 0 and "autosave" in m.autosave_error
    d.mkdir()
    m.step(1)
    assert m.autosave_error is None and (d / "a.npz").exists()


# -- hypothesis fuzz over every public entry point -------------------------------------------------------------
@FUZZ
@given(seed=nasty, name=st.sampled_from([p.name for p in PARAMS]), value=nasty)
def test_fuzz_constructor_and_traits(fuzz, seed, name, value):
    m = fuzz.call("Model", plantvr.Model, seed=seed, param="seed")
    if isinstance(m, Exception):
        m = plantvr.Model(seed=0)
    r = fuzz.call("Model(**params)", plantvr.Model, seed=0, param=name, **{name: value})
    before = m.params
    r = fuzz.call(f"Model.{name}", setattr, m, name, value, param=name)
    if isinstance(r, Exception):
        assert m.params == before
    m.paint([0, 3, 0], 1.5, 10)
    m.step(1)
    assert np.isfinite(m.snapshot.pos).all()


@FUZZ
@given(center=points, radius=nasty, n_darts=darts, steps=nasty, on=nasty, seed=nasty,
       h=nasty, t=nasty, e=nasty)
def test_fuzz_commands(fuzz, tmp_path_factory, base, center, radius, n_darts, steps, on, seed, h, t, e):
    tmp = tmp_path_factory.mktemp("fz")
    m = _fresh(base)
    before = _state(m, tmp)
    pt = np.asarray(center, dtype=object)[0] if isinstance(center, list) and center else center
    valid = isinstance(steps, (int, float, np.integer, np.floating)) and 0 <= steps <= 10_000_000
    few = min(int(steps), 2) if valid else steps  # an accepted count runs at most 2 steps (10**7 are allowed)
    calls = [
        ("Model.paint", m.paint, (pt, radius, n_darts), ("center", "radius", "n_darts")),
        ("Model.paint_stroke", m.paint_stroke, (center, radius, n_darts), ("points", "radius", "n_darts")),
        ("Model.add_markers", m.add_markers, (center,), ("points",)),
        ("Model.prune", m.prune, (pt, radius), ("center", "radius")),
        ("Model.prune_preview", m.prune_preview, (pt, radius), ("center", "radius")),
        ("Model.set_prune_mode", m.set_prune_mode, (on,), ("on",)),
        ("Model.reset", m.reset, (seed,), ("seed",)),
        ("Model.set_influence", m.set_influence, (h, t, e), ("H", "T", "E", "weights")),
        ("Model.step", m.step, (few,), ("steps",)),
        ("Model.grow", m.grow, (few,), ("steps",)),
        ("Model.wait", m.wait, (radius,), ("timeout",)),
        ("Model.save", m.save, (center,), ("path",)),
        ("Model.restore", m.restore, (center,), ("path",)),
        ("Model.enable_autosave", m.enable_autosave, (center,), ("path",)),
        ("Model.check_command", m.check_command, ("paint", {"center": pt, "radius": radius}), ("center", "radius")),
    ]
    for entry, fn, args, names in calls:
        r = fuzz.call(entry, fn, *args, param=names)
        if isinstance(r, Exception):
            assert _state(m, tmp) == before, entry
        else:
            _still_sane(m, tmp)
            before = _state(m, tmp)


@FUZZ
@given(cmd=st.sampled_from(["paint", "step", "prune", "set_params", "reset", "os.system", "__init__", "save", 5]),
       kwargs=st.dictionaries(st.sampled_from(["center", "radius", "steps", "seed", "view_radius", "x", "points"]),
                              nasty, max_size=3) | st.sampled_from([None, [], "x"]))
def test_fuzz_event_log_replay(fuzz, tmp_path_factory, cmd, kwargs):
    tmp = tmp_path_factory.mktemp("ev")
    m = plantvr.Model(seed=0)
    before = _state(m, tmp)
    log = EventLog()
    log.record("step", steps=1)
    log.events.append(Event(cmd, kwargs))
    r = fuzz.call("EventLog.replay", log.replay, m)
    if isinstance(r, Exception):
        assert _state(m, tmp) == before and len(m.log) == 0
    else:
        _still_sane(m, tmp)
    r = fuzz.call("EventLog.save", log.save, tmp / "l.jsonl")
    if not isinstance(r, Exception):
        back = fuzz.call("EventLog.load", EventLog.load, r)
        if not isinstance(back, Exception):
            assert [(x.command, x.kwargs) for x in back.events] == [(x.command, x.kwargs) for x in log.events]


@FUZZ
@given(data=st.binary(max_size=400), suffix=st.sampled_from([".tree", ".npz", ".jsonl"]),
       cut=st.integers(0, 5000), flips=st.lists(st.integers(0, 10**6), max_size=3))
def test_fuzz_readers(fuzz, tmp_path_factory, base, data, suffix, cut, flips):
    tmp = tmp_path_factory.mktemp("rd")
    m = plantvr.Model(seed=0)
    before = _state(m, tmp)
    path = tmp / f"f{suffix}"
    if suffix == ".jsonl":
        good = base.log.save(path).read_bytes()
    else:
        good = base.save(path).read_bytes()
    raw = bytearray(good[:cut] + data if data else good[:cut])
    for f in flips:
        if raw:
            raw[(f // 8) % len(raw)] ^= 1 << (f % 8)
    path.write_bytes(bytes(raw))
    if suffix == ".jsonl":
        r = fuzz.call("EventLog.load", EventLog.load, path, param="event log")
        return
    r = fuzz.call("Model.restore", m.restore, path, param=("cannot", "PlantVR state", str(path)))
    if isinstance(r, Exception):
        assert _state(m, tmp) == before
    else:
        _still_sane(m, tmp)
    fuzz.call("Model.load", plantvr.Model.load, path, param=("cannot", "PlantVR state", str(path)))

"""Issue 20 for TreeSketch: every entry point checks its input at the door, rejected commands change nothing, the
library's files are atomic, sealed and validated on load, and saved trees re-save byte-identically."""
import json
import os
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given
from hypothesis import settings as _settings
from hypothesis import strategies as st

from plantvr.documents.treesketch import SketchDocument
from plantvr.growth.bending import bend_path, pipe_widths, rotation_matrix, solve_exponent, stiffness
from plantvr.growth.sketch import SketchEngine
from plantvr.growth.sketch_rules import (
    autonomous_points,
    barycentric,
    branch_point,
    deflect_heading,
    ellipse_distance,
    gravimorphism,
    set_point_tropism,
    shoot_lengths,
)
from plantvr.growth.sketch_tools import StrokeEmitter, TreeLibrary, lasso_volume, nearest_node
from plantvr.params import PARAMS, defaults


def settings(**kw):
    return _settings(suppress_health_check=[HealthCheck.function_scoped_fixture], **kw)


#: Values no numeric input should accept silently.
BAD = [float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 1e19, 10 ** 12, -5, 1e-20, 0, "x", None,
       [1.0, 2.0], np.zeros((2, 2)), True]
BAD_POINTS = [[np.nan, 0, 0], [0, 1e100, 0], [1e19, 0, 0], [[0, 1, 0, 2]], "abc", None, np.zeros((2, 2)),
              [[0, -9.3e18, 0]]]


def _engine(**kw):
    return SketchEngine({**defaults(), **kw.pop("params", {})}, rng=kw.pop("rng", 3), **kw)


def _grown(steps=4, **kw):
    e = _engine(**kw)
    e.add_stroke_points([[0.0, y, 0.3 * y] for y in np.linspace(1.5, 5.0, 12)], [[0.0, 1.0, 0.0]] * 12)
    e.paint([0.0, 4.0, 0.0], 2.5, 200)
    for _ in range(steps):
        e.step()
    return e


def _state(e) -> bytes:
    """Everything a command could change, as bytes (compare before/after a rejected command)."""
    s = e.__getstate__()
    s.pop("history")
    return pickle.dumps((s, e.params, dict(e.sketch)), protocol=5)


def _sane(e) -> None:
    """After accepted input the engine still steps and its tree stays finite."""
    e.step()
    t = e.tree
    assert np.all(np.isfinite(t.pos[: t.n])) and np.all(np.isfinite(t.vigor[: t.n]))


# -- the issue's reproductions -------------------------------------------------------------------------------------
def test_tiny_base_length_after_growth_is_refused_not_a_crash():
    e = _grown()
    before = _state(e)
    with pytest.raises(ValueError, match="base_length"):
        e.set_params({"base_length": 1e-20})
    assert _state(e) == before
    _sane(e)


def test_far_marker_is_refused_and_growth_goes_on():
    e = _grown(2)
    before = _state(e)
    for bad in ([0, 1e100, 0], [1e19, 0, 0], [np.nan, 1, 1]):
        with pytest.raises(ValueError, match="points"):
            e.add_markers(np.array([bad], float))
    assert _state(e) == before
    _sane(e)


def test_huge_influence_weights_normalise_instead_of_zeros():
    assert barycentric(1e308, 1e308, 1e308) == pytest.approx((1 / 3, 1 / 3, 1 / 3))
    assert barycentric(0.4, 0.1, 0.5) == (0.4 / 1.0, 0.1 / 1.0, 0.5 / 1.0)  # the ordinary path is unchanged


def test_option_switches_are_strict_bools():
    with pytest.raises(ValueError, match="trunk_up"):
        _engine(trunk_up="no")
    e = _engine()
    with pytest.raises(ValueError, match="stroke_tropism"):
        e.set_options(stroke_tropism="no")
    assert e.sketch["stroke_tropism"] is False


def test_negative_seed_is_refused():
    with pytest.raises(ValueError, match="seed"):
        _engine(rng=-1)


# -- parameters at their range ends ----------------------------------------------------------------------------------
def _ends():
    for p in PARAMS:
        if p.range is None or p.kind is bool or p.name == "branching":
            continue
        lo, hi = p.range
        lo = lo * (1 + 1e-9) + 1e-9 if p.low_open else lo
        hi = hi * (1 - 1e-9) if p.high_open else hi
        for v in (lo, hi):
            yield p.name, (int(v) if p.kind is int else float(v))


@pytest.mark.parametrize("name,value", list(_ends()))
def test_every_parameter_at_its_range_ends_grows_or_is_refused(fuzz, name, value):
    params = {**defaults(), name: value}
    if name in ("w_heading", "w_tropism", "w_env") and value == 0.0:
        params = {**params, "w_env": 0.5} if name != "w_env" else {**params, "w_heading": 0.5}
    e = fuzz.call("SketchEngine", SketchEngine, params, rng=1, mode="autonomous", n_max=2, param=name)
    if isinstance(e, Exception):
        return
    fuzz.call("SketchEngine.add_markers", e.add_markers, [[0.0, 2.0, 0.0], [0.5, 3.0, 0.0]], param="points")
    for _ in range(2):
        r = fuzz.call("SketchEngine.step", e.step)
        assert not isinstance(r, Exception), r
    t = e.tree
    assert np.all(np.isfinite(t.pos[: t.n])) and np.all(np.isfinite(t.vigor[: t.n]))


@pytest.mark.parametrize("name,value", [("n_max", 1), ("n_max", 1000), ("deflection", 90.0), ("point_density", 0),
                                        ("point_density", 1000), ("ellipse", (1e-6, 1e6, -1e6)),
                                        ("ellipse", (1e6, 1e-6, 1e6)), ("shed_threshold", 1e12),
                                        ("bud_lifetime", 1), ("depth", {"normal": (0, 0, 1), "depth": 0.0})])
def test_every_option_at_its_range_ends_grows(fuzz, name, value):
    e = fuzz.call("SketchEngine", SketchEngine, defaults(), rng=2, mode="autonomous", **{name: value}, param=name)
    assert not isinstance(e, Exception), e
    for _ in range(2):
        if isinstance(fuzz.call("SketchEngine.step", e.step), Exception):  # e.g. the shadow grid is full
            return
    t = e.tree
    assert np.all(np.isfinite(t.pos[: t.n])) and np.all(np.isfinite(t.vigor[: t.n]))


# -- fuzz: constructor, options, commands ----------------------------------------------------------------------------
OPTIONS = ["n_max", "deflection", "mode", "point_density", "ellipse", "shed_threshold", "bud_lifetime", "region",
           "depth", "asymmetry", "trunk_up", "stroke_tropism"]
OPTION_BAD = BAD + [(1, 1), (np.nan, 1, 0), (0, 1, 0), (1e300, 1, 1), {"sites": [[np.nan, 0]], "weights": [1],
                    "weight": 1, "h_max": 5}, {"normal": (0, 0, 0), "depth": 1}, {"normal": (0, 0, 1), "depth": 1e300},
                    [1e300, 0], {"sites": [[0, 1]], "weights": [0], "weight": 1, "h_max": 5}, {}]


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(OPTIONS), value=st.sampled_from(OPTION_BAD))
def test_fuzz_constructor_and_set_options(fuzz, name, value):
    r = fuzz.call("SketchEngine", SketchEngine, defaults(), rng=0, **{name: value}, param=name.split("_")[0])
    if not isinstance(r, Exception):
        _sane(r)
    e = _engine()
    before = _state(e)
    r = fuzz.call("SketchEngine.set_options", e.set_options, **{name: value}, param=name.split("_")[0])
    if isinstance(r, Exception):
        assert _state(e) == before
    _sane(e)


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from([p.name for p in PARAMS]), value=st.sampled_from(BAD + ["opposite", 1e6]))
def test_fuzz_params(fuzz, name, value):
    r = fuzz.call("SketchEngine", SketchEngine, {**defaults(), name: value}, rng=0, param=name)
    if not isinstance(r, Exception):
        _sane(r)
    e = _grown(2)
    before = _state(e)
    r = fuzz.call("SketchEngine.set_params", e.set_params, {name: value}, param=name)
    if isinstance(r, Exception):
        assert _state(e) == before
    _sane(e)


def test_fuzz_params_container_and_rng(fuzz):
    for bad in (None, "params", [1, 2], {**defaults(), 3: 1}, {"w_heading": 0.4}):
        assert isinstance(fuzz.call("SketchEngine", SketchEngine, bad, param="params"), ValueError)
    for bad in (-1, 2 ** 64, 1.5, "seed", [1, 2], True):
        assert isinstance(fuzz.call("SketchEngine", SketchEngine, defaults(), rng=bad, param="rng"), ValueError)


COMMANDS = {
    "add_markers": lambda e, v: e.add_markers(v),
    "add_stroke_points": lambda e, v: e.add_stroke_points(v, v),
    "paint.center": lambda e, v: e.paint(v, 1.0, 10),
    "paint.radius": lambda e, v: e.paint([0, 3, 0], v, 10),
    "paint.n_darts": lambda e, v: e.paint([0, 3, 0], 1.0, v),
    "prune.center": lambda e, v: e.prune(v, 0.5),
    "prune.radius": lambda e, v: e.prune([0, 30, 0], v),
    "set_width.node": lambda e, v: e.set_width(v, 0.1),
    "set_width.diameter": lambda e, v: e.set_width(2, v),
    "bend.target": lambda e, v: e.bend(1, 3, v),
    "bend.base": lambda e, v: e.bend(v, 3, [0, 1, 0]),
    "bend.max_iter": lambda e, v: e.bend(1, 3, e.tree.pos[3], max_iter=v),
    "select.node": lambda e, v: e.select(v),
    "select.direction": lambda e, v: e.select(2, v),
    "prune_at": lambda e, v: e.prune_at(v),
    "stroke_directions": lambda e, v: e.stroke_directions(v),
    "branch_path": lambda e, v: e.branch_path(1, v),
}
PARAM_OF = {"add_markers": "points", "add_stroke_points": "points", "paint.center": "center",
            "paint.radius": "radius", "paint.n_darts": "n_darts", "prune.center": "center", "prune.radius": "radius",
            "set_width.node": "node", "set_width.diameter": "diameter", "bend.target": "target",
            "bend.base": "base", "bend.max_iter": "max_iter", "select.node": "node", "select.direction": "direction",
            "prune_at": "node", "stroke_directions": "points", "branch_path": "end"}


@pytest.fixture(scope="module")
def grown_blob():
    return pickle.dumps(_grown(5))


@settings(max_examples=60, deadline=None)
@given(cmd=st.sampled_from(sorted(COMMANDS)), value=st.sampled_from(BAD + BAD_POINTS + [10 ** 9, -7, 2 ** 70]))
def test_fuzz_commands_reject_and_leave_state(fuzz, grown_blob, cmd, value):
    e = pickle.loads(grown_blob)
    before = _state(e)
    r = fuzz.call(f"SketchEngine.{cmd}", COMMANDS[cmd], e, value, param=PARAM_OF[cmd])
    if isinstance(r, Exception) and cmd not in ("select.node",):
        assert _state(e) == before, cmd
    e.select(None)
    _sane(e)


def test_far_tree_grows_with_numba_kernels():
    """A tree whose markers sit at the coordinate limit: accepted, and every kernel stays in bounds."""
    from plantvr.growth.sketch import grid_reach

    e = _engine(params={"view_radius": 100.0})
    r = grid_reach(e.params)
    e.add_markers([[r, 3 * r, -r], [-r, 2.0, 0.0], [0.0, 3.0, 0.0]])
    with pytest.raises(ValueError, match="points must lie within"):
        e.add_markers([[1.01 * r, 0, 0]])
    for _ in range(3):
        e.step()
    assert e.tree.n_internodes >= 1


# -- fuzz: the flat numeric functions --------------------------------------------------------------------------------
FUNCS = {
    "barycentric": (lambda v: barycentric(v, 0.2, 0.3), "alpha"),
    "set_point_tropism.theta": (lambda v: set_point_tropism([[0, 1, 0]], v), "theta"),
    "set_point_tropism.heading": (lambda v: set_point_tropism(v, 0.5), "heading"),
    "deflect_heading.delta": (lambda v: deflect_heading([[0, 1, 0]], [[1, 0, 0]], v), "delta"),
    "deflect_heading.lateral": (lambda v: deflect_heading([[0, 1, 0]], v, 0.3), "lateral"),
    "shoot_lengths.vigor": (lambda v: shoot_lengths(v, 3), "vigor"),
    "shoot_lengths.n_max": (lambda v: shoot_lengths([1.0, 2.0], v), "n_max"),
    "autonomous_points.density": (lambda v: autonomous_points([[0, 0, 0]], [[0, 1, 0]], [1.0], density=v, r_in=0.5,
                                                              r_out=2.0, half_angle=0.5), "density"),
    "autonomous_points.r_out": (lambda v: autonomous_points([[0, 0, 0]], [[0, 1, 0]], [1.0], density=2, r_in=0.5,
                                                            r_out=v, half_angle=0.5), "r_out"),
    "autonomous_points.pos": (lambda v: autonomous_points(v, [[0, 1, 0]], [1.0], density=2, r_in=0.5, r_out=2.0,
                                                          half_angle=0.5), "pos"),
    "ellipse_distance": (lambda v: ellipse_distance([0.1], s_v=v, s_p=1.0, e_v=0.0), "s_v"),
    "gravimorphism": (lambda v: gravimorphism([[1, 0, 0]], [[0, 1, 0]], s_v=1.0, s_p=1.0, e_v=v), "e_v"),
    "branch_point": (lambda v: branch_point(np.array([-1, 0, 1, 2]), np.ones(4, bool), v), "node"),
    "rotation_matrix": (lambda v: rotation_matrix(v), "v"),
    "stiffness": (lambda v: stiffness(v, 1.0), "radius"),
    "solve_exponent.d_c": (lambda v: solve_exponent(v, [0.5, 0.5]), "d_c"),
    "solve_exponent.d_k": (lambda v: solve_exponent(1.0, v), "d_k"),
    "pipe_widths.tip": (lambda v: pipe_widths(np.array([-1, 0, 1, 1]), np.ones(4, bool), tip_diameter=v), "tip"),
    "pipe_widths.constraints": (lambda v: pipe_widths(np.array([-1, 0, 1, 1]), np.ones(4, bool), tip_diameter=0.1,
                                                      constraints={1: v}), "constraint"),
    "pipe_widths.parent": (lambda v: pipe_widths(v, np.ones(4, bool), tip_diameter=0.1), "parent"),
    "bend_path.target": (lambda v: bend_path(np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.0]]), np.array([-1, 0, 1]),
                                             np.full(3, 0.1), [0, 1, 2], v), "target"),
    "bend_path.radius": (lambda v: bend_path(np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.0]]), np.array([-1, 0, 1]),
                                             v, [0, 1, 2], [1, 1, 0]), "radius"),
    "bend_path.path": (lambda v: bend_path(np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.0]]), np.array([-1, 0, 1]),
                                           np.full(3, 0.1), v, [1, 1, 0]), "path"),
}


@settings(max_examples=60, deadline=None)
@given(fn=st.sampled_from(sorted(FUNCS)), value=st.sampled_from(BAD + BAD_POINTS + [[0.0], np.full(3, 1e-300)]))
def test_fuzz_numeric_functions(fuzz, fn, value):
    f, param = FUNCS[fn]
    r = fuzz.call(fn.split(".")[0], f, value, param=param)
    if not isinstance(r, Exception):
        for a in (r if isinstance(r, tuple) else (getattr(r, "diameter", r),)):
            if isinstance(a, np.ndarray) and a.dtype.kind == "f":
                assert np.all(np.isfinite(a)), fn


# -- tools: strokes, timeline, lasso, picking -----------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(where=st.sampled_from(["rate", "spacing", "point", "radius", "dt"]), value=st.sampled_from(BAD + BAD_POINTS))
def test_fuzz_stroke_emitter(fuzz, where, value):
    e = _engine()
    if where in ("rate", "spacing"):
        r = fuzz.call("StrokeEmitter", StrokeEmitter, e, **{where: value}, param=where)
        if isinstance(r, Exception):
            return
        s = r
        s.begin([0, 1, 0])
        fuzz.call("StrokeEmitter.move", s.move, [0.5, 1.5, 0], 0.5, 0.1)
        return
    s = StrokeEmitter(e, rng=0)
    s.begin([0, 1, 0])
    before = _state(e)
    kw = {"point": [0.5, 1.5, 0], "radius": 0.5, "dt": 0.1, where: value}
    r = fuzz.call("StrokeEmitter.move", s.move, kw["point"], kw["radius"], kw["dt"], param=where)
    if isinstance(r, Exception):
        assert _state(e) == before
    _sane(e)


def test_stroke_emitter_refuses_a_point_flood():
    e = _engine()
    s = StrokeEmitter(e, rate=1e9, spacing=1e-9, rng=0)
    s.begin([0, 1, 0])
    with pytest.raises(ValueError, match="points"):
        s.move([0, 2, 0], 1e3, 1e3)
    with pytest.raises(ValueError, match="points"):
        s.move([0, 1e6, 0], 0.0)
    assert len(e.markers) == 0


@settings(max_examples=40, deadline=None)
@given(cmd=st.sampled_from(["grow", "ungrow", "advance.speed", "advance.seconds", "max_undo_bytes"]),
       value=st.sampled_from([v for v in BAD if not (isinstance(v, (int, float)) and 1 < abs(v) < 1e6)] + [10 ** 7]))
def test_fuzz_timeline(fuzz, cmd, value):
    if cmd == "max_undo_bytes":
        fuzz.call("SketchDocument", SketchDocument, seed=3, max_undo_bytes=value, param="max_bytes")
        return
    doc = SketchDocument(seed=3)
    doc.paint([0.0, 4.0, 0.0], 2.5, 200)
    doc.grow(1)
    carry, items, before = doc._carry, len(doc.history.undo_stack), doc.state_bytes()
    fn = {"grow": lambda: doc.grow(value), "ungrow": lambda: doc.ungrow(value),
          "advance.speed": lambda: doc.advance(value, 1.0), "advance.seconds": lambda: doc.advance(2.0, value)}[cmd]
    r = fuzz.call(f"SketchDocument.{cmd.split('.')[0]}", fn, param=("steps", "speed", "seconds"))
    if isinstance(r, Exception):
        assert (doc._carry, len(doc.history.undo_stack), doc.state_bytes()) == (carry, items, before)
    doc.grow(1)


@settings(max_examples=40, deadline=None)
@given(where=st.sampled_from(["polygon", "pixel", "n_points", "origin", "u"]), value=st.sampled_from(BAD + BAD_POINTS))
def test_fuzz_lasso(fuzz, where, value):
    kw = {"polygon": [[0, 0], [2, 0], [2, 1], [0, 1.0]], "n_points": 50, "rng": 0}
    kw[where] = value
    poly = kw.pop("polygon")
    r = fuzz.call("lasso_volume", lasso_volume, poly, **kw, param=where)
    if not isinstance(r, Exception):
        assert np.all(np.isfinite(r.points))


def test_lasso_bounds_raster_and_points():
    poly = [[0, 0], [1e6, 0], [1e6, 1e6], [0, 1e6]]
    with pytest.raises(ValueError, match="pixel"):
        lasso_volume(poly, pixel=1e-3)
    with pytest.raises(ValueError, match="n_points"):
        lasso_volume(poly, n_points=10 ** 12)
    with pytest.raises(ValueError, match="enclose"):
        lasso_volume([[1e6, 1e6], [1e6 + 1e-300, 1e6], [1e6, 1e6 + 1e-300]])


def test_nearest_node_checks(fuzz):
    e = _grown(2)
    for bad in BAD_POINTS:
        assert isinstance(fuzz.call("nearest_node", nearest_node, e, bad, param="point"), ValueError)
    assert isinstance(fuzz.call("nearest_node", nearest_node, "engine", [0, 0, 0]), TypeError)


# -- the library: atomic saves, sealed and validated files, byte-identical re-saves ---------------------------------
def _lib_engine(branching="alternate", mode="directed"):
    e = _engine(params={"branching": branching}, mode=mode, ellipse=(0.8, 1.2, 0.1), deflection=10.0)
    e.add_stroke_points([[0.0, y, 0.2 * y] for y in np.linspace(1.5, 4.0, 8)], [[0.0, 1.0, 0.1]] * 8)
    e.paint([0.0, 4.0, 0.0], 2.0, 150)
    for _ in range(6):
        e.step()
    e.add_markers([[9.0, 20.0, 9.0], [-9.0, 25.0, 3.0]])  # out of reach: they persist in the saved state
    nodes = np.flatnonzero(e.tree.alive[: e.tree.n])
    e.set_width(int(nodes[2]), 0.3)
    e.select(int(nodes[3]))
    return e


def _files(folder, name):
    return {p.name: p.read_bytes() for p in sorted(folder.glob(f"{name}.*"))}


@pytest.mark.parametrize("branching,mode", [("alternate", "directed"), ("opposite", "directed"),
                                            ("opposite", "autonomous"), ("alternate", "autonomous")])
def test_library_roundtrip_is_byte_identical(tmp_path, branching, mode):
    lib = TreeLibrary(tmp_path / "a")
    e = _lib_engine(branching, mode)
    lib.save("t", e)
    f = lib.load("t")
    assert f.tree.n_internodes == e.tree.n_internodes > 1 and f.tree.nslots == e.tree.nslots
    lib2 = TreeLibrary(tmp_path / "b")
    lib2.save("t", f)
    assert _files(tmp_path / "a", "t") == _files(tmp_path / "b", "t")
    lib.save_preset("p", e)
    lib.apply_preset("p", f)
    lib2.save_preset("p", f)
    assert (tmp_path / "a" / "p.preset.json").read_bytes() == (tmp_path / "b" / "p.preset.json").read_bytes()


def test_library_files_hold_no_pickles_and_carry_checksums(tmp_path):
    lib = TreeLibrary(tmp_path)
    lib.save("t", _lib_engine())
    meta = json.loads((tmp_path / "t.json").read_text())
    assert meta["format"] == "plantvr-treesketch 2" and len(meta["checksum"]) == 64 and len(meta["tree_sha256"]) == 64


@pytest.fixture(scope="module")
def saved_entry(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lib")
    TreeLibrary(folder).save("t", _lib_engine("opposite"))
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def _corrupt_and_load(tmp_path, files, name, data):
    for k, v in files.items():
        (tmp_path / k).write_bytes(v)
    (tmp_path / name).write_bytes(data)
    return TreeLibrary(tmp_path).load("t")


@settings(max_examples=60, deadline=None)
@given(which=st.sampled_from(["t.tree", "t.json"]), frac=st.floats(0.0, 1.0), bit=st.integers(0, 7),
       kind=st.sampled_from(["flip", "truncate"]))
def test_corrupt_library_entry_is_refused(fuzz, tmp_path_factory, saved_entry, which, frac, bit, kind):
    tmp = tmp_path_factory.mktemp("c")
    data = bytearray(saved_entry[which])
    k = min(int(frac * len(data)), len(data) - 1)
    if kind == "flip":
        data[k] ^= 1 << bit
    else:
        data = data[:k]
    r = fuzz.call("TreeLibrary.load", _corrupt_and_load, tmp, saved_entry, which, bytes(data))
    assert isinstance(r, ValueError), f"{kind} at {k} of {which} loaded"


def _meta(saved_entry):
    return json.loads(saved_entry["t.json"])


def _reseal(meta):
    import hashlib

    body = json.dumps({k: v for k, v in meta.items() if k != "checksum"}, sort_keys=True, separators=(",", ":"))
    return json.dumps({**meta, "checksum": hashlib.sha256(body.encode()).hexdigest()}).encode()


EDITS = {
    "wrong version": lambda m: {**m, "format": "plantvr-treesketch 99"},
    "no checksum": lambda m: {k: v for k, v in m.items() if k != "checksum"},
    "markers NaN": lambda m: {**m, "markers": [[float("nan"), 0, 0]] + m["markers"][1:]},
    "markers far": lambda m: {**m, "markers": [[1e19, 0, 0]] + m["markers"][1:]},
    "markers shape": lambda m: {**m, "markers": [[1, 2]] * len(m["markers"])},
    "marker_age float": lambda m: {**m, "marker_age": [0.5] * len(m["marker_age"])},
    "marker_age short": lambda m: {**m, "marker_age": m["marker_age"][:-1]},
    "born negative": lambda m: {**m, "born": [-7] + m["born"][1:]},
    "creation_rank out of range": lambda m: {**m, "creation_rank": [10 ** 9] + m["creation_rank"][1:]},
    "creation_rank repeat": lambda m: {**m, "creation_rank": [0] * len(m["creation_rank"])},
    "width node -7": lambda m: {**m, "width_constraints": [[-7, 0.1]]},
    "width node huge": lambda m: {**m, "width_constraints": [[10 ** 9, 0.1]]},
    "width diameter inf": lambda m: {**m, "width_constraints": [[2, 1e400]]},
    "selected huge": lambda m: {**m, "selected": 10 ** 9},
    "selected str": lambda m: {**m, "selected": "x"},
    "override slot": lambda m: {**m, "bud_override": [[1, 7, 0, 1, 0]]},
    "seed negative": lambda m: {**m, "seed": -1},
    "seed str": lambda m: {**m, "seed": "1"},
    "step_count bool": lambda m: {**m, "step_count": True},
    "rng wrong": lambda m: {**m, "rng": {"bit_generator": "MT19937", "state": 1}},
    "rng garbage": lambda m: {**m, "rng": {**m["rng"], "state": {"state": "x", "inc": 1}}},
    "options unknown": lambda m: {**m, "options": {**m["options"], "bogus": 1}},
    "options bad": lambda m: {**m, "options": {**m["options"], "n_max": 10 ** 9}},
    "options list": lambda m: {**m, "options": [1]},
    "not a dict": lambda m: [m],
}


@pytest.mark.parametrize("edit", sorted(EDITS))
def test_corrupt_library_values_are_refused(fuzz, tmp_path, saved_entry, edit):
    m = EDITS[edit](_meta(saved_entry))
    data = _reseal(m) if isinstance(m, dict) and edit != "no checksum" else json.dumps(m).encode()
    r = fuzz.call("TreeLibrary.load", _corrupt_and_load, tmp_path, saved_entry, "t.json", data)
    assert isinstance(r, ValueError), edit


def test_mismatched_tree_and_json_are_refused(tmp_path):
    lib = TreeLibrary(tmp_path)
    lib.save("a", _lib_engine())
    lib.save("b", _engine())
    (tmp_path / "a.tree").write_bytes((tmp_path / "b.tree").read_bytes())
    with pytest.raises(ValueError, match="does not match"):
        lib.load("a")


def test_tree_file_with_far_node_is_refused(tmp_path, saved_entry):
    text = saved_entry["t.tree"].decode()
    start = text.index("tree=N(") + len("tree=N(")
    bad = text[:start] + "1e19" + text[text.index(",", start):]
    m = _meta(saved_entry)
    import hashlib

    m["tree_sha256"] = hashlib.sha256(bad.encode()).hexdigest()
    (tmp_path / "t.tree").write_text(bad)
    (tmp_path / "t.json").write_bytes(_reseal(m))
    with pytest.raises(ValueError):
        TreeLibrary(tmp_path).load("t")


def test_oversized_and_deep_json_is_refused(tmp_path, saved_entry, monkeypatch):
    import plantvr.growth.sketch_tools as tools

    (tmp_path / "t.tree").write_bytes(saved_entry["t.tree"])
    (tmp_path / "t.json").write_bytes(b"[" * 100_000 + b"]" * 100_000)
    with pytest.raises(ValueError, match="JSON"):
        TreeLibrary(tmp_path).load("t")
    (tmp_path / "t.json").write_bytes(saved_entry["t.json"])
    monkeypatch.setattr(tools, "MAX_ENTRY_BYTES", 1000)
    with pytest.raises(ValueError, match="more than the 1000 allowed"):
        TreeLibrary(tmp_path).load("t")


def test_failed_save_keeps_the_old_entry_and_leaves_no_temp(tmp_path, monkeypatch):
    lib = TreeLibrary(tmp_path)
    lib.save("t", _lib_engine())
    lib.save_preset("p", _engine())
    old = _files(tmp_path, "t"), (tmp_path / "p.preset.json").read_bytes()
    e = _grown(2)

    def failing(fd):
        raise OSError("disk full")
    monkeypatch.setattr(os, "fsync", failing)
    with pytest.raises(OSError, match="disk full"):
        lib.save("t", e)
    with pytest.raises(OSError, match="disk full"):
        lib.save_preset("p", e)
    monkeypatch.undo()
    assert (_files(tmp_path, "t"), (tmp_path / "p.preset.json").read_bytes()) == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.preset.json", "t.json", "t.tree"]
    lib.load("t")


PRESET_BAD = [b"{not json", b'{"format": "plantvr-treesketch 99", "params": {}, "options": {}}',
              b'{"params": {"tropism_angle": NaN}, "options": {}}', b'{"params": [], "options": {}}',
              b'{"params": {}, "options": {"n_max": -1}}', b'{"params": {"bogus": 1}, "options": {}}',
              b'{"params": {}, "options": {"ellipse": [1, 1]}}', b"\xff\xfe", b""]


@pytest.mark.parametrize("data", PRESET_BAD)
def test_corrupt_presets_are_refused_and_change_nothing(fuzz, tmp_path, data):
    lib = TreeLibrary(tmp_path)
    (tmp_path / "bad.preset.json").write_bytes(data)
    e = _grown(1)
    before = _state(e)
    assert isinstance(fuzz.call("TreeLibrary.apply_preset", lib.apply_preset, "bad", e), ValueError)
    assert _state(e) == before


def test_damaged_presets_are_refused(tmp_path):
    """Presets are the one preset format (no seal of their own): damage that leaves no valid preset is refused."""
    lib = TreeLibrary(tmp_path)
    lib.save_preset("p", _engine())
    data = (tmp_path / "p.preset.json").read_bytes()
    for bad in (data[: len(data) // 2], data.replace(b'"treesketch"', b'"treewand"'),
                data.replace(b'"n_max": 3', b'"n_max": 0'), data.replace(b"plantvr_preset", b"plantvr_prezet")):
        (tmp_path / "p.preset.json").write_bytes(bad)
        with pytest.raises(ValueError):
            lib.preset("p")


def test_library_entry_points_fuzz(fuzz, tmp_path):
    lib = TreeLibrary(tmp_path)
    e = _engine()
    for bad in ("../x", "", None, 5, "a" * 200, "x.preset"):
        assert isinstance(fuzz.call("TreeLibrary.save", lib.save, bad, e, param="name"), ValueError)
        assert isinstance(fuzz.call("TreeLibrary.load", lib.load, bad, param="name"), ValueError)
    assert isinstance(fuzz.call("TreeLibrary.save", lib.save, "x", "engine", param="engine"), TypeError)
    assert isinstance(fuzz.call("TreeLibrary.save_preset", lib.save_preset, "x", e, keys=["bogus"], param="keys"),
                      ValueError)
    assert isinstance(fuzz.call("TreeLibrary", TreeLibrary, None, param="folder"), ValueError)
    assert not list(tmp_path.iterdir())


def test_every_numeric_function_rejects_every_bad_value(fuzz):
    """The exhaustive grid behind the hypothesis samples."""
    for fn, (f, param) in FUNCS.items():
        for value in BAD + BAD_POINTS + [[0.0], np.full(3, 1e-300)]:
            r = fuzz.call(fn.split(".")[0], f, value, param=param)
            if not isinstance(r, Exception):
                for a in (r if isinstance(r, tuple) else (getattr(r, "diameter", r),)):
                    if isinstance(a, np.ndarray) and a.dtype.kind == "f":
                        assert np.all(np.isfinite(a)), (fn, value)


def test_every_option_rejects_every_bad_value(fuzz):
    for name in OPTIONS:
        for value in OPTION_BAD:
            r = fuzz.call("SketchEngine", SketchEngine, defaults(), rng=0, **{name: value}, param=name.split("_")[0])
            if not isinstance(r, Exception):
                _sane(r)


def test_every_command_rejects_every_bad_value(fuzz, grown_blob):
    for cmd in sorted(COMMANDS):
        for value in BAD + BAD_POINTS + [10 ** 9, -7, 2 ** 70]:
            e = pickle.loads(grown_blob)
            before = _state(e)
            r = fuzz.call(f"SketchEngine.{cmd}", COMMANDS[cmd], e, value, param=PARAM_OF[cmd])
            if isinstance(r, Exception) and cmd != "select.node":
                assert _state(e) == before, (cmd, value)


def test_every_parameter_rejects_every_bad_value(fuzz, grown_blob):
    for p in PARAMS:
        for value in BAD + ["opposite", 1e6]:
            e = pickle.loads(grown_blob)
            before = _state(e)
            r = fuzz.call("SketchEngine.set_params", e.set_params, {p.name: value}, param=p.name)
            if isinstance(r, Exception):
                assert _state(e) == before, (p.name, value)
            else:
                _sane(e)


def test_every_parameter_in_the_constructor(fuzz):
    for p in PARAMS:
        for value in BAD + ["opposite", 1e6]:
            r = fuzz.call("SketchEngine", SketchEngine, {**defaults(), p.name: value}, rng=0, param=p.name)
            if not isinstance(r, Exception):
                _sane(r)

"""Issue 20, growth engine and kernels: no accepted value or coordinate crashes, overflows or stalls the engine.

Reproducers run in a subprocess, so a segfault shows as a failed test instead of killing pytest.
"""
from __future__ import annotations

import hashlib
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr._validation import MAX_COORD
from plantvr.growth import _colonize_kernels as K
from plantvr.growth.colonize import TreeWandAssigner, assign_treewand, assign_treewand_reference
from plantvr.growth.engine import GrowthEngine
from plantvr.growth.lengths import internode_lengths
from plantvr.growth.markers import poisson_darts, poisson_darts_numpy
from plantvr.growth.shadow import (MAX_CELLS, ShadowGrid, ShadowGridFull, _cells_of, cells_of_numpy, coarse_key,
                                   shadow_lut)
from plantvr.growth.spatial import build_grid, within_any, within_any_numpy
from plantvr.growth.tree import Tree
from plantvr.growth import vigor as V
from plantvr.params import PARAMS, defaults

_SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=list(HealthCheck))


def _run(code: str, **env) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=300, env={**os.environ, **env})


def _grown(steps: int = 6, **params) -> GrowthEngine:
    e = GrowthEngine({**defaults(), **params}, rng=0)
    for s in range(steps):
        e.paint(np.array([0.0, 2.0 + 0.5 * s, 0.0]), 2.5, 80)
        e.step()
    return e


def _state(e: GrowthEngine) -> str:
    h = hashlib.sha256()
    for k, v in sorted(e.tree.arrays().items()):
        h.update(k.encode() + np.ascontiguousarray(v).tobytes())
    h.update(e.markers.tobytes() + e.marker_age.tobytes() + repr(sorted(e.params.items())).encode())
    h.update(repr(e.rng.bit_generator.state).encode() + str(e.step_count).encode())
    return h.hexdigest()


def _sane(e: GrowthEngine) -> None:
    t = e.tree
    live = t.alive
    assert np.all(np.isfinite(t.pos[live])) and np.all(np.isfinite(t.vigor[live]))
    assert np.all((t.L[live] >= 0) & (t.L[live] <= 1))
    assert np.all(np.isfinite(t.radius[live])) and np.all(t.radius[live] > 0)
    assert e.grid.nblocks * e.grid.F ** 3 <= MAX_CELLS


# -- the reported reproducers ----------------------------------------------------------------------------------
def test_issue20_tiny_base_length_after_growth_does_not_segfault():
    r = _run("""
        import plantvr
        m = plantvr.Model(seed=0); m.paint_stroke([[0, y, 0] for y in range(2, 10)], radius=2.5); m.step(3)
        n = m.n_internodes
        m.base_length = 1e-20
        m.step(2)
        print("OK", n, m.n_internodes)
    """)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "OK" in r.stdout


def test_issue20_tiny_view_radius_keeps_every_step_working():
    e = _grown()
    e.set_params({"view_radius": 1e-20})
    for _ in range(3):
        e.paint(np.array([0.0, 6.0, 0.0]), 2.5, 80)
        e.step()
    _sane(e)
    e.set_params({"view_radius": 4.0})
    n = e.tree.n_internodes
    for _ in range(3):
        e.paint(np.array([0.0, 7.0, 0.0]), 2.5, 80)
        e.step()
    assert e.tree.n_internodes > n


def test_markers_anywhere_within_max_coord_do_not_stop_growth():
    e = _grown()
    far = np.array([[s * MAX_COORD, t * MAX_COORD, u * MAX_COORD] for s in (-1, 1) for t in (-1, 1) for u in (-1, 1)])
    e.add_markers(far)
    n = e.tree.n_internodes
    for _ in range(4):
        e.paint(np.array([0.0, 7.0, 0.0]), 2.5, 80)
        e.paint(np.array([MAX_COORD, MAX_COORD, -MAX_COORD]), 20.0, 50)  # painted past MAX_COORD by the brush
        e.step()
    assert e.tree.n_internodes > n
    _sane(e)


def test_tree_grown_at_max_coord_keeps_growing_past_it():
    """Nodes may overshoot the markers by one internode: the engine accepts its own nodes beyond MAX_COORD."""
    e = GrowthEngine({**defaults(), "base_length": 100.0, "max_len_mult": 10.0, "view_radius": 100.0,
                      "occupation_radius": 0.5, "activation_threshold": 0.0}, rng=0)
    e.tree.pos[:] += [0.0, MAX_COORD - 150.0, 0.0]
    e.rebuild_light()
    for _ in range(4):
        e.paint(np.minimum(e.tree.pos[e.tree.alive].max(0) + [0, 30, 0], MAX_COORD - 1), 20.0, 100)
        e.step()
    assert e.tree.pos[:, 1].max() > MAX_COORD
    _sane(e)


# -- every parameter at its extremes ----------------------------------------------------------------------------
def _extremes(p) -> list:
    if p.choices:
        return list(p.choices)
    if p.kind is bool:
        return [False, True]
    lo, hi = p.range
    if p.kind is int:
        return [int(lo), int(lo) + 1, int(hi)]
    out = [float(hi) if not p.high_open else math.nextafter(hi, -math.inf)]
    if p.low_open:
        out += [math.nextafter(lo, math.inf), lo + 1e-20 if lo + 1e-20 > lo else math.nextafter(lo, math.inf)]
    else:
        out += [float(lo), math.nextafter(lo, math.inf)]
    return out


_EXTREMES = [(p.name, v) for p in PARAMS for v in _extremes(p)]


def _grow_checked(e: GrowthEngine, steps: int = 3) -> None:
    for s in range(steps):
        e.paint(np.array([0.3, 5.0 + 0.5 * s, 0.0]), 2.5, 60)
        st_ = e.step()
        assert st_.internodes == e.tree.n_internodes
    _sane(e)


@pytest.fixture(scope="module")
def seed_state():
    return _grown(5).__getstate__()


def _from_state(state) -> GrowthEngine:
    e = GrowthEngine.__new__(GrowthEngine)
    e.__setstate__({k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in state.items()})
    return e


@pytest.mark.parametrize("name,value", _EXTREMES, ids=[f"{n}={v!r}" for n, v in _EXTREMES])
def test_every_param_extreme_then_growth_continues(seed_state, name, value):
    e = _from_state(seed_state)
    if name == "branching":
        e = GrowthEngine({**defaults(), name: value}, rng=0)
    else:
        e.set_params({name: value})
    if name != "darts_per_paint":
        _grow_checked(e)
    else:
        e.paint(np.array([0.0, 6.0, 0.0]), 2.5)
        e.step()
        _sane(e)
    e.set_params({k: v for k, v in defaults().items() if k != "branching"})  # back to defaults: grows again
    n = e.tree.n_internodes
    for s in range(4):
        tips = e.tree.pos[np.flatnonzero(e.tree.alive)[-3:]]
        for p in tips:
            e.paint(np.clip(p + [0.0, 2.0, 0.0], -MAX_COORD, MAX_COORD), 3.0, 60)
        e.step()
    assert e.tree.n_internodes > n
    _sane(e)


@_SETTINGS
@given(st.lists(st.sampled_from([x for x in _EXTREMES if x[0] not in ("branching", "darts_per_paint")]),
                min_size=2, max_size=5))
def test_fuzz_param_extreme_combinations(seed_state, combo):
    e = _from_state(seed_state)
    e.set_params(dict(combo))
    _grow_checked(e, 2)


def test_tiny_base_length_on_a_wide_tree_coarsens_instead_of_exhausting_memory(monkeypatch):
    import functools

    from plantvr.growth import engine as E
    cap = 2 ** 22  # a smaller cap than MAX_CELLS, so the test stays light
    monkeypatch.setattr(E, "ShadowGrid", functools.partial(ShadowGrid, max_cells=cap))
    e = _grown(8, fine_cells=64, shadow_depth=32, shadow_loop_inclusive=True)
    assert e.grid.cell[0] == 1.0
    e.set_params({"base_length": 1e-3})  # every node alone in its blocks: 2M cells per node uncapped
    assert e.grid.nblocks * e.grid.F ** 3 <= cap
    assert e.grid.cell[0] > 1e-3  # the cell was coarsened, not the cap ignored
    _grow_checked(e, 2)
    e.set_params({"base_length": 1.0})  # back: the exact grid again
    assert e.grid.cell[0] == 1.0


def test_default_growth_is_unchanged_by_the_guards(grown):
    """The demo tree still equals a rebuild: the grid's cell is the base length, nothing was clipped."""
    assert grown.grid.cell[0] == grown.params["base_length"]
    cells = grown.grid.cells_of(grown.tree.pos)
    assert np.array_equal(cells, np.floor(grown.tree.pos / grown.grid.cell).astype(np.int64))


# -- shadow grid ----------------------------------------------------------------------------------------------
def test_cells_of_twin_clips_and_maps_nan_to_zero():
    rng = np.random.default_rng(0)
    pts = np.concatenate([rng.normal(0, 50, (500, 3)), [[1e300, -1e300, np.nan], [np.inf, -np.inf, 0.0],
                                                        [9.3e18, -9.3e18, 1e19]]])
    g = ShadowGrid(1e-3, 4)
    out = np.empty(pts.shape, np.int64)
    _cells_of(pts, g.cell, float(g.limit), out)
    assert np.array_equal(out, cells_of_numpy(pts, g.cell, g.limit))
    assert np.abs(out).max() <= g.limit and np.all(out[-3, 2] == 0)
    assert np.array_equal(g.cells_of(pts), out)


def test_shadow_grid_far_and_nan_nodes_stay_in_bounds():
    g = ShadowGrid(1e-20, 2)
    offs, vals = shadow_lut(0.2, 0.5, 32, True)
    pts = np.array([[0.0, 0.0, 0.0], [1e6, -1e6, 1e6], [-1e6, 1e6, -1e6], [np.nan, 1.0, 2.0], [1e-19, 3e-20, 0.0]])
    cells = g.cells_of(pts)
    g.add(cells, offs, vals)
    s = g.read(np.clip(cells + [0, -1, 0], -g.limit, g.limit))
    assert np.all(np.isfinite(s)) and np.all(s >= 0)
    g.add(cells, offs, vals, sign=-1.0)
    assert np.abs(g.blocks[: g.nblocks]).max() < 1e-12
    # the coarse key stays exact at the clip bound (no int64 overflow)
    lim = g.limit // g.F + 2
    keys = {coarse_key(i, j, k) for i in (-lim, lim) for j in (-lim, 0, lim) for k in (-lim, lim)}
    assert len(keys) == 12 and min(keys) >= 0


def test_shadow_grid_full_is_refused_and_leaves_the_grid_unchanged():
    g = ShadowGrid(1.0, 4, max_cells=4 ** 3 * 64)
    offs, vals = shadow_lut(0.2, 0.5, 6)
    g.add(np.array([[0, 0, 0]]), offs, vals)
    before = (g.nblocks, len(g.keys), g.blocks.tobytes())
    with pytest.raises(ShadowGridFull, match="max_cells"):
        g.add(np.array([[100 * i, 0, 0] for i in range(1, 30)]), offs, vals)
    assert (g.nblocks, len(g.keys), g.blocks.tobytes()) == before
    g.add(np.array([[1, 1, 1]]), offs, vals)  # still usable


# -- vigor kernels: twins, and bad indices read nothing out of bounds ------------------------------------------------
def _random_tree(rng, n, bad=False):
    child = np.full((n, 3), -1, np.int64)
    child[:, 2] = np.where(rng.random(n) < 0.5, -2, -1)
    parent = np.full(n, -1, np.int64)
    for i in range(1, n):
        p = int(rng.integers(0, i))
        free = np.flatnonzero(child[p] == -1)
        if len(free):
            child[p, free[0]] = i
        parent[i] = p
    if bad:
        idx = rng.integers(0, n, 4)
        child[idx[0], 0], child[idx[1], 1], parent[idx[2]], child[idx[3], 2] = 10 ** 9, -7, 10 ** 9, 2 ** 62
    return child, parent


@pytest.mark.parametrize("bad", [False, True])
def test_vigor_kernels_equal_numpy_twins(bad):
    rng = np.random.default_rng(3)
    for n in (1, 2, 7, 60):
        child, parent = _random_tree(rng, n, bad and n > 2)
        alive = rng.random(n) < 0.9
        L, factor = rng.random(n), rng.random(n) + 0.5
        outs = []
        for f in ((V.accumulate_light, V.distribute_vigor, V.shed_mask, V.pipe_radius),
                  (V.accumulate_light_numpy, V.distribute_vigor_numpy, V.shed_mask_numpy, V.pipe_radius_numpy)):
            Q, Qw, Qs = np.zeros(n), np.zeros(n), np.zeros((n, 3))
            vig, bv, rad = np.zeros(n), np.zeros((n, 3)), np.zeros(n)
            f[0](child, alive, L, factor, 1.3, 0.6, Q, Qw, Qs)
            f[1](child, alive, Qs, Qw, 0.6, 2.0, vig, bv)
            shed = [f[2](child, parent, alive, vig, s) for s in (False, True)]
            f[3](child, alive, 0.02, 2.5, rad)
            outs.append((Q, Qw, Qs, vig, bv, rad, *shed))
        for a, b in zip(*outs):
            np.testing.assert_array_equal(a, b)


def test_kernels_with_bad_indices_and_nan_under_boundscheck():
    r = _run("""
        import numpy as np
        from plantvr.growth import vigor as V
        from plantvr.growth.shadow import ShadowGrid, shadow_lut
        from plantvr.growth.spatial import build_grid, within_any
        child = np.array([[1, -2, -2], [10**9, -7, 2**62], [-1, -1, -2]], np.int64)
        parent = np.array([-1, 0, 10**9], np.int64)
        alive = np.ones(3, bool)
        n = 3
        Q, Qw, Qs, vig, bv, rad = np.zeros(n), np.zeros(n), np.zeros((n, 3)), np.zeros(n), np.zeros((n, 3)), np.zeros(n)
        V.accumulate_light(child, alive, np.ones(n), np.ones(n), 1.0, 0.5, Q, Qw, Qs)
        V.distribute_vigor(child, alive, Qs, Qw, 0.5, 2.0, vig, bv)
        V.shed_mask(child, parent, alive, vig, True); V.shed_mask(child, parent, alive, vig, False)
        V.pipe_radius(child, alive, 0.02, 2.5, rad)
        e = np.zeros((0, 3), np.int64)
        V.distribute_vigor(e, np.zeros(0, bool), np.zeros((0, 3)), np.zeros(0), 0.5, 2.0, np.zeros(0), np.zeros((0, 3)))
        g = ShadowGrid(1e-20, 2)
        pts = np.array([[np.nan, 0, 0], [1e19, -1e300, 9.3e18], [0, 0, 0]])
        g.add(g.cells_of(pts), *shadow_lut(0.2, 0.5, 32, True))
        g.read(g.cells_of(pts))
        gr = build_grid(np.array([[1e6, 1e6, 1e6], [0, 0, 0.0]]), 1e-300)
        within_any(gr, np.array([[1e6, 1e6, 1e6], [-2e6, 0, 0]]), 1e3)
        print("OK")
    """, NUMBA_BOUNDSCHECK="1", NUMBA_CACHE_DIR="/tmp/nbc_bc_growthk_test")
    assert r.returncode == 0, r.stderr[-3000:]
    assert "OK" in r.stdout


# -- spatial grid, darts, colonize grid ----------------------------------------------------------------------------
@pytest.mark.parametrize("h,r", [(1.0, 1.0), (1e-300, 0.5), (1e-20, 3.0), (0.01, 5.0), (1e6, 1e-3)])
def test_within_any_equals_brute_force_at_any_cell_size(h, r):
    rng = np.random.default_rng(1)
    pts = np.concatenate([rng.uniform(-3, 3, (400, 3)), [[MAX_COORD, -MAX_COORD, MAX_COORD]]])
    q = np.concatenate([rng.uniform(-3, 3, (30, 3)), [[MAX_COORD, -MAX_COORD, MAX_COORD - 0.5]]])
    np.testing.assert_array_equal(within_any(build_grid(pts, h), q, r), within_any_numpy(pts, q, r))


@pytest.mark.parametrize("rej", [0.0, 1e-20, 0.05, 1.0, 25.0])
def test_poisson_darts_kernel_equals_numpy_twin(rej):
    rng = np.random.default_rng(2)
    for center in (np.zeros(3), np.full(3, MAX_COORD - 3.0)):
        ex = center + rng.uniform(-4, 4, (150, 3))
        a = poisson_darts(center, 2.5, 300, ex, rej, np.random.default_rng(5))
        b = poisson_darts_numpy(center, 2.5, 300, ex, rej, np.random.default_rng(5))
        np.testing.assert_array_equal(a, b)


def test_poisson_darts_scales_to_the_largest_darts_per_paint():
    out = poisson_darts(np.zeros(3), 20.0, 10 ** 6, np.zeros((0, 3)), 1e-20, 0)  # was O(darts²): hours
    assert out.shape == (10 ** 6, 3)


@pytest.mark.parametrize("vr", [1e-20, 1e-300, 100.0])
def test_assign_with_tiny_view_radius_equals_reference(vr):
    rng = np.random.default_rng(4)
    markers = np.concatenate([rng.uniform(-2, 2, (300, 3)), [[MAX_COORD] * 3, [-MAX_COORD] * 3]])
    pos = np.concatenate([markers[:5] + 1e-21, rng.uniform(-2, 2, (20, 3))])
    dirs = rng.normal(size=(25, 3))
    lens = rng.uniform(0.5, 2, 25)
    kw = dict(view_radius=vr, view_angle=math.pi)
    np.testing.assert_array_equal(assign_treewand(markers, pos, dirs, lens, **kw),
                                  assign_treewand_reference(markers, pos, dirs, lens, **kw))
    ta = TreeWandAssigner(markers, **kw)
    assert np.prod(ta.dims.astype(float)) <= max(4096, len(markers) // 2)


def test_build_grid_cell_count_is_capped_for_a_tiny_radius():
    pts = np.array([[-MAX_COORD, -MAX_COORD, -MAX_COORD], [MAX_COORD, MAX_COORD, MAX_COORD], [0.0, 0.0, 0.0]])
    origin, h, dims, reach, *_ = K.build_grid(pts, 1e-20)
    assert np.prod(dims.astype(float)) <= 4096 and reach <= 3 and h > 0
    with pytest.raises(ValueError, match="radius"):
        K.build_grid(pts, 0.0)


# -- fuzz of the engine and core entry points ---------------------------------------------------------------------
_BAD = [np.nan, np.inf, -np.inf, 1e300, 1e19, 10 ** 12, 1e-20, -1, -1e-20, 0, "x", None, [], [1.0, 2.0],
        np.zeros((2, 2)), np.zeros((0, 3)), np.array(["a", "b", "c"]), np.full((2, 3), np.nan),
        np.full((1, 3), 1e19), np.array([[1, 2, 3]], np.int64), True]


@pytest.fixture(scope="module")
def fuzz_engine():
    return _grown(4)


@_SETTINGS
@given(bad=st.sampled_from(_BAD), which=st.integers(0, 2))
def test_fuzz_engine_entry_points(fuzz, fuzz_engine, bad, which):
    e = fuzz_engine
    ok_center, ok_r = np.array([0.0, 5.0, 0.0]), 2.0
    calls = {
        "GrowthEngine.paint": (e.paint, [[bad, ok_r, 10], [ok_center, bad, 10], [ok_center, ok_r, bad]],
                               ("center", "radius", "n_darts")),
        "GrowthEngine.prune_preview": (e.prune_preview, [[bad, 0.01], [ok_center, bad], [bad, bad]],
                                       ("center", "radius", "center")),
        "GrowthEngine.add_markers": (e.add_markers, [[bad], [bad], [bad]], ("points",) * 3),
        "GrowthEngine.set_params": (e.set_params, [[{"view_radius": bad}], [{"base_length": bad}], [bad]],
                                    ("view_radius", "base_length", "params")),
    }
    for entry, (fn, argsets, params) in calls.items():
        if entry == "GrowthEngine.set_params" and which == 2 and isinstance(bad, dict):
            continue
        before = _state(e)
        res = fuzz.call(entry, fn, *argsets[which], param=params[which])
        if isinstance(res, Exception):
            assert _state(e) == before, f"{entry} changed the engine although it refused the call"
    e.set_params({"view_radius": 4.0, "base_length": 1.0})
    e.paint(np.array([0.0, 6.0, 0.0]), 2.5, 40)
    e.step()
    _sane(e)


@_SETTINGS
@given(bad=st.sampled_from(_BAD), slot=st.integers(0, 9))
def test_fuzz_core_entry_points(fuzz, bad, slot):
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]])
    offs, vals = shadow_lut(0.2, 0.5, 4)
    t = Tree.seed(1.0)
    n = t.n
    g = ShadowGrid(1.0, 4)
    f = [
        ("GrowthEngine", lambda: GrowthEngine({**defaults(), "view_radius": bad}), "view_radius"),
        ("GrowthEngine", lambda: GrowthEngine(defaults(), rng=bad), "rng"),
        ("ShadowGrid", lambda: ShadowGrid(bad, 4), "cell"),
        ("ShadowGrid", lambda: ShadowGrid(1.0, bad), "fine"),
        ("ShadowGrid.add", lambda: g.add(bad, offs, vals), "cells"),
        ("ShadowGrid.read", lambda: g.read(bad), "cells"),
        ("shadow_lut", lambda: shadow_lut(0.2, bad, 4), "beta"),
        ("build_grid", lambda: build_grid(pts, bad), "h"),
        ("within_any", lambda: within_any(build_grid(pts, 1.0), bad, 1.0), "queries"),
        ("poisson_darts", lambda: poisson_darts(np.zeros(3), 1.0, bad, pts, 0.1, 0), "n_darts"),
    ]
    f += [
        ("accumulate_light", lambda: V.accumulate_light(t.child, t.alive, t.L, t.light_factor, bad, 0.5, t.Q, t.Qw,
                                                        t.Qslot), "kappa"),
        ("distribute_vigor", lambda: V.distribute_vigor(t.child, t.alive, t.Qslot, bad, 0.5, 2.0, t.vigor,
                                                        t.bud_vigor), "Qw"),
        ("pipe_radius", lambda: V.pipe_radius(bad, t.alive, 0.02, 2.5, t.radius), ("child", "alive")),
        ("shed_mask", lambda: V.shed_mask(t.child, bad, t.alive, t.vigor, False), "parent"),
        ("assign_treewand", lambda: assign_treewand(pts, pts, pts + 1, [1.0, 1.0], view_radius=bad,
                                                    view_angle=1.0), "view_radius"),
        ("TreeWandAssigner", lambda: TreeWandAssigner(bad, view_radius=1.0, view_angle=1.0), "markers"),
        ("internode_lengths", lambda: internode_lengths("vigor", base=bad, mult=2.0, vigor=np.ones(2), vmax=1.0),
         "base"),
        ("ShadowGrid.cells_of", lambda: g.cells_of(bad), "points"),
    ]
    for entry, fn, param in (f[slot], f[10 + slot % 8]):
        fuzz.call(entry, fn, param=param)
    assert t.n == n
    g.add(np.array([[0, 0, 0]]), offs, vals)  # the grid still works after whatever was refused
    assert np.all(np.isfinite(g.read(np.array([[0, -1, 0]]))))


def test_rejected_engine_commands_leave_it_unchanged():
    e = _grown(3)
    before = _state(e)
    for fn, args in [(e.paint, ([np.nan, 0, 0], 1.0)), (e.paint, ([0, 0, 0], 1.0, 10 ** 12)),
                     (e.add_markers, ([[1e100, 0, 0]],)), (e.prune, ([0, 0, 0], np.inf)),
                     (e.set_params, ({"view_radius": 2.0, "base_length": -1.0},)),
                     (e.set_params, ({"nonsense": 1},))]:
        with pytest.raises(ValueError):
            fn(*args)
        assert _state(e) == before
    with pytest.raises(ValueError, match="missing"):
        GrowthEngine({"view_radius": 1.0})

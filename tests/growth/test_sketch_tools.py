"""TreeSketch tools from code: strokes, lasso, selection, pruning, library (spec 004 §2.5–2.8; V15). Grow / ungrow /
undo (§2.4, V17) is the document's history: tests/documents/test_treesketch.py."""
import json
import math

import numpy as np
import pytest
from skimage.measure import points_in_poly

from plantvr.growth.sketch import SketchEngine
from plantvr.growth.sketch_tools import (
    StrokeEmitter,
    lasso_volume,
    prune_nearest,
    select_branch,
)
from plantvr.params import defaults


def _engine(**kw):
    return SketchEngine({**defaults(), **kw.pop("params", {})}, rng=kw.pop("rng", 7), **kw)


def test_ts_stroke_brush_and_sketch_points():
    e = _engine()
    s = StrokeEmitter(e, rate=50.0, spacing=0.25, rng=1)
    s.begin([0.0, 2.0, 0.0])
    pts = s.move([2.0, 2.0, 0.0], radius=1.0, dt=1.0)  # brush: points within R of the segment
    assert 10 < len(pts) < 100  # Poisson(50 * 1^3 * 1)
    seg_d = np.linalg.norm(np.cross(pts - [0, 2, 0], [1, 0, 0]), axis=1)
    assert np.all(seg_d <= 1.0 + 1e-12) and np.all((pts[:, 0] > -1.0) & (pts[:, 0] < 3.0))
    np.testing.assert_allclose(e.stroke_directions(pts), np.tile([1.0, 0, 0], (len(pts), 1)))
    sk = s.move([2.0, 3.0, 0.0], radius=0.0)  # radius shrinks to 0 mid-stroke: sketch on the stroke itself
    np.testing.assert_allclose(sk[:, 0], 2.0)
    np.testing.assert_allclose(np.diff(np.concatenate([[2.0], sk[:, 1]])), 0.25, atol=1e-12)
    sk2 = s.move([2.0, 3.1, 0.0], radius=0.0)
    sk3 = s.move([2.0, 3.3, 0.0], radius=0.0)  # spacing carried across moves
    assert len(sk2) == 0 and len(sk3) == 1 and abs(sk3[0, 1] - 3.25) < 1e-12
    np.testing.assert_allclose(e.stroke_directions(sk), np.tile([0.0, 1, 0], (len(sk), 1)))
    s.end()
    assert len(e.markers) == s.emitted
    with pytest.raises(ValueError, match="begin"):
        s.move([0, 0, 0], 1.0)
    with pytest.raises(ValueError, match="radius"):
        s.begin([0, 0, 0]), s.move([0, 1, 0], -1.0)


def test_ts_sketch_grows_along_the_stroke():
    """A thin sketch (radius 0) upward then sideways guides a branch along it (directed growth)."""
    e = _engine(n_max=2, params={"activation_threshold": 0.0, "length_mode": "constant"}, stroke_tropism=True)
    s = StrokeEmitter(e, spacing=0.5)
    s.begin([0.0, 1.0, 0.0])
    s.move([0.0, 6.0, 0.0], 0.0)
    s.move([5.0, 9.0, 0.0], 0.0)
    s.end()
    for _ in range(8):
        e.step()
    t = e.tree
    tip = t.pos[t.alive][np.argmax(t.pos[t.alive][:, 0])]
    assert tip[0] > 2.0 and tip[1] > 6.0


def _blob(k=40):
    a = np.linspace(0, 2 * math.pi, k, endpoint=False)
    r = 2.0 + 0.6 * np.cos(3 * a)
    return np.column_stack([r * np.cos(a), 1.5 * r * np.sin(a)])


def test_ts_v15_lasso_inflation():
    poly = _blob()
    origin, u, v = np.array([1.0, 5.0, -2.0]), np.array([1.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    lv = lasso_volume(poly, origin=origin, u=u, v=v, n_points=800, rng=3)
    assert lv.points.shape == (800, 3)
    assert lv.contains(lv.points).all()
    q = lv.to_plane(lv.points)
    inside = points_in_poly(q[:, :2], poly)
    assert inside.mean() > 0.98  # projects onto the silhouette (pixel-boundary slack)
    # the envelope projects exactly onto the silhouette mask: positive thickness on the mask, zero off it
    assert (lv.height[lv.mask] > 0).all() and (lv.height[~lv.mask] == 0).all()
    # maximal thickness on the chordal axis, and the axis carries h = R (circular cross-section)
    assert lv.axis[np.unravel_index(np.argmax(lv.height), lv.height.shape)]
    assert np.abs(q[:, 2]).max() <= lv.height.max() + 1e-12
    assert np.abs(q[:, 2]).max() > 0.5 * lv.height.max()  # a volume, not a flat sheet
    np.testing.assert_allclose(np.linalg.norm(lv.w), 1.0)
    with pytest.raises(ValueError, match="polygon"):
        lasso_volume(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]))
    with pytest.raises(ValueError, match="parallel"):
        lasso_volume(poly, u=[1, 0, 0], v=[2, 0, 0])


def test_ts_lasso_fills_a_crown():
    e = _engine(n_max=2, params={"activation_threshold": 0.0})
    lv = lasso_volume(_blob() + [0.0, 8.0], n_points=600, rng=1)
    e.add_markers(lv.points)
    for _ in range(12):
        e.step()
    t = e.tree
    top = t.pos[t.alive]
    assert top[:, 1].max() > 6.0 and e.tree.n_internodes > 30


def test_ts_selective_and_prune_by_picking():
    e = _engine(mode="autonomous")
    for _ in range(5):
        e.step()
    t = e.tree
    side = np.flatnonzero(t.alive & (t.order == 1))[0]
    node = select_branch(e, t.pos[side] + 1e-3)
    assert node == side and e.selected == side
    n_before = e.tree.n_internodes
    removed = prune_nearest(e, e.tree.pos[side])
    assert removed > 0 and e.tree.n_internodes == n_before - removed
    assert e.selected is None or e.tree.alive[e.selected]


# -- tree library and presets (Fig. E.8) -----------------------------------------------------------------------
from plantvr.growth.sketch_tools import PRESETS, TreeLibrary


def _live(e):
    a = e.tree.arrays()
    return {k: v[a["alive"]] for k, v in a.items() if k not in ("parent", "child")}


def test_ts_library_save_reload_continues_identically(tmp_path):
    e = _engine(mode="autonomous", ellipse=(0.8, 1.2, 0.2), deflection=12.0, stroke_tropism=True)
    for _ in range(5):
        e.step()
    prune_nearest(e, e.tree.pos[np.flatnonzero(e.tree.alive & (e.tree.order == 1))[0]])
    e.set_width(1, 0.4)
    tip = int(np.flatnonzero(e.tree.alive & (e.tree.child[:, 0] == -1))[-1])
    select_branch(e, e.tree.pos[tip], direction=[1.0, 0.5, 0.0])
    assert e.bud_override
    e.set_options(mode="directed")
    s = StrokeEmitter(e, rng=4)
    s.begin([0.0, 6.0, 0.0])
    s.move([3.0, 7.0, 1.0], 1.0, dt=1.0)
    lib = TreeLibrary(tmp_path / "lib")
    lib.save("oak-1", e)
    f = lib.load("oak-1")
    assert lib.trees() == ["oak-1"]
    assert f.sketch == e.sketch and f.seed == e.seed and f.step_count == e.step_count
    np.testing.assert_array_equal(f.markers, e.markers)
    np.testing.assert_array_equal(f.stroke_directions(f.markers), e.stroke_directions(e.markers))
    assert f.selected is not None and np.array_equal(f.tree.pos[f.selected], e.tree.pos[e.selected])
    assert [(f.tree.pos[n].tolist(), k, d.tolist()) for (n, k), d in f.bud_override.items()] == \
        [(e.tree.pos[n].tolist(), k, d.tolist()) for (n, k), d in e.bud_override.items()]
    for k, v in _live(e).items():
        np.testing.assert_array_equal(_live(f)[k], v, err_msg=k)
    for _ in range(3):
        e.step()
        f.step()
    for k, v in _live(e).items():
        np.testing.assert_array_equal(_live(f)[k], v, err_msg=k)


def test_ts_library_corrupt_and_names(tmp_path):
    lib = TreeLibrary(tmp_path)
    e = _engine()
    lib.save("t", e)
    (tmp_path / "t.json").write_text("{not json")
    with pytest.raises(ValueError, match="cannot read"):
        lib.load("t")
    (tmp_path / "t.json").write_text('{"format": "plantvr-treesketch 1", "options": {}}')
    with pytest.raises(ValueError, match="corrupt"):
        lib.load("t")
    with pytest.raises(ValueError, match="cannot read"):
        lib.load("missing")
    with pytest.raises(ValueError, match="name"):
        lib.save("../evil", e)


def test_ts_presets_apply_and_roundtrip(tmp_path):
    lib = TreeLibrary(tmp_path)
    assert set(PRESETS) <= set(lib.presets())
    e = _engine()
    lib.apply_preset("weeping", e)
    assert e.sketch["n_max"] == 6 and e.params["tropism_angle"] == 160.0
    lib.save_preset("mine", e, keys=["tropism_angle", "apical_dominance", "n_max"])
    g = _engine()
    lib.apply_preset("mine", g)
    assert g.params["tropism_angle"] == 160.0 and g.sketch["n_max"] == 6
    assert json.loads((tmp_path / "mine.preset.json").read_text())["table"] == "treesketch"  # the one preset format
    (tmp_path / "bad.preset.json").write_text('{"plantvr_preset": 1, "params": {"tropism_angle": 999}}')
    before = (dict(g.params), dict(g.sketch))
    with pytest.raises(ValueError, match="tropism_angle"):
        lib.apply_preset("bad", g)
    assert (g.params, g.sketch) == before  # a rejected preset leaves the engine unchanged
    with pytest.raises(ValueError, match="unknown preset"):
        lib.apply_preset("nope", g)

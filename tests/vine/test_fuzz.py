"""Fuzzing ViNE's public entry points (issue 20): every input ends in a result or a clear ValueError/TypeError
raised by PlantVR naming the parameter; a rejected command leaves the segmentation unchanged; after an accepted
one the session keeps working (paint, undo, save/load round trip)."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr._fileio import digest_arrays
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.commandlog import CommandLog, Event
from plantvr.documents.labels import Segmentation
from plantvr.io.ply import write_ply
from plantvr.vine import colors as C
from plantvr.vine import depthcue, fill, index, isosurface, labelstats, proxy, slices, synth, views, volume
from plantvr.vine.synth import synth_balls

SET = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

NUMBERS = [np.nan, np.inf, -np.inf, 1e300, 1e19, 10 ** 12, 1e-20, -1, -5, 0, 0.5, 3, 255, 256, 2 ** 63]
WEIRD = ["x", None, [], [[1, 2]], np.zeros((2, 2)), True, {}, b"3", 1 + 2j]
SCALARS = st.sampled_from(NUMBERS + WEIRD)
POINTS = st.sampled_from([
    [np.nan, 0, 0], [np.inf, 0, 0], [1e300, 0, 0], [1e19, -1e19, 0], [1e-20, 0, 0], [0, 0], [[0, 0, 0]],
    "abc", None, [], [0, 0, 0, 0], np.zeros(3, bool), np.array(["a", "b", "c"]), [10 ** 12, 0, 0], [5, 5, 5]])


@pytest.fixture(scope="module")
def surf():
    return extract_isosurface(synth_balls(), 100.0)


def _seg(surf):
    return Segmentation(surf.vertices, surf.faces, normals=surf.normals)


def _state(seg):
    return digest_arrays(seg._state_arrays(include_mesh=False)), len(seg.log), seg._stroke is None


#: Argument names of the positional event tuples EVENTS draws.
_ARGS = {"paint": ("center", "radius", "label"), "set_color": ("label", "rgb"), "set_visible": ("label", "visible"),
         "fill": ("vertex", "label", "radius"), "merge_labels": ("keep", "other")}


def _as_log(events) -> CommandLog:
    """The drawn events as an unchecked command log; a drawn non-event becomes one whose kwargs are no dict."""
    log = CommandLog()
    log.events = [Event(e[0], dict(zip(_ARGS.get(e[0], ()), e[1:]))) if isinstance(e, tuple) and e
                  else Event("paint", e) for e in events]
    return log


def _sane(seg, tmp_path):
    """The session still works after whatever was accepted: paint, undo, redo, save and load round trip."""
    assert seg.labels.dtype in (np.uint8, np.uint16) and int(seg.labels.max()) < len(seg.colors)
    if seg._stroke is not None:
        seg.end_stroke()
    vis = np.flatnonzero(seg.colors.visible)
    if vis.size:
        seg.paint(seg.vertices[0].astype(float), min(2.0, seg.max_radius), int(vis[-1]))
        seg.undo()
        seg.redo()
    seg.save(tmp_path / "sane.npz")
    back = Segmentation.load(tmp_path / "sane.npz")
    assert np.array_equal(back.labels, seg.labels) and np.array_equal(back.colors.rgba, seg.colors.rgba)


def _call(fuzz, seg, entry, fn, *args, param=None, **kw):
    before = _state(seg)
    r = fuzz.call(entry, fn, *args, param=param, **kw)
    if isinstance(r, Exception):
        assert _state(seg) == before, f"{entry} rejected its input but changed the segmentation"
    return r


@SET
@given(center=POINTS, radius=SCALARS, label=SCALARS)
def test_fuzz_paint(fuzz, surf, tmp_path, center, radius, label):
    s = _seg(surf)
    _call(fuzz, s, "Segmentation.paint", s.paint, center, 2.0, 1, param="center")
    _call(fuzz, s, "Segmentation.paint", s.paint, s.vertices[0], radius, 1, param="radius")
    _call(fuzz, s, "Segmentation.paint", s.paint, s.vertices[0], 2.0, label, param="label")
    _call(fuzz, s, "Segmentation.paint", s.paint, s.vertices[0], 2.0, 1, preserve=label, param="preserve")
    _call(fuzz, s, "Segmentation.paint_stroke", s.paint_stroke, [center, center], 2.0, 1, param="center")
    _call(fuzz, s, "Segmentation.paint_stroke", s.paint_stroke, center, 2.0, 1, param="centers")
    _call(fuzz, s, "Segmentation.paint_stroke", s.paint_stroke, [s.vertices[0]], radius, 2, param="radius")
    _sane(s, tmp_path)


@SET
@given(center=POINTS, radius=SCALARS, label=SCALARS)
def test_fuzz_strokes(fuzz, surf, tmp_path, center, radius, label):
    s = _seg(surf)
    s.begin_stroke()
    _call(fuzz, s, "Segmentation.paint(stroke)", s.paint, center, radius, label, param=("center", "radius", "label"))
    _call(fuzz, s, "Segmentation.begin_stroke", s.begin_stroke)        # a second one is refused
    _call(fuzz, s, "Segmentation.fill(stroke)", s.fill, 0, 2)          # so is a fill inside a stroke
    s.end_stroke()
    _call(fuzz, s, "Segmentation.end_stroke", s.end_stroke)
    _call(fuzz, s, "Segmentation.abort_stroke", s.abort_stroke)
    for _ in range(3):
        _call(fuzz, s, "Segmentation.undo", s.undo)
        _call(fuzz, s, "Segmentation.redo", s.redo)
    _sane(s, tmp_path)


@SET
@given(a=SCALARS, b=SCALARS, c=SCALARS)
def test_fuzz_fill_split_merge(fuzz, surf, tmp_path, a, b, c):
    s = _seg(surf)
    s.paint(s.vertices[0], 3.0, 2)
    _call(fuzz, s, "Segmentation.fill", s.fill, a, 3, param="vertex")
    _call(fuzz, s, "Segmentation.fill", s.fill, 0, b, param="label")
    _call(fuzz, s, "Segmentation.fill", s.fill, 5, 4, c, param="radius")
    _call(fuzz, s, "Segmentation.split_label", s.split_label, a, param="label")
    _call(fuzz, s, "Segmentation.split_label", s.split_label, 2, b, param="min_vertices")
    _call(fuzz, s, "Segmentation.merge_labels", s.merge_labels, a, 2, param="keep")
    _call(fuzz, s, "Segmentation.merge_labels", s.merge_labels, 1, b, param="other")
    _call(fuzz, s, "Segmentation.label_components", s.label_components, c, param="label")
    _call(fuzz, s, "Segmentation.smoothed_colors", s.smoothed_colors, a, param="iterations")
    _sane(s, tmp_path)


RGB = st.one_of(st.sampled_from([(0.5, 200.7, 3.2), (0, 256, 0), "red", None, (1, 2), (np.nan, 0, 0)]),
                st.tuples(SCALARS, SCALARS, SCALARS), st.lists(st.integers(0, 255), min_size=3, max_size=4))


@SET
@given(label=SCALARS, rgb=RGB, vis=SCALARS)
def test_fuzz_colors(fuzz, surf, tmp_path, label, rgb, vis):
    s = _seg(surf)
    _call(fuzz, s, "Segmentation.set_color", s.set_color, label, (1, 2, 3), param="label")
    _call(fuzz, s, "Segmentation.set_color", s.set_color, 1, rgb, param="rgb")
    _call(fuzz, s, "Segmentation.add_color", s.add_color, rgb, param="rgb")
    _call(fuzz, s, "Segmentation.set_visible", s.set_visible, label, False, param="label")
    _call(fuzz, s, "Segmentation.set_visible", s.set_visible, 2, vis, param="visible")
    _call(fuzz, s, "Segmentation.toggle_visible", s.toggle_visible, label, param="label")
    _call(fuzz, s, "Segmentation.preserve", setattr, s, "preserve", label, param="preserve")
    fuzz.call("ColorTable", C.ColorTable, [[rgb]] if rgb is not None else rgb, param="colors")
    _sane(s, tmp_path)


def test_full_colour_table_widens_to_uint16(fuzz, surf, tmp_path):
    s = _seg(surf)
    while len(s.colors) < 256:
        s.colors.add_color((1, 1, 1))
    _call(fuzz, s, "Segmentation.add_color", s.add_color, (1, 1, 1))
    s.paint(s.vertices[0], 3.0, 2)
    _call(fuzz, s, "Segmentation.split_label", s.split_label, 2)
    _sane(s, tmp_path)


VIEWS = st.sampled_from([np.full(13, np.nan), np.r_[np.zeros(3), np.eye(3).ravel(), 0.0],
                         np.r_[np.zeros(3), np.eye(3).ravel(), -1.0], np.r_[np.zeros(3), 2 * np.eye(3).ravel(), 1],
                         np.zeros(12), "view", None, np.r_[np.full(3, 1e300), np.eye(3).ravel(), 1.0],
                         np.r_[np.zeros(3), np.eye(3).ravel(), 1.0]])


@SET
@given(a=VIEWS, p=POINTS, x=SCALARS)
def test_fuzz_views(fuzz, surf, tmp_path, a, p, x):
    s = _seg(surf)
    v = fuzz.call("SavedView.from_array", views.SavedView.from_array, a, param="view")
    _call(fuzz, s, "Segmentation.add_view", s.add_view, v if not isinstance(v, Exception) else a, param="view")
    fuzz.call("save_view", views.save_view, p, np.eye(3), 1.0, viewer_position=np.zeros(3), view_dir=[0, 0, 1],
              param="model_position")
    fuzz.call("save_view", views.save_view, np.zeros(3), np.eye(3), x, viewer_position=np.zeros(3),
              view_dir=[0, 0, 1], param="model_scale")
    fuzz.call("save_view", views.save_view, np.zeros(3), np.eye(3), 1.0, viewer_position=np.zeros(3), view_dir=p,
              param="view_dir")
    fuzz.call("world_to_model", views.world_to_model, p, 1.0, position=np.zeros(3), rotation=[1, 0, 0, 0],
              scale=1.0, param="center")
    fuzz.call("world_to_model", views.world_to_model, np.zeros(3), x, position=np.zeros(3), rotation=[1, 0, 0, 0],
              scale=x, param=("radius", "scale"))
    fuzz.call("quat_from_axis_angle", views.quat_from_axis_angle, p, 1.0, param="axis")
    _sane(s, tmp_path)


EVENTS = st.lists(st.one_of(
    st.tuples(st.just("paint"), POINTS, SCALARS, SCALARS),
    st.tuples(st.sampled_from(["undo", "redo", "begin_stroke", "end_stroke", "abort_stroke"])),
    st.tuples(st.just("set_color"), SCALARS, RGB), st.tuples(st.just("set_visible"), SCALARS, SCALARS),
    st.tuples(st.just("fill"), SCALARS, SCALARS, SCALARS), st.tuples(st.just("merge_labels"), SCALARS, SCALARS),
    st.tuples(st.sampled_from(["explode", "save", "__init__"])), st.just(()), st.just(None), st.just("paint"),
), max_size=6)


@SET
@given(events=EVENTS)
def test_fuzz_replay_is_all_or_nothing(fuzz, surf, tmp_path, events):
    s = _seg(surf)
    s.paint(s.vertices[0], 2.0, 3)
    log = _as_log(events)
    r = _call(fuzz, s, "Segmentation.replay", s.replay, log, param="event")
    if not isinstance(r, Exception):                  # accepted: the same as applying the events one by one
        t = _seg(surf)
        t.paint(t.vertices[0], 2.0, 3)
        for ev in log:
            getattr(t, ev.command)(**ev.kwargs)
        assert _state(t) == _state(s)
    _sane(s, tmp_path)


ARRAYS = st.sampled_from([np.full((4, 3), np.nan), np.full((4, 3), 1e300), np.zeros((4, 2)), np.zeros((0, 3)),
                          np.array([[0, 1, 99]]), np.array([[0, 1, -1]]), np.zeros((3, 3), bool), "mesh", None,
                          np.zeros((2, 3), np.float32), np.array([[0.5, 1, 2]]), np.array([[0, 1, 2]], np.int64),
                          np.full((3, 3), 1e19), np.zeros(3)])


@SET
@given(a=ARRAYS, b=ARRAYS, x=SCALARS)
def test_fuzz_constructor_and_readers_of_arrays(fuzz, tmp_path, a, b, x):
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    f = np.array([[0, 1, 2]])
    for args, kw, p in (((a, f), {}, "vertices"), ((v, b), {}, "faces"), ((v, f), {"labels": a}, "labels"),
                        ((v, f), {"normals": a}, "normals"), ((v, f), {"index": x}, "index"),
                        ((v, f), {"max_undo": x}, "max_items"), ((v, f), {"max_undo_bytes": x}, "max_bytes"),
                        ((v, f), {"colors": a}, "colors")):
        s = fuzz.call("Segmentation", Segmentation, *args, param=p, **kw)
        if not isinstance(s, Exception):
            _sane(s, tmp_path)
    fuzz.call("write_ply", write_ply, tmp_path / "a.ply", a, f, param="vertices")
    fuzz.call("write_ply", write_ply, tmp_path / "a.ply", v, b, param="faces")
    fuzz.call("write_ply", write_ply, tmp_path / "a.ply", v, f, chunk=x, param="chunk")
    fuzz.call("mesh_graph", fill.mesh_graph, a, f, param="vertices")
    fuzz.call("mesh_graph", fill.mesh_graph, v, b, param="faces")
    fuzz.call("GridIndex", index.GridIndex, a, param="points")
    fuzz.call("KDTreeIndex", index.KDTreeIndex, a, param="points")
    fuzz.call("ball_query_brute", index.ball_query_brute, v, a, 1.0, param="center")
    fuzz.call("ball_query_brute", index.ball_query_brute, a, np.zeros(3), 1.0, param="points")
    fuzz.call("ball_query_brute", index.ball_query_brute, v, np.zeros(3), x, param="radius")
    fuzz.call("signed_volume", isosurface.signed_volume, a, f, param="vertices")
    fuzz.call("label_table", labelstats.label_table, v, b, np.zeros(3, np.uint8), param="faces")
    fuzz.call("label_mesh", labelstats.label_mesh, v, f, np.zeros(3, np.uint8), x, param="label")
    fuzz.call("coarse_hull", depthcue.coarse_hull, a, param="points")
    fuzz.call("depth_factor", depthcue.depth_factor, a, 0.0, 1.0, param="d")
    fuzz.call("depth_factor", depthcue.depth_factor, np.ones(3), x, 1.0, param="d_c")
    fuzz.call("plane_segments", slices.plane_segments, v, b, 0, 0.5, param="faces")
    fuzz.call("plane_segments", slices.plane_segments, v, f, x, 0.5, param="axis")
    fuzz.call("plane_segments", slices.plane_segments, v, f, 0, x, param="position")
    fuzz.call("tile_mesh", synth.tile_mesh, a, f, 2, param="vertices")
    fuzz.call("tile_mesh", synth.tile_mesh, v, f, x, param="n_vertices")


VOLS = st.sampled_from([np.zeros((0, 4, 4), np.uint8), np.zeros((8, 8), np.uint8), np.zeros((4, 4, 4), np.float32),
                        np.zeros((1, 4, 4), np.uint8), "vol", None, np.full((6, 6, 6), 7, np.uint8),
                        (synth_balls(8) > 0).astype(np.uint16) * 1000, np.zeros((4, 4, 4), bool)])


@SET
@given(vol=VOLS, x=SCALARS)
def test_fuzz_volumes(fuzz, vol, x):
    fuzz.call("downsample2", volume.downsample2, vol, param="volume")
    fuzz.call("downsample2", volume.downsample2, synth_balls(8), slab=x, param="slab")
    fuzz.call("histogram", volume.histogram, vol, param="volume")
    fuzz.call("histogram", volume.histogram, synth_balls(8), bins=x, param="bins")
    fuzz.call("suggest_level", volume.suggest_level, vol, param="volume")
    fuzz.call("extract_isosurface", isosurface.extract_isosurface, vol, 100.0, param=("volume", "level"))
    fuzz.call("extract_isosurface", isosurface.extract_isosurface, synth_balls(8), x, param="level")
    fuzz.call("Segmentation.from_volume", Segmentation.from_volume, synth_balls(8), x, param="level")
    fuzz.call("synth_flowerhead", synth.synth_flowerhead, x, param="shape")
    fuzz.call("vertex_labels_from_volume", synth.vertex_labels_from_volume, np.zeros((2, 3)), vol,
              np.zeros((4, 4, 4), np.uint8), param=("volume", "labels", "vertices"))


@SET
@given(x=SCALARS, src=st.sampled_from(["synth:x", "synth:0", "synth:5000", "", "nope.npy", "synth:16:2", 7, None]))
def test_fuzz_open_source_and_demo(fuzz, surf, x, src):
    from plantvr.documents.labels_app import paint_demo
    from plantvr.io.source import open_source
    fuzz.call("open_source", open_source, src, param=("source", "size"))
    fuzz.call("open_source", open_source, "synth", size=x, param="size")
    fuzz.call("open_source", open_source, "synth:16", level=x, param="level")
    s = _seg(surf)
    _call(fuzz, s, "paint_demo", paint_demo, s, stamps=x, param="stamps")
    _call(fuzz, s, "paint_demo", paint_demo, s, truth=np.zeros(3, np.uint8), param="truth")


def test_fuzz_display_proxy(fuzz, surf):
    s = _seg(surf)
    for x in NUMBERS + WEIRD:
        r = fuzz.call("DisplayProxy", proxy.DisplayProxy, s, target_faces=x, param="target_faces")
        if not isinstance(r, Exception):
            r.close()
    fuzz.call("DisplayProxy", proxy.DisplayProxy, "seg", param="seg")
    fuzz.call("decimate_with_owner", proxy.decimate_with_owner, np.full((3, 3), np.nan), np.array([[0, 1, 2]]), 4,
              param="vertices")

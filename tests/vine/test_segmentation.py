import numpy as np
import pytest
import trimesh

from plantvr.commandlog import CommandLog
from plantvr.documents.labels import Segmentation
from plantvr.vine.index import ball_query_brute
from plantvr.vine.views import quat_from_axis_angle, quat_rotate, save_view, world_to_model
from plantvr.io import labels as io_labels


@pytest.fixture
def seg(surface):
    return Segmentation(surface.vertices, surface.faces, normals=surface.normals)


def _state(seg):
    return (seg.labels.copy(), seg.colors.rgba.copy(), seg.colors.visible.copy(), len(seg.history.undo_stack),
            seg.version)


def _same(a, b):
    return all(np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y for x, y in zip(a, b))


def test_paint_rejects_bad_input_and_leaves_state_unchanged(seg):
    seg.paint(seg.vertices[0].astype(float), 3.0, 1)
    before = _state(seg)
    for args, match in [(([0, 0], 1.0, 1), "center"), (([0, 0, np.nan], 1.0, 1), "finite"),
                        (([0, 0, 0], -1.0, 1), "radius"), (([0, 0, 0], 1e9, 1), "radius"),
                        (([0, 0, 0], 1.0, 99), "label"), (([0, 0, 0], 1.0, 1.5), "label"),
                        (([0, 0, 0], 1.0, -1), "label")]:
        with pytest.raises(ValueError, match=match):
            seg.paint(*args)
        assert _same(_state(seg), before)
    seg.hide(4)
    with pytest.raises(ValueError, match="hidden"):
        seg.paint([0, 0, 0], 1.0, 4)


def test_tw_v3_brush_equals_brute_force_minus_hidden_in_model_space(seg):
    rng = np.random.default_rng(5)
    seg.labels[:] = rng.integers(0, 4, seg.n_vertices).astype(np.uint8)
    seg.hide(2)
    # a rotated, scaled, translated model: brush given in world space
    q = quat_from_axis_angle([1, 2, 3], 0.7)
    P, s = np.array([10.0, -3.0, 2.0]), 2.5
    v_model = seg.vertices[1234].astype(np.float64)
    world = P + s * quat_rotate(q, v_model)
    c, r = world_to_model(world, 12.0, position=P, rotation=q, scale=s)
    assert np.allclose(c, v_model) and r == pytest.approx(12.0 / s)
    before = seg.labels.copy()
    n = seg.paint(c, r, 1)
    hits = ball_query_brute(seg.vertices, c, r)
    expect = before.copy()
    sel = hits[(before[hits] != 2)]
    expect[sel] = 1
    assert np.array_equal(seg.labels, expect)
    assert n == int(((before[hits] != 2) & (before[hits] != 1)).sum())


def test_tw_v5_hidden_vertices_never_change_and_toggle_restores_faces(seg):
    rng = np.random.default_rng(2)
    seg.paint(seg.vertices[100].astype(float), 15.0, 3)
    faces_all = seg.visible_faces().copy()
    seg.toggle_visible(3)
    hidden = seg.labels == 3
    assert len(seg.visible_faces()) < len(faces_all)
    for _ in range(20):
        seg.paint(seg.vertices[rng.integers(seg.n_vertices)].astype(float), 10.0, 5)
    assert np.all(seg.labels[hidden] == 3)
    seg.toggle_visible(3)
    assert np.array_equal(seg.visible_faces(), faces_all)


def test_recolouring_edits_only_the_table(seg):
    seg.paint(seg.vertices[0].astype(float), 6.0, 2)
    labels = seg.labels.copy()
    seen = []
    seg.observe(lambda ch: seen.append(ch["new"].kind), names="change")
    seg.set_color(2, (1, 2, 3))
    assert np.array_equal(seg.labels, labels) and seen == ["colors"]
    assert np.all(seg.vertex_colors()[labels == 2, :3] == (1, 2, 3))
    assert seg.labels.dtype == np.uint8 and seg.labels.nbytes == seg.n_vertices


def test_session_round_trip_is_lossless(seg, tmp_path):
    rng = np.random.default_rng(3)
    for k in range(6):
        seg.paint_stroke(seg.vertices[rng.integers(seg.n_vertices, size=3)].astype(float), 4.0, 1 + k)
    seg.undo()
    seg.hide(5)
    seg.set_color(1, (9, 8, 7))
    seg.add_view(save_view([1, 2, 3], [1, 0, 0, 0], 2.0, viewer_position=[0, 1.7, 0], view_dir=[0.3, -0.2, -1]))
    p = tmp_path / "s.npz"
    seg.save(p)
    back = Segmentation.load(p)
    a, b = seg._state_arrays(), back._state_arrays()
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k]), k
    back.redo()
    seg.redo()
    assert np.array_equal(seg.labels, back.labels)


@pytest.mark.parametrize("damage", ["truncate", "garbage", "missing", "bad_faces"])
def test_corrupt_session_raises_and_leaves_object_unchanged(seg, tmp_path, damage):
    seg.paint(seg.vertices[0].astype(float), 5.0, 2)
    good = tmp_path / "good.npz"
    seg.save(good)
    bad = tmp_path / "bad.npz"
    if damage == "truncate":
        bad.write_bytes(good.read_bytes()[:200])
    elif damage == "garbage":
        bad.write_bytes(b"\x00" * 1000)
    else:
        d = seg._state_arrays()
        if damage == "missing":
            d.pop("labels")
        else:
            d["faces"] = d["faces"].copy()
            d["undo_idx"] = d["undo_idx"] + seg.n_vertices
        np.savez(bad, **d)
    before = _state(seg)
    with pytest.raises(ValueError, match="segmentation file"):
        seg.restore(bad)
    assert _same(_state(seg), before)
    with pytest.raises(ValueError, match="segmentation file"):
        Segmentation.load(bad)


def test_tw_v11_ply_round_trip_with_trimesh_oracle(seg, tmp_path):
    seg.paint(seg.vertices[7].astype(float), 8.0, 3)
    p = tmp_path / "seg.ply"
    io_labels.export_ply(seg, p)
    m = trimesh.load(p, process=False)
    assert np.array_equal(np.asarray(m.vertices, np.float32), seg.vertices)
    assert np.array_equal(m.faces, seg.faces.astype(np.int64))
    assert np.array_equal(m.visual.vertex_colors, seg.vertex_colors())
    seg.hide(3)
    io_labels.export_ply(seg, tmp_path / "vis.ply", visible_only=True)
    m2 = trimesh.load(tmp_path / "vis.ply", process=False)
    assert len(m2.faces) == len(seg.visible_faces())


def test_tw_v11_laplacian_colour_smoothing(seg):
    seg.paint(seg.vertices[300].astype(float), 10.0, 2)
    c0 = seg.vertex_colors().astype(float)
    c1 = seg.smoothed_colors(2).astype(float)
    f = seg.faces.astype(np.int64)
    energy = lambda c: sum(((c[f[:, a]] - c[f[:, b]]) ** 2).sum() for a, b in ((0, 1), (1, 2), (2, 0)))
    assert energy(c1) < 0.5 * energy(c0)
    # interior vertices (all neighbours in the same label, 2 rings) keep their colour
    lab = seg.labels
    same = np.ones(seg.n_vertices, bool)
    for _ in range(2):
        bad = np.zeros(seg.n_vertices, bool)
        for a, b in ((0, 1), (1, 2), (2, 0)):
            diff = (lab[f[:, a]] != lab[f[:, b]]) | ~same[f[:, a]] | ~same[f[:, b]]
            bad[f[diff, a]] = True
            bad[f[diff, b]] = True
        same &= ~bad
    assert np.abs(c1[same] - c0[same]).max() <= 1


def test_kdtree_session_paints_like_grid(surface):
    a = Segmentation(surface.vertices, surface.faces, index="grid")
    b = Segmentation(surface.vertices, surface.faces, index="kdtree")
    rng = np.random.default_rng(9)
    for _ in range(10):
        c, r, lab = surface.vertices[rng.integers(len(surface.vertices))].astype(float), rng.uniform(1, 9), \
            int(rng.integers(1, 6))
        assert a.paint(c, r, lab) == b.paint(c, r, lab)
    assert np.array_equal(a.labels, b.labels)
    assert np.array_equal(a.history.undo_stack[-1].indices, b.history.undo_stack[-1].indices)


def test_event_log_replay_gives_identical_labels(surface):
    from plantvr.vine.buffers import PaintWorker
    a = Segmentation(surface.vertices, surface.faces)
    rng = np.random.default_rng(11)
    for k in range(8):
        with a.stroke():
            for _ in range(4):
                a.paint(surface.vertices[rng.integers(len(surface.vertices))].astype(float), 3.0, (1, 3, 4, 5)[k % 4])
        if k == 3:
            a.undo()
            a.hide(2)
        if k == 5:
            a.show(2)
            a.set_color(1, (5, 6, 7))
    with pytest.raises(ValueError, match="center"):
        a.paint([0, 0], 1, 1)                      # rejected commands are not logged
    b = Segmentation(surface.vertices, surface.faces)
    b.replay(a.log)
    assert np.array_equal(a.labels, b.labels) and np.array_equal(a.colors.rgba, b.colors.rgba)
    c = Segmentation(surface.vertices, surface.faces)           # same replay through the worker thread
    w = PaintWorker(c)
    for ev in a.log:
        w.submit(ev.command, **ev.kwargs)
    w.join()
    w.close()
    assert not w.errors and np.array_equal(c.labels, a.labels)
    bad = CommandLog()
    bad.record("paint", center=(0, 0, 0), radius=1.0, label=1)
    bad.record("format_disk")
    with pytest.raises(ValueError, match="event 1 .format_disk.*command must be one of"):
        b.replay(bad)


def test_autosave_loses_at_most_the_open_operation(surface, tmp_path):
    seg = Segmentation(surface.vertices, surface.faces)
    auto = tmp_path / "auto.npz"
    seg.enable_autosave(auto)
    rng = np.random.default_rng(4)
    for k in range(3):
        seg.paint(surface.vertices[rng.integers(len(surface.vertices))].astype(float), 4.0, 1 + k)
    seg.undo()
    seg.hide(3)
    committed = seg.labels.copy()
    seg.begin_stroke()
    seg.paint(surface.vertices[0].astype(float), 6.0, 5)          # "crash" with this stroke open
    assert auto.stat().st_size < surface.vertices.nbytes          # labels-only file, no mesh
    fresh = Segmentation(surface.vertices, surface.faces)
    fresh.restore(auto)
    assert np.array_equal(fresh.labels, committed)
    assert len(fresh.history.undo_stack) == 2 and len(fresh.history.redo_stack) == 1
    assert not fresh.colors.visible[3]
    with pytest.raises(ValueError, match="holds no mesh"):
        Segmentation.load(auto)
    other = Segmentation(surface.vertices[:-1], surface.faces[surface.faces.max(1) < len(surface.vertices) - 1])
    with pytest.raises(ValueError, match="another mesh"):
        other.restore(auto)


def test_gltf_export_round_trip(seg, tmp_path):
    seg.paint(seg.vertices[3].astype(float), 6.0, 4)
    io_labels.export_gltf(seg, tmp_path / "seg.glb")
    scene = trimesh.load(tmp_path / "seg.glb", process=False)
    m = next(iter(scene.geometry.values())) if hasattr(scene, "geometry") else scene
    assert len(m.vertices) == seg.n_vertices and len(m.faces) == len(seg.faces)
    assert np.array_equal(np.asarray(m.visual.vertex_colors), seg.vertex_colors())
    with pytest.raises(ValueError, match="glb"):
        io_labels.export_gltf(seg, tmp_path / "seg.obj")

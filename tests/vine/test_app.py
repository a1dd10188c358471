"""``plantvr segment`` (issue 14): sources, the scripted demo, the headless ``--out`` path and the review app's
commands without a browser."""
import numpy as np
import pytest

from plantvr.vine.app import open_source, paint_demo
from plantvr.vine.segmentation import Segmentation
from plantvr.vine.volume import save_volume


def test_open_synth_and_paint_demo_follows_ground_truth():
    src = open_source("synth:40")
    seg = src.seg
    assert src.truth.shape == (seg.n_vertices,) and src.volume.shape == (40, 40, 40)
    n = paint_demo(seg, truth=src.truth, stamps=12)
    painted = seg.labels > 0
    assert n == painted.sum() > 100
    assert np.mean(seg.labels[painted] == src.truth[painted]) > 0.5   # stamps land on their own component
    assert len(seg.history.undo_stack) == 12


def test_open_volume_and_mesh_files(tmp_path, head):
    save_volume(tmp_path / "v.npy", head.volume)
    src = open_source(tmp_path / "v.npy", level=head.level)
    assert src.level == head.level and src.seg.n_vertices > 1000
    src.seg.export_ply(tmp_path / "m.ply")
    m = open_source(tmp_path / "m.ply")
    assert np.array_equal(m.seg.vertices, src.seg.vertices) and np.array_equal(m.seg.faces, src.seg.faces)
    with pytest.raises(ValueError, match="source must be"):
        open_source(tmp_path / "missing.tif")
    with pytest.raises(ValueError, match="synth:N"):
        open_source("synth:big")
    with pytest.raises(ValueError, match="truth must have shape"):
        paint_demo(src.seg, truth=np.zeros(3, np.uint8))


def test_main_segment_out_writes_painted_ply_session_and_png(tmp_path):
    pytest.importorskip("trame")
    import trimesh

    from plantvr.view.vine_app import main_segment
    assert main_segment(["synth:40", "--out", str(tmp_path), "--stamps", "6"]) == 0
    ply = trimesh.load(tmp_path / "segment.ply", process=False)
    src = open_source("synth:40")
    assert np.allclose(ply.vertices, src.seg.vertices)
    paint_demo(src.seg, truth=src.truth, stamps=6)
    assert np.array_equal(np.asarray(ply.visual.vertex_colors)[:, :3], src.seg.vertex_colors()[:, :3])
    src.seg.restore(tmp_path / "segment_session.npz")                  # labels-only session of the same mesh
    assert (src.seg.labels > 0).sum() > 50
    from PIL import Image
    img = np.asarray(Image.open(tmp_path / "segment.png"))
    assert img.shape[:2] == (600, 800) and (img[..., :3].sum(axis=2) > 150).sum() > 5000
    assert main_segment(["no/such/file.tif", "--out", str(tmp_path)]) == 2


def test_review_app_commands_without_a_browser(head):
    pytest.importorskip("trame_vtk")
    from plantvr.view.vine_app import VineReviewApp, histogram_svg
    app = VineReviewApp(volume=head.volume, level=head.level, target_faces=4000, radius=4.0)
    seg = app.seg
    assert app.proxy.n_vertices < seg.n_vertices and "<line" in app.state.histogram
    assert histogram_svg(head.volume, 10.0).count("<rect") == 64
    p = seg.vertices[seg.n_vertices // 2].astype(float)
    other = Segmentation(seg.vertices, seg.faces)
    app.state.label = 4
    n = app.paint_world(p)
    other.paint(p, 4.0, 4)
    assert n > 0 and np.array_equal(seg.labels, other.labels) and app.state.can_undo
    assert np.array_equal(app.view.mesh.point_data["rgba"], app.proxy.vertex_colors())
    # the stroke travels as a colour delta of exactly the proxy vertices that changed (8 B each)
    d = app.state.vine_delta
    ids = np.frombuffer(d["ids"], "<u4")
    want = np.unique(app.proxy.owner[np.nonzero(seg.labels)[0]])
    assert d["seq"] == app.deltas == 1 and d["n"] == app.proxy.n_vertices and app.resyncs == 0
    assert np.array_equal(ids, want[app.proxy.labels[want] != 0]) and len(d["rgba"]) == 4 * len(ids)
    assert np.array_equal(np.frombuffer(d["rgba"], np.uint8).reshape(-1, 4), app.proxy.vertex_colors()[ids])
    app.resync()                                                        # the page asked for a full resync
    assert app.resyncs == 1 and app.deltas == 1
    app.undo()
    assert not seg.labels.any() and app.state.can_redo
    assert app.deltas == 2 and np.array_equal(np.frombuffer(app.state.vine_delta["ids"], "<u4"), ids)
    app.redo()
    assert np.array_equal(seg.labels, other.labels)
    app.toggle_selected()
    assert not seg.colors.visible[4] and app.state.hidden == [4]
    app.on_pick({"worldPosition": list(p)})                             # painting with a hidden colour: refused
    assert "hidden" in app.state.message
    app.state.level = head.level + 40
    app.apply_level()                                                   # new iso-value: a new, smaller surface
    assert app.seg is not seg and app.seg.n_vertices < seg.n_vertices
    assert app.view.mesh.n_points == app.proxy.n_vertices
    with pytest.raises(ValueError, match="mode"):
        VineReviewApp(seg, mode="webgpu")
    with pytest.raises(ValueError, match="colour_updates"):
        VineReviewApp(seg, colour_updates="mesh")
    with pytest.raises(ValueError, match="give a Segmentation"):
        VineReviewApp()
    app.view.close()

"""SegmentationView (pyvista, offscreen): in-place colour updates, hidden colours, depth cue, saved views."""
import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from plantvr.documents.labels import Segmentation
from plantvr.view.segmentation import SegmentationView
from plantvr.vine.views import save_view


@pytest.fixture
def view(surface):
    seg = Segmentation(surface.vertices, surface.faces, normals=surface.normals)
    v = SegmentationView(seg, window_size=(320, 240))
    v.plotter.camera_position = [(32, -80, 120), (32, 32, 32), (0, 0, 1)]
    yield v
    v.close()


def _lit(img):
    return (img.sum(axis=2) > 30)


def test_paint_updates_colours_in_place_without_rebuild(view, tmp_path):
    seg = view.seg
    before = view.screenshot()
    points_mtime = view.mesh.GetPoints().GetMTime()
    n_cells = view.mesh.n_cells
    seg.set_color(3, (255, 0, 255))
    seg.paint(seg.vertices[np.argmax(seg.vertices[:, 2])].astype(float), 40.0, 3)
    after = view.screenshot(tmp_path / "painted.png")
    assert view.mesh.n_cells == n_cells and view.mesh.GetPoints().GetMTime() == points_mtime
    assert np.array_equal(view.mesh.point_data["rgba"], seg.vertex_colors())
    magenta = (after[..., 0] > 150) & (after[..., 1] < 80) & (after[..., 2] > 150)
    assert magenta.sum() > 500 and ((before[..., 0] > 150) & (before[..., 1] < 80)).sum() == 0
    seg.undo()
    assert np.array_equal(view.mesh.point_data["rgba"], seg.vertex_colors())


def test_hidden_colour_is_not_rendered(view):
    seg = view.seg
    seg.paint(seg.vertices[0].astype(float), seg.max_radius, 4)        # everything label 4
    full = _lit(view.screenshot()).sum()
    seg.hide(4)
    assert view.mesh.n_cells == 0 and _lit(view.screenshot()).sum() == 0
    seg.show(4)
    assert _lit(view.screenshot()).sum() == full


def test_depth_cue_darkens_and_toggles(view):
    seg = view.seg
    plain = view.screenshot().astype(int)
    view.set_depth_cue(True)
    cued = view.screenshot().astype(int)
    mask = _lit(plain)
    assert cued[mask].sum() < plain[mask].sum()
    view.set_depth_cue(False)
    assert np.array_equal(view.screenshot().astype(int), plain)
    assert np.array_equal(view.mesh.point_data["rgba"], seg.vertex_colors())


def test_apply_saved_view_sets_model_pose(view):
    sv = save_view([1.0, 2.0, 3.0], np.eye(3), 2.0, viewer_position=[0, 0, 0], view_dir=[0, 0, -1])
    view.apply_view(sv, viewer_position=[0, 0, 0], view_dir=[0, 0, -1])
    m = np.asarray(view.actor.user_matrix)
    assert np.allclose(m[:3, 3], [1, 2, 3]) and np.allclose(m[:3, :3], 2 * np.eye(3))
    view.show_brush([32, 32, 40], 5.0, 2)
    view.hide_brush()


def test_view_follows_the_worker_through_the_triple_buffer(view):
    from plantvr.vine.buffers import PaintWorker
    seg = view.seg
    worker = PaintWorker(seg)
    view.follow(worker.buffer)
    worker.submit("paint", seg.vertices[0].astype(float), seg.max_radius, 5)
    worker.join()
    assert view.poll() and not view.poll()
    assert np.array_equal(view.mesh.point_data["rgba"], seg.vertex_colors())
    worker.close()


def test_paint_at_picked_point_uses_model_transform(view):
    seg = view.seg
    view.set_model_pose([10.0, 0.0, 0.0], np.eye(3), 2.0)
    v = seg.vertices[50].astype(float)
    n = view.paint_at(np.array([10.0, 0.0, 0.0]) + 2.0 * v, radius=2.0 * 3.0, label=6)
    assert n > 0 and seg.labels[50] == 6
    from plantvr.vine.index import ball_query_brute
    assert set(np.nonzero(seg.labels == 6)[0]) == set(ball_query_brute(seg.vertices, v, 3.0).tolist())
    view.enable_mouse_painting(radius=1.0, label=2)

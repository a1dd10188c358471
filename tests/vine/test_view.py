"""``View(seg)`` of a segmentation (pyvista, offscreen; its LabelledSurfaceLayer): in-place colour updates, hidden
colours, depth cue, saved views."""
import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from plantvr.documents.labels import Segmentation
from plantvr.view import View
from plantvr.view.vine_layers import LabelledSurfaceLayer
from plantvr.vine.views import save_view


@pytest.fixture
def view(surface):
    seg = Segmentation(surface.vertices, surface.faces, normals=surface.normals)
    v = View(seg, off_screen=True, window_size=(320, 240), background="black")
    assert type(v.layers["surface"]) is LabelledSurfaceLayer
    v.plotter.camera_position = [(32, -80, 120), (32, 32, 32), (0, 0, 1)]
    yield v
    v.close()


def _lit(img):
    return (img.sum(axis=2) > 30)


def test_paint_updates_colours_in_place_without_rebuild(view, tmp_path):
    seg, surf = view.doc, view.layers["surface"]
    before = view.screenshot()
    points_mtime = surf.mesh.GetPoints().GetMTime()
    n_cells = surf.mesh.n_cells
    seg.set_color(3, (255, 0, 255))
    seg.paint(seg.vertices[np.argmax(seg.vertices[:, 2])].astype(float), 40.0, 3)
    after = view.screenshot(tmp_path / "painted.png")
    assert surf.mesh.n_cells == n_cells and surf.mesh.GetPoints().GetMTime() == points_mtime
    assert np.array_equal(surf.mesh.point_data["rgba"], seg.vertex_colors())
    magenta = (after[..., 0] > 150) & (after[..., 1] < 80) & (after[..., 2] > 150)
    assert magenta.sum() > 500 and ((before[..., 0] > 150) & (before[..., 1] < 80)).sum() == 0
    seg.undo()
    assert np.array_equal(surf.mesh.point_data["rgba"], seg.vertex_colors())


def test_hidden_colour_is_not_rendered(view):
    seg, surf = view.doc, view.layers["surface"]
    seg.paint(seg.vertices[0].astype(float), seg.max_radius, 4)        # everything label 4
    full = _lit(view.screenshot()).sum()
    seg.hide(4)
    assert surf.mesh.n_cells == 0 and _lit(view.screenshot()).sum() == 0
    seg.show(4)
    assert _lit(view.screenshot()).sum() == full


def test_depth_cue_darkens_and_toggles(view):
    seg, surf = view.doc, view.layers["surface"]
    plain = view.screenshot().astype(int)
    surf.set_depth_cue(True)
    cued = view.screenshot().astype(int)
    mask = _lit(plain)
    assert cued[mask].sum() < plain[mask].sum()
    surf.set_depth_cue(False)
    assert np.array_equal(view.screenshot().astype(int), plain)
    assert np.array_equal(surf.mesh.point_data["rgba"], seg.vertex_colors())


def test_apply_saved_view_sets_model_pose(view):
    sv = save_view([1.0, 2.0, 3.0], np.eye(3), 2.0, viewer_position=[0, 0, 0], view_dir=[0, 0, -1])
    view.apply_view(sv, viewer_position=[0, 0, 0], view_dir=[0, 0, -1])
    m = np.asarray(view.layers["surface"].actor.user_matrix)
    assert np.allclose(m[:3, 3], [1, 2, 3]) and np.allclose(m[:3, :3], 2 * np.eye(3))
    assert np.allclose(view._brush_actor.user_matrix, m)
    rgb = tuple(int(c) for c in view.doc.colors.rgba[2, :3])
    view.set_brush([32, 32, 40], 5.0, color=rgb)                  # the brush in label 2's colour
    assert np.allclose(view._brush_actor.GetProperty().GetColor(), np.array(rgb) / 255)
    view.set_brush([32, 32, 40], visible=False)


def test_view_follows_the_worker_through_the_triple_buffer(view):
    """A static view of the surface (a document view would redraw on the worker thread's changes) reads the
    labels from the worker's buffer."""
    from plantvr.types import LabelledSurface
    from plantvr.vine.buffers import PaintWorker
    seg = view.doc
    view = View({"surface": LabelledSurface(seg)}, off_screen=True, window_size=(320, 240))
    surf = view.layers["surface"]
    worker = PaintWorker(seg)
    surf.follow(worker.buffer)
    worker.submit("paint", seg.vertices[0].astype(float), seg.max_radius, 5)
    worker.join()
    assert surf.poll() and not surf.poll()
    assert np.array_equal(surf.mesh.point_data["rgba"], seg.vertex_colors())
    worker.close()
    view.close()


def test_paint_at_picked_point_uses_model_transform(view):
    seg, surf = view.doc, view.layers["surface"]
    view.set_model_pose([10.0, 0.0, 0.0], np.eye(3), 2.0)
    v = seg.vertices[50].astype(float)
    n = surf.paint_at(np.array([10.0, 0.0, 0.0]) + 2.0 * v, radius=2.0 * 3.0, label=6)
    assert n > 0 and seg.labels[50] == 6
    from plantvr.vine.index import ball_query_brute
    assert set(np.nonzero(seg.labels == 6)[0]) == set(ball_query_brute(seg.vertices, v, 3.0).tolist())
    surf.enable_mouse_painting(radius=1.0, label=2)

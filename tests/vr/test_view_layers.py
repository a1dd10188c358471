"""The headset draws a document through the View's own layers (issue 30): ``View.snapshot`` hands the render thread
every layer actor with a PolyData that later changes leave alone, and ``StereoRenderer`` copies the actors into its
GL context."""
import numpy as np
import pytest
import pyvista as pv

from plantvr import View, vr
from plantvr.documents.labels import Segmentation
from plantvr.vine.depthcue import coarse_hull, depth_cue_colors
from plantvr.vr import fake_openvr
from plantvr.vr.render import StereoRenderer


def _grow_more(model):
    model.paint_stroke([[1.5, y, 0.5] for y in range(4, 9)], radius=1.5)   # new markers: the tree grows on
    model.step(4)


def _sphere_seg():
    s = pv.Sphere(radius=1.0, theta_resolution=40, phi_resolution=40)
    return Segmentation(np.asarray(s.points), s.faces.reshape(-1, 4)[:, 1:])


def test_snapshot_is_the_views_layers_and_survives_later_changes(model):
    view = View(model, off_screen=True, window_size=(64, 64))
    snap = view.snapshot()
    assert set(snap) == {"tree", "tree.leaves", "markers"}
    tree_poly, tree_actor = snap["tree"]
    assert tree_actor is view.layers["tree"].actor and tree_actor.GetTexture() is not None   # bark texture
    drawn = view.layers["tree"].polys["main"]
    np.testing.assert_array_equal(tree_poly.points, drawn.points)
    before = np.array(tree_poly.points)
    _grow_more(model)                                      # the View re-meshes the tree
    assert view.layers["tree"].polys["main"].n_points > len(before)
    np.testing.assert_array_equal(tree_poly.points, before)   # the snapshot the headset may be drawing: unchanged
    assert view.snapshot()["tree"][0].n_points == view.layers["tree"].polys["main"].n_points
    view.close()


def test_labels_snapshot_copies_the_colours_painted_in_place():
    seg = _sphere_seg()
    view = View(seg, off_screen=True, window_size=(64, 64))
    old = view.snapshot()["surface"][0]
    rgba = np.array(old.point_data["rgba"])
    n = seg.paint(seg.vertices[0], 0.5, 3)
    assert n > 0
    new = view.snapshot()["surface"][0]
    np.testing.assert_array_equal(old.point_data["rgba"], rgba)                # in-place edit did not reach it
    np.testing.assert_array_equal(new.point_data["rgba"], seg.colors.rgba[seg.labels])
    seg.set_visible(3, False)
    assert view.snapshot()["surface"][0].n_cells == len(seg.visible_faces()) < old.n_cells
    view.close()


def test_depth_cue_follows_the_eye_given_to_the_snapshot():
    seg = _sphere_seg()
    view = View(seg, off_screen=True, window_size=(64, 64), depth_cue=True, background=(10, 20, 30))
    near, far = np.array([0.0, 0.0, 3.0]), np.array([0.0, 0.0, -3.0])
    a = np.array(view.snapshot(eye=near)["surface"][0].point_data["rgba"])
    want = depth_cue_colors(seg.colors.rgba[seg.labels], seg.vertices, near, coarse_hull(seg.vertices),
                            background=(10, 20, 30))
    np.testing.assert_array_equal(a, want)                                     # Eq. 5.8 toward the background
    b = np.array(view.snapshot(eye=far)["surface"][0].point_data["rgba"])
    front = seg.vertices[:, 2] > 0.5
    assert a[front, :3].astype(int).sum() > b[front, :3].astype(int).sum()     # the front darkens seen from behind
    view.close()


@pytest.mark.parametrize("kw, word", [({"sides": (2, 8)}, "sides"), ({"sides": (8, 6)}, "sides"),
                                      ({"sides": (6, np.nan)}, "sides"), ({"depth_cue": "yes"}, "depth_cue")])
def test_view_options_are_checked(model, kw, word):
    with pytest.raises(ValueError, match=word):
        View(model, off_screen=True, window_size=(32, 32), **kw)


def test_stereo_renderer_copies_the_layer_actors(model):
    view = View(model, off_screen=True, window_size=(64, 64), ground=False)
    frame = view.snapshot()
    r = StereoRenderer(96, 96, layout="pair")
    try:
        r.set_content(frame)
        for scene in r.scenes:                              # one context per eye: its own mappers and textures
            assert set(scene.content) == set(frame)
            bark = scene.content["tree"]
            assert bark.GetMapper() is not frame["tree"][1].GetMapper()
            assert bark.GetTexture() is not None and bark.GetTexture() is not frame["tree"][1].GetTexture()
            leaf = scene.content["tree.leaves"].GetProperty().GetColor()
            np.testing.assert_allclose(leaf, frame["tree.leaves"][1].GetProperty().GetColor())
        r.set_content({k: v for k, v in frame.items() if k != "markers"})
        assert all(not s.content["markers"].GetVisibility() for s in r.scenes)
    finally:
        r.close()
        view.close()


def test_headset_shows_leaves_with_the_views_colour(model):
    fake_openvr.install()
    try:
        fake_openvr.runtime.render_size = (160, 176)
        h = vr.Headset(model, readback=True)
        h.start()
        try:
            h.wait_content()
            assert {"tree", "tree.leaves", "markers"} <= set(h.content[1])
            img = h.last_images[0].astype(int)
            green = (img[..., 1] > img[..., 0] + 25) & (img[..., 1] > img[..., 2] + 25)
            assert green.sum() > 20                          # leaves (the View's LEAF green) in the left eye
            n_before = h.content[1]["tree"][0].n_points
            _grow_more(model)
            h.wait_content()
            assert h.content[1]["tree"][0].n_points > n_before   # the headset's View followed the growth
        finally:
            h.stop()
    finally:
        fake_openvr.uninstall()

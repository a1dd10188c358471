"""The pyvista view of the Tree Wand model: offscreen pictures, in-place updates of its layers, brush colours."""
import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

import plantvr  # noqa: E402
from plantvr.growth.scenarios import demo_session, run  # noqa: E402


@pytest.fixture(scope="module")
def view():
    m = plantvr.Model(seed=0)
    run(m, demo_session(), 30)
    v = plantvr.View(m, off_screen=True, window_size=(320, 320))
    yield v
    v.close()


def test_screenshot_shows_bark_coloured_tree(view, tmp_path):
    img = view.screenshot(tmp_path / "t.png")
    assert (tmp_path / "t.png").stat().st_size > 1000
    rgb = img[..., :3].astype(int)
    bark = np.abs(rgb - [139, 90, 43]).sum(-1) < 90
    assert bark.sum() > 200  # the trunk and branches are drawn


def test_view_updates_in_place_on_model_change(view):
    mesh = view.layers["tree"].polys["main"]
    n0 = mesh.n_points
    run(view.doc, demo_session(), 5)
    assert view.drawn_version == view.doc.version
    assert view.layers["tree"].polys["main"] is mesh and mesh.n_points >= n0


def test_only_changed_layers_are_redrawn(view):
    view.update()
    view.doc.paint([0, 21, 0], radius=1.0)   # markers change, the tree does not
    assert view.update() == []               # the change event already redrew; nothing is left to draw
    tree = view.layers["tree"].content
    view.doc.paint([0, 22, 0], radius=1.0)
    assert view.layers["tree"].content is tree   # the tree layer kept what it drew: not re-meshed


def test_brush_turns_red_in_prune_mode(view):
    view.set_brush([0, 6, 0], 2.0)
    view.doc.prune_mode = True
    assert np.allclose(view._brush_actor.GetProperty().GetColor(), pv.Color("#e03030").float_rgb)
    view.doc.prune_mode = False


def test_markers_can_be_hidden(view):
    view.doc.add_markers([[0.0, 20.0, 0.0]])
    view.show_markers = False
    view.doc.paint([0, 21, 0], radius=1.0)
    assert not view.layers["markers"].actor.GetVisibility()
    view.show_markers = True
    view.doc.paint([0, 22, 0], radius=1.0)
    assert view.layers["markers"].actor.GetVisibility()


def test_view_meshes_incrementally_and_equals_a_rebuild(view):
    from plantvr.io.tree import tree_geometry
    run(view.doc, demo_session(), 3)
    g = view.layers["tree"].geometry
    full, leaves = tree_geometry(view.doc.snapshot, view.doc.params, lod=(6, 32))
    inc = g.branches.to_branch_mesh()
    assert np.array_equal(inc.faces, full.faces) and np.allclose(inc.vertices, full.vertices)
    assert len(g.leaf_mesh.to_leaf_mesh().faces) == len(leaves.faces)

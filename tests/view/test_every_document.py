"""``plantvr.View(doc)`` renders every document offscreen (issue 21): one small document of each kind, drawn
through its ``scene()``; the picture is not blank and differs from the empty background, and a command on the
document redraws it."""
import os

import numpy as np
import pytest

from plantvr.documents import (CrownDocument, InflorescenceDocument, LSystemDocument, Model, Segmentation,
                               SketchDocument)
from plantvr.documents.forest import ForestDocument
from plantvr.view import View


def _treewand():
    m = Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(8)
    return m, lambda: (m.paint_stroke([[4, y, 0] for y in range(6, 10)], radius=2.0), m.step(6))


def _treesketch():
    d = SketchDocument(activation_threshold=0.0)
    d.begin_stroke([0.0, 1.0, 0.0])
    d.move_stroke([0.0, 6.0, 0.0], 0.0)
    d.end_stroke()
    d.grow(4)
    return d, lambda: (d.begin_stroke([0.0, 6.0, 0.0]), d.move_stroke([4.0, 9.0, 0.0], 0.0), d.end_stroke(),
                       d.grow(4))


def _vine():
    n = 24
    g = np.mgrid[:n, :n, :n].astype(np.float32)
    vol = ((np.sqrt(((g - n / 2) ** 2).sum(0)) < 8) * 200).astype(np.uint8)
    s = Segmentation.from_volume(vol, 100.0)
    return s, lambda: s.paint(s.vertices[0], 20.0, 3)


def _crown(tmp_path):
    d = CrownDocument(base_dir=tmp_path, seed=1)
    d.run("sphere crown 6 0 8 0\npoint_set_gen crown uniform num_points=200\n")
    return d, lambda: d.run("sphere lobe 4 4 10 0\nblend crown lobe body\n")


def _inflorescence():
    d = InflorescenceDocument()
    return d, lambda: d.set_params(time=0.2 if d.time > 0.5 else 0.9)


def _forest():
    d = ForestDocument(n_trees=2, width=20.0, depth=20.0, rounds=1, steps_per_round=3, n_darts=120, compete=False)
    d.grow()
    return d, lambda: d.regrow_tree(0, params={"branch_angle": 30.0})


def _lsystem():
    d = LSystemDocument()
    d.set_step(3)
    return d, lambda: d.set_step(5)


KINDS = {"lsystem": _lsystem, "treewand": _treewand, "treesketch": _treesketch, "vine": _vine, "crown": _crown,
         "inflorescence": _inflorescence, "forest": _forest}


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_view_renders_every_document_offscreen(kind, tmp_path):
    make = KINDS[kind]
    doc, edit = make(tmp_path) if kind == "crown" else make()
    assert doc.KIND == kind or kind == "inflorescence"
    view = View(doc, off_screen=True, window_size=(320, 240))
    try:
        img = view.screenshot()
        bg = img[0, 0]
        drawn = np.any(img != bg, axis=-1)
        assert drawn.mean() > 0.002, f"{kind}: nothing drawn"
        edit()                                     # the view follows the document's change event
        assert view.drawn_version == doc.version
        after = view.screenshot()
        assert after.shape == img.shape and np.any(after != img), f"{kind}: the edit did not redraw"
        if os.environ.get("PLANTVR_VIEW_PNG"):
            from plantvr._fileio import write_png
            write_png(os.path.join(os.environ["PLANTVR_VIEW_PNG"], f"doc_{kind}.png"), after)
    finally:
        view.close()


def test_lsystem_moves_before_f_draw_separate_trees(tmp_path):
    """``f`` and ``@M`` before ``F`` start new trees (parent -1 at a node > 0): the view draws them apart and the
    scene exports, where the mesher accepted only one root before."""
    from plantvr.io.scene import export_scene
    doc = LSystemDocument("Axiom: F(2) f(3) F(2) @M(4, 0, 0) F(1)\nderivation length: 0\nproduction:\nendlsystem\n")
    tree = doc.tree
    assert np.flatnonzero(tree.parent < 0).tolist() == [0, 2, 4]        # three roots: node 0 and after each move
    view = View(doc, off_screen=True, window_size=(320, 240))
    try:
        img = view.screenshot()
        rgb = img[..., :3].astype(int)
        r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
        bark = (r > g + 10) & (g > b) & (r > 40)                        # warm bark texture, not sky, ground, leaves
        cols = np.flatnonzero(bark.any(axis=0))
        trunk = bark[:, cols[0]:cols[0] + 6].any(axis=1)                # the column of the first two trees
        rows = np.flatnonzero(trunk)
        # the f(3) gap: ~3 trunk lengths of 2 units apart in pixels (the texture's dark furrows leave a few rows)
        assert len(np.flatnonzero(np.diff(rows) > 20)) == 1, "the f(3) gap does not split the trunk's column"
        assert np.ptp(cols) > 40, "the tree moved by @M is not drawn beside the others"
        if os.environ.get("PLANTVR_VIEW_PNG"):
            from plantvr._fileio import write_png
            write_png(os.path.join(os.environ["PLANTVR_VIEW_PNG"], "doc_lsystem_forest.png"), img)
    finally:
        view.close()
    import trimesh
    scene = trimesh.load(export_scene(doc, tmp_path / "forest.glb"))
    lo, hi = scene.bounds
    assert hi[1] - lo[1] > 6.9 and hi[0] - lo[0] > 3.9                  # 2 + 3 + 2 up; @M 4 along x


def test_treesketch_view_draws_leaves_that_follow_the_leaf_parameters():
    """Issue 31: the TreeSketch view draws leaves at the bud slots of its snapshot (as Tree Wand's), so its panel's
    leaf sliders change the picture."""
    doc, _ = _treesketch()
    view = View(doc, off_screen=True, window_size=(320, 240))
    try:
        layer = view.layers["tree"]
        assert "leaves" in layer.actors and layer.actors["leaves"].GetVisibility()
        before = view.screenshot()
        doc.set_params(leaf_size=2.0 * doc.leaf_size)
        after = view.screenshot()
        assert (np.abs(after.astype(int) - before).max(axis=-1) > 8).mean() > 0.002, "leaf_size did not redraw"
    finally:
        view.close()

"""The workbench headless (no browser: nbval and scripts): the layout, the regrow, the brushes and the status line
(issue 21, "The experience in JupyterLab"). The live trame path runs in tests/ui/test_jupyterlab.py."""
import io

import ipywidgets as W
import numpy as np
import pytest
import trimesh
from PIL import Image

import plantvr
from plantvr.documents.labels import Segmentation
from plantvr.ui import ColorWheel, GrowthControl, ParameterPanels, Workbench, live_frontend, workbench
from plantvr.view.interaction import BrushInteractor, LabelBrush


def _grown(seed: int = 0) -> plantvr.Model:
    m = plantvr.Model(seed=seed)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(6)
    m.paint([1.5, 7.0, 0.0], radius=1.5)
    m.step(6)
    return m


def _image(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.int16)


@pytest.fixture
def tw():
    m = _grown()
    wb = workbench(m, live=False, window_size=(240, 200))
    yield m, wb
    wb.close()


def test_live_frontend_follows_the_environment(monkeypatch):
    monkeypatch.delenv("JPY_SESSION_NAME", raising=False)
    monkeypatch.delenv("PLANTVR_LIVE", raising=False)
    assert live_frontend() is False                       # nbval / scripts: no Jupyter server session
    monkeypatch.setenv("JPY_SESSION_NAME", "nb.ipynb")
    assert live_frontend() is False                       # not inside a kernel
    monkeypatch.setenv("PLANTVR_LIVE", "1")
    assert live_frontend() is True
    monkeypatch.setenv("PLANTVR_LIVE", "0")
    assert live_frontend() is False


def test_treewand_workbench_layout(tw):
    m, wb = tw
    assert isinstance(wb, (Workbench, W.HBox)) and not wb.live
    assert isinstance(wb.screen, W.Image) and _image(wb.screen.value).shape == (200, 240, 3)
    assert isinstance(wb.panels, ParameterPanels) and wb.panels.triangle is not None
    assert isinstance(wb.growth, GrowthControl) and wb.wheel is None
    assert isinstance(wb.brush, BrushInteractor) and wb.brush.doc is m
    assert f"internodes {m.n_internodes} · markers {m.n_markers}" in wb.status.value


def test_slider_regrows_from_the_sessions_commands(tw):
    m, wb = tw
    img0, steps = _image(wb.screen.value), m.steps_done
    m.tropism_angle = 120.0                     # a Tree form slider: regrow (no kernel loop: at once)
    assert wb.regrows == 1 and m.steps_done == steps
    # the same as a fresh model grown by the same commands with the new parameter
    ref = plantvr.Model(seed=0, tropism_angle=120.0)
    ref.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    ref.step(6)
    ref.paint([1.5, 7.0, 0.0], radius=1.5)
    ref.step(6)
    np.testing.assert_array_equal(m.snapshot.pos, ref.snapshot.pos)
    assert m.state_bytes() == ref.state_bytes()
    assert np.abs(_image(wb.screen.value) - img0).max(axis=-1).mean() > 0.5  # the picture followed
    assert "regrows 1" in wb.status.value and "brush commands 0" in wb.status.value
    # a second regrow re-issues what the first issued: the same commands, the same tree
    m.tropism_angle = 120.0 + 1e-9
    assert wb.regrows == 2 and m.steps_done == steps
    # one undo takes the whole regrow back
    m.tropism_angle = 10.0
    grown = m.state_bytes()
    m.undo()
    assert m.state_bytes() != grown and m.steps_done == steps
    # an appearance parameter only redraws
    m.bark_rate = 3.0
    assert wb.regrows == 3


def test_treewand_brush_paints_and_prunes_through_commands(tw):
    m, wb = tw
    n_markers, n_log = m.n_markers, len(m.log)
    b = wb.brush
    b.press([0.0, 9.0, 0.0])
    for y in (9.5, 10.0, 10.5, 11.0):
        b.drag([0.0, y, 0.0])
    b.release()
    assert m.n_markers > n_markers
    assert [e.command for e in m.log.events[n_log:]].count("paint_stroke") >= 2
    assert f"markers {m.n_markers}" in wb.status.value and "brush commands 0" not in wb.status.value
    wb.prune.value = True                          # the Prune toggle is the document's prune mode
    assert m.prune_mode
    n_int = m.n_internodes
    snap = m.snapshot
    b.press(snap.pos[len(snap.pos) // 2])
    b.release()
    assert m.n_internodes < n_int and f"internodes {m.n_internodes}" in wb.status.value
    m.set_prune_mode(False)
    assert wb.prune.value is False


@pytest.fixture
def vine():
    ico = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    seg = Segmentation(ico.vertices.astype(np.float32), ico.faces)
    wb = workbench(seg, live=False, window_size=(200, 200))
    yield seg, wb
    wb.close()


def test_vine_workbench_paints_the_wheels_label(vine):
    seg, wb = vine
    assert isinstance(wb.wheel, ColorWheel) and isinstance(wb.brush, LabelBrush) and wb.panels is None
    assert wb.growth is None and wb.brush.label == wb.wheel.selected == 1
    img0 = _image(wb.screen.value)
    wb.wheel.selected = 4
    assert wb.brush.label == 4 and "label 4" in wb.status.value
    b = wb.brush
    b.radius = 0.3
    b.press([0.0, 0.0, 1.0])
    for x in (0.2, 0.4, 0.6):
        b.drag([x, 0.0, np.sqrt(1 - x * x)])
    b.release()
    painted = int((seg.labels > 0).sum())
    assert painted > 0 and set(np.unique(seg.labels)) == {0, 4}
    assert [e.command for e in seg.log.events].count("end_stroke") == 1   # one drag = one stroke
    assert f"painted vertices {painted}" in wb.status.value and "strokes 1" in wb.status.value
    assert np.abs(_image(wb.screen.value) - img0).max(axis=-1).mean() > 0.05
    seg.undo()                                       # the stroke is one undo item; the widgets follow
    assert not seg.labels.any() and "painted vertices 0" in wb.status.value
    seg.hide(4)                                      # a hidden label is not painted: said in brush.error
    b.press([0.0, 0.0, 1.0])
    b.release()
    assert not seg.labels.any() and "4" in b.error


def test_label_brush_radius_gesture_and_checks(vine):
    _, wb = vine
    b = wb.brush
    r = b.radius
    assert b.wheel(8) == pytest.approx(2 * r)
    with pytest.raises(ValueError, match="radius"):
        b.radius = -1.0
    with pytest.raises(ValueError, match="label"):
        LabelBrush(wb.view, label=99)


def test_workbench_rejects_bad_input():
    m = plantvr.Model(seed=0)
    with pytest.raises(ValueError, match="doc must be a document"):
        workbench(object())
    with pytest.raises(ValueError, match="live must be"):
        workbench(m, live="yes")
    with pytest.raises(ValueError, match="window_size"):
        workbench(m, live=False, window_size=(10, 10))
    with pytest.raises(ValueError, match="view must be a plantvr.View of a segmentation"):
        LabelBrush(plantvr.View(m, window_size=(64, 64)))


# -- the part's own panel beside the generated one (inflorescence, crown, TreeSketch) -------------------------
def _observers(doc) -> int:
    return sum(len(v) for v in doc._trait_notifiers.get("change", {}).values())


def test_inflorescence_workbench_has_the_floret_editor():
    from plantvr.documents.inflorescence import InflorescenceDocument
    from plantvr.ui import FloretEditor

    doc = InflorescenceDocument(preset="disc floret")
    n_obs = _observers(doc)
    wb = workbench(doc, live=False, window_size=(160, 160))
    try:
        assert isinstance(wb.editor, FloretEditor) and wb.editor.doc is doc
        assert wb.panels is None and wb.brush is None and wb.growth is None   # one panel for one floret
        assert wb.editor in wb.children[1].children and wb.editor.preview.layout.display == "none"
        assert f"{len(doc.floret.faces)} triangles" in wb.status.value
        img0 = _image(wb.screen.value)
        wb.editor.controls["n_fold"].value = 7          # the editor's slider: a document command
        assert doc.n_fold == 7 and f"{len(doc.floret.faces)} triangles" in wb.status.value
        assert np.abs(_image(wb.screen.value) - img0).max(axis=-1).mean() > 0.05   # the view followed
        doc.undo()
        assert wb.editor.controls["n_fold"].value == doc.n_fold != 7
    finally:
        wb.close()
    assert wb.editor.doc is doc and _observers(doc) <= n_obs + 1  # the editor's own lambda stays (no close)


def test_crown_workbench_has_the_implicit_panel():
    from plantvr.documents.crown import CrownDocument
    from plantvr.ui.implicit_panel import ImplicitPanel

    doc = CrownDocument(seed=0)
    n_obs = _observers(doc)
    wb = workbench(doc, live=False, window_size=(160, 160))
    assert isinstance(wb.editor, ImplicitPanel) and wb.panels is None and wb.editor.doc is doc
    assert "surfaces 0" in wb.status.value
    img0 = _image(wb.screen.value)
    assert wb.editor.run("sphere crown 20 0 14 0\npoint_set_gen crown uniform num_points=200")  # the Run button
    assert "surfaces 1 · points 200" in wb.status.value and "200 points" in wb.editor.status.value
    assert np.abs(_image(wb.screen.value) - img0).max(axis=-1).mean() > 0.05
    wb.close()
    assert _observers(doc) == n_obs


def test_treesketch_workbench_has_the_architecture_panel():
    from plantvr.documents.treesketch import SketchDocument

    doc = SketchDocument(seed=1)
    n_obs = _observers(doc)
    wb = workbench(doc, live=False, window_size=(160, 160))
    assert isinstance(wb.editor, plantvr.ui.ArchitecturePanel) and isinstance(wb.panels, ParameterPanels)
    doc.begin_stroke([0.0, 1.0, 0.0])
    doc.move_stroke([0.0, 6.0, 0.0], radius=0.0)
    doc.grow(4)
    doc.end_stroke()
    assert f"internodes {doc.n_internodes}" in wb.status.value and doc.n_internodes > 1
    wb.editor.controls["apical_dominance"].value = 0.3     # the panel's slider: set_params
    assert doc.apical_dominance == pytest.approx(0.3)
    assert wb.panels.controls["apical_dominance"].value == pytest.approx(0.3)   # the generated panel followed
    wb.close()
    assert _observers(doc) == n_obs


def test_forest_workbench_status():
    from plantvr.documents.forest import ForestDocument

    doc = ForestDocument(n_trees=2)
    wb = workbench(doc, live=False, window_size=(96, 96))
    assert wb.editor is None and "not grown" in wb.status.value
    wb.close()


def test_close_when_headless_keeps_live_views(monkeypatch, tw):
    from plantvr.ui import close_when_headless

    _m, wb = tw
    monkeypatch.setenv("PLANTVR_LIVE", "1")               # JupyterLab: Run All keeps the view
    assert close_when_headless(wb) is False and not wb._closed
    monkeypatch.setenv("PLANTVR_LIVE", "0")               # nbval / CI: closed, render window freed
    assert close_when_headless(wb) is True and wb._closed and wb.view.plotter.render_window is None
    with pytest.raises(ValueError, match="objects with close"):
        close_when_headless(3)


def test_treesketch_slider_regrows_the_same_tree_for_the_same_parameters():
    from plantvr.documents.treesketch import SketchDocument

    doc = SketchDocument(activation_threshold=0.0)
    doc.begin_stroke([0.0, 1.0, 0.0])
    for y in np.linspace(1.0, 7.0, 12):
        doc.move_stroke([0.3 * y, y, 0.0], 1.5)                 # a brush stroke: seeded random points
    doc.end_stroke()
    doc.grow(8)
    wb = workbench(doc, live=False, window_size=(96, 96))
    try:
        first = doc.tree.arrays()
        wb.panels.controls["branch_angle"].value = 30.0
        wb.flush()
        assert wb.regrows == 1
        at30 = doc.state_bytes()
        wb.panels.controls["branch_angle"].value = 45.0          # back: the same tree as before the first move
        wb.flush()
        again = doc.tree.arrays()
        assert wb.regrows == 2 and all(np.array_equal(first[k], again[k]) for k in first)
        doc.undo()                  # one undo item per regrow, joined to its parameter change: both come back
        assert doc.branch_angle == 30.0 and doc.state_bytes() == at30
        assert [e.command for e in doc.log.events[-3:]] == ["set_params", "regrow", "undo"]
    finally:
        wb.close()


def _camera(wb) -> np.ndarray:
    return np.array([tuple(v) for v in wb.view.plotter.camera_position], float)


def test_undo_of_a_regrow_restores_the_camera_fit_and_the_picture(tw):
    """Issue 31: a regrow fits the camera to the new size; undoing it fits it back (same picture, same camera),
    redoing it fits it again; an undo of a brush command leaves the camera alone."""
    m, wb = tw
    cam0, img0 = _camera(wb), wb.view.screenshot()
    m.tropism_angle = 120.0                               # regrow: a wider tree, the camera backs off
    cam1, img1 = _camera(wb), wb.view.screenshot()
    assert not np.allclose(cam1, cam0)
    m.undo()
    assert m.tropism_angle == 0.0
    np.testing.assert_allclose(_camera(wb), cam0, atol=1e-9)
    np.testing.assert_array_equal(wb.view.screenshot(), img0)
    m.redo()
    np.testing.assert_allclose(_camera(wb), cam1, atol=1e-9)
    np.testing.assert_array_equal(wb.view.screenshot(), img1)
    wb.view.plotter.camera.zoom(1.5)                       # the user zooms in, paints, undoes the stroke
    zoomed = _camera(wb)
    m.paint([1.0, 6.0, 0.0], radius=1.0)
    m.undo()
    np.testing.assert_allclose(_camera(wb), zoomed, atol=1e-9)


def test_forest_regrow_is_one_undo_item_with_its_parameter_change():
    """Issue 31: dragging a forest setting grows the forest again; one undo takes back both the setting and the
    forest (as a Tree Wand regrow does), and the log still replays to the same document."""
    from plantvr.documents.forest import ForestDocument

    settings = dict(n_trees=2, width=20.0, depth=20.0, min_dist=6.0, rounds=1, steps_per_round=2, crown_height=4.0,
                    crown_radius=3.0, seed=4)
    doc = ForestDocument(**settings)
    doc.grow(params={"activation_threshold": 0.0, "length_mode": "constant"})
    wb = workbench(doc, live=False, window_size=(96, 96))
    try:
        grown, img0 = doc.state_bytes(), _image(wb.screen.value)
        wb.panels.controls["n_trees"].value = 4
        assert wb.regrows == 1 and len(doc.forest.trees) > 2
        assert np.abs(_image(wb.screen.value) - img0).max(axis=-1).mean() > 0
        doc.undo()
        assert doc.n_trees == 2 and doc.state_bytes() == grown
        np.testing.assert_array_equal(_image(wb.view.png()), img0)
        doc.redo()
        replayed = ForestDocument(**settings)
        replayed.replay(doc.log)
        assert replayed.state_bytes() == doc.state_bytes() and doc.n_trees == 4
    finally:
        wb.close()

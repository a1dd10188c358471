"""Floret editor widget, a view of an inflorescence document, driven from code: document settings -> core floret ->
mesh invariants, preview, export (issues 9, 21)."""
import io
import os

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from plantvr.documents.inflorescence import PRESETS
from plantvr.flowers.composer import Canopy
from plantvr.flowers.floret import Corolla, build_floret, eval_surface, petal_net, read_obj_sequence
from plantvr.ui.floret_editor import FloretEditor, preview_png


def _editor(**kw):
    return FloretEditor(live_preview=False, **kw)


def _maps_onto_itself(x, angle, tol=1e-9):
    rot = Rotation.from_euler("z", angle).apply(x)
    d, _ = cKDTree(x).query(rot)
    return float(d.max()) <= tol * max(1.0, float(np.ptp(x, axis=0).max()))


def _img(png):
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def test_default_floret_is_valid_with_one_topology_and_n_fold_symmetry():
    ed = _editor()
    fm = ed.doc.floret
    assert ed.doc.message == ""
    assert fm.frames.shape == (ed.doc.n_frames, fm.frames.shape[1], 3) and fm.faces.dtype == np.int64
    assert fm.faces.min() >= 0 and fm.faces.max() < fm.frames.shape[1]
    assert len(fm.fixed) > 0 and np.all(fm.frames[:, fm.fixed, 2] == pytest.approx(0.0, abs=1e-12))
    for X in fm.frames:                                      # every frame n-fold symmetric about the axis
        assert _maps_onto_itself(X, 2 * np.pi / ed.doc.n_fold)
        a, b, c = X[fm.faces[:, 0]], X[fm.faces[:, 1]], X[fm.faces[:, 2]]
        assert np.linalg.norm(np.cross(b - a, c - a), axis=1).min() > 0     # no degenerate triangle


@pytest.mark.parametrize("n_fold", [3, 6])
def test_traits_drive_the_core_object(n_fold):
    ed = _editor()
    ed.doc.set_params(n_fold=n_fold, nu=7, nv=8, fused_rows=2, n_frames=5)     # several settings, one rebuild
    assert len(ed.doc.history.undo_stack) == 1
    fm = ed.doc.floret
    assert fm.frames.shape[0] == 5
    assert _maps_onto_itself(fm.frames[-1], 2 * np.pi / n_fold)
    assert not _maps_onto_itself(fm.frames[-1], 2 * np.pi / (n_fold + 1), tol=1e-6)
    # same floret as the core call with the editor's corollas
    ref = build_floret(ed.doc.corollas(), n_frames=5, growth=ed.doc.growth_knots(), lam=ed.doc.lam, eta=ed.doc.eta)
    np.testing.assert_array_equal(ref.faces, fm.faces)
    np.testing.assert_allclose(ref.frames, fm.frames, atol=0)
    assert all(c.petal.shape == (7, 8, 3) and c.n_fold == n_fold and c.fused_rows == 2 for c in ed.doc.corollas())


def test_welding_joins_fused_seams_and_can_be_turned_off():
    ed = _editor()
    ed.doc.fused_rows = 3
    welded = ed.doc.floret.frames.shape[1]
    ed.doc.weld = False
    sheets = ed.doc.floret.frames.shape[1]
    assert welded < sheets                                   # fused seams and the base are shared vertices
    assert sheets % ed.doc.n_fold == 0                           # unwelded: n identical petal sheets
    ed.doc.weld = True
    assert ed.doc.floret.frames.shape[1] == welded


def test_key_poses_are_the_first_middle_and_last_frames():
    ed = _editor()
    ed.doc.set_params(n_poses=3, growth="linear", n_frames=3, fused_rows=0, weld=False)
    ed.doc.set_pose(1, opening_deg=30.0, length=0.6)
    ed.pose_index = 2
    ed.controls["opening_deg"].value = 80.0                 # the pose sliders edit the selected pose
    assert ed.doc.poses[2]["opening_deg"] == 80.0 and ed.doc.poses[1]["opening_deg"] == 30.0
    fm = ed.doc.floret
    uv_count = fm.frames.shape[1] // ed.doc.n_fold
    for k, pose in enumerate(ed.doc.poses):                     # frame k of 3 with linear growth = pose k exactly
        d = ed.doc
        net = petal_net(nu=d.nu, nv=d.nv, base_radius=d.base_radius, base_width=d.base_width, **pose)
        petal0 = fm.frames[k, :uv_count]
        on_surface = eval_surface(net, *_uv_of(ed))
        np.testing.assert_allclose(petal0, on_surface, atol=1e-9)
    ed.pose_index = 1
    assert ed.controls["opening_deg"].value == 30.0 and ed.controls["length"].value == 0.6   # selecting loads it


def _uv_of(ed):
    from plantvr.flowers.floret import polygonize_uv
    uv, _, _ = polygonize_uv(ed.doc.lam, ed.doc.eta)
    return uv[:, 0], uv[:, 1]


def test_time_warp_growth_and_scrub():
    ed = _editor()
    ed.doc.set_params(growth="power", warp=2.0, n_frames=5)
    k = np.linspace(0, 1, 65)
    ref = build_floret(ed.doc.corollas(), n_frames=5, growth=np.column_stack([k, k ** 2]), lam=ed.doc.lam,
                       eta=ed.doc.eta)
    np.testing.assert_allclose(ed.doc.floret.frames, ref.frames, atol=1e-12)
    # a slow start: the second frame has moved less than a quarter of the way (t**2 at t = 1/4 is 1/16)
    d = np.linalg.norm(ed.doc.floret.frames - ed.doc.floret.frames[0], axis=2).max(axis=1)
    assert d[1] < 0.25 * d[-1]
    ed.doc.time = 0.0
    np.testing.assert_array_equal(ed.doc.current_frame(), ed.doc.floret.frames[0])
    ed.doc.time = 0.5
    np.testing.assert_array_equal(ed.doc.current_frame(), ed.doc.floret.frames[2])
    ed.doc.time = 0.625
    np.testing.assert_allclose(ed.doc.current_frame(), 0.5 * (ed.doc.floret.frames[2] + ed.doc.floret.frames[3]))


def test_bad_combination_shows_message_and_keeps_last_valid_floret():
    ed = _editor()
    good = ed.doc.floret
    ed.doc.fused_rows = 12                                       # more fused rows than the 6 control rows
    assert "fused rows (12)" in ed.doc.message and "nv = 6" in ed.doc.message
    assert ed.doc.floret is good and ed.doc.fused_rows == 12          # kept, with the message
    assert "floret-error" in ed.message_box.value
    ed.doc.fused_rows = 0
    ed.doc.n_fold = 1
    ed.doc.fused_rows = 2                                        # fusion needs 2 or more petals
    assert "at least 2 petals" in ed.doc.message and ed.doc.floret.frames.shape[1] > 0
    ed.doc.fused_rows = 0
    assert ed.doc.message == "" and ed.message_box.value == ""


def test_out_of_range_from_code_raises_and_changes_nothing():
    ed = _editor()
    before = (ed.doc.n_fold, ed.doc.version, ed.doc.floret)
    with pytest.raises(ValueError, match=r"n_fold must be an integer in \[1, 12\], got 0"):
        ed.doc.n_fold = 0
    with pytest.raises(ValueError, match="opening_deg"):
        ed.doc.open_opening_deg = 400.0
    with pytest.raises(ValueError, match="opening_deg"):
        ed.doc.set_pose(2, opening_deg=400.0)
    with pytest.raises(ValueError, match="growth must be one of"):
        ed.doc.growth = "cubic"
    with pytest.raises(ValueError, match="pose_index must be 0 .bud. or 2 .open."):
        ed.pose_index = 1
    with pytest.raises(ValueError, match="pose settings"):
        ed.doc.set_pose(0, colour=1.0)
    assert (ed.doc.n_fold, ed.doc.version, ed.doc.floret) == before


def test_sliders_are_linked_to_the_traits():
    ed = _editor()
    ed.controls["n_fold"].value = 4
    assert ed.doc.n_fold == 4 and _maps_onto_itself(ed.doc.floret.frames[-1], np.pi / 2)
    ed.pose_select.value = 0
    assert ed.controls["opening_deg"].value == ed.doc.poses[0]["opening_deg"]
    ed.controls["opening_deg"].value = 12.0
    assert ed.doc.poses[0]["opening_deg"] == 12.0
    ed.doc.n_poses = 3
    assert [o[1] for o in ed.pose_select.options] == [0, 1, 2] and ed.pose_index == 0
    ed.preset.value = "ray floret"
    assert ed.doc.n_fold == 1 and ed.doc.floret.frames.shape[1] > 0 and ed.doc.n_poses == 2


def test_every_preset_builds():
    ed = _editor()
    for name in PRESETS:
        ed.doc.load_preset(name)
        assert ed.doc.message == "", name
        ft = ed.doc.floret_type()                               # usable by the composer
        can = Canopy([ft], [0, 0], [[0, 0, 0], [5, 0, 0]], [[0, 0, 1]] * 2, [[1, 0, 0]] * 2, [1.0, 1.0])
        assert can.voff[-1] == 2 * ft.frames.shape[1]
    ed.doc.load_preset("disc floret")                            # a preset sets every setting: no leftovers
    np.testing.assert_array_equal(ed.doc.floret.frames, _editor().doc.floret.frames)


def test_export_obj_sequence_round_trip(tmp_path):
    ed = _editor()
    paths = ed.export_obj(tmp_path / "obj", prefix="floret")
    assert len(paths) == ed.doc.n_frames
    faces, frames, fixed = read_obj_sequence(str(tmp_path / "obj"), prefix="floret")
    np.testing.assert_array_equal(faces, ed.doc.floret.faces)
    np.testing.assert_array_equal(frames, ed.doc.floret.frames)
    np.testing.assert_array_equal(fixed, ed.doc.floret.fixed)
    ed.folder.value = str(tmp_path / "button")
    ed.export_button.click()
    assert len(os.listdir(tmp_path / "button")) == ed.doc.n_frames + 1 and "wrote" in ed.export_status.value


def test_preview_png_shows_the_floret_and_follows_time_and_views(tmp_path):
    ed = FloretEditor(preview_size=(240, 240))
    open_png = ed.preview.value
    assert open_png[:4] == b"\x89PNG"
    img = _img(open_png)
    assert img.shape == (240, 240, 3)
    petal = (img[..., 0] > img[..., 2] + 40) & (img[..., 0] > 80)   # orange petals on white
    assert 0.03 < petal.mean() < 0.7
    ed.doc.time = 0.0                                            # the bud is smaller than the open floret
    bud = _img(ed.preview.value)
    assert ((bud[..., 0] > bud[..., 2] + 40) & (bud[..., 0] > 80)).mean() < 0.5 * petal.mean()
    (tmp_path / "floret_open.png").write_bytes(open_png)
    # optional view: a pyvista plotter follows later changes
    import pyvista as pv
    pl = pv.Plotter(off_screen=True, window_size=(200, 200))
    mesh = ed.show_in(pl)
    np.testing.assert_allclose(mesh.points, ed.doc.floret.frame_at(0.0))
    ed.doc.n_fold = 7
    assert mesh.n_points == ed.doc.floret.frames.shape[1] and mesh.n_cells == len(ed.doc.floret.faces)
    pl.close()
    with pytest.raises(ValueError, match="Plotter"):
        ed.show_in(object())
    with pytest.raises(ValueError, match="t must be in"):
        preview_png(ed.doc.floret, 1.5)


def test_core_corolla_matches_editor_topology():
    ed = _editor()
    c = ed.doc.corollas()
    assert len(c) == 2 and all(isinstance(x, Corolla) for x in c)


def test_editor_is_a_view_that_follows_its_document():
    from plantvr.documents.inflorescence import InflorescenceDocument

    doc = InflorescenceDocument(preset="ray floret")
    ed = FloretEditor(doc, live_preview=False)
    assert ed.doc is doc and ed.controls["n_fold"].value == 1
    doc.set_params(n_fold=4, fused_rows=0)                   # code, another view or a replay edits the document
    assert ed.controls["n_fold"].value == 4 and "triangles" in ed.info.value
    ed.controls["nu"].value = 7                              # a slider is a logged document command
    assert doc.nu == 7 and doc.log.events[-1].kwargs == {"nu": 7}
    doc.undo()
    assert ed.controls["nu"].value == 5 and doc.nu == 5
    doc.set_pose(2, curl_deg=-20.0)
    assert ed.pose_index == 2 and ed.controls["curl_deg"].value == -20.0
    with pytest.raises(ValueError, match="InflorescenceDocument"):
        FloretEditor(object())

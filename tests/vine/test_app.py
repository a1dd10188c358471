"""``plantvr segment`` (issue 14): sources, the scripted demo, the headless ``--out`` path and the review app's
commands without a browser."""
import numpy as np
import pytest

from plantvr.documents.labels import Segmentation
from plantvr.documents.labels_app import paint_demo
from plantvr.io.source import open_source
from plantvr.vine.volume import save_volume
from plantvr.io import labels as io_labels


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
    io_labels.export_ply(src.seg, tmp_path / "m.ply")
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

    from plantvr.view.vine_cli import main_segment
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
    assert np.array_equal(app.surface.mesh.point_data["rgba"], app.proxy.vertex_colors())
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
    assert app.surface.mesh.n_points == app.proxy.n_vertices
    with pytest.raises(ValueError, match="mode"):
        VineReviewApp(seg, mode="webgpu")
    with pytest.raises(ValueError, match="colour_updates"):
        VineReviewApp(seg, colour_updates="mesh")
    with pytest.raises(ValueError, match="give a Segmentation"):
        VineReviewApp()
    app.view.close()


def _slices(svg):
    import xml.etree.ElementTree as ET
    root = ET.fromstring(svg)
    ns = "{http://www.w3.org/2000/svg}"
    return root, [g for g in root.iter(ns + "g") if "wheel-slice" in g.get("class", "")], ns


def test_wheel_svg_slices_selection_raised_and_hidden_lines():
    from plantvr.view.vine_app import WHEEL_RADIUS, wheel_geometry, wheel_svg
    from plantvr.vine.colors import DEFAULT_PALETTE
    n = len(DEFAULT_PALETTE)
    visible = np.ones(n, bool)
    visible[[2, 7]] = False
    root, gs, ns = _slices(wheel_svg(DEFAULT_PALETTE, visible, 7))
    lift, cen = wheel_geometry(WHEEL_RADIUS)
    assert float(root.get("width")) == round(2 * cen) and len(gs) == n
    assert [int(g.get("data-index")) for g in gs] == [k for k in range(n) if k != 7] + [7]   # selection on top
    for g in gs:
        k = int(g.get("data-index"))
        path = g.find(ns + "path")
        assert path.get("fill") == "rgb({},{},{})".format(*DEFAULT_PALETTE[k])
        assert ("selected" in g.get("class")) == (k == 7) and ("hidden" in g.get("class")) == (k in (2, 7))
        assert len(g.findall(ns + "line")) == (5 if k in (2, 7) else 0)               # §2.6 radial lines
        # the arc ends lie on the slice's boundary angles, at the raised radius for the selection only
        tok = path.get("d").split()
        x0, y0, x1, y1 = float(tok[4]), float(tok[5]), float(tok[-3]), float(tok[-2])
        r = WHEEL_RADIUS + (lift if k == 7 else 0.0)
        for (x, y), a in (((x0, y0), k * 2 * np.pi / n), ((x1, y1), (k + 1) * 2 * np.pi / n)):
            assert np.allclose([x, y], [cen + r * np.cos(a), cen - r * np.sin(a)], atol=0.01)
        for line in g.findall(ns + "line"):                                             # lines stay in the slice
            ang = np.arctan2(-(float(line.get("y2")) - cen), float(line.get("x2")) - cen) % (2 * np.pi)
            assert k * 2 * np.pi / n < ang < (k + 1) * 2 * np.pi / n
    _, one, _ = _slices(wheel_svg([[10, 20, 30]], [True], 0))                           # a one-colour table
    assert len(one) == 1
    with pytest.raises(ValueError, match="selected must be an integer in"):
        wheel_svg(DEFAULT_PALETTE, visible, n)
    with pytest.raises(ValueError, match="visible must have shape"):
        wheel_svg(DEFAULT_PALETTE, visible[:3], 0)
    with pytest.raises(ValueError, match="rgba must have shape"):
        wheel_svg(np.zeros((0, 3)), [], 0)
    with pytest.raises(ValueError, match="radius must be in"):
        wheel_geometry(4)
    with pytest.raises(ValueError, match=r"rgba must be in \[0, 255\]"):
        wheel_svg([[300, 0, 0]], [True], 0)


def test_review_app_wheel_click_follows_slice_at(surface):
    pytest.importorskip("trame_vtk")
    from plantvr.ui.wheel import slice_at
    from plantvr.view.vine_app import WHEEL_RADIUS, VineReviewApp, wheel_geometry
    seg = Segmentation(surface.vertices, surface.faces)
    app = VineReviewApp(seg, target_faces=4000)
    n = len(seg.colors)
    lift, cen = wheel_geometry(WHEEL_RADIUS)
    rng = np.random.default_rng(0)
    for x, y in rng.uniform(0, 2 * cen, (200, 2)):
        before = int(app.state.label)
        u, v = (x - cen) / WHEEL_RADIUS, (cen - y) / WHEEL_RADIUS
        k = app.wheel_click(x, y)
        if np.hypot(u, v) > (WHEEL_RADIUS + lift) / WHEEL_RADIUS:
            assert k is None and app.state.label == before                 # outside the wheel: nothing
        else:
            assert k == slice_at(u, v, n, last=before) == app.state.label  # dead zone keeps the selection
            assert f'class="wheel-slice selected" data-index="{k}"' in app.state.wheel
    a = 5.5 * 2 * np.pi / n
    x, y = cen + 0.6 * WHEEL_RADIUS * np.cos(a), cen - 0.6 * WHEEL_RADIUS * np.sin(a)
    app.select(2)
    assert app.wheel_click(x, y, shift=True) == 5                            # shift-click: hide slice 5 ...
    assert app.state.label == 2 and not seg.colors.visible[5] and app.state.hidden == [5]
    assert 'class="wheel-slice hidden" data-index="5"' in app.state.wheel
    assert app.wheel_click(cen, cen, shift=True) == 2                        # centre: the selected one
    assert app.state.hidden == [2, 5] and 'class="wheel-slice selected hidden" data-index="2"' in app.state.wheel
    app.toggle_selected()
    app.wheel_click(x, y, shift=True)
    assert seg.colors.visible.all() and app.state.hidden == [] and "hidden" not in app.state.wheel
    seg.set_color(4, (1, 2, 3))                         # a recolour from code reaches the wheel with the next command
    app.undo()
    assert "rgb(1,2,3)" in app.state.wheel
    with pytest.raises(ValueError, match="label must be an integer in"):
        app.select(n)
    with pytest.raises(ValueError, match=r"x must be in \["):
        app.wheel_click(float("nan"), 0)
    app.stop()

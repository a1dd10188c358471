"""Brush painting and pruning in the pyvista view, driven headlessly (simulated picks and VTK events); every
command lands in the document's log."""
import math

import numpy as np
import pytest

import plantvr
from plantvr.view import View
from plantvr.view.interaction import BrushInteractor

from ._views import grown_model_view


@pytest.fixture(scope="module")
def grown():
    m, v = grown_model_view()
    yield m, v
    v.close()


def _seg_dist(p, a, b):
    ab = b - a
    t = np.clip(((p - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-12), 0, 1)
    return np.linalg.norm(a + t[:, None] * ab - p, axis=1)


def test_pick_on_branch_surface_and_free_space_depth(grown):
    m, v = grown
    b = BrushInteractor(v)
    s = m.snapshot
    kids = np.flatnonzero(s.parent >= 0)
    node = kids[len(kids) // 2]
    xy = b.world_to_display(s.pos[node])
    p = b.world_point(*xy)
    # the picked point lies on some internode's tube and projects back under the mouse
    d = _seg_dist(p, s.pos[s.parent[kids]], s.pos[kids]) - s.radius[kids]
    assert d.min() < 0.05
    np.testing.assert_allclose(b.world_to_display(p), xy, atol=1.0)
    # in free space the brush sits on the ray at the chosen depth
    b.depth = 7.0
    q = b.world_point(3, 3)
    cam = np.array(v.plotter.camera.position)
    assert np.linalg.norm(q - cam) == pytest.approx(7.0)
    np.testing.assert_allclose(b.world_to_display(q), [3, 3], atol=1.0)
    b.close()


def test_paint_drag_goes_through_model_commands():
    m = plantvr.Model(seed=0)
    v = View(m, window_size=(200, 150))
    b = BrushInteractor(v, spacing=0.5)
    n_ev = len(m.log)
    b.press([0, 3, 0])
    for y in np.linspace(3, 6, 31):
        b.drag([0, y, 0])
    b.release()
    stamps = [e for e in m.log.events[n_ev:] if e.command == "paint_stroke"]
    assert 6 <= len(stamps) <= 8  # 3 m at one stamp per 0.5 m radius spacing (+ the press)
    assert m.n_markers > 0 and m.n_markers == len(m.snapshot.markers)
    assert np.all(np.abs(m.snapshot.markers[:, 0]) <= m.brush_radius + 1e-9)
    b.drag([0, 9, 0])  # not pressed: hover only, no paint
    assert len([e for e in m.log.events[n_ev:] if e.command == "paint_stroke"]) == len(stamps)
    np.testing.assert_allclose(v.brush_center, [0, 9, 0])
    v.close()


def test_tw_v17b_prune_preview_equals_removed_and_is_drawn_red(grown):
    m0, _ = grown
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(15)
    v = View(m, window_size=(400, 300))
    b = BrushInteractor(v)
    b.toggle_prune()
    assert m.prune_mode
    s = m.snapshot
    c = 0.5 * (s.pos[4] + s.pos[s.parent[4]])
    m.brush_radius = 0.3
    b.hover(c)
    preview = b.preview.copy()
    assert len(preview) > 0
    actor = v.plotter.actors["prune_preview"]
    assert actor.GetVisibility() and actor.GetProperty().GetColor() == pytest.approx((224 / 255, 48 / 255, 48 / 255))
    img = v.screenshot()
    red = (img[..., 0] > 180) & (img[..., 1] < 90) & (img[..., 2] < 90)
    assert red.sum() > 20
    before = m.n_internodes
    removed = b.press(c)
    assert m.n_internodes == before - len(preview)
    assert removed > 0
    b.toggle_prune()
    assert not actor.GetVisibility()
    v.close()


def test_tw_v22_thumb_circle_doubles_radius_and_wheel_clamps():
    m = plantvr.Model(seed=0)
    v = View(m, window_size=(200, 150))
    b = BrushInteractor(v)
    r0 = m.brush_radius
    for _ in range(36):  # one clockwise circle in 10° increments
        b.thumb(math.radians(10))
    assert m.brush_radius == pytest.approx(2 * r0, rel=0.01)
    b.wheel(-8)
    assert m.brush_radius == pytest.approx(r0, rel=0.01)
    b.wheel(-1000)
    assert m.brush_radius == 0.05  # clamped to the parameter's range
    v.close()


def test_vtk_mouse_events_drive_the_brush(grown):
    m, v = grown
    b = BrushInteractor(v)
    b.attach()
    iren = v.plotter.iren.interactor
    n_ev, r0 = len(m.log), m.brush_radius
    iren.SetEventInformation(150, 120, 0, 0)
    iren.InvokeEvent("MouseMoveEvent")
    assert b.center is not None and len(m.log) == n_ev  # hover only
    iren.InvokeEvent("LeftButtonPressEvent")
    iren.SetEventInformation(190, 140, 0, 0)
    iren.InvokeEvent("MouseMoveEvent")
    iren.InvokeEvent("LeftButtonReleaseEvent")
    assert [e.command for e in m.log.events[n_ev:]][:1] == ["paint_stroke"]
    iren.InvokeEvent("MouseWheelForwardEvent")
    assert m.brush_radius == pytest.approx(r0 * 2 ** (1 / 8))
    iren.SetKeySym("m")
    iren.InvokeEvent("KeyPressEvent")
    assert not v.plotter.actors["markers"].GetVisibility() and not v.show_markers
    b.set_markers_visible(True)
    b.detach()
    m.brush_radius = r0
    b.close()


def test_controller_emulator_session_replays_from_the_document_log():
    """The emulator's events become document commands; the document's log replays the session identically,
    also after a round trip through its text form."""
    from plantvr.commandlog import CommandLog

    m = plantvr.Model(seed=3)
    v = View(m, window_size=(200, 150))
    b = BrushInteractor(v)
    b.handle({"type": "thumb", "dphi": math.pi})
    for i, y in enumerate(np.linspace(2, 7, 12)):
        b.handle({"type": "pose", "pos": [0.0, y, 0.0], "trigger": 1.0 if i else 0.5})
    b.handle({"type": "pose", "pos": [0.0, 7.0, 0.0], "trigger": 0.0})
    m.step(5)
    b.handle({"type": "toggle_prune"})
    b.handle({"type": "pose", "pos": m.snapshot.pos[3].tolist(), "trigger": 1.0})
    b.close()
    v.close()
    commands = [e.command for e in m.log.events]
    assert {"paint_stroke", "set_params", "step", "set_prune_mode", "prune"} <= set(commands)
    for log in (m.log, CommandLog.from_text(m.log.to_text(), commands=m.COMMANDS, document=m.KIND)):
        fresh = plantvr.Model(seed=3)
        fresh.replay(log)
        np.testing.assert_array_equal(fresh.snapshot.pos, m.snapshot.pos)
        np.testing.assert_array_equal(fresh.snapshot.markers, m.snapshot.markers)
        assert fresh.state_bytes() == m.state_bytes()
    with pytest.raises(ValueError, match="event type must be one of"):
        b.handle({"type": "jump"})
    with pytest.raises(ValueError, match=r"trigger must be in \[0.0, 1.0\]"):
        b.handle({"type": "pose", "pos": [0, 0, 0], "trigger": 2})


def test_input_events_are_checked_at_the_door(fuzz):
    """Browser/headset events with missing fields, NaN, or non-bool flags are clear errors that change nothing
    (issue 20)."""
    m = plantvr.Model(seed=0)
    v = plantvr.View(m, off_screen=True, window_size=(64, 64))
    b = BrushInteractor(v)
    try:
        for ev, param in [({"type": "pose"}, "pos"), ({"type": "thumb"}, "dphi"),
                          ({"type": "markers", "visible": "no"}, "visible"), ({"type": "markers"}, "visible"),
                          ({"type": "pose", "pos": [math.nan, 0, 0]}, "pos"),
                          ({"type": "pose", "pos": [1e300, 0, 0], "trigger": 1.0}, "pos"),
                          ({"type": "thumb", "dphi": math.inf}, "dphi"), ("pose", "type"), (None, "type")]:
            assert isinstance(fuzz.call("BrushInteractor.handle", b.handle, ev, param=param), ValueError)
        for x, y in [(math.nan, 0), (0, math.inf), ("a", 0), (1e300, 0)]:
            assert isinstance(fuzz.call("BrushInteractor.world_point", b.world_point, x, y, param=("x", "y")),
                              ValueError)
        assert isinstance(fuzz.call("BrushInteractor.set_markers_visible", b.set_markers_visible, "no",
                                    param="visible"), ValueError)
        assert m.n_markers == 0 and m.log.events == []
        with pytest.raises(ValueError, match="view must be a plantvr.View of a document"):
            BrushInteractor(View({}, window_size=(32, 32)))
    finally:
        b.close()
        v.close()

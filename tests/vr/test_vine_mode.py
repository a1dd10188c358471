"""ViNE labels in the headset (spec 000_vine §2.1–2.6, §4.2–4.3): the ViNE control map, then the bridge on the fake
runtime."""
import math
import time

import numpy as np
import pytest
import trimesh

from plantvr import vr
from plantvr.documents.labels import Segmentation
from plantvr.vr import (
    CONTROL_MAPS,
    TIP_OFFSET,
    Command,
    ControllerState,
    Controls,
    InputFrame,
    SceneTransform,
    issue,
    wheel_label,
)

VINE = CONTROL_MAPS["vine"]


def VineControls(*, n_labels, label=None, brush_radius=1.0, max_radius=1e6, scene=None):
    """The one control map with the ViNE table (what ``Controls.for_document(seg)`` builds)."""
    return Controls(VINE, n_labels=n_labels, label=label, brush_radius=brush_radius,
                    radius_range=(1e-6 * max_radius, max_radius), scene=scene)


def replay_vine(seg, frames, controls):
    return vr.replay(seg, frames, controls)


@pytest.fixture
def seg():
    m = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    return Segmentation(np.asarray(m.vertices, np.float32), np.asarray(m.faces))


def wand_at(scene: SceneTransform, p_model) -> np.ndarray:
    """Controller pose (no rotation: pointing -z) whose brush tip is at model point ``p_model``."""
    pose = np.eye(4)
    pose[:3, 3] = scene.matrix[:3, :3] @ np.asarray(p_model, float) + scene.translation + [0, 0, TIP_OFFSET]
    return pose


def frame(t, *, left=None, right=None, hmd=None) -> InputFrame:
    h = np.eye(4)
    h[:3, 3] = (0.0, 1.6, 0.0)
    return InputFrame(t, h if hmd is None else hmd, left or ControllerState(), right or ControllerState())


def pad_at(angle_deg: float, r: float = 0.8) -> tuple[float, float]:
    a = math.radians(angle_deg)
    return (r * math.cos(a), r * math.sin(a))


# -- pure control map ---------------------------------------------------------------------------------------
def test_wheel_label_is_the_slice_rule_of_the_desktop_wheel():
    from plantvr.vine.colors import slice_at
    rng = np.random.default_rng(0)
    for x, y in rng.uniform(-1, 1, (300, 2)):
        for k in (1, 5, 13):
            assert wheel_label((x, y), k, 0) == slice_at(x, y, k, 0)
    assert wheel_label((0.05, 0.05), 13, last=7) == 7                     # dead zone keeps the last label
    assert wheel_label(pad_at(0.5 * 360 / 13 + 3 * 360 / 13), 13) == 3     # slice 3 centre
    with pytest.raises(ValueError, match="n_labels"):
        wheel_label((0.5, 0.5), 0)
    with pytest.raises(ValueError, match="last"):
        wheel_label((0.5, 0.5), 4, last=4)


def test_trigger_press_paints_at_the_tip_as_one_undo_item(seg):
    c = VineControls(n_labels=len(seg.colors), label=2, brush_radius=0.3, max_radius=seg.max_radius)
    p0, p1 = seg.vertices[0].astype(float), seg.vertices[40].astype(float)
    frames = [frame(0.00, right=ControllerState(pose=wand_at(c.scene, p0), trigger=0.5)),   # preview only
              frame(0.01, right=ControllerState(pose=wand_at(c.scene, p0), trigger=1.0)),
              frame(0.02, right=ControllerState(pose=wand_at(c.scene, p1), trigger=1.0)),
              frame(0.03, right=ControllerState(pose=wand_at(c.scene, p1), trigger=0.0))]
    cmds = [[cmd.name for cmd in c.update(f)] for f in frames]
    assert cmds == [[], ["begin_stroke", "paint"], ["paint"], ["end_stroke"]]
    c2 = VineControls(n_labels=len(seg.colors), label=2, brush_radius=0.3, max_radius=seg.max_radius)
    replay_vine(seg, frames, c2)
    d = np.linalg.norm(seg.vertices - seg.vertices[[0]], axis=1)
    d1 = np.linalg.norm(seg.vertices - seg.vertices[[40]], axis=1)
    inside = (d <= 0.3 - 1e-4) | (d1 <= 0.3 - 1e-4)
    assert np.all(seg.labels[inside] == 2)
    assert np.all(seg.labels[(d > 0.3 + 1e-4) & (d1 > 0.3 + 1e-4)] == 0)
    assert len(seg.history.undo_stack) == 1                                  # one trigger press, one item
    left_menu = [frame(0.04, left=ControllerState(menu=True)), frame(0.05)]
    replay_vine(seg, left_menu, c2)                                          # left menu = undo
    assert not seg.labels.any()
    replay_vine(seg, [frame(0.06, right=ControllerState(menu=True)), frame(0.07)], c2)   # right menu = redo
    assert np.all(seg.labels[inside] == 2)


def test_wheel_selects_and_click_toggles_hide_and_hidden_label_does_not_paint(seg):
    k = len(seg.colors)
    c = VineControls(n_labels=k, label=1, brush_radius=0.3, max_radius=seg.max_radius)
    target = 5
    pad = pad_at((target + 0.5) * 360 / k)
    replay_vine(seg, [frame(0, left=ControllerState(pad=pad, pad_touched=True))], c)
    assert c.label == target and seg.colors.visible.all()
    replay_vine(seg, [frame(0.01, left=ControllerState(pad=pad, pad_touched=True, pad_pressed=True)),
                      frame(0.02, left=ControllerState(pad=pad, pad_touched=True, pad_pressed=True))], c)
    assert not seg.colors.visible[target] and seg.colors.visible.sum() == k - 1   # one click, one toggle
    cmds = c.update(frame(0.03, right=ControllerState(pose=wand_at(c.scene, seg.vertices[0]), trigger=1.0)))
    assert cmds == []                                     # the active colour is hidden: nothing to paint
    replay_vine(seg, [frame(0.04, left=ControllerState(pad=pad, pad_touched=True)),
                      frame(0.05, left=ControllerState(pad=pad, pad_touched=True, pad_pressed=True))], c)
    assert seg.colors.visible[target]


def test_thumb_circle_resizes_the_brush(seg):
    c = VineControls(n_labels=len(seg.colors), brush_radius=0.2, max_radius=seg.max_radius)
    for i in range(37):                                   # one clockwise turn, 10° steps
        c.update(frame(i * 0.01, right=ControllerState(pad=pad_at(-10 * i), pad_touched=True)))
    assert c.brush_radius == pytest.approx(0.4, rel=1e-6)
    c.update(frame(1.0))
    for i in range(37):                                   # counter-clockwise: back to 0.2
        c.update(frame(1.01 + i * 0.01, right=ControllerState(pad=pad_at(10 * i), pad_touched=True)))
    assert c.brush_radius == pytest.approx(0.2, rel=1e-6)


def test_save_view_then_cycle_restores_the_placement(seg):
    c = VineControls(n_labels=len(seg.colors), max_radius=seg.max_radius)
    hmd = np.eye(4)
    hmd[:3, 3] = (0.3, 1.5, 0.2)
    up = ControllerState(pad=(0.0, 0.8), pad_touched=True, pad_pressed=True)
    down = ControllerState(pad=(0.0, -0.8), pad_touched=True, pad_pressed=True)
    replay_vine(seg, [frame(0, right=up, hmd=hmd), frame(0.01, hmd=hmd)], c)
    assert len(seg.views) == 1
    before = c.scene.matrix.copy()
    c.scene.translate([0.5, -0.2, 0.3])
    c.scene.scale *= 2
    replay_vine(seg, [frame(0.02, right=down, hmd=hmd), frame(0.03, hmd=hmd)], c)
    np.testing.assert_allclose(c.scene.matrix, before, atol=1e-9)


def test_one_grip_translates_the_model(seg):
    c = VineControls(n_labels=len(seg.colors), max_radius=seg.max_radius)
    t0 = c.scene.translation.copy()
    for i in range(6):
        pose = np.eye(4)
        pose[:3, 3] = (0.01 * i, 1.0, -0.3)
        c.update(frame(i / 90, left=ControllerState(pose=pose, grip=True)))
    np.testing.assert_allclose(c.scene.translation - t0, [0.05, 0, 0], atol=1e-9)


def test_issue_rejects_unknown(seg):
    with pytest.raises(ValueError, match="command must be one of"):
        issue(seg, Command("prune"))


# -- the bridge on the fake runtime -------------------------------------------------------------------------
def _press(bridge, fake, pose, frames=3):
    fake.right.pose = pose
    fake.right.trigger = 1.0
    bridge.wait_frames(frames)
    fake.right.trigger = 0.0
    bridge.wait_frames(2)
    bridge.wait_commands()


def test_bridge_paints_at_the_tip_hides_undoes_and_renders(seg, fake):
    with pytest.raises(ValueError, match="doc must be"):
        vr.attach(object())
    bridge = vr.attach(seg, readback=True)
    assert vr.attach(seg) is bridge
    bridge.start()
    try:
        bridge.wait_content()
        blank = [im.copy() for im in bridge.last_images]
        c = bridge.controls
        c.brush_radius = 0.35
        p = seg.vertices[0].astype(float)
        _press(bridge, fake, wand_at(c.scene, p))
        d = np.linalg.norm(seg.vertices - p, axis=1)
        assert np.all(seg.labels[d <= 0.35 - 1e-4] == c.label) and not seg.labels[d > 0.35 + 1e-4].any()
        assert len(seg.history.undo_stack) == 1 and bridge.command_errors == []
        bridge.wait_content()                 # the mesh thread may lag the frames on a loaded machine
        rgb = bridge.content[1]["surface"][0].point_data["rgba"]   # the View's labelled-surface layer
        assert len(rgb) == seg.n_vertices and bridge.depth_cue    # coloured (depth-cued) surface of the scene
        assert any(not np.array_equal(a, b) for a, b in zip(blank, bridge.last_images))   # a visible change
        # left pad: choose the painted colour, click to hide it
        k = len(seg.colors)
        fake.left.pad, fake.left.pad_touched = pad_at((c.label + 0.5) * 360 / k), True
        bridge.wait_frames(2)
        fake.left.pad_pressed = True
        bridge.wait_frames(2)
        fake.left.pad_pressed = fake.left.pad_touched = False
        bridge.wait_frames(2)
        bridge.wait_commands()
        assert not seg.colors.visible[c.label]
        fake.left.pad_touched, fake.left.pad_pressed = True, True
        bridge.wait_frames(2)
        fake.left.pad_pressed = fake.left.pad_touched = False
        bridge.wait_frames(2)
        bridge.wait_commands()
        assert seg.colors.visible[c.label]
        # left menu: undo
        fake.left.menu = True
        bridge.wait_frames(2)
        fake.left.menu = False
        bridge.wait_frames(2)
        bridge.wait_commands()
        assert not seg.labels.any()
        assert all(sorted(e) == [0, 1] for e in fake.submissions_by_frame().values())
    finally:
        bridge.stop()
    assert bridge.command_errors == [] and bridge.error is None


def test_frames_continue_during_a_slow_paint(seg, fake):
    bridge = vr.Headset(seg)
    real = seg.paint

    def slow_paint(*args, **kwargs):
        time.sleep(0.4)
        return real(*args, **kwargs)

    seg.paint = slow_paint              # instance attribute: the worker calls it through the public name
    bridge.start()
    try:
        bridge.wait_frames(2)
        fake.right.pose = wand_at(bridge.controls.scene, seg.vertices[3])
        fake.right.trigger = 1.0
        while not bridge.commands_done:   # begin_stroke issued; the first stamp is now sleeping
            time.sleep(0.005)
        f0 = bridge.frames
        time.sleep(0.3)
        assert bridge.frames - f0 >= 5, "render thread stalled behind the paint worker"
        fake.right.trigger = 0.0
        bridge.wait_frames(2)
    finally:
        bridge.stop()
    assert seg.labels[3] == bridge.controls.label and bridge.command_errors == []
    assert len(seg.history.undo_stack) == 1


def test_surface_colours_follow_paint_and_hidden_triangles_drop(seg, fake):
    bridge = vr.attach(seg, depth_cue=False)
    bridge.start()
    try:
        bridge.wait_frames(2)
        bridge.controls.brush_radius = 0.5
        _press(bridge, fake, wand_at(bridge.controls.scene, seg.vertices[0]))
        bridge.wait_content()
        label = bridge.controls.label
        surf = bridge.content[1]["surface"][0]
        assert seg.labels.any() and np.all(surf.point_data["rgba"][seg.labels == label] == seg.colors.rgba[label])
        seg.set_visible(label, False)
        bridge.wait_content()
        surf = bridge.content[1]["surface"][0]
        assert surf.n_cells == len(seg.visible_faces()) < len(seg.faces)
    finally:
        bridge.stop()


def test_wheel_mesh_extrudes_the_selected_slice_and_marks_hidden_colours(seg):
    from plantvr.vr.render import wheel_mesh
    rgba = seg.colors.rgba
    vis = np.ones(len(rgba), bool)
    vis[4] = False
    poly = wheel_mesh(rgba, vis, selected=2, thumb=(0.3, 0.4))
    rgb = poly.cell_data["rgb"]
    centres = poly.cell_centers().points
    ang = np.arctan2(centres[:, 1], centres[:, 0]) % (2 * np.pi)
    sl = np.floor(ang / (2 * np.pi / len(rgba))).astype(int)
    frac = ang / (2 * np.pi / len(rgba)) - sl
    base = (np.abs(centres[:, 2]) < 1e-6) & (frac > 0.01) & (frac < 0.99)   # off the slice borders
    assert np.all(rgb[base & (sl == 0)] == rgba[0, :3])
    assert np.all(centres[sl == 2][:, 2] > 0.1)                       # extruded
    dark = rgb[base & (sl == 4)]
    assert np.all(dark.astype(int) <= np.ceil(0.3 * rgba[4, :3].astype(int)))   # hidden: darkened
    assert (centres[:, 2] > 0.2).sum() == 8                            # thumb marker


def test_recorded_headset_session_replays_identically(seg, fake):
    scene = {"scale": 0.4, "translation": (0.0, 1.1, -0.6)}
    bridge = vr.Headset(seg, record=True, depth_cue=False, scene=SceneTransform(**scene))
    bridge.start()
    try:
        bridge.wait_frames(2)
        for i in (0, 50, 120):
            _press(bridge, fake, wand_at(SceneTransform(**scene), seg.vertices[i]))
        fake.left.menu = True                      # undo the last stroke
        bridge.wait_frames(2)
        fake.left.menu = False
        bridge.wait_frames(2)
        bridge.wait_commands()
    finally:
        bridge.stop()
    assert seg.labels.any() and len(seg.history.undo_stack) == 2
    m = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    fresh = Segmentation(np.asarray(m.vertices, np.float32), np.asarray(m.faces))
    controls = VineControls(n_labels=len(fresh.colors), label=1, brush_radius=bridge.controls.brush_radius,
                            max_radius=fresh.max_radius, scene=SceneTransform(**scene))
    replay_vine(fresh, bridge.recording, controls)
    np.testing.assert_array_equal(fresh.labels, seg.labels)
    assert len(fresh.history.undo_stack) == 2

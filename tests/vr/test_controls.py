"""Control map without a headset: gesture, momentum, handle bar, menu, windows, paint/prune, replay."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantvr import vr
from plantvr.documents.treewand import Model
from plantvr import vr as C
from plantvr.vr import gestures
from plantvr.vr.fake_openvr import pose_matrix
from plantvr.vr.math3d import quat_from_matrix, quat_rotate, quat_to_matrix


def circle(n=64, turns=1.0, clockwise=True, r=0.8):
    a = np.linspace(0, 2 * np.pi * turns, n + 1)
    a = -a if clockwise else a
    return [(r * math.cos(t), r * math.sin(t)) for t in a]


@pytest.mark.parametrize("clockwise,factor", [(True, 2.0), (False, 0.5)])
def test_tw_v22_brush_gesture_one_circle(clockwise, factor):
    g, r = C.BrushGesture(), 1.0
    for p in circle(clockwise=clockwise):
        r = g.update(p, True, r)
    assert r == pytest.approx(factor, rel=0.01)


def test_brush_gesture_two_circles_dead_zone_and_clamp():
    g, r = C.BrushGesture(), 1.0
    for p in circle(n=100, turns=2.0):
        r = g.update(p, True, r)
    assert r == pytest.approx(4.0, rel=0.01)
    assert g.update((0.05, 0.0), True, r) == r          # centre: no angle
    assert g.update((0.8, 0.0), False, r) == r          # thumb lifted
    g2, big = C.BrushGesture(), 19.0
    for p in circle():
        big = g2.update(p, True, big)
    assert big == gestures.RADIUS_RANGE[1]


def test_controls_gesture_emits_brush_radius_command_and_replays_into_model():
    m = Model(seed=0)
    frames = [C.InputFrame(i / 90, right=C.ControllerState(pad=p, pad_touched=True))
              for i, p in enumerate(circle())]
    ctl = vr.replay(m, frames)
    assert m.brush_radius == pytest.approx(2.0, rel=0.01)
    assert ctl.brush_radius == m.brush_radius
    assert m.log.events[-1].command == "set_params"


def test_smoothed_velocity_eq_5_2():
    rng = np.random.default_rng(0)
    t = np.arange(12) / 90
    x = np.outer(t, [0.9, 0.0, -0.3]) + rng.normal(0, 1e-4, (12, 3))
    v = C.smoothed_velocity(x, t, 5)
    np.testing.assert_allclose(v, (x[-1] - x[-6]) / (5 / 90))
    np.testing.assert_allclose(v, [0.9, 0, -0.3], atol=0.05)
    np.testing.assert_array_equal(C.smoothed_velocity(x[:1], t[:1]), 0)


def test_momentum_decays_by_a_per_frame_and_glides_a_over_1_minus_a():
    tr = C.OneGripTranslate()
    dt = 1 / 90
    tr.grab([0, 0, 0], 0.0)
    for i in range(1, 8):
        tr.move([0.01 * i, 0, 0], i * dt)           # 0.9 m/s
    v0 = tr.release()
    np.testing.assert_allclose(v0, [0.9, 0, 0], rtol=1e-9)
    d1 = tr.coast(dt)
    np.testing.assert_allclose(d1, v0 * dt)
    np.testing.assert_allclose(tr.velocity, 0.98 * v0)
    total = d1.copy()
    for _ in range(3000):
        total += tr.coast(dt)
    # sum_{i>=0} v a^i dt = v dt / (1 - a), within the eps cut-off
    assert total[0] == pytest.approx(0.9 * dt / (1 - 0.98), rel=1e-3)
    assert not np.any(tr.velocity)


def test_one_grip_translates_with_the_hand_and_a_new_grab_cancels_momentum():
    ctl = C.Controls()
    t0 = ctl.scene.translation.copy()
    for i in range(10):
        pose = pose_matrix((0.1 + 0.02 * i, 1.0, -0.3))
        ctl.update(C.InputFrame(i / 90, right=C.ControllerState(pose=pose, grip=True)))
    np.testing.assert_allclose(ctl.scene.translation - t0, [0.18, 0, 0], atol=1e-12)
    ctl.update(C.InputFrame(10 / 90, right=C.ControllerState(pose=pose)))      # release
    assert ctl.translate.velocity[0] == pytest.approx(0.02 * 90 * 0.98)   # released, then one coast frame
    moved = ctl.scene.translation.copy()
    ctl.update(C.InputFrame(11 / 90, right=C.ControllerState(pose=pose)))
    assert ctl.scene.translation[0] > moved[0]                                 # coasting
    ctl.update(C.InputFrame(12 / 90, left=C.ControllerState(pose=pose, grip=True)))
    assert not np.any(ctl.translate.velocity)                                  # grab cancels


def test_handlebar_yaw_roll_follows_the_hands_erratum():
    rng = np.random.default_rng(1)
    for _ in range(20):
        l0, r0 = rng.normal(size=3), rng.normal(size=3)
        rot = Rotation.from_rotvec(rng.normal(size=3) * 0.3)
        l1, r1 = l0, l0 + rot.apply(r0 - l0)
        q = np.array([1.0, 0, 0, 0])
        k, qq, m0, m1 = C.handlebar_step(l0, r0, q, q, l1, r1, q, q)
        lr0, lr1 = (r0 - l0) / np.linalg.norm(r0 - l0), (r1 - l1) / np.linalg.norm(r1 - l1)
        np.testing.assert_allclose(quat_rotate(qq, lr0), lr1, atol=1e-9)   # q LR_{i-1} q^-1 = LR_i
        assert k == pytest.approx(1.0)


def test_handlebar_scale_pitch_average_and_pivot():
    l0, r0 = np.array([-0.3, 1.0, 0.0]), np.array([0.3, 1.0, 0.0])
    ident = np.array([1.0, 0, 0, 0])
    k, q, m0, m1 = C.handlebar_step(l0, r0, ident, ident, 1.5 * l0, 1.5 * r0, ident, ident)
    assert k == pytest.approx(1.5)
    np.testing.assert_allclose(q, ident, atol=1e-12)
    # both hands twist about the bar (x): pitch = average; one hand only: half of it
    qx = Rotation.from_rotvec([0.2, 0, 0]).as_quat()[[3, 0, 1, 2]]
    _, q2, _, _ = C.handlebar_step(l0, r0, ident, ident, l0, r0, qx, qx)
    assert Rotation.from_quat(q2[[1, 2, 3, 0]]).as_rotvec() == pytest.approx([0.2, 0, 0], abs=1e-9)
    _, q1, _, _ = C.handlebar_step(l0, r0, ident, ident, l0, r0, qx, ident)
    assert Rotation.from_quat(q1[[1, 2, 3, 0]]).as_rotvec() == pytest.approx([0.1, 0, 0], abs=1e-9)
    # twist perpendicular to the bar gives no pitch
    qy = Rotation.from_rotvec([0, 0.3, 0]).as_quat()[[3, 0, 1, 2]]
    _, q3, _, _ = C.handlebar_step(l0, r0, ident, ident, l0, r0, qy, qy)
    np.testing.assert_allclose(q3, ident, atol=1e-12)
    # the scene pivots about the bar midpoint: a model point at the midpoint stays under it
    sc = C.SceneTransform(scale=1.0, translation=[0, 1.0, 0])
    sc.handlebar(k, np.array([1.0, 0, 0, 0]), m0, m0 + [0, 0.1, 0])
    np.testing.assert_allclose(sc.matrix @ [0, 0, 0, 1], [0, 1.1, 0, 1], atol=1e-12)
    assert sc.scale == pytest.approx(1.5)


def test_two_grips_through_controls_rotate_and_scale_the_scene():
    ctl = C.Controls(scene=C.SceneTransform(scale=1.0, translation=[0, 0, 0]))
    for i, (ang, spread) in enumerate([(0, 0.3), (0, 0.3), (0.2, 0.45)]):
        rot = Rotation.from_rotvec([0, ang, 0])
        lp = rot.apply([-spread, 0, 0]) + [0, 1, -0.5]
        rp = rot.apply([spread, 0, 0]) + [0, 1, -0.5]
        left = C.ControllerState(pose=pose_matrix(lp, yaw=ang), grip=True)
        right = C.ControllerState(pose=pose_matrix(rp, yaw=ang), grip=True)
        ctl.update(C.InputFrame(i / 90, left=left, right=right))
    assert ctl.scene.scale == pytest.approx(1.5)
    assert Rotation.from_matrix(ctl.scene.rotation).as_rotvec() == pytest.approx([0, 0.2, 0], abs=1e-9)


def test_menu_wedges_counterclockwise_from_the_top():
    assert C.menu_item_at((0.0, 0.9)) == 0                     # green, Appearance, at the top
    step = 2 * math.pi / 7
    for k in range(7):
        a = math.pi / 2 + k * step + 0.3 * step
        assert C.menu_item_at((0.9 * math.cos(a), 0.9 * math.sin(a))) == k
    assert C.menu_item_at((0.05, 0.05)) is None


def press_menu(ctl, k, t=0.0):
    a = math.pi / 2 + k * 2 * math.pi / 7
    pad = (0.9 * math.cos(a), 0.9 * math.sin(a))
    out = ctl.update(C.InputFrame(t, left=C.ControllerState(pad=pad, pad_touched=True)))
    assert ctl.menu_hover == k
    pressed = C.ControllerState(pad=pad, pad_touched=True, pad_pressed=True)
    out += ctl.update(C.InputFrame(t + 0.01, left=pressed))
    out += ctl.update(C.InputFrame(t + 0.02, left=C.ControllerState(pad=pad, pad_touched=True)))
    return out


def test_menu_selection_all_seven_items(tmp_path):
    ctl = C.Controls(save_path=str(tmp_path / "default.tree"))
    for k, name in enumerate(("appearance", "tree_form", "light")):
        assert press_menu(ctl, k) == []
        assert name in ctl.windows
    press_menu(ctl, 0)
    assert "appearance" not in ctl.windows
    assert [c.name for c in press_menu(ctl, 3)] == ["set_prune_mode"] and ctl.prune_mode
    assert press_menu(ctl, 4)[0] == C.Command("save", {"path": str(tmp_path / "default.tree")})
    assert press_menu(ctl, 5)[0].name == "restore"
    assert press_menu(ctl, 6)[0].name == "reset"


def test_menu_save_load_reset_through_the_model(tmp_path, model):
    ctl = C.Controls(save_path=str(tmp_path / "default.tree"))
    n = model.n_internodes
    for k in (4, 6):
        for cmd in press_menu(ctl, k):
            C.issue(model, cmd)
    assert model.n_internodes <= 1 < n          # "leaving the base"
    for cmd in press_menu(ctl, 5):
        C.issue(model, cmd)
    assert model.n_internodes == n


def test_place_window_one_metre_ahead_facing_the_controller_up_is_up():
    pose = pose_matrix((0.5, 1.2, 0.0), yaw=0.7, pitch=0.4)
    w = C.place_window(pose)
    heading = -pose[:3, 2]
    np.testing.assert_allclose(w[:3, 3], pose[:3, 3] + heading)
    np.testing.assert_allclose(w[:3, 1], [0, 1, 0])
    to_ctl = pose[:3, 3] - w[:3, 3]
    to_ctl[1] = 0
    np.testing.assert_allclose(w[:3, 2], to_ctl / np.linalg.norm(to_ctl), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(w[:3, :3]), 1.0)
    assert C.ray_hits_window(pose[:3, 3], heading, w) == pytest.approx((0.5, 0.5))


def test_controller_paint_lands_in_the_model_at_the_tip_in_model_space():
    m = Model(seed=0)
    ctl = C.Controls(brush_radius=1.0, scene=C.SceneTransform(scale=0.25, translation=[0, 0, -1.0]))
    pose = pose_matrix((0.1, 1.0, -0.8))
    cmds = ctl.update(C.InputFrame(0.0, right=C.ControllerState(pose=pose, trigger=1.0)))
    assert [c.name for c in cmds] == ["paint"]
    for c in cmds:
        C.issue(m, c)
    tip = pose[:3, 3] + C.TIP_OFFSET * -pose[:3, 2]
    centre = (tip - [0, 0, -1.0]) / 0.25
    assert m.n_markers > 0
    assert np.all(np.linalg.norm(m.snapshot.markers - centre, axis=1) <= 1.0 + 1e-9)
    assert m.log.events[-1].command == "paint"
    # partial trigger previews (shows the brush) but never paints
    assert ctl.update(C.InputFrame(0.1, right=C.ControllerState(pose=pose, trigger=0.5))) == []
    assert ctl.brush_visible


def test_pointing_at_a_window_blocks_painting():
    ctl = C.Controls()
    pose = pose_matrix((0.0, 1.2, 0.0))
    ctl.activate(0, pose=pose)
    cmds = ctl.update(C.InputFrame(0.0, right=C.ControllerState(pose=pose, trigger=1.0)))
    assert ctl.pointing is not None and ctl.pointing[0] == "appearance"
    assert cmds == [] and not ctl.brush_visible


def test_prune_mode_partial_previews_full_prunes_tw_v17b(model):
    sc = C.SceneTransform(scale=1.0, translation=[0, 0, 0])
    ctl = C.Controls(brush_radius=1.0, prune_mode=True, scene=sc)
    target = model.snapshot.pos[len(model.snapshot.pos) // 2]
    pose = np.eye(4)
    pose[:3, 3] = target + [0, 0, C.TIP_OFFSET]     # tip exactly on the node
    cmds = ctl.update(C.InputFrame(0.0, right=C.ControllerState(pose=pose, trigger=0.5)))
    assert [c.name for c in cmds] == ["prune_preview"]
    preview = C.issue(model, cmds[0])
    assert len(preview) > 0
    n = model.n_internodes
    cmds = ctl.update(C.InputFrame(0.1, right=C.ControllerState(pose=pose, trigger=1.0)))
    assert [c.name for c in cmds] == ["prune"]
    removed = C.issue(model, cmds[0])
    assert removed == len(preview) and model.n_internodes == n - removed
    # holding still does not prune again
    assert ctl.update(C.InputFrame(0.2, right=C.ControllerState(pose=pose, trigger=1.0))) == []


def test_recorded_session_replays_identically(tmp_path):
    rng = np.random.default_rng(3)
    frames = []
    for i in range(40):
        pose = pose_matrix((0.05 * math.sin(i / 5), 1.0 + 0.01 * i, -0.8))
        pad = circle(n=40)[i]
        frames.append(C.InputFrame(i / 90, hmd=pose_matrix((0, 1.6, 0), yaw=rng.normal() * 0.1),
                                   right=C.ControllerState(pose=pose, trigger=1.0 if i % 3 else 0.4,
                                                           pad=pad, pad_touched=i > 20)))
    path = C.save_recording(frames, tmp_path / "session.jsonl")
    loaded = C.load_recording(path)
    a, b = Model(seed=5), Model(seed=5)
    vr.replay(a, frames)
    vr.replay(b, loaded)
    b.step(3)
    a.step(3)
    np.testing.assert_array_equal(a.snapshot.markers, b.snapshot.markers)
    np.testing.assert_array_equal(a.snapshot.pos, b.snapshot.pos)
    assert a.brush_radius == b.brush_radius > 1.0
    (tmp_path / "bad.jsonl").write_text("{not json\n")
    with pytest.raises(ValueError, match="no trailer line"):
        C.load_recording(tmp_path / "bad.jsonl")


def test_issue_rejects_unknown_and_bad_values_leave_model_unchanged():
    m = Model(seed=0)
    with pytest.raises(ValueError, match="command must be one of"):
        C.issue(m, C.Command("fly"))
    with pytest.raises(ValueError, match="radius"):
        C.issue(m, C.Command("paint", {"center": [0, 1, 0], "radius": -1.0}))
    assert m.n_markers == 0
    with pytest.raises(ValueError, match="brush_radius"):
        C.Controls(brush_radius=100.0)


def test_quaternion_helpers_match_scipy():
    rng = np.random.default_rng(2)
    for r in Rotation.random(20, random_state=4):
        q = quat_from_matrix(r.as_matrix())
        np.testing.assert_allclose(quat_to_matrix(q), r.as_matrix(), atol=1e-12)
        v = rng.normal(size=3)
        np.testing.assert_allclose(quat_rotate(q, v), r.apply(v), atol=1e-12)

"""The headset bridge on a Tree Wand Model against the fake runtime: lifecycle, errors, stereo submission, controls,
threads."""
import sys
import threading
import time

import numpy as np
import pytest

import plantvr.vr as vr
from plantvr.vr import fake_openvr
from plantvr.vr.fake_openvr import pose_matrix


def test_start_without_openvr_package_says_what_to_install(model, monkeypatch):
    fake_openvr.uninstall()
    monkeypatch.setitem(sys.modules, "openvr", None)        # import openvr -> ImportError
    bridge = vr.Headset(model)
    with pytest.raises(RuntimeError, match=r"'openvr' Python package.*pip install plantvr\[vr\].*SteamVR"):
        bridge.start()
    assert not bridge.running


def test_start_without_runtime_reports_path_registry_and_steamvr(model, fake):
    fake.installed = False
    with pytest.raises(RuntimeError,
                       match=r"no OpenVR runtime.*PathRegistryNotFound.*install Steam and SteamVR"):
        vr.Headset(model).start()
    fake.installed, fake.hmd_present = True, False
    with pytest.raises(RuntimeError, match="no headset found"):
        vr.Headset(model).start()
    assert fake.init_count == 0


def test_lifecycle_both_eyes_every_frame_matching_sizes(model, fake):
    bridge = vr.attach(model, readback=True)
    assert vr.attach(model) is bridge
    bridge.start()
    with pytest.raises(RuntimeError, match="already running"):
        bridge.start()
    bridge.wait_content()
    bridge.wait_frames(4)
    bridge.stop()
    assert not bridge.running and bridge.status == "stopped"
    assert not any(t.is_alive() for t in bridge._threads)
    assert fake.init_count == fake.shutdown_count == 1
    by_frame = fake.submissions_by_frame()
    assert bridge.frames >= 4 and len(by_frame) >= bridge.frames
    assert all(sorted(eyes) == [0, 1] for eyes in by_frame.values())
    bounds = {(eye, b) for _, eye, _, b in fake.submissions}
    assert bounds == {(0, (0.0, 0.0, 0.5, 1.0)), (1, (0.5, 0.0, 1.0, 1.0))}   # one texture, two halves
    w, h = fake.render_size
    assert [im.shape for im in bridge.last_images] == [(h, w, 3), (h, w, 3)]
    counts, edges = bridge.histogram()
    assert counts.sum() == len(bridge.frame_ms) == bridge.frames
    assert "ms" in bridge.histogram_text() and bridge.stats()["frames"] == bridge.frames
    assert bridge.command_errors == []
    layers = bridge.content[1]
    assert layers["tree"][0].n_points > 0 and layers["markers"][0].n_points == model.n_markers


def test_pair_layout_submits_a_texture_per_eye(model, fake):
    bridge = vr.Headset(model, layout="pair", readback=True)
    bridge.start()
    bridge.wait_frames(2)
    bridge.stop()
    assert {b for *_, b in fake.submissions} == {None}
    assert all(sorted(e) == [0, 1] for e in fake.submissions_by_frame().values())
    left, right = bridge.last_images
    assert left.shape == right.shape and not np.array_equal(left, right)      # two viewpoints


def test_head_pose_moves_the_view(model, fake):
    bridge = vr.Headset(model, readback=True)
    bridge.start()
    bridge.wait_frames(2)
    before = bridge.last_images[0].copy()
    fake.hmd_pose = pose_matrix((0.0, 1.6, 0.0), yaw=0.6)
    bridge.wait_frames(2)
    after = bridge.last_images[0]
    bridge.stop()
    np.testing.assert_allclose(bridge.hmd_pose, fake.hmd_pose, atol=1e-6)
    assert np.abs(before.astype(int) - after).mean() > 1.0


def test_controller_trigger_paints_through_the_model(model, fake):
    bridge = vr.Headset(model)
    n0, e0 = model.n_markers, len(model.log)
    fake.right.pose = pose_matrix((0.0, 0.8, -0.9))
    bridge.start()
    bridge.wait_frames(2)
    fake.right.trigger = 1.0
    bridge.wait_frames(3)
    fake.right.trigger = 0.0
    bridge.wait_frames(1)
    bridge.wait_commands()
    bridge.stop()
    assert model.n_markers > n0
    new = [e.command for e in model.log.events[e0:]]
    assert set(new) <= {"paint", "paint_stroke"} and new
    centre = bridge.controls.scene.to_model(fake.right.pose[:3, 3] + 0.05 * -fake.right.pose[:3, 2])
    d = np.linalg.norm(model.snapshot.markers[n0:] - centre, axis=1)
    assert np.all(d <= model.brush_radius + 1e-9)


def test_menu_press_in_the_headset_toggles_prune_mode_on_the_model(model, fake):
    bridge = vr.Headset(model)
    a = np.pi / 2 + 3 * 2 * np.pi / 7
    fake.left.pad, fake.left.pad_touched = (0.9 * np.cos(a), 0.9 * np.sin(a)), True
    bridge.start()
    bridge.wait_frames(2)
    fake.left.pad_pressed = True
    bridge.wait_frames(2)
    fake.left.pad_pressed = False
    bridge.wait_frames(1)
    bridge.wait_commands()
    assert model.prune_mode and bridge.controls.prune_mode
    model.prune_mode = False            # notebook toggles it back: the headset follows
    bridge.wait_frames(2)
    bridge.stop()
    assert not bridge.controls.prune_mode


def test_frames_continue_while_a_slow_growth_step_runs(model, fake):
    engine = model._engine
    real_step = engine.step
    started = threading.Event()

    def slow_step():
        started.set()
        time.sleep(1.0)                 # a 1 s step, under the model lock
        return real_step()

    engine.step = slow_step
    bridge = vr.Headset(model)
    bridge.start()
    bridge.wait_frames(2)
    worker = model.grow(1, background=True)
    assert started.wait(5)
    fake.right.trigger = 1.0            # a paint queued behind the lock must not stall rendering either
    f0 = bridge.frames
    time.sleep(0.6)
    during = bridge.frames - f0
    still_growing = worker.is_alive()
    fake.right.trigger = 0.0
    worker.join()
    bridge.wait_commands()
    bridge.stop()
    assert still_growing and during >= 5
    assert model.n_markers > 0 and model.steps_done >= 13


def test_runtime_loss_stops_cleanly_and_the_model_keeps_its_work(model, fake, capsys):
    bridge = vr.Headset(model)
    bridge.start()
    bridge.wait_frames(2)
    snap = model.snapshot
    fake.fail_at_frame = fake.frame + 2
    t_end = time.monotonic() + 10
    while bridge.running and time.monotonic() < t_end:
        time.sleep(0.01)
    assert not bridge.running and bridge.status == "lost"
    assert type(bridge.error).__name__ == "CompositorError_RequestFailed"
    assert "headset mode stopped" in capsys.readouterr().err
    assert fake.shutdown_count == 1
    bridge.stop()
    assert model.snapshot is snap and model.n_internodes == snap.n_internodes
    fake.fail_at_frame = None
    bridge.start()                      # the headset is back
    bridge.wait_frames(2)
    bridge.stop()
    assert bridge.error is None and bridge.frames >= 2


def test_vrevent_quit_stops_the_bridge(model, fake):
    bridge = vr.Headset(model)
    bridge.start()
    bridge.wait_frames(1)
    fake.quit_at_frame = fake.frame + 1
    bridge.wait_frames(50, timeout=10)
    assert not bridge.running and "VREvent_Quit" in str(bridge.error)


def test_bridge_argument_checks(model):
    with pytest.raises(ValueError, match="layout must be one of"):
        vr.Headset(model, layout="quad")
    with pytest.raises(ValueError, match="render_scale"):
        vr.Headset(model, render_scale=0)


def test_recorded_headset_session_replays_identically_without_a_headset(fake):
    from plantvr.documents.treewand import Model

    def fresh():
        m = Model(seed=7)
        m.paint_stroke([[0.0, y, 0.0] for y in range(2, 6)], radius=1.5)
        m.step(5)
        return m

    live = fresh()
    bridge = vr.Headset(live, record=True)
    fake.right.pose = pose_matrix((0.05, 0.9, -0.9))
    bridge.start()
    bridge.wait_frames(2)
    fake.right.trigger = 1.0
    bridge.wait_frames(4)
    fake.right.trigger = 0.0
    bridge.wait_frames(2)
    bridge.stop()
    bridge.wait_commands()
    assert live.n_markers > 0 and len(bridge.recording) == bridge.frames
    again = fresh()
    vr.replay(again, bridge.recording)
    np.testing.assert_array_equal(again.snapshot.markers, live.snapshot.markers)


def test_prune_mode_partial_trigger_shows_the_red_preview(model, fake):
    bridge = vr.Headset(model)
    bridge.controls.scene.scale, bridge.controls.scene.translation = 1.0, np.zeros(3)
    node = model.snapshot.pos[len(model.snapshot.pos) // 2]
    fake.right.pose = pose_matrix(node + [0, 0, 0.05])           # brush tip on a node
    model.prune_mode = True
    n = model.n_internodes
    bridge.start()
    fake.right.trigger = 0.5
    bridge.wait_frames(3)
    t_end = time.monotonic() + 10
    while bridge.preview is None and time.monotonic() < t_end:
        time.sleep(0.01)
    bridge.stop()
    assert bridge.preview is not None and bridge.preview[1].n_points > 0
    assert model.n_internodes == n                                # a preview removes nothing

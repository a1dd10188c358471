"""A paint in the live view shows in the first picture trame captures, with one render (issue 31): the paint runs
on the server's thread and its change reaches the view on the kernel thread later; the capture draws it first,
and the change, when it arrives, leaves nothing to draw or push."""
from __future__ import annotations

import asyncio
import threading

import numpy as np
import pytest
import pyvista as pv

from plantvr.documents.labels import Segmentation
from plantvr.view import View
from plantvr.view.interaction import LabelBrush
from plantvr.vine.depthcue import coarse_hull, depth_cue_colors

from .test_render_lock import _delivery, _jpeg

OPTS = {"view": "1", "mtime": 0, "quality": 90, "size": [320, 240]}


class _Kernel:
    """A thread running an event loop, as ipykernel's shell: documents made on it apply their changes on it."""

    def __init__(self):
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()

    def call(self, fn):
        async def run():
            return fn()
        return asyncio.run_coroutine_threadsafe(run(), self.loop).result(60)

    def block(self) -> threading.Event:
        """Keep the loop busy until the returned event is set (a kernel still running a cell)."""
        go = threading.Event()
        self.loop.call_soon_threadsafe(go.wait, 60)
        return go

    def stop(self):
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)


class _Viewer:
    """Stands for the trame viewer of :meth:`View.widget`: counts the pushes."""

    def __init__(self):
        self.pushes = 0

    def update(self):
        self.pushes += 1


def _sphere_view():
    s = pv.Sphere(radius=10.0, theta_resolution=40, phi_resolution=30)
    seg = Segmentation(np.asarray(s.points, np.float32), s.regular_faces)
    view = View(seg, off_screen=True, window_size=(320, 240), background="black")
    view.plotter.camera_position = [(0, 0, 40), (0, 0, 0), (0, 1, 0)]
    return seg, view


@pytest.fixture
def live():
    kernel = _Kernel()
    seg, view = kernel.call(_sphere_view)
    view.viewer = _Viewer()
    view.lock.on_capture(view._before_capture)      # as View.widget() does
    renders = []
    view.plotter.ren_win.AddObserver("EndEvent", lambda *_: renders.append(1))
    yield kernel, seg, view, renders
    kernel.call(view.close)
    kernel.stop()


def test_capture_draws_a_paint_whose_change_has_not_arrived(live):
    kernel, seg, view, renders = live
    delivery = _delivery(view.plotter.ren_win)
    before = _jpeg(delivery.still_render(OPTS))
    surf = view.layers["surface"]
    go, seen = kernel.block(), {}

    def server():                                      # trame's thread: a mouse event paints, then the capture
        seen["n"] = seg.paint([0.0, 0.0, 10.0], 4.0, 3)
        seen["updates"] = surf.updates                 # the change has not reached the layer: the kernel is busy
        seen["first"] = _jpeg(delivery.still_render(OPTS))
        seen["drawn"] = np.array_equal(surf.mesh.point_data["rgba"], seg.vertex_colors())

    try:
        t = threading.Thread(target=server)
        t.start()
        t.join(60)
    finally:
        go.set()
    first = seen["first"]
    assert seen["n"] > 0 and seen["updates"] == 0 and seen["drawn"]
    kernel.call(lambda: None)                          # the kernel applies the change
    assert view.drawn_version == seg.version
    n_renders, pushes = len(renders), view.viewer.pushes
    kernel.call(lambda: None)                          # and runs what it scheduled
    assert surf.updates == 0 and view.viewer.pushes == pushes == 0 and len(renders) == n_renders
    changed = int((np.abs(first - before).max(axis=-1) > 40).sum())
    settled = _jpeg(delivery.still_render({**OPTS, "clearCache": True}))
    assert changed > 200 and int((np.abs(first - settled).max(axis=-1) > 40).sum()) < 4


def test_a_capture_before_a_due_push_leaves_it_nothing_to_send(live):
    kernel, seg, view, renders = live
    delivery = _delivery(view.plotter.ren_win)
    delivery.still_render(OPTS)
    kernel.call(lambda: view.set_brush([0.0, 0.0, 10.0], 2.0))            # a push is due after this message
    assert view.viewer.pushes == 1
    kernel.call(lambda: (view.set_brush([0.0, 2.0, 10.0], 2.0), delivery.still_render(OPTS)))
    kernel.call(lambda: None)
    assert view.viewer.pushes == 1                     # the capture sent the moved brush: no second push


def test_depth_cued_stamp_matches_the_whole_surface_cued_at_that_eye():
    seg, view = _sphere_view()
    try:
        surf = view.layers["surface"]
        surf.set_depth_cue(True)
        seg.paint([0.0, 0.0, 10.0], 4.0, 5)
        eye = np.asarray(view.plotter.camera.position, float)
        want = depth_cue_colors(seg.vertex_colors(), seg.vertices, eye, coarse_hull(seg.vertices))
        assert np.array_equal(surf.mesh.point_data["rgba"], want)
        view.plotter.camera_position = [(0, 30, 25), (0, 0, 0), (0, 1, 0)]   # the camera moves: all recued
        assert surf.refresh() and not surf.refresh()
        want = depth_cue_colors(seg.vertex_colors(), seg.vertices, np.array([0.0, 30.0, 25.0]),
                                coarse_hull(seg.vertices))
        assert np.array_equal(surf.mesh.point_data["rgba"], want)
    finally:
        view.close()


def test_a_held_stroke_in_a_live_view_draws_without_multisampling():
    seg, view = _sphere_view()
    brush = LabelBrush(view, label=2, radius=3.0)
    brush.attach()
    iren, window = view.plotter.iren.interactor, view.plotter.ren_win
    own = window.GetMultiSamples()
    try:
        iren.SetEventInformation(160, 120, 0, 0)
        for live_view, during in ((None, own), (_Viewer(), 0)):
            view.viewer = live_view
            iren.InvokeEvent("LeftButtonPressEvent")
            assert window.GetMultiSamples() == during
            iren.InvokeEvent("LeftButtonReleaseEvent")
            assert window.GetMultiSamples() == own
        assert np.count_nonzero(seg.labels == 2) > 0 and [e.command for e in seg.log.events].count("paint") == 2
        iren.InvokeEvent("LeftButtonPressEvent")
        brush.close()                                  # detached mid-stroke: the window's own again
        assert window.GetMultiSamples() == own
    finally:
        view.close()


def test_a_press_after_a_move_at_one_pixel_picks_once():
    seg, view = _sphere_view()
    brush = LabelBrush(view, label=2, radius=3.0)
    picks = []
    brush._picker.AddObserver("StartPickEvent", lambda *_: picks.append(1))
    try:
        a = brush.world_point(160, 120)
        b = brush.world_point(160, 120)                 # the press of the same browser event
        assert len(picks) == 1 and brush.picked and np.array_equal(a, b) and abs(np.linalg.norm(a) - 10) < 0.5
        seg.paint(a, 3.0, 2)                            # the colours changed: picked again, to the same point
        assert np.array_equal(brush.world_point(160, 120), a) and len(picks) == 2
        view.plotter.camera_position = [(0, 40, 0), (0, 0, 0), (0, 0, 1)]
        c = brush.world_point(160, 120)
        assert len(picks) == 3 and c[1] > 9              # a new camera: the top of the sphere
        off = brush.world_point(2, 2)                   # off the sphere: the free-space ray, not picked
        assert len(picks) == 4 and not brush.picked and brush.world_point(2, 2) is not off and not brush.picked
    finally:
        brush.close()
        view.close()

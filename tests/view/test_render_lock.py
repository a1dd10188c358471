"""One render thread at a time per view (issue 31): document changes redrawn on one thread while another renders
screenshots and trame's still images of the same view; VTK must report no error and the pictures are drawn."""
from __future__ import annotations

import io
import threading

import numpy as np
import pytest
import vtk

import plantvr
from plantvr.view import View
from plantvr.view._render_lock import lock_trame_image_delivery, render_lock

publish = pytest.importorskip("trame_vtk.modules.vtk.protocols.publish_image_delivery")
from vtkmodules.vtkWebCore import vtkWebApplication  # noqa: E402

N_EDITS = 40        # paint strokes (every 8th followed by a growth step); without the lock VTK reports errors in most runs


def _delivery(render_window):
    """trame-vtk's image delivery protocol bound to one render window, as a remote view's server runs it."""
    lock_trame_image_delivery()
    app = vtkWebApplication()
    app.SetImageEncoding(0)

    class Delivery(publish.vtkWebPublishImageDelivery):
        @property
        def app(self):
            return app

        def get_view(self, vid):
            return render_window

        def get_global_id(self, view):
            return 1

    return Delivery(decode=False)           # as trame-vtk makes it: JPEG bytes


def _content_fraction(img: np.ndarray) -> float:
    """Share of pixels unlike their row's median (the background is a vertical gradient)."""
    rgb = img[..., :3].astype(np.int16)
    return float((np.abs(rgb - np.median(rgb, axis=1, keepdims=True)).max(axis=-1) > 24).mean())


@pytest.fixture
def vtk_errors():
    """Everything VTK's output window receives (errors and warnings) while the test runs."""
    out = vtk.vtkStringOutputWindow()
    old = vtk.vtkOutputWindow.GetInstance()
    vtk.vtkOutputWindow.SetInstance(out)
    yield out
    vtk.vtkOutputWindow.SetInstance(old)


def test_doc_changes_and_trame_renders_from_two_threads(vtk_errors, capfd):
    from PIL import Image

    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(6)
    v = View(m, window_size=(320, 240))
    assert v.lock is render_lock(v.plotter.ren_win)
    delivery = _delivery(v.plotter.ren_win)
    n, failures = N_EDITS, []
    rng = np.random.default_rng(0)
    points = rng.uniform([-1.5, 2.0, -1.5], [1.5, 6.0, 1.5], (n, 3))

    def edit():                         # the "kernel": commands whose changes the view redraws on this thread
        try:
            for k, p in enumerate(points):
                m.paint_stroke([p, p + [0.2, 0.3, 0.0]], radius=0.4)
                if k % 8 == 7:
                    m.step(1)
        except Exception as exc:       # reported below: an exception in a thread would pass silently
            failures.append(repr(exc))

    shots, images = [], []
    t = threading.Thread(target=edit)
    t.start()
    try:
        while t.is_alive() or len(shots) < 5:           # the "server": screenshots and trame's still images
            shots.append(v.screenshot())
            reply = delivery.still_render({"view": "1", "mtime": 0, "quality": 90, "size": [320, 240]})
            if reply["image"]:
                images.append(reply["image"])
    finally:
        t.join(120)
    assert not failures, failures
    assert m.version > n
    v.screenshot()
    jpeg = np.asarray(Image.open(io.BytesIO(images[-1])).convert("RGB"))
    v.close()
    text = vtk_errors.GetOutput()
    err = capfd.readouterr()
    logged = "\n".join(line for line in (err.out + err.err).splitlines()
                       if "ERR|" in line or "vtkOpenGL" in line or "Error" in line)
    assert not text.strip() and not logged, (text + logged)[-3000:]
    assert len(images) >= 5
    assert min(_content_fraction(s) for s in shots) > 0.01
    assert jpeg.shape == (240, 320, 3) and _content_fraction(jpeg) > 0.01


def _jpeg(reply) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(reply["image"])).convert("RGB")).astype(np.int16)


def test_trame_capture_sends_the_frame_it_rendered():
    """VTK's web application returns the JPEG encoder's previous picture while it encodes the new one (trame
    sent the new one 0.5 s later): the capture waits for its own frame, so a paint shows in the first picture."""
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(6)
    v = View(m, window_size=(320, 240))
    delivery = _delivery(v.plotter.ren_win)
    opts = {"view": "1", "mtime": 0, "quality": 90, "size": [320, 240]}
    for _ in range(3):
        delivery.still_render(opts)
    try:
        for k in range(6):
            p = np.array([0.5 * k - 1.25, 4.5, 0.0])
            m.paint_stroke([p, p + [0.2, 0.3, 0.0]], radius=0.5)
            first = _jpeg(delivery.still_render(opts))
            for _ in range(3):                     # the settled picture of the same scene
                truth = _jpeg(delivery.still_render(opts))
            stale = int((np.abs(first - truth).max(axis=-1) > 40).sum())
            assert stale < 4, f"stroke {k}: the first picture differs from the scene in {stale} pixels"
    finally:
        v.close()

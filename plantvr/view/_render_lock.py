"""One lock per render window around every VTK call that draws in it (issue 31: the live notebook).

A live view is drawn from two threads: the kernel thread redraws on a document change (layer updates, then a
render and a push), and the trame server's thread renders the picture it sends to the browser
(``vtkWebPublishImageDelivery.still_render``, called for every mouse event and every push). One OpenGL context
used from two threads at once is undefined behaviour: VTK logged ``vtkOpenGLVertexArrayObject`` "handleless
buffer" and shader VAO errors from two thread ids. So each render window has one re-entrant
:class:`RenderLock` (:func:`render_lock`), held by :class:`plantvr.view.View` around its layer updates,
renders and screenshots, by the brush around its pick and preview, by the ViNE review app around its paint
commands, and by trame's image capture (:func:`lock_trame_image_delivery` wraps ``still_render``).
Serialising is not enough: an EGL context current on one thread cannot be made current on another
(``eglMakeCurrent`` fails and VTK draws with no buffers bound), so the outermost holder releases the context
(``ReleaseCurrent``) as it lets go.

Before it captures, a live :class:`plantvr.view.View` brings its layers up to date (:meth:`RenderLock.on_capture`):
a paint from the browser runs on the server's thread, inside the mouse event, and where that is not the kernel's
(a server on a thread of its own: a kernel off the main thread, marimo, ``benchmarks/paint_latency.py``) its
change reaches the view on the kernel thread only after the picture trame renders right after the event (which
holds the GIL), so the layers draw what was painted before that picture; and a push the view has due, when it
comes, finds the picture sent and renders nothing (one render per input event).

The capture also waits for its own picture: ``vtkWebApplication.StillRenderToBuffer`` renders, hands the
frame to its JPEG encoder threads and returns the newest picture *already encoded*, the previous frame's
(``stale``), and trame then sends the fresh one only 0.5 s later. A paint stroke's first picture showed the
scene before the stroke. :func:`lock_trame_image_delivery` polls the encoder for the frame just rendered
(a few ms; no second render) and sends that (``benchmarks/paint_latency.py`` measures both).

Lock order: a :class:`~plantvr.view.View` takes its window's lock inside its document's observers, so after
the document's lock (a document applies a change, and calls its observers, under its own lock in a script);
nothing a View does under that lock issues a document command, so trame's mouse replay, whose observers
paint, is not held under it as a whole. The ViNE review app holds its window's lock around its commands
(window, then segmentation: its :class:`~plantvr.view.vine_layers.LabelledSurfaceLayer` edits VTK arrays
inside the segmentation's observers), and its View draws a static scene, so no observer of a segmentation takes
that window's lock and the two orders never meet on one lock.
"""
from __future__ import annotations

import functools
import threading
import time
import weakref

__all__ = ["FRESH_PICTURES", "RenderLock", "lock_plotter", "lock_trame_image_delivery", "render_lock"]

#: Send the frame just rendered, not the encoder's previous one (False: trame's own behaviour, the baseline of
#: ``benchmarks/paint_latency.py``).
FRESH_PICTURES = True
#: Longest wait for the JPEG encoder, s (its threads encode a 900x700 frame in a few ms).
ENCODER_WAIT_S = 0.2

_LOCKS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_GUARD = threading.Lock()


class RenderLock:
    """A re-entrant lock of one render window whose outermost release also releases its OpenGL context, so the
    next holder, on whatever thread, can make it current."""

    def __init__(self, render_window):
        self._lock = threading.RLock()
        self._window = weakref.ref(render_window)   # the registry's key: no strong reference from its value
        self._depth = 0                             # only the holder changes it
        self._before_capture = None

    def on_capture(self, fn) -> None:
        """Call ``fn()`` (a bound method, held weakly) under this lock before each trame capture of the window
        (with :data:`FRESH_PICTURES`); it brings the scene up to date and returns whether the picture trame's
        image cache holds is stale, so the capture renders a new one."""
        self._before_capture = weakref.WeakMethod(fn)

    def before_capture(self) -> bool:
        """Run the :meth:`on_capture` function (False without one)."""
        fn = None if self._before_capture is None else self._before_capture()
        return bool(fn is not None and fn())

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        """Take the lock (as :meth:`threading.RLock.acquire`)."""
        if not self._lock.acquire(blocking, timeout):
            return False
        self._depth += 1
        return True

    def release(self) -> None:
        """Let go once; the outermost release first releases the window's context from this thread."""
        if self._depth == 1:
            window = self._window()
            if window is not None and hasattr(window, "ReleaseCurrent"):
                window.ReleaseCurrent()
        self._depth -= 1
        self._lock.release()

    def __enter__(self) -> "RenderLock":
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def render_lock(render_window) -> RenderLock:
    """The one :class:`RenderLock` of ``render_window`` (a ``vtkRenderWindow``), made on first use."""
    with _GUARD:
        lock = _LOCKS.get(render_window)
        if lock is None:
            lock = _LOCKS[render_window] = RenderLock(render_window)
        return lock


def lock_plotter(plotter) -> RenderLock:
    """Make ``plotter.render()`` take its render window's lock (pyvista renders from camera setters, pickers and
    ``add_mesh`` too); returns the lock."""
    lock = render_lock(plotter.ren_win)
    render = plotter.render
    if not getattr(render, "_plantvr_locked", False):
        @functools.wraps(render)
        def locked_render(*args, **kwargs):
            with lock:
                return render(*args, **kwargs)
        locked_render._plantvr_locked = True
        plotter.render = locked_render
    return lock


def lock_trame_image_delivery() -> None:
    """Make trame-vtk's image capture (``vtkWebPublishImageDelivery.still_render``: render, then encode the
    picture) take the lock of the render window it draws (once per process; nothing without trame-vtk)."""
    try:
        from trame_vtk.modules.vtk.protocols.publish_image_delivery import (  # noqa: PLC0415
            vtkWebPublishImageDelivery,
        )
    except ImportError:
        return
    still_render = vtkWebPublishImageDelivery.still_render
    if getattr(still_render, "_plantvr_locked", False):
        return

    @functools.wraps(still_render)
    def locked_still_render(self, options):
        view = self.get_view(options["view"])
        if not view:
            return still_render(self, options)
        with render_lock(view) as lock:
            if FRESH_PICTURES and lock.before_capture():
                self.app.InvalidateCache(view)
            reply = still_render(self, options)
            if reply.get("stale") and FRESH_PICTURES and not self.decode:
                _fresh_picture(self.app, view, reply, int(options.get("quality", 100)))
            return reply

    locked_still_render._plantvr_locked = True
    vtkWebPublishImageDelivery.still_render = locked_still_render


def _fresh_picture(app, view, reply: dict, quality: int) -> None:
    """Put the picture of the frame ``still_render`` just rendered into its ``reply`` once the encoder has it: with
    the image cache valid, ``StillRenderToBuffer`` does not render again but returns the encoder's newest
    output (and clears ``GetHasImagesBeingProcessed`` when that is the last frame pushed)."""
    deadline = time.monotonic() + ENCODER_WAIT_S
    data = None
    while app.GetHasImagesBeingProcessed(view) and time.monotonic() < deadline:
        time.sleep(0.001)
        data = app.StillRenderToBuffer(view, 0, quality)
    if data is None:
        return
    reply["image"] = memoryview(data).tobytes()
    reply["memsize"] = data.GetDataSize()
    reply["mtime"] = app.GetLastStillRenderToMTime()
    reply["stale"] = bool(app.GetHasImagesBeingProcessed(view))

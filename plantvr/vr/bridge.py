"""The headset bridge: any document mirrored into an OpenVR headset (spec 000_treewand §4.1, §4.10, §4.12;
000_vine §2.1–2.6, §4.2–4.5).

``plantvr.vr.attach(doc)`` returns the :class:`Headset` of a :class:`~plantvr.document.Document` (it attaches
from outside: the document holds no reference to it); ``start()`` opens headset mode, ``stop()`` ends it.
Three threads, none of which holds the document lock while rendering:

* **render** (``plantvr-vr-render``): ``waitGetPoses`` (OpenVR running start), read the controllers, run the
  control map (:class:`~plantvr.vr.controls.Controls`, the document kind's
  :class:`~plantvr.vr.controls.ControlMap`), render both eyes of the newest prepared content, submit both
  textures. No simulation and no document command runs here (§4.10).
* **commands** (``plantvr-vr-commands``, ViNE's *worker*): issues the control map's commands on the document by
  name (``getattr(doc, name)(**kwargs)``, the methods the notebook uses), so they land in ``doc.log``;
  consecutive paint stamps of one radius become one stroke where the map says so. A slow command never stalls
  the render thread, which keeps drawing the last content it was handed.
* **mesher** (``plantvr-vr-mesher``): when the document publishes a change (``doc.latest`` / ``doc.version``),
  publishes the :meth:`~plantvr.view.View.snapshot` of a :class:`~plantvr.view.View` of the document that is
  never rendered (the View's own layers: generalized-cylinder branches with bark and leaves, points, surfaces,
  instances, the labelled surface with the depth cue of 000_vine §2.2) by swapping one reference; the render
  thread copies the layer actors into its GL context.

A recording of input frames (``record=True``) replays through the same control map and command path without a
headset: :meth:`Headset.replay` / :func:`replay`.
"""
from __future__ import annotations

import importlib
import queue
import sys
import threading
import time
import warnings
import weakref
from collections import deque
from typing import Any

import numpy as np

from .._validation import check_choice, check_int, check_range
from ..document import Document
from ..types import Instances, Points, TreeArrays, TriMesh
from ..view.polydata import tube_polydata
from .controls import Command, Controls, issue
from .frames import ControllerState, InputFrame
from .gestures import SceneTransform
from .math3d import hmd34_to_array, hmd44_to_array

__all__ = ["HISTOGRAM_EDGES_MS", "HOME", "HOME_SIZE", "Headset", "attach", "replay"]

#: Frame-time histogram bins, ms: 90 fps (11.1 ms), 45 fps, 30 fps (§4.10) ...
HISTOGRAM_EDGES_MS = (0.0, 5.5, 11.1, 22.2, 33.3, 50.0, 100.0, 250.0, 1000.0, np.inf)
#: Room point a document without a tree has its bounding-box centre placed at on start (m; in reach).
HOME = np.array([0.0, 1.1, -0.6])
#: Room size of that bounding-box diagonal on start (m).
HOME_SIZE = 0.8

INSTALL_HINT = ("install the extra with `pip install plantvr[vr]` (PyPI package 'openvr', pyopenvr) and "
                "Steam + SteamVR (run SteamVR once so it registers its runtime path)")


def _import_openvr():
    try:
        return importlib.import_module("openvr")
    except ImportError as exc:
        raise RuntimeError(f"headset mode needs the 'openvr' Python package, which is not installed ({exc}); "
                           f"{INSTALL_HINT}") from None


def _init_openvr(openvr):
    try:
        return openvr.init(openvr.VRApplication_Scene)
    except Exception as exc:  # pyopenvr raises openvr.error_code.InitError_* (OpenVRError) subclasses
        kind = type(exc).__name__
        text = f"{kind}: {exc}" if str(exc) else kind
        if any(k in kind + str(exc) for k in ("PathRegistry", "InstallationNotFound", "VRClientDLLNotFound",
                                               "Installation path")):
            raise RuntimeError(f"no OpenVR runtime was found ({text}): the 'openvr' package is installed but "
                               f"SteamVR is not; install Steam and SteamVR and run SteamVR once") from None
        if "HmdNotFound" in kind + str(exc):
            raise RuntimeError(f"no headset found ({text}): connect and power on the headset, start SteamVR, "
                               f"then call start() again") from None
        raise RuntimeError(f"OpenVR could not start ({text}); is SteamVR running?") from None


# -- content (mesher thread) ----------------------------------------------------------------------------
def preview_mesh(tree: TreeArrays, nodes: np.ndarray, sides: int):
    """Red tubes over the internodes a prune would remove (§4.4 partial trigger)."""
    nodes = np.asarray(nodes, np.int64)
    nodes = nodes[(nodes < len(tree.pos)) & (nodes >= 0)]
    nodes = nodes[tree.parent[nodes] >= 0] if len(nodes) else nodes
    return tube_polydata(tree, nodes, np.asarray(tree.radius, float)[nodes] * 1.15 + 1e-3, sides=sides)


def _bounds(content: dict[str, Any]) -> tuple[np.ndarray, np.ndarray] | None:
    pts = []
    for c in content.values():
        if isinstance(c, TreeArrays):
            pts.append(c.pos)
        elif isinstance(c, Points):
            pts.append(np.asarray(c.xyz, float).reshape(-1, 3))
        elif isinstance(c, TriMesh):
            pts.append(np.asarray(c.vertices, float))
        elif isinstance(c, Instances):
            pts.append(np.asarray(c.transforms, float).reshape(-1, 4, 4)[:, :3, 3])
    pts = [p for p in pts if len(p)]
    if not pts:
        return None
    allp = np.concatenate(pts)
    return allp.min(axis=0), allp.max(axis=0)


class Headset:
    """Headset mode for any :class:`~plantvr.document.Document`: ``start()`` opens it, ``stop()`` ends it.

    Parameters
    ----------
    doc : Document
        The shared document; the headset draws its :meth:`~plantvr.document.Document.scene` and issues its
        commands by name, through the control map of its kind (:data:`~plantvr.vr.controls.CONTROL_MAPS`).
    controls : Controls, optional
        The control map state (default :meth:`Controls.for_document <plantvr.vr.controls.Controls.for_document>`
        with ``scene`` and a brush of 3 % of the content's size when the document has no ``brush_radius``).
    layout : {"side", "pair"}
        Stereo layout of :class:`~plantvr.vr.render.StereoRenderer`.
    tube_sides : int
        Cross-section sides of the branches (and of the prune preview's tubes): 6 is the thesis' LOD 6/32 budget
        at the tips; the bases get ``max(tube_sides, 12)``.
    render_scale : float
        Fraction of the runtime's recommended per-eye size to render (1.0 in a headset).
    leaves : bool
        Show the leaves of a document whose snapshot has ``buds`` (Tree Wand, TreeSketch, §3.4).
    record : bool
        Keep every :class:`~plantvr.vr.frames.InputFrame` in :attr:`recording` (replay with :meth:`replay`).
    readback : bool
        Copy both eye images to :attr:`last_images` every frame (tests, thumbnails; slow).
    near, far : float
        Clipping planes, metres.
    depth_cue : bool
        Blend the per-vertex colours of coloured meshes toward ``background`` with distance (000_vine §2.2,
        Eq. 5.8, normalised variant).
    background : 3 ints
        Depth-cue target colour (dark: "further = darker", 000_vine §2.2.1 [INFERRED]).
    eye_step : float
        Fraction of the content size the eye must move before the depth cue is recomputed.
    scene : SceneTransform, optional
        Initial placement; default: a document with tree content at a quarter scale 1 m ahead on the ground,
        any other with its bounding box centred at :data:`HOME`, diagonal :data:`HOME_SIZE` metres.

    Examples
    --------
    >>> headset = plantvr.vr.attach(doc)      # doctest: +SKIP
    >>> headset.start()                        # doctest: +SKIP
    >>> headset.stop()                         # doctest: +SKIP
    """

    def __init__(self, doc, *, controls: Controls | None = None, layout: str = "side", tube_sides: int = 6,
                 render_scale: float = 1.0, leaves: bool = True, record: bool = False,
                 readback: bool = False, near: float = 0.05, far: float = 100.0, depth_cue: bool = True,
                 background=(0, 0, 0), eye_step: float = 0.02, scene: SceneTransform | None = None):
        if not isinstance(doc, Document):
            raise ValueError(f"doc must be a plantvr Document, got {type(doc).__name__}")  # noqa: TRY004
        if scene is not None and not isinstance(scene, SceneTransform):
            raise ValueError(f"scene must be a SceneTransform, got {type(scene).__name__}")
        if controls is not None and not isinstance(controls, Controls):
            raise ValueError(f"controls must be a Controls, got {type(controls).__name__}")
        self.tube_sides = check_int("tube_sides", tube_sides, 3, 64)
        self.leaves = bool(leaves)
        self.layout = check_choice("layout", layout, ("side", "pair"))
        self.render_scale = check_range("render_scale", render_scale, 0.0, 1.0, low_open=True)
        self.near = check_range("near", near, 0.0, 10.0, low_open=True)
        self.far = check_range("far", far, self.near, 1e6, low_open=True)
        self.eye_step = check_range("eye_step", eye_step, 0.0, 1.0)
        bg = np.asarray(background, float)
        if bg.shape != (3,) or not np.all(np.isfinite(bg)) or bg.min() < 0 or bg.max() > 255:
            raise ValueError(f"background must be 3 values in [0, 255], got {list(np.ravel(bg))}"[:300])
        self.doc = doc
        self.depth_cue = bool(depth_cue)
        self.background = tuple(round(x) for x in bg)
        self.record = bool(record)
        self.readback = bool(readback)
        content = doc.scene()
        box = _bounds(content)
        lo, hi = box if box is not None else (np.zeros(3), np.ones(3))
        self.size = float(np.linalg.norm(hi - lo)) or 1.0
        #: Tree content stands on the ground disc; other content floats at :data:`HOME`.
        self.ground = any(isinstance(c, TreeArrays) for c in content.values())
        if scene is None and controls is None and not self.ground:
            s = HOME_SIZE / self.size
            scene = SceneTransform(scale=s, translation=HOME - s * 0.5 * (lo + hi))
        if controls is None:
            radius = None
            if not hasattr(doc, "brush_radius"):
                radius = min(0.03 * self.size, float(getattr(doc, "max_radius", np.inf)))
            controls = Controls.for_document(doc, brush_radius=radius, scene=scene)
        self.controls = controls
        self.recording: list[InputFrame] = []
        self.frame_ms: deque = deque(maxlen=100_000)
        self.frames = 0
        self.error: BaseException | None = None
        self.status = "stopped"
        self.command_errors: list[tuple[Command, str]] = []
        self.commands_done = 0
        self.last_images: list[np.ndarray] | None = None
        self.render_size: tuple[int, int] | None = None
        self.eye_to_head: list[np.ndarray] = []
        self.projection: list[np.ndarray] = []
        self.hmd_pose = np.eye(4)
        self._openvr = None
        self._threads: list[threading.Thread] = []
        self._stop = threading.Event()
        self._ready = threading.Event()
        self._queue: queue.Queue = queue.Queue()
        self.content: tuple[int, dict] | None = None   # (build id, View.snapshot()), swapped whole
        self.content_version = -1                       # document version the mesh thread last built
        self._drawn_content = None                      # build id the render thread last drew
        self._preview: tuple | None = None             # (tree, node indices) from the command thread
        self.preview: tuple | None = None              # (id, polydata) of the prune preview

    # -- lifecycle -----------------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        """True while the render thread runs."""
        return any(t.is_alive() for t in self._threads[:1])

    def start(self, *, timeout: float = 60.0) -> Headset:
        """Open headset mode: import and initialise OpenVR, then start the render, command and mesh threads.

        Raises
        ------
        RuntimeError
            The ``openvr`` package or the SteamVR runtime or the headset is missing (the message says which
            and how to install it), headset mode is already running, or the renderer failed to start.
        """
        if self.running:
            raise RuntimeError("headset mode is already running; call stop() first")
        openvr = _import_openvr()
        system = _init_openvr(openvr)
        self._openvr, self._system = openvr, system
        try:
            self._compositor = openvr.VRCompositor()
            if hasattr(self._compositor, "setTrackingSpace"):
                self._compositor.setTrackingSpace(openvr.TrackingUniverseStanding)
            w, h = system.getRecommendedRenderTargetSize()
            self.render_size = (max(int(w * self.render_scale), 1), max(int(h * self.render_scale), 1))
            self._read_eyes()
        except Exception:
            openvr.shutdown()
            raise
        self._stop.clear()
        self._ready.clear()
        self.error, self.status, self.frames = None, "starting", 0
        self._threads = [threading.Thread(target=self._render_loop, name="plantvr-vr-render", daemon=True),
                         threading.Thread(target=self._command_loop, name="plantvr-vr-commands", daemon=True),
                         threading.Thread(target=self._mesh_loop, name="plantvr-vr-mesher", daemon=True)]
        for t in self._threads:
            t.start()
        if not self._ready.wait(timeout) or self.error is not None:
            err = self.error
            self.stop()
            raise RuntimeError(f"headset renderer did not start: {err!r}")
        return self

    def stop(self, timeout: float | None = 30.0) -> None:
        """End headset mode: stop and join the threads, shut OpenVR down. The document keeps all work; a stroke
        left open by a held trigger is finished (one undo item)."""
        self._stop.set()
        me = threading.current_thread()
        for t in self._threads:
            if t is not me:
                t.join(timeout)
        for cmd in self.controls.close_stroke():
            self._issue(cmd)
        if self.status not in ("lost",):
            self.status = "stopped"

    def wait_frames(self, n: int, timeout: float = 30.0) -> int:
        """Block until ``n`` more frames were rendered (or the headset stopped); returns the frame count."""
        target = self.frames + n
        t_end = time.monotonic() + timeout
        while self.frames < target and self.running and time.monotonic() < t_end:
            time.sleep(0.002)
        return self.frames

    def wait_content(self, timeout: float = 30.0) -> int:
        """Block until the mesh thread has built the document's current version and a frame has drawn it (or the
        headset stopped); returns the frame count."""
        version, t_end = self.doc.version, time.monotonic() + timeout
        while self.running and time.monotonic() < t_end and (
                self.content_version < version or self.content is None or self._drawn_content != self.content[0]):
            time.sleep(0.002)
        return self.wait_frames(1, timeout=max(0.0, t_end - time.monotonic()))

    def wait_commands(self, timeout: float = 30.0) -> None:
        """Block until every queued controller command has been issued on the document."""
        t_end = time.monotonic() + timeout
        while (self._queue.unfinished_tasks or not self._queue.empty()) and time.monotonic() < t_end:
            time.sleep(0.002)

    # -- replay --------------------------------------------------------------------------------------------
    def replay(self, frames: list[InputFrame]) -> Controls:
        """Feed recorded frames through this headset's control map into the document, synchronously, without a
        headset or threads: the same commands the live command thread issues (a rejected one raises
        ``ValueError``); a stroke still open at the end is finished. Returns the controls."""
        if isinstance(frames, InputFrame) or not all(isinstance(f, InputFrame) for f in frames):
            raise ValueError("frames must be a list of InputFrame")
        c = self.controls
        for f in frames:
            c.follow(self.doc)
            for cmd in c.coalesce(c.update(f)):
                issue(self.doc, cmd)
        for cmd in c.close_stroke():
            issue(self.doc, cmd)
        return c

    # -- statistics ----------------------------------------------------------------------------------------
    def histogram(self, edges=HISTOGRAM_EDGES_MS) -> tuple[np.ndarray, np.ndarray]:
        """Counts of render-frame times (ms, ``waitGetPoses`` return to last submit) per bin."""
        ms = np.asarray(self.frame_ms, float)
        return np.histogram(ms, bins=np.asarray(edges, float))[0], np.asarray(edges, float)

    def stats(self) -> dict[str, Any]:
        """Frames, median/p95 frame ms, share of frames within 11.1 ms (90 fps), status and error."""
        ms = np.asarray(self.frame_ms, float)
        return {"frames": self.frames, "status": self.status,
                "error": repr(self.error) if self.error else None,
                "median_ms": float(np.median(ms)) if len(ms) else None,
                "p95_ms": float(np.percentile(ms, 95)) if len(ms) else None,
                "within_90fps": float(np.mean(ms <= 1000 / 90)) if len(ms) else None,
                "render_size": self.render_size, "commands": self.commands_done}

    def histogram_text(self) -> str:
        """The frame-time histogram as text bars."""
        counts, edges = self.histogram()
        total = max(int(counts.sum()), 1)
        lines = []
        for c, lo, hi in zip(counts, edges[:-1], edges[1:]):
            lines.append(f"{lo:7.1f}-{hi:<7.1f} ms {int(c):6d} {'#' * int(round(40 * c / total))}")
        return "\n".join(lines)

    # -- render thread -------------------------------------------------------------------------------------
    def _read_eyes(self) -> None:
        ovr, sysm = self._openvr, self._system
        eyes = (ovr.Eye_Left, ovr.Eye_Right)
        self.eye_to_head = [hmd34_to_array(sysm.getEyeToHeadTransform(e)) for e in eyes]
        self.projection = [hmd44_to_array(sysm.getProjectionMatrix(e, self.near, self.far)) for e in eyes]

    def _controller(self, poses, role: int) -> ControllerState:
        ovr, sysm = self._openvr, self._system
        i = sysm.getTrackedDeviceIndexForControllerRole(role)
        if i is None or i >= len(poses) or not poses[i].bPoseIsValid:
            return ControllerState(valid=False)
        ok, st = sysm.getControllerState(i)
        if not ok:
            return ControllerState(pose=hmd34_to_array(poses[i].mDeviceToAbsoluteTracking), valid=False)
        pressed, touched = int(st.ulButtonPressed), int(st.ulButtonTouched)

        def bit(button_id: int) -> int:   # openvr.h ButtonMaskFromId
            return 1 << int(button_id)
        return ControllerState(
            pose=hmd34_to_array(poses[i].mDeviceToAbsoluteTracking), valid=True,
            trigger=float(st.rAxis[1].x), grip=bool(pressed & bit(ovr.k_EButton_Grip)),
            menu=bool(pressed & bit(ovr.k_EButton_ApplicationMenu)),
            pad=(float(st.rAxis[0].x), float(st.rAxis[0].y)),
            pad_touched=bool(touched & bit(ovr.k_EButton_SteamVR_Touchpad)),
            pad_pressed=bool(pressed & bit(ovr.k_EButton_SteamVR_Touchpad)))

    def _render_loop(self) -> None:
        from .render import StereoRenderer
        ovr = self._openvr
        renderer = None
        try:
            renderer = StereoRenderer(*self.render_size, layout=self.layout, near=self.near, far=self.far)
            renderer.set_ground(self.ground)
            poses = (ovr.TrackedDevicePose_t * ovr.k_unMaxTrackedDeviceCount)()
            event = ovr.VREvent_t()
            self._drawn_content, self._drawn_preview, self._wheel_key = None, None, None
            self.status = "running"
            self._ready.set()
            while not self._stop.is_set():
                while self._system.pollNextEvent(event):
                    if event.eventType == ovr.VREvent_Quit:
                        raise RuntimeError("the OpenVR runtime asked the application to quit (VREvent_Quit)")
                self._compositor.waitGetPoses(poses, None)       # running start: render right after
                t0 = time.perf_counter()
                hmd = poses[ovr.k_unTrackedDeviceIndex_Hmd]
                if hmd.bPoseIsValid:
                    self.hmd_pose = hmd34_to_array(hmd.mDeviceToAbsoluteTracking)
                frame = InputFrame(time.monotonic(), self.hmd_pose,
                                   self._controller(poses, ovr.TrackedControllerRole_LeftHand),
                                   self._controller(poses, ovr.TrackedControllerRole_RightHand))
                if self.record:
                    self.recording.append(frame)
                self.controls.follow(self.doc)
                for cmd in self.controls.update(frame):
                    self._queue.put(cmd)
                self._update_content(renderer)
                self._update_overlays(renderer)
                eyes = [self.hmd_pose @ e for e in self.eye_to_head]
                renderer.render(eyes, self.projection)
                for eye, (handle, bounds) in zip((ovr.Eye_Left, ovr.Eye_Right), renderer.textures()):
                    tex = ovr.Texture_t()
                    tex.handle, tex.eType = handle, ovr.TextureType_OpenGL
                    tex.eColorSpace = ovr.ColorSpace_Gamma
                    if bounds is None:
                        self._compositor.submit(eye, tex)
                    else:
                        b = ovr.VRTextureBounds_t()
                        b.uMin, b.vMin, b.uMax, b.vMax = bounds
                        self._compositor.submit(eye, tex, b)
                if self.readback:
                    self.last_images = renderer.images()
                self.frame_ms.append(1000.0 * (time.perf_counter() - t0))
                self.frames += 1
        except Exception as exc:  # runtime lost, compositor error, renderer failure: stop cleanly, report
            self.error = exc
            self.status = "lost"
            self._ready.set()
            print(f"plantvr headset mode stopped: {type(exc).__name__}: {exc}. The document keeps all work; "
                  f"call start() again when the headset is back.", file=sys.stderr)
        finally:
            self._stop.set()
            if renderer is not None:
                renderer.close()
            try:
                ovr.shutdown()
            except Exception as exc:  # noqa: BLE001  shutting down a lost runtime may fail too
                warnings.warn(f"openvr.shutdown failed: {exc!r}", RuntimeWarning, stacklevel=1)

    def _update_content(self, renderer) -> None:
        """Hand the newest prepared layers and prune preview to the renderer (every frame, render thread)."""
        content = self.content
        if content is not None and content[0] != self._drawn_content:
            renderer.set_content(content[1])
            self._drawn_content = content[0]
        c = self.controls
        prev = self.preview if (c.prune_mode and c.brush_visible) else None
        pid = prev[0] if prev else None
        if pid != self._drawn_preview:
            renderer.set_preview(prev[1] if prev else None)
            self._drawn_preview = pid

    def _update_overlays(self, renderer) -> None:
        c = self.controls
        renderer.set_model_matrix(c.scene.matrix)
        colors = getattr(self.doc, "colors", None) if c.cmap.labels else None
        rgb = None if colors is None else tuple(float(x) / 255.0 for x in colors.rgba[c.label, :3])
        renderer.set_brush(c.brush_center_room, c.brush_radius * c.scene.scale, c.brush_visible, c.prune_mode,
                           color=rgb)
        renderer.set_windows(c.windows)
        right = c._prev.right if c._prev is not None else None
        if c.windows and right is not None and right.valid:
            renderer.set_ray(right.position, right.position + 1.5 * right.heading)
        else:
            renderer.set_ray(None, None)
        left = c._prev.left if c._prev is not None else None
        if colors is None or left is None or not left.valid:
            renderer.set_wheel(None, None)
            return
        from .render import WHEEL_LOCAL, WHEEL_RADIUS, wheel_mesh
        thumb = None if c.wheel_thumb is None else (round(c.wheel_thumb[0], 2), round(c.wheel_thumb[1], 2))
        key = (c.label, colors.visible.tobytes(), colors.rgba.tobytes(), thumb)
        poly = None
        if key != self._wheel_key:
            poly = wheel_mesh(colors.rgba, colors.visible, c.label, thumb)
            self._wheel_key = key
        local = WHEEL_LOCAL.copy()
        local[:3, :3] *= WHEEL_RADIUS
        renderer.set_wheel(poly, np.asarray(left.pose, float) @ local)

    # -- command thread ------------------------------------------------------------------------------------
    def _command_loop(self) -> None:
        while not (self._stop.is_set() and self._queue.empty()):
            try:
                cmd = self._queue.get(timeout=0.02)
            except queue.Empty:
                continue
            batch = [cmd]
            while True:  # drain what is queued
                try:
                    batch.append(self._queue.get_nowait())
                except queue.Empty:
                    break
            try:
                for c in self.controls.coalesce(batch):
                    self._issue(c)
            finally:
                for _ in batch:
                    self._queue.task_done()

    def _issue(self, cmd: Command) -> None:
        try:
            preview = cmd.name == self.controls.cmap.by_gesture.get("prune_half_trigger")
            tree = self._tree() if preview else None
            result = issue(self.doc, cmd)
            if preview and tree is not None:
                self._preview = (tree, result)
            self.commands_done += 1
        except Exception as exc:  # noqa: BLE001  a rejected command must not kill headset mode
            self.command_errors.append((cmd, f"{type(exc).__name__}: {exc}"))

    def _tree(self) -> TreeArrays | None:
        return next((c for c in self.doc.scene().values() if isinstance(c, TreeArrays)), None)

    # -- mesh thread ---------------------------------------------------------------------------------------
    def eye_model(self) -> np.ndarray:
        """(3,) eye midpoint (head position) in model space."""
        return self.controls.scene.to_model(np.asarray(self.hmd_pose, float)[:3, 3])

    def _mesh_loop(self) -> None:
        """The headset's content: a View of the document that is never rendered (its layers follow the document
        on the thread of each change, as a notebook's View does); its snapshot goes to the render thread."""
        from ..view import View
        view = built = built_eye = built_preview = None
        n = n_preview = 0
        try:
            view = View(self.doc, off_screen=True, window_size=(16, 16), ground=False, show_leaves=self.leaves,
                        depth_cue=self.depth_cue, background=self.background,
                        sides=(self.tube_sides, max(self.tube_sides, 12)))
            while not self._stop.is_set():
                version = view.drawn_version
                eye = self.eye_model() if self.depth_cue else None
                if eye is not None and built_eye is not None and (
                        np.linalg.norm(eye - built_eye) <= self.eye_step * self.size):
                    eye = None                           # the depth cue is redone when the head moved enough
                if version != built or eye is not None:
                    try:
                        n += 1
                        self.content = (n, view.snapshot(eye=eye))
                    except Exception as exc:  # noqa: BLE001  a bad scene must not kill headset mode
                        self.command_errors.append((Command("mesh"), repr(exc)))
                    built, self.content_version = version, version
                    built_eye = built_eye if eye is None else eye
                pv = self._preview
                if pv is not None and pv is not built_preview:
                    n_preview += 1
                    self.preview = (n_preview, preview_mesh(pv[0], pv[1], self.tube_sides))
                    built_preview = pv
                self._stop.wait(0.005)
        except Exception as exc:  # noqa: BLE001  the document's scene could not be drawn at all
            self.command_errors.append((Command("mesh"), repr(exc)))
        finally:
            if view is not None:
                view.close()


_HEADSETS: weakref.WeakKeyDictionary[Document, Headset] = weakref.WeakKeyDictionary()
_HEADSETS_LOCK = threading.Lock()


def attach(doc, **kwargs) -> Headset:
    """Return the headset of a document, creating it on first use; keyword arguments (those of
    :class:`Headset`) apply on creation only. The headset attaches from outside: the document holds no reference
    to it (a weak registry here maps documents to their headsets).

    Examples
    --------
    >>> headset = plantvr.vr.attach(model)   # doctest: +SKIP
    >>> headset.start()                       # doctest: +SKIP
    """
    with _HEADSETS_LOCK:
        headset = _HEADSETS.get(doc) if isinstance(doc, Document) else None
        if headset is None:
            headset = Headset(doc, **kwargs)
            _HEADSETS[doc] = headset
        return headset


def replay(doc, frames: list[InputFrame], controls: Controls | None = None, **kwargs) -> Controls:
    """Replay recorded headset frames into ``doc`` without a headset, through a :class:`Headset`'s control map and
    command path (:meth:`Headset.replay`); returns the controls. ``kwargs`` are those of :class:`Headset`."""
    return Headset(doc, controls=controls, **kwargs).replay(frames)

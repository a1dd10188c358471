"""OpenVR bridge mirroring the model into a headset (spec 000_treewand §4.1, §4.10, §4.12; 000_vine §4.2–4.5).

Three threads, none of which holds the model lock while rendering:

* **render** (``plantvr-vr-render``): ``waitGetPoses`` (OpenVR running start), read the controllers, run
  the control map, render both eyes of the latest prepared meshes, submit both textures. No simulation and
  no model command runs here (§4.10).
* **commands** (``plantvr-vr-commands``): issues the control map's commands on the model through the same
  methods the notebook uses (so they land in ``model.events``); consecutive paint stamps of one radius
  become one ``paint_stroke``.
* **mesher** (``plantvr-vr-mesher``): turns each new ``model.snapshot`` into tube and marker meshes and
  publishes them by swapping one reference (the render thread always takes the newest complete set).
"""
from __future__ import annotations

import importlib
import queue
import sys
import threading
import time
import warnings
from collections import deque
from typing import Any

import numpy as np

from .._validation import check_choice, check_int, check_range
from .controls import Command, ControllerState, Controls, InputFrame, SceneTransform, apply_command
from .math3d import hmd34_to_array, hmd44_to_array

__all__ = ["VRBridge", "attach", "HISTOGRAM_EDGES_MS"]

#: Frame-time histogram bins, ms: 90 fps (11.1 ms), 45 fps, 30 fps (§4.10) ...
HISTOGRAM_EDGES_MS = (0.0, 5.5, 11.1, 22.2, 33.3, 50.0, 100.0, 250.0, 1000.0, np.inf)

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


def _tube_mesh(snap, sides: int):
    """Fast headset branch mesh: VTK tube filter over the internode segments, radius per internode."""
    import pyvista as pv  # noqa: PLC0415
    kids = np.flatnonzero(np.asarray(snap.parent) >= 0)
    if not len(kids):
        return pv.PolyData()
    k = len(kids)
    pts = np.concatenate([snap.pos[snap.parent[kids]], snap.pos[kids]])
    poly = pv.PolyData(pts, lines=np.column_stack([np.full(k, 2), np.arange(k), np.arange(k) + k]).ravel())
    r = np.asarray(snap.radius, float)[kids]
    poly["radius"] = np.concatenate([r, r])
    return poly.tube(scalars="radius", absolute=True, n_sides=sides, capping=False)


def _mesh_from_snapshot(snap, sides: int, params: dict | None = None, leaves: bool = False,
                        kind: str = "tubes"):
    """(branches, markers, leaves) vtkPolyData of a snapshot.

    ``kind="tubes"``: :func:`_tube_mesh` (fast, no leaves); ``"cylinders"``: the shared generalized-cylinder
    geometry of :func:`plantvr.view.branch_mesh` (spec 000_treewand §3.2), with leaves when asked.
    """
    import pyvista as pv  # noqa: PLC0415
    leaf = pv.PolyData()
    if not snap.n_internodes:
        branches = pv.PolyData()
    elif kind == "tubes":
        branches = _tube_mesh(snap, sides)
    else:
        from ..view import branch_mesh  # noqa: PLC0415
        out = branch_mesh(snap, params, leaves=leaves, sides=sides)
        branches, leaf = out if isinstance(out, tuple) else (out, pv.PolyData())
    markers = pv.PolyData(np.asarray(snap.markers, float)) if len(snap.markers) else pv.PolyData()
    return branches, markers, leaf


def _preview_mesh(snap, nodes: np.ndarray, sides: int):
    """Red tubes over the internodes a prune would remove (§4.4 partial trigger)."""
    import pyvista as pv  # noqa: PLC0415
    nodes = np.asarray(nodes, np.int64)
    nodes = nodes[(nodes < len(snap.pos)) & (nodes >= 0)]
    nodes = nodes[snap.parent[nodes] >= 0] if len(nodes) else nodes
    if not len(nodes):
        return pv.PolyData()
    pts = np.concatenate([snap.pos[snap.parent[nodes]], snap.pos[nodes]])
    k = len(nodes)
    poly = pv.PolyData(pts, lines=np.column_stack([np.full(k, 2), np.arange(k), np.arange(k) + k]).ravel())
    r = np.asarray(snap.radius, float)[nodes] * 1.15 + 1e-3
    poly["radius"] = np.concatenate([r, r])
    return poly.tube(scalars="radius", absolute=True, n_sides=sides, capping=True)


class VRBridge:
    """Headset mode for a :class:`plantvr.Model`: ``start()`` opens it, ``stop()`` ends it.

    Parameters
    ----------
    model : plantvr.Model
        The shared model; the bridge reads its snapshots and issues its commands.
    layout : {"side", "pair"}
        Stereo layout of :class:`~plantvr.vr.render.StereoRenderer`.
    tube_sides : int
        Sides of the branch tubes (6 ≈ the thesis' LOD 6/32 budget).
    render_scale : float
        Fraction of the runtime's recommended per-eye size to render (1.0 in a headset).
    mesh : {"tubes", "cylinders"}
        Branch mesh: VTK tubes over the internodes (fast, the default) or the shared generalized
        cylinders of :func:`plantvr.view.branch_mesh` (smooth joins, leaves; its first build compiles
        numba kernels, ~1 s; later builds cost about 1.3x the tubes, ``benchmarks/vr_stereo.py``).
    leaves : bool
        With ``mesh="cylinders"``, also show the leaves (spec 000_treewand §3.4).
    record : bool
        Keep every :class:`~plantvr.vr.controls.InputFrame` in :attr:`recording` (replay with
        :func:`plantvr.vr.replay`).
    readback : bool
        Copy both eye images to :attr:`last_images` every frame (tests, thumbnails; slow).

    Examples
    --------
    >>> bridge = plantvr.vr.attach(model)      # doctest: +SKIP
    >>> bridge.start()                          # doctest: +SKIP
    >>> bridge.stop()                           # doctest: +SKIP
    """

    def __init__(self, model, *, layout: str = "side", tube_sides: int = 6, render_scale: float = 1.0,
                 mesh: str = "tubes", leaves: bool = False, record: bool = False, readback: bool = False,
                 near: float = 0.05,
                 far: float = 100.0):
        self.model = model
        self.tube_sides = check_int("tube_sides", tube_sides, 3, 64)
        self.leaves = bool(leaves)
        self.mesh = check_choice("mesh", mesh, ("tubes", "cylinders"))
        self._init_common(layout=layout, render_scale=render_scale, near=near, far=far, record=record,
                          readback=readback)
        self.controls = Controls(brush_radius=model.brush_radius, prune_mode=model.prune_mode,
                                 scene=SceneTransform())
        self._seen_radius = model.brush_radius
        self._seen_prune = model.prune_mode

    def _init_common(self, *, layout: str, render_scale: float, near: float, far: float, record: bool,
                     readback: bool) -> None:
        """Model-independent state (shared with :class:`plantvr.vr.vine_mode.VineBridge`)."""
        self.layout = check_choice("layout", layout, ("side", "pair"))
        self.render_scale = check_range("render_scale", render_scale, 0.0, 1.0, low_open=True)
        self.near = check_range("near", near, 0.0, 10.0, low_open=True)
        self.far = check_range("far", far, self.near, 1e6, low_open=True)
        self.record = bool(record)
        self.readback = bool(readback)
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
        self._meshes: tuple | None = None   # (snapshot version, branches, markers, leaves), swapped whole
        self._preview: tuple | None = None         # (snapshot, node indices) from the command worker
        self._preview_mesh: tuple | None = None    # (id, polydata)

    # -- lifecycle -----------------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        """True while the render thread runs."""
        return any(t.is_alive() for t in self._threads[:1])

    def start(self, *, timeout: float = 60.0) -> "VRBridge":
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
        """End headset mode: stop and join the threads, shut OpenVR down. The model keeps all work."""
        self._stop.set()
        me = threading.current_thread()
        for t in self._threads:
            if t is not me:
                t.join(timeout)
        if self.status not in ("lost",):
            self.status = "stopped"

    def wait_frames(self, n: int, timeout: float = 30.0) -> int:
        """Block until ``n`` more frames were rendered (or the bridge stopped); returns the frame count."""
        target = self.frames + n
        t_end = time.monotonic() + timeout
        while self.frames < target and self.running and time.monotonic() < t_end:
            time.sleep(0.002)
        return self.frames

    def wait_commands(self, timeout: float = 30.0) -> None:
        """Block until every queued controller command has been issued on the model."""
        t_end = time.monotonic() + timeout
        while (self._queue.unfinished_tasks or not self._queue.empty()) and time.monotonic() < t_end:
            time.sleep(0.002)

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
        self.projection = [hmd44_to_array(sysm.getProjectionMatrix(e, self.near, self.far))
                           for e in (ovr.Eye_Left, ovr.Eye_Right)]

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

    def _sync_from_model(self) -> None:
        """Adopt brush radius / prune mode when the model's value changes (a notebook widget, or our own queued
        command landing); a headset change still in the queue is not undone by the model's older value."""
        r, p = self.model.brush_radius, self.model.prune_mode
        if r != self._seen_radius:
            self._seen_radius = self.controls.brush_radius = r
        if p != self._seen_prune:
            self._seen_prune = self.controls.prune_mode = p

    def _render_loop(self) -> None:
        from .render import StereoRenderer  # noqa: PLC0415  (VTK only on this thread)
        ovr = self._openvr
        renderer = None
        try:
            renderer = StereoRenderer(*self.render_size, layout=self.layout, near=self.near, far=self.far)
            poses = (ovr.TrackedDevicePose_t * ovr.k_unMaxTrackedDeviceCount)()
            event = ovr.VREvent_t()
            self._drawn_mesh, self._drawn_preview = None, None
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
                self._sync_from_model()
                self._enqueue(self.controls.update(frame))
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
            print(f"plantvr headset mode stopped: {type(exc).__name__}: {exc}. The model keeps all work; "
                  f"call start() again when the headset is back.", file=sys.stderr)
        finally:
            self._stop.set()
            if renderer is not None:
                renderer.close()
            try:
                ovr.shutdown()
            except Exception as exc:  # noqa: BLE001  shutting down a lost runtime may fail too
                warnings.warn(f"openvr.shutdown failed: {exc!r}", RuntimeWarning, stacklevel=1)

    def _enqueue(self, cmds: list[Command]) -> None:
        """Queue this frame's commands for the command thread (hook: subclasses route their own)."""
        for cmd in cmds:
            self._queue.put(cmd)

    def _update_content(self, renderer) -> None:
        """Hand the newest prepared meshes to the renderer (hook: the render thread calls it every frame)."""
        meshes = self._meshes
        if meshes is not None and meshes[0] != self._drawn_mesh:
            renderer.set_meshes(meshes[1], meshes[2], leaves=meshes[3])
            self._drawn_mesh = meshes[0]
        show = self.controls.prune_mode and self.controls.brush_visible
        prev = self._preview_mesh if show else None
        pid = prev[0] if prev else None
        if pid != self._drawn_preview:
            import vtk  # noqa: PLC0415
            renderer.set_meshes(None, None, prev[1] if prev else vtk.vtkPolyData())
            self._drawn_preview = pid

    def _update_overlays(self, renderer) -> None:
        c = self.controls
        renderer.set_model_matrix(c.scene.matrix)
        renderer.set_brush(c.brush_center_room, c.brush_radius * c.scene.scale, c.brush_visible, c.prune_mode)
        renderer.set_windows(c.windows)
        right = self._prev_right()
        if c.windows and right is not None and right.valid:
            end = right.position + 1.5 * right.heading
            renderer.set_ray(right.position, end)
        else:
            renderer.set_ray(None, None)

    def _prev_right(self) -> ControllerState | None:
        prev = self.controls._prev
        return prev.right if prev is not None else None

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
                for c in self._coalesce(batch):
                    self._issue(c)
            finally:
                for _ in batch:
                    self._queue.task_done()

    @staticmethod
    def _coalesce(batch: list[Command]) -> list[Command]:
        """Merge runs of paint stamps with one radius into a paint_stroke; keep only the last preview."""
        out: list[Command] = []
        last_preview = max((i for i, c in enumerate(batch) if c.name == "prune_preview"), default=-1)
        for i, c in enumerate(batch):
            if c.name == "prune_preview" and i != last_preview:
                continue
            if c.name == "paint" and out and out[-1].name in ("paint", "paint_stroke") \
                    and out[-1].kwargs["radius"] == c.kwargs["radius"]:
                prev = out.pop()
                pts = [prev.kwargs["center"]] if prev.name == "paint" else list(prev.kwargs["points"])
                out.append(Command("paint_stroke", {"points": pts + [c.kwargs["center"]],
                                                    "radius": c.kwargs["radius"]}))
            else:
                out.append(c)
        return out

    def _issue(self, cmd: Command) -> None:
        try:
            snap = self.model.snapshot
            result = apply_command(self.model, cmd)
            if cmd.name == "prune_preview":
                self._preview = (snap, result)
            self.commands_done += 1
        except Exception as exc:  # a rejected command must not kill headset mode
            self.command_errors.append((cmd, f"{type(exc).__name__}: {exc}"))

    # -- mesh thread ---------------------------------------------------------------------------------------
    def _mesh_loop(self) -> None:
        built = None
        built_preview = None
        n_preview = 0
        while not self._stop.is_set():
            snap = self.model.snapshot
            if snap.version != built:
                try:
                    self._meshes = (snap.version, *_mesh_from_snapshot(
                        snap, self.tube_sides, self.model.params, self.leaves, self.mesh))
                except Exception as exc:  # noqa: BLE001
                    self.command_errors.append((Command("mesh"), repr(exc)))
                built = snap.version
            pv = self._preview
            if pv is not None and pv is not built_preview:
                n_preview += 1
                self._preview_mesh = (n_preview, _preview_mesh(pv[0], pv[1], self.tube_sides))
                built_preview = pv
            self._stop.wait(0.005)


def attach(model, **kwargs) -> VRBridge:
    """Return the model's headset bridge, creating it on first use (``model.vr`` in the notebook).

    The bridge is kept on the model as ``model._vr_bridge``; keyword arguments apply on creation only.
    """
    bridge = getattr(model, "_vr_bridge", None)
    if bridge is None:
        bridge = VRBridge(model, **kwargs)
        model._vr_bridge = bridge
    return bridge

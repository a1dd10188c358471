"""ViNE mode in the headset: a segmentation (or its display proxy) painted in stereo (spec 000_vine §2.1–2.6, §4.2–4.5).

``plantvr.vr.attach_segmentation(seg, proxy=None)`` returns a :class:`VineBridge`; ``start()`` opens it,
``stop()`` ends it. Three threads, as in :class:`~plantvr.vr.bridge.VRBridge` (§4.2):

* **render**: ``waitGetPoses``, controllers → :class:`~plantvr.vr.vine_controls.VineControls`, view
  manipulation, both eyes of the newest coloured surface, submit. No painting runs here.
* **commands** (the ViNE *worker*): issues paint stamps, strokes, undo/redo, hide/show and saved views on the
  segmentation through its public methods. Every change reaches a :class:`~plantvr.vine.buffers.TripleBuffer`
  of the displayed labels through the segmentation's (or proxy's) observer, so a paint that takes many frames
  never blocks rendering: the renderer keeps drawing the last completed labels (§4.3).
* **mesher**: turns the newest completed label buffer into per-vertex RGB colours (colour table, hidden
  colours' triangles dropped, §2.6 option 2) with the depth cue of §2.2 (colours blended toward the background
  by distance from the eye midpoint, normalised by the coarse hull), and publishes one vtkPolyData.
"""
from __future__ import annotations

import threading

import numpy as np

from .._validation import check_range
from ..vine.buffers import TripleBuffer
from ..vine.depthcue import coarse_hull, depth_cue_colors
from ..vine.proxy import DisplayProxy
from ..vine.segmentation import Segmentation
from .bridge import VRBridge
from .controls import Command, SceneTransform
from .vine_controls import VineControls, apply_vine_command

__all__ = ["VineBridge", "attach_segmentation", "wheel_mesh"]

#: Room point the model's bounding-box centre is placed at on start (m; in reach of a standing user).
HOME = np.array([0.0, 1.1, -0.6])
#: Room size of the model's bounding-box diagonal on start (m).
HOME_SIZE = 0.8


def _surface_poly(vertices: np.ndarray, faces: np.ndarray, rgb: np.ndarray):
    """vtkPolyData of a triangle mesh with a uint8 ``rgb`` point array."""
    import pyvista as pv
    f = np.asarray(faces, np.int64)
    if not len(f):
        poly = pv.PolyData(np.asarray(vertices, np.float32))
    else:
        poly = pv.PolyData.from_regular_faces(np.asarray(vertices, np.float32), f)
    poly.point_data["rgb"] = np.ascontiguousarray(rgb[:, :3], np.uint8)
    return poly


#: Wheel radius over the left trackpad (m): 1.5x a Vive pad of ~2 cm radius (000_vine §2.4.1).
WHEEL_RADIUS = 0.03
#: Wheel plane in the controller frame: pad x → x, pad y → −z (forward), normal → +y, pad centre offset.
_WHEEL_LOCAL = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0.012], [0, -1.0, 0, 0.05], [0, 0, 0, 1.0]])


def wheel_mesh(rgba: np.ndarray, visible: np.ndarray, selected: int, thumb: tuple[float, float] | None = None,
               *, segments: int = 6):
    """Colour-wheel polydata on the unit disc (000_vine §2.4.1, Fig. 5.9; §2.6, Fig. 5.11).

    Slice k (counter-clockwise from +x, as :func:`~plantvr.vr.vine_controls.wheel_label`) has colour k;
    the selected slice is extruded (+z), hidden colours are drawn darkened with a light radial line
    through the slice, and a small dark disc marks the thumb. Cell array ``rgb`` (uint8).
    """
    import pyvista as pv
    k = len(rgba)
    pts, tris, cols = [], [], []

    def fan(a0, a1, r0, r1, z, rgb):
        base = len(pts)
        angs = np.linspace(a0, a1, segments + 1)
        for a in angs:
            pts.append((r0 * np.cos(a), r0 * np.sin(a), z))
            pts.append((r1 * np.cos(a), r1 * np.sin(a), z))
        for i in range(segments):
            q = base + 2 * i
            tris.extend([(q, q + 1, q + 3), (q, q + 3, q + 2)])
            cols.extend([rgb, rgb])

    step = 2 * np.pi / k
    for i in range(k):
        rgb = np.asarray(rgba[i, :3], float)
        z = 0.15 if i == selected else 0.0
        if not visible[i]:
            fan(i * step, (i + 1) * step, 0.0, 1.0, z, 0.3 * rgb)
            mid = (i + 0.5) * step
            fan(mid - 0.04, mid + 0.04, 0.2, 0.95, z + 0.01, (230.0, 230.0, 230.0))   # radial line
        else:
            fan(i * step, (i + 1) * step, 0.0, 1.0, z, rgb)
    if thumb is not None:
        x, y = float(thumb[0]), float(thumb[1])
        base = len(pts)
        pts.append((x, y, 0.25))
        for a in np.linspace(0, 2 * np.pi, 9)[:-1]:
            pts.append((x + 0.07 * np.cos(a), y + 0.07 * np.sin(a), 0.25))
        for j in range(8):
            tris.append((base, base + 1 + j, base + 1 + (j + 1) % 8))
            cols.append((20.0, 20.0, 20.0))
    poly = pv.PolyData.from_regular_faces(np.asarray(pts, np.float32), np.asarray(tris, np.int64))
    poly.cell_data["rgb"] = np.clip(np.rint(cols), 0, 255).astype(np.uint8)
    return poly


class VineBridge(VRBridge):
    """Headset mode for a :class:`plantvr.vine.Segmentation` (ViNE): paint, hide, undo, views, manipulation.

    Parameters
    ----------
    seg : Segmentation
        The segmentation; the only truth for labels (painted through its public methods).
    proxy : DisplayProxy, optional
        Decimated display copy of ``seg`` (built with ``observe=True``); drawn instead of the full mesh.
    layout, render_scale, near, far, record, readback
        As :class:`~plantvr.vr.bridge.VRBridge`.
    depth_cue : bool
        Blend colours toward ``background`` with distance (§2.2, Eq. 5.8, normalised variant).
    background : 3 ints
        Depth-cue target colour (dark: "further = darker", §2.2.1 [INFERRED]).
    eye_step : float
        Fraction of the model size the eye must move before the depth cue is recomputed.
    scene : SceneTransform, optional
        Initial placement; default: the model's bounding box centred at :data:`HOME`, diagonal
        :data:`HOME_SIZE` metres.

    Attributes
    ----------
    buffer : TripleBuffer
        Displayed labels (proxy labels with a proxy), published on every change.
    controls : VineControls
    """

    def __init__(self, seg, proxy=None, *, layout: str = "side", render_scale: float = 1.0, near: float = 0.05,
                 far: float = 100.0, record: bool = False, readback: bool = False, depth_cue: bool = True,
                 background=(0, 0, 0), eye_step: float = 0.02, scene: SceneTransform | None = None):
        if not isinstance(seg, Segmentation):
            raise ValueError(f"seg must be a plantvr.vine.Segmentation, got {type(seg).__name__}")  # noqa: TRY004
        if proxy is not None and (not isinstance(proxy, DisplayProxy) or proxy.seg is not seg):
            raise ValueError("proxy must be a DisplayProxy built from seg (DisplayProxy(seg))")
        if scene is not None and not isinstance(scene, SceneTransform):
            raise ValueError(f"scene must be a SceneTransform, got {type(scene).__name__}")
        self.eye_step = check_range("eye_step", eye_step, 0.0, 1.0)
        bg = np.asarray(background, float)
        if bg.shape != (3,) or bg.min() < 0 or bg.max() > 255:
            raise ValueError(f"background must be 3 values in [0, 255], got {list(np.ravel(bg))}")
        self._init_common(layout=layout, render_scale=render_scale, near=near, far=far, record=record,
                          readback=readback)
        self.model = self.seg = seg
        self.proxy = proxy
        self.display = proxy if proxy is not None else seg
        self.depth_cue = bool(depth_cue)
        self.background = tuple(round(x) for x in bg)
        lo, hi = seg.vertices.min(axis=0).astype(float), seg.vertices.max(axis=0).astype(float)
        self.size = float(np.linalg.norm(hi - lo)) or 1.0
        if scene is None:
            s = HOME_SIZE / self.size
            scene = SceneTransform(scale=s, translation=HOME - s * 0.5 * (lo + hi))
        self.controls = VineControls(n_labels=len(seg.colors), label=min(1, len(seg.colors) - 1),
                                     brush_radius=min(0.03 * self.size, seg.max_radius),
                                     max_radius=seg.max_radius, scene=scene)
        self.buffer = TripleBuffer(self.display.labels)
        self._table_version = 0
        self._surface: tuple | None = None       # (build id, vtkPolyData), swapped whole
        self._drawn_surface = None
        self._wheel_key = None
        self._hull = None
        self._sync_from_model()
        self.display.observe(self._on_change)

    # -- worker → triple buffer ----------------------------------------------------------------------------
    def _on_change(self, kind: str, ids) -> None:
        """Observer of the displayed labels: publish sparse label changes, or everything on table changes."""
        if kind == "labels" and ids is not None:
            ids = np.asarray(ids, np.int64)
            self.buffer.publish(ids, self.display.labels[ids])
        else:
            self._table_version += 1
            self.buffer.publish(None, self.display.labels)

    def close(self) -> None:
        """Stop headset mode and stop following the segmentation."""
        self.stop()
        self.display.unobserve(self._on_change)

    def stop(self, timeout: float | None = 30.0) -> None:
        """End headset mode; a stroke left open by a held trigger is committed (one undo item)."""
        super().stop(timeout)
        if self.controls.painting:
            self.controls.painting = False
            self._issue(Command("end_stroke"))

    # -- notebook-side helpers (the thesis' keyboard) ------------------------------------------------------
    def save_view(self) -> int | None:
        """Save the current view for the current head pose; returns its number (``None`` looking straight
        up/down)."""
        view = self.controls.current_view(self.hmd_pose)
        return None if view is None else self.seg.add_view(view)

    def next_view(self) -> int | None:
        """Load the next saved view for the current head pose; returns its number."""
        return self.controls.next_view(self.hmd_pose)

    # -- render thread -------------------------------------------------------------------------------------
    def _sync_from_model(self) -> None:
        c = self.controls
        c.visible = self.seg.colors.visible
        c.n_labels = len(self.seg.colors)
        c.views = self.seg.views

    def _enqueue(self, cmds: list[Command]) -> None:
        for cmd in cmds:
            self._queue.put(cmd)

    def _update_content(self, renderer) -> None:
        if self._drawn_surface is None:
            renderer.set_ground(False)
            self._drawn_surface = -1
        surf = self._surface
        if surf is not None and surf[0] != self._drawn_surface:
            renderer.set_surface(surf[1])
            self._drawn_surface = surf[0]

    def _update_overlays(self, renderer) -> None:
        c = self.controls
        renderer.set_model_matrix(c.scene.matrix)
        rgb = tuple(float(x) / 255.0 for x in self.seg.colors.rgba[c.label, :3])
        renderer.set_brush(c.brush_center_room, c.brush_radius * c.scene.scale, c.brush_visible, False,
                           color=rgb)
        renderer.set_windows({})
        renderer.set_ray(None, None)
        left = self.controls._prev.left if self.controls._prev is not None else None
        if left is None or not left.valid:
            renderer.set_wheel(None, None)
            return
        colors = self.seg.colors
        thumb = None if c.wheel_thumb is None else (round(c.wheel_thumb[0], 2), round(c.wheel_thumb[1], 2))
        key = (c.label, colors.visible.tobytes(), colors.rgba.tobytes(), thumb)
        poly = None
        if key != self._wheel_key:
            poly = wheel_mesh(colors.rgba, colors.visible, c.label, thumb)
            self._wheel_key = key
        local = _WHEEL_LOCAL.copy()
        local[:3, :3] *= WHEEL_RADIUS
        renderer.set_wheel(poly, np.asarray(left.pose, float) @ local)

    # -- command (worker) thread ---------------------------------------------------------------------------
    @staticmethod
    def _coalesce(batch: list[Command]) -> list[Command]:
        return batch

    def _issue(self, cmd: Command) -> None:
        try:
            apply_vine_command(self.seg, cmd)
            self.commands_done += 1
        except Exception as exc:  # noqa: BLE001  a rejected command must not kill headset mode
            self.command_errors.append((cmd, f"{type(exc).__name__}: {exc}"))

    # -- mesh thread ---------------------------------------------------------------------------------------
    def eye_model(self) -> np.ndarray:
        """(3,) eye midpoint (head position) in model space."""
        return self.controls.scene.to_model(np.asarray(self.hmd_pose, float)[:3, 3])

    def build_surface(self, labels: np.ndarray, eye_model: np.ndarray | None = None):
        """vtkPolyData of the displayed mesh for ``labels``: colours, hidden triangles dropped, depth cue."""
        d = self.display
        colors = d.colors
        rgba = colors.rgba[labels]
        vis = colors.visible[labels]
        f = d.faces
        faces = f[vis[f[:, 0]] & vis[f[:, 1]] & vis[f[:, 2]]]
        if self.depth_cue and eye_model is not None and len(d.vertices) >= 4:
            if self._hull is None:
                self._hull = coarse_hull(d.vertices, n_vertices=min(274, max(5, len(d.vertices) // 4)))
            rgba = depth_cue_colors(rgba, d.vertices, eye_model, self._hull, background=self.background)
        return _surface_poly(d.vertices, faces, rgba)

    def _mesh_loop(self) -> None:
        built_key, built_eye, n = None, None, 0
        while not self._stop.is_set():
            eye = self.eye_model() if self.depth_cue else None
            moved = built_eye is None or (eye is not None and
                                          np.linalg.norm(eye - built_eye) > self.eye_step * self.size)
            labels, version = self.buffer.acquire()
            try:
                key = (version, self._table_version)
                if key != built_key or moved:
                    try:
                        poly = self.build_surface(labels, eye)
                        n += 1
                        self._surface = (n, poly)
                    except Exception as exc:  # noqa: BLE001
                        self.command_errors.append((Command("mesh"), repr(exc)))
                    built_key, built_eye = key, eye if eye is not None else np.zeros(3)
            finally:
                self.buffer.release()
            self._stop.wait(0.005)


_BRIDGES_LOCK = threading.Lock()


def attach_segmentation(seg, proxy=None, **kwargs) -> VineBridge:
    """Return the headset bridge of a segmentation (ViNE mode), creating it on first use.

    The bridge is kept on ``seg`` as ``seg._vr_bridge`` and reused while ``proxy`` is the same; keyword
    arguments (those of :class:`VineBridge`) apply on creation only.

    Examples
    --------
    >>> bridge = plantvr.vr.attach_segmentation(seg)   # doctest: +SKIP
    >>> bridge.start()                                  # doctest: +SKIP
    >>> bridge.stop()                                   # doctest: +SKIP
    """
    with _BRIDGES_LOCK:
        bridge = getattr(seg, "_vr_bridge", None)
        if bridge is None or bridge.proxy is not proxy:
            if bridge is not None:
                if bridge.running:
                    raise RuntimeError("the segmentation's headset bridge is running with another proxy; "
                                       "stop() it first")
                bridge.close()
            bridge = VineBridge(seg, proxy, **kwargs)
            seg._vr_bridge = bridge
        return bridge

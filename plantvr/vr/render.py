"""Offscreen stereo rendering of a document's content layers with VTK (spec 000_vine §4.5, 000_treewand §4.10).

Two layouts, measured in ``benchmarks/vr_stereo.py``:

* ``"side"``: one render window twice the eye width with a renderer per eye (left half, right half) that
  share actors, mappers and GPU buffers; both eyes are submitted from one texture with
  ``VRTextureBounds_t`` halves. VTK has no single-pass stereo (000_vine §4.5): it is still two draws.
* ``"pair"``: one window (GL context) per eye, each with its own mappers over the same meshes.

Each eye's camera is the HMD pose times OpenVR's eye-to-head transform, with OpenVR's projection
(x/y rows) and an OpenGL depth row (:func:`~plantvr.vr.math3d.gl_projection`). Content is drawn by a View's
layers (:meth:`plantvr.view.View.snapshot`, taken on the bridge's mesher thread); :meth:`StereoRenderer.set_content` copies
each layer actor into this thread's contexts; the document's placement in the room is the actors' user matrix, so
view manipulation never rebuilds a mesh.
"""
from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

from .._validation import check_choice, check_int, check_range
from ..view.polydata import brush_sphere, ground_disc, mesh_polydata, points_polydata, segment_polydata, window_quad
from .math3d import gl_projection

__all__ = ["LAYOUTS", "WHEEL_LOCAL", "WHEEL_RADIUS", "StereoRenderer", "wheel_mesh"]

LAYOUTS = ("side", "pair")
GROW, PRUNE = (0.18, 0.8, 0.25), (0.88, 0.19, 0.19)
_WINDOW_RGB = {"appearance": (0.18, 0.8, 0.25), "tree_form": (0.88, 0.19, 0.19), "light": (0.19, 0.38, 0.88)}


def _vtk_matrix(a: np.ndarray, out: vtk.vtkMatrix4x4 | None = None) -> vtk.vtkMatrix4x4:
    m = out or vtk.vtkMatrix4x4()
    for i in range(4):
        for j in range(4):
            m.SetElement(i, j, float(a[i, j]))
    m.Modified()
    return m


class _Scene:
    """The actors of one GL context: content layers, prune preview, ground, brush, ray, windows, colour wheel."""

    def __init__(self) -> None:
        self.model_matrix = vtk.vtkMatrix4x4()
        self.content: dict[str, vtk.vtkActor] = {}
        self._sources: dict[str, vtk.vtkActor] = {}     # the layer actor each content actor copies
        self._textures: dict[int, tuple] = {}           # id(layer texture): (its texture, this context's copy)
        self.renderers: list[vtk.vtkRenderer] = []
        self.preview = self._actor(points_polydata(), PRUNE, model=True)
        self.ground = self._actor(ground_disc(), (0.61, 0.70, 0.48), model=True)
        self.ground.GetProperty().SetAmbient(0.7)
        self.ground.GetProperty().SetDiffuse(0.3)
        self.brush_matrix = vtk.vtkMatrix4x4()
        self.brush = self._actor(brush_sphere(), GROW)
        self.brush.SetUserMatrix(self.brush_matrix)
        self.brush.GetProperty().SetOpacity(0.3)
        self.ray_line = segment_polydata()
        self.ray = self._actor(self.ray_line, (1.0, 1.0, 1.0))
        self.ray.GetProperty().SetLineWidth(2)
        self.windows: dict[str, tuple[vtk.vtkActor, vtk.vtkMatrix4x4]] = {}
        for name, rgb in _WINDOW_RGB.items():
            m = vtk.vtkMatrix4x4()
            a = self._actor(window_quad(), rgb)
            a.SetUserMatrix(m)
            a.GetProperty().SetOpacity(0.85)
            a.SetVisibility(False)
            self.windows[name] = (a, m)
        self.wheel_matrix = vtk.vtkMatrix4x4()                                      # ViNE colour wheel
        self.wheel = self._actor(points_polydata(), (1.0, 1.0, 1.0))
        self.wheel.SetUserMatrix(self.wheel_matrix)
        self.wheel.SetVisibility(False)
        self.wheel.GetProperty().SetLighting(False)
        self.actors = [self.ground, self.wheel, self.preview, self.brush, self.ray,
                       *(a for a, _ in self.windows.values())]
        self.ray.SetVisibility(False)
        self.brush.SetVisibility(False)

    def _actor(self, poly, rgb, model: bool = False) -> vtk.vtkActor:
        mapper = vtk.vtkPolyDataMapper()
        if poly is not None:
            mapper.SetInputData(poly)
        mapper.ScalarVisibilityOff()
        a = vtk.vtkActor()
        a.SetMapper(mapper)
        a.GetProperty().SetColor(*rgb)
        if model:
            a.SetUserMatrix(self.model_matrix)
        return a

    def show(self, frame: dict[str, tuple]) -> None:
        """Draw ``frame`` (``{name: (PolyData, layer actor)}``, :meth:`plantvr.view.View.snapshot`):
        one actor of this context per name, with the layer actor's mapper settings, property and texture, over
        the frame's PolyData (the mapper re-uploads only a new one); names not given are hidden."""
        for name, actor in self.content.items():
            if name not in frame:
                actor.SetVisibility(False)
        for name, (poly, src) in frame.items():
            actor = self.content.get(name)
            if actor is None or self._sources[name] is not src:
                for ren in self.renderers:
                    if actor is not None:
                        ren.RemoveActor(actor)
                actor = self.content[name] = self._copy(src)
                self._sources[name] = src
                for ren in self.renderers:
                    ren.AddActor(actor)
            mapper = actor.GetMapper()
            if mapper.GetInput() is not poly:
                mapper.SetInputData(poly)
            actor.SetVisibility(bool(src.GetVisibility()) and poly.GetNumberOfPoints() > 0)

    def _copy(self, src: vtk.vtkActor) -> vtk.vtkActor:
        """An actor of this context that looks as ``src`` (a layer's): its own mapper, property and texture."""
        mapper = vtk.vtkPolyDataMapper()
        mapper.ShallowCopy(src.GetMapper())            # colour mode, scalar array, lookup table
        prop = vtk.vtkProperty()
        prop.DeepCopy(src.GetProperty())
        actor = vtk.vtkActor()
        actor.SetMapper(mapper)
        actor.SetProperty(prop)
        actor.SetUserMatrix(self.model_matrix)
        tex = src.GetTexture()
        if tex is not None:
            own = self._textures.get(id(tex))
            if own is None or own[0] is not tex:
                copy = vtk.vtkTexture()
                copy.SetInputData(tex.GetInput())
                copy.SetRepeat(tex.GetRepeat())
                copy.SetInterpolate(tex.GetInterpolate())
                copy.SetMipmap(tex.GetMipmap())
                own = self._textures[id(tex)] = (tex, copy)
            actor.SetTexture(own[1])
        return actor


class StereoRenderer:
    """Offscreen two-eye renderer of content layers, brush, pointing ray, parameter windows and colour wheel.

    Create, use and close it on one thread (the bridge's render thread): a GL context is bound to it.

    Parameters
    ----------
    width, height : int
        Per-eye pixels (the runtime's recommended render size).
    layout : {"side", "pair"}
        One window with two renderers, or one window per eye.
    near, far : float
        Clipping planes, metres.
    """

    def __init__(self, width: int, height: int, *, layout: str = "side", near: float = 0.05,
                 far: float = 100.0):
        self.width = check_int("width", width, 1, 16384)
        self.height = check_int("height", height, 1, 16384)
        self.layout = check_choice("layout", layout, LAYOUTS)
        self.near = check_range("near", near, 0.0, 1e3, low_open=True)
        self.far = check_range("far", far, self.near, 1e6, low_open=True)
        self.windows: list[vtk.vtkRenderWindow] = []
        self.renderers: list[vtk.vtkRenderer] = []
        self.scenes: list[_Scene] = []
        n_win = 1 if layout == "side" else 2
        for w in range(n_win):
            rw = vtk.vtkRenderWindow()
            rw.SetOffScreenRendering(1)
            rw.SetMultiSamples(0)
            rw.SetSize(2 * self.width if layout == "side" else self.width, self.height)
            scene = _Scene()
            eyes = (0, 1) if layout == "side" else (w,)
            for eye in eyes:
                ren = vtk.vtkRenderer()
                if layout == "side":
                    ren.SetViewport(0.5 * eye, 0.0, 0.5 * eye + 0.5, 1.0)
                ren.SetBackground(0.81, 0.89, 0.96)
                ren.SetBackground2(0.96, 0.95, 0.92)
                ren.GradientBackgroundOn()
                vtk.vtkLightKit().AddLightsToRenderer(ren)      # the View's lighting (pyvista's light kit)
                for a in scene.actors:
                    ren.AddActor(a)
                scene.renderers.append(ren)
                cam = ren.GetActiveCamera()
                cam.SetUseExplicitProjectionTransformMatrix(True)
                rw.AddRenderer(ren)
                self.renderers.append(ren)
            self.windows.append(rw)
            self.scenes.append(scene)
        self._mesh_version = None

    # -- content -------------------------------------------------------------------------------------------
    def set_content(self, frame: dict[str, tuple]) -> None:
        """Show a frame of the View's layers, ``{name: (PolyData, layer actor)}``
        (:meth:`plantvr.view.View.snapshot`), in model space; uploaded on render."""
        for s in self.scenes:
            s.show(frame)

    def set_preview(self, poly: vtk.vtkPolyData | None) -> None:
        """Show the red prune preview (§4.4 partial trigger) in model space; ``None`` hides it."""
        for s in self.scenes:
            if poly is not None:
                s.preview.GetMapper().SetInputData(poly)
            s.preview.SetVisibility(poly is not None and poly.GetNumberOfPoints() > 0)

    def set_wheel(self, poly: vtk.vtkPolyData | None, pose: np.ndarray | None = None) -> None:
        """Show a colour-wheel mesh (uint8 ``rgb`` cell array) at a room pose (the left controller's pad,
        000_vine §2.4.1); ``poly=None`` keeps the mesh and only moves it, ``pose=None`` hides it."""
        for s in self.scenes:
            if poly is not None:
                mapper = s.wheel.GetMapper()
                mapper.SetInputData(poly)
                mapper.SetScalarModeToUseCellFieldData()
                mapper.SelectColorArray("rgb")
                mapper.SetColorModeToDirectScalars()
                mapper.ScalarVisibilityOn()
            s.wheel.SetVisibility(pose is not None)
            if pose is not None:
                _vtk_matrix(pose, s.wheel_matrix)

    def set_ground(self, visible: bool) -> None:
        """Show or hide the ground disc."""
        for s in self.scenes:
            s.ground.SetVisibility(bool(visible))

    def set_model_matrix(self, m: np.ndarray) -> None:
        """Model-to-room similarity (view manipulation)."""
        for s in self.scenes:
            _vtk_matrix(m, s.model_matrix)

    def set_brush(self, center_room: np.ndarray, radius_room: float, visible: bool, prune: bool,
                  color: tuple[float, float, float] | None = None) -> None:
        """Brush sphere on the wand: green to grow, red to prune (§4.3, §4.4), or ``color`` (RGB in [0, 1],
        the active ViNE label, 000_vine §2.4.1)."""
        m = np.eye(4) * radius_room
        m[3, 3] = 1.0
        m[:3, 3] = center_room
        for s in self.scenes:
            _vtk_matrix(m, s.brush_matrix)
            s.brush.SetVisibility(bool(visible))
            s.brush.GetProperty().SetColor(*(color if color is not None else PRUNE if prune else GROW))

    def set_ray(self, origin: np.ndarray | None, end: np.ndarray | None) -> None:
        """White pointing ray (§4.6); ``None`` hides it."""
        for s in self.scenes:
            s.ray.SetVisibility(origin is not None)
            if origin is not None:
                s.ray_line.points = np.array([origin, end], float)

    def set_windows(self, windows: dict[str, np.ndarray]) -> None:
        """Show the open parameter windows at their poses (coloured quads)."""
        for s in self.scenes:
            for name, (actor, mat) in s.windows.items():
                actor.SetVisibility(name in windows)
                if name in windows:
                    _vtk_matrix(windows[name], mat)

    # -- frames --------------------------------------------------------------------------------------------
    def render(self, eye_to_room: tuple[np.ndarray, np.ndarray],
               projections: tuple[np.ndarray, np.ndarray]) -> None:
        """Render both eyes: ``eye_to_room[e]`` (4x4 eye pose), ``projections[e]`` (OpenVR 4x4 projection)."""
        for eye, ren in enumerate(self.renderers):
            pose = np.asarray(eye_to_room[eye], float)
            cam = ren.GetActiveCamera()
            pos = pose[:3, 3]
            cam.SetPosition(*pos)
            cam.SetFocalPoint(*(pos - pose[:3, 2]))
            cam.SetViewUp(*pose[:3, 1])
            proj = gl_projection(projections[eye], self.near, self.far)
            cam.SetExplicitProjectionTransformMatrix(_vtk_matrix(proj))
        for rw in self.windows:
            rw.Render()

    def textures(self) -> list[tuple[int, tuple[float, float, float, float] | None]]:
        """Per eye: (GL texture handle, (uMin, vMin, uMax, vMax) bounds or ``None`` for the whole texture)."""
        out = []
        for eye in (0, 1):
            rw = self.windows[0 if self.layout == "side" else eye]
            tex = rw.GetRenderFramebuffer().GetColorAttachmentAsTextureObject(0)
            handle = int(tex.GetHandle()) if tex is not None else 0
            bounds = (0.5 * eye, 0.0, 0.5 * eye + 0.5, 1.0) if self.layout == "side" else None
            out.append((handle, bounds))
        return out

    def images(self) -> list[np.ndarray]:
        """Read back both eyes as (height, width, 3) uint8 arrays, top row first (slow; tests and stills)."""
        out = []
        for eye in (0, 1):
            rw = self.windows[0 if self.layout == "side" else eye]
            w, h = rw.GetSize()
            arr = vtk.vtkUnsignedCharArray()
            rw.GetPixelData(0, 0, w - 1, h - 1, 0, arr, 0)
            img = vtk_to_numpy(arr).reshape(h, w, 3)[::-1]
            if self.layout == "side":
                img = img[:, eye * self.width:(eye + 1) * self.width]
            out.append(np.ascontiguousarray(img))
        return out

    def close(self) -> None:
        """Free the GL contexts."""
        for rw in self.windows:
            rw.Finalize()
        self.windows, self.renderers, self.scenes = [], [], []


#: Wheel radius over the left trackpad (m): 1.5x a Vive pad of ~2 cm radius (000_vine §2.4.1).
WHEEL_RADIUS = 0.03
#: Wheel plane in the controller frame: pad x → x, pad y → −z (forward), normal → +y, pad centre offset.
WHEEL_LOCAL = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0.012], [0, -1.0, 0, 0.05], [0, 0, 0, 1.0]])


def wheel_mesh(rgba: np.ndarray, visible: np.ndarray, selected: int, thumb: tuple[float, float] | None = None,
               *, segments: int = 6):
    """Colour-wheel polydata on the unit disc (000_vine §2.4.1, Fig. 5.9; §2.6, Fig. 5.11).

    Slice k (counter-clockwise from +x, as :func:`~plantvr.vr.gestures.wheel_label`) has colour k;
    the selected slice is extruded (+z), hidden colours are drawn darkened with a light radial line
    through the slice, and a small dark disc marks the thumb. Cell array ``rgb`` (uint8).
    """
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
    return mesh_polydata(pts, tris, np.clip(np.rint(cols), 0, 255), cells=True)

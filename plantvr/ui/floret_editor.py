"""Floret editor widget for notebooks (spec 002 §2.1–§2.4, checklist C1–C4; issue 9).

The numeric work is :mod:`plantvr.flowers.floret`: a bilaterally symmetric clamped B-spline petal
(:func:`~plantvr.flowers.floret.petal_net`), replicated n-fold with its first rows fused
(:class:`~plantvr.flowers.floret.Corolla`), 2 or 3 key poses blended intrinsically under a time-warp growth
function and repolygonized with one topology for every frame (:func:`~plantvr.flowers.floret.build_floret`).
:class:`FloretEditor` only holds the editor's settings as traits, turns them into that core call and shows the
result: an off-screen pyvista preview (:func:`preview_png`) at the growth time of the scrub slider, and
optionally the same mesh in a pyvista plotter or :class:`plantvr.view.View` (:meth:`FloretEditor.show_in`).

Every setting is a trait, so code and sliders drive the same thing (``editor.n_fold = 6`` or moving the
slider). A value out of its range set from code raises ``ValueError`` and changes nothing; a combination of
valid values the core rejects (fused rows with a 1-fold corolla, more fused rows than control rows, ...)
shows a message and keeps the last valid floret, so :attr:`FloretEditor.floret` is always a valid
:class:`~plantvr.flowers.floret.FloretMesh`.
"""
from __future__ import annotations

import contextlib
import html
import io
import os
from pathlib import Path

import ipywidgets as W
import numpy as np
import traitlets

from .._validation import MAX_COORD, check_array, check_choice, check_int, check_range
from ..flowers.composer import FloretType
from ..flowers.floret import Corolla, FloretMesh, build_floret, growth_function, petal_net, write_obj_sequence

__all__ = ["GROWTH_KINDS", "POSE_KEYS", "POSE_NAMES", "PRESETS", "FloretEditor", "frame_at", "preview_png"]

#: Names of the three key poses; with two poses the middle one is not used.
POSE_NAMES = ("bud", "middle", "open")
#: Petal settings that differ between key poses (the topology settings are shared, spec 002 §2.2).
POSE_KEYS = ("length", "width", "opening_deg", "curl_deg", "roll_deg")
#: Time-warp growth functions: the core's two, and t**warp as knots ("power").
GROWTH_KINDS = ("linear", "sinusoidal", "power")

# name: (label, low, high, step) of every setting; ints have an integer step
_RANGES = {
    "nu": ("Across (nu)", 3, 15, 1), "nv": ("Along (nv)", 3, 15, 1),
    "base_radius": ("Base radius", 0.0, 0.5, 0.005), "base_width": ("Base width", 0.0, 1.0, 0.01),
    "n_fold": ("n-fold", 1, 12, 1), "fused_rows": ("Fused rows", 0, 15, 1),
    "weld_tol": ("Weld tol.", 0.0, 0.05, 1e-4),
    "length": ("Length", 0.01, 5.0, 0.01), "width": ("Width", 0.01, 3.0, 0.01),
    "opening_deg": ("Opening°", -90.0, 150.0, 1.0), "curl_deg": ("Curl°", -180.0, 180.0, 1.0),
    "roll_deg": ("Roll°", 0.0, 175.0, 1.0),
    "n_poses": ("Key poses", 2, 3, 1), "warp": ("Warp γ", 0.2, 5.0, 0.05), "n_frames": ("Frames", 2, 60, 1),
    "lam": ("Row spacing λ", 0.02, 1.0, 0.005), "eta": ("Per row η", 1.0, 31.0, 1.0),
    "time": ("Growth time", 0.0, 1.0, 0.01),
}
_TOPOLOGY = ("nu", "nv", "base_radius", "base_width", "n_fold", "fused_rows", "weld", "weld_tol", "n_poses",
             "growth", "warp", "n_frames", "lam", "eta")

_DISC = {"nu": 5, "nv": 6, "base_radius": 0.06, "base_width": 0.3, "n_fold": 5, "fused_rows": 3,
         "poses": [{"length": 0.35, "width": 0.07, "opening_deg": 6.0, "curl_deg": 0.0, "roll_deg": 0.0},
                   {"length": 0.6, "width": 0.25, "opening_deg": 25.0, "curl_deg": 10.0, "roll_deg": 0.0},
                   {"length": 0.8, "width": 0.42, "opening_deg": 55.0, "curl_deg": 25.0, "roll_deg": 0.0}]}
_MESH = {"lam": 0.2, "eta": 5.0, "weld": True, "weld_tol": 1e-9, "warp": 2.0, "n_frames": 8}
#: Starting points matching the example models' florets (:mod:`plantvr.flowers.models`); every preset sets
#: every setting.
PRESETS = {
    "disc floret": {**_MESH, **_DISC, "growth": "sinusoidal", "n_poses": 2},
    "ray floret": {**_MESH, "nu": 5, "nv": 7, "base_radius": 0.03, "base_width": 0.3, "n_fold": 1, "fused_rows": 0,
                   "growth": "sinusoidal", "n_poses": 2, "lam": 0.12, "eta": 7.0,
                   "poses": [{"length": 0.3, "width": 0.12, "opening_deg": 8.0, "curl_deg": 0.0, "roll_deg": 0.0},
                             {"length": 1.6, "width": 0.5, "opening_deg": 40.0, "curl_deg": 5.0, "roll_deg": 0.0},
                             {"length": 3.0, "width": 0.9, "opening_deg": 80.0, "curl_deg": 15.0,
                              "roll_deg": 0.0}]},
    "dahlia ray": {**_MESH, "nu": 7, "nv": 7, "base_radius": 0.05, "base_width": 0.3, "n_fold": 1, "fused_rows": 0,
                   "growth": "sinusoidal", "n_poses": 2, "lam": 0.11, "eta": 7.0,
                   "poses": [{"length": 1.26, "width": 1.2, "opening_deg": 5.0, "curl_deg": -4.0,
                              "roll_deg": 150.0},
                             {"length": 2.4, "width": 1.8, "opening_deg": 30.0, "curl_deg": -15.0,
                              "roll_deg": 110.0},
                             {"length": 3.6, "width": 2.2, "opening_deg": 60.0, "curl_deg": -30.0,
                              "roll_deg": 90.0}]},
    "fused tube (3 poses)": {**_MESH, **_DISC, "n_fold": 6, "fused_rows": 4, "growth": "linear", "n_poses": 3},
}


def frame_at(floret: FloretMesh, t: float) -> np.ndarray:
    """Vertices of ``floret`` at growth time ``t`` in [0, 1], linear between its frames.

    Parameters
    ----------
    floret : FloretMesh
    t : float
        Growth time; 0 is the first frame, 1 the last.

    Returns
    -------
    (V, 3) float64 ndarray
    """
    floret = _check_floret(floret)
    t = check_range("t", t, 0.0, 1.0)
    K = floret.frames.shape[0]
    x = t * (K - 1)
    i = min(int(np.floor(x)), K - 2) if K > 1 else 0
    f = x - i if K > 1 else 0.0
    return (1.0 - f) * floret.frames[i] + f * floret.frames[min(i + 1, K - 1)]


def _polydata(x: np.ndarray, faces: np.ndarray):
    import pyvista as pv

    return pv.PolyData(np.asarray(x, dtype=np.float64),
                       np.column_stack([np.full(len(faces), 3), faces]).ravel().astype(np.int64))


def _camera(floret: FloretMesh) -> list:
    pts = floret.frames.reshape(-1, 3)
    lo, hi = pts.min(0), pts.max(0)
    c = 0.5 * (lo + hi)
    size = max(float(np.max(hi - lo)), 1e-6)
    return [tuple(c + size * np.array([1.1, -1.5, 1.2])), tuple(c), (0.0, 0.0, 1.0)]


def preview_png(floret: FloretMesh, t: float = 1.0, *, size: tuple[int, int] = (420, 420),
                color: str = "#e8a33d", show_edges: bool = True, camera: list | None = None) -> bytes:
    """A PNG of a floret at growth time ``t``, rendered off-screen with pyvista (floret axis up).

    Parameters
    ----------
    floret : FloretMesh
    t : float
        Growth time in [0, 1] (:func:`frame_at`).
    size : (int, int)
        Pixels, each in [64, 4096].
    color : str
        Surface colour.
    show_edges : bool
        Draw the triangles' edges (the repolygonization).
    camera : list, optional
        pyvista camera position; default a three-quarter view framing every frame, so the camera does not
        move while the growth time is scrubbed.

    Returns
    -------
    bytes
        PNG data.
    """
    floret = _check_floret(floret)
    t = check_range("t", t, 0.0, 1.0)
    if not isinstance(size, (tuple, list, np.ndarray)) or len(size) != 2:
        raise ValueError(f"size must be (width, height) in pixels, got {size!r:.80}")
    w, h = (check_int("size[0]", size[0], 64, 4096), check_int("size[1]", size[1], 64, 4096))
    show_edges = _check_bool("show_edges", show_edges)
    if camera is not None:
        camera = [tuple(r) for r in check_array("camera", camera, shape=(3, 3), max_abs=MAX_COORD).tolist()]
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    try:
        pv.Color(color)
    except (TypeError, ValueError):
        raise ValueError(f"color must be a colour name or '#rrggbb', got {color!r:.80}") from None

    pl = pv.Plotter(off_screen=True, window_size=(w, h))
    try:
        pl.set_background("white")
        pl.add_mesh(_polydata(frame_at(floret, t), floret.faces), color=color, show_edges=show_edges,
                    edge_color="#7a4a12", line_width=0.5, smooth_shading=False, ambient=0.3,
                    diffuse=0.75)
        pl.camera_position = camera if camera is not None else _camera(floret)
        img = pl.screenshot(return_img=True)
    finally:
        pl.close()
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.asarray(img)).save(buf, format="PNG")
    return buf.getvalue()


class _Checked(traitlets.TraitType):
    """A trait whose every value, from code or a linked control, goes through a PlantVR check: a bad value
    raises ``ValueError`` naming the setting (never a bare ``TraitError``) and changes nothing (issue 20)."""

    def __init__(self, default_value, check, **kwargs):
        super().__init__(default_value, **kwargs)
        self._check_value = check

    def validate(self, obj, value):
        return self._check_value(self.name, value)


class _Setting(_Checked):
    """A numeric setting of :data:`_RANGES`: an int or a float inside its slider's range."""

    def __init__(self, default_value, **kwargs):
        super().__init__(default_value, _check_setting, **kwargs)


def _check_setting(name: str, value):
    _, lo, hi, step = _RANGES[name]
    if isinstance(step, int):
        return check_int(name, value, lo, hi)
    return check_range(name, value, lo, hi)


def _check_bool(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _check_str(name: str, value) -> str:
    if not isinstance(value, str):
        raise ValueError(f"{name} must be a string, got {type(value).__name__}")
    return value


def _check_pose_list(value) -> list[dict]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"poses must be a list of 3 key poses (bud, middle, open), "
                         f"got {type(value).__name__}")
    poses = list(value)
    if len(poses) != 3:
        raise ValueError(f"poses must hold 3 key poses (bud, middle, open), got {len(poses)}")
    out = []
    for i, p in enumerate(poses):
        if not isinstance(p, dict) or set(p) != set(POSE_KEYS):
            got = sorted(map(str, p)) if isinstance(p, dict) else type(p).__name__
            raise ValueError(f"poses[{i}] must be a dict with the keys {list(POSE_KEYS)}, got {got}")
        out.append({k: check_range(f"poses[{i}].{k}", p[k], *_RANGES[k][1:3]) for k in POSE_KEYS})
    return out


def _check_floret(floret) -> FloretMesh:
    if not isinstance(floret, FloretMesh):
        raise ValueError(f"floret must be a FloretMesh, got {type(floret).__name__}")
    return floret


def _pose_defaults() -> list[dict]:
    return [dict(p) for p in _DISC["poses"]]


class FloretEditor(W.VBox):
    """Sliders, key poses, growth scrub and preview over the floret core (spec 002 §2; C1–C4).

    Parameters
    ----------
    preset : str, optional
        Start from one of :data:`PRESETS` (default ``"disc floret"``).
    live_preview : bool
        Re-render the preview image after every change (turn off to edit from code quickly; :meth:`redraw`
        renders on demand).
    preview_size : (int, int)
        Preview pixels.

    Attributes
    ----------
    floret : FloretMesh
        The last valid floret (faces, frames, attachment vertices).
    message : str
        Why the last change was not applied ("" after a successful build).
    version : int
        Incremented after every successful build.
    """

    # petal topology and shape shared by every key pose
    nu = _Setting(5, help="control points across a petal")
    nv = _Setting(6, help="control points along a petal (control rows)")
    base_radius = _Setting(0.06, help="distance of the petal base from the floret axis")
    base_width = _Setting(0.3, help="petal width at the base, as a fraction of its width")
    # corolla
    n_fold = _Setting(5, help="petals replicated about the floret axis")
    fused_rows = _Setting(3, help="control rows fused with the neighbouring petals")
    weld = _Checked(True, _check_bool, help=
                    "weld coincident vertices (fused seams, shared base points)")
    weld_tol = _Setting(1e-9, help="welding distance, as a fraction of the floret size")
    # key poses: the pose sliders edit poses[pose_index]
    n_poses = _Setting(2, help="key poses: 2 (bud, open) or 3 (bud, middle, open)")
    pose_index = _Checked(2, lambda n, v: check_int(n, v, 0, 2),
                          help="key pose edited by the pose sliders: 0 bud, 1 middle, 2 open")
    poses = _Checked([], lambda n, v: _check_pose_list(v), help="settings of the three key poses")
    length = _Setting(0.8)
    width = _Setting(0.42)
    opening_deg = _Setting(55.0)
    curl_deg = _Setting(25.0)
    roll_deg = _Setting(0.0)
    # development and polygonization
    growth = _Checked("sinusoidal", lambda n, v: check_choice(n, v, GROWTH_KINDS),
                      help="time-warp growth function")
    warp = _Setting(2.0, help="exponent of the 'power' growth function t**warp")
    n_frames = _Setting(8, help="frames of the animation")
    lam = _Setting(0.2, help="lambda of Eq. 2.1: spacing between sample rows")
    eta = _Setting(5.0, help="eta: samples per row (rounded up to odd)")
    time = _Setting(1.0, help="growth time shown by the preview")
    # outputs
    message = _Checked("", lambda n, v: _check_str(n, v))
    version = _Checked(0, lambda n, v: check_int(n, v, 0, 2 ** 62))

    def __init__(self, *, preset: str | None = "disc floret", live_preview: bool = True,
                 preview_size: tuple[int, int] = (420, 420)):
        super().__init__()
        self.live_preview = bool(live_preview)
        self.preview_size = (check_int("preview_size[0]", preview_size[0], 64, 4096),
                             check_int("preview_size[1]", preview_size[1], 64, 4096))
        self._hold = 0
        self._dirty = False
        self._loading = False
        self._views: list = []
        self._camera = None
        self.poses = _pose_defaults()
        self._floret = build_floret(self.corollas(), n_frames=self.n_frames, growth=self.growth_knots(),
                                    lam=self.lam, eta=self.eta, weld=self.weld, weld_tol=self.weld_tol)
        self._build_widgets()
        self.observe(self._on_setting, names=list(_TOPOLOGY) + list(POSE_KEYS))
        self.observe(self._on_pose_index, names=["pose_index"])
        self.observe(lambda ch: self.redraw(), names=["time"])
        self.observe(self._on_message, names=["message"])
        if preset is not None:
            self.load_preset(preset)
        self._load_pose()
        self._camera = _camera(self._floret)
        self._update_info()
        if self.live_preview and not self.preview.value:
            self.redraw()

    # ------------------------------------------------------------------ validation (code path)
    @traitlets.validate("pose_index")
    def _check_pose_index(self, proposal):
        i = check_int("pose_index", proposal["value"], 0, 2)
        if self.n_poses == 2 and i == 1:
            raise ValueError("pose_index must be 0 (bud) or 2 (open) with 2 key poses, got 1")
        return i

    # ------------------------------------------------------------------ core calls
    def corollas(self) -> list[Corolla]:
        """The key poses as core :class:`~plantvr.flowers.floret.Corolla` objects (2 or 3)."""
        keys = (0, 2) if self.n_poses == 2 else (0, 1, 2)
        return [Corolla(petal_net(nu=self.nu, nv=self.nv, base_radius=self.base_radius, base_width=self.base_width,
                                  **self.poses[k]), n_fold=self.n_fold, fused_rows=self.fused_rows) for k in keys]

    def growth_knots(self) -> str | np.ndarray:
        """The growth argument of :func:`~plantvr.flowers.floret.build_floret` (a name or (K, 2) knots)."""
        if self.growth == "power":
            x = np.linspace(0.0, 1.0, 65)
            return np.column_stack([x, x ** self.warp])
        return self.growth

    def build(self) -> FloretMesh:
        """Build a floret from the current settings without storing it.

        Raises
        ------
        ValueError
            When the settings do not make a floret (the message says which settings clash).
        """
        if self.fused_rows and self.n_fold < 2:
            raise ValueError(f"fused rows need a corolla of at least 2 petals; n-fold is {self.n_fold} "
                             f"(set fused rows to 0 or n-fold to 2 or more)")
        if self.fused_rows > self.nv:
            raise ValueError(f"fused rows ({self.fused_rows}) must not exceed the control rows along the petal "
                             f"(nv = {self.nv})")
        fm = build_floret(self.corollas(), n_frames=self.n_frames, growth=self.growth_knots(), lam=self.lam,
                          eta=self.eta, weld=self.weld, weld_tol=self.weld_tol)
        if len(fm.faces) == 0 or not np.all(np.isfinite(fm.frames)):
            raise ValueError("the settings give an empty or non-finite mesh")
        return fm

    @property
    def floret(self) -> FloretMesh:
        """The last valid floret (never an invalid one)."""
        return self._floret

    def floret_type(self) -> FloretType:
        """The floret as a :class:`~plantvr.flowers.composer.FloretType` for a :class:`Canopy`."""
        return FloretType(self._floret.faces, self._floret.frames, self._floret.fixed)

    def current_frame(self) -> np.ndarray:
        """(V, 3) vertices at the scrubbed growth time."""
        return frame_at(self._floret, self.time)

    def rebuild(self) -> bool:
        """Build from the current settings; on failure keep the last valid floret and set :attr:`message`.

        Returns
        -------
        bool
            True when the floret was rebuilt.
        """
        if self._hold:
            self._dirty = True
            return False
        try:
            fm = self.build()
        except ValueError as e:
            self.message = f"Not applied: {e}. The preview keeps the last valid floret."
            return False
        self._floret = fm
        self._camera = _camera(fm)
        self.message = ""
        self.version += 1
        self._update_info()
        if self.live_preview or self._views:
            self.redraw()
        return True

    @contextlib.contextmanager
    def batch(self):
        """Apply several settings with one rebuild at the end: ``with editor.batch(): editor.nu = 7; ...``."""
        self._hold += 1
        try:
            yield self
        finally:
            self._hold -= 1
            if not self._hold and self._dirty:
                self._dirty = False
                self.rebuild()

    def set_pose(self, index: int, **values: float) -> None:
        """Set settings of key pose ``index`` (0 bud, 1 middle, 2 open) from code, with one rebuild."""
        index = check_int("index", index, 0, 2)
        bad = sorted(set(values) - set(POSE_KEYS))
        if bad:
            raise ValueError(f"pose settings must be among {list(POSE_KEYS)}, got {bad}")
        checked = {k: check_range(k, v, *_RANGES[k][1:3]) for k, v in values.items()}
        poses = [dict(p) for p in self.poses]
        poses[index].update(checked)
        with self.batch():
            self.poses = poses
            self._dirty = True
            if index == self.pose_index:
                self._load_pose()

    def load_preset(self, name: str) -> None:
        """Load one of :data:`PRESETS` (all settings, one rebuild)."""
        name = check_choice("name", name, tuple(PRESETS))
        p = PRESETS[name]
        with self.batch():
            self.poses = [dict(q) for q in p["poses"]]
            for k, v in p.items():
                if k not in ("poses", "n_poses"):
                    setattr(self, k, v)
            if p.get("n_poses", 2) == 2 and self.pose_index == 1:
                self.pose_index = 2
            self.n_poses = p.get("n_poses", 2)
            self._load_pose()
            self._dirty = True
        if hasattr(self, "preset") and self.preset.value != name:
            self._loading = True
            try:
                self.preset.value = name
            finally:
                self._loading = False

    # ------------------------------------------------------------------ observers
    def _on_setting(self, change) -> None:
        if self._loading:
            return
        if change["name"] in POSE_KEYS:
            poses = [dict(p) for p in self.poses]
            poses[self.pose_index][change["name"]] = change["new"]
            self.poses = poses
        if change["name"] == "n_poses":
            idx = self.pose_index
            self.pose_select.options = self._pose_options()      # resets the selection: restore it
            self.pose_index = 2 if (self.n_poses == 2 and idx == 1) else idx
        self.rebuild()

    def _pose_options(self):
        return [(POSE_NAMES[i], i) for i in ((0, 2) if self.n_poses == 2 else (0, 1, 2))]

    def _on_pose_index(self, change) -> None:
        self._load_pose()

    def _load_pose(self) -> None:
        self._loading = True
        try:
            for k in POSE_KEYS:
                setattr(self, k, self.poses[self.pose_index][k])
        finally:
            self._loading = False

    def _on_message(self, change) -> None:
        self.message_box.value = ("" if not change["new"] else
                                  f"<div class='floret-error' style='color:#b00020'>{html.escape(change['new'])}</div>")

    def _update_info(self) -> None:
        fm = self._floret
        self.info.value = (f"{fm.frames.shape[1]} vertices, {len(fm.faces)} triangles, {fm.frames.shape[0]} frames "
                           f"(one topology), {len(fm.fixed)} attachment vertices")
        self.curve.value = self._curve_svg()

    def _curve_svg(self) -> str:
        t = np.linspace(0.0, 1.0, 41)
        y = np.asarray(growth_function(self.growth_knots())(t))
        pts = " ".join(f"{4 + 112 * a:.1f},{64 - 56 * b:.1f}" for a, b in zip(t, y))
        tx = 4 + 112 * self.time
        return (f"<svg width='120' height='70' style='background:#fafafa;border:1px solid #ddd'>"
                f"<polyline points='{pts}' fill='none' stroke='#c0392b' stroke-width='2'/>"
                f"<line x1='{tx:.1f}' y1='4' x2='{tx:.1f}' y2='66' stroke='#555' stroke-dasharray='2,2'/></svg>")

    # ------------------------------------------------------------------ output
    def redraw(self) -> None:
        """Render the preview at the current growth time and update any attached views."""
        x = self.current_frame()
        if self.live_preview:
            self.preview.value = preview_png(self._floret, self.time, size=self.preview_size, camera=self._camera)
        self.curve.value = self._curve_svg()
        for pl, mesh in self._views:
            if mesh.n_points != len(x) or mesh.n_cells != len(self._floret.faces):
                mesh.copy_from(_polydata(x, self._floret.faces))
            else:
                mesh.points = x
            with contextlib.suppress(Exception):        # a closed plotter has no render window left
                pl.render()

    def show_in(self, target, *, color: str = "#e8a33d", name: str = "floret"):
        """Also show the floret in a pyvista ``Plotter`` or a :class:`plantvr.view.View` (its ``plotter``);
        the mesh follows every later change. Returns the pyvista mesh."""
        pl = getattr(target, "plotter", target)
        if not hasattr(pl, "add_mesh"):
            raise ValueError(f"target must be a pyvista Plotter or have a .plotter, got {type(target).__name__}")
        mesh = _polydata(self.current_frame(), self._floret.faces)
        pl.add_mesh(mesh, color=color, name=name, show_edges=True)
        self._views.append((pl, mesh))
        return mesh

    def export_obj(self, folder: str | os.PathLike, *, prefix: str = "frame") -> list[str]:
        """Write the floret as an OBJ sequence (one file per frame, shared faces) and ``weight.txt`` with the
        attachment vertices (spec 002 §2.4, V8). Returns the paths written."""
        if not isinstance(folder, (str, os.PathLike)) or not os.fspath(folder).strip():
            raise ValueError(f"folder must be a non-empty path, got {folder!r}")
        fm = self._floret
        return write_obj_sequence(os.fspath(folder), fm.faces, fm.frames, prefix=prefix, fixed=fm.fixed)

    # ------------------------------------------------------------------ widgets
    def _slider(self, name: str):
        label, lo, hi, step = _RANGES[name]
        cls = W.IntSlider if isinstance(step, int) else W.FloatSlider
        kw = {} if isinstance(step, int) else {"readout_format": ".4g" if step < 0.01 else ".3g"}
        s = cls(value=getattr(self, name), min=lo, max=hi, step=step, description=label, continuous_update=False,
                style={"description_width": "110px"}, layout=W.Layout(width="340px"), **kw)
        s.tooltip = self.trait_metadata(name, "help") or label
        W.link((s, "value"), (self, name))
        self.controls[name] = s
        return s

    def _build_widgets(self) -> None:
        self.controls: dict = {}
        self.preset = W.Dropdown(options=list(PRESETS), value=None, description="Preset",
                                 style={"description_width": "110px"})
        self.preset.observe(lambda ch: None if self._loading or ch["new"] is None else self.load_preset(ch["new"]),
                            names="value")
        self.weld_box = W.Checkbox(value=self.weld, description="Weld seams", indent=False)
        W.link((self.weld_box, "value"), (self, "weld"))
        self.controls["weld"] = self.weld_box
        self.pose_select = W.ToggleButtons(options=self._pose_options(), value=self.pose_index,
                                           description="Edit pose", style={"button_width": "70px"})
        W.link((self.pose_select, "value"), (self, "pose_index"))
        self.growth_select = W.Dropdown(options=list(GROWTH_KINDS), value=self.growth, description="Growth",
                                        style={"description_width": "110px"})
        W.link((self.growth_select, "value"), (self, "growth"))
        self.controls["growth"] = self.growth_select
        self.curve = W.HTML()
        self.folder = W.Text(value="floret_obj", description="OBJ folder", style={"description_width": "110px"})
        self.export_button = W.Button(description="Export OBJ sequence", icon="download")
        self.export_button.on_click(lambda _: self._export_clicked())
        self.export_status = W.HTML()
        self.message_box = W.HTML()
        self.info = W.HTML()
        self.preview = W.Image(format="png", layout=W.Layout(width=f"{self.preview_size[0]}px"))
        tabs = W.Tab(children=[
            W.VBox([self._slider(k) for k in ("nu", "nv", "base_radius", "base_width")]),
            W.VBox([self._slider("n_fold"), self._slider("fused_rows"), self.weld_box, self._slider("weld_tol")]),
            W.VBox([self._slider("n_poses"), self.pose_select] + [self._slider(k) for k in POSE_KEYS]),
            W.VBox([self.growth_select, self._slider("warp"), self._slider("n_frames"), self.curve]),
            W.VBox([self._slider("lam"), self._slider("eta")]),
            W.VBox([self.folder, self.export_button, self.export_status]),
        ])
        for i, title in enumerate(("Petal", "Corolla", "Key poses", "Growth", "Mesh", "Export")):
            tabs.set_title(i, title)
        left = W.VBox([self.preset, tabs], layout=W.Layout(width="380px"))
        right = W.VBox([self.preview, self._slider("time"), self.info, self.message_box])
        self.children = [W.HBox([left, right])]

    def _export_clicked(self) -> None:
        """The Export button: the folder comes from the browser's text field, so a bad one is reported in
        the panel instead of raising inside the widget callback."""
        try:
            paths = self.export_obj(self.folder.value)
        except (ValueError, OSError) as exc:
            self.export_status.value = (f"<span class='floret-error' style='color:#b00020'>Not exported: "
                                        f"{html.escape(str(exc))}</span>")
            return
        self.export_status.value = f"wrote {len(paths)} OBJ files to {html.escape(str(Path(self.folder.value)))}"

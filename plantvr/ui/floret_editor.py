"""Floret editor widget for notebooks: a view of an :class:`~plantvr.documents.inflorescence.InflorescenceDocument`
(spec 002 §2.1–§2.4, checklist C1–C4; issues 9 and 21).

The floret's settings, key poses and animation live in the document; the editor holds no floret state of its
own. Its sliders are linked to the document's parameters (rows of :data:`~plantvr.flowers.floret.FLORET`, so
their ranges and steps come from the table), the pose sliders edit the selected key pose through
``doc.set_pose``, the preset menu calls ``doc.load_preset``, and every document change redraws the editor: an
off-screen pyvista preview (:func:`preview_png`) at the document's growth time, and optionally the same mesh in
a pyvista plotter or :class:`plantvr.view.View` (:meth:`FloretEditor.show_in`). What the editor keeps is view
state: which key pose the pose sliders show (:attr:`FloretEditor.pose_index`) and the preview image.
"""
from __future__ import annotations

import contextlib
import html
import os
from pathlib import Path

import ipywidgets as W
import numpy as np
import traitlets

from .._validation import MAX_COORD, check_array, check_int, check_range
from ..documents.inflorescence import PRESETS, InflorescenceDocument
from ..flowers.floret import (
    FLORET,
    GROWTH_KINDS,
    POSE_KEYS,
    POSE_NAMES,
    FloretMesh,
    growth_function,
)
from ..io.obj import write_obj_sequence
from ..types import TriMesh

__all__ = ["FloretEditor", "preview_png"]

#: Slider labels (view text; ranges and steps are the table's).
_LABELS = {
    "nu": "Across (nu)", "nv": "Along (nv)", "base_radius": "Base radius", "base_width": "Base width",
    "n_fold": "n-fold", "fused_rows": "Fused rows", "weld_tol": "Weld tol.", "length": "Length", "width": "Width",
    "opening_deg": "Opening°", "curl_deg": "Curl°", "roll_deg": "Roll°", "n_poses": "Key poses", "warp": "Warp γ",
    "n_frames": "Frames", "lam": "Row spacing λ", "eta": "Per row η", "time": "Growth time",
}


def _camera(floret: FloretMesh) -> list:
    pts = floret.frames.reshape(-1, 3)
    lo, hi = pts.min(0), pts.max(0)
    c = 0.5 * (lo + hi)
    size = max(float(np.max(hi - lo)), 1e-6)
    return [tuple(c + size * np.array([1.1, -1.5, 1.2])), tuple(c), (0.0, 0.0, 1.0)]


def preview_png(floret: FloretMesh, t: float = 1.0, *, size: tuple[int, int] = (420, 420),
                color: str = "#e8a33d", show_edges: bool = True, camera: list | None = None) -> bytes:
    """A PNG of a floret at growth time ``t`` (floret axis up), rendered off-screen by a
    :class:`plantvr.view.View`.

    Parameters
    ----------
    floret : FloretMesh
    t : float
        Growth time in [0, 1] (:meth:`~plantvr.flowers.floret.FloretMesh.frame_at`).
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
    if not isinstance(floret, FloretMesh):
        raise ValueError(f"floret must be a FloretMesh, got {type(floret).__name__}")
    t = check_range("t", t, 0.0, 1.0)
    if not isinstance(size, (tuple, list, np.ndarray)) or len(size) != 2:
        raise ValueError(f"size must be (width, height) in pixels, got {size!r:.80}")
    w, h = (check_int("size[0]", size[0], 64, 4096), check_int("size[1]", size[1], 64, 4096))
    show_edges = _check_bool("show_edges", show_edges)
    if camera is not None:
        camera = [tuple(r) for r in check_array("camera", camera, shape=(3, 3), max_abs=MAX_COORD).tolist()]
    import pyvista as pv  # noqa: PLC0415

    from ..view import View  # noqa: PLC0415

    try:
        pv.Color(color)
    except (TypeError, ValueError):
        raise ValueError(f"color must be a colour name or '#rrggbb', got {color!r:.80}") from None

    style = {"color": color, "show_edges": show_edges, "edge_color": "#7a4a12", "line_width": 0.5,
             "smooth_shading": False, "specular": 0.0, "ambient": 0.3, "diffuse": 0.75}
    view = View({"floret": TriMesh(floret.frame_at(t), floret.faces)}, off_screen=True, window_size=(w, h),
                styles={"floret": style})
    try:
        view.plotter.set_background("white")
        view.plotter.camera_position = camera if camera is not None else _camera(floret)
        return view.png()
    finally:
        view.close()


class _PoseIndex(traitlets.TraitType):
    """The key pose the pose sliders show; a bad value raises ``ValueError`` naming it (never a ``TraitError``)."""

    def validate(self, obj, value):
        i = check_int("pose_index", value, 0, 2)
        if obj.doc.n_poses == 2 and i == 1:
            raise ValueError("pose_index must be 0 (bud) or 2 (open) with 2 key poses, got 1")
        return i


def _check_bool(name: str, value) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


class FloretEditor(W.VBox):
    """Sliders, key poses, growth scrub and preview: a view of an inflorescence document (spec 002 §2; C1–C4).

    Parameters
    ----------
    doc : InflorescenceDocument, optional
        The document to show and edit; default a new one started from ``preset``.
    preset : str, optional
        Preset of a new document (one of :data:`~plantvr.documents.inflorescence.PRESETS`; default
        ``"disc floret"``); not used with ``doc``.
    live_preview : bool
        Re-render the preview image after every change (turn off to edit from code quickly; :meth:`redraw`
        renders on demand).
    preview_size : (int, int)
        Preview pixels.

    Attributes
    ----------
    doc : InflorescenceDocument
    pose_index : int
        Key pose shown by the pose sliders: 0 bud, 1 middle (three poses only), 2 open.
    """

    pose_index = _PoseIndex(2, help="key pose edited by the pose sliders: 0 bud, 1 middle, 2 open")

    def __init__(self, doc: InflorescenceDocument | None = None, *, preset: str | None = "disc floret",
                 live_preview: bool = True, preview_size: tuple[int, int] = (420, 420)):
        if doc is not None and not isinstance(doc, InflorescenceDocument):
            raise ValueError(f"doc must be an InflorescenceDocument, got {type(doc).__name__}")
        super().__init__()
        self.live_preview = _check_bool("live_preview", live_preview)
        self.preview_size = (check_int("preview_size[0]", preview_size[0], 64, 4096),
                             check_int("preview_size[1]", preview_size[1], 64, 4096))
        self.doc = doc if doc is not None else InflorescenceDocument(preset=preset)
        self._syncing = False
        self._views: list = []
        self._shown = (None, None)          # (floret, time) the preview and views show
        self._camera = None
        self._build_widgets()
        self.observe(lambda ch: self._show_pose(), names=["pose_index"])
        self.doc.observe(self._on_doc, names="change")
        self._refresh()

    # ------------------------------------------------------------------ following the document
    def _pose_options(self):
        return [(POSE_NAMES[i], i) for i in ((0, 2) if self.doc.n_poses == 2 else (0, 1, 2))]

    def _on_doc(self, change) -> None:
        self._refresh()

    def close(self) -> None:
        """Stop following the document, then close the widgets."""
        self.doc.unobserve(self._on_doc, names="change")
        super().close()

    def _refresh(self) -> None:
        opts = self._pose_options()
        if list(self.pose_select.options) != opts:
            idx = self.pose_index
            self._syncing = True
            try:
                self.pose_select.options = opts          # resets the selection: restore it
            finally:
                self._syncing = False
            self.pose_index = 2 if (self.doc.n_poses == 2 and idx == 1) else idx
        self._show_pose()
        msg = self.doc.message
        self.message_box.value = ("" if not msg else
                                  f"<div class='floret-error' style='color:#b00020'>{html.escape(msg)}</div>")
        fm = self.doc.floret
        self.info.value = (f"{fm.frames.shape[1]} vertices, {len(fm.faces)} triangles, {fm.frames.shape[0]} frames "
                           f"(one topology), {len(fm.fixed)} attachment vertices")
        self.curve.value = self._curve_svg()
        if self._shown[0] is not fm or self._shown[1] != self.doc.time:
            self.redraw()

    def _show_pose(self) -> None:
        """Show the selected key pose in the pose selector and the pose sliders."""
        pose = self.doc.poses[self.pose_index]
        self._syncing = True
        try:
            self.pose_select.value = self.pose_index
            for k in POSE_KEYS:
                self.controls[k].value = pose[k]
        finally:
            self._syncing = False

    def _on_pose_select(self, value) -> None:
        if not self._syncing and value is not None:
            self.pose_index = value

    def _on_pose_slider(self, key: str, value: float) -> None:
        if not self._syncing:
            self.doc.set_pose(self.pose_index, **{key: value})

    def _curve_svg(self) -> str:
        t = np.linspace(0.0, 1.0, 41)
        y = np.asarray(growth_function(self.doc.growth_knots())(t))
        pts = " ".join(f"{4 + 112 * a:.1f},{64 - 56 * b:.1f}" for a, b in zip(t, y))
        tx = 4 + 112 * self.doc.time
        return (f"<svg width='120' height='70' style='background:#fafafa;border:1px solid #ddd'>"
                f"<polyline points='{pts}' fill='none' stroke='#c0392b' stroke-width='2'/>"
                f"<line x1='{tx:.1f}' y1='4' x2='{tx:.1f}' y2='66' stroke='#555' stroke-dasharray='2,2'/></svg>")

    # ------------------------------------------------------------------ output
    def redraw(self) -> None:
        """Render the preview at the document's growth time and update any attached views."""
        fm = self.doc.floret
        if self._shown[0] is not fm:
            self._camera = _camera(fm)
        self._shown = (fm, self.doc.time)
        x = self.doc.current_frame()
        if self.live_preview:
            self.preview.value = preview_png(fm, self.doc.time, size=self.preview_size, camera=self._camera)
        for pl, mesh in self._views:
            if mesh.n_points != len(x) or mesh.n_cells != len(fm.faces):
                from ..view.polydata import to_polydata  # noqa: PLC0415
                mesh.copy_from(to_polydata((x, fm.faces)))
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
        from ..view.polydata import to_polydata  # noqa: PLC0415
        mesh = to_polydata((self.doc.current_frame(), self.doc.floret.faces))
        pl.add_mesh(mesh, color=color, name=name, show_edges=True)
        self._views.append((pl, mesh))
        return mesh

    def export_obj(self, folder: str | os.PathLike, *, prefix: str = "frame") -> list[str]:
        """Write the floret as an OBJ sequence (one file per frame, shared faces) and ``weight.txt`` with the
        attachment vertices (spec 002 §2.4, V8). Returns the paths written."""
        if not isinstance(folder, (str, os.PathLike)) or not os.fspath(folder).strip():
            raise ValueError(f"folder must be a non-empty path, got {folder!r}")
        fm = self.doc.floret
        return write_obj_sequence(os.fspath(folder), fm.faces, fm.frames, prefix=prefix, fixed=fm.fixed)

    # ------------------------------------------------------------------ widgets
    def _slider(self, name: str, row: str | None = None):
        """A slider for table row ``row`` (default ``name``); linked to the document parameter ``name`` unless it
        is a pose key (those edit the selected pose)."""
        p = FLORET[row or name]
        lo, hi = p.range
        cls = W.IntSlider if p.kind is int else W.FloatSlider
        kw = {} if p.kind is int else {"readout_format": ".4g" if p.step < 0.01 else ".3g"}
        value = getattr(self.doc, name) if row is None else getattr(self.doc, row)
        s = cls(value=value, min=lo, max=hi, step=p.step, description=_LABELS[name], continuous_update=False,
                style={"description_width": "110px"}, layout=W.Layout(width="340px"), **kw)
        s.tooltip = p.doc
        if row is None:
            W.link((s, "value"), (self.doc, name))
        else:
            s.observe(lambda ch: self._on_pose_slider(name, ch["new"]), names="value")
        self.controls[name] = s
        return s

    def _build_widgets(self) -> None:
        self.controls: dict = {}
        self.preset = W.Dropdown(options=list(PRESETS), value=None, description="Preset",
                                 style={"description_width": "110px"})
        self.preset.observe(lambda ch: None if ch["new"] is None else self.doc.load_preset(ch["new"]), names="value")
        self.weld_box = W.Checkbox(value=self.doc.weld, description="Weld seams", indent=False)
        W.link((self.weld_box, "value"), (self.doc, "weld"))
        self.controls["weld"] = self.weld_box
        self.pose_select = W.ToggleButtons(options=self._pose_options(), value=self.pose_index,
                                           description="Edit pose", style={"button_width": "70px"})
        self.pose_select.observe(lambda ch: self._on_pose_select(ch["new"]), names="value")
        self.growth_select = W.Dropdown(options=list(GROWTH_KINDS), value=self.doc.growth, description="Growth",
                                        style={"description_width": "110px"})
        W.link((self.growth_select, "value"), (self.doc, "growth"))
        self.controls["growth"] = self.growth_select
        self.curve = W.HTML()
        self.folder = W.Text(value="floret_obj", description="OBJ folder", style={"description_width": "110px"})
        self.export_button = W.Button(description="Export OBJ sequence", icon="download")
        self.export_button.on_click(lambda _: self._export_clicked())
        self.export_status = W.HTML()
        self.message_box = W.HTML()
        self.info = W.HTML()
        self.preview = W.Image(format="png", layout=W.Layout(width=f"{self.preview_size[0]}px"))
        shown = POSE_NAMES[self.pose_index]
        tabs = W.Tab(children=[
            W.VBox([self._slider(k) for k in ("nu", "nv", "base_radius", "base_width")]),
            W.VBox([self._slider("n_fold"), self._slider("fused_rows"), self.weld_box, self._slider("weld_tol")]),
            W.VBox([self._slider("n_poses"), self.pose_select] + [self._slider(k, f"{shown}_{k}") for k in POSE_KEYS]),
            W.VBox([self.growth_select, self._slider("warp"), self._slider("n_frames"), self.curve]),
            W.VBox([self._slider("lam"), self._slider("eta")]),
            W.VBox([self.folder, self.export_button, self.export_status]),
        ])
        for i, title in enumerate(("Petal", "Corolla", "Poses", "Growth", "Mesh", "Export")):
            tabs.set_title(i, title)
        left = W.VBox([self.preset, tabs], layout=W.Layout(width="450px", flex="0 0 450px"))  # never squeezed
        right = W.VBox([self.preview, self._slider("time"), self.info, self.message_box],
                       layout=W.Layout(flex="0 1 auto", max_width="100%"))
        self.children = [W.HBox([left, right], layout=W.Layout(flex_flow="row wrap"))]  # narrow: one column

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

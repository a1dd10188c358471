"""Notebook panel for the implicit-crown command language: a view of a
:class:`~plantvr.documents.crown.CrownDocument` (spec 003_implicit_sca §5.1, §2.8; C-13; issues 10 and 21).

A text area takes a script in the thesis command language; **Run** sends it to the document (all or nothing: a
rejected script leaves the document unchanged) and the error line names the line number and the offending token,
with the line marked in a listing. The preview is a matplotlib picture of the chosen envelope (polygonized), the
sampled points coloured by their source tag and the trees grown so far. The scene, points and growth controls
(spec 003 §5.2) do not call the numeric code themselves: each button writes one line of the same command language
and runs it through :meth:`ImplicitPanel.run`, so every widget action lands in the document's command log, and the
saved log replays into an identical document. The panel follows every document change (an undo too) and keeps no
state of its own besides the document it shows.
"""
from __future__ import annotations

import html
import io
import re
from pathlib import Path

import ipywidgets as W
import numpy as np
import traitlets

from .._fileio import read_text
from .._validation import check_int
from ..commandlog import CommandLog
from ..documents.crown import TAG_COLORS, CrownDocument
from ..implicit import CommandError, polygonize
from ..implicit.commands import DISTRIBUTIONS

__all__ = ["BOOLEAN_OPS", "ImplicitPanel", "preview_png"]

#: Boolean panel choices and the command each issues (spec 003 §5.2).
BOOLEAN_OPS = {"Union": "union", "Difference": "diff", "Difference 2": "diff2", "Intersection": "inter",
               "Blend": "blend"}

_PREVIEW_ERROR = "<div class='preview-error' style='color:#b00020'>"
_EXAMPLE = """sphere crown 20 0 14 0
scale crown 1 1.25 1
sphere lobe 12 5 18 3
blend crown lobe envelope
point_set_gen envelope uniform num_points=800
grow step=0.6 kill=1.2
"""


def preview_png(doc: CrownDocument, surface: str | None = None, *, resolution: int = 40,
                max_points: int = 3000, size: float = 5.0, elev: float = 15.0, azim: float = -60.0) -> bytes:
    """A PNG of a crown document: envelope mesh, attraction points by source tag, grown trees (y up).

    Parameters
    ----------
    doc : CrownDocument
    surface : str, optional
        Envelope to draw; default none (points and trees only).
    resolution : int
        Polygonization samples along the longest box edge, in [8, 160].
    max_points : int
        At most this many points are drawn (an even subsample), in [0, 10**6].
    size : float
        Figure side in inches.
    elev, azim : float
        View angles in degrees.

    Returns
    -------
    bytes
        PNG data.

    Raises
    ------
    ValueError
        When ``surface`` is unknown or its envelope is empty.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    from .._validation import check_int, check_range

    resolution = check_int("resolution", resolution, 8, 160)
    max_points = check_int("max_points", max_points, 0, 10**6)
    size = check_range("size", size, 1.0, 20.0)
    verts = faces = None
    if surface is not None:
        verts, faces = polygonize(doc.surface(surface), resolution=resolution)
    fig = Figure(figsize=(size, size), dpi=80)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    ax.view_init(elev=elev, azim=azim)
    every = []
    if verts is not None:            # matplotlib's 3-D axes are z up: plot (x, z, y)
        ax.plot_trisurf(verts[:, 0], verts[:, 2], verts[:, 1], triangles=faces, color="#7fb069", alpha=0.25,
                        linewidth=0)
        every.append(verts)
    pts, tags = doc.points.points, doc.points.tags
    if len(pts) and max_points:
        sel = np.linspace(0, len(pts) - 1, min(max_points, len(pts))).astype(np.int64)
        for t in np.unique(tags[sel]):
            s = sel[tags[sel] == t]
            name = doc.points.sources[t] if t < len(doc.points.sources) else str(t)
            ax.scatter(pts[s, 0], pts[s, 2], pts[s, 1], s=2, color=TAG_COLORS[t % len(TAG_COLORS)], label=name)
        ax.legend(loc="upper left", fontsize=7, markerscale=4)
        every.append(pts)
    for tree in doc.trees:
        nodes, parent = np.asarray(tree.nodes), np.asarray(tree.parent)
        kids = np.flatnonzero(parent >= 0)
        seg = np.stack([nodes[parent[kids]], nodes[kids]], axis=1)[:, :, [0, 2, 1]]
        ax.add_collection3d(Line3DCollection(seg, colors="#6b4226", linewidths=0.8))
        every.append(nodes)
    if every:
        allp = np.concatenate(every)
        lo, hi = allp.min(0), allp.max(0)
        c, r = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-9)
        ax.set_xlim(c[0] - r, c[0] + r)
        ax.set_ylim(c[2] - r, c[2] + r)
        ax.set_zlim(c[1] - r, c[1] + r)
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    ax.set_zlabel("y")
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


class ImplicitPanel(W.VBox):
    """Script box, Run button, error line and preview: a view of a :class:`~plantvr.documents.crown.CrownDocument`.

    Parameters
    ----------
    doc : CrownDocument, optional
        The document to show and drive; default a new one (``seed=0``, files relative to the working directory).
    script : str, optional
        Initial text of the script box; default a small example crown.
    resolution : int
        Polygonization resolution of the preview.
    max_points : int
        Points drawn in the preview.

    Attributes
    ----------
    error_line : int
        Line of the last rejected script (0 after a success).
    error_token : str
    """

    error_line = traitlets.Int(0)
    error_token = traitlets.Unicode("")

    def __init__(self, doc: CrownDocument | None = None, *, script: str | None = None, resolution: int = 40,
                 max_points: int = 3000):
        if doc is not None and not isinstance(doc, CrownDocument):
            raise ValueError(f"doc must be a CrownDocument, got {type(doc).__name__}")
        if script is not None and not isinstance(script, str):
            raise ValueError(f"script must be a str, got {type(script).__name__}")
        self.doc: CrownDocument | None = None
        self.resolution = check_int("resolution", resolution, 8, 160)
        self.max_points = check_int("max_points", max_points, 0, 10**6)
        self.script = W.Textarea(value=_EXAMPLE if script is None else script,
                                 placeholder="sphere s 10 0 5 0\npoint_set_gen s uniform num_points=500",
                                 layout=W.Layout(width="100%", height="180px"))
        self.run_button = W.Button(description="Run", button_style="success", icon="play",
                                   tooltip="Run the script (all lines, or none if a line is rejected)")
        self.clear_button = W.Button(description="Clear box", tooltip="Empty the script box (the document stays)")
        self.surface = W.Dropdown(description="Envelope", options=[], layout=W.Layout(width="260px"))
        self.path = W.Text(value="crown.log", description="File", layout=W.Layout(width="320px"))
        self.save_button = W.Button(description="Save log", tooltip="Write the document's command log")
        self.load_button = W.Button(description="Replay", tooltip="Replay a saved command log into a new document")
        self.file_button = W.Button(description="Run script", tooltip="Run a script file (thesis command language)")
        self.error = W.HTML(value="")
        self.status = W.HTML(value="")
        self.history = W.Textarea(value="", disabled=True, layout=W.Layout(width="100%", height="100px"))
        self.preview = W.Image(format="png", layout=W.Layout(width="400px"))
        self.run_button.on_click(lambda _: self.run())
        self.clear_button.on_click(lambda _: setattr(self.script, "value", ""))
        self.save_button.on_click(lambda _: self._save_clicked())
        self.load_button.on_click(lambda _: self.replay())
        self.file_button.on_click(lambda _: self.run_file())
        self._syncing = False
        self.surface.observe(lambda ch: None if self._syncing else self.refresh(), names="value")
        self._build_controls()
        left = W.VBox([W.HTML("<b>Commands</b> (thesis language; <code>#</code> comments)"), self.script,
                       W.HBox([self.run_button, self.clear_button]), self.error, self.status,
                       W.HBox([self.path, self.save_button, self.load_button, self.file_button]),
                       W.HTML("<b>Commands run</b> (undone with the document)"), self.history],
                      layout=W.Layout(width="55%"))
        right = W.VBox([self.surface, self.preview, self.controls])
        super().__init__([W.HBox([left, right])])
        self._attach(doc if doc is not None else CrownDocument())

    def _attach(self, doc: CrownDocument) -> None:
        """Show ``doc`` (and follow its changes) instead of the current document."""
        if self.doc is not None:
            self.doc.off(self._on_change)
        self.doc = doc
        doc.on(self._on_change)
        self._sync(select_last=True)

    def _on_change(self, change) -> None:
        self._sync(select_last=True)

    def close(self) -> None:
        """Stop following the document, then close the widgets."""
        if self.doc is not None:
            self.doc.off(self._on_change)
            self.doc = None
        super().close()

    def _build_controls(self) -> None:
        lay = W.Layout(width="150px")
        # scene: transforms and Booleans on the selected surface
        self.offset = [W.FloatText(value=v, description=a, layout=W.Layout(width="120px")) for a, v in
                       zip("xyz", (0.0, 0.0, 0.0))]
        self.translate_button = W.Button(description="Translate", layout=lay)
        self.scale_button = W.Button(description="Scale", layout=lay)
        self.degrees = W.FloatText(value=0.0, description="degrees", layout=W.Layout(width="150px"))
        self.rotate_button = W.Button(description="Rotate about (x,y,z)", layout=W.Layout(width="170px"))
        self.operand_a = W.Dropdown(description="A", options=[], layout=W.Layout(width="180px"))
        self.operand_b = W.Dropdown(description="B", options=[], layout=W.Layout(width="180px"))
        self.swap_button = W.Button(description="\u2191\u2193 swap", layout=W.Layout(width="90px"))
        self.boolean = W.RadioButtons(options=list(BOOLEAN_OPS), value="Union")
        self.result_name = W.Text(value="result", description="Result", layout=W.Layout(width="200px"))
        self.boolean_button = W.Button(description="OK", button_style="info", layout=W.Layout(width="80px"))
        self.translate_button.on_click(lambda _: self.transform("translate"))
        self.scale_button.on_click(lambda _: self.transform("scale"))
        self.rotate_button.on_click(lambda _: self.transform("rotate"))
        self.swap_button.on_click(lambda _: self.swap_operands())
        self.boolean_button.on_click(lambda _: self.apply_boolean())
        scene = W.VBox([W.HBox(self.offset), W.HBox([self.translate_button, self.scale_button]),
                        W.HBox([self.degrees, self.rotate_button]),
                        W.HBox([W.VBox([self.operand_a, self.operand_b, self.swap_button]), self.boolean]),
                        W.HBox([self.result_name, self.boolean_button])])
        # points
        self.distribution = W.Dropdown(description="Distribution", options=list(DISTRIBUTIONS), value="uniform")
        self.num_points = W.BoundedIntText(value=1000, min=1, max=10**7, description="N")
        self.min_distance = W.BoundedFloatText(value=1.0, min=1e-6, max=1e6, description="r_min")
        self.grid = W.BoundedIntText(value=32, min=4, max=512, description="grid")
        self.thin_percent = W.BoundedFloatText(value=50.0, min=0.0, max=100.0, description="thin %")
        self.generate_button = W.Button(description="Generate", button_style="info")
        self.thin_button = W.Button(description="Thin in B")
        self.densify_button = W.Button(description="Densify in B")
        self.clear_points_button = W.Button(description="Clear points")
        self.generate_button.on_click(lambda _: self.generate_points())
        self.thin_button.on_click(lambda _: self.thin_points())
        self.densify_button.on_click(lambda _: self.densify_points())
        self.clear_points_button.on_click(lambda _: self.run("point_set_clear"))
        points = W.VBox([self.distribution, self.num_points, self.min_distance, self.grid, self.thin_percent,
                         W.HBox([self.generate_button, self.thin_button]),
                         W.HBox([self.densify_button, self.clear_points_button])])
        # growth
        self.step_size = W.BoundedFloatText(value=1.0, min=1e-6, max=1e6, description="D")
        self.kill_radius = W.BoundedFloatText(value=2.0, min=1e-6, max=1e6, description="d_k")
        self.influence = W.BoundedFloatText(value=10.0, min=1e-6, max=1e6, description="d_i")
        self.influence_inf = W.Checkbox(value=True, description="d_i = \u221e")
        self.max_steps = W.BoundedIntText(value=500, min=1, max=100_000, description="max iter")
        self.root = W.Text(value="", description="root", placeholder="x,y,z (blank: below the points)")
        self.grow_button = W.Button(description="Grow", button_style="success")
        self.grow_button.on_click(lambda _: self.grow())
        growth = W.VBox([self.step_size, self.kill_radius, W.HBox([self.influence, self.influence_inf]),
                         self.max_steps, self.root, self.grow_button])
        self.controls = W.Tab(children=[scene, points, growth])
        for i, t in enumerate(("Scene", "Points", "Growth")):
            self.controls.set_title(i, t)

    # -- widget actions: each writes one command line -------------------------------------------------------------
    def _selected(self) -> str | None:
        name = self.surface.value
        if not name:
            self._show_error("", 0, "", "no surface yet: define one with a command (e.g. sphere s 10 0 5 0)")
            return None
        return name

    def transform(self, kind: str) -> bool:
        """Translate, scale or rotate the selected surface by the x, y, z fields (rotate: about that axis)."""
        name = self._selected()
        if name is None:
            return False
        x, y, z = (f"{w.value:g}" for w in self.offset)
        line = {"translate": f"translate {name} {x} {y} {z}", "scale": f"scale {name} {x} {y} {z}",
                "rotate": f"rotate {name} {x} {y} {z} {self.degrees.value:g}"}[kind]
        return self.run(line)

    def swap_operands(self) -> None:
        """Exchange the Boolean operands A and B."""
        a, b = self.operand_a.value, self.operand_b.value
        self.operand_a.value, self.operand_b.value = b, a

    def apply_boolean(self) -> bool:
        """``union|diff|diff2|inter|blend A B RESULT`` from the Boolean panel."""
        a, b, r = self.operand_a.value, self.operand_b.value, self.result_name.value.strip()
        if not a or not b:
            self._show_error("", 0, "", "choose two operands A and B")
            return False
        if not r or len(r.split()) != 1:
            self._show_error("", 0, "", f"result name must be one word, got {r!r}")
            return False
        return self.run(f"{BOOLEAN_OPS[self.boolean.value]} {a} {b} {r}")

    def generate_points(self) -> bool:
        """``point_set_gen SURFACE DIST num_points=N min_distance=r grid=g`` on the selected surface."""
        name = self._selected()
        if name is None:
            return False
        return self.run(f"point_set_gen {name} {self.distribution.value} num_points={self.num_points.value} "
                        f"min_distance={self.min_distance.value:g} grid={self.grid.value}")

    def thin_points(self) -> bool:
        """``point_set_thin SURFACE B PERCENT``: thin the selected surface's points inside operand B."""
        name = self._selected()
        if name is None or not self.operand_b.value:
            return False
        return self.run(f"point_set_thin {name} {self.operand_b.value} {self.thin_percent.value:g}")

    def densify_points(self) -> bool:
        """``point_set_densify B N min_distance=r grid=g``: add N points inside operand B."""
        if not self.operand_b.value:
            self._show_error("", 0, "", "choose the secondary surface as operand B")
            return False
        return self.run(f"point_set_densify {self.operand_b.value} {self.num_points.value} "
                        f"min_distance={self.min_distance.value:g} grid={self.grid.value}")

    def grow(self) -> bool:
        """``grow step=D kill=d_k influence=d_i|inf max_steps=N [root=x,y,z]`` into the current points."""
        infl = "inf" if self.influence_inf.value else f"{self.influence.value:g}"
        line = (f"grow step={self.step_size.value:g} kill={self.kill_radius.value:g} influence={infl} "
                f"max_steps={self.max_steps.value}")
        root = self.root.value.replace(" ", "")
        return self.run(line + (f" root={root}" if root else ""))

    # -- commands -------------------------------------------------------------------------------------------------
    def run(self, text: str | None = None) -> bool:
        """Run ``text`` (default the script box) in the document; show the result or the rejected line.

        Returns
        -------
        bool
            True when every line ran; False when the script was rejected (the document is unchanged).
        """
        text = self.script.value if text is None else text
        self.error_line, self.error_token, self.error.value = 0, "", ""
        try:
            self.doc.run(text)                         # the document's change redraws the panel
        except CommandError as exc:
            self._show_error(text, exc.lineno, exc.token, str(exc))
            return False
        except ValueError as exc:                      # e.g. text that is not a string
            self._show_error(text, 0, "", str(exc))
            return False
        return True

    def run_file(self, path=None) -> bool:
        """Run the script file at ``path`` (default the path box) in the document, like :meth:`run`."""
        path = Path(self.path.value if path is None else path)
        self.error_line, self.error_token, self.error.value = 0, "", ""
        try:
            self.doc.run_file(path)
        except CommandError as exc:
            try:
                text = read_text(path, what="script")
            except ValueError:
                text = ""
            self._show_error(text, exc.lineno, exc.token, str(exc))
            return False
        except ValueError as exc:
            self._show_error("", 0, "", str(exc))
            return False
        return True

    def save(self, path=None) -> Path:
        """Write the document's command log to ``path`` (default the path box)."""
        path = Path(self.path.value if path is None else path)
        try:
            self.doc.log.save(path)                   # atomic: a failed save leaves the old file as it was
        except (OSError, ValueError) as exc:
            self._show_error("", 0, "", f"cannot save {path}: {exc}")
            raise ValueError(f"cannot save the command log to {str(path)!r}: {exc}") from None
        self.status.value = f"saved {len(self.doc.log)} commands to {html.escape(str(path))}"
        return path

    def _save_clicked(self) -> None:
        try:
            self.save()
        except ValueError:                             # already shown in the error box
            pass

    def replay(self, path=None) -> bool:
        """Show a new document that replays the command log at ``path`` (default the path box); it has this
        document's seed and radius, and file names resolve against the log's folder.

        On a rejected or missing file the current document stays and the error is shown.
        """
        path = Path(self.path.value if path is None else path)
        try:
            log = CommandLog.load(path, CrownDocument.COMMANDS, document=CrownDocument.KIND)
            new = CrownDocument(base_dir=path.parent, seed=self.doc.seed, default_radius=self.doc.default_radius)
            new.replay(log)
        except CommandError as exc:
            self._show_error("", exc.lineno, exc.token, str(exc))
            return False
        except ValueError as exc:
            self._show_error("", 0, "", str(exc))
            return False
        self.error_line, self.error_token, self.error.value = 0, "", ""
        self._attach(new)
        return True

    # -- display --------------------------------------------------------------------------------------------------
    def _show_error(self, text: str, lineno: int, token: str, message: str) -> None:
        self.error_line, self.error_token = int(lineno), str(token)
        listing = ""
        if lineno:
            lines = text.splitlines()
            lo, hi = max(lineno - 2, 1), min(lineno + 1, len(lines))
            rows = []
            for k in range(lo, hi + 1):
                line = lines[k - 1]
                m = re.search(r"(?<!\S)" + re.escape(token) + r"(?!\S)", line) if (k == lineno and token) else None
                if m:                                  # the offending whole token, underlined
                    line = (html.escape(line[:m.start()]) + f"<u><b>{html.escape(token)}</b></u>"
                            + html.escape(line[m.end():]))
                else:
                    line = html.escape(line)
                mark = "&#9654;" if k == lineno else "&nbsp;"
                rows.append(f"{mark} {k:>3}: {line}")
            listing = "<pre style='margin:2px 0'>" + "\n".join(rows) + "</pre>"
        self.error.value = (f"<div style='color:#b00020'><b>Rejected</b> (document unchanged): "
                            f"{html.escape(message)}{listing}</div>")

    def _sync(self, select_last: bool = False) -> None:
        s = self.doc
        names = list(s.surfaces)
        current = self.surface.value
        self._syncing = True                           # one redraw below, not one per trait change
        try:
            self.surface.options = names
            if names:
                self.surface.value = names[-1] if (select_last or current not in names) else current
            for dd, k in ((self.operand_a, -1), (self.operand_b, -2)):
                keep = dd.value
                dd.options = names
                if names:
                    dd.value = keep if keep in names else names[k if len(names) >= -k else -1]
        finally:
            self._syncing = False
        self.history.value = "\n".join(s.lines)
        self.status.value = (f"{len(s.surfaces)} surfaces, {len(s.points)} points "
                             f"({', '.join(s.points.sources) or 'none'}), {len(s.trees)} trees")
        self.refresh()

    def refresh(self) -> None:
        """Redraw the preview (envelope, points, trees); an empty envelope is reported, not raised."""
        try:
            png = preview_png(self.doc, self.surface.value or None, resolution=self.resolution,
                              max_points=self.max_points)
            if self.error.value.startswith(_PREVIEW_ERROR):       # a stale preview message goes
                self.error.value = ""
        except ValueError as exc:
            self.error.value = f"{_PREVIEW_ERROR}Preview: {html.escape(str(exc))}</div>"
            png = preview_png(self.doc, None, resolution=self.resolution, max_points=self.max_points)
        self.preview.value = png

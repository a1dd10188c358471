"""TreeSketch tools driven from code (spec 004_treesketch §2.4–2.8, §2.11; V15, V17).

* :class:`StrokeEmitter`: a brush that emits attraction points continuously while it moves, with a radius
  that may change mid-stroke; at radius 0 the brush becomes a sketch and emits points on the stroke itself
  (§2.5). Every point remembers the stroke direction for sketch-based tropism (§2.7).
* :class:`Timeline`: grow / ungrow at an adjustable speed through per-step snapshots of the engine state
  (the engine pickles), plus per-operation undo / redo (§2.4, V17). Snapshots are budgeted in bytes.
* :func:`lasso_volume`: a closed 2D lasso in a view plane inflated to a point-filled 3D volume: chordal axis
  by the medial axis of the silhouette, Teddy-like circular cross-sections, rejection sampling (§2.6, V15).
* :func:`nearest_node`, :func:`select_branch`, :func:`prune_nearest`: picking for selective growth (§2.8) and
  pruning at the nearest branching point (§2.11).
* :class:`TreeLibrary` and :data:`PRESETS`: a folder of saved trees (``.tree`` text + a JSON of the TreeSketch
  state) and of growth presets (JSON of parameters and options) (Fig. E.8).

The tools act on a :class:`~plantvr.growth.sketch.SketchEngine`; they are numeric (no UI imports), so a view,
a widget or a line of code can drive them alike.
"""
from __future__ import annotations

import json
import math
import pickle
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.ndimage import distance_transform_edt

from .._validation import check_array, check_int, check_point, check_range
from .directions import normalize
from .markers import uniform_in_ball
from .sketch import SketchEngine
from .treefile import tree_from_text, tree_to_text

__all__ = ["PRESETS", "LassoVolume", "StrokeEmitter", "Timeline", "TreeLibrary", "lasso_volume", "nearest_node",
           "prune_nearest", "select_branch"]


# -- brush / sketch strokes (§2.5) --------------------------------------------------------------------------
class StrokeEmitter:
    """Emit attraction points into ``engine`` along a stroke (spec 004 §2.5).

    While moving from the previous centre c0 to c with brush radius R over ``dt`` seconds, a brush (R > 0)
    emits Poisson(rate * R^3 * dt) points uniform in balls of radius R centred on the segment c0 -> c; a sketch
    (R = 0) emits points on the segment itself every ``spacing`` (carrying the remainder from move to move), so
    brushing turns into sketching continuously as R shrinks. Each point carries the stroke direction
    normalize(c - c0) (sketch-based tropism, §2.7).

    Parameters
    ----------
    engine : SketchEngine
        Receives the points (:meth:`SketchEngine.add_stroke_points`).
    rate : float
        Points per unit volume per second of brushing (> 0).
    spacing : float
        Distance between sketch points (R = 0), in internode lengths (> 0).
    rng : int or Generator or None
        Seed of the point positions.
    """

    def __init__(self, engine: SketchEngine, *, rate: float = 20.0, spacing: float = 0.5,
                 rng: int | np.random.Generator | None = None):
        if not isinstance(engine, SketchEngine):
            raise TypeError(f"engine must be a SketchEngine, got {type(engine).__name__}")
        self.engine = engine
        self.rate = check_range("rate", rate, 0.0, np.inf, low_open=True)
        self.spacing = check_range("spacing", spacing, 0.0, np.inf, low_open=True)
        self.rng = np.random.default_rng(rng)
        self._c: np.ndarray | None = None
        self._carry = 0.0
        self.emitted = 0

    @property
    def active(self) -> bool:
        """True between :meth:`begin` and :meth:`end`."""
        return self._c is not None

    def begin(self, point) -> None:
        """Start a stroke at ``point`` (3,)."""
        self._c = check_point("point", point)
        self._carry = 0.0

    def move(self, point, radius: float, dt: float = 1.0 / 30.0) -> np.ndarray:
        """Move the brush to ``point`` with ``radius`` (>= 0) over ``dt`` seconds; returns the points emitted."""
        if self._c is None:
            raise ValueError("move() before begin(): start a stroke first")
        c = check_point("point", point)
        radius = check_range("radius", radius, 0.0, np.inf)
        dt = check_range("dt", dt, 0.0, np.inf)
        c0, seg = self._c, c - self._c
        length = float(np.linalg.norm(seg))
        direction = seg / length if length > 0 else None
        if radius > 0:
            m = int(self.rng.poisson(self.rate * radius ** 3 * dt))
            centres = c0 + self.rng.random((m, 1)) * seg
            pts = centres + radius * uniform_in_ball(m, self.rng)
        else:
            if length == 0:
                pts = np.zeros((0, 3))
            else:
                s = np.arange(self.spacing - self._carry, length + 1e-12, self.spacing)
                self._carry = (self._carry + length) % self.spacing if not len(s) else length - s[-1]
                pts = c0 + s[:, None] / length * seg
        self._c = c
        if direction is None or not len(pts):  # no direction yet: plain points
            if len(pts):
                self.engine.add_markers(pts)
        else:
            self.engine.add_stroke_points(pts, np.tile(direction, (len(pts), 1)))
        self.emitted += len(pts)
        return pts

    def end(self) -> None:
        """Finish the stroke."""
        self._c = None


# -- grow / ungrow and per-operation undo (§2.4, V17) ---------------------------------------------------------
class Timeline:
    """Grow and ungrow ``engine`` continuously, with per-operation undo (spec 004 §2.4, V17).

    ``frames`` holds the engine state after every growth step of the current timeline (pickled bytes); ungrow
    restores an earlier frame, grow replays a later one when no edit happened since (so grow N, ungrow to k,
    regrow to N gives identical arrays), otherwise it steps the engine. :meth:`operation` brackets an edit (a
    stroke, a prune, a width change...) as one undo item; :meth:`undo` / :meth:`redo` swap whole states.
    Frames and undo items are dropped oldest first once they exceed ``max_bytes``.
    """

    def __init__(self, engine: SketchEngine, *, max_bytes: int = 256 * 2 ** 20):
        if not isinstance(engine, SketchEngine):
            raise TypeError(f"engine must be a SketchEngine, got {type(engine).__name__}")
        self.engine = engine
        self.max_bytes = check_int("max_bytes", max_bytes, 1, 2 ** 62)
        self.frames: list[bytes] = [self._dump()]
        self.cursor = 0
        self._undo: list[bytes] = []
        self._redo: list[bytes] = []
        self._carry = 0.0
        self._depth = 0

    def _dump(self) -> bytes:
        return pickle.dumps(self.engine.__getstate__(), protocol=5)

    def _load(self, blob: bytes) -> None:
        self.engine.__setstate__(pickle.loads(blob))

    @property
    def nbytes(self) -> int:
        """Bytes held by frames and undo / redo items."""
        return sum(map(len, self.frames)) + sum(map(len, self._undo)) + sum(map(len, self._redo))

    def _trim(self) -> None:
        while self.nbytes > self.max_bytes and (self._undo or self.cursor > 0):
            if self._undo:
                self._undo.pop(0)
            else:
                self.frames.pop(0)
                self.cursor -= 1

    # -- growth -------------------------------------------------------------------------------------
    def grow(self, steps: int = 1) -> int:
        """Advance ``steps`` growth steps (replaying frames when possible); returns the steps made."""
        steps = check_int("steps", steps, 0, 10 ** 6)
        for _ in range(steps):
            if self.cursor + 1 < len(self.frames):
                self.cursor += 1
                self._load(self.frames[self.cursor])
            else:
                self.engine.step()
                self.frames.append(self._dump())
                self.cursor += 1
                self._trim()
        return steps

    def ungrow(self, steps: int = 1) -> int:
        """Go back ``steps`` growth steps (not before the oldest frame kept); returns the steps undone."""
        steps = check_int("steps", steps, 0, 10 ** 6)
        k = min(steps, self.cursor)
        if k:
            self.cursor -= k
            self._load(self.frames[self.cursor])
        return k

    def advance(self, speed: float, seconds: float) -> int:
        """Grow (speed > 0) or ungrow (speed < 0) at ``speed`` steps per second for ``seconds``; fractional
        steps carry over between calls, as with the spring-loaded Grow slider. Returns the signed steps made."""
        speed = check_range("speed", speed, -1e6, 1e6)
        seconds = check_range("seconds", seconds, 0.0, 1e6)
        if speed * self._carry < 0:  # the slider changed direction: drop the fraction
            self._carry = 0.0
        self._carry += speed * seconds
        k = math.floor(abs(self._carry)) * (1 if self._carry >= 0 else -1)
        self._carry -= k
        return self.grow(k) if k >= 0 else -self.ungrow(-k)

    # -- edits --------------------------------------------------------------------------------------
    @contextmanager
    def operation(self) -> Iterator[SketchEngine]:
        """Bracket an edit of the engine as one undo item; the timeline then continues from the edited state.

        Growth inside the bracket (:meth:`grow`) belongs to the same item (growing while brushing).
        """
        if self._depth == 0:
            before = self._dump()
            del self.frames[self.cursor + 1:]
        self._depth += 1
        try:
            yield self.engine
        except BaseException:
            self._depth -= 1
            if self._depth == 0:
                self._load(before)
            raise
        self._depth -= 1
        if self._depth == 0:
            self._undo.append(before)
            self._redo.clear()
            del self.frames[self.cursor + 1:]
            self.frames[self.cursor] = self._dump()
            self._trim()

    def undo(self) -> bool:
        """Revert the last operation; returns False when there is nothing to undo."""
        if not self._undo:
            return False
        self._redo.append(self._dump())
        self._restart(self._undo.pop())
        return True

    def redo(self) -> bool:
        """Re-apply the last undone operation; returns False when there is nothing to redo."""
        if not self._redo:
            return False
        self._undo.append(self._dump())
        self._restart(self._redo.pop())
        return True

    def _restart(self, blob: bytes) -> None:
        self._load(blob)
        self.frames, self.cursor = [blob], 0


# -- lasso inflation (§2.6, V15) ------------------------------------------------------------------------------
@dataclass(frozen=True)
class LassoVolume:
    """A lasso silhouette inflated to a volume, and the points filling it.

    points : (N, 3) world points; mask : (H, W) bool silhouette raster; height : (H, W) float64 half-thickness
    h(x, y) (0 outside); axis : (H, W) bool chordal-axis pixels; origin, u, v, w : (3,) the plane frame (w the
    normal); lo : (2,) plane coordinates of pixel (0, 0)'s centre; pixel : float, pixel size.
    """

    points: np.ndarray
    mask: np.ndarray
    height: np.ndarray
    axis: np.ndarray
    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    lo: np.ndarray
    pixel: float

    def to_plane(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) world points -> (N, 3) plane coordinates (a along u, b along v, c along w)."""
        d = np.asarray(points, float) - self.origin
        return np.stack([d @ self.u, d @ self.v, d @ self.w], 1)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: inside the envelope (silhouette pixel and |c| <= h)."""
        q = self.to_plane(points)
        col = np.rint((q[:, 0] - self.lo[0]) / self.pixel).astype(np.int64)
        row = np.rint((q[:, 1] - self.lo[1]) / self.pixel).astype(np.int64)
        ok = (row >= 0) & (row < self.mask.shape[0]) & (col >= 0) & (col < self.mask.shape[1])
        out = np.zeros(len(q), bool)
        out[ok] = self.mask[row[ok], col[ok]] & (np.abs(q[ok, 2]) <= self.height[row[ok], col[ok]])
        return out


def lasso_volume(polygon, *, origin=(0.0, 0.0, 0.0), u=(1.0, 0.0, 0.0), v=(0.0, 1.0, 0.0), n_points: int = 500,
                 pixel: float | None = None, rng: int | np.random.Generator | None = None) -> LassoVolume:
    """Inflate a closed 2D lasso to a volume and fill it with ``n_points`` attraction points (spec 004 §2.6).

    The lasso is rasterised (``skimage.draw.polygon``); its chordal axis is the medial axis of the silhouette
    (``skimage.morphology.medial_axis``, thinning in the spirit of Hall 1989); with D the distance to the
    boundary and R the distance value at the nearest axis pixel, the envelope's half-thickness is
    h = sqrt(R^2 - (R - min(D, R))^2) (circular, Teddy-like cross-sections, maximal on the axis). Points are
    drawn uniformly in the bounding box and kept when inside the envelope.

    Parameters
    ----------
    polygon : (K, 2) float64 array, K >= 3
        Lasso vertices in plane coordinates (along ``u`` and ``v``); closed implicitly.
    origin, u, v : (3,) float64
        The view plane: its origin and two orthogonal in-plane directions (normalised here); w = u x v.
    n_points : int
        Points to generate.
    pixel : float, optional
        Raster pixel size; default 1/128 of the lasso's larger extent.
    rng : int or Generator or None
        Seed of the rejection sampler.

    Returns
    -------
    LassoVolume

    References
    ----------
    .. [1] Longay thesis §5.2.2, Fig. 5.12 (Hall 1989 chordal axis; Igarashi et al. 1999 Teddy inflation);
           spec 004 §2.6 [INFERRED] Python recipe.
    """
    from skimage.draw import polygon as raster_polygon
    from skimage.morphology import medial_axis

    poly = check_array("polygon", polygon, shape=(None, 2), min_rows=3)
    origin = check_point("origin", origin)
    u = normalize(check_point("u", u))
    v = check_point("v", v)
    v = v - (v @ u) * u
    if np.linalg.norm(v) < 1e-12:
        raise ValueError("u and v must not be parallel")
    v = normalize(v)
    w = np.cross(u, v)
    n_points = check_int("n_points", n_points, 0, 10 ** 8)
    ext = poly.max(0) - poly.min(0)
    if ext.min() <= 0:
        raise ValueError(f"polygon must enclose an area, got extent {ext.tolist()}")
    pixel = ext.max() / 128.0 if pixel is None else check_range("pixel", pixel, 0.0, np.inf, low_open=True)
    lo = poly.min(0) - 2 * pixel
    shape = tuple(np.ceil((poly.max(0) + 2 * pixel - lo) / pixel).astype(int)[::-1] + 1)  # (rows, cols)
    rr, cc = raster_polygon((poly[:, 1] - lo[1]) / pixel, (poly[:, 0] - lo[0]) / pixel, shape)
    mask = np.zeros(shape, bool)
    mask[rr, cc] = True
    if not mask.any():
        raise ValueError("polygon is smaller than one pixel; pass a smaller pixel")
    axis, dist = medial_axis(mask, return_distance=True)
    D = dist * pixel
    _, (ir, ic) = distance_transform_edt(~axis, return_indices=True)
    R = D[ir, ic]
    Dc = np.minimum(D, R)
    h = np.where(mask, np.sqrt(np.maximum(R * R - (R - Dc) ** 2, 0.0)), 0.0)
    h[mask] = np.maximum(h[mask], 0.5 * pixel * (D[mask] > 0))  # a sliver is at least half a pixel thick
    rng = np.random.default_rng(rng)
    hmax = float(h.max())
    vol = LassoVolume(np.zeros((0, 3)), mask, h, axis, origin, u, v, w, lo, float(pixel))
    box_lo = np.array([lo[0] - 0.5 * pixel, lo[1] - 0.5 * pixel, -hmax])
    box_hi = np.array([lo[0] + (shape[1] - 0.5) * pixel, lo[1] + (shape[0] - 0.5) * pixel, hmax])
    frac = max(float(2 * h.sum() * pixel ** 2) / float(np.prod(box_hi - box_lo)), 1e-3)
    got: list[np.ndarray] = []
    count = 0
    while count < n_points:
        m = int(1.2 * (n_points - count) / frac) + 16
        q = rng.uniform(box_lo, box_hi, (m, 3))
        world = origin + q[:, :1] * u + q[:, 1:2] * v + q[:, 2:] * w
        keep = world[vol.contains(world)]
        got.append(keep[: n_points - count])
        count += len(got[-1])
    pts = np.concatenate(got) if got else np.zeros((0, 3))
    return LassoVolume(pts, mask, h, axis, origin, u, v, w, lo, float(pixel))


# -- picking: selective growth and pruning (§2.8, §2.11) -------------------------------------------------------
def nearest_node(engine: SketchEngine, point) -> int:
    """The live node (internode tip, not the base point) nearest to ``point`` (3,)."""
    point = check_point("point", point)
    t = engine.tree
    live = np.flatnonzero(t.alive)
    live = live[live > 0]
    return int(live[np.argmin(np.sum((t.pos[live] - point) ** 2, 1))])


def select_branch(engine: SketchEngine, point, direction=None) -> int:
    """Press-and-hold: enter selective growth at the node nearest ``point``, its bud turned along the stroke's
    initial ``direction`` when given; returns that node (§2.8)."""
    node = nearest_node(engine, point)
    engine.select(node, direction)
    return node


def prune_nearest(engine: SketchEngine, point) -> int:
    """Double-tap: prune the branch nearest ``point`` at its nearest branching point; returns internodes removed."""
    return engine.prune_at(nearest_node(engine, point))


def _reorder(tree, rank: np.ndarray):
    """Tree whose node ``rank[i]`` is ``tree``'s node i (parents stay before children when ``rank`` is a
    creation order)."""
    from .tree import Tree

    perm = np.argsort(rank)
    out = Tree(tree.nslots, max(tree.n, 1))
    for k, arr in tree._data.items():
        out._data[k][: tree.n] = arr[: tree.n][perm]
    out.n = tree.n
    par = out.parent
    par[par >= 0] = rank[par[par >= 0]]
    ch = out.child
    ch[ch >= 0] = rank[ch[ch >= 0]]
    if np.any(par >= np.arange(out.n)):
        raise ValueError("creation_rank puts a child before its parent")
    return out


# -- tree library and presets (Fig. E.8) -----------------------------------------------------------------------
PRESETS: dict[str, dict[str, Any]] = {
    # [INFERRED] starting points after the thesis's figures; the parameter values are not thesis numbers
    "excurrent_conifer": {"params": {"apical_dominance": 0.62, "tropism_angle": 100.0, "w_heading": 0.4,
                                     "w_tropism": 0.2, "w_env": 0.4, "branch_angle": 70.0},
                          "options": {"trunk_up": True, "n_max": 3}},                       # Fig. 4.19
    "weeping": {"params": {"tropism_angle": 160.0, "w_heading": 0.35, "w_tropism": 0.3, "w_env": 0.35},
                "options": {"n_max": 6}},                                                  # Fig. 4.18, n_max = 6
    "broad_decurrent": {"params": {"apical_dominance": 0.46, "tropism_angle": 90.0, "w_heading": 0.3,
                                   "w_tropism": 0.3, "w_env": 0.4},
                        "options": {"ellipse": [0.7, 1.4, 0.0]}},                          # Figs. 4.13, 4.22C
    "gnarled": {"params": {"w_heading": 0.2, "w_tropism": 0.1, "w_env": 0.7},
                "options": {"deflection": 30.0, "n_max": 2}},                              # Fig. 4.24, δ = 30°
}

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}$")
_LIB_FORMAT = "plantvr-treesketch 1"


class TreeLibrary:
    """A folder of saved TreeSketch trees and growth presets (spec 004 checklist B, Fig. E.8).

    A tree is two files: ``<name>.tree`` (the tree and its growth parameters, :mod:`plantvr.growth.treefile`) and
    ``<name>.json`` (TreeSketch options, seed, step count, generator state, attraction points with their
    stroke directions, width constraints, selection and node birth steps). :meth:`load` rebuilds an engine that
    continues exactly as the saved one (node indices are renumbered in depth-first order; radius, light and
    vigor are recomputed). A preset is ``<name>.preset.json`` with ``{"params": ..., "options": ...}``; the
    built-in :data:`PRESETS` are always available.
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)

    @staticmethod
    def _name(name: str) -> str:
        if not isinstance(name, str) or not _NAME.match(name) or name.endswith(".preset"):
            raise ValueError(f"name must be 1-100 letters, digits, '_', '-' or '.', got {name!r}")
        return name

    def trees(self) -> list[str]:
        """Names of the saved trees."""
        return sorted(p.stem for p in self.folder.glob("*.tree") if (self.folder / f"{p.stem}.json").exists())

    def presets(self) -> list[str]:
        """Names of the built-in and saved presets."""
        saved = [p.name[: -len(".preset.json")] for p in self.folder.glob("*.preset.json")]
        return sorted(set(PRESETS) | set(saved))

    # -- trees --------------------------------------------------------------------------------------
    def save(self, name: str, engine: SketchEngine) -> Path:
        """Save ``engine``'s full state as ``name``; returns the ``.tree`` path."""
        name = self._name(name)
        if not isinstance(engine, SketchEngine):
            raise TypeError(f"engine must be a SketchEngine, got {type(engine).__name__}")
        t = engine.tree
        order = t.preorder()  # the .tree file's node order
        rank = np.cumsum(t.alive) - 1  # creation order among live nodes: growth visits nodes in this order
        markers = engine.markers
        meta = {"format": _LIB_FORMAT, "options": engine.sketch, "seed": engine.seed,
                "step_count": engine.step_count, "rng": engine.rng.bit_generator.state,
                "markers": markers.tolist(), "marker_age": engine.marker_age.tolist(),
                "stroke_dirs": engine.stroke_directions(markers).tolist(),
                "width_constraints": [[int(rank[k]), v] for k, v in engine.width_constraints.items()],
                "selected": None if engine.selected is None else int(rank[engine.selected]),
                "bud_override": [[int(rank[n]), int(k), *map(float, d)] for (n, k), d in engine.bud_override.items()],
                "born": t.born[t.alive].tolist(), "creation_rank": rank[order].tolist()}
        path = self.folder / f"{name}.tree"
        path.write_text(tree_to_text(t, engine.params))
        (self.folder / f"{name}.json").write_text(json.dumps(meta))
        return path

    def read_entry(self, name: str) -> tuple[str, Any]:
        """The ``.tree`` text and the parsed ``.json`` metadata saved as ``name`` (``ValueError`` if unreadable)."""
        name = self._name(name)
        try:
            text = (self.folder / f"{name}.tree").read_text()
            meta = json.loads((self.folder / f"{name}.json").read_text())
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"cannot read library tree {name!r} in {self.folder}: {exc}") from None
        return text, meta

    def load(self, name: str) -> SketchEngine:
        """Rebuild the engine saved as ``name``; raises ``ValueError`` on a missing or corrupt entry."""
        name = self._name(name)
        text, meta = self.read_entry(name)
        if not isinstance(meta, dict) or meta.get("format") != _LIB_FORMAT:
            raise ValueError(f"{name}.json is not a TreeSketch library entry (format {_LIB_FORMAT!r})")
        tree, params = tree_from_text(text)
        from ..params import defaults

        try:
            opts = dict(meta["options"])
            opts["ellipse"] = tuple(opts["ellipse"])
            e = SketchEngine({**defaults(), **params}, rng=int(meta["seed"]), **opts)
            markers = np.asarray(meta["markers"], float).reshape(-1, 3)
            dirs = np.asarray(meta["stroke_dirs"], float).reshape(-1, 3)
            age = np.asarray(meta["marker_age"], np.int64)
            born = np.asarray(meta["born"], np.int64)
            crank = np.asarray(meta["creation_rank"], np.int64)
            if len(born) != tree.n or len(crank) != tree.n or len(age) != len(markers) or len(dirs) != len(markers):
                raise ValueError("array lengths do not match the tree")
            if not np.array_equal(np.sort(crank), np.arange(tree.n)):
                raise ValueError("creation_rank is not a permutation")
            cons = {int(k): float(v) for k, v in meta["width_constraints"]}
            sel = meta["selected"]
            override = {(int(r[0]), int(r[1])): np.asarray(r[2:5], float) for r in meta.get("bud_override", [])}
            rng_state = meta["rng"]
            step_count = int(meta["step_count"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"library tree {name!r} is corrupt: {exc}") from None
        e.tree = _reorder(tree, crank)
        e.tree.born[:] = born
        e.markers, e.marker_age = markers, age
        stroke = np.linalg.norm(dirs, axis=1) > 0
        e._stroke_dirs = {m.tobytes(): d for m, d in zip(markers[stroke], dirs[stroke])}
        e.step_count = step_count
        e.rng.bit_generator.state = rng_state
        e.width_constraints = cons
        e.selected = None if sel is None else int(sel)
        e.bud_override = override
        e._new_nodes = np.zeros(0, np.int64)
        e.rebuild_light()
        return e

    # -- presets ------------------------------------------------------------------------------------
    def save_preset(self, name: str, engine: SketchEngine, *, keys: list[str] | None = None) -> Path:
        """Save ``engine``'s growth parameters (all, or ``keys``) and TreeSketch options as preset ``name``."""
        name = self._name(name)
        params = engine.params if keys is None else {k: engine.params[k] for k in keys}
        path = self.folder / f"{name}.preset.json"
        path.write_text(json.dumps({"format": _LIB_FORMAT, "params": params, "options": engine.sketch}))
        return path

    def preset(self, name: str) -> dict[str, Any]:
        """The preset ``name`` as ``{"params": {...}, "options": {...}}`` (a saved one shadows a built-in)."""
        name = self._name(name)
        path = self.folder / f"{name}.preset.json"
        if path.exists():
            try:
                data = json.loads(path.read_text())
                return {"params": dict(data["params"]), "options": dict(data["options"])}
            except (OSError, json.JSONDecodeError, KeyError, TypeError) as exc:
                raise ValueError(f"preset {name!r} is corrupt: {exc}") from None
        if name in PRESETS:
            return {k: dict(v) for k, v in PRESETS[name].items()}
        raise ValueError(f"unknown preset {name!r}; available: {self.presets()}")

    def apply_preset(self, name: str, engine: SketchEngine) -> None:
        """Load preset ``name`` into ``engine``: parameters validated first, then options; all checked before
        anything is set."""
        from ..params import validate

        pre = self.preset(name)
        params = validate(pre["params"])
        opts = dict(pre["options"])
        if "ellipse" in opts:
            opts["ellipse"] = tuple(opts["ellipse"])
        probe = SketchEngine({**engine.params, **params}, rng=0)
        probe.set_options(**opts)  # raises before the engine is touched
        engine.set_options(**opts)
        engine.set_params(params)

"""TreeSketch tools driven from code (spec 004_treesketch §2.5–2.8, §2.11; V15).

* :class:`StrokeEmitter`: a brush that emits attraction points continuously while it moves, with a radius
  that may change mid-stroke; at radius 0 the brush becomes a sketch and emits points on the stroke itself
  (§2.5). Every point remembers the stroke direction for sketch-based tropism (§2.7).
* :func:`lasso_volume`: a closed 2D lasso in a view plane inflated to a point-filled 3D volume: chordal axis
  by the medial axis of the silhouette, Teddy-like circular cross-sections, rejection sampling (§2.6, V15).
* :func:`nearest_node`, :func:`select_branch`, :func:`prune_nearest`: picking for selective growth (§2.8) and
  pruning at the nearest branching point (§2.11).
* :class:`TreeLibrary` and :data:`PRESETS`: a folder of saved trees (``.tree`` text + a JSON of the TreeSketch
  state) and of growth presets (the one preset format, :data:`~plantvr.growth.sketch.TREESKETCH` values) (Fig. E.8).

Grow / ungrow with per-operation undo (§2.4, V17) is the history of the TreeSketch document
(:class:`plantvr.documents.treesketch.SketchDocument`). The tools act on a :class:`~plantvr.growth.sketch.SketchEngine`; they are numeric (no UI imports), so a view,
a widget or a line of code can drive them alike.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.ndimage import distance_transform_edt

from .._fileio import atomic_write, make_folder, read_text, write_atomic
from .._validation import MAX_COORD, MAX_COUNT, check_array, check_int, check_point, check_points, check_range
from .directions import normalize
from .markers import uniform_in_ball
from .sketch import TREESKETCH, SketchEngine, split_values
from .treefile import tree_from_text, tree_to_text

__all__ = ["PRESETS", "LassoVolume", "StrokeEmitter", "TreeLibrary", "lasso_volume", "nearest_node",
           "prune_nearest", "select_branch"]


# -- brush / sketch strokes (§2.5) --------------------------------------------------------------------------
#: Most points one :meth:`StrokeEmitter.move` may emit (expected count): bounds memory whatever the radius.
MAX_POINTS_PER_MOVE = 10_000_000

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
        self.rate = check_range("rate", rate, *TREESKETCH["stroke_rate"].range, low_open=True)
        self.spacing = check_range("spacing", spacing, *TREESKETCH["stroke_spacing"].range)
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
        radius = check_range("radius", radius, 0.0, MAX_COORD)
        dt = check_range("dt", dt, 0.0, 1e6)
        c0, seg = self._c, c - self._c
        length = float(np.linalg.norm(seg))
        direction = seg / length if length > 0 else None
        expect = self.rate * radius ** 3 * dt if radius > 0 else length / self.spacing
        if expect > MAX_POINTS_PER_MOVE:  # checked before anything is drawn: a rejected move changes nothing
            raise ValueError(f"radius, dt and rate (or the sketch spacing) ask for about {expect:.3g} points in one "
                             f"move, more than {MAX_POINTS_PER_MOVE}; move in smaller steps")
        if len(self.engine.markers) + 2 * expect + 64 > MAX_COUNT:
            raise ValueError(f"the engine holds {len(self.engine.markers)} markers; this move would pass {MAX_COUNT}")
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


# -- lasso inflation (§2.6, V15) ------------------------------------------------------------------------------
#: Bounds of :func:`lasso_volume`: raster pixels and generated points.
MAX_LASSO_PIXELS = 1 << 24
MAX_LASSO_POINTS = 10_000_000

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
        d = check_array("points", points, shape=(None, 3)) - self.origin
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

    poly = check_array("polygon", polygon, shape=(None, 2), min_rows=3, max_abs=MAX_COORD)
    if len(poly) > 1_000_000:
        raise ValueError(f"polygon must have at most 1000000 vertices, got {len(poly)}")
    origin = check_point("origin", origin)
    u = check_point("u", u)
    if not np.linalg.norm(u) > 1e-12:
        raise ValueError(f"u must be a non-zero vector, got {u.tolist()}")
    u = normalize(u)
    v = check_point("v", v)
    v = v - (v @ u) * u
    if np.linalg.norm(v) < 1e-12:
        raise ValueError("u and v must not be parallel")
    v = normalize(v)
    w = np.cross(u, v)
    n_points = check_int("n_points", n_points, 0, MAX_LASSO_POINTS)
    ext = poly.max(0) - poly.min(0)
    if not ext.min() > 1e-9 * max(float(np.abs(poly).max()), 1e-300):
        raise ValueError(f"polygon must enclose an area, got extent {ext.tolist()}")
    pixel = ext.max() / 128.0 if pixel is None else check_range("pixel", pixel, 0.0, MAX_COORD, low_open=True)
    cells = np.ceil((ext + 4 * pixel) / pixel) + 1
    if float(np.prod(cells)) > MAX_LASSO_PIXELS:
        raise ValueError(f"pixel must be at least {float(np.sqrt(np.prod(ext + 4 * pixel) / MAX_LASSO_PIXELS)):.3g} "
                         f"for this polygon (the raster may hold {MAX_LASSO_PIXELS} pixels), got {pixel!r}")
    lo = poly.min(0) - 2 * pixel
    shape = tuple(np.ceil((poly.max(0) + 2 * pixel - lo) / pixel).astype(int)[::-1] + 1)  # (rows, cols)
    rr, cc = raster_polygon((poly[:, 1] - lo[1]) / pixel, (poly[:, 0] - lo[0]) / pixel, shape)
    mask = np.zeros(shape, bool)
    mask[rr, cc] = True
    if not mask.any():
        raise ValueError("polygon is smaller than one pixel; pass a smaller pixel")
    axis, dist = medial_axis(mask, return_distance=True, rng=0)  # its tie-breaking is random: fixed, so a lasso replays
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
    count = stall = 0
    while count < n_points:
        m = min(int(1.2 * (n_points - count) / frac) + 16, 1 << 22)  # batches bound the memory
        q = rng.uniform(box_lo, box_hi, (m, 3))
        world = origin + q[:, :1] * u + q[:, 1:2] * v + q[:, 2:] * w
        keep = world[vol.contains(world)]
        got.append(keep[: n_points - count])
        count += len(got[-1])
        stall = 0 if len(keep) else stall + 1
        if stall > 32:
            raise ValueError("polygon's envelope is too thin to sample at this pixel size; pass a smaller pixel")
    pts = np.concatenate(got) if got else np.zeros((0, 3))
    return LassoVolume(pts, mask, h, axis, origin, u, v, w, lo, float(pixel))


# -- picking: selective growth and pruning (§2.8, §2.11) -------------------------------------------------------
def nearest_node(engine: SketchEngine, point) -> int:
    """The live node (internode tip, not the base point) nearest to ``point`` (3,)."""
    if not isinstance(engine, SketchEngine):
        raise TypeError(f"engine must be a SketchEngine, got {type(engine).__name__}")
    point = check_point("point", point)
    t = engine.tree
    live = np.flatnonzero(t.alive[: t.n])
    live = live[live > 0]
    if not len(live):
        raise ValueError("engine has no internode to pick")
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
    # [INFERRED] starting points after the thesis's figures (TREESKETCH values); the values are not thesis numbers
    "excurrent_conifer": {"apical_dominance": 0.62, "tropism_angle": 100.0, "w_heading": 0.4, "w_tropism": 0.2,
                          "w_env": 0.4, "branch_angle": 70.0, "trunk_up": True, "n_max": 3},        # Fig. 4.19
    "weeping": {"tropism_angle": 160.0, "w_heading": 0.35, "w_tropism": 0.3, "w_env": 0.35, "n_max": 6},  # Fig. 4.18
    "broad_decurrent": {"apical_dominance": 0.46, "tropism_angle": 90.0, "w_heading": 0.3, "w_tropism": 0.3,
                        "w_env": 0.4, "ellipse_sv": 0.7, "ellipse_sp": 1.4, "ellipse_ev": 0.0},  # Figs. 4.13, 4.22C
    "gnarled": {"w_heading": 0.2, "w_tropism": 0.1, "w_env": 0.7, "deflection": 30.0, "n_max": 2},  # Fig. 4.24
}

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}$")
_LIB_FORMAT = "plantvr-treesketch 2"
_OLD_FORMATS = ("plantvr-treesketch 1",)  # read (no checksum), never written
#: Largest library file (``.tree``, ``.json`` or ``.preset.json``) :class:`TreeLibrary` reads, bytes.
MAX_ENTRY_BYTES = 1 << 30


def _sha256(data: str) -> str:
    return hashlib.sha256(data.encode("utf-8")).hexdigest()


def _canonical(meta: dict) -> str:
    """The text a library checksum covers: ``meta`` without its ``checksum``, keys sorted."""
    return json.dumps({k: v for k, v in meta.items() if k != "checksum"}, sort_keys=True, separators=(",", ":"))


def _sealed(meta: dict) -> str:
    """``meta`` as JSON text with a SHA-256 ``checksum`` of its other fields (checked on load)."""
    return json.dumps({**meta, "checksum": _sha256(_canonical(meta))}, allow_nan=False)


def _read_text(path: Path, what: str) -> str:
    """The UTF-8 text of ``path`` (at most MAX_ENTRY_BYTES), or ``ValueError`` starting "cannot read ``what``"."""
    try:
        return read_text(path, what="file", max_bytes=MAX_ENTRY_BYTES)
    except ValueError as exc:
        raise ValueError(f"cannot read {what}: {exc}") from None


def _parse_json(text: str, what: str) -> Any:
    try:
        return json.loads(text)
    except (json.JSONDecodeError, RecursionError, ValueError) as exc:
        raise ValueError(f"cannot read {what}: not valid JSON ({str(exc)[:200]})") from None


def _open_meta(text: str, what: str) -> dict:
    """Parse a library JSON file and check its format and (format 2) checksum."""
    meta = _parse_json(text, what)
    if not isinstance(meta, dict) or meta.get("format") not in (_LIB_FORMAT, *_OLD_FORMATS):
        fmt = meta.get("format") if isinstance(meta, dict) else None
        raise ValueError(f"{what} is not a TreeSketch library file (format {_LIB_FORMAT!r}), got format {fmt!r}")
    if meta["format"] == _LIB_FORMAT and meta.get("checksum") != _sha256(_canonical(meta)):
        raise ValueError(f"{what} is damaged: its checksum does not match its contents")
    return meta


def _float_rows(name: str, value: Any, cols: int, *, rows: int | None = None, max_abs: float = MAX_COORD
                ) -> np.ndarray:
    if isinstance(value, list) and not value:
        arr = np.zeros((0, cols))
    else:
        if not isinstance(value, list):
            raise ValueError(f"{name} must be a list of rows, got {type(value).__name__}")
        arr = check_array(name, value, shape=(rows, cols), max_abs=max_abs)
    if rows is not None and len(arr) != rows:
        raise ValueError(f"{name} must have {rows} rows, got {len(arr)}")
    if len(arr) > MAX_COUNT:
        raise ValueError(f"{name} must have at most {MAX_COUNT} rows, got {len(arr)}")
    return arr


def _int_list(name: str, value: Any, n: int, lo: int, hi: int) -> np.ndarray:
    if not isinstance(value, list) or not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        raise ValueError(f"{name} must be a list of integers")
    if len(value) != n:
        raise ValueError(f"{name} must have {n} entries, got {len(value)}")
    arr = np.array(value, dtype=object)
    if n and not all(lo <= v <= hi for v in value):
        raise ValueError(f"{name} entries must be in [{lo}, {hi}]")
    return np.asarray(arr.tolist() if n else [], np.int64)


class TreeLibrary:
    """A folder of saved TreeSketch trees and growth presets (spec 004 checklist B, Fig. E.8).

    A tree is two files: ``<name>.tree`` (the tree and its growth parameters, :mod:`plantvr.growth.treefile`) and
    ``<name>.json`` (TreeSketch options, seed, step count, generator state, attraction points with their
    stroke directions, width constraints, selection and node birth steps). :meth:`load` rebuilds an engine that
    continues exactly as the saved one (node indices are renumbered in depth-first order; radius, light and
    vigor are recomputed). A preset is ``<name>.preset.json`` in the one preset format of the parameter tables
    (:data:`~plantvr.growth.sketch.TREESKETCH` values); the built-in :data:`PRESETS` are always available.

    Files are JSON and text only (nothing is unpickled). Every save is atomic (:mod:`plantvr._fileio`): a failed
    save leaves the previous files as they were. Format 2 (written since issue 20) seals each JSON file with a
    SHA-256 checksum of its contents, and an entry's JSON with the checksum of its ``.tree`` text, so a damaged
    or mismatched file is refused on load; every value read is checked (types, finite values, ranges, indices)
    before an engine is built. Format 1 files (no checksum) are still read.
    """

    def __init__(self, folder: str | Path):
        if not isinstance(folder, (str, Path)):
            raise ValueError(f"folder must be a path, got {type(folder).__name__}")
        self.folder = Path(folder)             # created by the first save (one level), never by a load

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
        """Save ``engine``'s full state as ``name``; returns the ``.tree`` path.

        Both files are written to temporary files first and renamed over the old ones only when both are complete,
        so a failed save (disk full, a bad value) leaves the previous entry intact.
        """
        name = self._name(name)
        if not isinstance(engine, SketchEngine):
            raise TypeError(f"engine must be a SketchEngine, got {type(engine).__name__}")
        t = engine.tree
        order = t.preorder()  # the .tree file's node order
        rank = np.cumsum(t.alive) - 1  # creation order among live nodes: growth visits nodes in this order
        markers = engine.markers
        text = tree_to_text(t, engine.params)
        meta = {"format": _LIB_FORMAT, "options": engine.sketch, "seed": engine.seed,
                "step_count": engine.step_count, "rng": engine.rng.bit_generator.state,
                "markers": markers.tolist(), "marker_age": engine.marker_age.tolist(),
                "stroke_dirs": engine.stroke_directions(markers).tolist(),
                "width_constraints": [[int(rank[k]), v] for k, v in engine.width_constraints.items()],
                "selected": None if engine.selected is None else int(rank[engine.selected]),
                "bud_override": [[int(rank[n]), int(k), *map(float, d)] for (n, k), d in engine.bud_override.items()],
                "born": t.born[t.alive].tolist(), "creation_rank": rank[order].tolist(),
                "tree_sha256": _sha256(text)}
        try:
            js = _sealed(meta)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"cannot save {name!r}: the engine state is not JSON-serialisable ({exc})") from None
        make_folder(self.folder, name="tree library folder")   # one level; its parent must exist
        path = self.folder / f"{name}.tree"
        with atomic_write(self.folder / f"{name}.json", "w") as fj:
            fj.write(js)
            fj.flush()
            os.fsync(fj.fileno())  # the metadata is on disk before the .tree is replaced
            with atomic_write(path, "w") as ft:
                ft.write(text)
        return path

    def read_entry(self, name: str) -> tuple[str, Any]:
        """The ``.tree`` text and the parsed, checksum-verified ``.json`` metadata saved as ``name``
        (``ValueError`` if missing, unreadable, damaged or mismatched)."""
        name = self._name(name)
        text = _read_text(self.folder / f"{name}.tree", f"library tree {name!r}")
        meta = _open_meta(_read_text(self.folder / f"{name}.json", f"library tree {name!r}"),
                          f"library tree {name!r} in {self.folder} ({name}.json)")
        if meta["format"] == _LIB_FORMAT and meta.get("tree_sha256") != _sha256(text):
            raise ValueError(f"library tree {name!r} is damaged: {name}.tree does not match {name}.json "
                             "(one of them was changed or only partly saved)")
        return text, meta

    def load(self, name: str) -> SketchEngine:
        """Rebuild the engine saved as ``name``; raises ``ValueError`` on a missing or corrupt entry."""
        name = self._name(name)
        text, meta = self.read_entry(name)
        from ..params import defaults
        from .sketch import check_grid_reach

        try:
            tree, params = tree_from_text(text)
            n = tree.n
            pos = check_points("tree node positions", tree.pos[:n])
            check_array("tree node frames", np.concatenate([tree.head[:n], tree.lat[:n]]), shape=(None, 3),
                        max_abs=1e6)
            params = {**defaults(), **params}
            check_grid_reach(params, pos, name="tree node positions")
            if not isinstance(meta.get("options"), dict):
                raise ValueError("options must be a dict of SketchEngine options")
            seed = meta.get("seed")
            if not isinstance(seed, int) or isinstance(seed, bool):
                raise ValueError(f"seed must be an integer, got {seed!r}")
            step_count = meta.get("step_count")
            if not isinstance(step_count, int) or isinstance(step_count, bool):
                raise ValueError(f"step_count must be an integer, got {step_count!r}")
            step_count = check_int("step_count", step_count, 0, 10 ** 9)
            e = SketchEngine(params, rng=seed, **meta["options"])
            markers = _float_rows("markers", meta.get("markers"), 3)
            dirs = _float_rows("stroke_dirs", meta.get("stroke_dirs"), 3, rows=len(markers), max_abs=2.0)
            age = _int_list("marker_age", meta.get("marker_age"), len(markers), 0, 10 ** 9)
            born = _int_list("born", meta.get("born"), n, 0, 10 ** 9)
            crank = _int_list("creation_rank", meta.get("creation_rank"), n, 0, n - 1)
            if not np.array_equal(np.sort(crank), np.arange(n)):
                raise ValueError("creation_rank is not a permutation")
            new_tree = _reorder(tree, crank)
            cons = {}
            wc = meta.get("width_constraints")
            if not isinstance(wc, list):
                raise ValueError("width_constraints must be a list of [node, diameter] pairs")
            for item in wc:
                if not isinstance(item, list) or len(item) != 2:
                    raise ValueError(f"width_constraints entries must be [node, diameter], got {item!r}")
                k = check_int("width constraint node", item[0], 1, n - 1)
                cons[k] = check_range("width constraint diameter", item[1], 1e-9, MAX_COORD)
            sel = meta.get("selected")
            sel = None if sel is None else check_int("selected", sel, 0, n - 1)
            override = {}
            bo = meta.get("bud_override", [])
            if not isinstance(bo, list):
                raise ValueError("bud_override must be a list of [node, slot, dx, dy, dz]")
            for r in bo:
                if not isinstance(r, list) or len(r) != 5:
                    raise ValueError(f"bud_override entries must be [node, slot, dx, dy, dz], got {r!r}")
                key = (check_int("bud_override node", r[0], 0, n - 1),
                       check_int("bud_override slot", r[1], 0, tree.nslots - 1))
                override[key] = check_array("bud_override direction", r[2:5], shape=(3,), max_abs=2.0)
            rng_state = meta.get("rng")
            if not isinstance(rng_state, dict) or rng_state.get("bit_generator") != type(e.rng.bit_generator).__name__:
                raise ValueError(f"rng must be a {type(e.rng.bit_generator).__name__} generator state")
            try:
                e.rng.bit_generator.state = rng_state
            except (TypeError, ValueError, KeyError, OverflowError) as exc:
                raise ValueError(f"rng state is invalid ({exc})") from None
        except ValueError as exc:
            raise ValueError(f"library tree {name!r} is corrupt: {exc}") from None
        except (KeyError, TypeError, IndexError, OverflowError) as exc:
            raise ValueError(f"library tree {name!r} is corrupt: {exc!r}") from None
        e.tree = new_tree
        e.tree.born[:n] = born
        e.markers, e.marker_age = markers, age
        stroke = np.linalg.norm(dirs, axis=1) > 0
        e._stroke_dirs = {m.tobytes(): d for m, d in zip(markers[stroke], dirs[stroke])}
        e.step_count = step_count
        e.width_constraints = cons
        e.selected = sel
        e.bud_override = override
        e._new_nodes = np.zeros(0, np.int64)
        e.rebuild_light()
        return e

    # -- presets: the one preset format of the parameter tables --------------------------------------
    def save_preset(self, name: str, engine: SketchEngine, *, keys: list[str] | None = None) -> Path:
        """Save ``engine``'s growth parameters and TreeSketch options (all, or the :data:`~plantvr.growth.sketch.
        TREESKETCH` names ``keys``) as preset ``name``, atomically, in the one preset format
        (:meth:`plantvr.params.ParamTable.preset_text`)."""
        name = self._name(name)
        if not isinstance(engine, SketchEngine):
            raise TypeError(f"engine must be a SketchEngine, got {type(engine).__name__}")
        values = engine.table_values()
        if keys is not None:
            if isinstance(keys, str) or not all(isinstance(k, str) for k in keys):
                raise ValueError(f"keys must be a list of parameter names, got {keys!r}")
            unknown = sorted(set(keys) - set(values))
            if unknown:
                raise ValueError(f"keys must be parameter names, got unknown {unknown[:5]}")
            values = {k: values[k] for k in keys}
        make_folder(self.folder, name="tree library folder")
        path = self.folder / f"{name}.preset.json"
        write_atomic(path, TREESKETCH.preset_text(values))
        return path

    def preset(self, name: str) -> dict[str, Any]:
        """The preset ``name`` as checked :data:`~plantvr.growth.sketch.TREESKETCH` values ``{name: value}`` (a saved
        one shadows a built-in); a saved preset is read with :meth:`plantvr.params.ParamTable.read_preset`."""
        name = self._name(name)
        path = self.folder / f"{name}.preset.json"
        if path.exists():
            return TREESKETCH.read_preset(path)
        if name in PRESETS:
            return dict(PRESETS[name])
        raise ValueError(f"unknown preset {name!r}; available: {self.presets()}")

    def apply_preset(self, name: str, engine: SketchEngine) -> None:
        """Load preset ``name`` into ``engine``: parameters and options are all checked (against the table, the
        engine's option checks and this tree) before anything is set."""
        if not isinstance(engine, SketchEngine):
            raise TypeError(f"engine must be a SketchEngine, got {type(engine).__name__}")
        params, opts = split_values(self.preset(name), engine.sketch["ellipse"])
        opts = engine._check_options(opts)
        engine.checked_params(params)  # raises before the engine is touched
        engine.set_options(**opts)
        engine.set_params(params)

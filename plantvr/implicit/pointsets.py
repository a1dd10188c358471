"""Composite tagged point sets, thinning, densifying and their files (spec 003_implicit_sca §3.8-3.9; C-15, C-16).

``points.txt``: optional ``#`` header lines (generator parameters, seed, source names), then one ``x y z [tag]`` per
line in ``%.6g``. ``.props``: ``key = value`` lines with keys ``min_distance``, ``num_points``, ``grid`` (nx ny nz),
``seed``, ``exact``, plus ``r1``, ``alpha``, ``band``, ``gamma``, ``offset`` for the other distributions; unknown keys
raise.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from plantvr._fileio import read_text, write_atomic
from plantvr._validation import MAX_COUNT, check_array, check_int, check_points, check_range

from .blobtree import Node
from .fields import ISO

__all__ = ["PointSet", "thin", "densify", "save_point_set", "load_point_set", "PROPS_DEFAULTS", "read_props",
           "write_props"]

#: Most source names of one point set.
MAX_SOURCES = 100_000


@dataclass
class PointSet:
    """Points ``(N, 3)`` in generation order with an int source tag per point and the tag names."""

    points: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))
    tags: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    sources: list = field(default_factory=list)

    def __post_init__(self):
        self.points = check_points("points", self.points)
        if len(self.points) > MAX_COUNT:
            raise ValueError(f"points must have at most {MAX_COUNT} rows, got {len(self.points)}")
        try:
            tags = np.asarray(self.tags)
            if tags.size and tags.dtype.kind not in "iu" and not (
                    tags.dtype.kind in "fb" and np.all(np.isfinite(tags.astype(float)))
                    and np.all(tags.astype(float) == np.round(tags.astype(float)))):
                raise TypeError
            self.tags = tags.astype(np.int64).reshape(-1)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"tags must be integers, got {np.asarray(self.tags, dtype=object).dtype}") from None
        if len(self.tags) != len(self.points):
            raise ValueError(f"tags must have one entry per point ({len(self.points)}), got {len(self.tags)}")
        if not isinstance(self.sources, list) or not all(isinstance(x, str) for x in self.sources):
            raise ValueError(f"sources must be a list of str, got {self.sources!r}"[:200])
        if len(self.sources) > MAX_SOURCES:
            raise ValueError(f"sources must hold at most {MAX_SOURCES} names, got {len(self.sources)}")
        if len(self.tags) and (self.tags.min() < 0 or (self.sources and self.tags.max() >= len(self.sources))):
            raise ValueError(f"tags must index sources, in [0, {max(len(self.sources) - 1, 0)}], got range "
                             f"[{self.tags.min()}, {self.tags.max()}]")

    def __len__(self):
        return len(self.points)

    @classmethod
    def from_points(cls, points, source: str) -> "PointSet":
        """A single-source set."""
        p = check_points("points", points)
        if not isinstance(source, str):
            raise ValueError(f"source must be a str, got {type(source).__name__}")
        return cls(p, np.zeros(len(p), dtype=np.int64), [source])

    def add(self, points, source: str) -> "PointSet":
        """New set with ``points`` appended under ``source`` (existing points untouched)."""
        p = check_points("points", points)
        if not isinstance(source, str):
            raise ValueError(f"source must be a str, got {type(source).__name__}")
        sources = list(self.sources)
        if source not in sources:
            sources.append(str(source))
        tag = sources.index(source)
        return PointSet(np.vstack([self.points, p]), np.r_[self.tags, np.full(len(p), tag)], sources)

    def select(self, mask) -> "PointSet":
        """Subset by boolean mask, keeping order and tag names."""
        try:
            m = np.asarray(mask)
        except (TypeError, ValueError):
            raise ValueError(f"mask must be a boolean array of shape ({len(self)},), "
                             f"got {type(mask).__name__}") from None
        if m.shape != (len(self),) or m.dtype != bool:
            raise ValueError(f"mask must be a boolean array of shape ({len(self)},), got {m.dtype} {m.shape}")
        return PointSet(self.points[m], self.tags[m], list(self.sources))


def thin(points: PointSet, secondary: Node, percent: float, *, iso: float = ISO) -> PointSet:
    """``point_set_thin``: remove the first ``floor(percent/100 * n)`` of the n points inside ``secondary``.

    Parameters
    ----------
    points : PointSet
        The set, in generation order.
    secondary : Node
        Secondary implicit surface enclosing the region to thin.
    percent : float
        Density reduction d in [0, 100].
    iso : float
        Inside test ``F > iso``.

    Returns
    -------
    PointSet
        The thinned set; points outside the secondary are unchanged.

    References
    ----------
    .. [1] Kochhar 2010, §7.1 ("the first d/100 n points are removed"); spec 003 §3.8 (floor rounding [INFERRED]).
    """
    if not isinstance(points, PointSet):
        raise ValueError(f"points must be a PointSet, got {type(points).__name__}")
    if not isinstance(secondary, Node):
        raise ValueError(f"secondary must be a BlobTree Node, got {type(secondary).__name__}")
    percent = check_range("percent", percent, 0.0, 100.0)
    inside = np.flatnonzero(secondary.inside(points.points, iso=iso)) if len(points) else np.empty(0, int)
    k = int(np.floor(percent * len(inside) / 100.0 + 1e-9))
    keep = np.ones(len(points), dtype=bool)
    keep[inside[:k]] = False
    return points.select(keep)


def densify(points: PointSet, secondary: Node, n: int, *, source: str = "densify", r_min: float | None = None,
            respect_existing: bool = False, shape=(48, 48, 48), rng=None) -> PointSet:
    """Add ``n`` points inside ``secondary`` (thesis §7.1); existing points are untouched.

    Parameters
    ----------
    points : PointSet
        The set to densify.
    secondary : Node
        Region to densify.
    n : int
        Points to add (Poisson-disk by Lane's method if ``r_min`` is given, uniform otherwise).
    source : str
        Tag of the new points.
    r_min : float, optional
        Minimum distance for the new points.
    respect_existing : bool
        Pre-multiply the Lane pdf by the kernels of the existing points and check distances exactly, so the
        minimum distance holds across old and new points (requires ``r_min``).
    shape : (3,) tuple of int
        Lane grid.
    rng : int | numpy.random.Generator | None
        Seed or generator.

    Returns
    -------
    PointSet
        Old points followed by the new ones.
    """
    from .sampling import lane_sample, field_pdf, poisson_kernel, sample_inside

    if not isinstance(points, PointSet):
        raise ValueError(f"points must be a PointSet, got {type(points).__name__}")
    n = check_int("n", n, 0, 10**8)
    if respect_existing and r_min is None:
        raise ValueError("r_min must be given when respect_existing=True")
    if r_min is None:
        new = sample_inside(secondary, n, rng=rng)
    else:
        r_min = check_range("r_min", r_min, 0.0, np.inf, low_open=True)
        pdf, box = field_pdf(secondary, shape=shape, mode="inside")
        existing = points.points if respect_existing and len(points) else None
        old = points.points if existing is not None else np.empty((0, 3))

        def accept(p):
            ok = secondary.field(p) > ISO
            if len(old):
                from scipy.spatial import cKDTree
                d, _ = cKDTree(old).query(p)
                ok &= d >= r_min
            return ok

        new = lane_sample(pdf, n, bbox=box, kernel=poisson_kernel(r_min), rng=rng, accept=accept,
                          min_distance=r_min, existing=existing).points
    return points.add(new, source)


def save_point_set(path, points, *, header: dict | None = None) -> None:
    """Write ``points.txt``: ``#`` header lines, then ``x y z [tag]`` per point in ``%.6g`` (spec §3.9).

    Parameters
    ----------
    path : str or Path
        Output file.
    points : PointSet or (N, 3) array_like
        Points (tags are written as a 4th column for a PointSet).
    header : dict, optional
        Generator parameters and seed, written as ``# key = value``.
    """
    lines = []
    if header is not None and not isinstance(header, dict):
        raise ValueError(f"header must be a dict, got {type(header).__name__}")
    for k, v in (header or {}).items():
        text = f"{k} = {v}"
        if "\n" in text or "\r" in text or str(k).strip().startswith("sources"):
            raise ValueError(f"header entry {str(k)!r} must be one line and not 'sources', got {text[:80]!r}")
        lines.append(f"# {text}")
    if isinstance(points, PointSet):
        lines.append("# sources = " + " ".join(_source_token(s) for s in points.sources))
        body = [f"{x:.6g} {y:.6g} {z:.6g} {t}" for (x, y, z), t in zip(points.points, points.tags)]
    else:
        p = check_points("points", points)
        body = [f"{x:.6g} {y:.6g} {z:.6g}" for x, y, z in p]
    write_atomic(path, "\n".join(lines + body) + "\n")


def _source_token(name: str) -> str:
    """A source name as one whitespace-free token of the ``# sources =`` line (empty -> ``_``)."""
    return re.sub(r"\s", "_", name) or "_"


def load_point_set(path) -> PointSet:
    """Read a ``points.txt`` written by :func:`save_point_set` (3 or 4 columns); bad files raise ValueError."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"path {str(path)!r} does not exist")
    text = read_text(path, what="point file")
    sources = None
    rows = []
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            if s[1:].strip().startswith("sources ="):
                sources = s.split("=", 1)[1].split()
            continue
        parts = s.split()
        if len(parts) not in (3, 4):
            raise ValueError(f"{path.name} line {lineno}: expected 3 or 4 numbers, got {s!r}")
        try:
            xyz = [float(v) for v in parts[:3]]
            tag = int(parts[3]) if len(parts) == 4 else 0
        except ValueError:
            raise ValueError(f"{path.name} line {lineno}: not a number in {s!r}") from None
        if not all(np.isfinite(xyz)) or max(abs(v) for v in xyz) > 1e6:
            raise ValueError(f"{path.name} line {lineno}: coordinates must be finite and inside +-1e6, got {s!r}")
        if not 0 <= tag < MAX_SOURCES:
            raise ValueError(f"{path.name} line {lineno}: tag must be in [0, {MAX_SOURCES - 1}], got {parts[3]!r}")
        rows.append(xyz + [tag])
    arr = np.array(rows, dtype=np.float64).reshape(-1, 4)
    tags = arr[:, 3].astype(np.int64)
    if sources is None:
        sources = [f"source{i}" for i in range(int(tags.max()) + 1)] if len(tags) else []
    if len(tags) and tags.max() >= len(sources):
        raise ValueError(f"{path.name}: tag {tags.max()} has no source name")
    try:
        return PointSet(check_array("points", arr[:, :3], shape=(None, 3)), tags, sources)
    except ValueError as exc:
        raise ValueError(f"{path.name}: {exc}") from None


PROPS_DEFAULTS = {
    "min_distance": 1.0,      # Poisson / cluster r_min (r0), scene units
    "num_points": 1000,       # points wanted (fewer if the Poisson pdf saturates)
    "grid": (64, 64, 64),     # Lane grid cells
    "seed": 0,
    "exact": False,           # exact inside/band and distance tests (spec §3.4)
    "r1": None,               # cluster kernel outer radius (default 2 min_distance)
    "alpha": 3.0,             # cluster kernel boost
    "band": None,             # field band (f_lo, f_hi) for band distributions
    "gamma": 1.0,             # inverse-field exponent
    "offset": (0.02, 0.1),    # mesh offsets (u_min, u_max)
}


def _parse_prop(key, raw, where):
    vals = raw.split()
    try:
        if key == "num_points" or key == "seed":
            if len(vals) != 1:
                raise ValueError(f"{key} takes one integer, got {raw!r}")
            return check_int(key, float(vals[0]), 0, 10**9)
        if key == "grid":
            if len(vals) not in (1, 3):
                raise ValueError(f"grid takes 1 or 3 integers, got {raw!r}")
            g = tuple(int(v) for v in vals) if len(vals) == 3 else (int(vals[0]),) * 3
            return tuple(check_int("grid", v, 1, 1024) for v in g)
        if key == "exact":
            if vals[0].lower() not in ("true", "false", "1", "0", "yes", "no"):
                raise ValueError(f"exact must be true or false, got {raw!r}")
            return vals[0].lower() in ("true", "1", "yes")
        if key in ("band", "offset"):
            if len(vals) != 2:
                raise ValueError(f"{key} needs two numbers, got {raw!r}")
            pair = (check_range(key, vals[0], -1e6, 1e6), check_range(key, vals[1], -1e6, 1e6))
            if not pair[1] > pair[0] if key == "band" else not pair[1] >= pair[0]:
                raise ValueError(f"{key} must be increasing, got {raw!r}")
            return pair
        if len(vals) != 1:
            raise ValueError(f"{key} takes one number, got {raw!r}")
        if key == "r1" and vals[0].lower() == "none":
            return None
        if key == "gamma":
            return check_range(key, float(vals[0]), 0.0, 100.0)
        if key == "alpha":
            return check_range(key, float(vals[0]), 0.0, 1e6, low_open=True)
        return check_range(key, float(vals[0]), 0.0, 1e6, low_open=key in ("min_distance", "r1"))
    except (ValueError, IndexError, OverflowError) as exc:
        raise ValueError(f"{where}: bad value for {key!r}: {exc}") from None


def read_props(path_or_text, *, name: str | None = None) -> dict:
    """Parse a ``.props`` file (or its text): ``key = value`` lines, ``#`` comments; unknown keys raise.

    Returns
    -------
    dict
        :data:`PROPS_DEFAULTS` updated with the file's values.
    """
    if isinstance(path_or_text, Path) or (isinstance(path_or_text, str) and "=" not in path_or_text):
        path = Path(path_or_text)
        if not path.is_file():
            raise ValueError(f"props file {str(path)!r} does not exist")
        text, where = read_text(path, what="props file"), path.name
    elif isinstance(path_or_text, str):
        text, where = path_or_text, name or "props"
    else:
        raise ValueError(f"path_or_text must be a path or the text of a props file, got "
                         f"{type(path_or_text).__name__}")
    return _parse_props(text, where)


def _parse_props(text: str, where: str) -> dict:
    out = dict(PROPS_DEFAULTS)
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.split("#", 1)[0].strip()
        if not s:
            continue
        if "=" not in s:
            raise ValueError(f"{where} line {lineno}: expected 'key = value', got {line!r}")
        key, raw = (t.strip() for t in s.split("=", 1))
        if key not in PROPS_DEFAULTS:
            raise ValueError(f"{where} line {lineno}: unknown key {key!r}; allowed: {sorted(PROPS_DEFAULTS)}")
        out[key] = _parse_prop(key, raw, f"{where} line {lineno}")
    return out


def write_props(path, props: dict) -> None:
    """Write a ``.props`` file from a dict of known keys."""
    if not isinstance(props, dict):
        raise ValueError(f"props must be a dict, got {type(props).__name__}")
    lines = []
    for k, v in props.items():
        if k not in PROPS_DEFAULTS:
            raise ValueError(f"props key {k!r} is unknown; allowed: {sorted(PROPS_DEFAULTS)}")
        if v is None:
            continue
        lines.append(f"{k} = {' '.join(str(x) for x in v) if isinstance(v, (tuple, list)) else v}")
    text = "\n".join(lines) + "\n"
    parsed = _parse_props(text, "props")               # what is written must read back: check before writing
    for k, v in props.items():
        if v is not None and "\n" in str(v):
            raise ValueError(f"props value of {k!r} must be one line, got {str(v)[:80]!r}")
        if v is not None and not _same_value(parsed[k], v):
            raise ValueError(f"props value of {k!r} does not read back as written: {v!r} -> {parsed[k]!r}")
    write_atomic(path, text)


def _same_value(a, b) -> bool:
    if isinstance(a, tuple):
        return isinstance(b, (tuple, list)) and len(a) == len(b) and all(_same_value(x, y) for x, y in zip(a, b))
    try:
        return a == b or float(a) == float(b)
    except (TypeError, ValueError):
        return False

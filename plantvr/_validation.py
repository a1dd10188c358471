"""Input checks shared by every PlantVR entry point (STYLE §3).

Each check names the parameter, the value and the allowed range, so a bad call
fails at the door with a message the user can act on, before any state is written.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "check_range",
    "check_int",
    "check_choice",
    "check_points",
    "check_point",
    "check_array",
    "check_size",
    "check_index",
    "check_tree_arrays",
    "check_values",
    "MAX_COORD",
    "MAX_COUNT",
]

#: Largest coordinate magnitude any PlantVR entry point accepts (model units: metres for trees, the scan's
#: units for ViNE). Far beyond any plant or scan, and small enough that grid kernels can index cells of it
#: without integer overflow (issue 20: a marker at 1e100 or a node at 1e19 crashed or stalled the kernels).
MAX_COORD = 1e6

#: Largest element count (markers, darts, nodes, faces) a single command may ask for.
MAX_COUNT = 100_000_000


def check_range(name: str, value: Any, low: float, high: float, *,
                low_open: bool = False, high_open: bool = False) -> float:
    """Return ``value`` as a finite float inside [low, high] or raise ``ValueError``.

    ``low_open``/``high_open`` exclude the bound, e.g. ``(0, 1)`` for a falloff.
    """
    try:
        if isinstance(value, (bytes, bool, np.bool_)):   # b"1" and True are not numbers (text is parsed)
            raise TypeError
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be a number in {_interval(low, high, low_open, high_open)}, "
                         f"got {value!r}"[:300]) from None
    ok = np.isfinite(v) and (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    if not ok:
        raise ValueError(f"{name} must be in {_interval(low, high, low_open, high_open)}, got {value!r}")
    return v


def check_int(name: str, value: Any, low: int, high: int) -> int:
    """Return ``value`` as an int inside [low, high] or raise ``ValueError``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        if isinstance(value, (float, np.floating)) and float(value).is_integer():
            value = int(value)
        else:
            raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    v = int(value)
    if not low <= v <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {v!r}")
    return v


def check_choice(name: str, value: Any, choices: tuple) -> Any:
    """Return ``value`` if it is one of ``choices`` or raise ``ValueError``."""
    if not isinstance(value, (str, bytes, int, float, bool, type(None), np.generic)):  # arrays, lists, ...
        raise ValueError(f"{name} must be one of {list(choices)}, got {type(value).__name__}")
    if value not in choices:
        raise ValueError(f"{name} must be one of {list(choices)}, got {value!r}")
    return value


def check_size(name: str, value: Any, low: int, high: int) -> tuple[int, int]:
    """Return ``value`` as a ``(width, height)`` pair of ints in [low, high] (pixels) or raise ``ValueError``."""
    try:
        w, h = value
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be (width, height) in pixels, got {value!r}") from None
    return check_int(f"{name} width", w, low, high), check_int(f"{name} height", h, low, high)


def check_array(name: str, value: Any, *, shape: tuple, dtype: Any = np.float64,
                finite: bool = True, min_rows: int = 0, max_abs: float | None = None) -> np.ndarray:
    """Return ``value`` as a C-contiguous array of ``dtype`` and the given shape.

    ``shape`` uses ``None`` for a free dimension, e.g. ``(None, 3)`` for points; ``max_abs`` bounds the
    magnitude of every element.
    """
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be an array of shape {_shape_str(shape)}, got {type(value).__name__}") from None
    if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        raise ValueError(f"{name} must have shape {_shape_str(shape)}, got {arr.shape}")
    if arr.shape and arr.shape[0] < min_rows:
        raise ValueError(f"{name} must have at least {min_rows} rows, got {arr.shape[0]}")
    if finite and arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    if max_abs is not None and arr.size and arr.dtype.kind in "fiu":
        mag = max(float(arr.max()), -float(arr.min()))
        if mag > max_abs:
            raise ValueError(f"{name} values must lie in [-{max_abs:g}, {max_abs:g}], got magnitude {mag:g}")
    return np.ascontiguousarray(arr)


def check_index(name: str, value: Any, *, shape: tuple, low: int, high: int, table: str | None = None
                ) -> np.ndarray:
    """Return ``value`` as a C-contiguous int64 array of ``shape`` with every entry in ``[low, high]``.

    ``check_array(..., dtype=np.int64)`` would cast ``0.5`` to ``0`` and overflow on ``2**70``; index arrays
    go through this check instead, so a numba kernel never sees an index outside the table it reads.

    Integral floats (``1.0``) are accepted; ``0.5``, NaN, inf, booleans, strings and integers beyond int64
    raise ``ValueError`` naming ``name`` and the allowed range.
    """
    rng = f"[{low}, {high}]"
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be an integer array with entries in {rng}, "
                         f"got {type(value).__name__}") from None
    if raw.dtype.kind == "O":                               # e.g. a Python int beyond int64
        try:
            raw = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"{name} must be an integer array with entries in {rng}, "
                             f"got non-numeric entries") from None
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be an integer array with entries in {rng}, got dtype {raw.dtype}")
    if raw.dtype.kind == "f":
        if raw.size and not np.all(np.isfinite(raw)):
            raise ValueError(f"{name} must hold integers in {rng}, got NaN or inf")
        if raw.size and not np.all(raw == np.round(raw)):
            bad = raw.ravel()[np.flatnonzero(raw.ravel() != np.round(raw.ravel()))[0]]
            raise ValueError(f"{name} must hold integers in {rng}, got {float(bad)!r}")
    if raw.size:
        lo, hi = raw.min(), raw.max()
        if lo < low or hi > high:
            bad = lo if lo < low else hi
            if table is not None:
                raise ValueError(f"{name} must index {table} in {rng}, got range [{lo.item()!r}, {hi.item()!r}]")
            raise ValueError(f"{name} entries must lie in {rng}, got {bad.item()!r}")
    return check_array(name, raw, shape=shape, dtype=np.int64)


def check_points(name: str, value: Any, *, min_rows: int = 0, max_abs: float = MAX_COORD) -> np.ndarray:
    """Return ``value`` as a finite ``(N, 3)`` float64 array with coordinates inside ``±max_abs``."""
    return check_array(name, value, shape=(None, 3), min_rows=min_rows, max_abs=max_abs)


def check_point(name: str, value: Any, *, max_abs: float = MAX_COORD) -> np.ndarray:
    """Return ``value`` as a finite ``(3,)`` float64 array with coordinates inside ``±max_abs``."""
    return check_array(name, value, shape=(3,), max_abs=max_abs)


def check_values(name: str, value: Any, *, finite: bool = True) -> np.ndarray:
    """Return ``value`` (a number or an array of any shape) as a float64 array, finite unless ``finite=False``."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be a number or an array of numbers, got {type(value).__name__}") from None
    if finite and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    return arr


def check_tree_arrays(pos: Any, parent: Any, radius: Any, *, max_radius: float | None = MAX_COORD,
                      forest: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the node arrays of a tree rooted at node 0 (or a forest), checked, as ``(pos, parent, radius)``.

    ``pos`` (N, 3) float64 finite inside ``±MAX_COORD`` with ``2 <= N <= MAX_COUNT``; ``parent`` (N,) int64
    with ``parent[0] = -1`` and ``0 <= parent[i] < i`` for ``i > 0`` (forward-ordered, so no cycles), or, with
    ``forest=True``, ``-1 <= parent[i] < i`` (every -1 starts a tree, as a turtle move before ``F`` does);
    ``radius`` (N,) finite float64, inside ``±max_radius`` (None: unbounded; the caller checks its range).
    """
    pos = check_points("pos", pos, min_rows=2)
    n = len(pos)
    if n > MAX_COUNT:
        raise ValueError(f"pos must have at most {MAX_COUNT} rows (nodes), got {n}")
    parent = check_index("parent", parent, shape=(n,), low=-1, high=n - 1)
    radius = check_array("radius", radius, shape=(n,), max_abs=max_radius)
    if parent[0] != -1:
        raise ValueError(f"parent[0] must be -1 (node 0 is the root), got {parent[0]}")
    low = -1 if forest else 0
    bad = np.flatnonzero((parent[1:] < low) | (parent[1:] >= np.arange(1, n))) + 1
    if bad.size:
        raise ValueError(f"parent must satisfy {low} <= parent[i] < i for i > 0 (a forward-ordered "
                         f"{'forest' if forest else 'tree'} without cycles), got parent[{bad[0]}] = {parent[bad[0]]}")
    return pos, parent, radius


def _interval(low, high, low_open, high_open) -> str:
    return f"{'(' if low_open else '['}{low}, {high}{')' if high_open else ']'}"


def _shape_str(shape: tuple) -> str:
    return "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"

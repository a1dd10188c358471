"""TreeSketch parameter table and option checks (spec 004_treesketch §1.4, §2.3, §2.5).

:data:`SKETCH_ROWS` (the scalar :class:`~plantvr.growth.sketch.SketchEngine` options and the stroke brush),
:data:`TREESKETCH` (the Tree Wand rows, then those), :func:`split_values` (table values into engine parameters and
options), and the reach of the shadow grid that bounds node and marker positions (issue 20).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import MAX_COORD, check_array, check_int, check_point, check_range
from ..params import TREEWAND, WINDOWS, Param, ParamTable

__all__ = ["SKETCH_ROWS", "TREESKETCH", "check_grid_reach", "grid_reach", "split_values"]

#: Largest |coarse index| and pyramid offset of the shadow grid (plantvr.growth.shadow): nodes farther out than
#: (GRID_COARSE - 2) * fine_cells - GRID_OFFSET cells from the origin cannot be indexed (issue 20:
#: ``base_length = 1e-20`` after growth crashed ``ShadowGrid.add``).
try:
    from .shadow import COARSE_LIMIT as GRID_COARSE
    from .shadow import MAX_OFFSET as GRID_OFFSET
except ImportError:  # pragma: no cover - an older shadow grid without stated bounds
    GRID_COARSE, GRID_OFFSET = 2 ** 14, 64
#: Bounds of the gravimorphism ellipse's semi-axes and offset: beyond them Eq. 4.6 overflows to NaN vigor.
ELLIPSE_RANGE = (1e-6, 1e6)
#: Most neighbour sites a crown region may list (the region test is a (points x sites) distance table).
MAX_SITES = 10_000


def _row(name, kind, default, ref, doc, **kw) -> Param:
    return Param(name=name, kind=kind, default=default, window="sketch", ref=ref, doc=doc, **kw)


#: The TreeSketch rows of :data:`TREESKETCH` (spec 004 §1.4, §2.3, §2.5): the scalar
#: :class:`~plantvr.growth.sketch.SketchEngine` options (the gravimorphism ellipse as its three numbers) and the
#: stroke brush of :class:`~plantvr.growth.sketch_tools.StrokeEmitter`. The engine's option checks and the
#: architecture panel read their ranges from here.
SKETCH_ROWS: tuple[Param, ...] = (
    _row("n_max", int, 3, "§1.4.4 Eq. 4.3", "Maximum shoot length: internodes per step of the most vigorous bud.",
         symbol="n_max", range=(1, 1000)),
    _row("deflection", float, 0.0, "§1.4.7", "Deflection angle of the continuing heading, away from the lateral bud.",
         symbol="δ", unit="deg", range=(0.0, 90.0)),
    _row("trunk_up", bool, False, "§1.4.5 Fig. 4.19", "Tropism straight up on the main axis.", range=(0, 1)),
    _row("stroke_tropism", bool, False, "§2.7", "Tropism follows the stroke direction of a bud's selecting points.",
         range=(0, 1)),
    _row("mode", str, "directed", "§1.4.1", "Marker policy: user points kept until consumed, or generated per step.",
         choices=("directed", "autonomous")),
    _row("point_density", int, 4, "§1.4.1", "K of autonomous growth: up to 1 + K points per bud and step.",
         symbol="K", range=(0, 1000)),
    _row("ellipse_sv", float, 1.0, "§1.4.6 Eq. 4.6", "Gravimorphism control ellipse: semi-axis along V (up).",
         symbol="s_v", range=ELLIPSE_RANGE, slider=(0.05, 20.0), log=True),
    _row("ellipse_sp", float, 1.0, "§1.4.6 Eq. 4.6", "Gravimorphism control ellipse: semi-axis along P (side).",
         symbol="s_p", range=ELLIPSE_RANGE, slider=(0.05, 20.0), log=True),
    _row("ellipse_ev", float, 0.0, "§1.4.6 Eq. 4.6", "Gravimorphism control ellipse: offset of its centre along V.",
         symbol="e_v", range=(-ELLIPSE_RANGE[1], ELLIPSE_RANGE[1]), slider=(-10.0, 10.0)),
    _row("shed_threshold", float, 0.0, "§1.4.8", "Shedding threshold Th of the normalised rule (0: never shed).",
         symbol="Th", range=(0.0, 1e12), slider=(0.0, 10.0)),
    _row("stroke_rate", float, 20.0, "§2.5", "Brush: points per unit volume per second of brushing.",
         range=(0.0, 1e9), low_open=True, slider=(0.1, 1000.0), log=True),
    _row("stroke_spacing", float, 0.5, "§2.5", "Sketch (brush radius 0): distance between points on the stroke.",
         unit="m", range=(1e-9, MAX_COORD), slider=(0.01, 10.0), log=True),
)
_ROW = {p.name: p for p in SKETCH_ROWS}
#: The TreeSketch parameter table: every Tree Wand row, then :data:`SKETCH_ROWS`.
TREESKETCH = ParamTable("treesketch", [*TREEWAND.params, *SKETCH_ROWS],
                        {**WINDOWS, "sketch": ("TreeSketch", "#8e44ad")})
#: SketchEngine options that are rows of :data:`TREESKETCH` (``ellipse`` is the three ``ellipse_*`` rows).
TABLE_OPTIONS = ("n_max", "deflection", "trunk_up", "stroke_tropism", "mode", "point_density", "ellipse",
                 "shed_threshold")
_ELLIPSE_ROWS = ("ellipse_sv", "ellipse_sp", "ellipse_ev")


def _check_bool(name: str, value: Any) -> bool:
    """``value`` as a bool; only True/False (or 0/1) are accepted, so ``"no"`` is not silently True."""
    if isinstance(value, (bool, np.bool_)) or (isinstance(value, (int, np.integer)) and value in (0, 1)):
        return bool(value)
    raise ValueError(f"{name} must be True or False, got {value!r}")



def grid_reach(params: dict[str, Any]) -> float:
    """Largest |x| or |z| (and |y| / 3) a node or marker may have for the shadow grid of ``params`` to index it."""
    return ((GRID_COARSE - 2) * params["fine_cells"] - GRID_OFFSET) * params["base_length"]


def check_grid_reach(params: dict[str, Any], pos: np.ndarray, *, name: str = "base_length") -> None:
    """Raise ``ValueError`` (naming ``name``) unless every point of ``pos`` (N, 3) lies where the shadow grid of
    ``params`` (cell ``base_length``, ``fine_cells``) can index it: |x|, |z| and |y| / 3 within :func:`grid_reach`."""
    if not len(pos):
        return
    ext = max(float(np.abs(pos[:, [0, 2]]).max()), float(np.abs(pos[:, 1]).max()) / 3.0)
    reach = grid_reach(params)
    if ext > reach:
        if name == "base_length":
            raise ValueError(f"base_length must be at least {params['base_length'] * ext / reach:.3g} for a tree "
                             f"reaching {ext:.6g} from the origin (the shadow grid indexes "
                             f"{reach / params['base_length']:.0f} cells), got {params['base_length']!r}")
        raise ValueError(f"{name} must lie within {reach:.6g} of the origin (|y| within {3 * reach:.6g}) for the "
                         f"shadow grid of base_length {params['base_length']!r}, got {ext:.6g}")


def split_values(values: dict[str, Any], ellipse=(1.0, 1.0, 0.0)) -> tuple[dict[str, Any], dict[str, Any]]:
    """:data:`TREESKETCH` values, checked and split into engine parameters (the Tree Wand rows) and
    :class:`SketchEngine` options; the ``ellipse_*`` rows become ``ellipse`` when any is given (the others
    taken from ``ellipse``); the stroke rows belong to neither and are dropped."""
    values = TREESKETCH.validate(values)
    params = {k: v for k, v in values.items() if k in TREEWAND}
    opts = {k: v for k, v in values.items() if k in TABLE_OPTIONS}
    if any(k in values for k in _ELLIPSE_ROWS):
        opts["ellipse"] = tuple(values.get(k, e) for k, e in zip(_ELLIPSE_ROWS, ellipse))
    return params, opts


def _check_asym(v) -> list | None:
    if v is None:
        return None
    return check_array("asymmetry", v, shape=(2,), max_abs=MAX_COORD).tolist()


def _check_depth(depth) -> dict | None:
    if depth is None:
        return None
    if not isinstance(depth, dict) or set(depth) != {"normal", "depth"}:
        raise ValueError(f"depth must be a dict with keys normal, depth, got {depth!r}")
    n = check_point("depth normal", depth["normal"])
    if not np.linalg.norm(n) > 1e-12:
        raise ValueError(f"depth normal must be a non-zero vector, got {n.tolist()}")
    return {"normal": (n / np.linalg.norm(n)).tolist(),
            "depth": check_range("depth", depth["depth"], 0.0, 1e12)}


def _check_region(region) -> dict | None:
    if region is None:
        return None
    if not isinstance(region, dict) or set(region) != {"sites", "weights", "weight", "h_max"}:
        raise ValueError(f"region must be a dict with keys sites, weights, weight, h_max, got {region!r}")
    sites, weights = region["sites"], region["weights"]
    sites = np.zeros((0, 2)) if np.size(sites) == 0 else \
        check_array("region sites", sites, shape=(None, 2), max_abs=2 * MAX_COORD)
    weights = np.zeros(0) if np.size(weights) == 0 else check_array("region weights", weights, shape=(None,))
    if len(sites) > MAX_SITES:
        raise ValueError(f"region sites must list at most {MAX_SITES} neighbours, got {len(sites)}")
    if len(weights) != len(sites) or not np.all((weights >= 1e-12) & (weights <= 1e12)):
        raise ValueError(f"region weights must be ({len(sites)},) like the sites, each in [1e-12, 1e12]")
    return {"sites": sites.tolist(), "weights": weights.tolist(),
            "weight": check_range("region weight", region["weight"], 1e-12, 1e12),
            "h_max": check_range("region h_max", region["h_max"], 0.0, MAX_COORD, low_open=True)}


def _check_life(value) -> int | None:
    return None if value is None else check_int("bud_lifetime", value, 1, 10 ** 9)


def _check_ellipse(ellipse) -> tuple[float, float, float]:
    if isinstance(ellipse, (str, bytes)) or not hasattr(ellipse, "__len__") or len(ellipse) != 3:
        raise ValueError(f"ellipse must be (s_v, s_p, e_v), got {ellipse!r}")
    return tuple(check_range(f"ellipse {_ROW[k].symbol}", v, *_ROW[k].range) for k, v in zip(_ELLIPSE_ROWS, ellipse))

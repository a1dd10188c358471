"""Point distributions in and around implicit crowns (spec 003_implicit_sca §3.2-3.5; C-8 to C-11).

Uniform rejection in the bounding box, inverse-CDF sampling of step pdfs (1D/2D/3D), Lane's method with tabulated
kernels (Poisson, cluster, custom) and field-controlled initial pdfs (inside, band, inverse field, callable). Every
generator takes ``rng``; the same seed gives identical output.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_choice, check_int, check_points, check_range

from . import _lane_kernels as lk
from .blobtree import Node
from .fields import ISO

__all__ = [
    "rejection_sample", "sample_inside", "step_cdf", "icdf_step_1d", "sample_step_pdf",
    "LaneKernel", "poisson_kernel", "cluster_kernel", "custom_kernel", "LaneResult", "lane_sample",
    "field_pdf", "lane_in_node",
]


#: Most points one sampler call returns (Lane's method allocates its output up front).
MAX_POINTS = 10**8
MAX_LANE_POINTS = 10**7
#: Most cells of one Lane/field grid (2**25 cells: ~0.8 GB of cell centres).
MAX_GRID_CELLS = 2**25
#: Smallest box edge a grid may cover (cells must stay representable against the coordinates).
MIN_EXTENT = 1e-9
#: Largest pdf value; kernel products are clamped below ``lk.PDF_CAP`` so the pdf never overflows.
MAX_PDF = 1e100


def _check_band(band, name: str = "band"):
    try:
        lo, hi = float(band[0]), float(band[1])
        if len(band) != 2:
            raise IndexError
    except (TypeError, ValueError, IndexError, KeyError):
        raise ValueError(f"{name} must be a pair (f_lo, f_hi), got {band!r}") from None
    if np.isnan(lo) or np.isnan(hi) or not hi > lo:
        raise ValueError(f"{name} must be (f_lo, f_hi) with f_hi > f_lo, got {band!r}")
    return lo, hi


def _check_node(node):
    if not isinstance(node, Node):
        raise ValueError(f"node must be a BlobTree Node, got {type(node).__name__}")
    return node


def _box(node, bbox):
    box = node.bbox if bbox is None else check_array("bbox", bbox, shape=(2, 3), max_abs=MAX_COORD)
    return _check_grid_box(box)


def _check_grid_box(box):
    if np.any(box[1] <= box[0]):
        raise ValueError(f"bbox must have hi > lo on every axis, got {np.asarray(box).tolist()} (empty envelope)")
    if np.abs(box).max() > MAX_COORD:
        raise ValueError(f"bbox (the node's support box) must lie in [-{MAX_COORD:g}, {MAX_COORD:g}], got "
                         f"{np.asarray(box).tolist()}: scale the surface down")
    if np.any(box[1] - box[0] < MIN_EXTENT):
        raise ValueError(f"bbox must be at least {MIN_EXTENT:g} wide on every axis, got {np.asarray(box).tolist()}")
    return box


def rejection_sample(node: Node, n: int, *, f_lo: float, f_hi: float = np.inf, rng=None, bbox=None,
                     max_draws: int = 50_000_000, backend: str = "numba") -> np.ndarray:
    """Uniform points in the box accepted iff ``f_lo < F(p) < f_hi`` (thesis §6.1, §6.2.1).

    Parameters
    ----------
    node : Node
        The envelope.
    n : int
        Number of points.
    f_lo, f_hi : float
        Open field band; ``(iso, inf)`` is "inside", ``(iso - eps, iso)`` "outside and in proximity".
    rng : int | numpy.random.Generator | None
        Seed or generator.
    bbox : (2, 3) array_like, optional
        Sampling box (default: the node's support box).
    max_draws : int
        Give up (ValueError) after this many candidates.
    backend : {"numba", "numpy"}
        Field kernel.

    Returns
    -------
    (n, 3) float64 ndarray
        Accepted points in generation order.

    References
    ----------
    .. [1] Kochhar 2010, §6.1 (uniform rejection in the AABB), §6.2.1 (band condition); spec 003 §3.2, §3.6.1.
    """
    _check_node(node)
    n = check_int("n", n, 0, MAX_POINTS)
    f_lo, f_hi = _check_band((f_lo, f_hi), "f_lo, f_hi")
    for name, v in (("f_lo", f_lo), ("f_hi", f_hi)):
        if np.isfinite(v) and abs(v) > MAX_COORD:
            raise ValueError(f"{name} must be -inf, inf or a field value in [-{MAX_COORD:g}, {MAX_COORD:g}], got {v!r}")
    if not f_hi > f_lo:
        raise ValueError(f"f_hi must be greater than f_lo, got f_lo={f_lo}, f_hi={f_hi}")
    max_draws = check_int("max_draws", max_draws, 1, 10**12)
    box = _box(node, bbox)
    rng = np.random.default_rng(rng)
    out, have, draws, batch = [], 0, 0, 4096
    while have < n:
        if draws >= max_draws:
            raise ValueError(f"envelope is empty or the band f_lo, f_hi = ({f_lo}, {f_hi}) too thin: "
                             f"{have} of {n} points "
                             f"after {draws} draws (raise max_draws or widen the band)")
        b = min(batch, max_draws - draws)
        p = box[0] + (box[1] - box[0]) * rng.random((b, 3))
        f = node.field(p, backend=backend)
        acc = p[(f > f_lo) & (f < f_hi)]
        draws += b
        out.append(acc[: n - have])
        have += len(out[-1])
        rate = max(have, 1) / draws
        batch = int(np.clip(1.2 * (n - have) / rate, 1024, 1 << 20))
    return np.concatenate(out) if out else np.empty((0, 3))


def sample_inside(node: Node, n: int, *, iso: float = ISO, rng=None, bbox=None,
                  max_draws: int = 50_000_000) -> np.ndarray:
    """Uniform points inside the envelope (``F > iso``) by rejection in its box (thesis §6.1, C-8):
    :func:`rejection_sample` with the band ``(iso, inf)``; ``node``, ``n``, ``rng``, ``bbox`` and ``max_draws`` as
    there, ``iso`` (> 0) the iso-value. Returns the (n, 3) points, in generation order.
    """
    iso = check_range("iso", iso, 0.0, np.inf, low_open=True)
    return rejection_sample(node, n, f_lo=iso, rng=rng, bbox=bbox, max_draws=max_draws)


# ------------------------------------------------------------------------------------------------ inverse CDF
def step_cdf(values) -> np.ndarray:
    """CDF values ``F_i`` at the interval ends of a step pdf (``F_0 = 0``, ``F_n = 1``)."""
    c = check_array("values", values, shape=(None,), min_rows=1, max_abs=MAX_PDF)
    if np.any(c < 0) or c.sum() <= 0:
        raise ValueError("values must be non-negative with a positive sum")
    return np.r_[0.0, np.cumsum(c)] / c.sum()


def icdf_step_1d(values, y, *, a: float = 0.0, b: float = 1.0) -> np.ndarray:
    """``F^-1(y)`` of a step pdf on [a, b] by linear interpolation inside the interval (ERRATUM A.5).

    Parameters
    ----------
    values : (n,) float64 array_like
        Step heights c_0 ... c_{n-1} >= 0.
    y : (M,) float64 array_like
        Uniform variates in [0, 1).
    a, b : float
        Domain.

    Returns
    -------
    (M,) float64 ndarray
        ``a + (i + (y - F_i) / (F_{i+1} - F_i)) dx``.

    References
    ----------
    .. [1] Kochhar 2010, §5.2.2 (step pdf CDF; general ``x - a - i dx``, ERRATUM A.5); spec 003 §3.3.
    """
    cdf = step_cdf(values)
    a = check_range("a", a, -1e12, 1e12)
    b = check_range("b", b, -1e12, 1e12)
    if not b > a:
        raise ValueError(f"b must be greater than a, got a={a}, b={b}")
    try:
        y = np.asarray(y, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"y must be an array of numbers in [0, 1], got {type(y).__name__}") from None
    if not np.all((y >= 0) & (y <= 1)):
        raise ValueError("y must hold uniform variates in [0, 1] (no NaN)")
    n = len(cdf) - 1
    i = np.clip(np.searchsorted(cdf, y, side="right") - 1, 0, n - 1)
    dx = (b - a) / n
    width = cdf[i + 1] - cdf[i]
    frac = np.where(width > 0, (y - cdf[i]) / np.where(width > 0, width, 1.0), 0.5)
    return a + (i + frac) * dx


def sample_step_pdf(pdf, n: int, *, bbox=None, rng=None) -> np.ndarray:
    """Samples of a 1D, 2D or 3D step pdf (constant over each cell) by the inverse CDF method.

    The marginal of the first axis is drawn first, then the conditionals of the next axes given the earlier
    ones (thesis §5.2.1-5.2.2); the position inside the chosen cell is uniform (= linear interpolation of F^-1).

    Parameters
    ----------
    pdf : (n0,) or (n0, n1) or (n0, n1, n2) float64 array_like
        Non-negative cell values, ``ij`` indexing.
    n : int
        Number of samples.
    bbox : (2, d) float64 array_like, optional
        Domain ``[lo, hi]``; the unit cube by default.
    rng : int | numpy.random.Generator | None
        Seed or generator.

    Returns
    -------
    (n, d) float64 ndarray
        Samples.

    References
    ----------
    .. [1] Kochhar 2010, §5.2.1-5.2.2, Figs. 5.5-5.6; spec 003 §3.3 (C-9).
    """
    try:
        g = np.asarray(pdf, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"pdf must be a 1D, 2D or 3D array of numbers, got {type(pdf).__name__}") from None
    if g.ndim not in (1, 2, 3) or g.size == 0:
        raise ValueError(f"pdf must be a non-empty 1D, 2D or 3D array, got shape {g.shape}")
    if not np.all(np.isfinite(g)) or np.any(g < 0) or g.max() > MAX_PDF or g.sum() <= 0:
        raise ValueError(f"pdf must be finite, non-negative (at most {MAX_PDF:g}) and have a positive sum")
    d = g.ndim
    box = (np.array([np.zeros(d), np.ones(d)]) if bbox is None
           else check_array("bbox", bbox, shape=(2, d), max_abs=MAX_COORD))
    if np.any(box[1] <= box[0]):
        raise ValueError(f"bbox must have hi > lo on every axis, got {box.tolist()}")
    n = check_int("n", n, 0, MAX_POINTS)
    rng = np.random.default_rng(rng)
    u = rng.random((n, 2 * d))
    idx = np.zeros((n, d), dtype=np.int64)
    # marginal of axis 0, then conditionals of axis 1 | 0 and axis 2 | 0, 1
    marg0 = g.reshape(g.shape[0], -1).sum(axis=1)
    c0 = np.r_[0.0, np.cumsum(marg0)] / marg0.sum()
    idx[:, 0] = np.clip(np.searchsorted(c0, u[:, 0], side="right") - 1, 0, g.shape[0] - 1)
    if d >= 2:
        m1 = g.sum(axis=2) if d == 3 else g                           # (n0, n1)
        c1 = np.concatenate([np.zeros((g.shape[0], 1)), np.cumsum(m1, axis=1)], axis=1)
        c1 /= np.where(c1[:, -1:] > 0, c1[:, -1:], 1.0)
        rows = c1[idx[:, 0]]
        idx[:, 1] = np.clip((rows <= u[:, 1:2]).sum(axis=1) - 1, 0, g.shape[1] - 1)
    if d == 3:
        c2 = np.concatenate([np.zeros(g.shape[:2] + (1,)), np.cumsum(g, axis=2)], axis=2)
        c2 /= np.where(c2[..., -1:] > 0, c2[..., -1:], 1.0)
        rows = c2[idx[:, 0], idx[:, 1]]
        idx[:, 2] = np.clip((rows <= u[:, 2:3]).sum(axis=1) - 1, 0, g.shape[2] - 1)
    h = (box[1] - box[0]) / np.array(g.shape)
    return box[0] + (idx + u[:, d:]) * h


# ------------------------------------------------------------------------------------------------ Lane's method
@dataclass(frozen=True)
class LaneKernel:
    """Radial kernel h(d) tabulated at ``radii`` (increasing); 1 beyond the last radius (its support).

    ``interp="step"``: h = values[q] for radii[q-1] <= d < radii[q]; ``"linear"``: piecewise linear through
    (radii, values).
    """

    radii: np.ndarray
    values: np.ndarray
    interp: str = "step"

    @property
    def support(self) -> float:
        return float(self.radii[-1])

    def __call__(self, d):
        return lk._kernel_value_numpy(np.asarray(d, dtype=float), self.radii, self.values,
                                      self.interp == "linear")


def custom_kernel(radii, values, *, interp: str = "linear") -> LaneKernel:
    """Tabulated kernel (spec §3.4 [INFERRED]): non-negative values at increasing radii."""
    r = check_array("radii", radii, shape=(None,), min_rows=1, max_abs=MAX_COORD)
    v = check_array("values", values, shape=(len(r),), max_abs=1e6)
    check_choice("interp", interp, ("step", "linear"))
    if np.any(r <= 0) or np.any(np.diff(r) <= 0):
        raise ValueError(f"radii must be positive and strictly increasing, got {r.tolist()}")
    if np.any(v < 0):
        raise ValueError(f"values must be non-negative, got {v.tolist()}")
    return LaneKernel(r, v, interp)


def poisson_kernel(r_min: float) -> LaneKernel:
    """Poisson kernel (Fig. 5.7): h = 0 for d < r_min, 1 beyond."""
    r_min = check_range("r_min", r_min, 0.0, MAX_COORD, low_open=True)
    return LaneKernel(np.array([r_min]), np.array([0.0]), "step")


def cluster_kernel(r0: float, r1: float | None = None, alpha: float = 3.0) -> LaneKernel:
    """Cluster kernel (Fig. 5.9): 0 below r0, ``alpha > 1`` in [r0, r1), 1 beyond (defaults r1 = 2 r0, alpha 3)."""
    r0 = check_range("r0", r0, 0.0, MAX_COORD, low_open=True)
    r1 = 2 * r0 if r1 is None else check_range("r1", r1, r0, 2 * MAX_COORD, low_open=True)
    alpha = check_range("alpha", alpha, 0.0, 1e6, low_open=True)
    return LaneKernel(np.array([r0, r1]), np.array([0.0, alpha]), "step")


def _check_kernel(kernel):
    """A LaneKernel whose tables the numba kernels can index: increasing positive radii, bounded values."""
    if not isinstance(kernel, LaneKernel):
        raise ValueError(f"kernel must be a LaneKernel, got {type(kernel).__name__}")
    custom_kernel(kernel.radii, kernel.values, interp=kernel.interp)
    return kernel


@dataclass(frozen=True)
class LaneResult:
    """Output of :func:`lane_sample`: points in generation order, whether the pdf saturated, and draws made."""

    points: np.ndarray
    saturated: bool
    draws: int
    pdf: np.ndarray


def lane_sample(pdf, n: int, *, bbox, kernel: LaneKernel, rng=None, accept=None, min_distance: float | None = None,
                existing=None, backend: str = "numba", max_rejections_per_cell: int = 50) -> LaneResult:
    """Lane's distribution method in 3D: draw from the pdf, then multiply it by the kernel around each point.

    Parameters
    ----------
    pdf : (nx, ny, nz) float64 array_like
        Initial non-negative pdf over the cells of ``bbox`` (not modified; a copy evolves).
    n : int
        Number of points wanted; fewer are returned when the pdf saturates (all zero).
    bbox : (2, 3) float64 array_like
        Box covered by the grid.
    kernel : LaneKernel
        Multiplicative kernel (:func:`poisson_kernel`, :func:`cluster_kernel`, :func:`custom_kernel`).
    rng : int | numpy.random.Generator | None
        Seed or generator.
    accept : callable, optional
        ``accept(points (B, 3)) -> (B,) bool`` exact test (e.g. inside or in band); rejected draws do not apply the
        kernel, and a cell is zeroed after ``max_rejections_per_cell`` rejections in it.
    min_distance : float, optional
        Exact mode: reject a draw closer than this to an emitted point (KD check).
    existing : (M, 3) array_like, optional
        Points already placed: their kernels are applied first (densifying with ``respect_existing``).
    backend : {"numba", "numpy"}
        Kernel implementation (the numpy twin consumes the same uniforms).
    max_rejections_per_cell : int
        See ``accept``.

    Returns
    -------
    LaneResult
        Points ``(k, 3)``, ``saturated``, ``draws`` and the final pdf.

    Notes
    -----
    The kernel acts on cell centres while points fall anywhere in a cell, so without ``min_distance`` the spacing
    is only guaranteed to ``r_min - sqrt(3) h`` and points can leave the enabled region by one cell diagonal
    (spec §3.4, discretization caveat). With ``accept``, candidates are drawn in batches from the current pdf and
    processed in order; a candidate whose cell was zeroed meanwhile is dropped, which is exact rejection sampling
    for 0/1 kernels (other kernels use batches of one).

    References
    ----------
    .. [1] Kochhar 2010, §5.2.2, §6.1, Figs. 5.7-5.9, 6.1-6.2; Lane & Prusinkiewicz 2002 [54]; spec 003 §3.4.
    """
    G = check_array("pdf", pdf, shape=(None, None, None), max_abs=MAX_PDF).copy()
    if G.size == 0 or np.any(G < 0):
        raise ValueError(f"pdf must be non-empty and non-negative, got shape {G.shape}")
    box = _check_grid_box(check_array("bbox", bbox, shape=(2, 3), max_abs=MAX_COORD))
    _check_kernel(kernel)
    n = check_int("n", n, 0, MAX_LANE_POINTS)
    check_choice("backend", backend, ("numba", "numpy"))
    max_rej = check_int("max_rejections_per_cell", max_rejections_per_cell, 1, 10**9)
    if min_distance is not None:
        min_distance = check_range("min_distance", min_distance, 0.0, MAX_COORD, low_open=True)
    if accept is not None and not callable(accept):
        raise ValueError(f"accept must be callable, got {type(accept).__name__}")
    rng = np.random.default_rng(rng)
    lo = box[0].copy()
    h = (box[1] - box[0]) / np.array(G.shape)
    Y, Z = lk.recompute_sums(G)
    kr, kv, linear = kernel.radii.astype(float), kernel.values.astype(float), kernel.interp == "linear"
    apply = lk.apply_kernel_numba if backend == "numba" else lk.apply_kernel_numpy
    if existing is not None:
        for x in check_points("existing", existing):
            apply(G, Y, Z, lo, h, x, kr, kv, linear)
    out = np.empty((n, 3))
    run = lk.lane_run_numba if backend == "numba" else lk.lane_run_numpy
    draws = 0
    saturated = False
    if accept is None and min_distance is None:
        have = 0
        while have < n:
            U = rng.random((min(max(64, 2 * (n - have)), 1 << 21), 6))    # same stream, bounded memory
            have, used, saturated = run(G, Y, Z, lo, h, kr, kv, linear, U, n, out, have)
            draws += used
            if saturated:
                break
        return LaneResult(out[:have].copy(), bool(saturated), draws, G)
    # exact / accept mode: batches drawn from the current pdf, processed in order
    binary = bool(np.all((kv == 0) | (kv == 1)))
    emitted: list = []
    grid_hash: dict = {}
    rej = np.zeros(G.shape, dtype=np.int64)
    accepted_rate = 1.0
    while len(emitted) < n:
        total = Z.sum()
        if total <= 0:
            saturated = True
            break
        need = n - len(emitted)
        b = int(np.clip(2 * need / max(accepted_rate, 1e-4), 64, 65536)) if binary else 1
        cells_flat = np.flatnonzero(G.ravel() > 0)
        w = G.ravel()[cells_flat]
        cdf = np.cumsum(w)
        u = rng.random((b, 4))
        pick = np.minimum(np.searchsorted(cdf, u[:, 0] * cdf[-1], side="right"), len(cdf) - 1)
        cells = np.array(np.unravel_index(cells_flat[pick], G.shape)).T
        x = lo + (cells + u[:, 1:]) * h
        ok = np.asarray(accept(x), dtype=bool) if accept is not None else np.ones(b, dtype=bool)
        draws += b
        n_ok = 0
        for q in range(b):
            i, j, k = cells[q]
            if G[i, j, k] <= 0:
                continue
            good = ok[q]
            if good and min_distance is not None:
                key = tuple(np.floor(x[q] / min_distance).astype(int))
                for di in (-1, 0, 1):
                    for dj in (-1, 0, 1):
                        for dk in (-1, 0, 1):
                            for y in grid_hash.get((key[0] + di, key[1] + dj, key[2] + dk), ()):
                                if np.sum((y - x[q]) ** 2) < min_distance**2:
                                    good = False
            if not good:
                rej[i, j, k] += 1
                if rej[i, j, k] >= max_rej:
                    lk.set_cell(G, Y, Z, i, j, k, 0.0)
                continue
            rej[i, j, k] = 0
            emitted.append(x[q])
            n_ok += 1
            if min_distance is not None:
                grid_hash.setdefault(tuple(np.floor(x[q] / min_distance).astype(int)), []).append(x[q])
            apply(G, Y, Z, lo, h, x[q], kr, kv, linear)
            if len(emitted) >= n:
                break
        accepted_rate = max(n_ok / b, 0.5 * accepted_rate if n_ok == 0 else 0.0, 1e-4)
    pts = np.array(emitted).reshape(-1, 3)
    return LaneResult(pts, bool(saturated), draws, G)


# ------------------------------------------------------------------------------------------------ field pdfs
def field_pdf(node: Node, *, shape=(64, 64, 64), bbox=None, mode: str = "inside", iso: float = ISO,
              band=None, gamma: float = 1.0, func=None, cache=None):
    """Initial Lane pdf from the field at cell centres (thesis §6.1, Fig. 6.3; §6.2.3).

    Parameters
    ----------
    node : Node
        The envelope.
    shape : (3,) tuple of int
        Grid cells per axis.
    bbox : (2, 3) array_like, optional
        Box of the grid (default: the node's support box).
    mode : {"inside", "band", "band_corners", "inverse", "callable"}
        ``inside``: 1 where F_c > iso; ``band``: 1 where ``band[0] < F_c < band[1]``; ``band_corners``: 1 where the
        range of the cell's corner values meets the band (recommended with an exact test, spec §3.6.3);
        ``inverse``: ``(1/F_c)^gamma`` inside; ``callable``: ``func(F_c)``.
    iso : float
        Iso-value.
    band : (float, float), optional
        Field band for the band modes (e.g. ``(iso, iso + eps)`` for the near-boundary crown of Fig. 7.5b).
    gamma : float
        Exponent of the inverse-field pdf (1 is the thesis's choice).
    func : callable, optional
        ``func(F (M,)) -> (M,)`` non-negative, for ``mode="callable"``.
    cache : FieldCache, optional
        Classify centres by the cache instead of the exact field (``band`` mode; Table 6.2 "with a cache").

    Returns
    -------
    pdf : (nx, ny, nz) float64 ndarray
        Initial pdf.
    bbox : (2, 3) float64 ndarray
        Box of the grid.

    References
    ----------
    .. [1] Kochhar 2010, §6.1, Fig. 6.3, Fig. 7.5, §6.2.3; spec 003 §3.5, §3.6.3 (C-11).
    """
    _check_node(node)
    shape = _check_shape(shape)
    check_choice("mode", mode, ("inside", "band", "band_corners", "inverse", "callable"))
    iso = check_range("iso", iso, 0.0, np.inf, low_open=True)
    gamma = check_range("gamma", gamma, 0.0, 100.0)
    box = _box(node, bbox)
    if mode in ("band", "band_corners"):
        band = _check_band(band)
    if mode == "callable" and not callable(func):
        raise ValueError(f"func must be callable for mode='callable', got {type(func).__name__}")
    if cache is not None:
        if not callable(getattr(cache, "classify", None)):  # a band.FieldCache (band imports this module)
            raise ValueError(f"cache must be a FieldCache, got {type(cache).__name__}")
        if mode != "band":
            raise ValueError(f"cache is only used with mode='band', got mode={mode!r}")
    h = (box[1] - box[0]) / np.array(shape)
    if mode == "band_corners":
        axes = [box[0][i] + h[i] * np.arange(shape[i] + 1) for i in range(3)]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        c = node.field(pts).reshape(tuple(s + 1 for s in shape))
        views = [c[a:a + shape[0], b:b + shape[1], d:d + shape[2]] for a in (0, 1) for b in (0, 1) for d in (0, 1)]
        cmin, cmax = np.min(views, axis=0), np.max(views, axis=0)
        return ((cmax > band[0]) & (cmin < band[1])).astype(np.float64), box
    axes = [box[0][i] + h[i] * (np.arange(shape[i]) + 0.5) for i in range(3)]
    centres = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    if cache is not None:
        if mode != "band":
            raise ValueError(f"cache is only used with mode='band', got mode={mode!r}")
        return cache.classify(centres, band=band).reshape(shape).astype(np.float64), box
    f = node.field(centres).reshape(shape)
    if mode == "inside":
        g = (f > iso).astype(np.float64)
    elif mode == "band":
        g = ((f > band[0]) & (f < band[1])).astype(np.float64)
    elif mode == "inverse":
        g = np.where(f > iso, (1.0 / np.where(f > iso, f, 1.0)) ** gamma, 0.0)
    else:
        g = np.asarray(func(f.ravel()), dtype=np.float64).reshape(shape)
        if not np.all(np.isfinite(g)) or np.any(g < 0):
            raise ValueError("func must return finite non-negative values")
    return g, box


def _check_shape(shape) -> tuple:
    """Grid shape: 3 positive ints with at most :data:`MAX_GRID_CELLS` cells in all."""
    try:
        items = list(shape)
    except TypeError:
        raise ValueError(f"shape must have 3 entries, got {shape!r}") from None
    if len(items) != 3:
        raise ValueError(f"shape must have 3 entries, got {shape!r}")
    shape = tuple(check_int(f"shape[{i}]", s, 1, 4096) for i, s in enumerate(items))
    cells = shape[0] * shape[1] * shape[2]
    if cells > MAX_GRID_CELLS:
        raise ValueError(f"shape {shape} has {cells} cells, more than the {MAX_GRID_CELLS} allowed")
    return shape


def _tight_box(node: Node, level: float, *, res: int = 33) -> np.ndarray:
    """Box of the region ``F > level`` from a coarse corner grid (one coarse cell of margin), so the Lane grid's
    resolution is not spent on the empty part of the support box."""
    box = _box(node, None)
    axes = [np.linspace(box[0][i], box[1][i], res) for i in range(3)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    f = node.field(pts).reshape(res, res, res)
    idx = np.argwhere(f > level)
    if len(idx) == 0:
        return box
    h = (box[1] - box[0]) / (res - 1)
    lo = np.maximum(box[0], box[0] + (idx.min(axis=0) - 1) * h)
    hi = np.minimum(box[1], box[0] + (idx.max(axis=0) + 1) * h)
    return np.array([lo, hi])


def lane_in_node(node: Node, n: int, *, kernel: LaneKernel, shape=(64, 64, 64), mode: str = "inside",
                 iso: float = ISO, band=None, gamma: float = 1.0, exact: bool = False, rng=None,
                 existing=None, bbox=None) -> LaneResult:
    """Lane's method in an envelope: field-controlled pdf, kernel, optional exact tests (C-10, C-11).

    Parameters
    ----------
    node : Node
        The envelope.
    n : int
        Number of points (fewer if the pdf saturates).
    kernel : LaneKernel
        Poisson, cluster or custom kernel.
    shape : (3,) tuple of int
        Grid cells per axis.
    mode : str
        Initial pdf, see :func:`field_pdf`.
    iso : float
        Iso-value.
    band : (float, float), optional
        Field band for band modes.
    gamma : float
        Inverse-field exponent.
    exact : bool
        Reject draws that fail the exact inside/band test or come closer than the kernel's first radius to an
        emitted point (Poisson kernels) without applying the kernel (spec §3.4).
    rng : int | numpy.random.Generator | None
        Seed or generator.
    existing : (M, 3) array_like, optional
        Points whose kernels pre-multiply the pdf.
    bbox : (2, 3) array_like, optional
        Grid box.

    Returns
    -------
    LaneResult
        Points, saturation flag, draws and final pdf.
    """
    _check_node(node)
    _check_kernel(kernel)
    check_choice("mode", mode, ("inside", "band", "band_corners", "inverse", "callable"))
    iso = check_range("iso", iso, 0.0, np.inf, low_open=True)
    if band is not None or mode in ("band", "band_corners"):
        band = _check_band(band)
    _check_shape(shape)
    n = check_int("n", n, 0, MAX_LANE_POINTS)
    if bbox is None:
        bbox = _tight_box(node, iso if mode in ("inside", "inverse") else (min(band) if band is not None else iso))
    pdf, box = field_pdf(node, shape=shape, bbox=bbox, mode=mode, iso=iso, band=band, gamma=gamma)
    if pdf.sum() <= 0:
        raise ValueError(f"the envelope is empty on this grid (no cell enabled for mode={mode!r}); "
                         "check the surface, its scale or the band")
    accept = None
    min_d = None
    if exact:
        if mode in ("band", "band_corners"):
            lo_f, hi_f = float(band[0]), float(band[1])
            accept = lambda p: (lambda f: (f > lo_f) & (f < hi_f))(node.field(p))  # noqa: E731
        else:
            accept = lambda p: node.field(p) > iso  # noqa: E731
        if kernel.values[0] == 0.0:
            min_d = float(kernel.radii[0])
    return lane_sample(pdf, n, bbox=box, kernel=kernel, rng=rng, accept=accept, min_distance=min_d,
                       existing=existing)

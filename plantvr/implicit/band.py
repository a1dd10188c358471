"""Points outside and in proximity to a surface: field band rejection and the field-value cache
(spec 003_implicit_sca §3.6; C-12).

The cache is the thesis's hash table of cubes whose corner values meet the band, with the corner values stored for
trilinear interpolation. It is built vectorised on a dense corner grid (spec §3.6.2: the pure-Python BFS is ~100x
slower) and addressed directly by the integer cube key, so a rejected sample costs one table lookup.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_choice, check_int, check_points, check_range

from .blobtree import Node
from .sampling import MAX_POINTS, _check_grid_box, rejection_sample

#: Most cube corners of one cache (dense corner grid).
MAX_CORNERS = 2e8

__all__ = ["FieldCache", "sample_band"]


def _check_band(band):
    try:
        lo, hi = float(band[0]), float(band[1])
    except (TypeError, ValueError, IndexError, KeyError):
        raise ValueError(f"band must be a pair (f_lo, f_hi), got {band!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError(f"band must satisfy f_lo < f_hi (finite), got {band!r}")
    return lo, hi


class FieldCache:
    """Cube table over the node's box for a field band, with cached corner values (thesis §6.2.2).

    Parameters
    ----------
    node : Node
        The surface.
    edge : float
        Cube edge length (0.5 in Tables 6.1/6.2).
    band : (float, float)
        Field band; a cube is kept iff its corner range meets it.
    bbox : (2, 3) array_like, optional
        Box (default: the node's support box, "all points whose field value is not zero").
    method : {"dense", "bfs"}
        ``dense``: every corner of the box grid is evaluated (vectorised) and cubes are masked. ``bfs``: the
        thesis's continuation, marching cubes around the surface from seed cubes (cubes holding band points found
        by rejection), one vectorised field call per breadth-first wave; only visited corners are evaluated, and a
        band component without a seed is missed.
    seeds : int
        Band points drawn by rejection to seed the ``bfs`` method.
    rng : int | numpy.random.Generator | None
        Seed for the ``bfs`` seed points.

    Attributes
    ----------
    table : (nx, ny, nz) bool ndarray
        Kept cubes, addressed by ``floor((p - origin) / edge)``.
    corners : (nx+1, ny+1, nz+1) float64 ndarray
        Exact field values at cube corners.
    n_cubes : int
        Number of cubes in the cache (2275 in the thesis's test).

    References
    ----------
    .. [1] Kochhar 2010, §6.2.2, Table 6.1; Schmidt [85] (corner caching); spec 003 §3.6.2.
    """

    def __init__(self, node: Node, *, edge: float = 0.5, band=(0.40, 0.41), bbox=None, method: str = "dense",
                 seeds: int = 32, rng=None):
        if not isinstance(node, Node):
            raise ValueError(f"node must be a BlobTree Node, got {type(node).__name__}")
        self.node = node
        self.edge = check_range("edge", edge, 0.0, MAX_COORD, low_open=True)
        self.band = _check_band(band)
        box = node.bbox if bbox is None else check_array("bbox", bbox, shape=(2, 3), max_abs=MAX_COORD)
        box = _check_grid_box(box)
        counts = np.ceil((box[1] - box[0]) / self.edge)           # float first: a tiny edge cannot overflow
        if np.prod(counts + 1) > MAX_CORNERS:
            raise ValueError(f"edge must give at most {MAX_CORNERS:g} cube corners over the box, got edge={edge} "
                             f"({counts.astype(np.float64).tolist()} cubes); use a larger edge")
        check_choice("method", method, ("dense", "bfs"))
        seeds = check_int("seeds", seeds, 1, 10**6)
        self.origin = box[0].copy()
        self.shape = tuple(int(v) for v in counts)
        self.method = method
        if method == "dense":
            axes = [self.origin[i] + self.edge * np.arange(self.shape[i] + 1) for i in range(3)]
            pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
            self.corners = node.field(pts).reshape(tuple(s + 1 for s in self.shape))
            nx, ny, nz = self.shape
            c = self.corners
            views = [c[a:a + nx, b:b + ny, d:d + nz] for a in (0, 1) for b in (0, 1) for d in (0, 1)]
            cmin, cmax = np.min(views, axis=0), np.max(views, axis=0)
            self.table = (cmax > self.band[0]) & (cmin < self.band[1])
            self.evaluations = int(c.size)
        else:
            self._build_bfs(seeds, rng)
        self.n_cubes = int(self.table.sum())
        hi = self.origin + self.edge * np.array(self.shape)
        self.bbox = np.array([self.origin, hi])

    def _build_bfs(self, seeds, rng):
        node, shape = self.node, np.array(self.shape)
        start = rejection_sample(node, seeds, f_lo=self.band[0], f_hi=self.band[1], rng=rng,
                                 bbox=np.array([self.origin, self.origin + self.edge * shape]))
        self.corners = np.full(tuple(shape + 1), np.nan)
        self.table = np.zeros(tuple(shape), dtype=bool)
        visited = np.zeros(tuple(shape), dtype=bool)
        offs = np.array([[a, b, d] for a in (0, 1) for b in (0, 1) for d in (0, 1)])
        nbrs = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
        front = np.unique(np.clip(np.floor((start - self.origin) / self.edge).astype(np.int64), 0, shape - 1),
                          axis=0)
        visited[tuple(front.T)] = True
        evals = 0
        while len(front):
            corner_idx = np.unique((front[:, None, :] + offs[None]).reshape(-1, 3), axis=0)
            need = corner_idx[np.isnan(self.corners[tuple(corner_idx.T)])]
            if len(need):
                self.corners[tuple(need.T)] = node.field(self.origin + need * self.edge)
                evals += len(need)
            vals = self.corners[tuple((front[:, None, :] + offs[None]).reshape(-1, 3).T)].reshape(-1, 8)
            keep = (vals.max(axis=1) > self.band[0]) & (vals.min(axis=1) < self.band[1])
            kept = front[keep]
            self.table[tuple(kept.T)] = True
            cand = (kept[:, None, :] + nbrs[None]).reshape(-1, 3)
            cand = cand[np.all((cand >= 0) & (cand < shape), axis=1)]
            cand = np.unique(cand, axis=0)
            cand = cand[~visited[tuple(cand.T)]]
            visited[tuple(cand.T)] = True
            front = cand
        self.evaluations = evals

    def lookup(self, p: np.ndarray):
        """Cube keys (N, 3) and a mask of points whose cube is in the table."""
        key = np.floor((p - self.origin) / self.edge).astype(np.int64)
        ok = np.all((key >= 0) & (key < np.array(self.shape)), axis=1)
        hit = np.zeros(len(p), dtype=bool)
        hit[ok] = self.table[key[ok, 0], key[ok, 1], key[ok, 2]]
        return key, hit

    def interpolate(self, p: np.ndarray) -> np.ndarray:
        """Trilinear interpolation of the cached corner values (points must lie in the box)."""
        t = (p - self.origin) / self.edge
        key = np.clip(np.floor(t).astype(np.int64), 0, np.array(self.shape) - 1)
        fr = t - key
        i, j, k = key.T
        c = self.corners
        out = np.zeros(len(p))
        for a in (0, 1):
            wa = fr[:, 0] if a else 1 - fr[:, 0]
            for b in (0, 1):
                wb = fr[:, 1] if b else 1 - fr[:, 1]
                for d in (0, 1):
                    wd = fr[:, 2] if d else 1 - fr[:, 2]
                    out += wa * wb * wd * c[i + a, j + b, k + d]
        return out

    def classify(self, p, *, band=None, mode: str = "approx") -> np.ndarray:
        """Band membership by the cache: table hit and trilinear value in band (``approx``) or exact (``filter``)."""
        p = check_points("p", p)
        check_choice("mode", mode, ("approx", "filter"))
        lo, hi = self.band if band is None else _check_band(band)
        _, hit = self.lookup(p)
        out = np.zeros(len(p), dtype=bool)
        if hit.any():
            f = self.interpolate(p[hit]) if mode == "approx" else self.node.field(p[hit])
            out[hit] = (f > lo) & (f < hi)
        return out


def sample_band(node: Node, n: int, *, band=(0.40, 0.41), method: str = "cache", cache_mode: str = "filter",
                edge: float = 0.5, cache: FieldCache | None = None, rng=None, max_draws: int = 200_000_000):
    """Uniform points with ``f_lo < F < f_hi`` ("outside and in proximity", thesis §6.2.1) by rejection or the cache.

    Parameters
    ----------
    node : Node
        The surface.
    n : int
        Number of points.
    band : (float, float)
        Field band, e.g. ``(iso - eps, iso)``; Tables 6.1/6.2 use (0.40, 0.41).
    method : {"rejection", "cache"}
        Direct rejection with exact field values, or the cube cache.
    cache_mode : {"filter", "approx"}
        ``filter`` (default): the table only rejects, survivors get the exact test, so 100 % are in band.
        ``approx`` (faithful): accept by the trilinear value.
    edge : float
        Cube edge of a cache built here.
    cache : FieldCache, optional
        A prebuilt cache (its band must contain ``band``).
    rng : int | numpy.random.Generator | None
        Seed or generator.
    max_draws : int
        Candidate budget before a ValueError.

    Returns
    -------
    (n, 3) float64 ndarray
        Points in generation order.

    References
    ----------
    .. [1] Kochhar 2010, §6.2.1-6.2.2, Table 6.1; spec 003 §3.6.1-3.6.2, ERRATUM A.7.
    """
    lo, hi = _check_band(band)
    check_choice("method", method, ("rejection", "cache"))
    check_choice("cache_mode", cache_mode, ("filter", "approx"))
    n = check_int("n", n, 0, MAX_POINTS)
    max_draws = check_int("max_draws", max_draws, 1, 10**12)
    if cache is not None and not isinstance(cache, FieldCache):
        raise ValueError(f"cache must be a FieldCache, got {type(cache).__name__}")
    if method == "rejection":
        return rejection_sample(node, n, f_lo=lo, f_hi=hi, rng=rng, max_draws=max_draws)
    if cache is None:
        cache = FieldCache(node, edge=edge, band=(lo, hi))
    if cache.n_cubes == 0:
        raise ValueError(f"the cache holds no cube meeting the band {band}: empty envelope or band outside the field")
    rng = np.random.default_rng(rng)
    box = cache.bbox
    out, have, draws, batch = [], 0, 0, 8192
    while have < n:
        if draws >= max_draws:
            raise ValueError(f"only {have} of {n} points after {draws} draws; widen the band or raise max_draws")
        p = box[0] + (box[1] - box[0]) * rng.random((batch, 3))
        acc = p[cache.classify(p, band=(lo, hi), mode=cache_mode)]
        draws += batch
        out.append(acc[: n - have])
        have += len(out[-1])
        batch = int(np.clip(1.2 * (n - have) * draws / max(have, 1), 4096, 1 << 21))
    return np.concatenate(out)

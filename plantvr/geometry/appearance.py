"""TreeSketch appearance: thickest-path tubes with adaptive sides, fruit, leaf hue by vigor (spec 004_treesketch §4.1, §4.2, §4.4).

* :func:`contour_sides` and :func:`thickest_path_mesh`: generalized cylinders built along the *thickest-path*
  topology (every node continues into its widest child), one side count per branch from the width at its base
  by Eq. C.2 as corrected (ERRATUM E4): C = ceil(3 (d / d_e)^(1/n)), so the thinnest branches are 3-sided tubes
  (App. C.3, V28). The mesh itself is :mod:`plantvr.geometry.mesh`'s, with per-branch ring counts.
* :func:`hash_random` and :func:`place_fruit`: fruit on thin-branch buds where p = r L^2 (Eq. C.1) exceeds a
  threshold, r read from a seeded random table by an XOR hash of the quantised bud position, so a bud keeps its
  fruit as the tree grows (V30); each fruit is oriented in its bud frame and drooped toward gravity.
* :func:`hsv_to_rgb`, :func:`rgb_to_hsv` and :func:`vigor_leaf_colors`: leaves on less vigorous branches shift
  toward yellows and reds, hue -= shift (1 - v / v_max) (§4.1 [INFERRED]).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import grid
from .._validation import check_array, check_int, check_points, check_range
from .mesh import BranchMesh, _check_options, _check_tree, _evaluate, _offsets, ring_counts, tree_segments

__all__ = [
    "HASH_PRIMES",
    "FruitPlacement",
    "contour_sides",
    "fruit_probability",
    "hash_random",
    "hsv_to_rgb",
    "place_fruit",
    "position_hash",
    "rgb_to_hsv",
    "thickest_main_child",
    "thickest_path_mesh",
    "vigor_leaf_colors",
]

#: Multipliers of the spatial hash (spec 004 §4.4 [INFERRED], Teschner et al. 2003): those of plantvr.grid.
HASH_PRIMES = grid.HASH_PRIMES
_Y = np.array([0.0, 1.0, 0.0])


# -- branch tubes (App. C.3) -------------------------------------------------------------------------------------
def contour_sides(diameter, *, d_e: float, n: float = 1.0, c_max: int = 32) -> np.ndarray:
    """Number of sides of a branch's generalized cylinder from its base width (Eq. C.2, ERRATUM E4).

    Parameters
    ----------
    diameter : float or (M,) float64 array_like
        Branch widths d at their bases, in scene units (> 0).
    d_e : float
        Width of the thinnest branches (tips); they get 3 sides.
    n : float
        Contour exponent >= 1: n = 1 keeps the circumference per face constant, n > 1 gives thick branches
        fewer polygons (sublinear in d).
    c_max : int
        Upper clamp, in [3, 64].

    Returns
    -------
    (M,) int64 ndarray
        C = clamp(ceil(3 (d / d_e)^(1/n)), 3, c_max).

    References
    ----------
    .. [1] Longay thesis App. C.3, Eq. C.2 (printed C = 3 d^n / d_e); spec 004 §4.2, ERRATUM E4.

    Examples
    --------
    >>> contour_sides([0.02, 0.04, 0.2], d_e=0.02).tolist()
    [3, 6, 30]
    """
    d = np.atleast_1d(np.asarray(diameter, float))
    if not np.all(np.isfinite(d)) or np.any(d <= 0):
        raise ValueError(f"diameter must be finite and > 0, got min {d.min() if d.size else None!r}")
    d_e = check_range("d_e", d_e, 0.0, np.inf, low_open=True)
    n = check_range("n", n, 1.0, 100.0)
    c_max = check_int("c_max", c_max, 3, 64)
    ratio = np.maximum(d / d_e, 1.0)
    c = np.ceil(3.0 * ratio ** (1.0 / n) - 1e-9)  # exact ratios like (2)^1 stay at 6, not 7
    return np.clip(c, 3, c_max).astype(np.int64)


def thickest_main_child(parent, radius, *, alive=None) -> np.ndarray:
    """Main child of every node along the thickest-path topology: the live child with the largest radius.

    Parameters
    ----------
    parent : (N,) int array_like
        Parent of each node, -1 for node 0, ``parent[i] < i``.
    radius : (N,) float64 array_like
        Radius of the internode ending at each node.
    alive : (N,) bool array_like, optional

    Returns
    -------
    (N,) int64 ndarray
        Child index or -1 for tips; ties go to the lowest index (the growth model's main child comes first).

    References
    ----------
    .. [1] Longay thesis App. C.3, Figs. C.6–C.7 ("thickest path", ERRATUM E5); spec 004 §4.2 step (1).
    """
    parent = np.asarray(parent, np.int64)
    n = len(parent)
    radius = check_array("radius", radius, shape=(n,))
    alive = np.ones(n, bool) if alive is None else check_array("alive", alive, shape=(n,), dtype=np.bool_)
    kids = np.flatnonzero((parent >= 0) & alive & alive[np.maximum(parent, 0)])
    # sort by (parent, -radius, index): the first child per parent is its thickest
    order = np.lexsort((kids, -radius[kids], parent[kids]))
    kids = kids[order]
    par = parent[kids]
    first = np.ones(len(kids), bool)
    first[1:] = par[1:] != par[:-1]
    main = np.full(n, -1, np.int64)
    main[par[first]] = kids[first]
    return main


def thickest_path_mesh(pos, parent, radius, *, alive=None, tip_radius: float | None = None,
                       side_exponent: float = 1.0, c_max: int = 32, bezier_w: float = 3.0, u_steps: int = 4,
                       bark_rate: float = 1.0, bark_repeat: int = 1) -> BranchMesh:
    """Generalized cylinders along the thickest-path topology, 3 sides at the tips (spec 004 §4.2, V28).

    Parameters
    ----------
    pos : (N, 3) float64 array_like
        Node positions; node 0 is the base point.
    parent : (N,) int array_like
        Parent index, -1 for node 0, ``parent[i] < i``.
    radius : (N,) float64 array_like
        Radius of the internode ending at each node (> 0).
    alive : (N,) bool array_like, optional
    tip_radius : float, optional
        d_e / 2 of Eq. C.2; default the smallest live radius.
    side_exponent : float
        Contour exponent n >= 1 of Eq. C.2.
    c_max : int
        Most sides of any branch.
    bezier_w, u_steps, bark_rate, bark_repeat
        As in :func:`plantvr.geometry.build_branch_mesh`.

    Returns
    -------
    BranchMesh
        Every branch (a chain of thickest children) is one closed tube with a constant side count
        ``options["sides"][axis]`` = :func:`contour_sides` of its base width.

    References
    ----------
    .. [1] Longay thesis App. C.3, Eq. C.2 (ERRATUM E4), Figs. C.5–C.7 (ERRATUM E5); spec 004 §4.2.
    """
    pos, parent, radius, alive, _ = _check_tree(pos, parent, radius, alive, None)
    c_max = check_int("c_max", c_max, 3, 64)
    opts = _check_options(bezier_w, u_steps, (3, c_max), tip_radius, bark_rate, bark_repeat, radius, parent,
                          alive)
    side_exponent = check_range("side_exponent", side_exponent, 1.0, 100.0)
    main = thickest_main_child(parent, radius, alive=alive)
    seg = tree_segments(pos, parent, radius, alive=alive, main_child=main, bezier_w=opts["bezier_w"],
                        bark_rate=opts["bark_rate"], _checked=True)
    # the width at the base of each branch: the internode that starts its axis (the trunk: node 0's main child)
    axes = np.unique(seg.axis)
    start = np.where(axes == 0, max(int(main[0]), 0), axes)
    sides = contour_sides(2.0 * radius[start], d_e=2.0 * opts["tip_radius"], n=side_exponent, c_max=c_max)
    seg_sides = sides[np.searchsorted(axes, seg.axis)]  # axes sorted (np.unique)
    cnt = ring_counts(seg_sides, seg_sides, opts["u_steps"])
    opts.update(main_child=main, sides=dict(zip(axes.tolist(), sides.tolist())), side_exponent=side_exponent)
    return _evaluate(seg, cnt, *_offsets(cnt, seg.caps), opts)


# -- fruit (App. C.2) ----------------------------------------------------------------------------------------------
def position_hash(pos, *, quant: float = 0.05, table_size: int = 4096) -> np.ndarray:
    """Table index of each 3D position: (ix p1) XOR (iy p2) XOR (iz p3) mod table_size, i = floor(x / quant).

    Parameters
    ----------
    pos : (B, 3) float64 array_like
        Bud positions, scene units.
    quant : float
        Quantisation step (> 0): positions in the same cell share an index.
    table_size : int
        Size of the random table, in [1, 2^24].

    Returns
    -------
    (B,) int64 ndarray in [0, table_size).

    References
    ----------
    .. [1] Longay thesis App. C.2 ("bitwise-XOR function to combine the components of the 3D bud position");
       hash primes [INFERRED] in spec 004 §4.4.
    """
    pos = check_points("pos", pos)
    quant = check_range("quant", quant, 0.0, np.inf, low_open=True)
    table_size = check_int("table_size", table_size, 1, 2 ** 24)
    cell = np.floor(pos / quant)
    if cell.size and np.abs(cell).max() > 2 ** 30:
        raise ValueError(f"pos / quant must stay within +-2^30 cells, got {np.abs(cell).max():.3g}")
    return grid.hash_coords(cell.astype(np.int64)) % table_size


def hash_random(pos, *, seed: int = 0, quant: float = 0.05, table_size: int = 4096) -> np.ndarray:
    """Position-stable pseudo-random numbers r in [0, 1): a seeded table read at :func:`position_hash`.

    Parameters
    ----------
    pos : (B, 3) float64 array_like
    seed : int
        Seed of the table (the same seed and position always give the same r).
    quant, table_size
        As in :func:`position_hash`.

    Returns
    -------
    (B,) float64 ndarray

    References
    ----------
    .. [1] Longay thesis App. C.2, Eq. C.1 (r); spec 004 §4.4, V30 (hash stability).
    """
    seed = check_int("seed", seed, 0, 2 ** 63 - 1)
    idx = position_hash(pos, quant=quant, table_size=table_size)
    return np.random.default_rng(seed).random(table_size)[idx]


def fruit_probability(r, light) -> np.ndarray:
    """Eq. C.1: p = r L^2 with 0 <= r, L <= 1.

    Parameters
    ----------
    r : (B,) float64 array_like
        Hashed random numbers in [0, 1].
    light : (B,) float64 array_like
        Light exposure L of each bud in [0, 1].

    Returns
    -------
    (B,) float64 ndarray in [0, 1].

    References
    ----------
    .. [1] Longay thesis App. C.2, Eq. C.1; spec 004 §4.4.
    """
    r = np.asarray(check_array("r", r, shape=(None,)))
    light = check_array("light", light, shape=(len(r),))
    for name, a in (("r", r), ("light", light)):
        if a.size and (a.min() < 0 or a.max() > 1):
            raise ValueError(f"{name} must be in [0, 1], got range [{a.min()!r}, {a.max()!r}]")
    return r * light ** 2


@dataclass(frozen=True)
class FruitPlacement:
    """Fruit chosen among buds, as instances (spec 004 §4.4).

    Attributes
    ----------
    probability : (B,) float64 ndarray
        p = r L^2 of every bud (0 for buds on branches thicker than the thin-branch threshold).
    index : (F,) int64 ndarray
        Rows of the bud arrays that carry a fruit.
    transforms : (F, 4, 4) float64 ndarray
        Instance matrices: columns (e1, e2, a) scaled by the fruit size, translation at the bud; the fruit
        template hangs along its local +z.
    axis : (F, 3) float64 ndarray
        Unit hanging direction a of each fruit (bud heading drooped toward -Y).
    """

    probability: np.ndarray
    index: np.ndarray
    transforms: np.ndarray
    axis: np.ndarray

    @property
    def n_fruit(self) -> int:
        """Number of fruit."""
        return len(self.index)

    def mesh(self, template=None, *, subdivisions: int = 2):
        """All fruit as one ``trimesh.Trimesh`` (``process=False``): ``template`` (a Trimesh in fruit units, default
        a unit sphere centred at z = 1 on a short stalk axis) placed by every instance transform."""
        import trimesh

        if template is None:
            template = trimesh.creation.icosphere(subdivisions=check_int("subdivisions", subdivisions, 0, 5))
            template = trimesh.Trimesh(template.vertices + [0.0, 0.0, 1.0], template.faces, process=False)
        v = np.asarray(template.vertices, float)
        f = np.asarray(template.faces, np.int64)
        F = self.n_fruit
        if F == 0:
            return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
        M = self.transforms
        verts = np.einsum("fij,vj->fvi", M[:, :3, :3], v) + M[:, None, :3, 3]
        faces = f[None] + (np.arange(F) * len(v))[:, None, None]
        return trimesh.Trimesh(verts.reshape(-1, 3), faces.reshape(-1, 3), process=False)


def _droop(heading: np.ndarray, droop: float) -> np.ndarray:
    """Rotate each unit heading toward -Y by the fraction ``droop`` of the angle between them (slerp)."""
    down = -_Y
    c = np.clip(heading @ down, -1.0, 1.0)
    ang = np.arccos(c)
    perp = heading - c[:, None] * down
    nrm = np.linalg.norm(perp, axis=1)
    out = np.tile(down, (len(heading), 1))
    ok = nrm > 1e-12
    if ok.any():
        a = (1.0 - droop) * ang[ok]  # remaining angle from -Y
        out[ok] = np.cos(a)[:, None] * down + np.sin(a)[:, None] * (perp[ok] / nrm[ok, None])
    # heading exactly up (or down): no plane to rotate in; up stays up unless fully drooped
    up = ~ok & (c < 0)
    if up.any() and droop < 1.0:
        out[up] = _Y
    return out


def place_fruit(bud_pos, bud_dir, bud_radius, bud_light, *, threshold: float = 0.5, radius_threshold: float,
                droop: float = 0.7, size: float = 0.1, seed: int = 0, quant: float = 0.05,
                table_size: int = 4096, bud_up=None) -> FruitPlacement:
    """Fruit on thin-branch buds where p = r L^2 > threshold (Eq. C.1), deterministic per seed.

    Parameters
    ----------
    bud_pos : (B, 3) float64 array_like
        Bud positions.
    bud_dir : (B, 3) float64 array_like
        Bud headings (bud frame H).
    bud_radius : (B,) float64 array_like
        Radius of the internode each bud sits on.
    bud_light : (B,) float64 array_like
        Light exposure L in [0, 1] (the growth model's shadow field at the bud).
    threshold : float
        Probability threshold in [0, 1]: fruit where p > threshold.
    radius_threshold : float
        Thin-branch filter: only buds with ``bud_radius <= radius_threshold`` are candidates (> 0).
    droop : float
        Fraction in [0, 1] of the angle from the bud heading to -Y by which the fruit is rotated downward
        (0 = along the bud, 1 = hanging straight down) [INFERRED reading of "Droop"].
    size : float
        Fruit radius, scene units (> 0).
    seed : int
        Seed of the hashed random table.
    quant, table_size
        As in :func:`position_hash`.
    bud_up : (B, 3) float64 array_like, optional
        Lateral vector of the bud frame (orients the fruit about its axis); default any perpendicular.

    Returns
    -------
    FruitPlacement

    References
    ----------
    .. [1] Longay thesis App. C.2, Eq. C.1, Fig. C.4; spec 004 §4.4, V30.
    """
    bud_pos = check_points("bud_pos", bud_pos)
    B = len(bud_pos)
    bud_dir = check_array("bud_dir", bud_dir, shape=(B, 3))
    bud_radius = check_array("bud_radius", bud_radius, shape=(B,))
    bud_light = check_array("bud_light", bud_light, shape=(B,))
    threshold = check_range("threshold", threshold, 0.0, 1.0)
    radius_threshold = check_range("radius_threshold", radius_threshold, 0.0, np.inf, low_open=True)
    droop = check_range("droop", droop, 0.0, 1.0)
    size = check_range("size", size, 0.0, np.inf, low_open=True)
    if bud_up is not None:
        bud_up = check_array("bud_up", bud_up, shape=(B, 3))
    if B and (bud_light.min() < 0 or bud_light.max() > 1):
        raise ValueError(f"bud_light must be in [0, 1], got range [{bud_light.min()!r}, {bud_light.max()!r}]")
    hn = np.linalg.norm(bud_dir, axis=1)
    if np.any(hn <= 0):
        raise ValueError("bud_dir must be non-zero vectors")
    r = hash_random(bud_pos, seed=seed, quant=quant, table_size=table_size)
    p = fruit_probability(r, bud_light)
    p = np.where(bud_radius <= radius_threshold, p, 0.0)
    idx = np.flatnonzero(p > threshold)
    H = bud_dir[idx] / hn[idx, None]
    a = _droop(H, droop)
    ref = bud_up[idx] if bud_up is not None else np.tile([1.0, 0.0, 0.0], (len(idx), 1))
    e1 = ref - np.sum(ref * a, 1, keepdims=True) * a
    bad = np.linalg.norm(e1, axis=1) < 1e-9
    if bad.any():
        alt = np.tile([0.0, 0.0, 1.0], (int(bad.sum()), 1))
        e1[bad] = alt - np.sum(alt * a[bad], 1, keepdims=True) * a[bad]
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(a, e1)
    M = np.zeros((len(idx), 4, 4))
    M[:, :3, 0], M[:, :3, 1], M[:, :3, 2] = size * e1, size * e2, size * a
    M[:, :3, 3] = bud_pos[idx]
    M[:, 3, 3] = 1.0
    return FruitPlacement(probability=p, index=idx, transforms=M, axis=a)


# -- leaf hue by vigor (§4.1) ------------------------------------------------------------------------------------
def rgb_to_hsv(rgb) -> np.ndarray:
    """(M, 3) RGB in [0, 1] -> (M, 3) HSV with hue in degrees [0, 360), saturation and value in [0, 1]
    (vectorised :func:`colorsys.rgb_to_hsv`, hue scaled by 360)."""
    rgb = check_array("rgb", rgb, shape=(None, 3))
    if rgb.size and (rgb.min() < 0 or rgb.max() > 1):
        raise ValueError("rgb must be in [0, 1]")
    r, g, b = rgb.T
    mx, mn = rgb.max(1), rgb.min(1)
    c = mx - mn
    safe = np.where(c > 0, c, 1.0)
    h = np.where(mx == r, ((g - b) / safe) % 6.0, np.where(mx == g, (b - r) / safe + 2.0, (r - g) / safe + 4.0))
    h = np.where(c > 0, h * 60.0, 0.0) % 360.0
    s = np.where(mx > 0, c / np.where(mx > 0, mx, 1.0), 0.0)
    return np.stack([h, s, mx], 1)


def hsv_to_rgb(hsv) -> np.ndarray:
    """(M, 3) HSV (hue in degrees, any real value wraps) -> (M, 3) RGB in [0, 1]."""
    hsv = check_array("hsv", hsv, shape=(None, 3))
    h = (hsv[:, 0] % 360.0) / 60.0
    s, v = np.clip(hsv[:, 1], 0, 1), np.clip(hsv[:, 2], 0, 1)
    i = np.floor(h).astype(np.int64) % 6
    f = h - np.floor(h)
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    table = np.stack([np.stack([v, t, p], 1), np.stack([q, v, p], 1), np.stack([p, v, t], 1),
                      np.stack([p, q, v], 1), np.stack([t, p, v], 1), np.stack([v, p, q], 1)])
    return table[i, np.arange(len(i))]


def vigor_leaf_colors(vigor, *, base_rgb=(0.22, 0.55, 0.15), shift: float = 90.0,
                      v_max: float | None = None) -> np.ndarray:
    """Per-leaf RGB: the base colour's hue lowered by shift (1 - v / v_max), toward yellows and reds.

    Parameters
    ----------
    vigor : (L,) float64 array_like
        Vigor of the branch (or bud) each leaf sits on, >= 0.
    base_rgb : (3,) float array_like
        Colour of the most vigorous leaves, RGB in [0, 1].
    shift : float
        Hue-shift magnitude in degrees, [0, 360] (the modeller's parameter; 0 = no shift).
    v_max : float, optional
        Vigor that keeps the base colour; default the largest given vigor. Vigor above it is clipped.

    Returns
    -------
    (L, 3) float64 ndarray
        RGB in [0, 1]; saturation and value of the base colour are kept.

    References
    ----------
    .. [1] Longay thesis §5.5 ("shift towards yellows and reds"); spec 004 §4.1 [INFERRED] hue formula.
    """
    v = check_array("vigor", vigor, shape=(None,))
    if v.size and v.min() < 0:
        raise ValueError(f"vigor must be >= 0, got min {v.min()!r}")
    base = check_array("base_rgb", base_rgb, shape=(3,))
    shift = check_range("shift", shift, 0.0, 360.0)
    if v_max is None:
        v_max = float(v.max()) if v.size else 1.0
    v_max = check_range("v_max", v_max, 0.0, np.inf)
    rel = np.clip(v / v_max, 0.0, 1.0) if v_max > 0 else np.ones_like(v)
    hsv = np.repeat(rgb_to_hsv(base[None]), len(v), axis=0)
    hsv[:, 0] = hsv[:, 0] - shift * (1.0 - rel)
    return hsv_to_rgb(hsv)

"""Florets-first branching: the extended Rodkaew algorithm for corymbs and umbels (spec 002 §5; C22–C25).

Particles start at the floret positions (at their emergence times) and trace branches toward the
inflorescence base A0, steered by Eq. 7.1, H' = (w_a A + w_b B + w_h H) / (w_a + w_b + w_h), where B points to
the nearest node of a *foreign* tree (another particle's tree or the established structure). A particle that
comes within the merging distance of a foreign node grafts its tree there and the host's ID_branch is
propagated through the grafted tree (read live, spec §5.3 pitfall 1). Corymbs of heads and compound umbels are
generated level by level (Fig. 7.2b) and joined. Widths follow the pipe model d^p = sum d_i^p; a tube mesh is
made along every segment.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from plantvr._validation import MAX_COORD, check_array, check_int, check_point, check_range
from plantvr.grid import CellLists

__all__ = [
    "BranchTree",
    "compound_umbel",
    "corymb",
    "linear_wb",
    "pipe_widths",
    "rodkaew",
    "scale_tree",
    "tube_mesh",
]


@dataclass
class BranchTree:
    """A branching structure as parent pointers toward the base (node 0 is the base A0).

    Attributes
    ----------
    pos : (N, 3) float64 ndarray
        Node positions.
    parent : (N,) int64 ndarray
        Parent node (toward the base); -1 for the root (node 0).
    branch_id : (N,) int64 ndarray
        ID_branch of each node at the end of the run (all equal to the base's ID when connected).
    tips : (K,) int64 ndarray
        Node of each floret, in input order.
    grafts : list of (child node, host node, host id, relabelled ids)
        Every graft, for the ID checks of V38.
    """

    pos: np.ndarray
    parent: np.ndarray
    branch_id: np.ndarray
    tips: np.ndarray
    grafts: list

    def __post_init__(self):
        # every reader of a tree (pipe widths, tubes, scaling) indexes with these tables: check them once here
        self.pos = check_array("pos", self.pos, shape=(None, 3), min_rows=1, max_abs=_MAX_TREE_COORD)
        n = self.pos.shape[0]
        self.parent = _index_array("parent", self.parent, (n,), -1, n - 1)
        self.branch_id = _index_array("branch_id", self.branch_id, (n,), -(2 ** 62), 2 ** 62)
        self.tips = _index_array("tips", self.tips, (None,), 0, n - 1)
        if not isinstance(self.grafts, list):
            raise ValueError(f"grafts must be a list, got {type(self.grafts).__name__}")

    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return int(self.pos.shape[0])

    def depth_to_root(self) -> np.ndarray:
        """Number of edges from every node to the root; raises ValueError on a cycle or a dangling node."""
        n = self.n_nodes
        depth = np.full(n, -1, np.int64)
        depth[self.parent < 0] = 0
        for start in range(n):
            path = []
            v = start
            while depth[v] < 0:
                path.append(v)
                v = self.parent[v]
                if len(path) > n:
                    raise ValueError("branch structure has a cycle")
            d = depth[v]
            for u in reversed(path):
                d += 1
                depth[u] = d
        return depth


#: Largest node coordinate magnitude of a BranchTree (scene units): trees are built from florets inside
#: MAX_COORD and may be scaled up, but never to values whose differences overflow.
_MAX_TREE_COORD = 1e9


def _index_array(name: str, value, shape: tuple, low: int, high: int) -> np.ndarray:
    """An int64 array of ``shape`` with entries in [low, high]; NaN, inf, fractions, huge values refused."""
    try:
        arr = np.asarray(value)
        if arr.dtype.kind not in "iub":
            f = np.asarray(arr, dtype=np.float64)
            if f.size and (not np.all(np.isfinite(f)) or np.any(f != np.round(f))
                           or np.abs(f).max() > 2.0 ** 62):
                raise ValueError
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be an integer array with entries in [{low}, {high}]") from None
    arr = check_array(name, arr, shape=shape, dtype=np.int64)
    if arr.size and (arr.min() < low or arr.max() > high):
        raise ValueError(f"{name} must hold entries in [{low}, {high}], got values in "
                         f"[{arr.min()}, {arr.max()}]")
    return arr


def linear_wb(radius: float, w_max: float = 1.0) -> Callable[[float], float]:
    """w_b(d) = w_max (1 - d / radius) for d < radius, else 0 (a simple graphical function, Fig. 7.4)."""
    radius = check_range("radius", radius, 0.0, 1e12, low_open=True)
    w_max = check_range("w_max", w_max, 0.0, 1e12)
    return lambda d: w_max * max(0.0, 1.0 - d / radius)


def _nearest_foreign(cells: CellLists, p, pos, bid, own, radius) -> tuple[int, float]:
    """The nearest node of another tree within ``radius`` of ``p`` (Fig. 7.5a: the own tree is ignored) and its
    distance; ``(-1, radius)`` if none. ``cells`` has cell size ``radius``, so its 27 cells hold every candidate."""
    cand = [i for i in cells.near(p) if bid[i] != own]
    if not cand:
        return -1, radius
    d = np.sqrt(((np.array([pos[i] for i in cand]) - p) ** 2).sum(axis=1))
    k = int(np.argmin(d))                       # the first of equal minima, as a strict-< scan keeps
    return (cand[k], float(d[k])) if d[k] < radius else (-1, radius)


def rodkaew(florets: np.ndarray, base, *, emergence: np.ndarray | None = None, w_a: float = 1.0,
            w_h: float = 1.0, w_b: Callable[[float], float] | None = None, delta: float = 0.01,
            merge_dist: float | None = None, search_radius: float | None = None, merge: bool = True,
            initial_direction: str = "down", max_steps: int = 100_000) -> BranchTree:
    """Grow a branching structure from floret positions to the base (extended Rodkaew, spec 002 §5.3).

    Parameters
    ----------
    florets : (K, 3) float64 array_like
        Floret (tip) positions.
    base : (3,) float64 array_like
        Inflorescence base A0.
    emergence : (K,) float64 array_like, optional
        Emergence step of each floret's particle (default all 0).
    w_a, w_h : float
        Weights of the base attraction A and the previous direction H in Eq. 7.1.
    w_b : callable d -> weight, optional
        Attraction to the nearest foreign node as a function of its distance (default ``linear_wb(8 delta)``).
    delta : float
        Step length [INFERRED].
    merge_dist, search_radius : float, optional
        Grafting distance (default 1.2 delta) and nearest-neighbour range (default 8 delta) [INFERRED].
    merge : bool
        Graft onto foreign nodes; ``False`` with ``w_b = 0`` gives the umbel limit of Fig. 7.3a.
    initial_direction : {"down", "base"}
        H of a new particle: -z (the canopy normal reversed) or toward the base.

    Returns
    -------
    BranchTree

    References
    ----------
    .. [1] Owens 2016, §7.2, Eq. 7.1, Figs. 7.2–7.5; spec 002 §5.3 (live IDs, pitfall 1; umbel limit, pitfall 2).
    """
    F = check_array("florets", florets, shape=(None, 3), min_rows=1, max_abs=MAX_COORD)
    A0 = check_point("base", base)
    K = check_int("florets count", F.shape[0], 1, 1_000_000)
    max_steps = check_int("max_steps", max_steps, 1, 100_000_000)
    tau = np.zeros(K) if emergence is None else check_array("emergence", emergence, shape=(K,))
    if tau.size and (tau.min() < -1e12 or tau.max() > max_steps):
        raise ValueError(f"emergence must be in [-1e12, max_steps={max_steps}], got values in "
                         f"[{tau.min()!r}, {tau.max()!r}]")
    w_a = check_range("w_a", w_a, 0.0, 1e12)
    w_h = check_range("w_h", w_h, 0.0, 1e12)
    delta = check_range("delta", delta, 0.0, 1e11, low_open=True)      # 8 delta is a valid search radius
    merge_dist = 1.2 * delta if merge_dist is None else check_range("merge_dist", merge_dist, 0.0, 1e12)
    search_radius = 8 * delta if search_radius is None else check_range("search_radius", search_radius, 0.0,
                                                                         1e12, low_open=True)
    if initial_direction not in ("down", "base"):
        raise ValueError(f"initial_direction must be one of ['down', 'base'], got {initial_direction!r}")
    # some particle must walk to the base (every tree ends there), one delta per step: refuse what cannot
    # finish within max_steps at the door instead of after max_steps slow steps
    reach = (float(np.min(np.linalg.norm(F - A0, axis=1))) - delta) / delta
    if reach > max_steps + float(tau.max() if tau.size else 0.0):
        raise ValueError(f"delta={delta!r} is too small: the nearest floret is {reach:.3g} steps from the "
                         "base, "
                         f"more than max_steps={max_steps}")
    if w_b is not None and not callable(w_b):
        raise ValueError(f"w_b must be a callable d -> weight or None, got {type(w_b).__name__}")
    wb = linear_wb(search_radius) if w_b is None else w_b
    if w_a + w_h == 0:
        raise ValueError("w_a + w_h must be > 0 so that every particle has a direction")

    pos = [A0.copy()]
    parent = [-1]
    bid = [0]                                   # the base's ID_branch is 0
    members: dict[int, list[int]] = {0: [0]}
    grid = CellLists(search_radius)
    grid.add(0, A0)
    tips = np.full(K, -1, np.int64)
    grafts = []
    particles: list[list] = []                  # [node, H, active]
    order = np.argsort(tau, kind="stable")
    nxt = 0
    step = 0
    while True:
        while nxt < K and tau[order[nxt]] <= step:
            k = order[nxt]
            nxt += 1
            i = len(pos)
            pos.append(F[k].copy())
            parent.append(-1)
            bid.append(i)                        # unique ID_branch per particle-tree pair
            members[i] = [i]
            grid.add(i, F[k])
            tips[k] = i
            H = np.array([0.0, 0.0, -1.0]) if initial_direction == "down" else A0 - F[k]
            H = H / (np.linalg.norm(H) or 1.0)
            particles.append([i, H, True])
        active = [P for P in particles if P[2]]
        if not active and nxt >= K:
            break
        if step >= max_steps:
            raise ValueError(f"particles did not reach the base within max_steps={max_steps}")
        for P in active:
            node = P[0]
            p = pos[node]
            own = bid[node]                                       # read live (pitfall 1)
            A = A0 - p
            dA = float(np.linalg.norm(A))
            if dA < delta:                                        # at the base
                parent[node] = 0
                _relabel(members, bid, own, 0, grafts, node, 0)
                P[2] = False
                continue
            A /= dA
            N, d = _nearest_foreign(grid, p, pos, bid, own, search_radius)
            wbv = _weight(wb, d) if N >= 0 else 0.0
            B = (pos[N] - p) / d if N >= 0 and d > 0 else np.zeros(3)
            Hn = (w_a * A + wbv * B + w_h * P[1]) / (w_a + wbv + w_h)          # Eq. 7.1
            nh = float(np.linalg.norm(Hn))
            Hn = A if nh < 1e-15 else Hn / nh
            q = p + delta * Hn
            if merge and N >= 0 and np.linalg.norm(pos[N] - q) < merge_dist:
                parent[node] = N                                  # graft onto the foreign tree
                _relabel(members, bid, own, bid[N], grafts, node, N)
                P[2] = False
                continue
            if np.linalg.norm(A0 - q) < delta:
                parent[node] = 0
                _relabel(members, bid, own, 0, grafts, node, 0)
                P[2] = False
                continue
            m = len(pos)
            pos.append(q)
            parent.append(-1)
            bid.append(own)
            members[own].append(m)
            grid.add(m, q)
            parent[node] = m
            P[0] = m
            P[1] = Hn
        step += 1
    return BranchTree(np.array(pos), np.array(parent, np.int64), np.array(bid, np.int64), tips, grafts)


def _weight(wb, d: float) -> float:
    try:
        v = float(wb(d))
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"w_b({d!r}) must return a number: {exc}") from None
    if not (np.isfinite(v) and 0.0 <= v <= 1e12):
        raise ValueError(f"w_b({d!r}) must return a finite weight in [0, 1e12], got {v!r}")
    return v


def _relabel(members, bid, old, new, grafts, child, host):
    if old != new:
        moved = members.pop(old)
        for v in moved:
            bid[v] = new
        members[new].extend(moved)
    grafts.append((child, host, new, old))


def pipe_widths(tree: BranchTree, *, tip_diameter: float = 1.0, p: float = 2.5) -> np.ndarray:
    """Diameters by the pipe model: tips d0, d^p = sum of children's d^p (spec 002 §5.2 item 9, V40).

    Returns
    -------
    (N,) float64 ndarray
        Diameter of the segment from each node to its parent.
    """
    _check_tree(tree)
    tip_diameter = check_range("tip_diameter", tip_diameter, 0.0, 1e12, low_open=True)
    p = check_range("p", p, 1.0, 100.0)
    depth = tree.depth_to_root()
    acc = np.zeros(tree.n_nodes)
    acc[tree.tips] = tip_diameter ** p
    for v in np.argsort(-depth, kind="stable"):               # deepest first: children before parents
        if tree.parent[v] >= 0:
            acc[tree.parent[v]] += acc[v]
    return acc ** (1.0 / p)


def scale_tree(tree: BranchTree, scale, *, about=None) -> BranchTree:
    """Free-form deformation by axis scaling about a point (uniform or allometric growth, spec §5.2 item 7)."""
    _check_tree(tree)
    try:
        s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"scale must be a number or 3 numbers, got {scale!r:.80}") from None
    if np.any(~np.isfinite(s)) or np.any(s <= 0) or np.any(s > 1e6):
        raise ValueError(f"scale must be finite and in (0, 1e6], got {s.tolist()}")
    c = tree.pos[0] if about is None else check_point("about", about)
    new = c + (tree.pos - c) * s
    if np.abs(new).max() > _MAX_TREE_COORD:
        raise ValueError(f"scale {s.tolist()} moves nodes beyond ±{_MAX_TREE_COORD:g}")
    return BranchTree(new, tree.parent.copy(), tree.branch_id.copy(), tree.tips.copy(),
                      list(tree.grafts))


def tube_mesh(tree: BranchTree, diameters: np.ndarray, *, sides: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Open tube (prism) per segment, radius = diameter / 2 (spec 002 §5.2 item 9, C25).

    Returns
    -------
    vertices : (2 S sides, 3) float64 ndarray
    faces : (2 S sides, 3) int64 ndarray
    """
    _check_tree(tree)
    sides = check_int("sides", sides, 3, 64)
    d = check_array("diameters", diameters, shape=(tree.n_nodes,), max_abs=_MAX_TREE_COORD)
    if d.size and d.min() < 0:
        raise ValueError(f"diameters must be >= 0, got {d.min()!r}")
    child = np.flatnonzero(tree.parent >= 0)
    a, b = tree.pos[child], tree.pos[tree.parent[child]]
    axis = b - a
    ln = np.linalg.norm(axis, axis=1, keepdims=True)
    axis = axis / np.where(ln > 0, ln, 1)
    ref = np.where(np.abs(axis[:, 2:3]) < 0.9, [[0, 0, 1.0]], [[1.0, 0, 0]])
    u = np.cross(axis, ref)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = np.cross(axis, u)
    ang = 2 * np.pi * np.arange(sides) / sides
    ring = np.cos(ang)[None, :, None] * u[:, None] + np.sin(ang)[None, :, None] * w[:, None]   # (S, sides, 3)
    r = 0.5 * d[child][:, None, None]
    verts = np.concatenate([a[:, None] + r * ring, b[:, None] + r * ring], axis=1).reshape(-1, 3)
    base = (np.arange(len(child)) * 2 * sides)[:, None]
    j = np.arange(sides)[None]
    j1 = (j + 1) % sides
    f1 = np.stack([base + j, base + j1, base + sides + j1], axis=-1)
    f2 = np.stack([base + j, base + sides + j1, base + sides + j], axis=-1)
    return verts, np.concatenate([f1.reshape(-1, 3), f2.reshape(-1, 3)]).astype(np.int64)


def _check_tree(tree) -> None:
    if not isinstance(tree, BranchTree):
        raise ValueError(f"tree must be a BranchTree, got {type(tree).__name__}")


def _vogel(n, radius, offset=0.5):
    i = np.arange(n, dtype=np.float64)
    r = radius * np.sqrt((i + offset) / (n - 1 + offset)) if n > 1 else np.zeros(1)
    th = np.deg2rad(137.5 * i)
    return np.column_stack([r * np.cos(th), r * np.sin(th), np.zeros(n)])


def corymb(n_florets: int = 200, *, radius: float = 0.5, height: float = 1.0, emergence_interval: float = 0.5,
           **kwargs) -> BranchTree:
    """A corymb: florets on a flat canopy (Vogel pattern at z = height) branched to the base at the origin.

    Florets emerge centripetally (rim first) every ``emergence_interval`` steps; other keywords go to
    :func:`rodkaew` (defaults from the spec's prototype, §5.3 pitfall 3).
    """
    n_florets = check_int("n_florets", n_florets, 1, 1_000_000)
    radius = check_range("radius", radius, 0.0, 1e6, low_open=True)
    height = check_range("height", height, 0.0, 1e6, low_open=True)
    emergence_interval = check_range("emergence_interval", emergence_interval, 0.0, 1e6)
    max_steps = check_int("max_steps", kwargs.get("max_steps", 100_000), 1, 100_000_000)
    if (n_florets - 1) * emergence_interval > max_steps:
        raise ValueError(f"emergence_interval * (n_florets - 1) must be <= max_steps={max_steps}, got "
                         f"{(n_florets - 1) * emergence_interval!r}")
    F = _vogel(n_florets, radius)[::-1] + [0, 0, height]       # rim first
    tau = np.arange(n_florets) * emergence_interval
    return rodkaew(F, [0.0, 0.0, 0.0], emergence=tau, **kwargs)


def compound_umbel(n_umbellets: int = 8, florets_per_umbellet: int = 20, *, radius: float = 0.5,
                   umbellet_radius: float = 0.08, height: float = 1.0, umbellet_height: float = 0.15,
                   delta: float = 0.01) -> tuple[BranchTree, np.ndarray]:
    """A two-level compound umbel generated level by level and joined (Fig. 7.2b, C24).

    Level 1: each umbellet's florets (Vogel around its centre at z = height) to the umbellet base
    (``umbellet_height`` below). Level 2: the umbellet bases to the inflorescence base at the origin. Both levels
    use the umbel limit (w_b = 0, no merging), so every ray is straight.

    Returns
    -------
    tree : BranchTree
        The joined structure (node 0 = inflorescence base).
    level : (N,) int8 ndarray
        1 for umbellet nodes, 2 for main-umbel nodes (the base is level 2).
    """
    n_umbellets = check_int("n_umbellets", n_umbellets, 1, 100_000)
    florets_per_umbellet = check_int("florets_per_umbellet", florets_per_umbellet, 1, 100_000)
    if n_umbellets * florets_per_umbellet > 1_000_000:
        raise ValueError(f"n_umbellets * florets_per_umbellet must be <= 1000000, got "
                         f"{n_umbellets * florets_per_umbellet}")
    radius = check_range("radius", radius, 0.0, 1e6, low_open=True)
    umbellet_radius = check_range("umbellet_radius", umbellet_radius, 0.0, 1e6, low_open=True)
    height = check_range("height", height, -1e6, 1e6)
    umbellet_height = check_range("umbellet_height", umbellet_height, -1e6, 1e6)
    delta = check_range("delta", delta, 0.0, 1e6, low_open=True)
    centres = _vogel(n_umbellets, radius) + [0, 0, height]
    bases = centres - [0, 0, umbellet_height]
    kw = {"w_b": (lambda d: 0.0), "merge": False, "w_h": 0.0, "delta": delta}
    main = rodkaew(bases, [0.0, 0.0, 0.0], initial_direction="base", **kw)
    pos, parent, bid = [main.pos], [main.parent], [main.branch_id]
    level = [np.full(main.n_nodes, 2, np.int8)]
    tips, off = [], main.n_nodes
    for j in range(n_umbellets):
        F = _vogel(florets_per_umbellet, umbellet_radius) + centres[j]
        sub = rodkaew(F, bases[j], initial_direction="base", **kw)
        # node 0 of the umbellet is its base: identify it with the main level's tip for umbellet j
        par = np.where(sub.parent > 0, sub.parent + off - 1, -1)
        par[sub.parent == 0] = main.tips[j]
        pos.append(sub.pos[1:])
        parent.append(par[1:])
        bid.append(np.zeros(sub.n_nodes - 1, np.int64))
        level.append(np.full(sub.n_nodes - 1, 1, np.int8))
        tips.append(sub.tips + off - 1)
        off += sub.n_nodes - 1
    tree = BranchTree(np.concatenate(pos), np.concatenate(parent), np.concatenate(bid), np.concatenate(tips),
                      list(main.grafts))
    return tree, np.concatenate(level)

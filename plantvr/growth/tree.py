"""Tree data structure: struct-of-arrays nodes with 2- or 3-way branching (spec 000_treewand §1).

Slot 0 of ``child`` is the main child, slots 1–2 are laterals; ``BUD`` marks a bud (the thesis's null
pointer), ``NO_SLOT`` an absent slot (slot 2 of a two-way node, slots 1–2 of the root). Nodes are only
appended, so a child's index is always larger than its parent's: folds run over indices backwards and
unfolds forwards. Node 0 is the base point, node 1 the tip of the first internode.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .._validation import MAX_COORD

__all__ = ["Tree", "BUD", "NO_SLOT", "MAX_NODES", "check_tree_arrays"]

BUD = -1
NO_SLOT = -2

#: Most nodes a tree read from a file may have (about 0.9 GB of arrays); far beyond any grown tree.
MAX_NODES = 4_000_000

_FIELDS = {  # name: (trailing shape, dtype)
    "pos": ((3,), np.float64), "head": ((3,), np.float64), "lat": ((3,), np.float64),
    "parent": ((), np.int64), "child": ((3,), np.int64), "order": ((), np.int64),
    "alive": ((), np.bool_), "radius": ((), np.float64), "vigor": ((), np.float64),
    "Q": ((), np.float64), "Qw": ((), np.float64), "Qslot": ((3,), np.float64),
    "L": ((), np.float64), "bud_vigor": ((3,), np.float64), "shadow_cast": ((), np.bool_),
    "born": ((), np.int64), "light_factor": ((), np.float64),
}


class Tree:
    """Growing tree stored as arrays of capacity ``len(self.pos_all)``; the first ``n`` rows are in use.

    Attributes ``pos``, ``parent``, ... are views of the rows in use (dead rows included; see ``alive``).
    """

    def __init__(self, nslots: int = 2, capacity: int = 64):
        if nslots not in (2, 3):
            raise ValueError(f"nslots must be 2 (alternate) or 3 (opposite), got {nslots!r}")
        self.nslots = nslots
        self.n = 0
        self.epoch = 0  # bumped when rows move (compact): caches keyed by row index start over
        self._data = {k: np.zeros((capacity, *shape), dtype) for k, (shape, dtype) in _FIELDS.items()}

    def __getattr__(self, name):
        data = self.__dict__.get("_data")
        if data is not None and name in data:
            return data[name][: self.n]
        raise AttributeError(name)

    # -- construction -------------------------------------------------------------------------------
    @classmethod
    def seed(cls, base_length: float = 1.0, nslots: int = 2) -> "Tree":
        """Return the start state: a base point and one vertical internode with its buds (§2.1, item 4)."""
        t = cls(nslots)
        root = t.append(np.zeros(3), parent=-1, head=np.array([0.0, 1.0, 0.0]), lat=np.array([1.0, 0.0, 0.0]),
                        order=0)
        t._data["child"][root, 1:] = NO_SLOT
        first = t.append(np.array([0.0, base_length, 0.0]), parent=root, head=np.array([0.0, 1.0, 0.0]),
                         lat=np.array([1.0, 0.0, 0.0]), order=0)
        t._data["child"][root, 0] = first
        return t

    def _reserve(self, extra: int) -> None:
        cap = len(self._data["pos"])
        if self.n + extra <= cap:
            return
        new = max(2 * cap, self.n + extra)
        for k, arr in self._data.items():
            grown = np.zeros((new, *arr.shape[1:]), arr.dtype)
            grown[: self.n] = arr[: self.n]
            self._data[k] = grown

    def append(self, pos, *, parent: int, head, lat, order: int, born: int = 0) -> int:
        """Append one node (its slots are buds) and return its index."""
        self._reserve(1)
        i = self.n
        d = self._data
        d["pos"][i], d["head"][i], d["lat"][i] = pos, head, lat
        d["parent"][i], d["order"][i], d["alive"][i], d["born"][i] = parent, order, True, born
        d["child"][i] = (BUD, BUD, BUD if self.nslots == 3 else NO_SLOT)
        d["light_factor"][i] = 1.0
        self.n += 1
        return i

    def append_many(self, pos, parent, head, lat, order, born: int = 0) -> np.ndarray:
        """Vectorised :meth:`append`; ``parent`` indices must already exist. Returns the new indices."""
        k = len(pos)
        self._reserve(k)
        idx = np.arange(self.n, self.n + k)
        d = self._data
        d["pos"][idx], d["head"][idx], d["lat"][idx] = pos, head, lat
        d["parent"][idx], d["order"][idx], d["alive"][idx], d["born"][idx] = parent, order, True, born
        d["child"][idx] = (BUD, BUD, BUD if self.nslots == 3 else NO_SLOT)
        for f in ("radius", "vigor", "Q", "Qw", "L"):
            d[f][idx] = 0.0
        d["Qslot"][idx] = 0.0
        d["bud_vigor"][idx] = 0.0
        d["shadow_cast"][idx] = False
        d["light_factor"][idx] = 1.0
        self.n += k
        return idx

    # -- topology edits -----------------------------------------------------------------------------
    def subtree_mask(self, roots) -> np.ndarray:
        """Return a (n,) mask of the live nodes in the subtrees rooted at ``roots`` (one forward pass)."""
        mask = np.zeros(self.n, bool)
        roots = np.atleast_1d(np.asarray(roots, np.int64))
        if roots.size == 0:
            return mask
        mask[roots] = True
        lo = int(roots.min())
        par = self.parent
        for i in range(lo + 1, self.n):  # parent < child: one pass suffices
            if not mask[i] and par[i] >= 0 and mask[par[i]]:
                mask[i] = True
        return mask & self.alive

    def remove(self, mask: np.ndarray) -> np.ndarray:
        """Kill the nodes in ``mask`` (closed under descendants); their parents' slots become buds.

        Returns the indices removed.
        """
        gone = np.flatnonzero(mask & self.alive)
        if gone.size == 0:
            return gone
        d = self._data
        d["alive"][gone] = False
        ch = d["child"][: self.n]
        hit = (ch >= 0) & np.isin(ch, gone)
        ch[hit] = BUD  # §1.1: a freed slot becomes a bud again
        return gone

    def compact(self) -> np.ndarray:
        """Drop dead rows keeping index order (so parent < child still holds); return old→new map (-1 = dead)."""
        keep = np.flatnonzero(self.alive)
        self.epoch = getattr(self, "epoch", 0) + 1
        remap = np.full(self.n, -1, np.int64)
        remap[keep] = np.arange(len(keep))
        for k, arr in self._data.items():
            arr[: len(keep)] = arr[keep]
        self.n = len(keep)
        d = self._data
        par = d["parent"][: self.n]
        par[par >= 0] = remap[par[par >= 0]]
        ch = d["child"][: self.n]
        ch[ch >= 0] = remap[ch[ch >= 0]]
        return remap

    # -- derived ------------------------------------------------------------------------------------
    @property
    def n_internodes(self) -> int:
        """Number of live internodes (live nodes except the base point)."""
        return int(self.alive[1:].sum())

    def preorder(self) -> np.ndarray:
        """Live node indices in depth-first preorder, slots in index order (the ``.tree`` file order)."""
        out, stack = [], [0]
        ch, alive = self.child, self.alive
        while stack:
            n = stack.pop()
            out.append(n)
            stack.extend(int(c) for c in ch[n, ::-1] if c >= 0 and alive[c])
        return np.array(out, np.int64)

    def check(self, what: str = "tree") -> "Tree":
        """Raise ``ValueError`` unless the rows in use form a tree the kernels can run on; returns ``self``.

        See :func:`check_tree_arrays` (the one validation of tree arrays, used by every reader).
        """
        check_tree_arrays({k: v[: self.n] for k, v in self._data.items()}, self.nslots, what=what)
        return self

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray], nslots: int, *, what: str = "tree") -> "Tree":
        """Return a tree holding copies of ``arrays`` (one per field, as :meth:`arrays` returns them), after
        :func:`check_tree_arrays`; raises ``ValueError`` naming ``what`` and the bad field."""
        check_tree_arrays(arrays, nslots, what=what)
        n = len(arrays["pos"])
        t = cls(nslots, n)
        for k in _FIELDS:
            t._data[k][:n] = arrays[k]
        t.n = n
        return t

    def copy(self) -> "Tree":
        """Return a deep copy trimmed to the rows in use."""
        t = Tree(self.nslots, max(self.n, 1))
        for k, arr in self._data.items():
            t._data[k][: self.n] = arr[: self.n]
        t.n = self.n
        return t

    def arrays(self) -> dict[str, np.ndarray]:
        """Return copies of every field, trimmed to the rows in use."""
        return {k: v[: self.n].copy() for k, v in self._data.items()}


def check_tree_arrays(arrays: Mapping[str, np.ndarray], nslots: int, *, what: str = "tree") -> None:
    """Raise ``ValueError`` unless ``arrays`` describe a tree every kernel can index safely.

    Checked, before anything is written anywhere (issue 20: a child index of 10**9, a node at 1e19 or a NaN
    position crashed the kernels): exactly the fields of :class:`Tree`, each of shape ``(n, *trailing)`` and
    its exact dtype, ``2 <= n <=`` :data:`MAX_NODES`; every float finite; positions inside ±``MAX_COORD``;
    headings and lateral vectors of unit length; ``light_factor`` in [0, MAX_COORD]; ``order`` in [0, n],
    ``born`` >= 0; node 0 is the live base point (parent -1) and node 1 its live main child; every other
    parent index is smaller than its node's; every child slot holds ``BUD``, ``NO_SLOT`` (always in the slots
    past ``nslots``) or a larger node index whose parent is that node, each node in at most one slot, and
    every live node but the base sits in a slot of its live parent.

    Parameters
    ----------
    arrays : mapping of str to ndarray
        One array per field (``pos``, ``parent``, ``child``, ...).
    nslots : {2, 3}
        Slots per node: 2 alternate, 3 opposite branching.
    what : str
        Names the source in messages (e.g. the file).
    """
    def fail(msg: str):
        raise ValueError(f"{what}: {msg}")

    if isinstance(nslots, (bool, np.bool_)) or nslots not in (2, 3):
        fail(f"nslots must be 2 (alternate) or 3 (opposite), got {nslots!r}")
    if not isinstance(arrays, Mapping):
        fail(f"tree arrays must be a mapping of field names to arrays, got {type(arrays).__name__}")
    missing, extra = sorted(set(_FIELDS) - set(arrays)), sorted(set(arrays) - set(_FIELDS))
    if missing or extra:
        fail(f"tree fields must be exactly {sorted(_FIELDS)}; missing {missing}, unknown {extra[:5]}")
    pos = arrays["pos"]
    if not isinstance(pos, np.ndarray) or pos.ndim != 2:
        fail(f"field 'pos' must be an array of shape (n, 3), got {getattr(pos, 'shape', type(pos).__name__)}")
    n = len(pos)
    if not 2 <= n <= MAX_NODES:
        fail(f"a tree must have between 2 and {MAX_NODES} nodes, got {n}")
    for k, (trail, dtype) in _FIELDS.items():
        a = arrays[k]
        if not isinstance(a, np.ndarray) or a.shape != (n, *trail):
            fail(f"field {k!r} must have shape {(n, *trail)}, got {getattr(a, 'shape', type(a).__name__)}")
        if a.dtype != np.dtype(dtype):
            fail(f"field {k!r} must have dtype {np.dtype(dtype)}, got {a.dtype}")
        if a.dtype.kind == "f" and not np.isfinite(a).all():
            fail(f"field {k!r} must contain only finite values (no NaN or inf)")
    for k in ("pos", "head", "lat"):
        mag = float(np.abs(arrays[k]).max())
        if mag > MAX_COORD:
            fail(f"field {k!r} values must lie in [-{MAX_COORD:g}, {MAX_COORD:g}], got magnitude {mag:g}")
    for k in ("head", "lat"):
        dev = float(np.abs(np.linalg.norm(arrays[k], axis=1) - 1.0).max())
        if dev > 1e-6:
            fail(f"field {k!r} must hold unit vectors (|norm - 1| <= 1e-6), got a deviation of {dev:g}")
    lf = arrays["light_factor"]
    if lf.min() < 0 or lf.max() > MAX_COORD:
        fail(f"field 'light_factor' must lie in [0, {MAX_COORD:g}], got [{lf.min():g}, {lf.max():g}]")
    order, born = arrays["order"], arrays["born"]
    if order.min() < 0 or order.max() > n:
        fail(f"field 'order' must lie in [0, {n}], got [{order.min()}, {order.max()}]")
    if born.min() < 0:
        fail(f"field 'born' must be >= 0, got {born.min()}")
    alive, parent, child = arrays["alive"], arrays["parent"], arrays["child"]
    if not (alive[0] and alive[1]):
        fail("the base point (node 0) and the first internode (node 1) must be alive")
    if parent[0] != -1:
        fail(f"tree_parent[0] (the base point) must be -1, got {parent[0]}")
    idx = np.arange(n)
    bad = np.flatnonzero((parent[1:] < 0) | (parent[1:] >= idx[1:])) + 1
    if bad.size:
        i = int(bad[0])
        fail(f"parent[{i}] must be in [0, {i - 1}] (a parent comes before its child), got {parent[i]}")
    ok = (child == BUD) | (child == NO_SLOT) | ((child > idx[:, None]) & (child < n))
    if not ok.all():
        i, s = map(int, np.argwhere(~ok)[0])
        fail(f"child[{i}, {s}] must be {BUD} (bud), {NO_SLOT} (no slot) or a node index in [{i + 1}, {n - 1}], "
             f"got {child[i, s]}")
    if nslots == 2 and np.any(child[:, 2] != NO_SLOT):
        i = int(np.flatnonzero(child[:, 2] != NO_SLOT)[0])
        fail(f"child[{i}, 2] must be {NO_SLOT} (no slot) in a two-way (alternate) tree, got {child[i, 2]}")
    if child[0, 0] != 1:
        fail(f"child[0, 0] must be 1 (the first internode), got {child[0, 0]}")
    src, slot = np.nonzero(child >= 0)
    dst = child[src, slot]
    if np.any(parent[dst] != src):
        j = int(np.flatnonzero(parent[dst] != src)[0])
        fail(f"child[{src[j]}, {slot[j]}] = {dst[j]} but parent[{dst[j]}] = {parent[dst[j]]}")
    refs = np.bincount(dst, minlength=n)
    if refs.max(initial=0) > 1:
        fail(f"node {int(np.argmax(refs))} sits in more than one child slot")
    if np.any(alive[src] & ~alive[dst]):
        j = int(np.flatnonzero(alive[src] & ~alive[dst])[0])
        fail(f"child[{src[j]}, {slot[j]}] of a live node points at the dead node {dst[j]}")
    orphan = np.flatnonzero(alive[1:] & ((refs[1:] == 0) | ~alive[parent[1:]])) + 1
    if orphan.size:
        fail(f"live node {int(orphan[0])} is not in a child slot of its live parent {parent[orphan[0]]}")

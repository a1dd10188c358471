"""Tree data structure: struct-of-arrays nodes with 2- or 3-way branching (spec 000_treewand §1).

Slot 0 of ``child`` is the main child, slots 1–2 are laterals; ``BUD`` marks a bud (the thesis's null
pointer), ``NO_SLOT`` an absent slot (slot 2 of a two-way node, slots 1–2 of the root). Nodes are only
appended, so a child's index is always larger than its parent's: folds run over indices backwards and
unfolds forwards. Node 0 is the base point, node 1 the tip of the first internode.
"""
from __future__ import annotations

import numpy as np

__all__ = ["Tree", "BUD", "NO_SLOT"]

BUD = -1
NO_SLOT = -2

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

"""L-Py's ``NodeModule`` (issue 33): the module a ``$A(a)`` pattern binds, with the axial tree around it.

A rule ``$A(a) : ...`` matches a module of class ``A`` (or, with the ``Module inheritance`` option, of a class
derived from it) whatever its parameters, and binds ``a`` to a copy of it: its ``name``, its parameters
(``a[0]``, ``len(a)``, and by the names of its declaration, ``module A(age)`` giving ``a.age``) and the tree
around it, read as L-Py's ``axialtree_manip.h`` reads it (brackets and the rule's ignored modules skipped):
``parent()``, ``children()`` (lateral ones first, then the direct child), ``lateral_children()``,
``direct_child()``, ``complex(scale)``, ``components()``, ``components_at_scale(scale)``, ``position()``,
``isRoot()``, ``isValid()`` and the deprecated ``father``/``sons``/``lateralSons``/``directSon``. A successor's
``$a`` puts the module (with what the rule changed in it) into the new string. As in L-Py, ``parent``,
``direct_child`` and ``complex`` give None where there is none, and ``children``-like calls None for no node.
"""
from __future__ import annotations

import sys
from collections import deque

import numpy as np

from . import sandbox as SB
from ._derive_kernels import match_brackets
from .lexer import LSystemError
from .modules import _module_vals, module_text

__all__ = ["FINEST", "NodeModule"]

#: The scale of a module declared without one, and of brackets (L-Py's ``ModuleClass::DEFAULT_SCALE``, INT_MAX).
FINEST = 2**31 - 1


class _Tree:
    """The string a node lives in: its arrays, symbol table, scales by id, ignored names and declared parameter
    names (the partner of each bracket found once, when a walk first needs it)."""

    def __init__(self, ids, ptr, args, objs, names, scales: dict, ignored, param_names: dict) -> None:
        self.ids, self.ptr, self.args, self.objs = ids, ptr, args, objs
        self.names, self.scales, self.param_names = names, scales, param_names
        self.ignored = ignored
        self._partner = None

    @property
    def partner(self) -> np.ndarray:
        if self._partner is None:
            self._partner = match_brackets(self.ids, 0, 1)
        return self._partner

    def ign(self, p: int) -> bool:
        s = int(self.ids[p])
        if self.ignored is None or s < 2:
            return False
        names, ignore = self.ignored
        return (self.names[s] in names) == ignore

    def scale(self, p: int) -> int:
        return self.scales.get(int(self.ids[p]), FINEST)

    # -- axialtree_manip.h, with -1 for string_end ---------------------------------------------------------------
    def parent(self, p: int) -> int:
        ids = self.ids
        if p <= 0:
            return -1
        p -= 1
        while p > 0 and (ids[p] < 2 or self.ign(p)):
            while p > 0 and (ids[p] == 0 or self.ign(p)):
                p -= 1
            while p > 0 and ids[p] == 1:
                p = int(self.partner[p])                      # beginBracket
                if p <= 0:
                    return -1
                p -= 1
        return -1 if ids[p] < 2 or self.ign(p) else p

    def children(self, p: int, direct: bool = True) -> list[int]:
        ids, n, out = self.ids, len(self.ids), []
        if p < 0 or ids[p] == 1:
            return out
        p += 1
        if p >= n or ids[p] == 1:
            return out
        while p < n and (ids[p] == 0 or self.ign(p)):
            while p < n and ids[p] >= 2 and self.ign(p):
                p += 1
            while p < n and ids[p] == 0:
                out += self.children(p)
                p = int(self.partner[p])                      # endBracket
                if p < 0:
                    return out
                p += 1
        if direct and p < n and ids[p] != 1:
            out.append(p)
        return out

    def direct_child(self, p: int) -> int:
        ids, n = self.ids, len(self.ids)
        if p < 0 or ids[p] == 1:
            return -1
        p += 1
        while p < n and (ids[p] == 0 or self.ign(p)):
            while p < n and ids[p] != 0 and self.ign(p):
                p += 1
            while p < n and ids[p] == 0:
                p = int(self.partner[p])
                if p < 0:
                    return -1
                p += 1
        return -1 if p >= n or ids[p] == 1 else p

    def complex(self, p: int, scale: int) -> int:
        """As L-Py's ``complex``: from a module of a scale below ``scale``, the first parent at ``scale``."""
        if p <= 0 or not self.scale(p) < scale:
            return -1
        p = self.parent(p)
        while p >= 0 and self.scale(p) < scale:
            p = self.parent(p)
        return p if p >= 0 and self.scale(p) == scale else -1

    def components(self, p: int, scale: int | None = None) -> list[int]:
        """The modules of a finer scale (larger number) reached from ``p`` through such modules, breadth first;
        only those at ``scale`` if given (``components_at_scale``)."""
        if p < 0 or self.ids[p] == 1:
            return []
        cur, out = self.scale(p), []
        todo = deque(self.children(p))
        while todo:
            c = todo.popleft()
            s = self.scale(c)
            if s > cur:
                if scale is None or s == scale:
                    out.append(c)
                todo.extend(self.children(c))
        return out


class NodeModule(SB.SafeAttrs):
    """A module of the string bound by a ``$A(a)`` pattern (the module docstring)."""

    __slots__ = ("_tree", "_pos", "name", "_vals")

    def __init__(self, tree: _Tree, pos: int) -> None:
        object.__setattr__(self, "_tree", tree)
        object.__setattr__(self, "_pos", pos)
        object.__setattr__(self, "name", tree.names[int(tree.ids[pos])])
        object.__setattr__(self, "_vals", _module_vals(tree.ptr, tree.args, tree.objs, pos))

    # -- the module's parameters (L-Py's ParamModule) -----------------------------------------------------------
    def __len__(self) -> int:
        return len(self._vals)

    def __getitem__(self, k):
        return self._vals[k]

    def __setitem__(self, k, value) -> None:
        self._vals[k] = value

    @property
    def args(self) -> list:
        return list(self._vals)

    def _named(self, attr: str) -> int:
        """The position of parameter ``attr``: the declared names are the last values (L-Py's
        ``ParamModule::getParameterPosition``)."""
        names = self._tree.param_names.get(self.name, ())
        at = max(0, len(self._vals) - len(names)) + names.index(attr) if attr in names else len(self._vals)
        if at < len(self._vals):
            return at
        raise AttributeError(f"module {self.name} has no parameter {attr!r} (declared: {', '.join(names) or 'none'})")

    def __getattr__(self, attr: str):
        if attr.startswith("_"):
            raise AttributeError(attr)
        return self._vals[self._named(attr)]

    def __setattr__(self, attr: str, value) -> None:
        self._vals[self._named(attr)] = value

    def __str__(self) -> str:
        return module_text(self.name, self._vals)

    __repr__ = __str__

    # -- the tree around it ------------------------------------------------------------------------------------
    def _node(self, p: int) -> NodeModule | None:
        return None if p < 0 else NodeModule(self._tree, p)

    def _nodes(self, ps: list[int]) -> list[NodeModule] | None:
        return [NodeModule(self._tree, p) for p in ps] or None

    def _walk(self, fn, *a):
        try:
            return fn(self._pos, *a)
        except RecursionError:
            raise LSystemError(f"the string's branches are nested too deeply to walk (more than "
                               f"{sys.getrecursionlimit()} levels)") from None

    def position(self) -> int:
        return self._pos

    def isRoot(self) -> bool:
        return self._pos == 0

    def isValid(self) -> bool:
        return 0 <= self._pos < len(self._tree.ids)

    def parent(self) -> NodeModule | None:
        return self._node(self._walk(self._tree.parent))

    def children(self) -> list[NodeModule] | None:
        return self._nodes(self._walk(self._tree.children))

    def lateral_children(self) -> list[NodeModule] | None:
        return self._nodes(self._walk(self._tree.children, False))

    def direct_child(self) -> NodeModule | None:
        return self._node(self._walk(self._tree.direct_child))

    def complex(self, scale: int | None = None) -> NodeModule | None:
        """``complex()`` is ``complex(scale + 1)``, as L-Py's ``NodeModule::complex``."""
        s = self._tree.scale(self._pos) + 1 if scale is None else _int(scale, "scale")
        return self._node(self._walk(self._tree.complex, s))

    def components(self) -> list[NodeModule] | None:
        return self._nodes(self._walk(self._tree.components))

    def components_at_scale(self, scale) -> list[NodeModule] | None:
        return self._nodes(self._walk(self._tree.components, _int(scale, "scale")))

    father, sons, lateralSons, directSon = parent, children, lateral_children, direct_child


def _int(v, what: str) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise LSystemError(f"{what} must be an integer, got {v!r:.40}")
    return int(v)

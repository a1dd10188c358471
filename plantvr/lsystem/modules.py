"""A derived L-system string as arrays: module ids plus their parameters (CSR layout).

One :class:`ModuleString` is what the engine derives and what the turtle interprets; a million modules are a
few arrays, not a million Python objects.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

__all__ = ["ModuleString", "is_number"]

_EMPTY: Mapping[int, Any] = MappingProxyType({})


def is_number(v) -> bool:
    """Whether module parameter ``v`` is stored in the float64 ``args`` (int or float, numpy's included, not a
    bool: L-Py keeps ``True`` a bool)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


@dataclass(frozen=True, eq=False)
class ModuleString:
    """A string of parametric modules.

    Attributes
    ----------
    names : tuple of str
        The symbol table: module id ``k`` is named ``names[k]``.
    ids : (n,) int32 ndarray
        Module ids in string order.
    arg_ptr : (n + 1,) int64 ndarray
        Module ``i`` has parameters ``args[arg_ptr[i]:arg_ptr[i + 1]]``.
    args : (m,) float64 ndarray
        All parameters, module after module; a parameter that is not a number (a str, tuple, list, None,
        bool...) is NaN here and its value is in ``objects``.
    objects : mapping int -> object
        The side-table of non-number parameters (issue 33: L-Py modules hold any Python value), keyed by their
        index in ``args``; empty for numeric strings, which the numba paths derive.
    """

    names: tuple[str, ...]
    ids: np.ndarray
    arg_ptr: np.ndarray
    args: np.ndarray
    objects: Mapping[int, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        ids = np.asarray(self.ids)
        ptr = np.asarray(self.arg_ptr)
        args = np.asarray(self.args)
        n = ids.shape[0] if ids.ndim == 1 else -1
        if n < 0 or (ids.size and ids.dtype.kind not in "iu"):
            raise ValueError(f"ids must be a 1-d integer array, got {ids.dtype} {ids.shape}")
        if n and (ids.min() < 0 or ids.max() >= len(self.names)):
            raise ValueError(f"ids must lie in [0, {len(self.names)}) (the symbol table), got "
                             f"[{ids.min()}, {ids.max()}]")
        if ptr.shape != (n + 1,) or (ptr.size and ptr.dtype.kind not in "iu"):
            raise ValueError(f"arg_ptr must be an integer array of shape ({n + 1},), got {ptr.dtype} {ptr.shape}")
        if args.ndim != 1:
            raise ValueError(f"args must be a 1-d array, got shape {args.shape}")
        if ptr[0] != 0 or ptr[-1] != args.shape[0] or np.any(np.diff(ptr) < 0):
            raise ValueError(f"arg_ptr must rise from 0 to len(args) = {args.shape[0]}")
        for name, value, dtype in (("ids", ids, np.int32), ("arg_ptr", ptr, np.int64), ("args", args, np.float64)):
            value = np.ascontiguousarray(value, dtype)
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "names", tuple(str(s) for s in self.names))
        objs = dict(self.objects) if self.objects else {}
        m = self.args.shape[0]
        for k in objs:
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < m:
                raise ValueError(f"objects keys must be parameter indices in [0, {m}), got {k!r:.40}")
        if objs and not np.isnan(self.args[np.fromiter(objs, np.int64, len(objs))]).all():
            raise ValueError("args must be NaN where objects holds the parameter")
        object.__setattr__(self, "objects", MappingProxyType({int(k): v for k, v in objs.items()}))

    @classmethod
    def _trusted(cls, names: tuple[str, ...], ids: np.ndarray, arg_ptr: np.ndarray,
                 args: np.ndarray) -> ModuleString:
        """Wrap arrays the engine's kernels wrote, without the checks (private: the caller guarantees contiguous
        int32 ``ids`` in ``[0, len(names))``, int64 ``arg_ptr`` rising from 0 to ``len(args)``, float64 ``args``,
        ``names`` a tuple of str)."""
        self = object.__new__(cls)
        for name, value in (("ids", ids), ("arg_ptr", arg_ptr), ("args", args)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "objects", _EMPTY)
        return self

    @classmethod
    def from_modules(cls, modules: Iterable[tuple[str, Sequence[Any]] | str],
                     names: Sequence[str] = ()) -> "ModuleString":
        """Build from ``[("F", (1.0,)), "+", ("A", (2, 3)), ("@L", ("text",)), ...]`` (a bare name has no
        parameters; a parameter that is not an int or float goes to ``objects``); ``names`` fixes the first
        entries of the symbol table."""
        table = {s: i for i, s in enumerate(names)}
        ids, counts, args, objs = [], [], [], {}
        for m in modules:
            name, vals = (m, ()) if isinstance(m, str) else m
            ids.append(table.setdefault(name, len(table)))
            counts.append(len(vals))
            for v in vals:
                if is_number(v):
                    args.append(float(v))
                else:
                    objs[len(args)] = v
                    args.append(math.nan)
        ptr = np.zeros(len(ids) + 1, np.int64)
        np.cumsum(counts, out=ptr[1:])
        return cls(tuple(table), np.array(ids, np.int32), ptr, np.array(args, np.float64), objs)

    @classmethod
    def concat(cls, parts: Sequence["ModuleString"], names: Sequence[str]) -> "ModuleString":
        """The strings of ``parts`` one after the other, all of them ids into the symbol table ``names``."""
        ptr, objects, off = [np.zeros(1, np.int64)], {}, 0
        for p in parts:
            ptr.append(p.arg_ptr[1:] + off)
            objects.update({k + off: v for k, v in p.objects.items()})
            off += len(p.args)
        return cls(tuple(names), np.concatenate([p.ids for p in parts]), np.concatenate(ptr),
                   np.concatenate([p.args for p in parts]), objects)

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    def module(self, i: int) -> tuple[str, tuple]:
        """``(name, parameters)`` of module ``i`` (floats, and the objects of non-number parameters)."""
        a, b = int(self.arg_ptr[i]), int(self.arg_ptr[i + 1])
        vals = self.args[a:b].tolist()
        if self.objects:
            vals = [self.objects.get(a + q, v) if math.isnan(v) else v for q, v in enumerate(vals)]
        return self.names[self.ids[i]], tuple(vals)

    def modules(self) -> list[tuple[str, tuple[float, ...]]]:
        """Every module as ``(name, parameters)`` (a Python list: for tests and small strings)."""
        return [self.module(i) for i in range(len(self))]

    def count(self, name: str) -> int:
        """How many modules are named ``name``."""
        if name not in self.names:
            return 0
        return int(np.count_nonzero(self.ids == self.names.index(name)))

    def __str__(self) -> str:
        return "".join(module_text(name, vals) for name, vals in self.modules())

    def __repr__(self) -> str:
        if len(self) <= 40:
            text = str(self)
        else:
            m = int(self.arg_ptr[40])
            text = str(ModuleString(self.names, self.ids[:40], self.arg_ptr[:41], self.args[:m],
                                    {k: v for k, v in self.objects.items() if k < m})) + "..."
        return f"ModuleString({len(self)} modules: {text})"


class LstringView:
    """A grammar hook's lstring (L-Py's ``AxialTree`` API over a :class:`ModuleString`): ``len``, ``str``,
    ``==`` (by text), ``lstring[i]`` a module (``.name``, ``m[k]`` its k-th parameter, ``m[k] = v`` sets it),
    ``lstring.count(name)``, ``lstring + 'B'`` / ``+=`` (an L-string text or another lstring appended). The
    string underneath is not changed: :meth:`string` is the one a hook's edits give (the engine adopts it)."""

    def __init__(self, string: ModuleString, parse) -> None:
        self._base, self._parse = string, parse
        self._mods: list | None = None                # [name, [params]] once a module is edited

    def _edit(self) -> list:
        if self._mods is None:
            self._mods = [[name, list(vals)] for name, vals in self._base.modules()]
        return self._mods

    @property
    def edited(self) -> bool:
        return self._mods is not None

    def string(self) -> ModuleString:
        """The lstring with the hook's edits."""
        if self._mods is None:
            return self._base
        return ModuleString.from_modules([(n, tuple(v)) for n, v in self._mods], self._base.names)

    def __len__(self) -> int:
        return len(self._base) if self._mods is None else len(self._mods)

    def __getitem__(self, i: int) -> _ModuleView:
        n = len(self)
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not -n <= i < n:
            raise IndexError(f"lstring index {i!r:.40} out of range for {n} modules")
        return _ModuleView(self, int(i) % n)

    def __iter__(self):
        return (self[i] for i in range(len(self)))

    def count(self, name: str) -> int:
        """How many modules are named ``name`` (L-Py's ``AxialTree.count``)."""
        if self._mods is not None:
            return sum(m[0] == name for m in self._mods)
        return sum(n == name for n, _ in self._base.modules())

    def __add__(self, other) -> LstringView:
        extra = self._parse(other) if isinstance(other, str) else other.string() if isinstance(
            other, LstringView) else other
        if not isinstance(extra, ModuleString):
            raise TypeError(f"an lstring takes an L-string text or an lstring, got {type(other).__name__}")
        out = LstringView(self._base, self._parse)
        out._mods = [list(m) for m in self._edit()] + [[n, list(v)] for n, v in extra.modules()]
        return out

    __iadd__ = __add__

    def __eq__(self, other) -> bool:
        if isinstance(other, str):                   # an L-string text, read as one (blanks do not count)
            other = self._parse(other)
        if isinstance(other, (LstringView, ModuleString)):
            return str(self) == str(other)
        return NotImplemented

    __hash__ = None

    def __str__(self) -> str:
        return str(self.string())

    def __repr__(self) -> str:
        return f"Lstring({str(self)[:200]!r})"


class _ModuleView:
    """Module ``i`` of a hook's lstring."""

    __slots__ = ("_of", "_i")

    def __init__(self, of: LstringView, i: int) -> None:
        self._of, self._i = of, i

    def _vals(self) -> list:
        of = self._of
        return of._mods[self._i][1] if of._mods is not None else list(of._base.module(self._i)[1])

    @property
    def name(self) -> str:
        of = self._of
        return of._mods[self._i][0] if of._mods is not None else of._base.module(self._i)[0]

    def __len__(self) -> int:
        return len(self._vals())

    def __getitem__(self, k: int):
        return self._vals()[k]

    def __setitem__(self, k: int, value) -> None:
        self._of._edit()[self._i][1][k] = value

    def __str__(self) -> str:
        return module_text(self.name, self._vals())

    __repr__ = __str__


class Kwds(dict):
    """A successor's ``A(**p)``: parameters given by the names of ``A``'s declaration (placed by
    :meth:`~plantvr.lsystem.rules._Rules._produced`)."""


def module_text(name: str, vals) -> str:
    """``name(v1,v2)`` as an L-string writes a module (``name`` alone without parameters)."""
    return name + ("(" + ",".join(f"{v:g}" if type(v) is float else repr(v) for v in vals) + ")" if vals else "")


def _pyval(v):
    return int(v) if type(v) is float and v.is_integer() and abs(v) < 2 ** 53 else v


def _module_vals(ptr, args, objs, i: int) -> list:
    """Parameters of module ``i`` as rule code sees them: integral floats as int, objects from the side-table."""
    a = int(ptr[i])
    vals = args[a:ptr[i + 1]].tolist()
    if objs:
        return [objs.get(a + q, v) if math.isnan(v) else _pyval(v) for q, v in enumerate(vals)]
    return [_pyval(v) for v in vals]

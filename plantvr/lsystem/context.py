"""What L-Py's grammar code reaches through ``context()`` and its namespace (issue 33): ``ParameterSet``, the
matching ``options`` (``setSelection``, ``find(name).currentValue()``), the editor's ``turtle`` settings and
materials, and ``ModuleClass.get(name)`` (``lsyscontext.cpp``, ``moduleclass.cpp``)."""
from __future__ import annotations

import copy

from . import sandbox as SB
from .lexer import LSystemError

__all__ = ["MAX_MATERIAL", "ParameterSet"]


class ParameterSet:
    """L-Py's ``ParameterSet`` (``openalea.lpy.parameterset``): a bag of named values, attributes and items."""

    def __init__(self, **kwd) -> None:
        self.__dict__.update(kwd)

    def rename(self, old: str, new: str) -> None:
        setattr(self, new, getattr(self, old))
        delattr(self, old)

    def setdefault(self, *args, **kwd) -> None:
        if args and kwd or len(args) % 2:
            raise ValueError("setdefault takes name, value pairs or keywords")
        for name, value in [*zip(args[::2], args[1::2]), *kwd.items()]:
            if not hasattr(self, name):
                setattr(self, name, value)

    def hasattr(self, name: str) -> bool:
        return hasattr(self, name)

    def get(self, name: str, default=None):
        return getattr(self, name, default)

    def set(self, **kwd) -> None:
        self.__dict__.update(kwd)

    def parameter_names(self) -> list[str]:
        return list(self.__dict__)

    def copy(self, deep: bool = True) -> ParameterSet:
        return copy.deepcopy(self) if deep else copy.copy(self)

    def __repr__(self) -> str:
        return f"ParameterSet({','.join(f'{k}={v!r}' for k, v in self.__dict__.items())})"

    def __getitem__(self, name: str):
        return getattr(self, name)

    def __setitem__(self, name: str, value) -> None:
        setattr(self, name, value)

    def __delitem__(self, name: str) -> None:
        delattr(self, name)

    def __contains__(self, name: str) -> bool:
        return hasattr(self, name)


class _ContextStub(SB.SafeAttrs):
    """``context()`` / ``execContext()`` of L-Py: records turtle options, accepts editor settings; in a trusted
    grammar ``context["name"] = value`` sets a name of the grammar's namespace, as L-Py's context is that
    namespace (the editor's ``__initialiseContext__`` defines its curves and functions so)."""

    def __init__(self, options: dict, namespace: dict | None, on_option=None) -> None:
        self.turtle = _TurtleStub(options)
        self.options = _Options(on_option)
        self.animation_timestep = 0.0
        self._ns = namespace

    def __setitem__(self, key, value) -> None:
        if self._ns is not None and isinstance(key, str):
            self._ns[key] = value

    def __getattr__(self, name):
        raise LSystemError(f"context().{name} is not supported")


class _ModuleClass(SB.SafeAttrs):
    """L-Py's ``ModuleClass.get(name)``: a declared module's ``name``, ``scale`` and ``issubclass(other)``
    (its ``: base = A`` declarations, transitively)."""

    def __init__(self, name: str, scales: dict, bases: dict) -> None:
        self.name, self._bases = name, bases
        self.scale = scales.get(name, 2**31 - 1)        # ModuleClass::DEFAULT_SCALE
        self.bases = tuple(bases.get(name, ()))

    def issubclass(self, other) -> bool:
        if not isinstance(other, _ModuleClass):
            raise LSystemError(f"ModuleClass.issubclass needs a ModuleClass, got {type(other).__name__}")
        todo, seen = [self.name], set()
        while todo:
            n = todo.pop()
            if n == other.name:
                return True
            if n not in seen:
                seen.add(n)
                todo.extend(self._bases.get(n, ()))
        return False

    def __repr__(self) -> str:
        return f"ModuleClass({self.name!r})"


class _ModuleClasses(SB.SafeAttrs):
    def __init__(self, grammar) -> None:
        self._g = grammar

    def get(self, name) -> _ModuleClass:
        if not isinstance(name, str):
            raise LSystemError(f"ModuleClass.get needs a module name, got {type(name).__name__}")
        return _ModuleClass(name, self._g.scales, self._g.bases)


class _Options(SB.SafeAttrs):
    """``context().options``: L-Py's matching options (``lsyscontext.cpp``) are checked and handed to
    ``on_option(name, index)``; the editor's other settings are accepted and ignored."""

    CHOICES = {"String matching": ("As String", "As AxialTree", "As Multi-level AxialTree",
                                   "As Multiscale AxialTree"),
               "Module inheritance": ("Disabled", "Enabled")}

    def __init__(self, on_option=None) -> None:
        self._on = on_option
        self._index = {"String matching": 1, "Module inheritance": 0}

    def setSelection(self, name, index=None, *_) -> None:
        values = self.CHOICES.get(name) if isinstance(name, str) else None
        if values is None:
            return
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(values):
            raise LSystemError(f"option {name!r} takes an index in [0, {len(values) - 1}], got {index!r:.40}")
        self._index[name] = index
        if self._on is not None:
            self._on(name, index)

    def find(self, name) -> _Option:
        """L-Py's ``options.find(name)``: the option, whose ``currentValue()`` names its selection."""
        return _Option(self, name)


class _Option(SB.SafeAttrs):
    def __init__(self, options: _Options, name) -> None:
        self._options, self.name = options, name

    def currentValue(self) -> str | None:
        k = self._options._index.get(self.name)
        return None if k is None else self._options.CHOICES[self.name][k]

    def activateSelection(self) -> None:
        """The selection is in force once set (L-Py's editor applies it here)."""

    def __getattr__(self, name):
        return lambda *a, **k: None


#: Highest material index ``setMaterial`` may set (PlantGL's editor shows a few dozen).
MAX_MATERIAL = 1023


class _TurtleStub(SB.SafeAttrs):
    _MAP = {"setAngleIncrement": "angle", "setWidth": "width", "setDefaultStep": "step"}

    def __init__(self, options: dict) -> None:
        self._options = options
        self.materials: dict[int, tuple] = {}           # index -> (name, ambient, diffuse), from setMaterial

    def setMaterial(self, index, material) -> None:
        """``context().turtle.setMaterial(i, Material(...))``, as the editor's colour panel writes it."""
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= MAX_MATERIAL:
            raise LSystemError(f"setMaterial needs an index in [0, {MAX_MATERIAL}], got {index!r:.40}")
        entry = getattr(material, "as_entry", None)
        if callable(entry):                                  # a texture or other appearance keeps the default
            self.materials[index] = entry()

    def __getattr__(self, name):
        if name in self._MAP:
            def setter(value, _key=self._MAP[name]):
                self._options[_key] = float(value)
            return setter
        if name.startswith("setMaterial") or name.startswith("setColor"):
            return lambda *a, **k: None
        raise LSystemError(f"context().turtle.{name} is not supported")

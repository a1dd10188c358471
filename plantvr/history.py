"""The one undo/redo history of every document (spec 000_vine §2.5 generalised; DESIGN "Documents").

A history holds *atoms*, each sized to its change, under a byte budget and an item budget (the oldest is
dropped first; a new operation clears redo):

- :class:`ArrayEdit`: ``array[indices]`` went from ``old`` to ``new`` (ViNE label strokes: memory
  proportional to the change, never to the array, napari's lesson);
- :class:`StateAtom`: a whole-state before/after pair, where a delta is not practical (a growth step);
- :class:`Group`: atoms applied together, undone in reverse (a stroke of stamps, a composite command).

Staging groups what a gesture does into one item: :meth:`History.stage` opens a group, :meth:`commit` pushes
it as one item, :meth:`abort` undoes what it staged and records nothing. An atom applies itself to its
document (``atom.undo(doc)`` / ``atom.redo(doc)``) and returns what changed, ``(kind, ids)``, which the
document publishes as its change event.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Protocol

import numpy as np

from ._validation import check_int

__all__ = ["Atom", "ArrayEdit", "StateAtom", "Group", "History"]


class Atom(Protocol):
    """What a history holds: its size, and how to take it back and apply it again."""

    @property
    def nbytes(self) -> int: ...

    def undo(self, doc: Any) -> tuple[str, np.ndarray | None]: ...

    def redo(self, doc: Any) -> tuple[str, np.ndarray | None]: ...


@dataclass(frozen=True)
class ArrayEdit:
    """``getattr(doc, target)[indices]`` went from ``old`` to ``new``.

    Attributes
    ----------
    indices : (K,) int32 or int64 ndarray
        Sorted, unique element ids.
    old, new : (K,) ndarray
        Values before and after.
    target : str
        Name of the document's array attribute (also the change kind published).
    """

    indices: np.ndarray
    old: np.ndarray
    new: np.ndarray
    target: str = "labels"

    @property
    def nbytes(self) -> int:
        """Memory held by the record."""
        return int(self.indices.nbytes + self.old.nbytes + self.new.nbytes)

    def __len__(self) -> int:
        return int(self.indices.size)

    def undo(self, doc) -> tuple[str, np.ndarray]:
        getattr(doc, self.target)[self.indices] = self.old
        return self.target, self.indices

    def redo(self, doc) -> tuple[str, np.ndarray]:
        getattr(doc, self.target)[self.indices] = self.new
        return self.target, self.indices


@dataclass(frozen=True)
class StateAtom:
    """A whole-state change: ``doc.set_state(before)`` undoes it, ``doc.set_state(after)`` redoes it.

    ``before`` and ``after`` are what the document's ``get_state()`` returned (bytes, or a tuple of arrays);
    ``kind`` is the change kind published.
    """

    before: Any
    after: Any
    kind: str = "all"

    @cached_property
    def nbytes(self) -> int:
        """Memory held by both states (counted once: a whole-state walk per push cost a paint stroke ~5 ms)."""
        return _nbytes(self.before) + _nbytes(self.after)

    def undo(self, doc) -> tuple[str, None]:
        doc.set_state(self.before)
        return self.kind, None

    def redo(self, doc) -> tuple[str, None]:
        doc.set_state(self.after)
        return self.kind, None


def _nbytes(x: Any) -> int:
    if isinstance(x, (bytes, bytearray, memoryview)):
        return len(x)
    if isinstance(x, np.ndarray):
        return int(x.nbytes)
    if isinstance(x, dict):
        return sum(_nbytes(v) for v in x.values())
    if isinstance(x, (tuple, list)):
        return sum(_nbytes(v) for v in x)
    return 64


@dataclass(frozen=True)
class Group:
    """Atoms applied in order as one history item; undone in reverse."""

    atoms: tuple

    @cached_property
    def nbytes(self) -> int:
        """Memory held by the atoms (counted once)."""
        return sum(a.nbytes for a in self.atoms)

    def __len__(self) -> int:
        return len(self.atoms)

    def undo(self, doc) -> tuple[str, np.ndarray | None]:
        return _merge([a.undo(doc) for a in reversed(self.atoms)])

    def redo(self, doc) -> tuple[str, np.ndarray | None]:
        return _merge([a.redo(doc) for a in self.atoms])


def _merge(changes: list[tuple[str, np.ndarray | None]]) -> tuple[str, np.ndarray | None]:
    """One change for several: the common kind with the union of ids, else ``("all", None)``."""
    kinds = {k for k, _ in changes}
    if len(kinds) == 1 and all(ids is not None for _, ids in changes):
        return kinds.pop(), np.unique(np.concatenate([ids for _, ids in changes])) if changes else None
    return ("all", None) if len(kinds) != 1 else (kinds.pop(), None)


class History:
    """Undo and redo stacks of atoms, bounded by item count and bytes.

    Parameters
    ----------
    max_items : int
        Undo depth, in [1, 10000] (ViNE thesis: 20).
    max_bytes : int
        Byte budget for undo plus redo records, in [0, 2**62].
    """

    def __init__(self, *, max_items: int = 20, max_bytes: int = 512 * 2 ** 20):
        self.max_items = check_int("max_items", max_items, 1, 10000)
        self.max_bytes = check_int("max_bytes", max_bytes, 0, 2 ** 62)
        self.undo_stack: deque = deque()
        self.redo_stack: deque = deque()
        self._staged: list | None = None
        self._marks: list[int] = []          # where each open (nested) stage starts in _staged
        self._muted = 0                      # > 0: pushes are dropped (Document.unrecorded)

    @property
    def nbytes(self) -> int:
        """Bytes held by both stacks (and an open stage)."""
        staged = sum(a.nbytes for a in self._staged) if self._staged else 0
        return sum(e.nbytes for e in self.undo_stack) + sum(e.nbytes for e in self.redo_stack) + staged

    @property
    def can_undo(self) -> bool:
        return bool(self.undo_stack)

    @property
    def can_redo(self) -> bool:
        return bool(self.redo_stack)

    @property
    def staging(self) -> bool:
        """True while a stage is open."""
        return self._staged is not None

    def __len__(self) -> int:
        """Items that :meth:`undo` can take back."""
        return len(self.undo_stack)

    @property
    def top(self):
        """The item :meth:`undo` would take back next (None when there is none)."""
        return self.undo_stack[-1] if self.undo_stack else None

    @property
    def next_redo(self):
        """The item :meth:`redo` would apply next (None when there is none)."""
        return self.redo_stack[-1] if self.redo_stack else None

    def push(self, atom) -> None:
        """Record a finished operation (added to the open stage, if any); clears redo and drops the oldest
        items over budget. Dropped while muted."""
        if self._muted:
            return
        if self._staged is not None:
            self._staged.append(atom)
            return
        self.redo_stack.clear()
        self.undo_stack.append(atom)
        self._trim()

    def clear_redo(self) -> None:
        """Drop the redo items (what they would apply again is stale)."""
        self.redo_stack.clear()

    def _trim(self) -> None:
        while self.undo_stack and (len(self.undo_stack) > self.max_items or self.nbytes > self.max_bytes):
            self.undo_stack.popleft()

    def stage(self) -> None:
        """Open a group: atoms pushed until :meth:`commit` become one item. Stages nest: an inner stage's
        atoms join the outer one when it is committed."""
        if self._staged is None:
            self._staged = []
        self._marks.append(len(self._staged))

    def mute(self) -> None:
        """Drop pushes until :meth:`unmute` (nested: as many unmutes as mutes)."""
        self._muted += 1

    def unmute(self) -> None:
        self._muted = max(self._muted - 1, 0)

    @property
    def undo_items(self) -> tuple:
        """The undo items, oldest first (read them; change them only through this class)."""
        return tuple(self.undo_stack)

    @property
    def redo_items(self) -> tuple:
        """The redo items, the next one to redo last."""
        return tuple(self.redo_stack)

    def restore(self, undo_items, redo_items) -> None:
        """Replace both stacks (a session loaded from a file); no stage stays open."""
        self.undo_stack, self.redo_stack = deque(undo_items), deque(redo_items)
        self._staged, self._marks = None, []
        self._trim()

    def commit(self, fold=None, *, amend: bool = False) -> Group | Any | None:
        """Close the innermost open stage. The outermost pushes what was staged as one item (a single atom as
        itself, several as a :class:`Group`, or what ``fold(atoms)`` makes of them) and returns it; an inner one
        leaves its atoms in the outer stage and returns None. None too when nothing was staged."""
        if self._staged is None:
            raise ValueError("no stage is open; call stage() first")
        self._marks.pop()
        if self._marks:
            return None
        atoms, self._staged = self._staged, None
        if not atoms:
            return None
        if amend:
            return self.amend(atoms, fold)
        item = atoms[0] if len(atoms) == 1 else (fold(tuple(atoms)) if fold is not None else Group(tuple(atoms)))
        if item is not None:           # a fold that finds no net change records nothing
            self.push(item)
        return item

    def amend(self, atoms, fold=None) -> Any | None:
        """Add ``atoms`` to the top undo item (one item that undoes both, made by ``fold(atoms)`` when given, else
        a :class:`Group`); pushes them as a new item when there is none. Returns the item."""
        atoms = tuple(atoms)
        if not atoms:
            return None
        if self._staged is not None:
            self._staged.extend(atoms)
            return None
        join = fold if fold is not None else Group
        if not self.undo_stack or self._muted:
            item = atoms[0] if len(atoms) == 1 else join(atoms)
            if item is not None:
                self.push(item)
            return item
        top = self.undo_stack.pop()
        item = join(((top.atoms if isinstance(top, Group) else (top,))) + atoms)
        self.redo_stack.clear()
        if item is None:
            return None
        self.undo_stack.append(item)
        self._trim()
        return item

    def abort(self, doc) -> tuple[str, np.ndarray | None] | None:
        """Undo what the innermost open stage recorded (latest first) and drop it; returns the change, or None."""
        if self._staged is None:
            return None
        mark = self._marks.pop()
        atoms = self._staged[mark:]
        del self._staged[mark:]
        if not self._marks:
            self._staged = None
        return Group(tuple(atoms)).undo(doc) if atoms else None

    def undo(self, doc):
        """Take back the top item on ``doc``; returns ``(item, change)`` or None if there is nothing to undo."""
        return self._move(doc, self.undo_stack, self.redo_stack, "undo")

    def redo(self, doc):
        """Apply the top redo item on ``doc`` again; returns ``(item, change)`` or None."""
        done = self._move(doc, self.redo_stack, self.undo_stack, "redo")
        if done is not None:
            self._trim()
        return done

    @staticmethod
    def _move(doc, src: deque, dst: deque, how: str):
        """Pop the top item of ``src``, apply its ``undo`` or ``redo`` (``how``) on ``doc``, push it on ``dst``."""
        if not src:
            return None
        item = src.pop()
        change = getattr(item, how)(doc)
        dst.append(item)
        return item, change

    def clear(self) -> None:
        """Drop all history (and an open stage)."""
        self.undo_stack.clear()
        self.redo_stack.clear()
        self._staged = None
        self._marks = []

    def copy(self) -> "History":
        """A history with the same items (atoms are immutable, so they are shared)."""
        h = History(max_items=self.max_items, max_bytes=self.max_bytes)
        h.undo_stack, h.redo_stack = deque(self.undo_stack), deque(self.redo_stack)
        h._staged = None if self._staged is None else list(self._staged)
        h._marks, h._muted = list(self._marks), self._muted
        return h

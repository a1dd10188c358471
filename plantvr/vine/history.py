"""Undo/redo of painting operations sized to the change (spec 000_vine §2.5, checklist item 16; STYLE §6).

One item per painting operation (a stroke of many stamps): sorted unique vertex ids with their old and new
labels, so one record serves undo and redo. At most ``max_items`` (20, thesis) items and ``max_bytes``;
the oldest is dropped first. A new operation clears the redo stack.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from plantvr._validation import check_int

__all__ = ["LabelEdit", "History", "merge_stamps"]


@dataclass(frozen=True)
class LabelEdit:
    """One painting operation: ``labels[indices]`` went from ``old`` to ``new``.

    Attributes
    ----------
    indices : (K,) int32 or int64 ndarray
        Sorted, unique vertex ids.
    old, new : (K,) uint8 ndarray
        Labels before and after the operation.
    """

    indices: np.ndarray
    old: np.ndarray
    new: np.ndarray

    @property
    def nbytes(self) -> int:
        """Memory held by the record."""
        return int(self.indices.nbytes + self.old.nbytes + self.new.nbytes)

    def __len__(self) -> int:
        return int(self.indices.size)


def merge_stamps(idx_parts: list, old_parts: list, labels: np.ndarray) -> LabelEdit | None:
    """Fold a stroke's stamps into one :class:`LabelEdit` keeping each vertex's first (pre-operation) label.

    Parameters
    ----------
    idx_parts, old_parts : list of ndarray
        Per-stamp changed ids and their labels before that stamp, in stamp order.
    labels : (V,) uint8 ndarray
        Labels after the stroke (gives ``new``).

    Returns
    -------
    LabelEdit or None
        None when nothing changed (including a vertex painted and painted back).
    """
    if not idx_parts:
        return None
    idx = np.concatenate(idx_parts)
    old = np.concatenate(old_parts)
    if idx.size == 0:
        return None
    itype = np.int32 if labels.size < 2 ** 31 else np.int64
    if len(idx_parts) == 1:
        order = np.argsort(idx, kind="stable")
        uidx, first = idx[order], order
    else:
        uidx, first = np.unique(idx, return_index=True)      # first occurrence = pre-operation label
    old = old[first]
    new = labels[uidx]
    keep = old != new
    if not keep.all():
        uidx, old, new = uidx[keep], old[keep], new[keep]
    if uidx.size == 0:
        return None
    return LabelEdit(uidx.astype(itype), old.astype(np.uint8), new.astype(np.uint8))


class History:
    """Two stacks of :class:`LabelEdit` bounded by item count and bytes.

    Parameters
    ----------
    max_items : int
        Undo depth, in [1, 10000] (thesis: 20).
    max_bytes : int
        Byte budget for undo plus redo records, in [0, 2**62].
    """

    def __init__(self, *, max_items: int = 20, max_bytes: int = 512 * 2 ** 20):
        self.max_items = check_int("max_items", max_items, 1, 10000)
        self.max_bytes = check_int("max_bytes", max_bytes, 0, 2 ** 62)
        self.undo_stack: deque[LabelEdit] = deque()
        self.redo_stack: deque[LabelEdit] = deque()

    @property
    def nbytes(self) -> int:
        """Bytes held by both stacks."""
        return sum(e.nbytes for e in self.undo_stack) + sum(e.nbytes for e in self.redo_stack)

    def push(self, edit: LabelEdit) -> None:
        """Record a finished operation; clears redo and drops the oldest items over budget."""
        self.redo_stack.clear()
        self.undo_stack.append(edit)
        while self.undo_stack and (len(self.undo_stack) > self.max_items or self.nbytes > self.max_bytes):
            self.undo_stack.popleft()

    def undo(self, labels: np.ndarray) -> LabelEdit | None:
        """Write the top operation's old labels; returns it, or None if there is nothing to undo."""
        if not self.undo_stack:
            return None
        e = self.undo_stack.pop()
        labels[e.indices] = e.old
        self.redo_stack.append(e)
        return e

    def redo(self, labels: np.ndarray) -> LabelEdit | None:
        """Write the top redo operation's new labels; returns it, or None."""
        if not self.redo_stack:
            return None
        e = self.redo_stack.pop()
        labels[e.indices] = e.new
        self.undo_stack.append(e)
        return e

    def clear(self) -> None:
        """Drop all history."""
        self.undo_stack.clear()
        self.redo_stack.clear()

"""The two-way sync guard of the widgets that follow a document and command it (one mechanism, issue 30)."""
from __future__ import annotations

__all__ = ["SyncGuard"]


class SyncGuard:
    """True inside a ``with guard:`` block: a widget sets it while it shows the document's values (or commands the
    document), so the trait changes that makes do not echo back as commands (or as a second pull)."""

    __slots__ = ("_depth",)

    def __init__(self) -> None:
        self._depth = 0

    def __bool__(self) -> bool:
        return self._depth > 0

    def __enter__(self) -> SyncGuard:
        self._depth += 1
        return self

    def __exit__(self, *exc) -> None:
        self._depth -= 1

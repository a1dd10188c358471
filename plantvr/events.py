"""Input-event log and replay (DESIGN: every command a widget, view or headset issues is logged).

A session is a list of ``(command, kwargs)`` pairs; replaying it on a model seeded the same way
reproduces the same tree (spec 000_treewand §8.3 TW-V23 scenarios are replays).
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["Event", "EventLog"]

REPLAYABLE = ("paint", "paint_stroke", "add_markers", "prune", "step", "set_params", "set_influence", "set_prune_mode",
              "reset")


@dataclass(frozen=True)
class Event:
    """One command with its JSON-able arguments and wall-clock time."""

    command: str
    kwargs: dict[str, Any]
    t: float = field(default_factory=time.time)


class EventLog:
    """Append-only list of :class:`Event`, saved as JSON lines."""

    def __init__(self) -> None:
        self.events: list[Event] = []

    def record(self, command: str, **kwargs: Any) -> None:
        """Append a command; numpy values become lists."""
        self.events.append(Event(command, {k: _plain(v) for k, v in kwargs.items()}))

    def __len__(self) -> int:
        return len(self.events)

    def replay(self, model) -> None:
        """Issue every logged command on ``model`` in order."""
        for ev in self.events:
            if ev.command not in REPLAYABLE:
                raise ValueError(f"event command must be one of {list(REPLAYABLE)}, got {ev.command!r}")
            getattr(model, ev.command)(**ev.kwargs)

    def save(self, path: str | Path) -> None:
        """Write the log as JSON lines."""
        Path(path).write_text("".join(json.dumps({"command": e.command, "kwargs": e.kwargs, "t": e.t}) + "\n"
                                      for e in self.events))

    @classmethod
    def load(cls, path: str | Path) -> "EventLog":
        """Read a log written by :meth:`save`."""
        log = cls()
        for i, line in enumerate(Path(path).read_text().splitlines(), 1):
            try:
                d = json.loads(line)
                log.events.append(Event(d["command"], d["kwargs"], d["t"]))
            except (json.JSONDecodeError, KeyError, TypeError):
                raise ValueError(f"event log {path!s} line {i} is not a PlantVR event") from None
        return log


def _plain(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v

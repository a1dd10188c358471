"""Input-event log and replay (DESIGN: every command a widget, view or headset issues is logged).

A session is a list of ``(command, kwargs)`` pairs in the order the model applied them (a model records each
command under its lock when it applies it, so edits made during background growth land between the steps
they followed); replaying it on a model seeded the same way reproduces the same tree (spec 000_treewand §8.3
TW-V23 scenarios are replays).

File format: one JSON object per line, ``{"command", "kwargs", "t"}``, then a last line
``{"plantvr_events": 1, "count": n, "sha256": hex}`` whose digest covers every byte before it, so a truncated
or damaged log is refused instead of replaying part of a session.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ._fileio import write_atomic

__all__ = ["Event", "EventLog", "REPLAYABLE", "LOG_VERSION", "MAX_LOG_BYTES"]

REPLAYABLE = ("paint", "paint_stroke", "add_markers", "prune", "step", "set_params", "set_influence", "set_prune_mode",
              "reset")
#: Version of the event-log file format (the trailer's ``plantvr_events``).
LOG_VERSION = 1
#: Largest event-log file :meth:`EventLog.load` reads (bytes).
MAX_LOG_BYTES = 256 * 2**20


@dataclass(frozen=True)
class Event:
    """One command with its JSON-able arguments and wall-clock time."""

    command: str
    kwargs: dict[str, Any]
    t: float = field(default_factory=time.time)


class EventLog:
    """Append-only list of :class:`Event`, saved as JSON lines with a checksum trailer."""

    def __init__(self) -> None:
        self.events: list[Event] = []

    def record(self, command: str, **kwargs: Any) -> Event:
        """Append a command (numpy values become lists) and return its event."""
        ev = Event(command, {k: _plain(v) for k, v in kwargs.items()})
        self.events.append(ev)
        return ev

    def __len__(self) -> int:
        return len(self.events)

    def check(self, model=None) -> None:
        """Raise ``ValueError`` unless every event is a replayable command with well-formed arguments.

        With ``model``, each event's arguments also go through the model's door checks
        (``model.check_command``), so :meth:`replay` fails before issuing anything.
        """
        check = getattr(model, "check_command", None)
        for i, ev in enumerate(self.events):
            if not isinstance(ev, Event):
                raise ValueError(f"event {i} must be an Event, got {type(ev).__name__}")
            if ev.command not in REPLAYABLE:
                raise ValueError(f"event {i}: event command must be one of {list(REPLAYABLE)}, got {ev.command!r}")
            if not isinstance(ev.kwargs, dict) or not all(isinstance(k, str) for k in ev.kwargs):
                raise ValueError(f"event {i} ({ev.command}): kwargs must be a dict with str keys, "
                                 f"got {ev.kwargs!r}"[:300])
            if check is not None:
                try:
                    check(ev.command, ev.kwargs)
                except ValueError as exc:
                    raise ValueError(f"event {i} ({ev.command}): {exc}") from None

    def replay(self, model) -> None:
        """Issue every logged command on ``model`` in order; every event is checked first, so a bad one
        raises ``ValueError`` before anything is issued."""
        self.check(model)
        for ev in list(self.events):
            getattr(model, ev.command)(**ev.kwargs)

    def to_text(self) -> str:
        """The log as file text (JSON lines and the checksum trailer)."""
        try:
            body = "".join(json.dumps({"command": e.command, "kwargs": e.kwargs, "t": e.t}, allow_nan=False) + "\n"
                           for e in self.events)
        except (TypeError, ValueError, RecursionError) as exc:
            raise ValueError(f"event log holds a value a JSON file cannot store: {exc}") from None
        digest = hashlib.sha256(body.encode("utf-8")).hexdigest()
        return body + json.dumps({"plantvr_events": LOG_VERSION, "count": len(self.events), "sha256": digest}) + "\n"

    def save(self, path: str | os.PathLike) -> Path:
        """Write the log atomically; returns the path."""
        return write_atomic(_check_path(path), self.to_text())

    @classmethod
    def load(cls, path: str | os.PathLike) -> "EventLog":
        """Read a log written by :meth:`save`; a truncated, damaged or foreign file raises ``ValueError``."""
        path = _check_path(path)
        try:
            with open(path, "rb") as fh:
                raw = fh.read(min(os.fstat(fh.fileno()).st_size, MAX_LOG_BYTES) + 1)
        except OSError as exc:
            raise ValueError(f"cannot read event log {str(path)!r}: {exc}") from None
        if len(raw) > MAX_LOG_BYTES:
            raise ValueError(f"event log {path!s} is larger than the cap of {MAX_LOG_BYTES} bytes")
        return cls.from_text(raw, where=str(path))

    @classmethod
    def from_text(cls, text: str | bytes, *, where: str = "text") -> "EventLog":
        """Parse what :meth:`to_text` wrote (see :meth:`load`)."""
        if isinstance(text, bytes):
            try:
                text = text.decode("utf-8")
            except UnicodeDecodeError:
                raise ValueError(f"event log {where} is not UTF-8 text") from None
        if not isinstance(text, str):
            raise ValueError(f"event log text must be str or bytes, got {type(text).__name__}")
        text = text.replace("\r\n", "\n")
        body, _, last = text.rstrip("\n").rpartition("\n")
        body = body + "\n" if body else ""
        try:
            trailer = json.loads(last)
        except (json.JSONDecodeError, RecursionError):
            trailer = None
        if not isinstance(trailer, dict) or "plantvr_events" not in trailer:
            raise ValueError(f"event log {where} has no trailer line (truncated, or not a PlantVR event log)")
        if trailer["plantvr_events"] != LOG_VERSION or isinstance(trailer["plantvr_events"], bool):
            raise ValueError(f"event log {where}: format version {trailer['plantvr_events']!r} is not supported "
                             f"(this PlantVR reads version {LOG_VERSION})"[:300])
        if trailer.get("sha256") != hashlib.sha256(body.encode("utf-8", "surrogatepass")).hexdigest():
            raise ValueError(f"event log {where}: checksum mismatch (the file is damaged or was edited)")
        log = cls()
        for i, line in enumerate(body.splitlines(), 1):
            try:
                d = json.loads(line)
                ok = (isinstance(d, dict) and set(d) == {"command", "kwargs", "t"} and isinstance(d["command"], str)
                      and isinstance(d["kwargs"], dict) and isinstance(d["t"], (int, float))
                      and not isinstance(d["t"], bool) and math.isfinite(d["t"]))
            except (json.JSONDecodeError, RecursionError):
                ok = False
            if not ok:
                raise ValueError(f"event log {where} line {i} is not a PlantVR event")
            if d["command"] not in REPLAYABLE:
                raise ValueError(f"event log {where} line {i}: event command must be one of {list(REPLAYABLE)}, "
                                 f"got {d['command']!r}"[:300])
            log.events.append(Event(d["command"], d["kwargs"], float(d["t"])))
        if trailer.get("count") != len(log.events):
            raise ValueError(f"event log {where}: the trailer counts {trailer.get('count')!r} events, "
                             f"the file holds {len(log.events)}"[:300])
        log.check()
        return log


def _check_path(path) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or path-like, got {type(path).__name__}")
    try:
        return Path(path)
    except TypeError:
        raise ValueError(f"path must be a str or path-like, got {path!r}") from None


def _plain(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v

"""The one command log of every document, and replay by command name (DESIGN "Documents").

A session is a list of ``(command, kwargs)`` pairs in the order the document applied them (a document records
each command under its lock when it applies it, so edits made during background growth land between the steps
they followed); replaying it on a fresh document of the same kind reproduces the same state (spec 000_treewand
§8.3 TW-V23 scenarios are replays; spec 000_vine §2.0 sessions are replays). Widgets, the 3D view and the
headset all end in document commands, so one log records what any of them did.

File format: one JSON object per line, ``{"command", "kwargs", "t"}``, then a last line
``{"plantvr_events": 1, "count": n, "sha256": hex}`` (plus ``"document": kind`` when the log knows it) whose
digest covers every byte before it, so a truncated or damaged log is refused instead of replaying part of a
session.
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

from ._fileio import read_text, write_atomic

__all__ = ["Event", "CommandLog", "LOG_VERSION", "MAX_LOG_BYTES"]
#: Version of the event-log file format (the trailer's ``plantvr_events``).
LOG_VERSION = 1
#: Largest event-log file :meth:`CommandLog.load` reads (bytes).
MAX_LOG_BYTES = 256 * 2**20


@dataclass(frozen=True)
class Event:
    """One command with its JSON-able arguments and wall-clock time."""

    command: str
    kwargs: dict[str, Any]
    t: float = field(default_factory=time.time)


class CommandLog:
    """Append-only list of :class:`Event`, saved as JSON lines with a checksum trailer.

    Parameters
    ----------
    commands : tuple of str, optional
        The replayable command names of the document kind this log belongs to; events outside it are refused
        when recorded, loaded or replayed. ``None`` accepts any name (checked against the document on replay).
    document : str, optional
        The document kind (``Document.KIND``), written into the trailer and checked on load.
    """

    def __init__(self, commands: tuple[str, ...] | None = None, *, document: str | None = None) -> None:
        self.events: list[Event] = []
        self.commands = None if commands is None else tuple(commands)
        self.document = document

    def record(self, command: str, **kwargs: Any) -> Event:
        """Append a command (numpy values become lists) and return its event."""
        if self.commands is not None and command not in self.commands:
            raise ValueError(f"command must be one of {list(self.commands)}, got {command!r}"[:300])
        ev = Event(command, {k: _plain(v) for k, v in kwargs.items()})
        self.events.append(ev)
        return ev

    def extend(self, command: str, entry: Event | None, key: str, amount: int = 1) -> Event:
        """Add ``amount`` to ``entry.kwargs[key]`` while ``entry`` is the newest event (consecutive growth
        steps merge into one), else record a new ``command`` with ``key=amount``; returns the entry."""
        if entry is not None and self.events and self.events[-1] is entry:
            entry.kwargs[key] += amount
            return entry
        return self.record(command, **{key: amount})

    def __len__(self) -> int:
        return len(self.events)

    def __iter__(self):
        return iter(self.events)

    def _names(self, doc) -> tuple[str, ...] | None:
        return getattr(doc, "COMMANDS", None) if doc is not None else self.commands

    def check(self, doc=None) -> None:
        """Raise ``ValueError`` unless every event is a replayable command with well-formed arguments.

        With ``doc``, each event's arguments also go through the document's door checks
        (``doc.check_command``), so :meth:`replay` fails before issuing anything.
        """
        names = self._names(doc)
        check = getattr(doc, "check_command", None)
        kind = getattr(doc, "KIND", None)
        if doc is not None and self.document is not None and kind is not None and self.document != kind:
            raise ValueError(f"the log records a {self.document!r} session, not a {kind!r} one"[:300])
        for i, ev in enumerate(self.events):
            if not isinstance(ev, Event):
                raise ValueError(f"event {i} must be an Event, got {type(ev).__name__}")
            if names is not None and ev.command not in names:
                raise ValueError(f"event {i}: event command must be one of {list(names)}, got {ev.command!r}"[:300])
            if not isinstance(ev.kwargs, dict) or not all(isinstance(k, str) for k in ev.kwargs):
                raise ValueError(f"event {i} ({ev.command}): kwargs must be a dict with str keys, "
                                 f"got {ev.kwargs!r}"[:300])
            if check is not None:
                try:
                    check(ev.command, ev.kwargs)
                except ValueError as exc:
                    raise ValueError(f"event {i} ({ev.command}): {exc}") from None

    def replay(self, doc) -> None:
        """Issue every logged command on ``doc`` by name, in order (``doc.replay(log)`` when the document has
        one, which may apply the whole log atomically). Every event is checked first, so a bad one raises
        ``ValueError`` before anything is issued."""
        replay = getattr(doc, "replay", None)
        if replay is not None:
            replay(self)
            return
        self.check(doc)
        for ev in list(self.events):
            getattr(doc, ev.command)(**ev.kwargs)

    def to_text(self) -> str:
        """The log as file text (JSON lines and the checksum trailer)."""
        try:
            body = "".join(json.dumps({"command": e.command, "kwargs": e.kwargs, "t": e.t}, allow_nan=False) + "\n"
                           for e in self.events)
        except (TypeError, ValueError, RecursionError) as exc:
            raise ValueError(f"event log holds a value a JSON file cannot store: {exc}") from None
        trailer = {"plantvr_events": LOG_VERSION, "count": len(self.events),
                   "sha256": _digest(body.encode("utf-8"), self.document)}
        if self.document is not None:
            trailer["document"] = self.document
        return body + json.dumps(trailer) + "\n"

    def save(self, path: str | os.PathLike) -> Path:
        """Write the log atomically; returns the path."""
        return write_atomic(_check_path(path), self.to_text())

    @classmethod
    def load(cls, path: str | os.PathLike, commands: tuple[str, ...] | None = None, *,
             document: str | None = None) -> "CommandLog":
        """Read a log written by :meth:`save`; a truncated, damaged or foreign file raises ``ValueError``.
        With ``commands`` (a document's ``COMMANDS``) and ``document`` (its ``KIND``) the events and the trailer
        are checked against them."""
        text = read_text(_check_path(path), what="event log", max_bytes=MAX_LOG_BYTES)
        return cls.from_text(text, where=str(path), commands=commands, document=document)

    @classmethod
    def from_text(cls, text: str | bytes, *, where: str = "text", commands: tuple[str, ...] | None = None,
                  document: str | None = None) -> "CommandLog":
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
        kind = trailer.get("document")
        if trailer.get("sha256") != _digest(body.encode("utf-8", "surrogatepass"), kind):
            raise ValueError(f"event log {where}: checksum mismatch (the file is damaged or was edited)")
        kind = document if kind is None else kind
        if document is not None and kind != document:
            raise ValueError(f"event log {where} records a {kind!r} session, not a {document!r} one"[:300])
        log = cls(commands, document=kind if isinstance(kind, str) else None)
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
            if commands is not None and d["command"] not in commands:
                raise ValueError(f"event log {where} line {i}: event command must be one of {list(commands)}, "
                                 f"got {d['command']!r}"[:300])
            log.events.append(Event(d["command"], d["kwargs"], float(d["t"])))
        if trailer.get("count") != len(log.events):
            raise ValueError(f"event log {where}: the trailer counts {trailer.get('count')!r} events, "
                             f"the file holds {len(log.events)}"[:300])
        log.check()
        return log


def _digest(body: bytes, document: Any) -> str:
    """SHA-256 of the event lines, and of the document kind when the trailer names one."""
    h = hashlib.sha256(body)
    if document is not None:
        h.update(b"\ndocument=" + str(document).encode("utf-8", "surrogatepass"))
    return h.hexdigest()


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

"""The one document base every part's state lives on (DESIGN "Documents"; issue 21).

A :class:`Document` is a traitlets object with

- ``version`` and a ``change`` event (a :class:`Change`: what changed, as a kind and element ids); the kinds a
  document publishes are declared once, in ``EVENTS``, and views, widgets and the headset subscribe to those:
  ``doc.on(fn, "labels", "colors")`` (parameters are traits, observed by name);
- one :class:`~plantvr.history.History` (byte-budgeted undo atoms, grouped, stage/commit/abort); undo goes by
  gesture: a parameter change is one item (restoring the parameter and what it changed), and
  :meth:`Document.history_block` makes whatever is inside one item and one logged ``block`` command
  (:meth:`Document.unrecorded` for a caller recording its own item); nothing outside this base and
  :mod:`plantvr.history` touches the undo and redo stacks;
- one :class:`~plantvr.commandlog.CommandLog`: every command is logged when it is applied (under the document
  lock, so commands, undo and redo from any thread and background steps are logged in the order they applied),
  and :meth:`Document.replay` re-issues a log by command name, all or nothing;
- parameters: traits generated from the document's :class:`~plantvr.params.ParamTable` (``PARAMS``), set one
  at a time or with :meth:`Document.set_params` (logged as one command), saved and read as presets;
- snapshots for renderers on other threads: :meth:`Document.changed` makes ``make_snapshot()`` and the version
  under the lock, as one change, and publishes it; one applier at a time (the kernel thread) applies the newest
  one (older ones are replaced, never queued, and never applied after a newer one), and a render thread reads
  :attr:`Document.latest` without waiting: versions never go back;
- autosave after every state-changing command, atomic (:mod:`plantvr._fileio`).

Every state change is a command (issue 30): a public method that changes state is in ``COMMANDS`` and logs
itself, so replaying ``doc.log`` reproduces a session, the headset's included (``tests/test_commands.py`` scans
every document for state changes outside ``COMMANDS``). A load from a file (``restore``) logs the absolute path
and the SHA-256 of the bytes it loaded (:func:`file_digest`); its door check (:func:`check_digest`) refuses a file
whose bytes differ, so a replay reproduces the same state or is refused before anything is issued (a log does not
carry the file: keep the file with the log). A regrow (:meth:`Document._reissue`, ``Model.regrow``) re-issues the
session's :meth:`Document.effective_events` (undone items left out) as one undo item and one ``regrow`` command;
an observer of a parameter that issues a command of its own (the workbench's regrow) waits with
:meth:`Document.after_command` until the ``set_params`` that set it is logged and its undo item pushed.

A subclass declares ``KIND``, ``COMMANDS`` (its replayable commands; each has a door check ``_check_<name>``
that raises ``ValueError`` and changes nothing), ``PARAMS``, and implements :meth:`state_bytes` (and
:meth:`get_state`/:meth:`set_state` for whole-state undo atoms), :meth:`save` and :meth:`scene`.
"""
from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import hashlib
import inspect
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, ClassVar, Iterator

import numpy as np
from traitlets import Any as AnyTrait
from traitlets import All as traitlets_all
from traitlets import Bool, HasTraits, Int, MetaHasTraits

from .commandlog import CommandLog
from .history import Group, History, StateAtom, _merge
from .params import ParamTable, ParamTrait

__all__ = ["MAX_BLOCK_DEPTH", "Change", "Document", "file_digest", "kernel_loop", "serialise"]
#: Deepest nesting of ``block`` commands a log may hold.
MAX_BLOCK_DEPTH = 8


@dataclass(frozen=True)
class Change:
    """What one change did: ``kind`` (``"labels"``, ``"tree"``, ``"params"``, ``"all"``, ...), the element
    ``ids`` it touched (None: everything of that kind), the document ``version`` after it, and the ``command``
    that made it."""

    kind: str
    ids: np.ndarray | None
    version: int
    command: str | None = None


class _DocumentMeta(MetaHasTraits):
    """Adds one :class:`~plantvr.params.ParamTrait` per row of a class's ``PARAMS`` table to the class."""

    def __new__(mcls, name, bases, namespace, **kw):
        commands = namespace.get("COMMANDS")
        if isinstance(commands, tuple) and "undo" in commands and "block" not in commands:
            namespace["COMMANDS"] = (*commands, "block")     # a history block, logged as one command
        events = namespace.get("EVENTS")
        if isinstance(events, tuple):                        # every document publishes these two
            namespace["EVENTS"] = tuple(dict.fromkeys(("all", "params", *events)))
        table = namespace.get("PARAMS")
        if isinstance(table, ParamTable):
            for p in table:
                namespace.setdefault(p.name, ParamTrait(p))
        return super().__new__(mcls, name, bases, namespace, **kw)


class Document(HasTraits, metaclass=_DocumentMeta):
    """Base of every PlantVR document (see the module docstring).

    A subclass that sets ``PARAMS`` gets one trait per parameter, generated from the table.

    Parameters
    ----------
    max_undo : int
        Undo depth, in [1, 10000].
    max_undo_bytes : int
        Byte budget of the undo and redo records.
    **params
        Initial parameter values, checked against ``PARAMS``.
    """

    #: Document kind, written into command logs and files.
    KIND: ClassVar[str] = "document"
    #: Replayable command names; each has a door check ``_check_<name>``.
    COMMANDS: ClassVar[tuple[str, ...]] = ()
    #: What a change can be, declared once (the ``kind`` of every :class:`Change` it publishes and of its undo
    #: atoms; ``"all"`` and ``"params"`` always): observers subscribe to them with :meth:`on`.
    EVENTS: ClassVar[tuple[str, ...]] = ()
    #: The document's parameter table (None: no parameters).
    PARAMS: ClassVar[ParamTable | None] = None
    #: A parameter change (``set_params``, a trait set by a slider) is one undo item of the whole state
    #: (:meth:`get_state` must then hold the parameters as its ``"params"`` entry, and :meth:`set_state` restore
    #: them); False for a document that records its own parameter items.
    PARAMS_UNDO: ClassVar[bool] = True
    #: Commands that make no undo item (a brush mode, a saved view): :meth:`effective_events` keeps them.
    NO_UNDO_ITEM: ClassVar[tuple[str, ...]] = ()
    #: Commands that join the undo item of the next command that makes one (the events of an open stroke).
    ITEM_OPENERS: ClassVar[tuple[str, ...]] = ()
    #: Commands that join an open item (growth while a stroke is open belongs to the stroke's item).
    JOIN_OPEN: ClassVar[tuple[str, ...]] = ()
    #: Commands logged with a ``steps`` count that made one undo item per step (``grow`` in the background).
    PER_STEP: ClassVar[tuple[str, ...]] = ()

    version = Int(0, help="Bumped after every change; views observe it.")
    change = AnyTrait(None, allow_none=True, help="The latest Change (observe names='change').")
    can_undo = Bool(False, help="Whether undo() has something to take back.")
    can_redo = Bool(False, help="Whether redo() has something to apply again.")

    def __init__(self, *, max_undo: int = 20, max_undo_bytes: int = 512 * 2 ** 20, **params: Any):
        checked = self.PARAMS.validate(params) if self.PARAMS is not None else {}
        if self.PARAMS is None and params:
            raise ValueError(f"{type(self).__name__} takes no parameters, got {sorted(params)}")
        history = History(max_items=max_undo, max_bytes=max_undo_bytes)
        super().__init__(**checked)
        self.history = history
        self.log = CommandLog(self.COMMANDS, document=self.KIND)
        self._lock = threading.RLock()
        self._pending_lock = threading.Lock()  # guards _pending only (a leaf lock: nothing is taken under it)
        self._apply_lock = threading.Lock()    # one applier at a time: snapshot and version never go back
        self._blocks = 0                  # > 0: inside history_block() (the thread holding the lock)
        self._batch: int | None = None    # thread inside set_params: trait observers log nothing
        self._deferred: list[Callable[[], None]] = []   # after_command() calls made inside set_params
        self._restoring = False           # a load sets traits of state it built itself
        self._hold = 0                    # > 0: autosave deferred (replay, batches)
        self._dirty = False               # a change happened while held
        self._autosave_path: Path | None = None
        self.autosave_error: str | None = None
        self._loop = kernel_loop()
        self._seq = 0
        self._after: tuple[int, Any] | None = None      # (version, state) after the last undoable block
        self._pending: tuple[Any, Change, tuple[bool, bool]] | None = None
        self.latest: Any = None           # newest published snapshot, for render threads
        self.snapshot: Any = None         # newest snapshot applied on the kernel thread
        self._subscribers: dict[Callable, Callable] = {}     # on(): fn -> its filtering observer
        if self.PARAMS is not None:
            self.observe(self._on_param, names=self.PARAMS.names)

    def on(self, fn: Callable[[Change], None], *kinds: str) -> Callable[[Change], None]:
        """Call ``fn(change)`` on the kernel thread for every :class:`Change` of one of ``kinds`` (names from
        :attr:`EVENTS`; none: every change); an ``"all"`` change (a replay, merged changes) reaches every
        subscriber. Returns ``fn``, the handle for :meth:`off`. Parameters are traits: observe them by name."""
        unknown = [k for k in kinds if k not in self.EVENTS]
        if unknown:
            raise ValueError(f"kinds: {unknown} not in {type(self).__name__}.EVENTS {self.EVENTS}")
        wanted = frozenset(kinds)

        def handler(event) -> None:
            c = event["new"]
            if c is not None and (not wanted or c.kind in wanted or c.kind == "all"):
                fn(c)

        self.off(fn)
        self._subscribers[fn] = handler
        self.observe(handler, names="change")
        return fn

    def off(self, fn: Callable[[Change], None]) -> None:
        """Stop calling ``fn`` (a no-op when it is not subscribed)."""
        handler = self._subscribers.pop(fn, None)
        if handler is not None:
            self.unobserve(handler, names="change")

    def unobserve(self, handler, names=traitlets_all, type: str = "change") -> None:
        """As ``HasTraits.unobserve``, but a handler that is not (or no longer) registered is ignored, so a view
        can stop following its document twice (a widget closed twice)."""
        with contextlib.suppress(ValueError, KeyError):
            super().unobserve(handler, names=names, type=type)

    # -- parameters -------------------------------------------------------------------------------------
    @property
    def restoring(self) -> bool:
        """True while the document sets traits of a state it restores (undo, redo, a load, a rolled-back replay):
        an observer that reacts to a parameter change with a command of its own (a regrow) skips those."""
        return self._restoring

    @property
    def params(self) -> dict[str, Any]:
        """Current parameter values, ``{name: value}``."""
        return {} if self.PARAMS is None else {p.name: getattr(self, p.name) for p in self.PARAMS}

    def _check_set_params(self, **params: Any) -> dict[str, Any]:
        if self.PARAMS is None:
            raise ValueError(f"{type(self).__name__} has no parameters")
        return self.PARAMS.validate(params)

    def set_params(self, **params: Any) -> None:
        """Set several parameters at once; all are checked before any is set. Logged as one command and one undo
        item (restoring the parameters with whatever they changed)."""
        checked = self._check_set_params(**params)
        with self._lock, self._param_item():
            self._batch = threading.get_ident()
            try:
                with self.hold_trait_notifications():
                    for k, v in checked.items():
                        setattr(self, k, v)
            finally:
                self._batch = None
            self.log.record("set_params", **checked)
        deferred, self._deferred = self._deferred, []
        for fn in deferred:     # after the command is logged and its undo item pushed (a regrow amends it)
            fn()
        self._autosave()

    def after_command(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` once the parameter command in progress on this thread is logged and its undo item pushed
        (an observer of a parameter set by :meth:`set_params` is notified before that), else now: a regrow then
        follows its ``set_params`` in the log and amends its undo item."""
        if self._batch == threading.get_ident():
            self._deferred.append(fn)
        else:
            fn()

    def _param_item(self, old: dict[str, Any] | None = None):
        """The undo item of a parameter change (``old``: values the traits held before, when they are already
        set); a no-op for a document whose parameter changes record themselves (``PARAMS_UNDO`` False)."""
        if not self.PARAMS_UNDO or type(self).set_state is Document.set_state:   # no whole-state undo
            return contextlib.nullcontext()
        before = None
        if old is not None:
            before = self.get_state()
            if isinstance(before, dict) and isinstance(before.get("params"), dict):
                before = {**before, "params": {**before["params"], **old}}
        return self.undoable("params", before=before)

    def _on_param(self, change) -> None:
        if self._restoring:
            return
        direct = self._batch != threading.get_ident()
        # a trait set directly (a slider): one undo item, logged like set_params, so replay sees it (the item is
        # opened once the lock is held)
        with self._lock, self._param_item({change["name"]: change["old"]}) if direct else contextlib.nullcontext():
            self.apply_param(change["name"], change["new"])
            if direct:
                self.log.record("set_params", **{change["name"]: change["new"]})
        self.changed("params", command="set_params", save=direct)

    def apply_param(self, name: str, value: Any) -> None:
        """Hook: make the numeric state follow a parameter that was just set (called under the lock)."""

    def save_preset(self, path, *, names: list[str] | None = None) -> Path:
        """Write the parameters (or only ``names``) as a JSON preset, atomically."""
        if self.PARAMS is None:
            raise ValueError(f"{type(self).__name__} has no parameters")
        unknown = [n for n in names or () if n not in self.PARAMS]
        if unknown:
            raise ValueError(f"names must be parameters of {self.PARAMS.name}, got {unknown[0]!r}")
        values = self.params if names is None else {n: getattr(self, n) for n in names}
        return self.PARAMS.save_preset(path, values)

    def load_preset(self, path) -> dict[str, Any]:
        """Apply a preset (every value checked first; a bad file changes nothing); returns the values set."""
        if self.PARAMS is None:
            raise ValueError(f"{type(self).__name__} has no parameters")
        values = self.PARAMS.read_preset(path)
        self.set_params(**values)
        return values

    # -- commands ---------------------------------------------------------------------------------------
    def check_command(self, command: str, kwargs: dict[str, Any]) -> None:
        """Raise ``ValueError`` unless ``getattr(self, command)(**kwargs)`` passes the door checks (nothing is
        changed); :meth:`replay` checks a whole log this way first."""
        if command not in self.COMMANDS:
            raise ValueError(f"command must be one of {list(self.COMMANDS)}, got {command!r}"[:300])
        if not isinstance(kwargs, dict) or not all(isinstance(k, str) for k in kwargs):
            raise ValueError(f"kwargs of {command} must be a dict with str keys, got {kwargs!r}"[:300])
        self._check_signature(command, kwargs)(**kwargs)

    def _check_signature(self, command: str, kwargs: dict[str, Any]) -> Callable[..., Any]:
        """The door check of ``command`` once its name and argument names fit (``ValueError`` otherwise)."""
        if command not in self.COMMANDS:
            raise ValueError(f"command must be one of {list(self.COMMANDS)}, got {command!r}"[:300])
        if not isinstance(kwargs, dict) or not all(isinstance(k, str) for k in kwargs):
            raise ValueError(f"kwargs of {command} must be a dict with str keys, got {kwargs!r}"[:300])
        check = getattr(self, f"_check_{command}", None)
        if check is None:
            raise ValueError(f"{type(self).__name__}.{command} has no door check")  # a bug, not user input
        try:
            inspect.signature(check).bind(**kwargs)
        except TypeError as exc:
            raise ValueError(f"{command} arguments do not fit: {exc}") from None
        return check

    def replay(self, log: CommandLog) -> None:
        """Issue every command of ``log`` by name, in order, all or nothing.

        Every event is checked at its door first (against the current state), so a bad one raises ``ValueError``
        before anything is issued. A command whose validity depends on the state the earlier ones built (a crown
        script naming a surface, a stroke move with no stroke open) can still fail while the log runs: then the
        whole state (parameters, :meth:`get_state`, history, log) is rolled back to what it was before the
        replay, observers get one ``"all"`` change, and the error is raised as ``ValueError`` naming the event.
        Autosave writes once, at the end."""
        if not isinstance(log, CommandLog):
            raise ValueError(f"log must be a CommandLog, got {type(log).__name__}")
        log.check(self)
        events = list(log.events)
        if not events:
            return
        with self._lock, self.held():
            saved = self._checkpoint()
            try:
                for i, ev in enumerate(events):
                    try:
                        self.check_command(ev.command, ev.kwargs)
                        getattr(self, ev.command)(**ev.kwargs)
                    except (ValueError, TypeError, OverflowError, ZeroDivisionError) as exc:
                        raise ValueError(f"event {i} ({ev.command}) cannot be applied: {exc}"[:500]) from exc
            except BaseException:
                self._rollback(saved)
                raise

    def _checkpoint(self) -> dict[str, Any]:
        """Everything a replay may change: parameters, the whole state, history, log and
        :meth:`transient_state` (restored by :meth:`_rollback`)."""
        return {"params": self.params, "state": self.get_state(), "history": self.history.copy(),
                "events": list(self.log.events), "transient": self.transient_state(), "after": self._after}

    def _rollback(self, saved: dict[str, Any]) -> None:
        with self._lock:
            self.restore_params(saved["params"])
            self.set_state(saved["state"])
            self.set_transient_state(saved["transient"])
            self.history = saved["history"]
            self.log.events = saved["events"]
            self._after = saved["after"]
        self.changed("all", command="replay", save=False)

    def transient_state(self) -> Any:
        """Hook: state outside :meth:`get_state` that a command may change (an open stroke), for a replay's
        rollback; restored by :meth:`set_transient_state`."""
        return None

    def set_transient_state(self, state: Any) -> None:
        """Hook: restore what :meth:`transient_state` returned."""

    def restore_params(self, values: dict[str, Any]) -> None:
        """Set parameter traits to ``values`` without logging, applying or recording them (a restore of state
        taken earlier; the numeric state is restored with it)."""
        if not values:
            return
        with self._lock:
            was, self._restoring = self._restoring, True
            try:
                with self.hold_trait_notifications():
                    for k, v in values.items():
                        if getattr(self, k) != v:
                            self.set_trait(k, v)
            finally:
                self._restoring = was

    # -- history ----------------------------------------------------------------------------------------
    def _check_undo(self) -> None:
        return None

    def _check_redo(self) -> None:
        return None

    def undo(self):
        """Take back the last operation; returns its atom, or None when there is nothing to undo."""
        return self._travel("undo")

    def redo(self):
        """Apply the last undone operation again; returns its atom, or None."""
        return self._travel("redo")

    def _check_block(self, events, amend: bool = False, _depth: int = 0) -> list[tuple[str, dict]]:
        if not isinstance(amend, (bool, np.bool_)):
            raise ValueError(f"amend must be True or False, got {amend!r:.80}")  # noqa: TRY004
        if _depth > MAX_BLOCK_DEPTH:
            raise ValueError(f"events: history blocks nest at most {MAX_BLOCK_DEPTH} deep")
        if not isinstance(events, (list, tuple)) or not events:
            raise ValueError(f"events must be a non-empty list of [command, kwargs] pairs, got {events!r:.200}")
        out = []
        for i, ev in enumerate(events):
            if (not isinstance(ev, (list, tuple)) or len(ev) != 2 or not isinstance(ev[0], str)
                    or not isinstance(ev[1], dict)):
                raise ValueError(f"events[{i}] must be a [command, kwargs] pair, got {ev!r:.200}")
            command, kwargs = ev
            if command in ("undo", "redo"):
                raise ValueError(f"events[{i}]: a history block cannot hold {command}")
            if command == "block":
                if set(kwargs) - {"events", "amend"}:
                    raise ValueError(f"events[{i}]: block takes events and amend, got {sorted(kwargs)}")
                self._check_block(kwargs.get("events"), kwargs.get("amend", False), _depth + 1)
            else:     # names and arguments here; each door check runs just before its command (it may depend on
                try:  # the state the block's earlier commands build, e.g. a stroke they opened)
                    self._check_signature(command, kwargs)
                except ValueError as exc:
                    raise ValueError(f"events[{i}] ({command}): {exc}"[:500]) from None
            out.append((command, kwargs))
        return out

    def block(self, events, amend: bool = False) -> None:
        """Apply ``events`` (``[[command, kwargs], ...]``, what a :meth:`history_block` logged) as one undo item,
        all or nothing: a command that fails rolls back the ones before it."""
        events = self._check_block(events, amend)
        with self._lock:
            saved = self._checkpoint()
            try:
                with self.history_block(amend=bool(amend)):
                    for command, kwargs in events:
                        self.check_command(command, kwargs)
                        getattr(self, command)(**kwargs)
            except BaseException:
                self._rollback(saved)
                raise

    @contextlib.contextmanager
    def history_block(self, *, amend: bool = False) -> Iterator[None]:
        """Everything the commands inside do is ONE undo item and ONE logged ``block`` command, so undo takes back
        exactly the block and never crosses into an earlier command (napari's ``block_history``).

        The document lock is held for the block (background work waits), an open gesture (a stroke) is ended
        before it and at its end, blocks nest (an inner one joins the outer), and undo or redo inside one is
        refused. With ``amend=True`` the block joins the previous undo item instead (a regrow after the parameter
        change that caused it: one undo restores both). A block that raises keeps what it did, as one item.
        """
        if not isinstance(amend, (bool, np.bool_)):
            raise ValueError(f"amend must be True or False, got {amend!r:.80}")  # noqa: TRY004
        with self._lock:
            if self._blocks:
                self._blocks += 1
                try:
                    yield
                finally:
                    self._blocks -= 1
                return
            self.before_undo()
            start = len(self.log.events)
            self.history.stage()
            self._blocks = 1
            try:
                yield
            finally:
                self._blocks = 0
                self.before_undo()
                self.history.commit(self.fold_atoms, amend=bool(amend))
                inner = self.log.events[start:]
                if inner:
                    del self.log.events[start:]
                    self.log.record("block", events=[[e.command, e.kwargs] for e in inner],
                                    **({"amend": True} if amend else {}))
                self._after = None
                self._sync_undo_traits()

    def fold_atoms(self, atoms: tuple):
        """Hook: the one history item a block's atoms make (default a :class:`~plantvr.history.Group`)."""
        return Group(atoms)

    @contextlib.contextmanager
    def unrecorded(self) -> Iterator[None]:
        """Commands inside change the state without undo items (they are still logged): for a caller that records
        its own item for the whole (one :class:`~plantvr.history.StateAtom` of a regrow). The redo items stay;
        push an item after the block (which clears them) when the state changed."""
        with self._lock:
            self.history.mute()
            try:
                yield
            finally:
                self.history.unmute()
                self._after = None

    def effective_events(self, events=None) -> list[tuple[str, dict[str, Any]]]:
        """The logged commands (``events``: default ``self.log``'s) whose effect the state still holds, in order:
        the log's ``undo`` / ``redo`` are played on a model of the undo stack (one item per command, a ``block`` or a
        ``regrow`` with ``amend`` joining the previous one, :attr:`ITEM_OPENERS` joining the next,
        :attr:`PER_STEP` commands one item per step, :attr:`NO_UNDO_ITEM` commands never undone), so undone items
        are left out and redone ones come back. ``block`` events are kept whole. What a regrow re-issues
        (:meth:`_reissue`).

        Limits: an undo the real history refused (past ``max_undo``, or after a history cleared by a new branching
        mode) and a command that changed nothing (no item) are modelled as if they made one."""
        events = self.log.events if events is None else events
        seq: list[list] = []          # [undoable, [(command, kwargs), ...]] in applied order
        redo: list[list] = []
        pending: list[tuple[str, dict]] = []

        def close_pending():
            if pending:
                seq.append([True, list(pending)])
                pending.clear()

        for ev in events:
            c, kw = ev.command, dict(ev.kwargs)
            if c in ("undo", "redo"):
                close_pending()          # before_undo ends an open stroke: an item of its own
                if c == "undo":
                    i = next((i for i in range(len(seq) - 1, -1, -1) if seq[i][0]), None)
                    if i is not None:
                        redo.append(seq.pop(i))
                elif redo:
                    seq.append(redo.pop())
                continue
            if c in self.ITEM_OPENERS:
                if c == self.ITEM_OPENERS[0]:
                    close_pending()      # a new stroke ends the open one
                pending.append((c, kw))
                continue
            if pending and c in self.JOIN_OPEN:
                pending.append((c, kw))
                continue
            if c in self.NO_UNDO_ITEM:
                seq.append([False, [(c, kw)]])
                continue
            redo.clear()
            if c in ("block", "regrow") and kw.get("amend"):
                i = next((i for i in range(len(seq) - 1, -1, -1) if seq[i][0]), None)
                if i is not None:
                    seq[i][1].append((c, kw))
                    continue
            if c in self.PER_STEP and isinstance(kw.get("steps"), int) and kw["steps"] > 1 and not pending:
                seq.extend([True, [(c, {**kw, "steps": 1})]] for _ in range(kw["steps"]))
                continue
            seq.append([True, [*pending, (c, kw)]])
            pending.clear()
        out = [e for _, evs in seq for e in evs]
        return out + pending

    def _check_regrow(self, amend: bool = False) -> bool:
        if not isinstance(amend, (bool, np.bool_)):
            raise ValueError(f"amend must be True or False, got {amend!r:.80}")  # noqa: TRY004
        return bool(amend)

    def _reissue(self, commands: list[tuple[str, dict[str, Any]]], prepare: Callable[[], None], *, amend: bool,
                 command: str = "regrow", kind: str = "tree") -> int:
        """Run ``prepare()`` (a reset) and ``commands`` again as ONE undo item (a :meth:`history_block`, joining
        the previous item with ``amend``: the parameter change that caused the regrow) holding one
        :class:`~plantvr.history.StateAtom` of the whole state (the re-issued commands keep no atoms of their
        own), logged as one ``command`` (``regrow``), observers notified once; all or nothing."""
        for name, kwargs in commands:
            self.check_command(name, kwargs)
        with self._lock, self.held():
            saved = self._checkpoint()
            start = len(self.log.events)
            try:
                with self.hold_trait_notifications(), self.history_block(amend=amend):
                    before = self.get_state()
                    with self.unrecorded():
                        prepare()
                        for name, kwargs in commands:
                            getattr(self, name)(**kwargs)
                    after = self.get_state()
                    if not _same(before, after):
                        self.history.push(StateAtom(before, after, kind))
                    del self.log.events[start:]         # logged as the one command below
            except BaseException:
                self._rollback(saved)
                raise
            self.log.record(command, **({"amend": True} if amend else {}))
        self.changed(kind, command=command)
        return len(commands)

    def take_history(self, history: History) -> None:
        """Replace the undo history with ``history`` (a scratch copy's after a replay, a loaded file's): the one
        place outside the history module that swaps it (the undo traits follow with the next change)."""
        if not isinstance(history, History):
            raise ValueError(f"history must be a History, got {type(history).__name__}")  # noqa: TRY004
        with self._lock:
            self.history = history
            self._after = None

    def _travel(self, command: str):
        if self._blocks and self._lock._is_owned():
            raise ValueError(f"{command} inside a history block: end the block first")
        with self._lock:
            self.before_undo()
            done = getattr(self.history, command)(self)
            if done is not None:
                self._after = None     # the state changed before its change is published: no cached "before"
            self.log.record(command)
        if done is None:
            self._sync_undo_traits()
            return None
        item, (kind, ids) = done
        self.changed(kind, ids, command=command)
        return item

    def before_undo(self) -> None:
        """Hook: finish an open gesture before undo/redo (ViNE ends an open stroke)."""

    def _sync_undo_traits(self) -> None:
        self.can_undo, self.can_redo = self.history.can_undo, self.history.can_redo

    @contextlib.contextmanager
    def undoable(self, kind: str = "all", *, before: Any = None) -> Iterator[None]:
        """Record what the block does to the whole state as one :class:`~plantvr.history.StateAtom` (for
        operations, like a growth step, whose delta is not practical to keep); nothing when it changed nothing.

        The state after a block is kept with the :attr:`version` it was taken at: a block that starts at that
        same version (nothing changed since, e.g. the next growth step) takes it as its ``before`` instead of
        copying the whole state again, so a run of steps costs one copy per step and consecutive atoms share it.
        ``before`` gives the state before the block instead (a change already made when the block opens).
        """
        cached, self._after = self._after, None
        if before is None:
            before = cached[1] if cached is not None and cached[0] == self._seq else self.get_state()
        yield
        after = self.get_state()
        if not _same(before, after):
            self.history.push(StateAtom(before, after, kind))
        self._after = (self._seq, after)

    def get_state(self) -> Any:
        """The whole state, for a :class:`~plantvr.history.StateAtom` (default: :meth:`state_bytes`)."""
        return self.state_bytes()

    def set_state(self, state: Any) -> None:
        """Replace the whole state with what :meth:`get_state` returned."""
        raise NotImplementedError(f"{type(self).__name__} has no whole-state undo")

    def state_bytes(self) -> bytes:
        """Deterministic bytes of everything a session changes (replay and undo tests compare them)."""
        raise NotImplementedError

    # -- the one change path ----------------------------------------------------------------------------
    def make_snapshot(self) -> Any:
        """Hook: an immutable picture of the state for renderers (None: no snapshot)."""
        return None

    def on_snapshot(self, snapshot: Any) -> None:
        """Hook: set derived traits from a snapshot just applied on the kernel thread."""

    def changed(self, kind: str = "all", ids: np.ndarray | None = None, *, command: str | None = None,
                save: bool = True) -> None:
        """The one path every state change takes: publish a snapshot, bump :attr:`version` and send the
        :class:`Change` on the kernel thread, and autosave (``save``), so no command changes state unseen or
        unsaved. Callable from any thread; changes a slow kernel has not applied yet are merged. ``kind`` is one of
        :attr:`EVENTS` (a programming error otherwise, raised before anything is published)."""
        if kind not in self.EVENTS:
            raise ValueError(f"kind {kind!r} is not declared in {type(self).__name__}.EVENTS {self.EVENTS}")
        with self._lock:        # the snapshot and the version come from the same state, in order
            snap = self.make_snapshot()
            self._seq += 1
            change = Change(kind, None if ids is None else np.asarray(ids), self._seq, command)
            if snap is not None:
                self.latest = snap
            undo = (self.history.can_undo, self.history.can_redo)
            with self._pending_lock:
                scheduled = self._pending is not None
                if scheduled:
                    old_snap, old, _ = self._pending
                    k, merged = _merge([(old.kind, old.ids), (kind, change.ids)])
                    change = Change(k, merged, self._seq, command)
                    snap = old_snap if snap is None else snap
                self._pending = (snap, change, undo)
        if not scheduled:
            self._call_in_kernel(self._apply_pending)
        if save:
            self._autosave()

    def _apply_pending(self) -> None:
        # One applier at a time (the kernel loop, or a worker thread in a script) drains the newest pending change,
        # so snapshot and version are set together and never go back. A thread that finds another applying leaves
        # its change to it (the applier looks again after letting go); nothing here waits on the document lock, so
        # a command holding it can publish while an observer of the previous change runs.
        while True:
            if not self._apply_lock.acquire(blocking=False):
                return
            loop = self._loop
            # in a script (no kernel loop) whatever thread made the change applies it: under the document lock,
            # so its trait updates never interleave with a command's (traitlets objects are not thread-safe)
            guard = self._lock if loop is None or not loop.is_running() else contextlib.nullcontext()
            try:
                while True:
                    with self._pending_lock:
                        pending, self._pending = self._pending, None
                    if pending is None:
                        break
                    snap, change, undo = pending
                    if change.version < self.version:
                        continue
                    with guard:
                        with self.hold_trait_notifications():
                            if snap is not None:
                                self.snapshot = snap
                                self.on_snapshot(snap)
                            self.can_undo, self.can_redo = undo
                            self.version = change.version
                        self.change = change
            finally:
                self._apply_lock.release()
            with self._pending_lock:
                if self._pending is None:
                    return

    def flush(self) -> None:
        """Apply a pending change now (after background work, or from a test)."""
        self._apply_pending()

    def _call_in_kernel(self, fn: Callable[[], None]) -> None:
        loop = self._loop
        if threading.current_thread() is threading.main_thread() or loop is None or not loop.is_running():
            fn()
        else:
            loop.call_soon_threadsafe(fn)

    # -- autosave ---------------------------------------------------------------------------------------
    def save(self, path) -> Path:
        """Write the document to ``path`` atomically. By default the session's command log (JSON lines), which
        :meth:`from_log` replays into the same state; documents with a file format of their own override this."""
        return self.log.save(path)

    @classmethod
    def from_log(cls, path, **init: Any) -> "Document":
        """A new document (``cls(**init)``) with the session saved at ``path`` replayed into it."""
        doc = cls(**init)
        doc.replay(CommandLog.load(path, cls.COMMANDS, document=cls.KIND))
        return doc

    def enable_autosave(self, path) -> Path | None:
        """Save to ``path`` now and after every state-changing command; ``None`` turns it off.

        Each save is atomic. A failed autosave does not stop the command: it warns and sets
        :attr:`autosave_error` (cleared by the next successful one).
        """
        if path is None:
            self._autosave_path = None
            return None
        self.save(path)  # fails here, not later, for a folder that does not exist
        self._autosave_path = Path(path)
        self.autosave_error = None
        return self._autosave_path

    def disable_autosave(self) -> None:
        """Stop autosaving."""
        self._autosave_path = None

    @property
    def autosave_path(self) -> Path | None:
        """Where the document autosaves, or ``None``."""
        return self._autosave_path

    @contextlib.contextmanager
    def held(self) -> Iterator[None]:
        """Defer autosave to the end of the block (one save for a replay or a batch of commands)."""
        self._hold += 1
        try:
            yield
        finally:
            self._hold -= 1
            if not self._hold and self._dirty:
                self._dirty = False
                self._autosave()

    def _autosave(self) -> None:
        path = self._autosave_path
        if path is None:
            return
        if self._hold:
            self._dirty = True
            return
        try:
            self.save(path)
        except (OSError, ValueError) as exc:
            self.autosave_error = f"autosave to {str(path)!r} failed: {exc}"
            warnings.warn(self.autosave_error, RuntimeWarning, stacklevel=3)
        else:
            self.autosave_error = None

    # -- views ------------------------------------------------------------------------------------------
    def scene(self) -> dict[str, Any]:
        """What a view draws: ``{name: content}`` with :class:`~plantvr.types.TreeArrays`,
        :class:`~plantvr.types.TriMesh` (with optional per-vertex ``colors``), :class:`~plantvr.types.Points`
        or :class:`~plantvr.types.Instances` values; :class:`plantvr.View` picks one actor layer per type."""
        return {}


def file_digest(*paths) -> str:
    """SHA-256 (hex) of the bytes of ``paths`` in order: what a logged ``restore`` records beside the path, so a
    replay refuses a file that changed since the session was recorded (issue 30)."""
    h = hashlib.sha256()
    for p in paths:
        try:
            with open(p, "rb") as fh:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
        except OSError as exc:
            raise ValueError(f"cannot read {str(p)!r}: {exc}"[:300]) from None
    return h.hexdigest()


def check_digest(what: str, digest: Any, now: str) -> None:
    """Door check of a logged file load: ``digest`` (None, or what :func:`file_digest` gave when the session was
    recorded) must equal ``now``, else ``ValueError`` naming the file: replay refuses a file that changed."""
    if digest is None:
        return
    if not isinstance(digest, str) or len(digest) != 64:
        raise ValueError(f"digest must be a 64-character SHA-256 hex string, got {digest!r:.80}")
    if digest != now:
        raise ValueError(f"{what} changed since the session was recorded (sha256 {now[:12]}... here, "
                         f"{digest[:12]}... logged): replay refuses a different file"[:300])


def serialise(x: Any, *, skip: frozenset[str] = frozenset()) -> bytes:
    """Deterministic bytes of a nested state (dicts by sorted key, lists, arrays with dtype and shape,
    dataclasses by field; field or key names in ``skip`` — timings, say — left out): what
    :meth:`Document.state_bytes` returns, so replay and undo tests compare whole states."""
    out: list[bytes] = []
    _serialise(x, out, skip)
    return b"".join(out)


def _serialise(x: Any, out: list[bytes], skip: frozenset[str]) -> None:
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        x = {f.name: getattr(x, f.name) for f in dataclasses.fields(x)}
    if isinstance(x, dict):
        keys = sorted((k for k in x if k not in skip), key=repr)
        out.append(b"{%d" % len(keys))
        for k in keys:
            out.append(repr(k).encode())
            _serialise(x[k], out, skip)
    elif isinstance(x, (list, tuple)):
        out.append(b"[%d" % len(x))
        for v in x:
            _serialise(v, out, skip)
    elif isinstance(x, np.ndarray):
        out.append(f"<{x.dtype.str}{x.shape}>".encode())
        out.append(np.ascontiguousarray(x).tobytes())
    else:
        out.append(repr(x).encode())


def _bulky(x: Any) -> bool:
    return isinstance(x, (np.ndarray, dict, list, tuple, bytes))


def _same(a: Any, b: Any) -> bool:
    if a is b:                                             # a shared (read-only) array: nothing to compare
        return True
    if isinstance(a, (bytes, bytearray)) or isinstance(b, (bytes, bytearray)):
        return a == b
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        return a.shape == b.shape and a.dtype == b.dtype and bool(np.array_equal(a, b))
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):       # scalars first: a step changes its counter
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in sorted(a, key=lambda k: _bulky(a[k])))
    return a is b or a == b


def kernel_loop() -> asyncio.AbstractEventLoop | None:
    """The running event loop of the kernel thread (ipykernel), or None in scripts."""
    try:
        return asyncio.get_running_loop()
    except RuntimeError:
        pass
    try:  # ipykernel: the cell runs on the thread of a running loop
        from IPython import get_ipython  # noqa: PLC0415
        if get_ipython() is not None:
            loop = asyncio.get_event_loop_policy().get_event_loop()
            return loop if loop.is_running() else None
    except Exception:  # no IPython / no loop: apply changes directly
        return None
    return None

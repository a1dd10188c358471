"""The Tree Wand document: the one kernel-resident model shared by widgets, the 3D view and the headset
(spec 000_treewand §4.12; DESIGN "Documents").

A :class:`Model` is a :class:`~plantvr.document.Document`: its parameters are traits generated from
:data:`plantvr.params.TREEWAND`; every command validates its arguments, then edits the
:class:`~plantvr.growth.engine.GrowthEngine` under the document's lock, records itself in ``model.log`` and
ends in :meth:`~plantvr.document.Document.changed`, which publishes an immutable :class:`Snapshot` (a
background growth worker never sets a trait itself, STYLE §9). Paint, strokes, markers, prune, growth steps,
reset, restore (a file load, logged with the file's digest) and regrow are undoable: each is one whole-engine-state
atom of ``model.history``. The headset attaches from
outside (``plantvr.vr.attach(model)``).
"""
from __future__ import annotations

import json
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Callable

import numpy as np
from traitlets import Bool, Dict, Float, Int

from .._fileio import read_text, write_atomic
from .._validation import MAX_COORD, MAX_COUNT, check_int, check_point, check_points, check_range
from ..document import Document, check_digest, file_digest, serialise
from ..growth.engine import GrowthEngine, StepStats
from ..growth.treefile import MAX_TREE_BYTES, state_from_npz, state_to_bytes, tree_from_text, tree_to_text
from ..params import TREEWAND
from ..types import Points, TreeArrays

__all__ = ["Model", "Snapshot"]


def _of_tree(name: str, doc: str) -> property:
    """A read-only attribute of a snapshot's tree."""
    return property(lambda self: getattr(self.tree, name), doc=doc)


@dataclass(frozen=True)
class Snapshot:
    """Read-only picture of the model after one change: the live tree as :class:`~plantvr.types.TreeArrays`
    (compacted, parents and main children remapped), markers, buds and the last step's statistics."""

    version: int
    step: int
    tree: TreeArrays
    markers: np.ndarray   # (M, 3)
    stats: StepStats | None
    buds: dict[str, np.ndarray]  # "pos", "dir", "radius", "up" of every bud slot (leaves grow there)

    pos = _of_tree("pos", "(N, 3) node positions; node 0 is the base point.")
    parent = _of_tree("parent", "(N,) int64 parent node, -1 for the base point.")
    radius = _of_tree("radius", "(N,) pipe-model radius of the internode ending at each node.")
    order = _of_tree("order", "(N,) int64 branch order.")
    main_child = _of_tree("main_child", "(N,) int64 snapshot index of each node's main (slot 0) child, -1 if none.")

    @property
    def n_internodes(self) -> int:
        """Number of internodes (nodes except the base point)."""
        return max(len(self.tree) - 1, 0)

    @classmethod
    def from_tree(cls, tree, *, buds: dict[str, np.ndarray] | None = None, markers: np.ndarray | None = None,
                  version: int = 0, step: int = 0, stats: StepStats | None = None) -> "Snapshot":
        """Snapshot of a tree (a :class:`~plantvr.growth.tree.Tree` or a dict of its arrays): live nodes
        compacted, parents and main children remapped (:meth:`TreeArrays.from_tree`). ``buds`` defaults to every
        bud slot with its node's heading as direction."""
        tree = SimpleNamespace(**tree) if isinstance(tree, dict) else tree
        if buds is None:
            node, _ = np.nonzero((tree.child == -1) & tree.alive[:, None])
            buds = {"pos": tree.pos[node], "dir": tree.head[node], "radius": tree.radius[node], "up": tree.lat[node]}
        return cls(version, step, TreeArrays.from_tree(tree), _frozen(np.zeros((0, 3)) if markers is None else markers),
                   stats, {k: _frozen(v) for k, v in buds.items()})


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.flags.writeable = False
    return a


class Model(Document):
    """Tree Wand model: growth parameters, tree, markers, light grid, brush and saved views.

    Parameters
    ----------
    seed : int, optional
        Seed of the random generator (marker darts); same seed + same commands = same tree.
    max_undo : int
        Undo depth, in [1, 10000].
    max_undo_bytes : int
        Byte budget of the undo and redo records (each holds the engine state before and after).
    **params
        Initial parameter values (see :data:`plantvr.params.TREEWAND`).

    Examples
    --------
    >>> import plantvr
    >>> m = plantvr.Model(seed=0)
    >>> m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    >>> _ = m.step(5)
    >>> m.n_internodes > 1
    True
    >>> _ = m.undo()
    >>> m.steps_done
    0
    """

    KIND = "treewand"
    COMMANDS = ("paint", "paint_stroke", "add_markers", "prune", "step", "grow", "set_params", "set_influence",
                "set_prune_mode", "reset", "restore", "regrow", "undo", "redo")
    EVENTS = ("tree", "markers")
    PARAMS = TREEWAND
    NO_UNDO_ITEM = ("set_prune_mode",)
    PER_STEP = ("grow",)
    #: Commands :meth:`regrow` re-issues (what grew the tree since the last reset).
    REGROW_COMMANDS = ("paint", "paint_stroke", "add_markers", "step", "prune")

    n_internodes = Int(1, help="Live internodes in the latest snapshot.")
    n_markers = Int(0, help="Live markers in the latest snapshot.")
    step_ms = Float(0.0, help="Duration of the last growth step, ms.")
    steps_done = Int(0, help="Growth steps since the tree was started.")
    growing = Bool(False, help="True while the background worker grows.")
    prune_mode = Bool(False, help="Brush prunes (red) instead of painting markers (green) (§4.4).")
    saved_views = Dict(help="Named camera views: name -> (position, focal point, view up).")

    def __init__(self, seed: int | None = None, *, max_undo: int = 20, max_undo_bytes: int = 512 * 2 ** 20,
                 **params: Any):
        seed = None if seed is None else check_int("seed", seed, 0, 2**63 - 1)
        super().__init__(max_undo=max_undo, max_undo_bytes=max_undo_bytes, **params)
        self.seed = seed
        self._engine = GrowthEngine(self.params, rng=seed)
        self._worker: threading.Thread | None = None
        self._stop = threading.Event()
        self._snap_seq = 0
        self.snapshot = self.latest = self.make_snapshot()

    # -- parameters ---------------------------------------------------------------------------------
    def set_influence(self, H: float, T: float, E: float) -> None:
        """Set the influence-triangle weights (Eq. 9.5), normalised to H + T + E = 1 (§4.9)."""
        w = self._check_set_influence(H, T, E)
        self.set_params(w_heading=float(w[0]), w_tropism=float(w[1]), w_env=float(w[2]))

    @staticmethod
    def _check_set_influence(H: float, T: float, E: float) -> np.ndarray:
        w = np.array([check_range(n, v, 0.0, np.inf) for n, v in (("H", H), ("T", T), ("E", E))])
        with np.errstate(over="ignore"):
            total = w.sum()
        if total <= 0:
            raise ValueError("influence weights H, T, E must not all be 0")
        if not np.isfinite(total):  # e.g. 1e308 each: scale first so the sum does not overflow
            w = w / w.max()
            total = w.sum()
        return w / total

    @property
    def influence(self) -> tuple[float, float, float]:
        """(H, T, E) weights of Eq. 9.5."""
        return (self.w_heading, self.w_tropism, self.w_env)

    def apply_param(self, name: str, value: Any) -> None:
        """The engine follows a parameter; a new branching mode starts a new tree, which the undo history
        (trees of the other mode) cannot go back across."""
        if name == "branching":
            self._engine.params = self.params
            self._engine.reset()
            self.history.clear()
        else:
            self._engine.set_params({name: value})

    # -- commands -----------------------------------------------------------------------------------
    # Every command checks its arguments with its ``_check_<command>`` (the same checks replay runs on a whole
    # log first), then applies and logs itself under the lock, so the log holds commands in applied order.
    def paint(self, center, radius: float | None = None, n_darts: int | None = None) -> int:
        """Paint markers by Poisson darts in a sphere (§2.2, §4.3); returns how many were added."""
        center, radius, n_darts = self._check_paint(center, radius, n_darts)
        with self._lock, self.undoable("markers"):
            n = self._engine.paint(center, radius, n_darts)
            self.log.record("paint", center=center, radius=radius, n_darts=n_darts)
        self.changed("markers", command="paint")
        return n

    def paint_stroke(self, points, radius: float | None = None, n_darts: int | None = None) -> int:
        """Paint at every point of a stroke (one undo item and one logged command); returns the markers added."""
        pts, radius, n_darts = self._check_paint_stroke(points, radius, n_darts)
        with self._lock, self.undoable("markers"):
            n = sum(self._engine.paint(p, radius, n_darts) for p in pts)
            self.log.record("paint_stroke", points=pts, radius=radius, n_darts=n_darts)
        self.changed("markers", command="paint_stroke")
        return n

    def add_markers(self, points) -> None:
        """Add a marker cloud as it is (imported or scripted), bypassing the darts."""
        pts = self._check_add_markers(points)
        with self._lock, self.undoable("markers"):
            self._engine.add_markers(pts)
            self.log.record("add_markers", points=pts)
        self.changed("markers", command="add_markers")

    def prune_preview(self, center, radius: float) -> np.ndarray:
        """Snapshot-node indices the same :meth:`prune` would remove (§4.4 partial trigger, TW-V17b)."""
        center, radius = self._check_prune(center, radius)
        with self._lock:
            mask = self._engine.prune_preview(center, radius)
            live = np.flatnonzero(self._engine.tree.alive)
            return np.flatnonzero(mask[live])

    def prune(self, center, radius: float) -> int:
        """Remove internodes whose midpoint is in the brush, with their subtrees (§4.4)."""
        center, radius = self._check_prune(center, radius)
        with self._lock, self.undoable("tree"):
            n = self._engine.prune(center, radius)
            self.log.record("prune", center=center, radius=radius)
        self.changed("tree", command="prune")
        return n

    def set_prune_mode(self, on: bool) -> None:
        """Switch the brush between growing (green) and pruning (red) (§4.4, menu item 4); logged."""
        on = self._check_set_prune_mode(on)
        with self._lock:
            self.log.record("set_prune_mode", on=on)
        self.prune_mode = on  # a brush setting, not engine state: its observers run outside the lock

    def reset(self, seed: int | None = None) -> None:
        """Start a new tree: remove every internode, leaving the base (§4.5 item 7); undoable.

        With ``seed``, the random generator restarts too, so the same commands grow the same tree again.
        """
        seed = self._check_reset(seed)
        with self._lock, self.undoable("tree"):
            if seed is not None:
                self.seed = seed
                self._engine.rng = np.random.default_rng(seed)
            self._engine.reset()
            self.log.record("reset", seed=seed)
        self.changed("tree", command="reset")

    def step(self, steps: int = 1) -> list[StepStats]:
        """Run ``steps`` growth steps synchronously (deterministic for a seed): one undo item, logged as one
        ``step`` entry; a snapshot is published after every step."""
        steps = self._check_step(steps)
        out: list[StepStats] = []
        entry = None
        with self._lock:
            if steps == 0:
                self.log.record("step", steps=0)
                return out
            try:
                with self.undoable("tree"):
                    for _ in range(steps):
                        out.append(self._engine.step())
                        entry = self.log.extend("step", entry, "steps")
                        self.changed("tree", command="step", save=False)
            finally:
                self._autosave()
        return out

    def _grow_step(self, entry):
        """One growth step of :meth:`grow`, one undo item, logged as applied (a command made meanwhile on
        another thread lands between the steps) and published; returns its stats and the log entry: consecutive
        steps merge into one ``grow(steps=n)`` entry, which replays as ``n`` undo items, as it was made."""
        with self._lock:
            with self.undoable("tree"):
                st = self._engine.step()
                entry = self.log.extend("grow", entry, "steps")
                self.changed("tree", command="grow", save=False)
        return st, entry

    # -- door checks (shared by the commands and by replay) -------------------------------------------------
    def _check_brush(self, center: np.ndarray, radius: float | None, n_darts: int | None):
        radius = self.brush_radius if radius is None else check_range("radius", radius, 0.0, 1e6, low_open=True)
        if n_darts is not None:
            n_darts = check_int("n_darts", n_darts, 1, 10_000_000)
        reach = float(np.abs(center).max(initial=0.0)) + radius
        if reach > MAX_COORD:
            raise ValueError(f"radius: the brush sphere must lie inside [-{MAX_COORD:g}, {MAX_COORD:g}], got a "
                             f"reach of {reach:g} (radius {radius!r})")
        return radius, n_darts

    def _check_paint(self, center, radius=None, n_darts=None):
        center = check_point("center", center)
        return (center, *self._check_brush(center, radius, n_darts))

    def _check_paint_stroke(self, points, radius=None, n_darts=None):
        pts = check_points("points", points, min_rows=1)
        if len(pts) > MAX_COUNT:
            raise ValueError(f"points must have at most {MAX_COUNT} rows, got {len(pts)}")
        radius, n_darts = self._check_brush(pts, radius, n_darts)
        total = len(pts) * (self.darts_per_paint if n_darts is None else n_darts)
        if total > MAX_COUNT:
            raise ValueError(f"n_darts: a stroke may throw at most {MAX_COUNT} darts in all, got {len(pts)} points "
                             f"x {n_darts if n_darts is not None else self.darts_per_paint} darts = {total}")
        return pts, radius, n_darts

    @staticmethod
    def _check_add_markers(points):
        pts = check_points("points", points)
        if len(pts) > MAX_COUNT:
            raise ValueError(f"points must have at most {MAX_COUNT} rows, got {len(pts)}")
        return pts

    @staticmethod
    def _check_prune(center, radius):
        return check_point("center", center), check_range("radius", radius, 0.0, 1e6)

    @staticmethod
    def _check_set_prune_mode(on):
        if not isinstance(on, (bool, np.bool_)):
            raise ValueError(f"on must be True or False, got {on!r}")
        return bool(on)

    @staticmethod
    def _check_reset(seed=None):
        return None if seed is None else check_int("seed", seed, 0, 2**63 - 1)

    @staticmethod
    def _check_step(steps=1):
        return check_int("steps", steps, 0, 10_000_000)

    @staticmethod
    def _check_grow(steps):
        """Door check of a logged ``grow`` (replayed synchronously: one undo item per step, as it was made)."""
        return check_int("steps", steps, 0, 10_000_000)

    # -- regrow -------------------------------------------------------------------------------------------
    def regrow_commands(self) -> list[tuple[str, dict[str, Any]]]:
        """What :meth:`regrow` re-issues: the :data:`REGROW_COMMANDS` whose effect the tree still holds (undone
        ones left out, :meth:`~plantvr.document.Document.effective_events`) since the last ``reset``; none when a
        ``restore`` came after it (a loaded tree is not regrown)."""
        events = self.effective_events()
        start = max((i for i, (c, _) in enumerate(events) if c in ("reset", "restore")), default=-1)
        if start >= 0 and events[start][0] == "restore":
            return []
        return [(c, kw) for c, kw in events[start + 1:] if c in self.REGROW_COMMANDS]

    def regrow(self, amend: bool = False) -> int:
        """Grow the tree again with the current parameters: ``reset(seed=seed)``, then :meth:`regrow_commands`
        re-issued in order (the same darts and step count). One undo item (with ``amend``: joined to the previous
        one, the parameter change that caused it, so one undo restores both), logged as one ``regrow`` command,
        one change. Returns the number of commands re-issued (0, changing nothing, when there is nothing to
        regrow)."""
        amend = self._check_regrow(amend)
        if self.growing:
            self.stop()
        with self._lock:           # the commands and their re-issue see the same log
            commands = self.regrow_commands()
            if not commands:
                return 0
            return self._reissue(commands, lambda: self.reset(seed=self.seed), amend=amend)

    # -- background growth --------------------------------------------------------------------------
    def grow(self, steps: int, *, background: bool = False, progress: bool = False,
             on_step: Callable[[StepStats], None] | None = None) -> threading.Thread | list[StepStats]:
        """Grow ``steps`` steps, one undo item each; with ``background=True`` on a worker thread (returned), else
        synchronously."""
        steps = self._check_step(steps)
        for name, v in (("background", background), ("progress", progress)):
            if not isinstance(v, (bool, np.bool_)):
                raise ValueError(f"{name} must be True or False, got {v!r}")
        if on_step is not None and not callable(on_step):
            raise ValueError(f"on_step must be a callable or None, got {type(on_step).__name__}")
        if not background:
            stats = []
            entry = None
            try:
                for _ in _progress(range(steps), progress):
                    st, entry = self._grow_step(entry)
                    stats.append(st)
                    if on_step:
                        on_step(st)
            finally:
                if stats:
                    self._autosave()
            return stats
        if self._worker is not None and self._worker.is_alive():
            raise RuntimeError("growth is already running; call model.stop() first")
        self._stop.clear()
        self.growing = True

        def work() -> None:
            entry = None
            try:
                for _ in _progress(range(steps), progress):
                    if self._stop.is_set():
                        break
                    st, entry = self._grow_step(entry)
                    self._autosave()                 # outside the lock: commands are not held up by the write
                    if on_step:
                        on_step(st)
            finally:
                self._call_in_kernel(lambda: setattr(self, "growing", False))

        self._worker = threading.Thread(target=work, name="plantvr-growth", daemon=True)
        self._worker.start()
        return self._worker

    def stop(self) -> None:
        """Stop background growth after the current step."""
        self._stop.set()
        self.wait()

    def wait(self, timeout: float | None = None) -> None:
        """Block until background growth ends, then apply the latest snapshot."""
        if timeout is not None:
            timeout = check_range("timeout", timeout, 0.0, 1e9)
        if self._worker is not None:
            self._worker.join(timeout)
        self.growing = bool(self._worker and self._worker.is_alive())
        self.flush()

    # -- snapshots and state ------------------------------------------------------------------------
    def make_snapshot(self) -> Snapshot:
        """The engine's live tree, markers and buds as a :class:`Snapshot` (versions count snapshots)."""
        with self._lock:
            e = self._engine
            t, b = e.tree, e.buds()
            # the bud arrays are fresh gathers: frozen in place, not copied again; the markers are shared as a
            # read-only view (the engine replaces its marker array on every change and never writes one in place),
            # so publishing 200k markers costs nothing (issue 24)
            buds = {"pos": b.pos, "dir": b.dir, "radius": t.radius[b.node], "up": t.lat[b.node]}
            for v in buds.values():
                v.flags.writeable = False
            markers = e.markers.view()
            markers.flags.writeable = False
            self._snap_seq += 1
            return Snapshot(self._snap_seq, e.step_count, TreeArrays.from_tree(t), markers,
                            e.history[-1] if e.history else None, buds)

    def on_snapshot(self, snap: Snapshot) -> None:
        self.n_internodes = snap.n_internodes
        self.n_markers = len(snap.markers)
        self.steps_done = snap.step
        if snap.stats is not None:
            self.step_ms = snap.stats.ms

    def scene(self) -> dict[str, Any]:
        """``{"tree": TreeArrays, "markers": Points}`` of the newest snapshot."""
        snap = self.latest
        return {"tree": snap.tree, "markers": Points(snap.markers)}

    def get_state(self) -> dict[str, Any]:
        """The parameters, the seed and the engine's whole state (:meth:`GrowthEngine.get_state`), for undo atoms
        (a parameter change is one, restoring the parameter with what it changed)."""
        with self._lock:   # the parameters as the engine follows them (a trait set on another thread is not yet)
            e = self._engine
            return {"params": {k: e.params[k] for k in self.PARAMS.names}, "seed": self.seed,
                    "engine": e.get_state()}

    def set_state(self, state: dict[str, Any]) -> None:
        with self._lock:
            self.seed = state["seed"]
            if "params" in state:
                self.restore_params(state["params"])
            self._engine.params = dict(state["engine"]["params"])   # what the state's light and vigor used
            self._engine.set_state(state["engine"])

    def state_bytes(self) -> bytes:
        """Parameters, seed and engine state as deterministic bytes (step timings left out)."""
        with self._lock:
            return serialise({"params": self.params, **self.get_state()}, skip=frozenset({"ms"}))

    # -- persistence --------------------------------------------------------------------------------
    @property
    def step_stats(self) -> list[StepStats]:
        """Statistics of every growth step since the tree was started."""
        return list(self._engine.history)

    @property
    def tree(self):
        """The engine's tree (read it; change it only through commands)."""
        return self._engine.tree

    def save(self, path: str | Path) -> Path:
        """Save to ``.tree`` (bracketed text + parameters, §4.5) or ``.npz`` (lossless full state), atomically:
        a save that fails half way leaves the previous file as it was (:mod:`plantvr._fileio`)."""
        path = _check_path(path)
        with self._lock:  # serialised and written under the lock: autosaves from the worker never interleave
            if path.suffix == ".tree":
                write_atomic(path, tree_to_text(self._engine.tree, self.params))
            else:
                e = self._engine
                write_atomic(path, state_to_bytes(e.tree, self.params, {
                    "markers": e.markers, "marker_age": e.marker_age, "step_count": np.array(e.step_count, np.int64),
                    "rng_state": np.array(_json_rng(e.rng)), "new_nodes": np.asarray(e._new_nodes, np.int64)}))
        return path

    # -- loading --------------------------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path, seed: int | None = None) -> "Model":
        """Return a new model loaded from a ``.tree`` or ``.npz`` file."""
        m = cls(seed=seed)
        m.restore(path)
        return m

    def _check_restore(self, path, digest: str | None = None) -> tuple[Path, str]:
        """Door check of :meth:`restore`: the path (made absolute, so a log replays from any folder) and the
        file's digest now, which must equal a logged ``digest``."""
        path = _check_path(path).absolute()
        if not path.is_file():
            what = "cannot load" if path.suffix == ".tree" else "cannot read PlantVR state"
            raise ValueError(f"{what} {str(path)!r}: no such file")
        now = file_digest(path)
        check_digest(f"file {str(path)!r}", digest, now)
        return path, now

    def restore(self, path: str | Path, digest: str | None = None) -> None:
        """Replace this model's tree and parameters with a saved file's: one undo item, logged as
        ``restore(path, digest)``; on any error nothing changes.

        Every file is checked in full first (format version, checksum, size caps, every array: see
        :mod:`plantvr.growth.treefile`); a bad one raises ``ValueError`` naming the file and the problem. The log
        records the absolute path and the SHA-256 of the bytes loaded: a replay loads the same file again and is
        refused (``ValueError`` at its door, before anything is issued) when the file's bytes differ, so a replay
        either reproduces the same state or changes nothing. ``digest`` (what a log holds) must match the file.
        """
        path, digest = self._check_restore(path, digest)
        extra: dict[str, np.ndarray] = {}
        if path.suffix == ".tree":
            try:
                tree, params = tree_from_text(read_text(path, what="tree file", max_bytes=MAX_TREE_BYTES))
            except ValueError as exc:
                raise ValueError(f"cannot load {path!s}: {exc}") from None
        else:
            tree, params, extra = state_from_npz(path)
        engine = GrowthEngine({**self.params, **params}, rng=self.seed)  # parsed fully before touching self
        engine.tree = tree
        if extra:
            try:
                engine.rng.bit_generator.state = _unjson_rng(str(extra["rng_state"]))
            except (ValueError, TypeError, KeyError, AttributeError, OverflowError, RecursionError) as exc:
                raise ValueError(f"PlantVR state {str(path)!r}: member 'rng_state' is not a random generator "
                                 f"state ({exc})"[:300]) from None
            engine.markers, engine.marker_age = extra["markers"], extra["marker_age"]
            engine.step_count = int(extra["step_count"])
        saved = {k: getattr(tree, k).copy() for k in _DERIVED}
        engine.rebuild_light()
        engine._new_nodes = extra["new_nodes"] if extra else np.zeros(0, np.int64)
        if extra and all(np.allclose(getattr(tree, k), v, rtol=1e-9, atol=1e-9) for k, v in saved.items()):
            for k, v in saved.items():  # the saved light and vigor (the rebuilt shadow grid sums in another order)
                getattr(tree, k)[:] = v
        if file_digest(path) != digest:
            raise ValueError(f"cannot load {str(path)!r}: the file changed while it was read")
        with self._lock, self.undoable("all"):
            self.restore_params(params)
            self._engine = engine
            self.log.record("restore", path=str(path), digest=digest)
        self.changed("all", command="restore")


#: Tree fields :meth:`GrowthEngine.rebuild_light` recomputes; an ``.npz`` restores its saved values when they
#: agree with the recomputation (so a loaded state re-saves to the same bytes).
_DERIVED = ("L", "Q", "Qw", "Qslot", "vigor", "bud_vigor", "radius")


def _check_path(path) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or path-like ending in .tree or .npz, got {type(path).__name__}")
    try:
        path = Path(path)
    except TypeError:
        raise ValueError(f"path must be a str or path-like ending in .tree or .npz, got {path!r}") from None
    if path.suffix not in (".tree", ".npz"):
        raise ValueError(f"path must end in .tree or .npz, got {path.suffix!r}")
    return path


def _json_rng(rng: np.random.Generator) -> str:
    return json.dumps(rng.bit_generator.state)


def _unjson_rng(s: str) -> dict:
    state = json.loads(s)
    if not isinstance(state, dict):
        raise ValueError(f"expected a JSON object, got {type(state).__name__}")
    return state


def _progress(it, show: bool):
    if not show:
        return it
    from tqdm.auto import tqdm  # noqa: PLC0415
    return tqdm(it, desc="growing", unit="step")

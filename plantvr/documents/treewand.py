"""The one kernel-resident model shared by widgets, the 3D view and the VR bridge (spec 000_treewand §4.12).

Parameters are traits generated from :mod:`plantvr.params`; commands validate, then edit the
:class:`~plantvr.growth.engine.GrowthEngine` under a lock; after every change an immutable
:class:`Snapshot` is published. A background growth worker never sets a trait itself: it hands the
snapshot to the kernel's event loop (STYLE §9), and views observe ``version``.
"""
from __future__ import annotations

import asyncio
import inspect
import json
import os
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
from traitlets import Bool, Dict, Float, HasTraits, Int, TraitType

from .._fileio import write_atomic
from .._validation import MAX_COORD, MAX_COUNT, check_int, check_point, check_points, check_range
from ..commandlog import CommandLog, Event
from ..growth.engine import GrowthEngine, StepStats
from ..growth.treefile import MAX_TREE_BYTES, state_from_npz, state_to_bytes, tree_from_text, tree_to_text
from ..params import PARAMS, Param, validate

__all__ = ["Model", "Snapshot"]

REPLAYABLE = ("paint", "paint_stroke", "add_markers", "prune", "step", "set_params", "set_influence", "set_prune_mode",
              "reset")


class ParamTrait(TraitType):
    """A trait whose default, type and range come from one :class:`~plantvr.params.Param`."""

    def __init__(self, param: Param):
        super().__init__(default_value=param.default, help=param.doc)
        self.param = param
        self.tag(param=param, window=param.window)

    def validate(self, obj, value):
        return self.param.check(value)


_Params = type("_Params", (HasTraits,), {p.name: ParamTrait(p) for p in PARAMS})


@dataclass(frozen=True)
class Snapshot:
    """Read-only picture of the model after one change: live nodes compacted, parents remapped."""

    version: int
    step: int
    pos: np.ndarray       # (N, 3) node positions; node 0 is the base point
    parent: np.ndarray    # (N,) int64, -1 for the base point
    radius: np.ndarray    # (N,) pipe-model radius of the internode ending at each node
    order: np.ndarray     # (N,) branch order
    markers: np.ndarray   # (M, 3)
    stats: StepStats | None
    main_child: np.ndarray  # (N,) int64 snapshot index of each node's main (slot 0) child, -1 if none
    buds: dict[str, np.ndarray]  # "pos", "dir", "radius", "up" of every bud slot (leaves grow there)

    @property
    def n_internodes(self) -> int:
        """Number of internodes (nodes except the base point)."""
        return max(len(self.pos) - 1, 0)

    @classmethod
    def from_tree(cls, tree, *, buds: dict[str, np.ndarray] | None = None, markers: np.ndarray | None = None,
                  version: int = 0, step: int = 0, stats: StepStats | None = None) -> "Snapshot":
        """Snapshot of a tree (a :class:`~plantvr.growth.tree.Tree` or a dict of its arrays): live nodes
        compacted, parents and main children remapped. ``buds`` defaults to every bud slot with its node's
        heading as direction."""
        get = tree.__getitem__ if isinstance(tree, dict) else lambda k: getattr(tree, k)
        alive, child = get("alive"), get("child")
        live = np.flatnonzero(alive)
        remap = np.full(len(alive), -1, np.int64)
        remap[live] = np.arange(len(live))
        par, main = get("parent")[live], child[live, 0]
        par = np.where(par >= 0, remap[np.maximum(par, 0)], -1)
        main = np.where(main >= 0, remap[np.maximum(main, 0)], -1)
        if buds is None:
            node, _ = np.nonzero((child == -1) & alive[:, None])
            buds = {"pos": get("pos")[node], "dir": get("head")[node], "radius": get("radius")[node],
                    "up": get("lat")[node]}
        return cls(version, step, _frozen(get("pos")[live]), _frozen(par), _frozen(get("radius")[live]),
                   _frozen(get("order")[live]), _frozen(np.zeros((0, 3)) if markers is None else markers), stats,
                   _frozen(main), {k: _frozen(v) for k, v in buds.items()})


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.flags.writeable = False
    return a


class Model(_Params):
    """Tree Wand model: growth parameters, tree, markers, light grid, brush and saved views.

    Parameters
    ----------
    seed : int, optional
        Seed of the random generator (marker darts); same seed + same commands = same tree.
    **params
        Initial parameter values (see :data:`plantvr.params.PARAMS`).

    Examples
    --------
    >>> import plantvr
    >>> m = plantvr.Model(seed=0)
    >>> m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    >>> _ = m.step(5)
    >>> m.n_internodes > 1
    True
    """

    COMMANDS = REPLAYABLE

    version = Int(0, help="Bumped after every change; views observe it.")
    n_internodes = Int(1, help="Live internodes in the latest snapshot.")
    n_markers = Int(0, help="Live markers in the latest snapshot.")
    step_ms = Float(0.0, help="Duration of the last growth step, ms.")
    steps_done = Int(0, help="Growth steps since the tree was started.")
    growing = Bool(False, help="True while the background worker grows.")
    prune_mode = Bool(False, help="Brush prunes (red) instead of painting markers (green) (§4.4).")
    saved_views = Dict(help="Named camera views: name -> (position, focal point, view up).")

    def __init__(self, seed: int | None = None, **params: Any):
        seed = None if seed is None else check_int("seed", seed, 0, 2**63 - 1)
        checked = validate(params)
        super().__init__(**checked)
        self.seed = seed
        self.events = CommandLog(REPLAYABLE, document="treewand")
        self._lock = threading.RLock()
        self._batch: int | None = None   # thread setting traits in set_params: the observer applies, logs nothing
        self._restoring = False          # restore() sets the traits of an engine it built itself
        self._autosave_path: Path | None = None
        self.autosave_error: str | None = None
        self._engine = GrowthEngine(self.params, rng=seed)
        self._worker: threading.Thread | None = None
        self._stop = threading.Event()
        self._loop = _kernel_loop()
        self._pending: Snapshot | None = None
        self.snapshot: Snapshot = self._make_snapshot(None)
        self.observe(self._on_param, names=[p.name for p in PARAMS])

    # -- parameters ---------------------------------------------------------------------------------
    @property
    def params(self) -> dict[str, Any]:
        """Current parameter values, ``{name: value}``."""
        return {p.name: getattr(self, p.name) for p in PARAMS}

    def set_params(self, **params: Any) -> None:
        """Set several parameters at once; all are checked before any is set. Logged as one command."""
        checked = self._check_set_params(**params)
        with self._lock:
            self._batch = threading.get_ident()
            try:
                with self.hold_trait_notifications():
                    for k, v in checked.items():
                        setattr(self, k, v)
            finally:
                self._batch = None
            self.events.record("set_params", **checked)
        self._autosave()

    def set_influence(self, H: float, T: float, E: float) -> None:
        """Set the influence-triangle weights (Eq. 9.5), normalised to H + T + E = 1 (§4.9)."""
        w = self._check_set_influence(H, T, E)
        self.set_params(w_heading=float(w[0]), w_tropism=float(w[1]), w_env=float(w[2]))

    @staticmethod
    def _check_set_params(**params: Any) -> dict[str, Any]:
        return validate(params)

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

    def _on_param(self, change) -> None:
        if self._restoring:
            return  # restore() built its engine with these values already
        with self._lock:
            if change["name"] == "branching":
                self._engine.params = self.params
                self._engine.reset()
            else:
                self._engine.set_params({change["name"]: change["new"]})
            direct = self._batch != threading.get_ident()
            if direct:  # a trait set directly (a slider): logged like set_params, so replay sees it
                self.events.record("set_params", **{change["name"]: change["new"]})
        self._publish()
        if direct:
            self._autosave()

    # -- commands -----------------------------------------------------------------------------------
    # Every command checks its arguments with its ``_check_<command>`` (the same checks replay runs on a whole
    # log first), then applies and logs itself under the lock, so the log holds commands in applied order.
    def paint(self, center, radius: float | None = None, n_darts: int | None = None) -> int:
        """Paint markers by Poisson darts in a sphere (§2.2, §4.3); returns how many were added."""
        center, radius, n_darts = self._check_paint(center, radius, n_darts)
        with self._lock:
            n = self._engine.paint(center, radius, n_darts)
            self.events.record("paint", center=center, radius=radius, n_darts=n_darts)
        self._commit()
        return n

    def paint_stroke(self, points, radius: float | None = None, n_darts: int | None = None) -> int:
        """Paint at every point of a stroke (one undo/event unit); returns the markers added."""
        pts, radius, n_darts = self._check_paint_stroke(points, radius, n_darts)
        with self._lock:
            n = sum(self._engine.paint(p, radius, n_darts) for p in pts)
            self.events.record("paint_stroke", points=pts, radius=radius, n_darts=n_darts)
        self._commit()
        return n

    def add_markers(self, points) -> None:
        """Add a marker cloud as it is (imported or scripted), bypassing the darts."""
        pts = self._check_add_markers(points)
        with self._lock:
            self._engine.add_markers(pts)
            self.events.record("add_markers", points=pts)
        self._commit()

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
        with self._lock:
            n = self._engine.prune(center, radius)
            self.events.record("prune", center=center, radius=radius)
        self._commit()
        return n

    def set_prune_mode(self, on: bool) -> None:
        """Switch the brush between growing (green) and pruning (red) (§4.4, menu item 4); logged."""
        on = self._check_set_prune_mode(on)
        with self._lock:
            self.events.record("set_prune_mode", on=on)
        self.prune_mode = on  # a brush setting, not engine state: its observers run outside the lock

    def reset(self, seed: int | None = None) -> None:
        """Start a new tree: remove every internode, leaving the base (§4.5 item 7).

        With ``seed``, the random generator restarts too, so the same commands grow the same tree again.
        """
        seed = self._check_reset(seed)
        with self._lock:
            if seed is not None:
                self.seed = seed
                self._engine.rng = np.random.default_rng(seed)
            self._engine.reset()
            self.events.record("reset", seed=seed)
        self._commit()

    def step(self, steps: int = 1) -> list[StepStats]:
        """Run ``steps`` growth steps synchronously (deterministic for a seed); logged as one ``step`` entry
        unless another thread's command lands between two of the steps."""
        steps = self._check_step(steps)
        if steps == 0:
            with self._lock:
                self.events.record("step", steps=0)
            return []
        out: list[StepStats] = []
        entry = None
        try:
            for _ in range(steps):
                with self._lock:
                    out.append(self._engine.step())
                    entry = self._log_step(entry)
                self._publish()
        finally:
            self._autosave()
        return out

    def _log_step(self, entry: Event | None) -> Event:
        """Log one applied growth step (under the lock): added to ``entry`` while it is the newest event."""
        ev = self.events.events
        if entry is not None and ev and ev[-1] is entry:
            entry.kwargs["steps"] += 1
            return entry
        return self.events.record("step", steps=1)

    # -- door checks (shared by the commands and by replay) -------------------------------------------------
    def check_command(self, command: str, kwargs: dict[str, Any]) -> None:
        """Raise ``ValueError`` unless ``getattr(self, command)(**kwargs)`` passes the door checks (nothing is
        changed); :meth:`CommandLog.replay <plantvr.commandlog.CommandLog.replay>` checks a whole log this way first."""
        if command not in REPLAYABLE:
            raise ValueError(f"command must be one of {list(REPLAYABLE)}, got {command!r}"[:300])
        if not isinstance(kwargs, dict) or not all(isinstance(k, str) for k in kwargs):
            raise ValueError(f"kwargs of {command} must be a dict with str keys, got {kwargs!r}"[:300])
        check = getattr(self, f"_check_{command}")
        try:
            inspect.signature(check).bind(**kwargs)
        except TypeError as exc:
            raise ValueError(f"{command} arguments do not fit: {exc}") from None
        check(**kwargs)

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

    # -- background growth --------------------------------------------------------------------------
    def grow(self, steps: int, *, background: bool = False, progress: bool = False,
             on_step: Callable[[StepStats], None] | None = None) -> threading.Thread | list[StepStats]:
        """Grow ``steps`` steps; with ``background=True`` on a worker thread (returned), else synchronously."""
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
                    with self._lock:
                        stats.append(self._engine.step())
                        entry = self._log_step(entry)
                    self._publish()
                    if on_step:
                        on_step(stats[-1])
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
                    with self._lock:  # logged as applied: a paint made meanwhile lands between the steps
                        st = self._engine.step()
                        entry = self._log_step(entry)
                    self._commit()
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
        self._apply(self._make_snapshot(self._last_stats()))

    # -- snapshots ----------------------------------------------------------------------------------
    def _last_stats(self) -> StepStats | None:
        h = self._engine.history
        return h[-1] if h else None

    def _make_snapshot(self, stats: StepStats | None) -> Snapshot:
        with self._lock:
            t = self._engine.tree
            b = self._engine.buds()
            buds = {"pos": b.pos, "dir": b.dir, "radius": t.radius[b.node], "up": t.lat[b.node]}
            self._seq = getattr(self, "_seq", 0) + 1
            return Snapshot.from_tree(t, buds=buds, markers=self._engine.markers, version=self._seq,
                                      step=self._engine.step_count, stats=stats)

    def _commit(self) -> None:
        """After a state-changing command: publish the snapshot, then autosave."""
        self._publish()
        self._autosave()

    def _publish(self) -> None:
        """Hand the newest snapshot to the kernel thread; snapshots a slow observer has not taken yet are
        replaced, never queued (views render the latest complete snapshot, DESIGN)."""
        snap = self._make_snapshot(self._last_stats())
        with self._lock:
            scheduled, self._pending = self._pending is not None, snap
        if not scheduled:
            self._call_in_kernel(self._apply_pending)

    def _apply_pending(self) -> None:
        with self._lock:
            snap, self._pending = self._pending, None
        if snap is not None:
            self._apply(snap)

    def _call_in_kernel(self, fn: Callable[[], None]) -> None:
        loop = self._loop
        if threading.current_thread() is threading.main_thread() or loop is None or not loop.is_running():
            fn()
        else:
            loop.call_soon_threadsafe(fn)

    def _apply(self, snap: Snapshot) -> None:
        if snap.version < self.snapshot.version:
            return  # a newer snapshot was applied already
        self.snapshot = snap
        with self.hold_trait_notifications():
            self.n_internodes = snap.n_internodes
            self.n_markers = len(snap.markers)
            self.steps_done = snap.step
            if snap.stats is not None:
                self.step_ms = snap.stats.ms
            self.version = snap.version

    # -- persistence --------------------------------------------------------------------------------
    @property
    def history(self) -> list[StepStats]:
        """Statistics of every growth step since the tree was started."""
        return list(self._engine.history)

    @property
    def vr(self):
        """Headset mode for this model: ``model.vr.start()`` / ``model.vr.stop()`` (OpenVR bridge thread)."""
        from ..vr import attach  # noqa: PLC0415  (UI layer, imported on first use)
        return attach(self)

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

    # -- autosave -------------------------------------------------------------------------------------------
    def enable_autosave(self, path: str | Path | None) -> Path | None:
        """Save to ``path`` (``.tree`` or ``.npz``) now and after every state-changing command (paint, stroke,
        markers, prune, step and each background growth step, parameters, reset, restore); ``None`` turns it off.

        Each save is atomic. A failed autosave does not stop the command: it warns and sets
        :attr:`autosave_error` (cleared by the next successful one).
        """
        if path is None:
            self._autosave_path = None
            return None
        path = _check_path(path)
        self.save(path)  # fails here, not later, for a folder that does not exist
        self._autosave_path = path
        self.autosave_error = None
        return path

    def disable_autosave(self) -> None:
        """Stop autosaving."""
        self._autosave_path = None

    @property
    def autosave_path(self) -> Path | None:
        """Where the model autosaves, or ``None``."""
        return self._autosave_path

    def _autosave(self) -> None:
        path = self._autosave_path
        if path is None:
            return
        try:
            self.save(path)
        except (OSError, ValueError) as exc:
            self.autosave_error = f"autosave to {str(path)!r} failed: {exc}"
            warnings.warn(self.autosave_error, RuntimeWarning, stacklevel=3)
        else:
            self.autosave_error = None

    # -- loading --------------------------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path, seed: int | None = None) -> "Model":
        """Return a new model loaded from a ``.tree`` or ``.npz`` file."""
        m = cls(seed=seed)
        m.restore(path)
        return m

    def restore(self, path: str | Path) -> None:
        """Replace this model's tree and parameters with a saved file's; on any error nothing changes.

        Every file is checked in full first (format version, checksum, size caps, every array: see
        :mod:`plantvr.growth.treefile`); a bad one raises ``ValueError`` naming the file and the problem.
        """
        path = _check_path(path)
        extra: dict[str, np.ndarray] = {}
        if path.suffix == ".tree":
            try:
                with open(path, "rb") as fh:
                    size = os.fstat(fh.fileno()).st_size
                    raw = fh.read(min(size, MAX_TREE_BYTES) + 1)
                if len(raw) > MAX_TREE_BYTES:
                    raise ValueError(f"larger than the cap of {MAX_TREE_BYTES} bytes")
                tree, params = tree_from_text(raw.decode("utf-8"))
            except UnicodeDecodeError:
                raise ValueError(f"cannot load {path!s}: not UTF-8 text (damaged?)") from None
            except (OSError, ValueError) as exc:
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
        with self._lock:
            self._restoring = True
            try:
                with self.hold_trait_notifications():
                    for k, v in params.items():
                        self.set_trait(k, v)
            finally:
                self._restoring = False
            self._engine = engine
        self._commit()


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


def _kernel_loop() -> asyncio.AbstractEventLoop | None:
    try:
        return asyncio.get_running_loop()
    except RuntimeError:
        pass
    try:  # ipykernel: the cell runs on the thread of a running loop
        from IPython import get_ipython  # noqa: PLC0415
        if get_ipython() is not None:
            loop = asyncio.get_event_loop_policy().get_event_loop()
            return loop if loop.is_running() else None
    except Exception:  # no IPython / no loop: apply snapshots directly
        return None
    return None


def _progress(it, show: bool):
    if not show:
        return it
    from tqdm.auto import tqdm  # noqa: PLC0415
    return tqdm(it, desc="growing", unit="step")

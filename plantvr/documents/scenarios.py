"""Replayable stroke files of the thesis scenarios, Figs. 12.1–12.7 (spec 000_treewand §6.1, §6.2; checklist item
32; TW-V23).

A stroke file (``plantvr/documents/scenario_files/<name>.jsonl``) is a Tree Wand command log
(:class:`~plantvr.commandlog.CommandLog`, the one log format): a session from a fresh model that sets the
parameters the thesis states for a figure (``set_params``), starts the tree with the scenario's seed
(``reset``), then issues the commands of its wand session (``paint`` stamps, ``step``, ``set_params``). The
files are recorded from the session functions of :mod:`plantvr.growth.scenarios` by :func:`record_scenario`
(a test checks they have not drifted); the figure, title and notes of each come from :data:`SCENARIOS`.
:func:`replay_scenario` puts the model's parameters back to the defaults and issues every command, so a replay
is deterministic and ends in the same tree as ``Model(seed, **params)`` fed the same commands
(:class:`plantvr.ui.strokes.ScenarioPicker` is its dropdown).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._validation import check_choice, check_int
from ..commandlog import CommandLog, Event
from ..growth import scenarios as S
from ..params import defaults, validate
from .treewand import Model

__all__ = ["SCENARIOS", "SCENARIO_DIR", "Scenario", "list_scenarios", "load_scenario",
           "read_scenario", "record_scenario", "replay_scenario", "save_scenario"]

SCENARIO_DIR = Path(__file__).resolve().parent / "scenario_files"
#: File suffix of stroke files.
SUFFIX = ".jsonl"


@dataclass(frozen=True)
class _Spec:
    figure: str
    title: str
    notes: str
    params: dict[str, Any]
    session: Callable[[], S.Session]
    steps: int
    param_changes: dict[int, dict[str, Any]] = field(default_factory=dict)


_BROAD = dict(branch_angle=60.0, main_branch_angle=20.0, tropism_angle=90.0, w_heading=0.2, w_tropism=0.1,
              w_env=0.7, view_angle=180.0)

#: The scenarios: only the parameters the thesis states (spec §6.1 table); values for "decreased"/"high" are
#: [INFERRED]. Everything else keeps its default.
SCENARIOS: dict[str, _Spec] = {
    "fig12_1": _Spec("12.1", "Well-defined main trunk (fast sweep)",
                     "Tropism 90° for orders >= 1; the trunk stroke, then the brush quickly swept up the trunk.",
                     dict(tropism_angle=90.0, tropism_min_order=1), lambda: S.sweep_session(10, 4), 40),
    "fig12_1_slow": _Spec("12.1", "Main trunk, slow sweep (the lowest laterals run to the top)",
                          "As Fig. 12.1 with the sweep made slowly.",
                          dict(tropism_angle=90.0, tropism_min_order=1), lambda: S.sweep_session(10, 24), 40),
    "fig12_2": _Spec("12.2", "Two well-established main branches",
                     "Lower shadow decay exponent (β 0.5 → 0.3); a 'Y' with a small brush, then a larger brush on top.",
                     dict(shadow_falloff=0.3), lambda: S.y_session(), 40),
    "fig12_3": _Spec("12.3", "Columnar tree",
                     "Narrow view angle (40°), vertical tropism (0°), high environment weight.",
                     dict(view_angle=40.0, tropism_angle=0.0, w_heading=0.2, w_tropism=0.2, w_env=0.6),
                     lambda: S.sweep_session(8, 20), 40),
    "fig12_4": _Spec("12.4", "Small tree with winding branches",
                     "Larger lateral and main branching angles, tropism 90°, high E, view angle 180°; broad "
                     "motions filling the crown, then a smaller radius on chosen spots.",
                     _BROAD, lambda: S.broad_session(), 40),
    "fig12_5": _Spec("12.5", "Large oak",
                     "As Fig. 12.4 with λ 0.4 and a weaker horizontal tropism; a broad brush towards three "
                     "concentrations of leaves.",
                     {**_BROAD, "apical_dominance": 0.4, "w_heading": 0.25, "w_tropism": 0.05},
                     lambda: S.concentrations_session(), 45),
    "fig12_6": _Spec("12.6", "Manitoba maple (opposite branching)",
                     "Opposite branching, lateral angle 45°, main angle 12°, higher E; λ 0.6, lowered to 0.4 "
                     "later for denser tips.",
                     dict(branching="opposite", branch_angle=45.0, main_branch_angle=12.0, w_heading=0.25,
                          w_tropism=0.1, w_env=0.65, apical_dominance=0.6),
                     lambda: S.crown_session(), 40, {28: dict(apical_dominance=0.4)}),
    "fig12_7_constant": _Spec("12.7", "Internode length: constant",
                              "λ 0.6, the wand held above the root and raised; constant internode length.",
                              dict(apical_dominance=0.6, length_mode="constant"), lambda: S.vertical_stroke(), 40),
    "fig12_7_vigor": _Spec("12.7", "Internode length: vigor (default)",
                           "λ 0.6, the same strokes; internode length from vigor (Eq. 9.17).",
                           dict(apical_dominance=0.6, length_mode="vigor"), lambda: S.vertical_stroke(), 40),
    "fig12_7_order": _Spec("12.7", "Internode length: branch order",
                           "λ 0.6, the same strokes; internode length from branch order (Eq. 9.16).",
                           dict(apical_dominance=0.6, length_mode="order"), lambda: S.vertical_stroke(), 40),
}


@dataclass(frozen=True)
class Scenario:
    """A loaded stroke file: the stated parameters and the model commands of one thesis session.

    Attributes
    ----------
    name, figure, title, notes : str
    seed : int
        Seed the session's ``reset`` starts the tree with.
    params : dict
        Parameters set over the defaults before the first command (checked against the table).
    events : tuple of (str, dict)
        ``(command, kwargs)`` pairs of the session after its ``set_params`` and ``reset`` header.
    """

    name: str
    figure: str
    title: str
    notes: str
    seed: int
    params: dict[str, Any]
    events: tuple[tuple[str, dict[str, Any]], ...]

    @property
    def label(self) -> str:
        """Dropdown text, e.g. ``"Fig. 12.3 · Columnar tree"``."""
        return f"Fig. {self.figure} · {self.title}" if self.figure else self.title

    @property
    def n_steps(self) -> int:
        """Growth steps the session takes."""
        return sum(int(kw.get("steps", 1)) for c, kw in self.events if c == "step")

    @property
    def log(self) -> CommandLog:
        """The whole session as a Tree Wand command log: ``set_params(**params)``, ``reset(seed)``, the events.
        Times are 0 (a recorded session is not timed), so a file's bytes depend on its commands only."""
        log = CommandLog(Model.COMMANDS, document=Model.KIND)
        log.events = [Event(cmd, dict(kw), 0.0)
                      for cmd, kw in (("set_params", self.params), ("reset", {"seed": self.seed}), *self.events)]
        log.check()
        return log


class _Recorder:
    """Stands in for a model: records the session's paint stamps and steps into a command log."""

    def __init__(self) -> None:
        self.log = CommandLog(Model.COMMANDS, document=Model.KIND)

    def paint(self, center, radius, n_darts=None) -> None:
        kw = {"center": [round(float(v), 6) for v in center], "radius": round(float(radius), 6)}
        if n_darts is not None:
            kw["n_darts"] = int(n_darts)
        self.log.record("paint", **kw)

    def step(self) -> None:
        self.log.record("step", steps=1)


def record_scenario(name: str, *, seed: int = 0) -> Scenario:
    """Record the scenario ``name`` of :data:`SCENARIOS` from its session function (no growth is run).

    Parameters
    ----------
    name : str
        A key of :data:`SCENARIOS`.
    seed : int
        Seed of the session's ``reset``.

    Returns
    -------
    Scenario
    """
    name = check_choice("name", name, tuple(SCENARIOS))
    spec = SCENARIOS[name]
    session, rec = spec.session(), _Recorder()
    for s in range(spec.steps):
        if s in spec.param_changes:
            rec.log.record("set_params", **spec.param_changes[s])
        session(rec, s)
        rec.step()
    return Scenario(name, spec.figure, spec.title, spec.notes, check_int("seed", seed, 0, 2**63 - 1),
                    validate(spec.params), tuple((e.command, e.kwargs) for e in rec.log))


def _check_suffix(path: str | Path) -> Path:
    path = Path(path)
    if path.suffix != SUFFIX:
        raise ValueError(f"scenario path must end in {SUFFIX}, got {path.suffix!r}")
    return path


def save_scenario(scenario: Scenario, path: str | Path) -> Path:
    """Write a stroke file (the session's command log, atomically).

    Parameters
    ----------
    scenario : Scenario
    path : str or Path
        Destination ending in ``.jsonl``.

    Returns
    -------
    Path
    """
    return scenario.log.save(_check_suffix(path))


def read_scenario(path: str | Path) -> Scenario:
    """Read and check a stroke file; every command goes through the model's door checks before anything is
    returned.

    Raises
    ------
    ValueError
        Missing, unreadable, damaged or not a Tree Wand log, a session that does not start with ``set_params``
        and ``reset(seed)``, or any bad parameter or command (the message names it).
    """
    path = _check_suffix(path)
    try:
        log = CommandLog.load(path, Model.COMMANDS, document=Model.KIND)
    except ValueError as exc:
        raise ValueError(f"scenario {path!s}: {exc}") from None
    ev = log.events
    if len(ev) < 2 or ev[0].command != "set_params" or ev[1].command != "reset" or ev[1].kwargs.get("seed") is None:
        raise ValueError(f"scenario {path!s} must start with set_params(...) and reset(seed=...), got "
                         f"{[e.command for e in ev[:2]]}")
    try:
        log.check(Model())
    except ValueError as exc:
        raise ValueError(f"scenario {path!s}: {exc}") from None
    spec = SCENARIOS.get(path.stem)
    figure, title, notes = (spec.figure, spec.title, spec.notes) if spec is not None else ("", path.stem, "")
    return Scenario(path.stem, figure, title, notes, ev[1].kwargs["seed"], validate(ev[0].kwargs),
                    tuple((e.command, e.kwargs) for e in ev[2:]))


def list_scenarios(folder: str | Path | None = None) -> list[Scenario]:
    """Every stroke file in ``folder`` (default: the shipped :data:`SCENARIO_DIR`), sorted by name."""
    folder = SCENARIO_DIR if folder is None else Path(folder)
    return [read_scenario(p) for p in sorted(folder.glob(f"*{SUFFIX}"))]


def load_scenario(name: str) -> Scenario:
    """The shipped stroke file ``name`` (e.g. ``"fig12_3"``)."""
    names = sorted(p.stem for p in SCENARIO_DIR.glob(f"*{SUFFIX}"))
    return read_scenario(SCENARIO_DIR / f"{check_choice('name', name, tuple(names))}{SUFFIX}")


def replay_scenario(model, scenario: Scenario | str, *, steps: int | None = None,
                    on_event: Callable[[int, int], None] | None = None) -> Scenario:
    """Replay a scenario into ``model``: parameters back to the defaults, then the session's commands
    (its parameters, the seeded ``reset``, the strokes and steps).

    Parameters
    ----------
    model : plantvr.Model
        Receives every command (they are logged in ``model.log`` and undoable).
    scenario : Scenario or str
        A scenario or the name of a shipped stroke file.
    steps : int, optional
        Stop after this many growth steps (default: the whole session).
    on_event : callable, optional
        ``on_event(done, total)`` after each command of :attr:`Scenario.events` (progress).

    Returns
    -------
    Scenario
        The scenario replayed.
    """
    sc = load_scenario(scenario) if isinstance(scenario, str) else scenario
    if not isinstance(sc, Scenario):
        raise ValueError(f"scenario must be a Scenario or a name, got {type(scenario).__name__}")
    limit = sc.n_steps if steps is None else check_int("steps", steps, 0, sc.n_steps)
    model.stop()
    with model.held():
        model.set_params(**defaults())
        model.set_params(**sc.params)
        model.reset(seed=sc.seed)
        done = 0
        for i, (cmd, kw) in enumerate(sc.events):
            if done >= limit:
                break
            getattr(model, cmd)(**kw)
            done += int(kw.get("steps", 1)) if cmd == "step" else 0
            if on_event is not None:
                on_event(i + 1, len(sc.events))
    return sc


def _write_all(folder: str | Path | None = None) -> list[Path]:
    """Re-record every scenario of :data:`SCENARIOS` into ``folder`` (maintainers: after editing a session)."""
    folder = SCENARIO_DIR if folder is None else Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return [save_scenario(record_scenario(n), folder / f"{n}{SUFFIX}") for n in SCENARIOS]


if __name__ == "__main__":  # python -m plantvr.documents.scenarios
    for p in _write_all():
        print(p)

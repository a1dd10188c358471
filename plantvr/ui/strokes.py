"""Replayable stroke files of the thesis scenarios, Figs. 12.1–12.7, and a dropdown to load them (spec 000_treewand
§6.1, §6.2; checklist item 32; TW-V23).

A stroke file (``plantvr/ui/scenarios/<name>.json``) holds the parameters the thesis states for a figure
and the list of model commands of its wand session (``paint`` stamps, ``step`` and ``set_params``), as
``{"plantvr_scenario": 1, "name", "figure", "title", "notes", "seed", "params", "events": [...]}``.
The files are recorded from the session functions of :mod:`plantvr.growth.scenarios` by
:func:`record_scenario` (a test checks they have not drifted). :func:`replay_scenario` re-seeds the model,
sets the parameters over the defaults and issues every command, so a replay is deterministic and ends in
the same tree as ``Model(seed, **params)`` fed the same commands; :class:`ScenarioPicker` is the dropdown.
"""
from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import ipywidgets as W

from .._validation import check_choice, check_int, check_point, check_range
from ..growth import scenarios as S
from ..params import defaults, validate
from .presets import _json_path, _read_json, _write_text

__all__ = ["SCENARIOS", "SCENARIO_DIR", "Scenario", "ScenarioPicker", "list_scenarios", "load_scenario",
           "read_scenario", "record_scenario", "replay_scenario", "save_scenario"]

SCENARIO_DIR = Path(__file__).resolve().parent / "scenarios"
_FORMAT = 1
_COMMANDS = ("paint", "step", "set_params")


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
        Seed of the model the commands are replayed on.
    params : dict
        Parameters set over the defaults before the first command (checked against the table).
    events : tuple of (str, dict)
        ``(command, kwargs)`` pairs, commands among ``paint``, ``step``, ``set_params``.
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
        return f"Fig. {self.figure} · {self.title}"

    @property
    def n_steps(self) -> int:
        """Growth steps the session takes."""
        return sum(int(kw.get("steps", 1)) for c, kw in self.events if c == "step")


class _Recorder:
    """Stands in for a model: records the session's paint stamps and steps as commands."""

    def __init__(self) -> None:
        self.events: list[tuple[str, dict[str, Any]]] = []

    def paint(self, center, radius, n_darts=None) -> None:
        kw = {"center": [round(float(v), 6) for v in center], "radius": round(float(radius), 6)}
        if n_darts is not None:
            kw["n_darts"] = int(n_darts)
        self.events.append(("paint", kw))

    def step(self) -> None:
        self.events.append(("step", {"steps": 1}))


def record_scenario(name: str, *, seed: int = 0) -> Scenario:
    """Record the scenario ``name`` of :data:`SCENARIOS` from its session function (no growth is run).

    Parameters
    ----------
    name : str
        A key of :data:`SCENARIOS`.
    seed : int
        Seed stored in the file.

    Returns
    -------
    Scenario
    """
    name = check_choice("name", name, tuple(SCENARIOS))
    spec = SCENARIOS[name]
    session, rec = spec.session(), _Recorder()
    for s in range(spec.steps):
        if s in spec.param_changes:
            rec.events.append(("set_params", dict(spec.param_changes[s])))
        session(rec, s)
        rec.step()
    return Scenario(name, spec.figure, spec.title, spec.notes, check_int("seed", seed, 0, 2**32 - 1),
                    validate(spec.params), tuple(rec.events))


def save_scenario(scenario: Scenario, path: str | Path) -> Path:
    """Write a stroke file (JSON, one event per line).

    Parameters
    ----------
    scenario : Scenario
    path : str or Path
        Destination ending in ``.json``.

    Returns
    -------
    Path
    """
    path = _json_path(path, "scenario")
    head = {"plantvr_scenario": _FORMAT, "name": scenario.name, "figure": scenario.figure, "title": scenario.title,
            "notes": scenario.notes, "seed": scenario.seed, "params": scenario.params}
    body = ",\n".join("  " + json.dumps({"command": c, "kwargs": kw}) for c, kw in scenario.events)
    text = json.dumps(head, indent=1)[:-2] + ',\n "events": [\n' + body + "\n ]\n}\n"
    return _write_text(path, text, "scenario")


def _check_event(i: int, ev: Any) -> tuple[str, dict[str, Any]]:
    where = f"event {i}"
    if not isinstance(ev, dict) or not isinstance(ev.get("kwargs"), dict):
        raise ValueError(f"{where} must be {{'command': ..., 'kwargs': {{...}}}}, got {ev!r:.80}")
    cmd, kw = check_choice(f"{where} command", ev.get("command"), _COMMANDS), ev["kwargs"]
    if cmd == "paint":
        extra = set(kw) - {"center", "radius", "n_darts"}
        if extra or "center" not in kw:
            raise ValueError(f"{where}: paint takes center, radius, n_darts, got {sorted(kw)}")
        check_point(f"{where} center", kw["center"])
        if kw.get("radius") is not None:
            check_range(f"{where} radius", kw["radius"], 0.0, 1e6, low_open=True)
        if kw.get("n_darts") is not None:
            check_int(f"{where} n_darts", kw["n_darts"], 1, 10_000_000)
    elif cmd == "step":
        if set(kw) - {"steps"}:
            raise ValueError(f"{where}: step takes steps, got {sorted(kw)}")
        check_int(f"{where} steps", kw.get("steps", 1), 0, 10_000_000)
    else:
        kw = validate(kw)
    return cmd, dict(kw)


def read_scenario(path: str | Path) -> Scenario:
    """Read and check a stroke file; every event is checked before anything is returned.

    Raises
    ------
    ValueError
        Missing, unreadable or not a PlantVR scenario, or any bad parameter or event (the message names it).
    """
    path = Path(path)
    data = _read_json(path, "scenario")
    keys = ("name", "figure", "title", "notes", "seed", "params", "events")
    if (not isinstance(data, dict) or data.get("plantvr_scenario") != _FORMAT or any(k not in data for k in keys)
            or not isinstance(data["params"], dict) or not isinstance(data["events"], list)):
        raise ValueError(f"scenario {path!s} is not a PlantVR scenario (expected {{'plantvr_scenario': {_FORMAT}, "
                         f"{', '.join(repr(k) for k in keys)}}})")
    try:
        params = validate(data["params"])
        events = tuple(_check_event(i, ev) for i, ev in enumerate(data["events"]))
        seed = check_int("seed", data["seed"], 0, 2**32 - 1)
    except ValueError as exc:
        raise ValueError(f"scenario {path!s}: {exc}") from None
    return Scenario(str(data["name"]), str(data["figure"]), str(data["title"]), str(data["notes"]), seed, params,
                    events)


def list_scenarios(folder: str | Path | None = None) -> list[Scenario]:
    """Every stroke file in ``folder`` (default: the shipped :data:`SCENARIO_DIR`), sorted by name."""
    folder = SCENARIO_DIR if folder is None else Path(folder)
    return [read_scenario(p) for p in sorted(folder.glob("*.json"))]


def load_scenario(name: str) -> Scenario:
    """The shipped stroke file ``name`` (e.g. ``"fig12_3"``)."""
    names = sorted(p.stem for p in SCENARIO_DIR.glob("*.json"))
    return read_scenario(SCENARIO_DIR / f"{check_choice('name', name, tuple(names))}.json")


def _reseed(model, seed: int, params: dict[str, Any]) -> None:
    """Put ``model`` in the state of a fresh ``Model(seed, **params)`` (tree, markers, RNG), via its
    lossless ``restore`` (the model has no public re-seed command)."""
    from ..documents.treewand import Model
    fresh = Model(seed=seed, **params)
    with tempfile.TemporaryDirectory() as d:
        path = fresh.save(Path(d) / "start.npz")
        model.restore(path)


def replay_scenario(model, scenario: Scenario | str, *, steps: int | None = None,
                    on_event: Callable[[int, int], None] | None = None) -> Scenario:
    """Replay a scenario into ``model``: re-seed, set its parameters over the defaults, issue its commands.

    Parameters
    ----------
    model : plantvr.Model
        Receives every command (they are logged in ``model.events``).
    scenario : Scenario or str
        A scenario or the name of a shipped stroke file.
    steps : int, optional
        Stop after this many growth steps (default: the whole session).
    on_event : callable, optional
        ``on_event(done, total)`` after each command (progress).

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
    _reseed(model, sc.seed, {**defaults(), **sc.params})
    done = 0
    for i, (cmd, kw) in enumerate(sc.events):
        if done >= limit:
            break
        if cmd == "set_params":
            model.set_params(**kw)
        else:
            getattr(model, cmd)(**kw)
            done += int(kw.get("steps", 1)) if cmd == "step" else 0
        if on_event is not None:
            on_event(i + 1, len(sc.events))
    return sc


class ScenarioPicker(W.VBox):
    """Dropdown of the shipped thesis scenarios; *Replay* re-seeds the model and replays the chosen one.

    Parameters
    ----------
    model : plantvr.Model
        The shared model; the picker keeps no tree of its own.
    folder : str or Path, optional
        Folder of stroke files (default: :data:`SCENARIO_DIR`).

    Attributes
    ----------
    dropdown : ipywidgets.Dropdown
        Values are scenario names.
    """

    def __init__(self, model, *, folder: str | Path | None = None, **kwargs):
        self.model = model
        self.scenarios = {s.name: s for s in list_scenarios(folder)}
        if not self.scenarios:
            raise ValueError(f"no scenario files (*.json) in {folder or SCENARIO_DIR!s}")
        self.dropdown = W.Dropdown(options=[(s.label, n) for n, s in self.scenarios.items()],
                                   description="Scenario", layout=W.Layout(width="420px"))
        self.button = W.Button(description="Replay", icon="play", button_style="success")
        self.progress = W.IntProgress(0, 0, 1, layout=W.Layout(width="200px"))
        self.info = W.HTML()
        self.status = W.HTML()
        self.button.on_click(lambda _: self.replay())
        self.dropdown.observe(lambda _: self._describe(), names="value")
        self._describe()
        super().__init__([W.HBox([self.dropdown, self.button, self.progress]), self.info, self.status], **kwargs)

    def _describe(self) -> None:
        s = self.scenarios[self.dropdown.value]
        stated = ", ".join(f"{k} = {v}" for k, v in s.params.items())
        self.info.value = (f"<b>{s.label}</b><br>{s.notes}<br><small>parameters: {stated}; "
                           f"{s.n_steps} steps, {len(s.events)} commands, seed {s.seed}</small>")

    def select(self, name: str) -> None:
        """Choose a scenario in the dropdown."""
        self.dropdown.value = check_choice("name", name, tuple(self.scenarios))

    def replay(self, name: str | None = None, *, steps: int | None = None) -> Scenario:
        """Replay the selected scenario (or ``name``) into the model; returns it."""
        if name is not None:
            self.select(name)
        sc = self.scenarios[self.dropdown.value]
        self.progress.max, self.progress.value = len(sc.events), 0
        self.button.disabled = True

        def tick(done: int, total: int) -> None:
            if done % 10 == 0 or done == total:
                self.progress.value = done

        try:
            replay_scenario(self.model, sc, steps=steps, on_event=tick)
        finally:
            self.button.disabled = False
        self.progress.value = self.progress.max
        self.status.value = (f"replayed {sc.name}: {self.model.n_internodes} internodes, "
                             f"{self.model.n_markers} markers after {self.model.steps_done} steps")
        return sc


def _write_all(folder: str | Path | None = None) -> list[Path]:
    """Re-record every scenario of :data:`SCENARIOS` into ``folder`` (maintainers: after editing a session)."""
    folder = SCENARIO_DIR if folder is None else Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return [save_scenario(record_scenario(n), folder / f"{n}.json") for n in SCENARIOS]


if __name__ == "__main__":  # python -m plantvr.ui.strokes
    for p in _write_all():
        print(p)

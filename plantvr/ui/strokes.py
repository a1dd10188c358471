"""The scenario dropdown: replays a shipped thesis stroke file into the model (spec 000_treewand §6.1, §6.2); the
stroke files and their replay are :mod:`plantvr.documents.scenarios`."""
from __future__ import annotations

from pathlib import Path

import ipywidgets as W

from .._validation import check_choice
from ..documents.scenarios import SCENARIO_DIR, SUFFIX, Scenario, list_scenarios, replay_scenario

__all__ = ["ScenarioPicker"]


class ScenarioPicker(W.VBox):
    """Dropdown of the shipped thesis scenarios; *Replay* replays the chosen one into the model (seeded).

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
            raise ValueError(f"no scenario files (*{SUFFIX}) in {folder or SCENARIO_DIR!s}")
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

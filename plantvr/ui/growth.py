"""Growth control: play/pause/step/reset, steps per second, live ms/step and internodes with a plot
(spec 000_treewand §4.10, §4.12; §6.4 Figs. 12.8/12.9 data).

Play starts ``model.grow(..., background=True)``: growth runs on the model's worker thread, paced by
``on_step``, while sliders keep setting parameters through the model. The control only reads the
model's published statistics; it owns no growth state.
"""
from __future__ import annotations

import time

import anywidget
import ipywidgets as W
import traitlets

from .._validation import check_int, check_range
from ._assets import asset

__all__ = ["GrowthPlot", "GrowthControl"]


class GrowthPlot(anywidget.AnyWidget):
    """Small canvas plot of ms/step (left axis) and internodes (right axis) against step."""

    _esm = asset("growth_plot.js")
    steps = traitlets.List(traitlets.Int()).tag(sync=True)
    ms = traitlets.List(traitlets.Float()).tag(sync=True)
    internodes = traitlets.List(traitlets.Int()).tag(sync=True)
    width = traitlets.Int(420).tag(sync=True)
    height = traitlets.Int(160).tag(sync=True)


class GrowthControl(W.VBox):
    """Play / pause / step / reset for a model, with live figures.

    Parameters
    ----------
    model : plantvr.Model
    steps_per_second : float
        Pace of play, in (0, 1000]; the worker sleeps between steps to keep it.
    max_points : int
        Points kept in the live plot.

    Attributes
    ----------
    plot : GrowthPlot
    status : ipywidgets.HTML
        ``"step k · x ms/step · n internodes · m markers"``.
    """

    PLAY_STEPS = 100_000  # steps asked of the worker by Play; Pause stops it early

    def __init__(self, model, *, steps_per_second: float = 10.0, max_points: int = 500):
        from ..documents.treewand import Model  # noqa: PLC0415
        if not isinstance(model, Model):
            raise TypeError(f"model must be a plantvr.Model, got {type(model).__name__}")
        self.model = model
        self.max_points = check_int("max_points", max_points, 1, 1_000_000)
        self.rate = W.BoundedFloatText(value=check_range("steps_per_second", steps_per_second, 0, 1000,
                                                         low_open=True),
                                       min=0.1, max=1000, step=1, description="steps/s",
                                       tooltip="Play pace (steps per second)", layout=W.Layout(width="160px"))
        fit = {"layout": W.Layout(width="auto")}     # a button as wide as its label: never clipped
        self.play_button = W.Button(description="Play", icon="play", button_style="success", **fit)
        self.pause_button = W.Button(description="Pause", icon="pause", **fit)
        self.step_button = W.Button(description="Step", icon="step-forward", **fit)
        self.reset_button = W.Button(description="Reset", icon="undo", button_style="warning",
                                     tooltip="Start a new tree (keeps the base)", **fit)
        self.play_button.on_click(lambda _b: self.play())
        self.pause_button.on_click(lambda _b: self.pause())
        self.step_button.on_click(lambda _b: self.step())
        self.reset_button.on_click(lambda _b: self.reset())
        self.status = W.HTML()
        self.plot = GrowthPlot()
        self._last_step = -1
        self._next_t = 0.0
        model.on(self._on_version)
        model.observe(self._on_growing, names=["growing"])
        self._on_version(None)
        self._on_growing(None)
        super().__init__([W.HBox([self.play_button, self.pause_button, self.step_button, self.reset_button,
                                  self.rate], layout=W.Layout(flex_flow="row wrap")), self.status, self.plot])

    # -- commands -------------------------------------------------------------------------------------
    def play(self) -> None:
        """Grow on the worker thread at :attr:`rate` steps per second until :meth:`pause`."""
        if self.model.growing:
            return
        self._next_t = time.perf_counter()
        self.model.grow(self.PLAY_STEPS, background=True, on_step=self._pace)

    def _pace(self, stats) -> None:  # runs on the worker thread, between steps
        self._next_t += 1.0 / float(self.rate.value)
        delay = self._next_t - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        else:
            self._next_t = time.perf_counter()

    def pause(self) -> None:
        """Stop the worker after its current step."""
        self.model.stop()

    def step(self, n: int = 1) -> None:
        """Run ``n`` synchronous steps (ignored while playing)."""
        if not self.model.growing:
            self.model.step(n)

    def reset(self) -> None:
        """Stop, then start a new tree; the plot is cleared."""
        self.model.stop()
        self.model.reset()
        with self.plot.hold_sync():
            self.plot.steps, self.plot.ms, self.plot.internodes = [], [], []
        self._last_step = -1
        self._on_version(None)

    # -- observers ------------------------------------------------------------------------------------
    def _on_growing(self, change) -> None:
        g = self.model.growing
        self.play_button.disabled, self.pause_button.disabled = g, not g
        self.step_button.disabled = g

    def _on_version(self, change) -> None:
        snap = self.model.snapshot
        st = snap.stats
        ms = f"{st.ms:.2f}" if st is not None else "–"
        self.status.value = (f"step <b>{snap.step}</b> · <b>{ms}</b> ms/step · "
                             f"<b>{snap.n_internodes}</b> internodes · {len(snap.markers)} markers")
        if st is not None and st.step != self._last_step and snap.step > 0:
            self._last_step = st.step
            # every step since the tree started (the model keeps them): steps grown before this control
            # existed, several steps of one call and a regrow's steps are all plotted, not only the last
            hist = self.model.step_stats[-self.max_points:]
            with self.plot.hold_sync():
                self.plot.steps = [int(h.step) for h in hist]
                self.plot.ms = [float(h.ms) for h in hist]
                self.plot.internodes = [int(h.internodes) for h in hist]

    def close(self) -> None:
        """Stop growth and observing the model."""
        model = getattr(self, "model", None)  # None when the constructor refused its arguments
        if model is not None:
            model.stop()
            model.off(self._on_version)
            model.unobserve(self._on_growing, names=["growing"])
        super().close()

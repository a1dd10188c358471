"""Growth control: buttons, live figures, and growth continuing on the worker while sliders move."""
import time

import pytest

import plantvr
from plantvr.ui import GrowthControl, ParameterPanels


@pytest.fixture
def model():
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 9)], radius=2.0)
    return m


def test_step_and_reset_buttons_update_figures(model):
    gc = GrowthControl(model)
    gc.step_button.click()
    gc.step_button.click()
    assert model.steps_done == 2
    assert gc.plot.steps == [1, 2] and len(gc.plot.ms) == 2
    assert gc.plot.internodes[-1] == model.n_internodes
    assert f"<b>{model.n_internodes}</b> internodes" in gc.status.value
    gc.reset_button.click()
    assert model.n_internodes == plantvr.Model().n_internodes and model.steps_done == 0 and gc.plot.steps == []


def test_play_runs_on_worker_while_sliders_move(model):
    gc = GrowthControl(model, steps_per_second=200)
    panels = ParameterPanels(model)
    gc.play()
    assert model.growing and gc.play_button.disabled and not gc.pause_button.disabled
    t0 = time.time()
    while model.steps_done < 3 and time.time() - t0 < 20:
        time.sleep(0.01)
    s0 = model.steps_done
    for v in (30.0, 60.0, 90.0):  # user drags a slider during growth
        panels.controls["tropism_angle"].value = v
        time.sleep(0.05)
    assert model.tropism_angle == 90.0
    t0 = time.time()
    while model.steps_done <= s0 and time.time() - t0 < 20:
        time.sleep(0.01)
    assert model.steps_done > s0  # growth kept going
    gc.pause_button.click()
    assert not model.growing and not gc.play_button.disabled
    n = model.steps_done
    time.sleep(0.1)
    assert model.steps_done == n
    assert gc.plot.steps[-1] == n


def test_play_respects_pace(model):
    gc = GrowthControl(model, steps_per_second=20)
    gc.play()
    time.sleep(0.5)
    gc.pause()
    assert 3 <= model.steps_done <= 13  # ~10 expected at 20 steps/s


def test_bad_rate_rejected(model):
    with pytest.raises(ValueError, match=r"steps_per_second must be in \(0, 1000\]"):
        GrowthControl(model, steps_per_second=0)


def test_plot_shows_every_step_grown_before_and_in_one_call(model):
    model.step(4)                                   # grown before the control existed
    gc = GrowthControl(model)
    assert gc.plot.steps == [1, 2, 3, 4]            # not an empty box
    model.step(3)                                   # several steps in one call: one version change
    assert gc.plot.steps == list(range(1, 8)) and len(gc.plot.ms) == len(gc.plot.internodes) == 7
    assert gc.plot.internodes == [s.internodes for s in model.step_stats]
    gc.close()

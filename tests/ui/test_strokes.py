"""The scenario dropdown (spec 000_treewand §6.1): the browser's click replays the chosen stroke file."""
import numpy as np
import pytest

import plantvr
from plantvr.documents.scenarios import SCENARIOS, load_scenario
from plantvr.ui.strokes import ScenarioPicker


def test_picker_replays_selected_scenario_into_model():
    m = plantvr.Model(seed=0)
    picker = ScenarioPicker(m)
    labels = [lab for lab, _ in picker.dropdown.options]
    assert len(labels) == len(SCENARIOS) and labels[0].startswith("Fig. 12.1")
    picker.select("fig12_3")
    assert "Columnar" in picker.info.value and "view_angle = 40.0" in picker.info.value
    picker.button.click()  # what the browser does
    assert m.view_angle == 40.0 and m.steps_done == 40
    assert picker.progress.value == picker.progress.max == len(load_scenario("fig12_3").events)
    assert "replayed fig12_3" in picker.status.value and not picker.button.disabled
    first = m.snapshot.pos.copy()
    picker.replay("fig12_3")
    np.testing.assert_array_equal(m.snapshot.pos, first)
    with pytest.raises(ValueError, match="name must be one of"):
        picker.select("fig99")

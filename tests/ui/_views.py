"""A small grown tree in an offscreen view, shared by the brush tests."""
from __future__ import annotations

import plantvr
from plantvr.view import View


def grown_model_view() -> tuple[plantvr.Model, View]:
    """A model grown 15 steps from one painted stroke, and a 400x300 view that has rendered it once."""
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(15)
    v = View(m, window_size=(400, 300))
    v.screenshot()
    return m, v

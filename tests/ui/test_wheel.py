"""Colour wheel: slice index rule, commands, and duck-typed linking to a segmentation."""
import math

import numpy as np
import pytest
import traitlets

from plantvr.ui import ColorWheel, slice_at
from plantvr.ui.wheel import hex_to_rgb, rgb_to_hex


def test_slice_index_rule_and_dead_zone():
    K = 13
    for k in range(K):
        a = (k + 0.5) * 2 * math.pi / K
        assert slice_at(math.cos(a), math.sin(a), K, last=0) == k
    assert slice_at(0.05, 0.05, K, last=7) == 7  # near the centre the last slice is kept
    assert slice_at(1.0, -1e-9, K) == K - 1       # just below +x wraps to the last slice
    with pytest.raises(ValueError, match="n_slices must be an integer"):
        slice_at(1, 0, 0)


def test_hex_round_trip_and_errors():
    assert rgb_to_hex((255, 0, 16)) == "#ff0010"
    assert hex_to_rgb("#ff0010") == (255, 0, 16)
    with pytest.raises(ValueError, match="color must be '#rrggbb'"):
        hex_to_rgb("red")
    with pytest.raises(ValueError, match="rgb must be 3 values"):
        rgb_to_hex((300, 0, 0))


class TableStandIn(traitlets.HasTraits):
    """A tiny colour-table model with traits, as another component might expose."""

    colors = traitlets.List(traitlets.Unicode())
    hidden = traitlets.List(traitlets.Bool())


def test_wheel_linked_to_traitlets_stand_in():
    t = TableStandIn(colors=["#000000", "#ff0000", "#00ff00"], hidden=[False, False, False])
    w = ColorWheel(target=t)
    assert w.colors == t.colors and w.hidden == [False] * 3
    w.select(2)
    assert w.toggle_hidden() is True
    assert t.hidden == [False, False, True]
    w.set_color(1, "#123456")
    assert t.colors[1] == "#123456"
    t.colors = ["#000000", "#ffffff", "#00ff00"]  # model side edit reaches the wheel
    assert w.colors[1] == "#ffffff"
    with pytest.raises(ValueError, match="label must be an integer in"):
        w.select(3)
    assert w.selected == 2


def _segmentation():
    from plantvr.documents.labels import Segmentation
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    f = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
    return Segmentation(v, f)


def test_wheel_linked_to_vine_segmentation():
    seg = _segmentation()
    w = ColorWheel(target=seg)
    assert len(w.colors) == len(seg.colors)
    assert w.colors[2] == rgb_to_hex(seg.colors.rgba[2, :3])
    w.select(3)
    w.toggle_hidden()                      # the click with the modifier = the trackpad press
    assert not seg.colors.visible[3]
    seg.show(3)                            # a change made on the segmentation shows on the wheel
    assert w.hidden[3] is False
    w.set_color(4, "#010203")
    assert tuple(seg.colors.rgba[4, :3]) == (1, 2, 3)
    seg.set_color(5, (9, 8, 7))
    assert w.colors[5] == "#090807"


def test_wheel_cannot_resize_table_and_reports():
    seg = _segmentation()
    w = ColorWheel(target=seg)
    n = len(seg.colors)
    w.colors = w.colors + ["#ffffff"]
    assert "cannot resize" in w.error
    assert len(seg.colors) == n and len(w.colors) == n


def test_wheel_link_rejects_unknown_objects():
    with pytest.raises(ValueError, match="target must be a Segmentation-like document"):
        ColorWheel(colors=["#000000"], target=object())

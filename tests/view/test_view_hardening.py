"""Forest, subdivision and slice views check their options at the door; screenshots are atomic (issue 20)."""
import math

import numpy as np
import pytest
import pyvista as pv

from plantvr.view.forest import ForestView
from plantvr.view.slices import VolumeSlices
from plantvr.view.subdivision import SubdivisionView

TREE = (np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.0]]), np.array([-1, 0, 1]), np.array([0.1, 0.08, 0.05]))


@pytest.mark.parametrize("kw, param", [({"levels": 0}, "levels"), ({"levels": 99}, "levels"),
                                       ({"billboard_px": 10**9}, "billboard_px"),
                                       ({"thresholds": [math.nan]}, "thresholds"),
                                       ({"thresholds": [-5.0]}, "thresholds"), ({"thresholds": []}, "thresholds"),
                                       ({"window_size": (0, 0)}, "window_size")])
def test_forest_view_options(fuzz, kw, param):
    assert isinstance(fuzz.call("ForestView", ForestView, [TREE], param=param, **kw), ValueError)


@pytest.mark.parametrize("trees", [[], "trees", {"pos": 1}, None])
def test_forest_view_trees(fuzz, trees):
    assert isinstance(fuzz.call("ForestView", ForestView, trees, param="trees"), ValueError)


@pytest.mark.parametrize("size", [(1, 1), (10**6, 10), "big", (100,)])
def test_subdivision_view_window(fuzz, size):
    assert isinstance(fuzz.call("SubdivisionView", SubdivisionView, window_size=size, param="window_size"),
                      ValueError)


def test_subdivision_screenshot_is_atomic(tmp_path, monkeypatch):
    v = SubdivisionView(window_size=(64, 32))
    try:
        p = tmp_path / "s.png"
        v.screenshot(p)
        before = p.read_bytes()
        with pytest.raises(ValueError, match="must end in .png"):
            v.screenshot(tmp_path / "s.jpg")
        from PIL import Image

        def boom(*a, **k):
            raise OSError(28, "No space left on device")
        monkeypatch.setattr(Image.Image, "save", boom)
        with pytest.raises(OSError, match="No space"):
            v.screenshot(p)
        assert p.read_bytes() == before and [x.name for x in tmp_path.iterdir()] == ["s.png"]
    finally:
        v.close()


@pytest.mark.parametrize("volume, spacing, param", [
    (np.zeros((0, 4, 4)), (1, 1, 1), "volume"), (np.full((4, 4, 4), np.nan), (1, 1, 1), "volume"),
    (np.array([["a"]]), (1, 1, 1), "volume"), (np.zeros((4, 4, 4)), (0, 1, 1), "spacing"),
    (np.zeros((4, 4, 4)), (1e300, 1, 1), "spacing"), (np.zeros((4, 4, 4)), (1, 1), "spacing")])
def test_volume_slices_input(fuzz, volume, spacing, param):
    pl = pv.Plotter(off_screen=True, window_size=(32, 32))
    try:
        assert isinstance(fuzz.call("VolumeSlices", VolumeSlices, pl, volume, spacing=spacing, param=param),
                          ValueError)
    finally:
        pl.close()


@pytest.mark.parametrize("kw, param", [({"near": 0}, "near"), ({"near": math.nan}, "near"),
                                       ({"far": 0.01}, "far"), ({"far": math.inf}, "far"), ({"width": 0}, "width"),
                                       ({"layout": "3d"}, "layout")])
def test_stereo_renderer_options(fuzz, kw, param):
    from plantvr.vr.render import StereoRenderer
    args = {"width": 32, "height": 32, **kw}
    w, h = args.pop("width"), args.pop("height")
    assert isinstance(fuzz.call("StereoRenderer", StereoRenderer, w, h, param=param, **args), ValueError)

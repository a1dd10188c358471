"""The view checks its options and scene content at the door; screenshots are atomic (issue 20, issue 21)."""
import math

import numpy as np
import pytest

from plantvr.types import LabelledSurface, Points, TreeArrays, TriMesh
from plantvr.view import LOD, View, side_by_side
from plantvr.view.vine_layers import OrthoSlices

TREE = TreeArrays.from_arrays(np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.0]]), np.array([-1, 0, 1]),
                              np.array([0.1, 0.08, 0.05]))


@pytest.mark.parametrize("kw, param", [({"levels": 0}, "levels"), ({"levels": 99}, "levels"),
                                       ({"billboard_px": 10**9}, "billboard_px"),
                                       ({"thresholds": [math.nan]}, "thresholds"),
                                       ({"thresholds": [-5.0]}, "thresholds"), ({"thresholds": []}, "thresholds"),
                                       ({"billboard": 1}, "billboard")])
def test_forest_lod_options(fuzz, kw, param):
    assert isinstance(fuzz.call("LOD", LOD, param=param, **kw), ValueError)


@pytest.mark.parametrize("kw, param", [({"window_size": (0, 0)}, "window_size"),
                                       ({"window_size": (1, 1)}, "window_size"),
                                       ({"window_size": (10**6, 10)}, "window_size"),
                                       ({"window_size": "big"}, "window_size"),
                                       ({"window_size": (100,)}, "window_size"),
                                       ({"lod": "far"}, "lod"), ({"panels": "control"}, "panels"),
                                       ({"panels": [[1]]}, "panels"), ({"titles": ["a", "b"]}, "titles"),
                                       ({"styles": {"tree": 3}}, "styles"), ({"show_leaves": "no"}, "show_leaves"),
                                       ({"ground": 1}, "ground"), ({"params": [1]}, "params"),
                                       ({"background": "nocolour"}, "background"),
                                       ({"background": (1, 2)}, "background")])
def test_view_options(fuzz, kw, param):
    assert isinstance(fuzz.call("View", View, {"tree": TREE}, param=param, **kw), ValueError)


@pytest.mark.parametrize("scene, param", [({"tree": "trees"}, "scene['tree']"), ({"m": {"pos": 1}}, "scene['m']"),
                                          ({1: TREE}, "str names"), ([TREE], "doc must be")])
def test_view_scene_content(fuzz, scene, param):
    assert isinstance(fuzz.call("View", View, scene, param=param), (ValueError, TypeError))


def test_static_update_checks_everything_first():
    v = View({"tree": TREE}, window_size=(64, 64))
    try:
        with pytest.raises(ValueError, match=r"scene\['bad'\]"):
            v.update({"pts": Points(np.zeros((2, 3))), "bad": 3})
        assert list(v.layers) == ["tree"]                      # nothing was drawn
        with pytest.raises(ValueError, match="faces must index vertices"):
            v.update({"m": TriMesh(np.zeros((3, 3)), np.array([[0, 1, 5]]))})
        assert v.update({"tree": None}) == ["tree"] and not v.layers
    finally:
        v.close()


def test_screenshot_is_atomic(tmp_path, monkeypatch):
    v = side_by_side(None, None, window_size=(64, 32))
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
    assert isinstance(fuzz.call("OrthoSlices", OrthoSlices, volume, spacing=spacing, param=param), ValueError)


@pytest.mark.parametrize("kw, param", [({"line_width": 0}, "line_width"), ({"opacity": 2}, "opacity"),
                                       ({"indices": {"w": 1}}, "indices"), ({"indices": {"x": 9}}, "indices"),
                                       ({"indices": [1]}, "indices"), ({"level": math.nan}, "level"),
                                       ({"seg": "mesh"}, "seg"), ({"cmap": 3}, "cmap")])
def test_volume_slices_options(fuzz, kw, param):
    assert isinstance(fuzz.call("OrthoSlices", OrthoSlices, np.zeros((4, 4, 4)), param=param, **kw), ValueError)


@pytest.mark.parametrize("args, param", [(([0, 0, 0], np.eye(3), 0.0), "scale"),
                                         (([0, 0], np.eye(3), 1.0), "position"),
                                         (([0, 0, 0], np.eye(2), 1.0), "rotation")])
def test_model_pose_input(fuzz, args, param):
    v = View({"tree": TREE}, window_size=(64, 64))
    try:
        assert isinstance(fuzz.call("View.set_model_pose", v.set_model_pose, *args, param=param), ValueError)
        assert isinstance(fuzz.call("View.set_brush", v.set_brush, [0, 0, 0], color="nocolour", param="color"),
                          ValueError)
        assert isinstance(fuzz.call("LabelledSurface", LabelledSurface, TREE, param="source"), ValueError)
    finally:
        v.close()


@pytest.mark.parametrize("kw, param", [({"near": 0}, "near"), ({"near": math.nan}, "near"),
                                       ({"far": 0.01}, "far"), ({"far": math.inf}, "far"), ({"width": 0}, "width"),
                                       ({"layout": "3d"}, "layout")])
def test_stereo_renderer_options(fuzz, kw, param):
    from plantvr.vr.render import StereoRenderer
    args = {"width": 32, "height": 32, **kw}
    w, h = args.pop("width"), args.pop("height")
    assert isinstance(fuzz.call("StereoRenderer", StereoRenderer, w, h, param=param, **args), ValueError)

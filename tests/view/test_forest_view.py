"""Forest view: trees switch LOD level (and billboard) by camera distance (issue 16)."""
import numpy as np
import pytest

from plantvr.landscape import grow_forest
from plantvr.view.billboard import BILLBOARD_LEVEL
from plantvr.view.forest import ForestView


@pytest.fixture(scope="module")
def forest():
    return grow_forest(4, size=(30.0, 30.0), min_dist=8.0, rounds=2, steps_per_round=5, client="sync", seed=0)


@pytest.fixture(scope="module")
def view(forest):
    v = ForestView(forest.trees, window_size=(640, 480), billboard_px=64)
    yield v
    v.close()
    v.plotter.close()


def _look(view, center, dist):
    view.plotter.camera_position = [tuple(center + np.array([0.3, 0.4, 1.0]) * dist), tuple(center), (0, 1, 0)]


def test_levels_follow_the_camera(view, forest, tmp_path):
    center = view.centers.mean(0)
    _look(view, center, 15.0)                           # the observer updates the levels: no update() call
    near, tris_near = view.levels.copy(), view.triangles
    assert near.min() <= 1, near
    pv_near = view.plotter.screenshot(str(tmp_path / "near.png"), return_img=True)
    _look(view, center, 120.0)
    mid, tris_mid = view.levels.copy(), view.triangles
    _look(view, center, 2000.0)
    far, tris_far = view.levels.copy(), view.triangles
    assert np.all(mid >= near) and np.all(far >= mid) and np.all(far == BILLBOARD_LEVEL), (near, mid, far)
    assert tris_near > tris_mid > tris_far == 4 * len(forest.trees), (tris_near, tris_mid, tris_far)
    # exactly one actor per tree is visible, the one of its level
    for k, acts in enumerate(view.actors):
        vis = [i for i, a in enumerate(acts) if a.GetVisibility()]
        assert vis == [len(acts) - 1]
    assert view.switches >= 2 * len(forest.trees)
    assert view.update() == 0                           # nothing moved: nothing switches
    assert pv_near.shape[:2] == (480, 640)


def test_update_without_observer(forest):
    v = ForestView(forest.trees[:1], observe=False, billboard=False, window_size=(320, 240))
    try:
        c = v.centers[0]
        v.plotter.camera_position = [tuple(c + np.array([0, 0, 3000.0])), tuple(c), (0, 1, 0)]
        assert v.levels[0] <= 1                         # not observed: the level stays until update()
        assert v.update() == 1 and v.levels[0] == BILLBOARD_LEVEL
        assert v.triangles == v.chains[0][-1].triangles  # no billboard: the last mesh level is shown
    finally:
        v.plotter.close()


def test_validation():
    with pytest.raises(ValueError, match="trees"):
        ForestView([])

"""Forest view (a View with ``lod``): trees switch LOD level (and billboard) by camera distance (issue 16)."""
import numpy as np
import pytest

from plantvr.landscape import grow_forest
from plantvr.types import TreeArrays
from plantvr.view import LOD, View
from plantvr.view.billboard import BILLBOARD_LEVEL
from plantvr.view.layers import LodTreeLayer


def _scene(trees):
    """The forest's trees as scene content (one TreeArrays per tree, world coordinates)."""
    from types import SimpleNamespace
    return {f"tree{k}": TreeArrays.from_tree(SimpleNamespace(**t)) for k, t in enumerate(trees)}


@pytest.fixture(scope="module")
def forest():
    return grow_forest(4, size=(30.0, 30.0), min_dist=8.0, rounds=2, steps_per_round=5, client="sync", seed=0)


@pytest.fixture(scope="module")
def view(forest):
    v = View(_scene(forest.trees), window_size=(640, 480), lod=LOD(billboard_px=64))
    yield v
    v.close()


def _look(view, center, dist):
    view.plotter.camera_position = [tuple(center + np.array([0.3, 0.4, 1.0]) * dist), tuple(center), (0, 1, 0)]


def test_levels_follow_the_camera(view, forest, tmp_path):
    trees = [lay for lay in view.layers.values() if isinstance(lay, LodTreeLayer)]
    assert len(trees) == len(forest.trees)
    assert view.centers.shape == (len(trees), 3)
    center = view.centers.mean(0)
    _look(view, center, 15.0)                           # the observer updates the levels: no update_lod() call
    near, tris_near = view.levels.copy(), view.triangles
    assert near.min() <= 1, near
    pv_near = view.screenshot(tmp_path / "near.png")
    _look(view, center, 120.0)
    mid, tris_mid = view.levels.copy(), view.triangles
    _look(view, center, 2000.0)
    far, tris_far = view.levels.copy(), view.triangles
    assert np.all(mid >= near) and np.all(far >= mid) and np.all(far == BILLBOARD_LEVEL), (near, mid, far)
    assert tris_near > tris_mid > tris_far == 4 * len(forest.trees), (tris_near, tris_mid, tris_far)
    # exactly one actor per tree is visible, the one of its level
    for t in trees:
        vis = [i for i, a in enumerate(t.actors.values()) if a.GetVisibility()]
        assert vis == [len(t.actors) - 1]
    assert view.switches >= 2 * len(forest.trees)
    assert view.update_lod() == 0                       # nothing moved: nothing switches
    assert pv_near.shape[:2] == (480, 640)


def test_update_without_observer(forest):
    v = View(_scene(forest.trees[:1]), lod=LOD(billboard=False), window_size=(320, 240))
    try:
        v.plotter.camera.RemoveObserver(v._camera_tag)   # not observed: the level stays until update_lod()
        v._camera_tag = None
        (t,) = v.layers.values()
        v.plotter.camera_position = [tuple(t.center + np.array([0, 0, 3000.0])), tuple(t.center), (0, 1, 0)]
        assert v.levels[0] <= 1
        assert v.update_lod() == 1 and v.levels[0] == BILLBOARD_LEVEL
        assert v.triangles == t.chain[-1].triangles      # no billboard: the last mesh level is shown
    finally:
        v.close()


def test_validation():
    for kw, param in [({"levels": 0}, "levels"), ({"levels": 99}, "levels"), ({"billboard_px": 10**9}, "billboard_px"),
                      ({"thresholds": [np.nan]}, "thresholds"), ({"thresholds": [-5.0]}, "thresholds"),
                      ({"thresholds": []}, "thresholds"), ({"billboard": "yes"}, "billboard")]:
        with pytest.raises(ValueError, match=param):
            LOD(**kw)
    with pytest.raises(ValueError, match="lod must be"):
        View({}, lod="near")

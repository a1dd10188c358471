"""V6: grid polygonization of a point primitive (spec 003 §2.8)."""
import numpy as np
import pytest
import trimesh

from plantvr.implicit import Blend, Difference, polygonize, sample_grid, segment, sphere


def test_v6_sphere_polygonization():
    v, f = polygonize(sphere(radius=2.0), resolution=96)
    h = 4.0 / 95
    r = np.linalg.norm(v, axis=1)
    assert np.all(np.abs(r - 1.0) <= 1.5 * h)
    m = trimesh.Trimesh(v, f, process=False)
    assert m.is_watertight
    assert m.volume == pytest.approx(4 / 3 * np.pi, rel=0.02)


def test_compound_crown_is_watertight():
    crown = Difference(Blend(sphere((0, 0, 0), 2.0), sphere((1.0, 0.3, 0), 2.0)), segment((0, -2, 0), (0, 2, 0), 0.8))
    v, f = polygonize(crown, resolution=48)
    assert trimesh.Trimesh(v, f, process=False).is_watertight


def test_sample_grid_and_empty_envelope_errors():
    vals, origin, h = sample_grid(sphere(radius=2.0), resolution=10)
    assert vals.shape == (12, 12, 12) and h == pytest.approx(4 / 9)
    with pytest.raises(ValueError, match="empty envelope"):
        polygonize(sphere(radius=2.0), bbox=[[5, 5, 5], [6, 6, 6]])
    with pytest.raises(ValueError, match="resolution"):
        polygonize(sphere(), resolution=2)

"""V19: mesh-near sampling, uniform vs area-weighted triangle choice (spec 003 §3.7)."""
import numpy as np
import pytest
import trimesh

from plantvr.implicit.mesh_sampling import face_cdf, sample_mesh_near


def _ratio(points):
    z = points[:, 2] / np.linalg.norm(points, axis=1)
    counts = np.histogram(z, bins=10, range=(-1, 1))[0]
    return (counts[0] + counts[-1]) / (counts[4] + counts[5])


def test_v19_pole_equator_ratio():
    m = trimesh.creation.uv_sphere(radius=1.0, count=[64, 64])
    v, f = m.vertices, m.faces
    pu, _ = sample_mesh_near(v, f, 20000, offset=(0.02, 0.1), selection="uniform", rng=19)
    pa, _ = sample_mesh_near(v, f, 20000, offset=(0.02, 0.1), selection="area", rng=19)
    assert 2.6 <= _ratio(pu) <= 3.4
    assert 0.9 <= _ratio(pa) <= 1.1
    r = np.linalg.norm(pa, axis=1)
    assert r.min() > 1.0 + 0.02 - 2e-3 and r.max() < 1.0 + 0.1 + 1e-9


def test_v19_cdf_and_zero_area_faces():
    m = trimesh.creation.uv_sphere(radius=1.0, count=[16, 16])
    v = np.vstack([m.vertices, [[5, 5, 5]]])
    f = np.vstack([m.faces, [[len(v) - 1, len(v) - 1, 0]]])         # a zero-area face
    cdf = face_cdf(v, f)
    assert cdf[0] == 0 and cdf[-1] == 1 and np.all(np.diff(cdf) >= 0)
    _, idx = sample_mesh_near(v, f, 50000, offset=(0.0, 0.0), rng=1)
    assert not np.any(idx == len(f) - 1)
    # zero offset: points lie on their faces (barycentric, inside the triangle)
    p, idx = sample_mesh_near(m.vertices, m.faces, 200, offset=(0.0, 0.0), rng=2)
    tri = m.triangles[idx]
    bary = trimesh.triangles.points_to_barycentric(tri, p)
    assert np.all(bary > -1e-9)


def test_mesh_sampling_bad_input():
    m = trimesh.creation.icosphere(1)
    with pytest.raises(ValueError, match="selection"):
        sample_mesh_near(m.vertices, m.faces, 10, selection="random")
    with pytest.raises(ValueError, match="offset"):
        sample_mesh_near(m.vertices, m.faces, 10, offset=(0.1, 0.0))
    with pytest.raises(ValueError, match="faces must index"):
        face_cdf(m.vertices, m.faces + 1000)

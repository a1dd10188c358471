"""Crown envelopes from points (issue 22): alpha shape (closed TriMesh) and implicit blob (BlobTree)."""
import numpy as np
import pytest
import trimesh

from plantvr.implicit.blobtree import Node
from plantvr.implicit.crown import grow_in_crown
from plantvr.implicit.envelope import alpha_shape, crown_from_points, implicit_envelope
from plantvr.implicit.sampling import sample_inside
from plantvr.types import TriMesh


def _ball_scan(n=3000, seed=0, r=2.0, c=(0.0, 0.0, 4.0)):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    return v * r * rng.random(n)[:, None] ** (1 / 3) + c


def test_alpha_shape_of_a_solid_is_closed_and_near_the_hull():
    pts = _ball_scan()
    hull = trimesh.convex.convex_hull(pts)
    inf = alpha_shape(pts, alpha=np.inf)  # alpha = inf: the convex hull
    assert isinstance(inf, TriMesh) and inf.is_watertight
    assert np.isclose(inf.to_trimesh().volume, hull.volume, rtol=1e-9)
    m = crown_from_points(pts, method="alpha", alpha=1.0)
    assert m.is_watertight
    vol = m.to_trimesh().volume
    assert 0.8 * hull.volume < vol <= hull.volume * (1 + 1e-9)  # outward winding: positive volume


def _winding(mesh, q):
    """Generalized winding number of points q (van Oosterom-Strackee solid angles): 1 inside, 0 outside."""
    v, f = mesh.vertices, mesh.faces
    out = []
    for p in np.atleast_2d(q):
        a, b, c = v[f[:, 0]] - p, v[f[:, 1]] - p, v[f[:, 2]] - p
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la \
            + np.einsum("ij,ij->i", c, a) * lb
        out.append(2 * np.arctan2(num, den).sum() / (4 * np.pi))
    return np.array(out)


def test_alpha_shape_follows_a_concave_crown():
    a, b = _ball_scan(2000, 1, 1.0, (-1.6, 0, 4)), _ball_scan(2000, 2, 1.0, (1.6, 0, 4))
    pts = np.concatenate([a, b])
    m = alpha_shape(pts, alpha=0.5)
    assert m.is_watertight
    w = _winding(m, [[0.0, 0.0, 4.0], [-1.6, 0, 4.0], [1.6, 0, 4.0]])
    np.testing.assert_allclose(w, [0.0, 1.0, 1.0], atol=1e-6)  # the gap between the lobes stays outside


def test_implicit_envelope_contains_the_scan_and_feeds_the_crown_sca():
    pts = _ball_scan(2000, 3)
    node = crown_from_points(pts, method="implicit", radius=0.8, max_primitives=500)
    assert isinstance(node, Node)
    assert node.inside(pts).mean() > 0.97
    assert not node.inside([[0.0, 0.0, 10.0]])[0]
    markers = sample_inside(node, 1500, rng=0)
    res = grow_in_crown(markers, np.array([[0.0, 0.0, 0.0]]), step_size=0.2, kill_radius=0.3,
                        influence_radius=3.0)
    assert len(res.nodes) > 20


def test_envelope_checked():
    with pytest.raises(ValueError, match="method"):
        crown_from_points(np.zeros((5, 3)), method="convex")
    with pytest.raises(ValueError, match="coplanar"):
        alpha_shape(np.c_[np.random.default_rng(0).random((20, 2)), np.zeros(20)])
    with pytest.raises(ValueError, match="radius"):
        implicit_envelope(_ball_scan(10), radius=-1)
    with pytest.raises(ValueError, match="keeps no"):
        alpha_shape(_ball_scan(50), alpha=1e-6)

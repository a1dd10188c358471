"""Loop smoothing with collision resolution (spec 002 §3.9, V25, C14)."""
import numpy as np
import pytest

from plantvr.flowers import ccd
from plantvr.flowers.composer import grow
from plantvr.flowers.models import sunflower_head
from plantvr.flowers.smoothing import loop_smooth, midpoint_subdivide
from plantvr.subdivision.loop import subdivide_loop


def _sheet(n=4):
    xs = np.linspace(0, 1, n)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    V = np.column_stack([X.ravel(), Y.ravel(), np.sin(3 * X.ravel()) * 0.2])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return V, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_v25_midpoint_mesh_matches_loop_vertex_for_vertex():
    V, F = _sheet()
    Ms, F2 = midpoint_subdivide(V, F)
    Mf, F3 = subdivide_loop(V, F, 1)
    np.testing.assert_array_equal(F2, F3)
    assert Ms.shape == Mf.shape
    # child 0 of face f is (a, e_ab, e_ca): its odd vertices are the midpoints of the parent's edges
    a, b, c = F[:, 0], F[:, 1], F[:, 2]
    np.testing.assert_allclose(Ms[F2[0::4, 1]], 0.5 * (V[a] + V[b]))
    np.testing.assert_allclose(Ms[F2[0::4, 2]], 0.5 * (V[a] + V[c]))
    np.testing.assert_array_equal(Ms[:len(V)], V)


@pytest.fixture(scope="module")
def grown_head():
    head = sunflower_head(21, detail=0.6, n_frames=4)
    x, _ = grow(head.canopy, head.schedule(5))
    assert ccd.count_static_intersections(x, head.canopy.faces) == 0
    return head, x


def test_v25_smoothing_without_handling_intersects_with_handling_not(grown_head):
    head, x = grown_head
    V0, F0 = loop_smooth(x, head.canopy.faces, 2, fixed=head.canopy.fixed, collisions=False)
    assert ccd.count_static_intersections(V0, F0) >= 1            # Fig. 4.8b
    st = []
    V1, F1 = loop_smooth(x, head.canopy.faces, 2, fixed=head.canopy.fixed, stats=st)
    assert len(F1) == 16 * len(head.canopy.faces)
    assert ccd.count_static_intersections(V1, F1) == 0            # Fig. 4.8c
    assert len(st) == 2 and st[0]["constraints"] > 0
    # attachments stay put; old vertices keep their indices
    np.testing.assert_array_equal(V1[head.canopy.fixed], x[head.canopy.fixed])


def test_v25_coarse_pinning_moves_only_new_vertices(grown_head):
    head, x = grown_head
    V1, F1 = loop_smooth(x, head.canopy.faces, 1, fixed=head.canopy.fixed, pin="coarse")
    assert ccd.count_static_intersections(V1, F1) == 0
    Vf, _ = subdivide_loop(x, head.canopy.faces, 1, boundary_rule="loop_cubic")
    Vf[head.canopy.fixed] = x[head.canopy.fixed]
    n = len(x)
    np.testing.assert_allclose(V1[:n], Vf[:n])                    # even vertices: exact Loop positions


def test_bad_input_smoothing():
    V, F = _sheet()
    with pytest.raises(ValueError, match="pin"):
        loop_smooth(V, F, 1, pin="all")
    with pytest.raises(ValueError, match="faces must index"):
        loop_smooth(V, F + 100, 1)
    with pytest.raises(ValueError, match="fixed must index"):
        loop_smooth(V, F, 1, fixed=[999])
    with pytest.raises(ValueError, match="n_iter"):
        loop_smooth(V, F, -1)

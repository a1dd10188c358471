"""Spec 001 §1.2 / issue 5: a tree grown by the growth engine (plantvr.Model snapshot) becomes one watertight surface."""
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

import plantvr
from plantvr.growth.scenarios import demo_session, run
from plantvr.subdivision import as_graph, build_control_mesh, tree_mesh

from ._helpers import mesh_invariants


@pytest.fixture(scope="module")
def grown():
    model = plantvr.Model(seed=0)
    run(model, demo_session(darts=100), 16)
    return model


def test_grown_model_snapshot_is_watertight(grown):
    snap = grown.snapshot
    assert snap.n_internodes > 20 and np.any(np.bincount(snap.parent[1:]) > 1)   # a real branching tree
    with warnings.catch_warnings():
        warnings.simplefilter("error")               # a benign grown tree needs no fallback (V7) or clamp (§2.2)
        mesh = tree_mesh(snap, levels=2)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.euler_number == 2 and mesh.volume > 0
    inv = mesh_invariants(mesh.vertices, mesh.faces)
    assert inv["max_edge_faces"] == 2 and inv["duplicate_directed"] == 0 and inv["degenerate"] == 0
    # the surface follows the skeleton: every node lies inside the surface's bounding box grown by its radius
    lo, hi = mesh.bounds
    r = snap.radius.max()
    assert np.all(snap.pos >= lo - r) and np.all(snap.pos <= hi + r)
    # the tips and the base stay where the growth engine put them (fixed boundary loops, spec V16)
    leaves = np.setdiff1d(np.arange(1, len(snap.pos)), snap.parent)
    cm = build_control_mesh(as_graph(snap))
    g = cm.graph
    tips = cm.vertices[cm.last_loop[g.is_leaf]].mean(axis=1)
    np.testing.assert_allclose(np.sort(tips, 0), np.sort(snap.pos[leaves], 0), atol=1e-9)


def test_model_and_tuple_give_the_same_mesh(grown):
    snap = grown.snapshot
    a = tree_mesh(grown, levels=1)
    b = tree_mesh((snap.pos, snap.parent, snap.radius), levels=1)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)


def test_snapshot_errors_are_clear():
    one = SimpleNamespace(pos=np.zeros((1, 3)), parent=np.array([-1]), radius=np.ones(1))
    with pytest.raises(ValueError, match="the snapshot has 1 node"):
        as_graph(one)
    cyc = SimpleNamespace(pos=np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.]]), parent=np.array([-1, 2, 1]),
                          radius=np.ones(3))
    with pytest.raises(ValueError, match="without cycles"):
        as_graph(cyc)
    with pytest.raises(ValueError, match="tree must be an L-system str"):
        as_graph(3.0)

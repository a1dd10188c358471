"""Flood fill, geodesic fill, split, merge and the preserve-labels brush (issue 15) against brute-force graph
searches and scipy csgraph, on the synthetic flower head and pyvista's frog-tissue scan (label 1 = vessels)."""
from collections import deque

import numpy as np
import pytest
from scipy.sparse import csgraph

from plantvr.documents.labels import Segmentation
from plantvr.vine import fill as F
from plantvr.adapters.vtk_isosurface import extract_isosurface


@pytest.fixture(scope="module")
def graph(surface):
    return F.mesh_graph(surface.vertices, surface.faces)


@pytest.fixture(scope="module")
def frog():
    """Blood-vessel surface of pyvista's bundled frog tissue volume (ships with pyvista, loads offline)."""
    examples = pytest.importorskip("pyvista.examples")
    img = examples.load_frog_tissues()
    a = np.asarray(img.point_data.active_scalars).reshape(img.dimensions[::-1]).transpose(2, 1, 0)
    vessels = ((a[::2, ::2, ::2] == 1) * 255).astype(np.uint8)
    s = extract_isosurface(vessels, 127.5)
    return s


def _brute_adjacency(faces, n):
    nb = [set() for _ in range(n)]
    for a, b, c in faces.tolist():
        nb[a] |= {b, c}
        nb[b] |= {a, c}
        nb[c] |= {a, b}
    return nb


def _brute_flood(nb, labels, seed):
    """Plain-Python BFS over same-label neighbours (the oracle of the oracle)."""
    seen = {seed}
    q = deque([seed])
    while q:
        u = q.popleft()
        for w in nb[u]:
            if w not in seen and labels[w] == labels[seed]:
                seen.add(w)
                q.append(w)
    return np.array(sorted(seen), np.int64)


def test_mesh_graph_matches_faces(surface, graph):
    nb = _brute_adjacency(surface.faces, len(surface.vertices))
    for v in (0, 17, 4000, len(nb) - 1):
        row = graph.indices[graph.indptr[v]:graph.indptr[v + 1]]
        assert row.tolist() == sorted(nb[v])
        w = graph.weights[graph.indptr[v]:graph.indptr[v + 1]]
        np.testing.assert_allclose(w, np.linalg.norm(surface.vertices[row].astype(np.float64)
                                                     - surface.vertices[v].astype(np.float64), axis=1))
    assert graph.indices.size == 2 * len({tuple(sorted(e)) for f in surface.faces.tolist()
                                          for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))})


def test_csr_kernel_matches_scipy_twin(surface):
    f = surface.faces.copy()
    f[5] = [f[5, 0], f[5, 0], f[5, 1]]                  # a degenerate face: no self loop
    ip, ix = F._csr_numba(f, len(surface.vertices))
    ip2, ix2 = F._csr_scipy(f, len(surface.vertices))
    np.testing.assert_array_equal(ip, ip2)
    np.testing.assert_array_equal(ix, ix2)
    g = F.mesh_graph(surface.vertices, f)
    assert g.nbytes == ip.nbytes + ix.nbytes             # edge lengths not built yet
    assert g.weights.size == ix.size and g.nbytes == ip.nbytes + ix.nbytes + 8 * ix.size
    np.testing.assert_array_equal(g.weights, F._edge_lengths(ip, ix, surface.vertices))


def test_flood_equals_brute_force_and_csgraph(surface, graph, truth):
    nb = _brute_adjacency(surface.faces, len(surface.vertices))
    rng = np.random.default_rng(3)
    for seed in rng.integers(0, len(truth), 8):
        got = F.flood_region(graph, truth, int(seed))
        np.testing.assert_array_equal(got, _brute_flood(nb, truth, int(seed)))
        np.testing.assert_array_equal(got, F._flood_numpy(graph, truth, int(seed)))
        assert np.all(truth[got] == truth[seed])


def test_geodesic_fill_equals_scipy_dijkstra(graph, truth):
    rng = np.random.default_rng(4)
    for seed, radius in zip(rng.integers(0, len(truth), 6), (0.0, 0.5, 2.0, 5.0, 12.0, 1e9)):
        ids, d = F.flood_region(graph, truth, int(seed), radius=radius, return_distances=True)
        ids2, d2 = F._geodesic_numpy(graph, truth, int(seed), radius)
        np.testing.assert_array_equal(ids, ids2)
        np.testing.assert_allclose(d, d2, rtol=1e-12, atol=1e-12)
        assert d.max() <= radius and seed in ids
    whole = F.flood_region(graph, truth, 5)
    np.testing.assert_array_equal(F.flood_region(graph, truth, 5, radius=1e9), whole)


def test_components_twin(graph, truth):
    c, n = F.label_components(graph, truth)
    c2, n2 = F._components_numpy(graph, truth)
    assert n == n2
    np.testing.assert_array_equal(c, c2)
    for lab in (0, 2, 6):
        c, n = F.label_components(graph, truth, label=lab)
        c2, n2 = F._components_numpy(graph, truth, lab)
        np.testing.assert_array_equal(c, c2)
        sub = graph.to_scipy()[truth == lab][:, truth == lab]
        assert n == csgraph.connected_components(sub, directed=False)[0]


def test_kernels_match_twins_without_jit(monkeypatch, surface, graph, truth):
    """The kernels' Python source (coverage sees it) gives the same answers as the compiled ones."""
    for name in ("_bfs_fill", "_flood_numba", "_geodesic_numba", "_components_numba", "_csr_numba",
                 "_edge_lengths_numba"):
        monkeypatch.setattr(F, name, getattr(F, name).py_func)
    f = surface.faces[:800]
    g = F.mesh_graph(surface.vertices, f)
    ip, ix = F._csr_scipy(f, len(surface.vertices))
    np.testing.assert_array_equal(g.indptr, ip)
    np.testing.assert_array_equal(g.indices, ix)
    np.testing.assert_array_equal(g.weights, F._edge_lengths(ip, ix, surface.vertices))
    np.testing.assert_array_equal(F.flood_region(graph, truth, 7), F._flood_numpy(graph, truth, 7))
    ids, _ = F.flood_region(graph, truth, 7, radius=3.0, return_distances=True)
    np.testing.assert_array_equal(ids, F._geodesic_numpy(graph, truth, 7, 3.0)[0])
    np.testing.assert_array_equal(F.label_components(graph, truth, label=3)[0],
                                  F._components_numpy(graph, truth, 3)[0])


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"seed": -1}, "seed must be an integer"), ({"seed": 10 ** 9}, "seed must be an integer"),
    ({"seed": 0, "radius": -1.0}, "radius must be in"), ({"seed": 0, "radius": float("nan")}, "radius must be"),
    ({"seed": 0, "return_distances": True}, "return_distances needs a radius")])
def test_flood_region_rejects(graph, truth, kwargs, match):
    with pytest.raises(ValueError, match=match):
        F.flood_region(graph, truth, **kwargs)


def test_flood_rejects_bad_labels_and_mesh(graph):
    with pytest.raises(ValueError, match="labels must be an integer array"):
        F.flood_region(graph, np.zeros(3, np.uint8), 0)
    with pytest.raises(ValueError, match="faces must index vertices"):
        F.mesh_graph(np.zeros((3, 3)), np.array([[0, 1, 5]]))


# ------------------------------------------------------------------------------------------------ Segmentation
@pytest.fixture
def seg(surface, truth):
    return Segmentation(surface.vertices, surface.faces, labels=truth)


def _state(seg):
    return (seg.labels.copy(), seg.colors.rgba.copy(), seg.colors.visible.copy(), len(seg.history.undo_stack),
            len(seg.history.redo_stack))


def _same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(a, b))


def test_fill_one_undo_step(seg, truth):
    nb_before = len(seg.history.undo_stack)
    region = F._flood_numpy(seg.graph, truth, 100)
    n = seg.fill(100, 11)
    assert n == region.size and len(seg.history.undo_stack) == nb_before + 1
    assert np.all(seg.labels[region] == 11)
    out = np.setdiff1d(np.arange(seg.n_vertices), region)
    np.testing.assert_array_equal(seg.labels[out], truth[out])
    seg.undo()
    np.testing.assert_array_equal(seg.labels, truth)
    seg.redo()
    assert np.all(seg.labels[region] == 11)
    assert seg.fill(100, 11) == 0                    # same label: nothing to do, no undo item
    assert len(seg.history.undo_stack) == nb_before + 1


def test_geodesic_fill_limits_region(seg, truth):
    ids, _d = F._geodesic_numpy(seg.graph, truth, 200, 3.0)
    assert seg.fill(200, 12, radius=3.0) == ids.size
    np.testing.assert_array_equal(np.flatnonzero(seg.labels != truth), ids)


def test_fill_rejects_and_changes_nothing(seg):
    before = _state(seg)
    log = len(seg.log)
    for args, match in [((-1, 2), "vertex must be an integer"), ((seg.n_vertices, 2), "vertex must be"),
                        ((0, 99), "label must be an integer"), ((0, 2, -1.0), "radius must be in"),
                        ((0, 2, 1e12), "radius must be in")]:
        with pytest.raises(ValueError, match=match):
            seg.fill(*args)
    seg.hide(3)
    with pytest.raises(ValueError, match="label 3 is hidden"):
        seg.fill(0, 3)
    v3 = int(np.flatnonzero(seg.labels == 3)[0])
    with pytest.raises(ValueError, match=f"vertex {v3} has hidden label 3"):
        seg.fill(v3, 2)
    seg.show(3)
    assert _same(before, _state(seg))
    assert len(seg.log) == log + 2              # only the hide/show events


def test_split_label_into_components(seg, truth):
    lab = 4
    comp, n = F._components_numpy(seg.graph, truth, lab)
    assert n > 2
    ncol = len(seg.colors)
    parts = seg.split_label(lab)
    assert len(parts) == n and parts[0] == lab and len(seg.colors) == ncol + n - 1
    assert len(set(map(tuple, seg.colors.rgba[parts].tolist()))) == n        # separately coloured
    sizes = np.bincount(comp[comp >= 0])
    for c in range(n):                                 # each component holds exactly one label
        got = np.unique(seg.labels[comp == c])
        assert got.size == 1
        if sizes[c] == sizes.max() and c == int(np.argmax(sizes)):
            assert got[0] == lab
    np.testing.assert_array_equal(seg.labels[truth != lab], truth[truth != lab])
    assert len(seg.history.undo_stack) == 1
    seg.undo()
    np.testing.assert_array_equal(seg.labels, truth)


def test_split_min_vertices_and_full_table(seg, truth):
    comp, _n = F._components_numpy(seg.graph, truth, 5)
    sizes = np.sort(np.bincount(comp[comp >= 0]))[::-1]
    parts = seg.split_label(5, min_vertices=int(sizes[2]))
    assert len(parts) == int(np.sum(sizes[1:] >= sizes[2])) + 1
    before = _state(seg)
    for _ in range(256 - len(seg.colors)):
        seg.colors.add_color((1, 2, 3))
    full = _state(seg)
    with pytest.raises(ValueError, match="colour table has room for 0 more colours"):
        seg.split_label(6)
    assert _same(full, _state(seg))
    with pytest.raises(ValueError, match="min_vertices must be an integer"):
        seg.split_label(6, min_vertices=0)
    assert before[0].tolist() == seg.labels.tolist()


def test_merge_labels(seg, truth):
    n7 = int(np.sum(truth == 7))
    assert seg.merge_labels(2, 7) == n7
    assert not np.any(seg.labels == 7)
    np.testing.assert_array_equal(seg.labels == 2, (truth == 2) | (truth == 7))
    seg.undo()
    np.testing.assert_array_equal(seg.labels, truth)
    before = _state(seg)
    for args, match in [((2, 2), "other must differ from keep"), ((2, 300), "other must be an integer"),
                        ((-1, 2), "keep must be an integer")]:
        with pytest.raises(ValueError, match=match):
            seg.merge_labels(*args)
    assert _same(before, _state(seg))


def test_fill_split_merge_replay(seg, surface, truth):
    seg.fill(100, 11)
    seg.split_label(4)
    seg.merge_labels(2, 7)
    seg.fill(300, 1, 2.5)
    seg.paint(surface.vertices[50], 4.0, 3, True)
    other = Segmentation(surface.vertices, surface.faces, labels=truth)
    other.replay(seg.log)
    np.testing.assert_array_equal(other.labels, seg.labels)
    np.testing.assert_array_equal(other.colors.rgba, seg.colors.rgba)


def test_frog_vessels_fill_split_merge(frog):
    """Real scan: the frog's blood vessels fall apart into many pieces; fill, split and merge match csgraph."""
    s = frog
    labels = np.where(s.vertices[:, 0] < np.median(s.vertices[:, 0]), 1, 0).astype(np.uint8)
    seg = Segmentation(s.vertices, s.faces, labels=labels)
    A = seg.graph.to_scipy()
    n_all = csgraph.connected_components(A, directed=False)[0]
    assert n_all > 20                                   # many separate vessel pieces in the scan
    nb = _brute_adjacency(s.faces, len(s.vertices))
    seed = int(np.flatnonzero(labels == 0)[0])
    region = _brute_flood(nb, labels, seed)
    assert seg.fill(seed, 2) == region.size
    seg.undo()
    sub = A[labels == 1][:, labels == 1]
    n1 = csgraph.connected_components(sub, directed=False)[0]
    parts = seg.split_label(1, min_vertices=1) if n1 <= 255 - len(seg.colors) else seg.split_label(1, 30)
    comp, _ = F._components_numpy(seg.graph, labels, 1)
    for c in np.unique(comp[comp >= 0]):
        assert np.unique(seg.labels[comp == c]).size == 1
    assert set(np.unique(seg.labels[labels == 1])) == set(parts)
    seg.merge_labels(parts[0], parts[1])
    assert not np.any(seg.labels == parts[1])
    seg.undo()
    seg.undo()
    np.testing.assert_array_equal(seg.labels, labels)


# ------------------------------------------------------------------------------------------------ preserve labels
def test_preserve_never_overwrites_finished_labels(surface):
    rng = np.random.default_rng(5)
    seg = Segmentation(surface.vertices, surface.faces)
    for _ in range(10):
        seg.paint(surface.vertices[rng.integers(seg.n_vertices)], 5.0, int(rng.integers(1, 4)))
    finished = seg.labels.copy()
    for _ in range(30):
        c = surface.vertices[rng.integers(seg.n_vertices)]
        seg.paint(c, float(rng.uniform(0, 15)), int(rng.integers(4, 9)), preserve=True)
    kept = finished != 0
    np.testing.assert_array_equal(seg.labels[kept], finished[kept])
    assert np.any(seg.labels[~kept] != 0)                # and it did paint the unlabelled ones


def test_preserve_set_and_attribute(surface):
    seg = Segmentation(surface.vertices, surface.faces)
    c = surface.vertices[0]
    seg.paint(c, 6.0, 2)
    seg.paint(c, 3.0, 3)
    before = seg.labels.copy()
    seg.preserve = (2,)                                  # only label 2 may be painted over
    seg.paint(c, 10.0, 5)
    assert np.all(seg.labels[before == 3] == 3) and np.all(seg.labels[before == 0] == 0)
    assert np.all(seg.labels[before == 2] == 5)
    seg.undo()
    seg.preserve = False
    n = seg.paint_stroke([c, c], 10.0, 6, preserve=(0,))
    assert n == int(np.sum((before == 0) & (np.linalg.norm(surface.vertices - c, axis=1) <= 10.0)))
    assert np.all(seg.labels[before != 0] == before[before != 0])


def test_preserve_rejects(surface):
    seg = Segmentation(surface.vertices, surface.faces)
    for bad, match in [((1, 300), "preserve must be an integer in"), ("x", "preserve must be an integer"),
                       (2.5, "preserve must be False, True or a collection")]:
        with pytest.raises(ValueError, match=match):
            seg.paint(surface.vertices[0], 5.0, 2, preserve=bad)
    assert not np.any(seg.labels) and not seg.log.events


@pytest.fixture(scope="module")
def ico():
    import trimesh
    m = trimesh.creation.icosphere(subdivisions=2)
    return m.vertices.astype(np.float32), m.faces.astype(np.uint32)


def test_property_fill_split_merge_random_labels(ico):
    """Random labellings of an icosphere: fill = brute-force BFS, split parts = csgraph components,
    merge + undo restores; every command is one undo step."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    v, f = ico
    nb = _brute_adjacency(f, len(v))

    @settings(max_examples=15, deadline=None, derandomize=True)
    @given(seed=st.integers(0, 2 ** 32 - 1), k=st.integers(1, 4), vertex=st.integers(0, len(v) - 1))
    def check(seed, k, vertex):
        labels = np.random.default_rng(seed).integers(0, k, len(v)).astype(np.uint8)
        seg = Segmentation(v, f, labels=labels)
        region = _brute_flood(nb, labels, vertex)
        target = (int(labels[vertex]) + 1) % 5
        assert seg.fill(vertex, target) == region.size
        assert np.flatnonzero(seg.labels != labels).tolist() == region.tolist()
        seg.undo()
        lab = int(labels[vertex])
        sub = seg.graph.to_scipy()[labels == lab][:, labels == lab]
        n = csgraph.connected_components(sub, directed=False)[0]
        parts = seg.split_label(lab)
        assert len(parts) == n
        assert set(np.unique(seg.labels[labels == lab]).tolist()) == set(parts)
        seg.undo()
        other = (lab + 1) % 5
        seg.merge_labels(other, lab)
        assert not np.any(seg.labels == lab)
        seg.undo()
        np.testing.assert_array_equal(seg.labels, labels)
        assert len(seg.history.undo_stack) == 0 and len(seg.history.redo_stack) == 1   # new commands clear redo

    check()


def test_preserve_attribute_is_validated(surface):
    seg = Segmentation(surface.vertices, surface.faces)
    seg.preserve = [3, 0, 3]
    assert seg.preserve == (0, 3)
    with pytest.raises(ValueError, match="preserve must be an integer in"):
        seg.preserve = (99,)
    assert seg.preserve == (0, 3)
    seg.preserve = None
    assert seg.preserve is False

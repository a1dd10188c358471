"""Display proxy (issue 14): mapping covers every vertex once, delta update == recompute, painting through the
proxy view == painting the full mesh, hiding acts on both."""
import numpy as np
import pytest
import trimesh

from plantvr.documents.labels import Segmentation
from plantvr.vine.index import ball_query_brute
from plantvr.vine.proxy import (
    DisplayProxy,
    _collapse_roots,
    _collapse_roots_numpy,
    _merge_hash,
    _merge_numpy,
    _proxy_labels_numpy,
    decimate_with_owner,
    merge_coincident,
    proxy_labels,
)


@pytest.fixture
def seg(surface):
    return Segmentation(surface.vertices, surface.faces, normals=surface.normals)


@pytest.fixture
def proxy(seg):
    return DisplayProxy(seg, target_faces=len(seg.faces) // 8)


def _recomputed(px, seg):
    return _proxy_labels_numpy(px.owner, px.n_vertices, seg.labels, seg.colors.paintable_lut())


def test_mapping_covers_every_vertex_exactly_once(seg, proxy):
    assert proxy.owner.shape == (seg.n_vertices,)
    assert len(proxy.faces) <= len(seg.faces) // 8 + 8 and proxy.n_vertices < seg.n_vertices // 4
    assert proxy.owner.min() >= 0 and proxy.owner.max() < proxy.n_vertices
    # the CSR member lists partition the full-resolution vertices
    assert np.array_equal(np.sort(proxy.members), np.arange(seg.n_vertices))
    assert np.all(np.diff(proxy.starts) >= 1)                 # every proxy vertex stands for someone
    for p in (0, proxy.n_vertices // 2, proxy.n_vertices - 1):
        assert np.all(proxy.owner[proxy.members_of(p)] == p)
    # members sit near their proxy vertex (decimation error, a few voxels on this 64³ head)
    d = np.linalg.norm(proxy.vertices[proxy.owner] - seg.vertices, axis=1)
    assert np.percentile(d, 95) < 4.0
    assert proxy.faces.max() < proxy.n_vertices and proxy.normals.shape == proxy.vertices.shape


def test_chunked_decimation_maps_every_vertex_once(seg):
    """Meshes above chunk_faces are decimated in two stages (slabs with locked cuts, then their union): the
    mapping is still a partition, the cut vertices are not duplicated and the proxy is as good as one pass."""
    whole = DisplayProxy(seg, target_faces=len(seg.faces) // 8, observe=False)
    px = DisplayProxy(seg, target_faces=len(seg.faces) // 8, chunk_faces=len(seg.faces) // 5, observe=False)
    assert px.owner.dtype == np.int32 and px.members.dtype == np.int32
    assert np.array_equal(np.sort(px.members), np.arange(seg.n_vertices))
    assert np.all(np.diff(px.starts) >= 1)
    assert len(px.faces) <= len(seg.faces) // 8 + 8 and abs(px.n_vertices / whole.n_vertices - 1) < 0.1
    assert len(np.unique(px.vertices, axis=0)) == px.n_vertices          # cut vertices merged across slabs
    d = np.linalg.norm(px.vertices[px.owner] - seg.vertices, axis=1)
    d_whole = np.linalg.norm(whole.vertices[whole.owner] - seg.vertices, axis=1)
    assert np.percentile(d, 95) < 1.5 * np.percentile(d_whole, 95) + 0.5
    # members far from their collapse survivor (long chains) went to their nearest proxy vertex instead
    from scipy.spatial import cKDTree
    e = px.vertices[px.faces[:, 0]] - px.vertices[px.faces[:, 1]]
    lim = 3.0 * np.sqrt(np.median(np.einsum("ij,ij->i", e, e)))
    d_near, _ = cKDTree(px.vertices).query(seg.vertices)
    assert np.all((d <= lim + 1e-4) | (d <= d_near + 1e-4))
    assert d.max() <= max(lim, d_near.max()) + 1e-4
    # the proxy surface is no more open than the one-pass proxy (no cracks along the slab cuts)
    def n_border(p):
        m = trimesh.Trimesh(p.vertices, p.faces, process=False)
        return len(trimesh.grouping.group_rows(m.edges_sorted, require_count=1))
    assert n_border(px) <= n_border(whole) + 8
    area = [trimesh.Trimesh(p.vertices, p.faces, process=False).area for p in (px, whole)]
    assert abs(area[0] / area[1] - 1) < 0.05


def test_decimate_with_owner_direct_and_rejects(surface):
    first, inverse, mf = merge_coincident(surface.vertices, surface.faces)
    assert mf.dtype == np.int32 and inverse.dtype == np.int32
    merged = surface.vertices[first]
    pts, pf, owner = decimate_with_owner(merged, mf, len(mf) // 10, chunk_faces=len(mf) // 3)
    assert pts.dtype == np.float32 and pf.dtype == np.uint32 and owner.shape == (len(merged),)
    assert owner.min() >= 0 and owner.max() < len(pts) and len(np.unique(owner)) == len(pts)
    with pytest.raises(ValueError, match="chunk_faces"):
        decimate_with_owner(merged, mf, 100, chunk_faces=10)
    with pytest.raises(ValueError, match="target_faces"):
        decimate_with_owner(merged, mf, 1)


def test_nearest_method_maps_to_nearest_proxy_vertex(seg):
    px = DisplayProxy(seg, target_faces=len(seg.faces) // 8, method="nearest")
    d_own = np.linalg.norm(px.vertices[px.owner] - seg.vertices, axis=1)
    from scipy.spatial import cKDTree
    d_best, _ = cKDTree(px.vertices).query(seg.vertices)
    assert np.allclose(d_own, d_best, atol=1e-5)


def test_small_mesh_is_its_own_proxy(seg):
    px = DisplayProxy(seg, target_faces=len(seg.faces))
    assert px.vertices is seg.vertices and np.array_equal(px.owner, np.arange(seg.n_vertices))
    seg.paint(seg.vertices[7], 5.0, 4)
    assert np.array_equal(px.labels, seg.labels)


def test_delta_update_equals_recompute_over_paint_undo_redo(seg, proxy):
    rng = np.random.default_rng(3)
    seen = []
    proxy.observe(lambda ch: seen.append((ch["new"].kind, None if ch["new"].ids is None else ch["new"].ids.copy())),
                  names="change")
    for k in range(12):
        before = proxy.labels.copy()
        c = seg.vertices[rng.integers(seg.n_vertices)]
        seg.paint(c, float(rng.uniform(1.0, 9.0)), int(rng.integers(1, 8)))
        assert np.array_equal(proxy.labels, _recomputed(proxy, seg))
        changed = np.nonzero(proxy.labels != before)[0]
        got = np.concatenate([ids for kind, ids in seen if kind == "labels"]) if seen else np.zeros(0)
        assert np.array_equal(np.unique(got), changed)   # notified ids == exactly the changed proxy vertices
        seen.clear()
        if k % 4 == 3:
            seg.undo()
            assert np.array_equal(proxy.labels, _recomputed(proxy, seg))
            seg.redo()
            assert np.array_equal(proxy.labels, _recomputed(proxy, seg))
            seen.clear()
    while seg.undo() is not None:
        pass
    assert np.array_equal(proxy.labels, _recomputed(proxy, seg))


def test_proxy_label_is_visible_majority(seg, proxy):
    p = int(np.argmax(np.diff(proxy.starts)))                 # the proxy vertex with most members
    m = proxy.members_of(p)
    seg.labels[m[: len(m) // 2 + 1]] = 5                      # direct write, then recompute
    seg.labels[m[len(m) // 2 + 1:]] = 6
    proxy.recompute()
    assert proxy.labels[p] == 5
    seg.hide(5)                                               # majority hidden: the visible minority shows
    assert proxy.labels[p] == 6 and proxy.vertex_visible()[p]
    seg.hide(6)
    assert not proxy.vertex_visible()[p]
    assert np.array_equal(proxy.labels, _recomputed(proxy, seg))


def test_hiding_a_colour_hides_it_on_both(seg, proxy):
    top = seg.vertices[np.argmax(seg.vertices[:, 2])]
    seg.paint(top, 12.0, 3)
    seg.hide(3)
    full_vis = seg.vertex_visible()
    assert not full_vis[seg.labels == 3].any()
    # no drawn proxy face has a hidden-coloured vertex, and no proxy vertex with a hidden label is drawn
    vf = proxy.visible_faces()
    assert not np.isin(proxy.labels[vf], [3]).any()
    # a proxy vertex is drawn iff at least one of its members is visible
    any_visible = np.zeros(proxy.n_vertices, bool)
    np.logical_or.at(any_visible, proxy.owner, full_vis)
    assert np.array_equal(proxy.vertex_visible(), any_visible)
    seg.show(3)
    assert len(proxy.visible_faces()) == len(proxy.faces)


def test_kernels_equal_numpy_twins(surface):
    rng = np.random.default_rng(0)
    v = surface.vertices.copy()
    dup = rng.integers(0, len(v), 500)
    v2 = np.concatenate([v, v[dup]])
    keys = np.ascontiguousarray(v2).view(np.uint32).reshape(-1, 3)
    f1, i1 = _merge_hash(keys)
    f2, i2 = _merge_numpy(keys)
    assert np.array_equal(f1, f2) and np.array_equal(i1, i2) and len(f1) == len(v)
    first, inverse, faces = merge_coincident(v2, np.concatenate([surface.faces, surface.faces]))
    assert np.array_equal(v2[first][inverse], v2) and faces.max() < len(first)
    col = np.array([[1, 0], [1, 2], [3, 1], [5, 4]])
    assert np.array_equal(_collapse_roots(6, col), _collapse_roots_numpy(6, col))
    owner = rng.integers(0, 50, 1000)
    labels = rng.integers(0, 6, 1000).astype(np.uint8)
    vis = np.array([True, True, False, True, False, True])
    assert np.array_equal(proxy_labels(owner, 50, labels, vis), _proxy_labels_numpy(owner, 50, labels,
                                                                                     np.r_[vis, np.zeros(250, bool)]))


def test_paint_through_proxy_view_equals_full_mesh_paint(surface, seg, proxy):
    pytest.importorskip("pyvista")
    from plantvr.types import LabelledSurface
    from plantvr.view import View
    view = View({"surface": LabelledSurface(proxy)}, off_screen=True, window_size=(240, 180))
    surf = view.layers["surface"]
    assert surf.mesh.n_points == proxy.n_vertices
    other = Segmentation(surface.vertices, surface.faces)
    p = proxy.vertices[proxy.n_vertices // 3].astype(float)   # a point picked on the proxy surface
    n = surf.paint_at(p, radius=6.0, label=2)
    other.paint(p, 6.0, 2)
    assert n > 0 and np.array_equal(seg.labels, other.labels)
    assert set(np.nonzero(seg.labels == 2)[0]) == set(ball_query_brute(seg.vertices, p, 6.0).tolist())
    assert np.array_equal(surf.mesh.point_data["rgba"], proxy.vertex_colors())
    seg.undo()
    assert not (seg.labels == 2).any()
    assert np.array_equal(surf.mesh.point_data["rgba"], proxy.vertex_colors())
    view.close()
    proxy.close()


def test_coarser_proxy_composes_the_owner_maps(seg, proxy):
    """A level of detail decimated from the proxy: every full-resolution vertex still has exactly one owner,
    owner = (proxy → coarse) ∘ (full → proxy), and its labels follow paint like any proxy's."""
    lod = proxy.coarser(len(proxy.faces) // 4)
    assert len(lod.faces) <= len(proxy.faces) // 4 + 8 and lod.n_vertices < proxy.n_vertices
    assert np.array_equal(np.sort(lod.members), np.arange(seg.n_vertices))
    assert np.all(np.diff(lod.starts) >= 1)
    p2c = np.empty(proxy.n_vertices, np.int64)
    p2c[proxy.owner] = lod.owner                              # each proxy vertex's members share a coarse owner
    assert np.array_equal(p2c[proxy.owner], lod.owner)
    d = np.linalg.norm(lod.vertices[lod.owner] - seg.vertices, axis=1)
    assert np.percentile(d, 95) < 8.0
    seg.paint(seg.vertices[seg.n_vertices // 2], 6.0, 3)
    assert np.array_equal(lod.labels, _recomputed(lod, seg))
    same = proxy.coarser(10 * len(proxy.faces))               # within the budget: the proxy's own mesh
    assert same.vertices is proxy.vertices and np.array_equal(same.owner, proxy.owner)
    other = Segmentation(seg.vertices, seg.faces)
    with pytest.raises(ValueError, match="base must be a DisplayProxy of the same segmentation"):
        DisplayProxy(other, base=proxy)


def test_rejected_arguments(seg):
    with pytest.raises(ValueError, match="target_faces"):
        DisplayProxy(seg, target_faces=2)
    with pytest.raises(ValueError, match="method"):
        DisplayProxy(seg, method="random")
    with pytest.raises(ValueError, match="chunk_faces"):
        DisplayProxy(seg, chunk_faces=5)
    with pytest.raises(ValueError, match="seg must be"):
        DisplayProxy("mesh")
    px = DisplayProxy(seg, target_faces=len(seg.faces) // 4)
    with pytest.raises(ValueError, match="labels must be uint8"):
        px.labels_from(np.zeros(3, np.uint8))
    assert np.array_equal(px.labels_from(seg.labels), px.labels)


# ---------------------------------------------------------------------------------------------- uint16 labels
def test_uint16_kernel_equals_numpy_twin():
    rng = np.random.default_rng(7)
    owner = rng.integers(0, 300, 20_000)
    labels = rng.integers(0, 1200, 20_000).astype(np.uint16)
    labels[rng.random(20_000) < 0.5] = 917                    # real majorities to find
    vis = rng.random(1200) < 0.7
    got = proxy_labels(owner, 300, labels, vis)
    assert got.dtype == np.uint16 and got.max() > 255
    assert np.array_equal(got, _proxy_labels_numpy(owner, 300, labels, vis))
    narrow = proxy_labels(owner, 300, (labels % 256).astype(np.uint8), vis[:256])
    assert narrow.dtype == np.uint8                           # uint8 stays uint8


def test_uint16_segmentation_through_the_proxy(surface):
    """More than 256 colours: proxy labels are uint16, follow paint / undo / hide, and its colours are the
    table's, through a decimated proxy and its view."""
    pytest.importorskip("pyvista")
    from plantvr.types import LabelledSurface
    from plantvr.view import View
    from plantvr.vine.colors import ColorTable
    seg = Segmentation(surface.vertices, surface.faces, normals=surface.normals, colors=ColorTable.with_size(1000))
    assert seg.labels.dtype == np.uint16
    proxy = DisplayProxy(seg, target_faces=len(seg.faces) // 8)
    assert proxy.labels.dtype == np.uint16
    view = View({"surface": LabelledSurface(proxy)}, off_screen=True, window_size=(240, 180))
    surf = view.layers["surface"]
    rng = np.random.default_rng(5)
    for k in (300, 917, 5, 999, 256):
        p = proxy.vertices[rng.integers(proxy.n_vertices)].astype(float)
        n = surf.paint_at(p, radius=6.0, label=k)
        assert n > 0 and np.array_equal(proxy.labels, _recomputed(proxy, seg))
        assert set(np.nonzero(seg.labels == k)[0]) <= set(ball_query_brute(seg.vertices, p, 6.0).tolist())
    assert {300, 917, 999}.issubset(set(proxy.labels.tolist()))
    assert np.array_equal(surf.mesh.point_data["rgba"], proxy.vertex_colors())
    assert np.array_equal(proxy.vertex_colors(), seg.colors.rgba[proxy.labels])
    seg.hide(917)
    assert not np.isin(proxy.labels[proxy.visible_faces()], [917]).any()
    assert np.array_equal(proxy.labels, _recomputed(proxy, seg))
    seg.undo()
    assert np.array_equal(proxy.labels, _recomputed(proxy, seg))
    assert np.array_equal(proxy.labels_from(seg.labels), proxy.labels)
    lod = proxy.coarser(len(proxy.faces) // 4)
    assert lod.labels.dtype == np.uint16 and np.array_equal(lod.labels, _recomputed(lod, seg))
    view.close()
    proxy.close()
    lod.close()


def test_proxy_follows_a_segmentation_that_widens(seg, proxy):
    seg.paint(seg.vertices[3], 5.0, 4)
    assert proxy.labels.dtype == np.uint8
    while len(seg.colors) <= 300:
        seg.add_color((10, 20, 30))                           # the 257th entry widens the labels once
    assert seg.labels.dtype == np.uint16 and proxy.labels.dtype == np.uint16
    assert np.array_equal(proxy.labels, _recomputed(proxy, seg))
    seg.paint(seg.vertices[seg.n_vertices // 2].astype(float), 6.0, 300)
    assert 300 in proxy.labels and np.array_equal(proxy.labels, _recomputed(proxy, seg))
    assert np.array_equal(proxy.vertex_colors()[proxy.labels == 300], np.tile([10, 20, 30, 255], (
        int((proxy.labels == 300).sum()), 1)))
    with pytest.raises(ValueError, match="labels must be uint8 or uint16"):
        proxy.labels_from(seg.labels.astype(np.int32))

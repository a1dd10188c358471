"""Slices against the raw volume (issue 15): the mesh–plane cut lies on skimage's slice contours."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantvr.vine import slices as S
from plantvr.view.plots import slice_figure
from plantvr.vine.colors import ColorTable


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_cut_lies_on_find_contours(head, surface, axis):
    segs = S.plane_segments(surface.vertices, surface.faces, axis, 32.0)
    cs = S.slice_contours(head.volume, head.level, axis, 32)
    pts = np.concatenate(cs)
    d, _ = cKDTree(pts).query(segs.reshape(-1, 3))
    assert d.max() < 1e-4
    assert np.all(segs[:, :, axis] == 32.0)
    assert len(segs) == sum(len(c) - 1 for c in cs)      # one cut segment per contour segment
    length = np.linalg.norm(segs[:, 0] - segs[:, 1], axis=1).sum()
    clen = sum(np.linalg.norm(np.diff(c, axis=0), axis=1).sum() for c in cs)
    assert length == pytest.approx(clen, rel=0.02)


def test_cut_between_grid_planes(surface):
    """Off-grid planes: every end point is on a mesh edge and on the plane."""
    v, f = surface.vertices.astype(np.float64), surface.faces.astype(np.int64)
    segs = S.plane_segments(v, f, "y", 30.37)
    assert len(segs) > 100 and np.allclose(segs[:, :, 1], 30.37)
    # brute force: faces with vertices strictly on both sides
    d = v[:, 1] - 30.37
    up = (d[f] > 0).sum(1)
    assert len(segs) == int(np.sum((up == 1) | (up == 2)))


def test_end_labels_from_nearer_vertex():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float64)
    f = np.array([[0, 1, 2]])
    lab = np.array([1, 2, 3], np.uint8)
    segs, el = S.plane_segments(v, f, 0, 0.25, labels=lab)
    assert segs.shape == (1, 2, 3)
    assert sorted(map(tuple, segs[0].round(6).tolist())) == [(0.25, 0.0, 0.0), (0.25, 0.75, 0.0)]
    assert sorted(el[0].tolist()) == [1, 3]          # (0.25, 0.75) is nearer vertex 2 (label 3)
    segs, el = S.plane_segments(v, f, 0, 0.75, labels=lab)
    assert sorted(el[0].tolist()) == [2, 2]


def test_slice_figure_colours(tmp_path, head, surface, truth):
    fig = slice_figure(head.volume, 2, 32, level=head.level, vertices=surface.vertices, faces=surface.faces,
                         labels=truth)
    ax = fig.axes[0]
    lc = ax.collections[0]
    cols = {tuple(np.round(c[:3] * 255).astype(int)) for c in lc.get_colors()}
    _, el = S.plane_segments(surface.vertices, surface.faces, 2, 32.0, labels=truth)
    assert cols == {tuple(int(x) for x in ColorTable().rgba[k, :3]) for k in np.unique(el)}
    assert len(ax.lines) == len(S.slice_contours(head.volume, head.level, 2, 32))
    fig.savefig(tmp_path / "slice.png")


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"axis": 3}, "axis must be an integer"), ({"axis": "w"}, "axis must be 0, 1, 2"),
    ({"index": 64}, "index must be an integer in"), ({"linewidth": 0}, "linewidth must be in"),
    ({"spacing": (1, 1)}, "spacing must have shape")])
def test_slice_figure_rejects(head, kwargs, match):
    args = {"axis": 0, "index": 3} | kwargs
    with pytest.raises(ValueError, match=match):
        slice_figure(head.volume, args.pop("axis"), args.pop("index"), **args)


def test_plane_segments_rejects(surface):
    with pytest.raises(ValueError, match="position must be in"):
        S.plane_segments(surface.vertices, surface.faces, 0, float("inf"))
    with pytest.raises(ValueError, match="labels must be uint8"):
        S.plane_segments(surface.vertices, surface.faces, 0, 1.0, labels=np.zeros(3, np.uint8))


def test_view_slices_follow_labels(tmp_path, head, surface, truth):
    """pyvista slices: the labelled cut is drawn in label colours and recoloured after a fill."""
    import os
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    pytest.importorskip("pyvista")
    from plantvr.documents.labels import Segmentation
    from plantvr.view import View
    from plantvr.view.vine_layers import OrthoSlices, VolumeSlicesLayer
    seg = Segmentation(surface.vertices, surface.faces, labels=truth)
    view = View({"slices": OrthoSlices(head.volume, level=head.level, seg=seg, indices={"z": 32})},
                off_screen=True, window_size=(400, 400), background="#404050")
    p, vs = view.plotter, view.layers["slices"]
    assert type(vs) is VolumeSlicesLayer
    cut = vs.actors["cut2"].mapper.dataset
    _, el = S.plane_segments(surface.vertices, surface.faces, 2, 32.0, labels=truth)
    assert cut.n_cells == 2 * len(el)
    assert {tuple(c) for c in cut.cell_data["rgb"].tolist()} == {
        tuple(ColorTable().rgba[k, :3].tolist()) for k in np.unique(el)}
    p.view_xy()
    img = p.screenshot(str(tmp_path / "slice3d.png"))
    red = np.all(img == ColorTable().rgba[2, :3], axis=-1).sum()
    assert red > 50                                     # the receptacle's red cut is on screen
    v2 = int(np.flatnonzero(truth == 2)[0])
    seg.fill(v2, 11)
    cut = vs.actors["cut2"].mapper.dataset
    assert tuple(ColorTable().rgba[11, :3].tolist()) in {tuple(c) for c in cut.cell_data["rgb"].tolist()}
    with pytest.raises(ValueError, match="index must be an integer in"):
        vs.set_index("z", 64)
    assert vs.indices == {2: 32}
    view.update({"slices": None})                       # the layer stops following the segmentation
    assert vs._seg is None and not vs.actors
    view.close()


@pytest.mark.parametrize(("axis", "pos"), [(0, 32.0), (1, 30.37), (2, 20.5)])
def test_cut_kernel_matches_numpy_twin(monkeypatch, surface, truth, axis, pos):
    v, f = surface.vertices, surface.faces
    segs, el = S.plane_segments(v, f, axis, pos, labels=truth)
    s2, e2 = S._plane_cut_numpy(v, f, axis, pos, truth)
    np.testing.assert_array_equal(segs, s2)
    np.testing.assert_array_equal(el, e2)
    monkeypatch.setattr(S, "_plane_cut_numba", S._plane_cut_numba.py_func)
    s3, e3 = S.plane_segments(v, f[:3000], axis, pos, labels=truth)
    s4, e4 = S._plane_cut_numpy(v, f[:3000], axis, pos, truth)
    np.testing.assert_array_equal(s3, s4)
    np.testing.assert_array_equal(e3, e4)
    with pytest.raises(ValueError, match="vertices must contain only finite values"):
        S.plane_segments(np.full((3, 3), np.nan), np.array([[0, 1, 2]]), 0, 0.0)


def test_check_slice_is_the_one_slice_check(head):
    vol, ax, index, sp = S.check_slice(head.volume, "y", 3, (1, 2, 3))
    assert vol.shape == head.volume.shape
    assert (ax, index) == (1, 3) and sp.tolist() == [1.0, 2.0, 3.0]
    for entry in (lambda *a: S.check_slice(*a, (1, 1, 1)),
                  lambda v, a, i: S.slice_contours(v, 0.5, a, i),
                  lambda v, a, i: slice_figure(v, a, i)):
        with pytest.raises(ValueError, match="volume must be 3-D"):
            entry(np.zeros((4, 4)), 0, 0)
        with pytest.raises(ValueError, match="axis must be 0, 1, 2"):
            entry(head.volume, "w", 0)
        with pytest.raises(ValueError, match="index must be"):
            entry(head.volume, 2, head.volume.shape[2])

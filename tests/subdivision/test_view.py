"""plantvr.view.subdivision: trimesh/ControlMesh → PolyData, the side-by-side offscreen view, UV display copy."""
import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from plantvr.subdivision import build_control_mesh, control_uvs, parse_lsystem, tree_mesh
from plantvr.view.subdivision import (
    SubdivisionView,
    checker_texture,
    side_by_side,
    textured_polydata,
    to_polydata,
)

TEXT = "F(2,0.2)[+F(1,0.1)][-F(1,0.1)]F(1,0.15)"


def test_to_polydata_keeps_vertex_order_and_faces():
    m = tree_mesh(TEXT, levels=1)
    poly = to_polydata(m)
    np.testing.assert_array_equal(np.asarray(poly.points), m.vertices)
    np.testing.assert_array_equal(poly.regular_faces, m.faces)
    cm = build_control_mesh(parse_lsystem(TEXT, angle=40))
    assert to_polydata(cm).n_cells == len(cm.faces)
    assert to_polydata((cm.vertices, cm.faces)).n_points == len(cm.vertices)
    with pytest.raises(ValueError, match="faces must index vertices"):
        to_polydata((cm.vertices, cm.faces + len(cm.vertices)))
    with pytest.raises(ValueError, match="mesh must have vertices and faces"):
        to_polydata(3)


def test_textured_polydata_splits_corners():
    cm = build_control_mesh(parse_lsystem(TEXT, angle=40))
    uv = control_uvs(cm)
    poly = textured_polydata(cm.vertices, cm.faces, uv)
    assert poly.n_points == 3 * len(cm.faces) and poly.n_cells == len(cm.faces)
    np.testing.assert_array_equal(np.asarray(poly.active_texture_coordinates), uv.reshape(-1, 2))
    assert checker_texture(4).dimensions == (256, 256)


def test_side_by_side_renders_both_panels_and_updates_in_place():
    cm = build_control_mesh(parse_lsystem(TEXT, angle=40), cap=True)
    view = side_by_side(cm, tree_mesh(TEXT, levels=2), off_screen=True, window_size=(400, 200))
    img = view.screenshot()
    assert img.shape == (200, 400, 3)
    bg = img[2, 200]                                                     # a background pixel (gradient top)
    for half in (img[:, :200], img[:, 200:]):                            # the tree is drawn in both panels
        assert (np.abs(half.astype(int) - bg).sum(axis=2) > 60).mean() > 0.01
    poly = view.surface
    view.update(surface=tree_mesh(TEXT, levels=1))
    assert view.surface is poly and poly.n_cells == len(tree_mesh(TEXT, levels=1).faces)
    assert view.png()[:8] == b"\x89PNG\r\n\x1a\n"
    view.close()
    assert isinstance(SubdivisionView(off_screen=True), SubdivisionView)

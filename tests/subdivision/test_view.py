"""Yggdrasil meshes in the view: mesh → PolyData (vertex order kept, per-corner UVs split for display), and the
side-by-side View of a control mesh and its subdivided surface, updated in place."""
from dataclasses import dataclass

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from plantvr.subdivision import build_control_mesh, control_uvs, parse_lsystem, tree_mesh  # noqa: E402
from plantvr.types import TriMesh  # noqa: E402
from plantvr.view import View, side_by_side  # noqa: E402
from plantvr.view.polydata import checker_texture, to_polydata  # noqa: E402

TEXT = "F(2,0.2)[+F(1,0.1)][-F(1,0.1)]F(1,0.15)"


@dataclass(eq=False)
class UVMesh(TriMesh):
    uv: np.ndarray = None


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


def test_per_corner_uvs_split_corners():
    cm = build_control_mesh(parse_lsystem(TEXT, angle=40))
    uv = control_uvs(cm)
    poly = to_polydata(UVMesh(cm.vertices, cm.faces, uv))
    assert poly.n_points == 3 * len(cm.faces) and poly.n_cells == len(cm.faces)
    np.testing.assert_array_equal(np.asarray(poly.active_texture_coordinates), uv.reshape(-1, 2))
    np.testing.assert_array_equal(np.asarray(poly.points), cm.vertices[cm.faces.ravel()])
    assert checker_texture(4).dimensions == (256, 256)
    with pytest.raises(ValueError, match="uv"):
        to_polydata(UVMesh(cm.vertices, cm.faces, uv[:-1]))


def test_side_by_side_renders_both_panels_and_updates_in_place(tmp_path):
    cm = build_control_mesh(parse_lsystem(TEXT, angle=40), cap=True)
    view = side_by_side(cm, tree_mesh(TEXT, levels=2), off_screen=True, window_size=(400, 200))
    img = view.screenshot(tmp_path / "side_by_side.png")
    assert img.shape == (200, 400, 3)
    bg = img[2, 200]                                                     # a background pixel (gradient top)
    for half in (img[:, :200], img[:, 200:]):                            # the tree is drawn in both panels
        assert (np.abs(half.astype(int) - bg).sum(axis=2) > 60).mean() > 0.01
    poly = view.layers["surface"].polys["main"]
    assert view.update({"surface": tree_mesh(TEXT, levels=1)}) == ["surface"]
    assert view.layers["surface"].polys["main"] is poly and poly.n_cells == len(tree_mesh(TEXT, levels=1).faces)
    assert view.update({"control": cm}) == []                            # same mesh: nothing redrawn
    assert view.png()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match="document view"):
        View(_OneMesh(), window_size=(64, 64)).update({"surface": cm})
    view.close()
    assert isinstance(side_by_side(None, None, off_screen=True), View)


class _OneMesh:
    """The smallest document-like source: scene() and observe()."""

    def scene(self):
        return {}

    def observe(self, *a, **k):
        pass

    def has_trait(self, name):
        return False

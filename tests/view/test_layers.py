"""One View for any document: one actor layer per kind of scene content, redrawn only when its content changes
(issue 21). A small Document subclass returns each content type; a PNG is rendered per type."""
import ast
import os
from pathlib import Path

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

from plantvr.document import Document  # noqa: E402
from plantvr.types import Instances, Points, TreeArrays, TriMesh  # noqa: E402
from plantvr.view import View  # noqa: E402
from plantvr.view.layers import InstancesLayer, MeshLayer, PointsLayer, TreeLayer, layer_class, same_content  # noqa: E402

VIEW_PACKAGE = Path(__file__).resolve().parents[2] / "plantvr" / "view"

OUT = os.environ.get("PLANTVR_VIEW_PNG")  # set to a folder to keep the pictures


def _sphere(center=(0.0, 1.0, 0.0), radius=1.0) -> TriMesh:
    s = pv.Sphere(radius=radius, center=center, theta_resolution=24, phi_resolution=16)
    return TriMesh(np.asarray(s.points, float), np.asarray(s.regular_faces, np.int64))


def _labelled() -> TriMesh:
    m = _sphere()
    m.colors = np.where((m.vertices[:, 0] > 0)[:, None], [220, 40, 40], [40, 80, 220]).astype(np.uint8)
    return m


def _tree() -> TreeArrays:
    pos = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0], [0.6, 2.6, 0], [-0.5, 2.7, 0.2], [0, 3, 0.0]])
    return TreeArrays.from_arrays(pos, [-1, 0, 1, 2, 2, 2], [0.12, 0.1, 0.07, 0.03, 0.03, 0.04])


def _boxes() -> Instances:
    c = pv.Cube(x_length=0.6, y_length=0.6, z_length=0.6).triangulate()
    T = np.stack([np.eye(4)] * 3)
    T[:, 0, 3], T[:, 1, 3], T[:, 2, 3] = [-1.5, 0.0, 1.5], 0.3, -1.0
    T[1, :3, :3] *= 1.5                                   # one copy scaled
    return Instances(TriMesh(np.asarray(c.points, float), np.asarray(c.regular_faces, np.int64)), T)


class SceneDoc(Document):
    """A document whose scene holds one entry per content kind; ``move`` shifts the points only."""

    KIND = "scene_test"
    COMMANDS = ("move",)
    EVENTS = ("points",)

    def __init__(self, kinds=("tree", "mesh", "points", "instances")):
        super().__init__()
        self.kinds, self.dy = kinds, 0.0

    def _check_move(self, dy):
        return float(dy)

    def move(self, dy) -> None:
        dy = self._check_move(dy)
        with self._lock:
            self.dy += dy
            self.log.record("move", dy=dy)
        self.changed("points", command="move")

    def state_bytes(self) -> bytes:
        return np.float64(self.dy).tobytes()

    def scene(self):
        out = {"tree": _tree(), "mesh": _labelled(), "instances": _boxes(),
               "points": Points(np.array([[1.5, 2.5 + self.dy, 0], [-1.5, 2.0, 0], [0, 3.5, 1.0]]),
                                colors=(250, 200, 30), size=0.12)}
        return {k: v for k, v in out.items() if k in self.kinds}


@pytest.mark.parametrize("kind, cls", [("tree", TreeLayer), ("mesh", MeshLayer), ("points", PointsLayer),
                                       ("instances", InstancesLayer)])
def test_each_content_type_renders_offscreen(kind, cls, tmp_path):
    doc = SceneDoc((kind,))
    v = View(doc, window_size=(240, 200), ground=False)
    try:
        assert type(v.layers[kind]) is cls
        path = os.path.join(OUT, f"layer_{kind}.png") if OUT else tmp_path / f"{kind}.png"
        img = v.screenshot(path, window_size=(320, 240))            # a still at another resolution
        assert img.shape == (240, 320, 3)
        v.set_visible(kind, False)
        bg = v.screenshot(window_size=(320, 240)).astype(int)
        v.set_visible(kind, True)
        assert (np.abs(img.astype(int) - bg).sum(-1) > 60).mean() > 0.003, kind   # something is drawn
        if kind == "mesh":   # the per-vertex colours reach the picture: red and blue halves
            rgb = img.astype(int)
            assert ((rgb[..., 0] > 120) & (rgb[..., 2] < 90)).sum() > 50
            assert ((rgb[..., 2] > 120) & (rgb[..., 0] < 90)).sum() > 50
    finally:
        v.close()


def test_only_the_changed_layer_is_redrawn():
    doc = SceneDoc()
    v = View(doc, window_size=(120, 100))
    try:
        polys = {k: lay.polys["main"] for k, lay in v.layers.items()}
        drawn = {k: lay.content for k, lay in v.layers.items()}
        calls = []
        orig = v._apply
        v._apply = lambda scene: calls.append(orig(scene)) or calls[-1]
        doc.move(0.5)                                     # a Change of kind "points"
        assert calls == [["points"]] and v.drawn_version == doc.version
        for k, lay in v.layers.items():
            assert lay.polys["main"] is polys[k]          # edited in place, never re-added
            assert (lay.content is drawn[k]) == (k != "points")
        assert np.asarray(v.layers["points"].content.xyz)[0, 1] == pytest.approx(3.0)
        assert v.update() == []                           # nothing left to draw
    finally:
        v.close()


def test_layers_follow_content_kind_and_removal():
    v = View({"a": _sphere()}, window_size=(64, 64))
    try:
        assert isinstance(v.layers["a"], MeshLayer)
        assert v.update({"a": Points(np.zeros((3, 3)))}) == ["a"] and isinstance(v.layers["a"], PointsLayer)
        assert v.update({"a": None}) == ["a"] and "a" not in v.plotter.actors
        v.update({"b": Points(np.zeros((0, 3)))})        # an empty point set draws nothing, and is fine
        assert v.layers["b"].actor is None
    finally:
        v.close()


def test_instances_are_copies_at_their_transforms():
    inst = _boxes()
    lay = InstancesLayer.__new__(InstancesLayer)
    m = lay.mesh(inst)
    n = len(inst.mesh.vertices)
    assert m.vertices.shape == (3 * n, 3) and m.faces.shape == (3 * len(inst.mesh.faces), 3)
    np.testing.assert_allclose(m.vertices[:n], inst.mesh.vertices + inst.transforms[0, :3, 3])
    np.testing.assert_allclose(m.vertices[n:2 * n], 1.5 * inst.mesh.vertices + inst.transforms[1, :3, 3])


def test_same_content_and_layer_class():
    a, b = _tree(), _tree()
    assert a is not b and same_content(a, b)
    assert not same_content(a, TreeArrays.from_arrays(a.pos + 1, a.parent, a.radius))
    assert same_content(_labelled(), _labelled()) and not same_content(_labelled(), _sphere())
    with pytest.raises(ValueError, match="TreeArrays, TriMesh, Points or Instances, LabelledSurface, OrthoSlices"):
        layer_class("tree")
    from plantvr.documents.labels import Segmentation
    from plantvr.types import LabelledSurface
    from plantvr.view.vine_layers import LabelledSurfaceLayer, OrthoSlices, VolumeSlicesLayer
    sphere = _sphere()
    surface = Segmentation(sphere.vertices, sphere.faces).scene()["surface"]
    assert isinstance(surface, LabelledSurface) and layer_class(surface) is LabelledSurfaceLayer
    assert layer_class(OrthoSlices(np.zeros((2, 2, 2)))) is VolumeSlicesLayer


def test_tree_layer_draws_leaves_only_with_buds():
    tree = _tree()
    n = len(tree.pos)
    buds = {"pos": tree.pos[[3, 4]], "dir": np.array([[1.0, 1, 0], [-1.0, 1, 0]]) / np.sqrt(2),
            "radius": np.full(2, 0.01), "up": np.array([[0, 0, 1.0], [0, 0, 1.0]])}
    v = View({"t": tree}, window_size=(64, 64), params={"tip_radius": 0.01, "leaf_size": 0.4})
    try:
        assert v.layers["t"].actors.get("leaves") is None
        snap = type("Snap", (), {"pos": tree.pos, "parent": tree.parent, "radius": tree.radius,
                                 "main_child": tree.main_child, "buds": buds})()
        assert n == len(snap.pos) and v.update({"t": snap}) == ["t"]
        assert v.layers["t"].actors["leaves"].GetVisibility()
    finally:
        v.close()


def plotter_owners(package: Path = VIEW_PACKAGE) -> list[str]:
    """Classes of ``package`` (``plantvr/view``) that own a pyvista plotter: they construct a ``Plotter`` or keep
    one as ``self.plotter``, the actor layers (subclasses of ``Layer``, which draw into the view's) aside."""
    classes = [c for f in sorted(package.glob("*.py")) for c in ast.walk(ast.parse(f.read_text()))
               if isinstance(c, ast.ClassDef)]
    layers = {"Layer"}
    for _ in classes:                                     # enough passes for any order of definition
        layers |= {c.name for c in classes if any(getattr(b, "id", None) in layers for b in c.bases)}

    def owns(node) -> bool:
        for n in ast.walk(node):
            if isinstance(n, ast.Call) and getattr(n.func, "id", getattr(n.func, "attr", None)) == "Plotter":
                return True
            targets = n.targets if isinstance(n, ast.Assign) else []
            for t in [e for t in targets for e in (t.elts if isinstance(t, ast.Tuple) else [t])]:
                if isinstance(t, ast.Attribute) and t.attr == "plotter" and getattr(t.value, "id", "") == "self":
                    return True
        return False
    return sorted(c.name for c in classes if c.name not in layers and owns(c))


def test_one_view_class_owns_a_plotter():
    """Issue 30: one ``View`` with a layer registry; the segmentation surface and the volume slices are layers,
    the review app owns a ``View`` (was: View, SegmentationView, VolumeSlices)."""
    assert plotter_owners() == ["View"]

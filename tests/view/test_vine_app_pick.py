"""Server-side picking and strokes of the ViNE review page (issue 14) without a browser: the viewing ray of a
vtk.js camera hits the display proxy where VTK's own ``vtkCellPicker`` (the oracle) does, and a stroke
(begin, moves, end) paints the full-resolution labels exactly where brute-force sphere tests say, as one undo
item, with colour deltas that rebuild both levels of detail's colour arrays."""
import numpy as np
import pytest

pytest.importorskip("trame_vtk")

from plantvr.documents.labels import Segmentation
from plantvr.vine.index import ball_query_brute


@pytest.fixture(scope="module")
def surface():
    from plantvr.adapters.vtk_isosurface import extract_isosurface
    from plantvr.vine.synth import synth_flowerhead
    head = synth_flowerhead(64, rng=1)
    return extract_isosurface(head.volume, head.level, slab=16)


def _camera(plotter):
    cam = plotter.camera
    return {"position": list(cam.position), "focalPoint": list(cam.focal_point), "viewUp": list(cam.up),
            "viewAngle": cam.view_angle, "parallelProjection": bool(cam.parallel_projection),
            "parallelScale": cam.parallel_scale}


@pytest.mark.parametrize("parallel", [False, True])
def test_pick_display_matches_vtk_cell_picker(surface, parallel):
    from vtkmodules.vtkRenderingCore import vtkCellPicker

    from plantvr.view.vine_app import VineReviewApp
    seg = Segmentation(surface.vertices, surface.faces)
    w, h = 320, 240
    app = VineReviewApp(seg, target_faces=len(seg.faces) // 2, window_size=(w, h), interactive_faces=None)
    pl = app.view.plotter
    pl.camera.azimuth = 30
    if parallel:
        pl.enable_parallel_projection()
    pl.render()
    cam = _camera(pl)
    diag = float(np.linalg.norm(np.ptp(seg.vertices, axis=0)))
    picker = vtkCellPicker()
    picker.SetTolerance(0.0)
    hits = misses = 0
    for x in np.linspace(10, w - 10, 17):
        for y in np.linspace(10, h - 10, 13):
            got = app.pick_display(x, y, cam, (w, h))
            if picker.Pick(x, h - y, 0, pl.renderer):            # VTK display y points up
                want = np.asarray(picker.GetPickPosition())
                assert got is not None, (x, y)
                assert np.linalg.norm(got - want) < 1e-4 * diag, (x, y, got, want)
                hits += 1
            else:
                assert got is None, (x, y, got)
                misses += 1
    assert hits >= 15 and misses >= 15
    app.stop()


def test_camera_ray_checks_and_centre():
    from plantvr.view.vine_app import camera_ray
    cam = {"position": [0, 0, 10], "focalPoint": [0, 0, 0], "viewUp": [0, 1, 0], "viewAngle": 30}
    o, d = camera_ray(cam, 50, 40, (100, 80))
    assert np.allclose(o, [0, 0, 10]) and np.allclose(d, [0, 0, -1])
    _, d = camera_ray(cam, 100, 40, (100, 80))                      # right edge: half the horizontal angle
    assert np.isclose(np.degrees(np.arctan2(d[0], -d[2])), np.degrees(np.arctan(np.tan(np.radians(15)) * 1.25)))
    o, d = camera_ray({**cam, "parallelProjection": True, "parallelScale": 2.0}, 50, 0, (100, 80))
    assert np.allclose(o, [0, 2, 10]) and np.allclose(d, [0, 0, -1])
    with pytest.raises(ValueError, match="size must be positive"):
        camera_ray(cam, 0, 0, (0, 10))
    with pytest.raises(ValueError, match="coincide"):
        camera_ray({**cam, "focalPoint": [0, 0, 10]}, 0, 0, (10, 10))
    with pytest.raises(ValueError, match="parallel to the view direction"):
        camera_ray({**cam, "viewUp": [0, 0, 1]}, 0, 0, (10, 10))
    with pytest.raises(ValueError, match="position must have shape"):
        camera_ray({**cam, "position": [0, 0]}, 0, 0, (10, 10))
    with pytest.raises(ValueError, match="camera must be a dict"):
        camera_ray([0, 0, 1], 0, 0, (10, 10))


def _apply(colours, d):
    for part in [d, *d["more"]]:
        ids = np.frombuffer(part["ids"], "<u4")
        colours[part["n"]][ids] = np.frombuffer(part["rgba"], np.uint8).reshape(-1, 4)


def test_stroke_paints_full_resolution_as_one_undo_item_with_lod_deltas(surface):
    from plantvr.view.vine_app import VineReviewApp
    seg = Segmentation(surface.vertices, surface.faces)
    w, h = 400, 300
    app = VineReviewApp(seg, target_faces=len(seg.faces) // 2, window_size=(w, h), radius=4.0,
                        interactive_faces=len(seg.faces) // 8)
    assert app.lod is not None and app.lod.n_vertices < app.proxy.n_vertices < seg.n_vertices
    assert app.state.n_lod == app.lod.n_vertices
    app.state.label = 3
    cam = _camera(app.view.plotter)
    # what the page holds: both levels of detail's colour arrays, keyed by their tuple count
    page = {app.proxy.n_vertices: app.surface.mesh.point_data["rgba"].copy(),
            app.lod.n_vertices: app.view.layers["lod"].mesh.point_data["rgba"].copy()}
    path = [(w / 2 - 40 + 8 * k, h / 2 + 3 * np.sin(k)) for k in range(11)]
    d = app.stroke("begin", [path[0]], cam, (w, h))
    assert d is not None and d["n"] == app.lod.n_vertices and d["more"] == []    # only the coarse level moves
    _apply(page, d)
    for k in range(1, 10, 3):
        d = app.stroke("move", path[k:k + 3], cam, (w, h))
        if d is not None:
            assert d["n"] == app.lod.n_vertices
            _apply(page, d)
    assert app._stroking and not seg.history.undo_stack                     # still open
    d = app.stroke("end", [path[-1]], cam, (w, h))
    assert {d["n"], *(p["n"] for p in d["more"])} <= {app.proxy.n_vertices, app.lod.n_vertices}
    assert d["n"] == app.proxy.n_vertices                                   # the display proxy at the end
    _apply(page, d)
    assert np.array_equal(page[app.proxy.n_vertices], app.surface.mesh.point_data["rgba"])
    assert np.array_equal(page[app.lod.n_vertices], app.view.layers["lod"].mesh.point_data["rgba"])
    assert np.array_equal(page[app.proxy.n_vertices], app.proxy.vertex_colors())
    # full resolution: exactly the union of the stamps' spheres, one undo item
    centres = np.asarray(app.last_stroke)
    assert len(centres) >= 8 and app.stroke_stats["stamps"] == len(centres)
    want = np.unique(np.concatenate([ball_query_brute(seg.vertices, c, 4.0) for c in centres]))
    assert np.array_equal(np.nonzero(seg.labels)[0], want) and np.all(seg.labels[want] == 3)
    assert len(seg.history.undo_stack) == 1 and app.state.can_undo and app.state.painted == len(want)
    # every stamp centre lies on the drawn proxy surface, on the ray through its page position
    app.undo()
    assert not seg.labels.any()
    _apply(page, app.state.vine_delta)                                      # undo: both levels in one batch
    assert np.array_equal(page[app.proxy.n_vertices], app.proxy.vertex_colors())
    assert np.array_equal(page[app.lod.n_vertices], app.lod.vertex_colors())
    # a click is one undoable stamp; a miss paints nothing; a hidden colour is refused
    assert app.stroke("click", [(w / 2, h / 2)], cam, (w, h)) is None
    assert len(seg.history.undo_stack) == 1 and seg.labels.any()
    hit = np.asarray(app.last_pick["worldPosition"])
    n = np.count_nonzero(seg.labels)
    app.stroke("click", [(1, 1)], cam, (w, h))
    assert np.count_nonzero(seg.labels) == n and app.stroke_stats["misses"] >= 1
    assert app.stroke("move", [(w / 2, h / 2)], cam, (w, h)) is None       # no open stroke: ignored
    app.stroke("begin", [(w / 2 + 5, h / 2)], cam, (w, h))                  # a release that never came:
    app.undo()                                                              # undo ends the stroke, then undoes it
    assert not app._stroking and len(seg.history.undo_stack) == 1 and np.count_nonzero(seg.labels) == n
    seg.hide(3)
    app.resync()
    behind = app.pick_display(w / 2, h / 2, cam, (w, h))                    # hidden triangles are not picked
    assert behind is None or np.linalg.norm(behind - hit) > 1.0
    assert app.stroke("begin", [(w / 2, h / 2)], cam, (w, h)) is None and "hidden" in app.state.message
    assert not app._stroking
    with pytest.raises(ValueError, match="phase"):
        app.stroke("drag", [], cam, (w, h))
    with pytest.raises(ValueError, match="interactive_faces"):
        VineReviewApp(seg, interactive_faces=0)
    app.stop()

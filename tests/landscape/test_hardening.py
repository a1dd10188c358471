"""Issue 20 for landscapes: every entry point checks its input at the door, kernels stay in bounds at the
extremes that pass, and the glTF writer is atomic and deterministic."""
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given
from hypothesis import settings as _settings
from hypothesis import strategies as st

from plantvr.landscape import (
    CrownVoxels,
    Species,
    brush_height,
    brush_mask,
    cell_geometry,
    claim_segments,
    clustering_kernel,
    crown_regions,
    crown_voxels,
    distribute,
    grow_forest,
    heightfield,
    inhibitory_kernel,
    landscape_tropism,
    neighbour_asymmetry,
    placement_mask,
    poisson_disc,
    propagate_layer,
    regrow_tree,
    region_geometry,
    ripley_k,
    sample_field,
    sample_height,
    terrain_mesh,
)
from plantvr.landscape.crowns import tree_region
from plantvr.io.gltf import write_glb
from plantvr.io.landscape import export_landscape


def settings(**kw):
    return _settings(suppress_health_check=[HealthCheck.function_scoped_fixture], **kw)


BAD = [float("nan"), float("inf"), -float("inf"), 1e300, -1e300, 1e19, 10 ** 12, -5, 1e-20, 0, "x", None,
       [1.0, 2.0, 3.0], np.zeros((2, 2)), True, (1, 2, 3)]
HF = np.linspace(0, 1, 16).reshape(4, 4)
B2 = np.array([[2.0, 3.0], [7.0, 6.0], [5.0, 1.0]])
A3 = np.array([1.0, 2.0, 1.5])

CALLS = {
    "heightfield.shape": (lambda v: heightfield(v, rng=0), "shape"),
    "heightfield.amplitude": (lambda v: heightfield((8, 8), amplitude=v, rng=0), "amplitude"),
    "sample_height.size": (lambda v: sample_height(HF, v, np.zeros((2, 2))), "size"),
    "sample_height.xz": (lambda v: sample_height(HF, (4.0, 4.0), v), "xz"),
    "sample_height.hf": (lambda v: sample_height(v, (4.0, 4.0), np.zeros((2, 2))), "hf"),
    "brush_height.radius": (lambda v: brush_height(HF, (4.0, 4.0), (1.0, 1.0), v, 1.0), "radius"),
    "brush_height.center": (lambda v: brush_height(HF, (4.0, 4.0), v, 1.0, 1.0), "center"),
    "brush_height.amount": (lambda v: brush_height(HF, (4.0, 4.0), (1.0, 1.0), 1.0, v), "amount"),
    "brush_mask.value": (lambda v: brush_mask(HF > 0.5, (4.0, 4.0), (1.0, 1.0), 1.0, v), "value"),
    "placement_mask.water_level": (lambda v: placement_mask(HF, water_level=v), "water_level"),
    "placement_mask.shape": (lambda v: placement_mask(HF, shape=v), "shape"),
    "clustering_kernel.s": (lambda v: clustering_kernel([1.0, 2.0], r=0.5, a=3.0, s=v), "s"),
    "inhibitory_kernel.a": (lambda v: inhibitory_kernel([1.0, 2.0], r=0.5, a=v, s=2.0), "a"),
    "ripley_k.t": (lambda v: ripley_k(B2, v, box=(10.0, 10.0)), "t"),
    "ripley_k.box": (lambda v: ripley_k(B2, [1.0], box=v), "box"),
    "sample_field.n": (lambda v: sample_field(HF + 0.1, v, rng=0), "n"),
    "sample_field.field": (lambda v: sample_field(v, 3, rng=0), "field"),
    "distribute.n": (lambda v: distribute(v, [Species()], {}, size=(10.0, 10.0), shape=(16, 16), rng=0), "n"),
    "distribute.size": (lambda v: distribute(3, [Species()], {}, size=v, shape=(16, 16), rng=0), "size"),
    "distribute.species": (lambda v: distribute(3, v, {}, rng=0), "species"),
    "distribute.interactions": (lambda v: distribute(3, [Species()], {(0, 0): v}, shape=(16, 16), rng=0),
                                "interactions"),
    "poisson_disc.min_dist": (lambda v: poisson_disc((10.0, 10.0), v, max_points=50, rng=0), "min_dist"),
    "poisson_disc.size": (lambda v: poisson_disc(v, 1.0, max_points=50, rng=0), "size"),
    "neighbour_asymmetry.radius": (lambda v: neighbour_asymmetry(B2, A3, v), "radius"),
    "neighbour_asymmetry.areas": (lambda v: neighbour_asymmetry(B2, v, 3.0), "areas"),
    "cell_geometry.size": (lambda v: cell_geometry(B2, v, resolution=16), "size"),
    "landscape_tropism.V": (lambda v: landscape_tropism(v, np.array([[0, 1.0, 0]]), 1.0, 5.0), "V"),
    "landscape_tropism.h_max": (lambda v: landscape_tropism([1.0, 0, 0], np.array([[0, 1.0, 0]]), 1.0, v), "h_max"),
    "propagate_layer.bases": (lambda v: propagate_layer((8, 8), v, A3, size=(10.0, 10.0)), ("bases", "areas")),
    "propagate_layer.areas": (lambda v: propagate_layer((8, 8), B2, v, size=(10.0, 10.0)), "areas"),
    "propagate_layer.size": (lambda v: propagate_layer((8, 8), B2, A3, size=v), "size"),
    "propagate_layer.trunk_radius": (lambda v: propagate_layer((8, 8), B2, A3, size=(10.0, 10.0), trunk_radius=v),
                                     "trunk_radius"),
    "propagate_layer.shape": (lambda v: propagate_layer(v, B2, A3, size=(10.0, 10.0)), "shape"),
    "crown_voxels.h_max": (lambda v: crown_voxels(B2, A3, v, size=(10.0, 10.0), shape=(4, 8, 8)), "h_max"),
    "crown_voxels.shape": (lambda v: crown_voxels(B2, A3, A3, size=(10.0, 10.0), shape=v), "shape"),
    "crown_regions.reach": (lambda v: crown_regions(np.zeros((2, 3)) + [[0, 0, 0], [1, 0, 1]], reach=v, h_max=5.0),
                            "reach"),
    "terrain_mesh.size": (lambda v: terrain_mesh(HF, v), "size"),
}


@settings(max_examples=60, deadline=None)
@given(fn=st.sampled_from(sorted(CALLS)), value=st.sampled_from(BAD))
def test_fuzz_landscape_functions(fuzz, fn, value):
    f, param = CALLS[fn]
    r = fuzz.call(fn.split(".")[0], f, value, param=param)
    if isinstance(r, np.ndarray) and r.dtype.kind == "f":
        assert np.all(np.isfinite(r)), fn


def test_every_landscape_function_rejects_every_bad_value(fuzz):
    """The exhaustive grid behind the hypothesis sample (cheap calls only)."""
    for fn, (f, param) in CALLS.items():
        if fn.startswith(("distribute", "crown_voxels", "poisson")):
            continue
        for v in BAD:
            r = fuzz.call(fn.split(".")[0], f, v, param=param)
            if isinstance(r, np.ndarray) and r.dtype.kind == "f":
                assert np.all(np.isfinite(r)), (fn, v)


def test_crown_kernels_in_bounds_at_the_extremes():
    """Bases at the coordinate limit, the smallest plot, the widest spread of areas: owners stay valid."""
    b = np.array([[1e6, -1e6], [-1e6, 1e6], [0.0, 0.0]])
    for size in ((1e-6 * 1.01, 1e-6 * 1.01), (1e6, 1e6)):
        o = propagate_layer((16, 16), b, np.array([1.0, 1e-12, 1e-6]), size=size, trunk_radius=1e6)
        assert o.min() >= 0 and o.max() <= 2
    with pytest.raises(ValueError, match="areas"):
        propagate_layer((8, 8), b, np.array([1.0, 1e-300, 1.0]), size=(10.0, 10.0))
    v = crown_voxels(b, np.ones(3), np.array([1.0, 1e6, 1e-3]), size=(1e6, 1e6), shape=(3, 8, 8))
    assert v.owner.min() >= -1 and v.owner.max() <= 2
    with pytest.raises(ValueError, match="voxels"):
        crown_voxels(b, np.ones(3), np.ones(3), size=(10.0, 10.0), shape=(4096, 8192, 8192))


def test_corrupt_crown_voxels_are_refused(fuzz):
    v = crown_voxels(B2, A3, A3, size=(10.0, 10.0), shape=(2, 8, 8))
    bad = CrownVoxels(v.owner.copy(), v.size, v.layer_height, v.h_max)
    bad.owner[0, 0, 0] = 10 ** 6
    for fn in (lambda: region_geometry(bad), lambda: tree_region(bad, 0),
               lambda: claim_segments(bad, 0, np.zeros((1, 3)), np.ones((1, 3)))):
        assert isinstance(fuzz.call("CrownVoxels", fn, param="owner"), ValueError)
    assert isinstance(fuzz.call("claim_segments", claim_segments, v, 0, np.zeros((1, 3)), [[1e19, 1e6, 1e6]],
                                param="ends"), ValueError)
    fine = crown_voxels(B2, A3, A3, size=(10.0, 10.0), shape=(64, 512, 512))
    assert isinstance(fuzz.call("claim_segments", claim_segments, fine, 0, -1e6 * np.ones((2, 3)), 1e6 * np.ones((2, 3)),
                                param="starts"), ValueError)
    assert isinstance(fuzz.call("claim_segments", claim_segments, v, 7, np.zeros((1, 3)), np.ones((1, 3)),
                                param="tree"), ValueError)


def test_fuzz_forest_entry_points(fuzz):
    small = {"n_trees": 2, "size": (12.0, 12.0), "min_dist": 5.0, "rounds": 1, "steps_per_round": 1,
             "n_darts": 20, "client": "sync"}
    cases = [("seed", -1), ("terrain_amplitude", np.nan), ("size", (0, 5)), ("n_darts", 10 ** 12),
             ("params", {"base_length": np.nan}), ("params", "x"), ("sketch", {"n_max": -1}),
             ("sketch", {"region": None}), ("sketch", {"bogus": 1}), ("positions", [[np.nan, 1.0]]),
             ("positions", [[1e19, 1.0]]), ("scales", [np.inf, 1.0]), ("client", 5), ("compete", "no"),
             ("heroes", [{"tree": {"pos": np.zeros((2, 3)), "parent": np.array([-1, 10 ** 9]),
                                   "alive": np.ones(2, bool), "radius": np.ones(2), "child": np.zeros((2, 2), int)},
                          "position": (1.0, 1.0)}]),
             ("voxel_shape", (1, 2)), ("scale_range", (2.0, 1.0))]
    for name, value in cases:
        r = fuzz.call("grow_forest", grow_forest, **{**small, name: value}, param=(name.split("_")[0], "base_length"))
        assert isinstance(r, ValueError), (name, value)
    f = grow_forest(**small, sketch={"n_max": 2})
    for kw in ({"tree": 5}, {"tree": -1}, {"tree": 0, "params": {"w_env": np.nan}}, {"tree": 0, "sketch": {"n_max": 0}},
               {"tree": 0, "params": {"branching": "opposite"}}):
        tree = kw.pop("tree")
        assert isinstance(fuzz.call("regrow_tree", regrow_tree, f, tree, **kw,
                                    param=("tree", "w_env", "n_max", "branching")), ValueError)
    assert isinstance(fuzz.call("regrow_tree", regrow_tree, "forest", 0, param="forest"), ValueError)
    g = f.regrow(0)
    assert g.n_internodes == f.n_internodes


def test_glb_export_is_atomic_and_deterministic(tmp_path, monkeypatch, fuzz):
    mesh = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]), np.array([[0, 1, 2]]))
    pos = np.array([[0.0, 0, 0], [3.0, 0, 0]])
    a, b = tmp_path / "a.glb", tmp_path / "b.glb"
    export_landscape(a, [mesh, mesh], pos, terrain=(HF, (4.0, 4.0)))
    export_landscape(b, [mesh, mesh], pos, terrain=(HF, (4.0, 4.0)))
    assert a.read_bytes() == b.read_bytes()
    old = a.read_bytes()

    def failing(fd):
        raise OSError("disk full")
    monkeypatch.setattr(os, "fsync", failing)
    with pytest.raises(OSError, match="disk full"):
        export_landscape(a, [mesh], pos[:1])
    monkeypatch.undo()
    assert a.read_bytes() == old and sorted(p.name for p in tmp_path.iterdir()) == ["a.glb", "b.glb"]
    bad_meshes = [(np.array([[0, 0, np.nan]] * 3), mesh[1]), (mesh[0], np.array([[0, 1, 9]])),
                  (mesh[0], np.array([[0, 1, 2.5]])), (mesh[0] * 1e300, mesh[1]), "mesh", (mesh[0],)]
    for m in bad_meshes:
        assert isinstance(fuzz.call("export_landscape", export_landscape, tmp_path / "c.glb", [m], pos[:1],
                                    param="trees"), ValueError)
    for kw, param in (({"yaw": [np.inf]}, "yaw"), ({"scale": [0.0]}, "scale"), ({"names": [5]}, "names")):
        assert isinstance(fuzz.call("export_landscape", export_landscape, tmp_path / "c.glb", [mesh], pos[:1], **kw,
                                    param=param), ValueError)
    for meshes, nodes, param in (([{"vertices": mesh[0], "faces": mesh[1], "color": (2, 0, 0, 1)}], [{"mesh": 0}],
                                   "color"),
                                  ([{"vertices": mesh[0], "faces": mesh[1]}], [{"mesh": 3}], "mesh"),
                                  ([{"vertices": mesh[0], "faces": mesh[1]}], [{"mesh": 0, "translation": [np.nan] * 3}],
                                   "translation"),
                                  ("x", [], "meshes")):
        assert isinstance(fuzz.call("write_glb", write_glb, tmp_path / "c.glb", meshes, nodes, param=param),
                          ValueError)
    assert not (tmp_path / "c.glb").exists()

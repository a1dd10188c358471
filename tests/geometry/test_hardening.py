"""Issue 20 for tree geometry: entry points check their input at the door (fuzzed); every exporter writes
atomically (a failed save keeps the old file, no temporary file) and re-exports byte-identically."""
import dataclasses
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr.geometry import build_branch_mesh, build_leaves
from plantvr.geometry.lod import lod_chain
from plantvr.io.tree import export_skinned_glb, export_tree, tree_skeleton

from ._trees import random_tree

FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
BAD = [np.nan, np.inf, -np.inf, 1e300, -1e300, 1e19, -9.3e18, 1e-20, -1.0, 0.0, 0.5, 10**12, None, "x", True]


@pytest.fixture(scope="module")
def tree():
    pos, parent, radius, _ = random_tree(39, seed=3)
    return pos, parent, radius


@pytest.fixture(scope="module")
def meshes(tree):
    pos, parent, radius = tree
    br = build_branch_mesh(pos, parent, radius)
    leaf = build_leaves(pos[1:], pos[1:] - pos[parent[1:]], radius[1:], leaf_size=0.3, radius_threshold=1.0, rng=0)
    return br, leaf


@FUZZ
@given(arr=st.sampled_from(["pos", "parent", "radius", "main_child", "alive"]), i=st.integers(0, 39),
       v=st.sampled_from(BAD))
def test_fuzz_tree_arrays(fuzz, tree, arr, i, v):
    pos, parent, radius = (a.copy() for a in tree)
    arrays = {"pos": pos, "parent": parent, "radius": radius, "main_child": np.full(40, -1), "alive": np.ones(40, bool)}
    a = arrays[arr].astype(object)
    if a.ndim == 2:
        a[i, i % 3] = v
    else:
        a[i] = v
    try:
        a = np.array(a.tolist())
    except ValueError:
        a = a.tolist()
    arrays[arr] = a
    kw = {k: arrays[k] for k in ("main_child", "alive")}
    for name, fn in (("build_branch_mesh", build_branch_mesh), ("lod_chain", lod_chain)):
        r = fuzz.call(name, fn, arrays["pos"], arrays["parent"], arrays["radius"], **kw, param=arr)
        if not isinstance(r, Exception):
            m = r if name == "build_branch_mesh" else r[0].mesh
            assert np.isfinite(m.vertices).all() and m.faces.max() < len(m.vertices)
    if arr in ("pos", "parent", "radius", "main_child"):
        r = fuzz.call("tree_skeleton", tree_skeleton, arrays["pos"], arrays["parent"], arrays["radius"],
                      main_child=arrays["main_child"], param=arr)
        if not isinstance(r, Exception):
            assert (r.joint_of_node >= 0).all() and (r.joint_of_node < len(r)).all()


@FUZZ
@given(kw=st.sampled_from(["bezier_w", "u_steps", "tip_radius", "bark_rate", "bark_repeat", "lod"]),
       v=st.sampled_from(BAD + [(3, 2), (3, 10**9), [6]]))
def test_fuzz_mesh_options(fuzz, tree, kw, v):
    r = fuzz.call("build_branch_mesh", build_branch_mesh, *tree, **{kw: v}, param=kw)
    if not isinstance(r, Exception):
        assert np.isfinite(r.vertices).all()


@FUZZ
@given(kw=st.sampled_from(["max_joints", "duration", "steps", "leaf_node", "birth"]), v=st.sampled_from(BAD))
def test_fuzz_skinned_glb(fuzz, tree, meshes, tmp_path, kw, v):
    br, leaf = meshes
    val = np.full(len(tree[0]) if kw == "birth" else 39, v, dtype=object).tolist() if kw in ("leaf_node", "birth") \
        else v
    extra = {"leaves": leaf} if kw == "leaf_node" else {}
    fuzz.call("export_skinned_glb", export_skinned_glb, tmp_path / "t.glb", br, *tree, **extra, **{kw: val},
              param=kw)


def test_exporters_refuse_inconsistent_meshes(tree, meshes, tmp_path):
    br, leaf = meshes
    bad = dataclasses.replace(br, faces=br.faces + len(br.vertices))
    for p in ("t.ply", "t.obj", "t.glb"):
        with pytest.raises(ValueError, match="faces"):
            export_tree(tmp_path / p, bad, leaf)
    with pytest.raises(ValueError, match="node_id"):
        export_skinned_glb(tmp_path / "s.glb", dataclasses.replace(br, node_id=br.node_id - 5), *tree)
    with pytest.raises(ValueError, match="normals"):
        export_tree(tmp_path / "t.ply", dataclasses.replace(br, normals=br.normals[:3]))
    assert os.listdir(tmp_path) == []


def _usd(path, br, leaf):
    pytest.importorskip("pxr")
    from plantvr.io.usd import export_usd
    return export_usd(path, br, leaf)


WRITERS = {
    "ply": lambda p, br, leaf, tree: export_tree(p, br, leaf),
    "obj": lambda p, br, leaf, tree: export_tree(p, br, leaf),
    "glb": lambda p, br, leaf, tree: export_tree(p, br, leaf),
    "skinned.glb": lambda p, br, leaf, tree: export_skinned_glb(p, br, *tree),
    "usdc": lambda p, br, leaf, tree: _usd(p, br, leaf),
    "usda": lambda p, br, leaf, tree: _usd(p, br, leaf),
}


@pytest.mark.parametrize("kind", sorted(WRITERS))
def test_export_atomic_and_byte_identical(kind, tree, meshes, tmp_path, monkeypatch):
    br, leaf = meshes
    p = tmp_path / f"t.{kind.split('.')[-1]}"
    WRITERS[kind](p, br, leaf, tree)
    first = p.read_bytes()
    before = sorted(os.listdir(tmp_path))
    WRITERS[kind](p, br, leaf, tree)
    assert p.read_bytes() == first                       # re-export is byte-identical (USD layers too)
    # a failure while writing (disk full) keeps the old file and leaves no temporary file
    import plantvr._fileio as fio

    real = os.fsync

    def full(fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(fio.os, "fsync", full)
    with pytest.raises(OSError):
        WRITERS[kind](p, br, leaf, tree)
    monkeypatch.setattr(fio.os, "fsync", real)
    assert p.read_bytes() == first
    assert sorted(os.listdir(tmp_path)) == before
    with pytest.raises(ValueError, match="does not exist"):
        WRITERS[kind](tmp_path / "missing" / p.name, br, leaf, tree)

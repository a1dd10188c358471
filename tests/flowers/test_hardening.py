"""Issue 20 for inflorescences: entry points check their input at the door, kernels never see out-of-range
indices, SCN/RBA/OBJ writes are atomic and readers refuse corrupt files; round trips are byte-identical."""
from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr.flowers import ccd, pbd, phyllotaxis as ph, scn
from plantvr.flowers.dynamic import DynamicPhyllotaxis
from plantvr.flowers.floret import read_obj_sequence
from plantvr.io.obj import write_obj_sequence

BAD = [np.nan, np.inf, -np.inf, 1e300, 1e19, 10**12, -5, 0, 1e-20, "x", None, [], True]
BAD_INT = [np.nan, np.inf, 1e300, 10**12, -5, -1, 0.5, "3", None, 2**70]
FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _patch():
    x, faces = pbd.cloth_patch(4, 4, spacing=0.1)
    return np.ascontiguousarray(x, dtype=np.float64), faces


@FUZZ
@given(st.sampled_from(BAD_INT))
def test_fuzz_counts(fuzz, bad):
    fuzz.call("phyllotaxis.vogel_disc", ph.vogel_disc, bad, param="n")
    fuzz.call("phyllotaxis.dome_receptacle", ph.dome_receptacle, 1.0, 0.5, nodes=bad, param="nodes")
    fuzz.call("pbd.cloth_patch", pbd.cloth_patch, bad, param=("nx", "n"))
    fuzz.call("DynamicPhyllotaxis", DynamicPhyllotaxis, max_primordia=bad, param="max_primordia")
    fuzz.call("ccd.CollisionDetector", ccd.CollisionDetector, np.zeros((0, 3), np.int64), bad,
              param="n_vertices")


@FUZZ
@given(st.sampled_from(BAD))
def test_fuzz_phyllotaxis_values(fuzz, bad):
    fuzz.call("phyllotaxis.vogel_disc", ph.vogel_disc, 10, c=bad, param="c")
    fuzz.call("phyllotaxis.disc_receptacle", ph.disc_receptacle, bad, param="radius")
    fuzz.call("phyllotaxis.cone_receptacle", ph.cone_receptacle, 1.0, bad, param="height")
    r = ph.disc_receptacle(1.0)
    fuzz.call("phyllotaxis.ridley_placement", ph.ridley_placement, r, area=bad, param="area")
    fuzz.call("DynamicPhyllotaxis", DynamicPhyllotaxis, inner_area=bad, param="inner_area")
    fuzz.call("scn.Placement", scn.Placement, "o", 0, (0, 0, 0), (bad, 1, 1), (0, 1, 0), (1, 0, 0),
              param="scale")
    fuzz.call("scn.Placement", scn.Placement, "o", bad, (0, 0, 0), (1, 1, 1), (0, 1, 0), (1, 0, 0), param="id")


@FUZZ
@given(st.sampled_from([10**9, -7, 2**40, np.nan, 1e300]), st.sampled_from(["faces", "edges", "cons", "x"]))
def test_fuzz_kernel_indices_never_reach_numba(fuzz, bad, which):
    """Index tables naming a vertex that does not exist are refused before any numba kernel runs."""
    x, faces = _patch()
    f = faces.astype(np.float64).copy()
    if which == "faces":
        f[0, 0] = bad
        fuzz.call("ccd.detect_collisions", ccd.detect_collisions, x, x + 0.01, f, param="faces")
        fuzz.call("ccd.count_static_intersections", ccd.count_static_intersections, x, f, param="faces")
    elif which == "edges":
        e = ccd.mesh_edges_of(faces).astype(np.float64)
        e[0, 1] = bad
        fuzz.call("ccd.CollisionDetector", ccd.CollisionDetector, faces, len(x), edges=e, param="edges")
        fuzz.call("ccd.count_static_intersections", ccd.count_static_intersections, x, faces, edges=e,
                  param="edges")
        fuzz.call("pbd.solve_internal", pbd.solve_internal, x.copy(), np.ones(len(x)), e, np.ones(len(e)),
                  np.zeros((0, 4), np.int64), np.zeros(0), param="edges")
    elif which == "cons":
        cons = np.array([[0, 1, 2, 3]], dtype=np.float64)
        cons[0, 2] = bad
        fuzz.call("ccd.solve_collisions", ccd.solve_collisions, x.copy(), np.ones(len(x)), cons, np.ones(1),
                  param="cons")
    else:
        y = x.copy()
        y[0, 0] = bad
        fuzz.call("ccd.detect_collisions", ccd.detect_collisions, x, y, faces, param="x1")
        fuzz.call("ccd.count_static_intersections", ccd.count_static_intersections, y, faces, param="x")


def test_detector_refuses_terabyte_vertex_count():
    with pytest.raises(ValueError, match="n_vertices"):
        ccd.CollisionDetector(np.zeros((0, 3), np.int64), 1 << 40)


# ---------------------------------------------------------------------------------------------- files
def _scene():
    return [scn.Placement("ca", 3, (0.1, 2.0, -3.5), (1, 1, 1), (0, 1, 0), (1, 0, 0), (0, 120.5), 7),
            scn.Placement("o", 0, (1e-7, 0, 5), (0.5, 2, 1), (0, 0, 1), (0, 1, 0))]


def _frames():
    rng = np.random.default_rng(0)
    return [scn.RigidBodyFrame(np.arange(4), rng.random((4, 3)), 1 + rng.random((4, 3)),
                               np.tile([0.0, 1, 0], (4, 1)), np.tile([1.0, 0, 0], (4, 1))) for _ in range(3)]


def test_round_trips_are_byte_identical(tmp_path):
    a = scn.write_scn(tmp_path / "a.scn", _scene())
    b = scn.write_scn(tmp_path / "b.scn", scn.read_scn(a))
    assert a.read_bytes() == b.read_bytes()
    scn.write_rba_sequence(tmp_path / "r1", _frames())
    scn.write_rba_sequence(tmp_path / "r2", scn.read_rba_sequence(tmp_path / "r1"))
    for name in sorted(os.listdir(tmp_path / "r1")):
        assert (tmp_path / "r1" / name).read_bytes() == (tmp_path / "r2" / name).read_bytes()
    x, faces = _patch()
    frames = np.stack([x, x * 1.5, x + 0.25])
    write_obj_sequence(str(tmp_path / "o1"), faces, frames, fixed=[0, 1, 2])
    f2, fr2, fx2 = read_obj_sequence(str(tmp_path / "o1"))
    write_obj_sequence(str(tmp_path / "o2"), f2, fr2, fixed=fx2)
    assert np.array_equal(fr2, frames) and np.array_equal(f2, faces)
    for name in sorted(os.listdir(tmp_path / "o1")):
        assert (tmp_path / "o1" / name).read_bytes() == (tmp_path / "o2" / name).read_bytes()


def test_shorter_sequence_replaces_a_longer_one(tmp_path):
    scn.write_rba_sequence(tmp_path, _frames())
    scn.write_rba_sequence(tmp_path, _frames()[:1])
    assert len(scn.read_rba_sequence(tmp_path)) == 1
    x, faces = _patch()
    write_obj_sequence(str(tmp_path), faces, np.stack([x, x, x]))
    write_obj_sequence(str(tmp_path), faces, np.stack([x, x]))
    assert read_obj_sequence(str(tmp_path))[1].shape[0] == 2


def test_failed_writes_keep_the_old_file(tmp_path, monkeypatch):
    path = scn.write_scn(tmp_path / "a.scn", _scene())
    rba = scn.write_rba(tmp_path / "f_0000.rba", _frames()[0])
    old, old_rba = path.read_bytes(), rba.read_bytes()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "fsync", boom)
    with pytest.raises(OSError):
        scn.write_scn(path, _scene()[:1])
    with pytest.raises(OSError):
        scn.write_rba(rba, _frames()[1])
    x, faces = _patch()
    with pytest.raises(OSError):
        write_obj_sequence(str(tmp_path / "o"), faces, np.stack([x, x]))
    monkeypatch.undo()
    assert path.read_bytes() == old and rba.read_bytes() == old_rba
    leftovers = [p for _, _, fs in os.walk(tmp_path) for p in fs if p.endswith(".tmp")]
    assert not leftovers
    with pytest.raises(ValueError, match="faces"):
        write_obj_sequence(str(tmp_path / "o"), faces + 1000, np.stack([x, x]))


CORRUPT_SCN = ["o: 0 0 0 0 1 1 1 0 1 0 1 0\n", "o: 0 0 0 nan 1 1 1 0 1 0 1 0 0\n", "o: -1 0 0 0 1 1 1 0 1 0 1 0 0\n",
               "o: 1e300 0 0 0 1 1 1 0 1 0 1 0 0\n", "o: 0 0 0 0 1e300 1 1 0 1 0 1 0 0\n",
               "o: 0 0 0 0 1 1 1 0 0 0 1 0 0\n", "zz: 0\n", "mtl: 3\n", "o: 0 0 0 0 1 1 1 0 1 0 1 0 0\nmtl: 256\n",
               "ca: 0 0 0 0 1 1 1 0 1 0 1 0 0 10 5\n", "ca: 0 0 0 0 1 1 1 0 1 0 1 0 0 0 1e300\n"]


@pytest.mark.parametrize("text", CORRUPT_SCN)
def test_corrupt_scn_is_rejected(tmp_path, text):
    p = tmp_path / "a.scn"
    p.write_text(text)
    with pytest.raises(ValueError):
        scn.read_scn(p)


@pytest.mark.parametrize("text", ["0 0 0 0 1 1 1 0 1 0 1 0\n", "0 nan 0 0 1 1 1 0 1 0 1 0 0\n",
                                  "0 0 0 0 1 1 1 0 1 0 1 0 0\n0 0 0 0 1 1 1 0 1 0 1 0 0\n",
                                  "1e300 0 0 0 1 1 1 0 1 0 1 0 0\n", "0 0 0 0 -1 1 1 0 1 0 1 0 0\n"])
def test_corrupt_rba_is_rejected(tmp_path, text):
    p = tmp_path / "f_0001.rba"
    p.write_text(text)
    with pytest.raises(ValueError):
        scn.read_rba(p)
    with pytest.raises(ValueError):
        scn.read_rba_sequence(tmp_path)


def test_binary_and_truncated_files_never_crash(tmp_path):
    a = scn.write_scn(tmp_path / "a.scn", _scene())
    data = a.read_bytes()
    rng = np.random.default_rng(0)
    bad = tmp_path / "b.scn"
    for k in range(0, len(data), 5):
        bad.write_bytes(data[:k])
        try:
            scn.read_scn(bad)
        except ValueError:
            pass
    for _ in range(60):
        b = bytearray(data)
        b[int(rng.integers(len(b)))] ^= 1 << int(rng.integers(8))
        bad.write_bytes(bytes(b))
        try:
            scn.read_scn(bad)
        except ValueError:
            pass
    bad.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError):
        scn.read_scn(bad)


@pytest.mark.parametrize("obj", [b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
                                 b"v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", b"v 0 0\nf 1 2 3\n",
                                 b"v 1e300 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", b"v x y z\n", b"\xff\xfe\x00\x01",
                                 b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n"])
def test_corrupt_obj_sequences_are_rejected(tmp_path, obj):
    (tmp_path / "frame_0000.obj").write_bytes(obj)
    with pytest.raises(ValueError):
        read_obj_sequence(str(tmp_path))


def test_corrupt_weight_file_is_rejected(tmp_path):
    x, faces = _patch()
    write_obj_sequence(str(tmp_path), faces, np.stack([x, x]), fixed=[0, 1])
    for text in ("0\n99999\n", "-1\n", "a b\n"):
        (tmp_path / "weight.txt").write_text(text)
        with pytest.raises(ValueError, match="weight"):
            read_obj_sequence(str(tmp_path))


def test_scene_tree_rejects_corrupt_nested_scene(tmp_path):
    (tmp_path / "top.scn").write_text("rba: 0 0 0 0 1 1 1 0 1 0 1 0 0 0 10\n")
    (tmp_path / "sub.scn").write_bytes(b"\xff\xfe garbage")
    with pytest.raises(ValueError):
        scn.load_scene_tree(tmp_path / "top.scn", {0: tmp_path / "sub.scn"})
    with pytest.raises(ValueError):
        scn.load_scene_tree(tmp_path / "top.scn", {0: tmp_path / "top.scn"})

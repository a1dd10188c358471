"""Tests for spec 002 §3.8: SCN and RBA files (lossless round trips, malformed files, nested scenes)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from plantvr.flowers.dynamic import DynamicPhyllotaxis
from plantvr.flowers.scn import (
    SCN_TYPES,
    Placement,
    RigidBodyFrame,
    format_scn,
    load_scene_tree,
    parse_rba,
    parse_scn,
    read_rba,
    read_rba_sequence,
    read_scn,
    scene_from_frames,
    write_rba,
    write_rba_sequence,
    write_scn,
)


def _random_scene(rng, n=30):
    out = []
    kinds = list(SCN_TYPES)
    for k in range(n):
        kind = kinds[k % len(kinds)]
        extra = list(rng.normal(size=len(SCN_TYPES[kind])) * 10.0 ** rng.integers(-8, 8))
        if "frame_start" in SCN_TYPES[kind]:
            extra[:2] = sorted([int(rng.integers(0, 500)), float(rng.uniform(0, 1000))])
        up = rng.normal(size=3)
        out.append(Placement(kind, int(rng.integers(0, 5)), rng.normal(size=3) * 1e3,
                             rng.uniform(1e-6, 1e3, 3), up, np.cross(up, rng.normal(size=3)), tuple(extra),
                             int(rng.integers(0, 256)) if k % 3 == 0 else None))
    return out


def test_scn_round_trip_is_lossless(tmp_path):
    scene = _random_scene(np.random.default_rng(0))
    path = write_scn(tmp_path / "s1.sce", scene)
    back = read_scn(path)
    assert back == scene                                      # every float bit-identical, materials kept
    assert format_scn(back) == path.read_text()               # file -> model -> file is stable


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=3, max_size=3))
def test_scn_numbers_round_trip_exactly(pos):
    p = Placement("o", 7, pos, (1, 2, 3), (0, 1, 0), (1, 0, 0))
    assert parse_scn(format_scn([p])) == [p]


def test_thesis_example_lines():
    text = ("# ca: ID Position Scale Up Left FrameStart FrameEnd\n"
            "ca: 0 0 0 0 1 1 1 0 1 0 1 0 0 0 1000\nmtl: 3\n"
            "ca: 0 000 111 010 100 0 1000\n")             # the App. C.2 example as extracted
    a, b = parse_scn(text)
    assert a.kind == "ca" and a.id == 0 and a.scale == (1.0, 1.0, 1.0) and a.up == (0.0, 1.0, 0.0)
    assert a.right == (1.0, 0.0, 0.0) and a.field("frame_end") == 1000.0 and a.material == 3
    assert b == Placement("ca", 0, (0, 0, 0), (1, 1, 1), (0, 1, 0), (1, 0, 0), (0, 1000))


def test_placement_transform_maps_y_up_object():
    p = Placement("o", 0, (1, 2, 3), (2, 2, 2), (0, 0, 1), (1, 0, 0.5))   # right made orthogonal on load
    R = p.frame()
    assert np.allclose(R.T @ R, np.eye(3)) and np.linalg.det(R) == pytest.approx(1.0)
    x = p.transform([[0, 1, 0], [1, 0, 0]])
    assert np.allclose(x, [[1, 2, 5], [3, 2, 3]])            # local +y -> up, local +x -> right


@pytest.mark.parametrize("text, match", [
    ("xx: 0 0 0 0 1 1 1 0 1 0 1 0 0\n", "line 1: unknown entry type 'xx'"),
    ("o: 0 0 0 0 1 1 1 0 1 0 1 0\n", "line 1: 'o' entries have 13 fields"),
    ("# c\nca: 0 0 0 0 1 1 1 0 1 0 1 0 0 5\n", "line 2: 'ca' entries have 15 fields"),
    ("o: 0 0 0 zero 1 1 1 0 1 0 1 0 0\n", "'zero' is not a number"),
    ("o: 0 0 0 nan 1 1 1 0 1 0 1 0 0\n", "must be finite"),
    ("o: 1.5 0 0 0 1 1 1 0 1 0 1 0 0\n", "id must be a non-negative integer"),
    ("o: 0 0 0 0 1 1 1 0 0 0 1 0 0\n", "up must be non-zero"),
    ("o: 0 0 0 0 1 1 1 0 1 0 0 2 0\n", "right not parallel"),
    ("o: 0 0 0 0 1 -1 1 0 1 0 1 0 0\n", "scale must be > 0"),
    ("ca: 0 0 0 0 1 1 1 0 1 0 1 0 0 10 5\n", "frame_end must be >= frame_start"),
    ("mtl: 2\n", "'mtl:' must follow a placement entry"),
    ("o: 0 0 0 0 1 1 1 0 1 0 1 0 0\nmtl: 2\nmtl: 3\n", "line 3: 'mtl:' must follow"),
    ("o: 0 0 0 0 1 1 1 0 1 0 1 0 0\nmtl: 256\n", r"material index must be an integer in \[0, 255\]"),
    ("o 0 0 0 0 1 1 1 0 1 0 1 0 0\n", "expected 'type: fields'"),
])
def test_malformed_scn_raises_clear_error(text, match):
    with pytest.raises(ValueError, match=match):
        parse_scn(text)


def test_unreadable_files_raise_value_error(tmp_path):
    with pytest.raises(ValueError, match="SCN file .*missing.sce' does not exist"):
        read_scn(tmp_path / "missing.sce")
    (tmp_path / "bin.sce").write_bytes(b"\xff\xfe\x00o: 0")
    with pytest.raises(ValueError, match="bin.sce' is not UTF-8 text"):
        read_scn(tmp_path / "bin.sce")
    with pytest.raises(ValueError, match="does not exist"):
        read_rba_sequence(tmp_path / "nope")


def _rba(rng, n=12):
    up = rng.normal(size=(n, 3))
    return RigidBodyFrame(rng.permutation(50)[:n], rng.normal(size=(n, 3)), rng.uniform(0.1, 3, (n, 3)), up,
                          np.cross(up, rng.normal(size=(n, 3))))


def test_rba_round_trip_and_sequence_order(tmp_path):
    rng = np.random.default_rng(1)
    frames = [_rba(rng) for _ in range(12)]
    paths = write_rba_sequence(tmp_path / "anim", frames)
    assert paths[3].name == "frame_0003.rba"
    (tmp_path / "anim" / "notes.txt").write_text("ignored")
    back = read_rba_sequence(tmp_path / "anim")
    assert back == frames
    # numeric, not lexicographic, order: frame_10 after frame_9
    d = tmp_path / "plain"
    d.mkdir()
    for k in (10, 9, 1):
        write_rba(d / f"f_{k}.rba", RigidBodyFrame([k], [[k, 0, 0]], [[1, 1, 1]], [[0, 1, 0]], [[1, 0, 0]]))
    assert [int(f.ids[0]) for f in read_rba_sequence(d)] == [1, 9, 10]
    assert read_rba(paths[0]) == frames[0]


@pytest.mark.parametrize("text, match", [
    ("0 0 0 0 1 1 1 0 1 0 1 0\n", "line 1: RBA lines have 13 fields"),
    ("0 0 0 0 1 1 1 0 1 0 1 0 0\n0 1 0 0 1 1 1 0 1 0 1 0 0\n", "ids must be unique"),
    ("-1 0 0 0 1 1 1 0 1 0 1 0 0\n", "id must be a non-negative integer"),
    ("0 0 0 0 1 1 x 0 1 0 1 0 0\n", "'x' is not a number"),
    ("0 0 0 0 1 1 1 0 1 0 0 1 0\n", "right not parallel"),
])
def test_malformed_rba_raises_clear_error(text, match):
    with pytest.raises(ValueError, match=match):
        parse_rba(text)


def test_rba_ids_must_exist_in_scene(tmp_path):
    write_rba_sequence(tmp_path, [RigidBodyFrame([0, 3], np.zeros((2, 3)), np.ones((2, 3)), [[0, 0, 1]] * 2,
                                                 [[1, 0, 0]] * 2)])
    scene = [Placement("o", 0, (0, 0, 0), (1, 1, 1), (0, 0, 1), (1, 0, 0))] * 3
    with pytest.raises(ValueError, match="id 3 has no entry in the 3-entry SCN file"):
        read_rba_sequence(tmp_path, scene=scene)


def test_nested_scenes_and_cycle_detection(tmp_path):
    leaf = Placement("ca", 0, (0, 0, 0), (1, 1, 1), (0, 0, 1), (1, 0, 0), (0, 10))
    write_scn(tmp_path / "head.sce", [leaf])
    sub = Placement("rba", 1, (0, 0, 0), (1, 1, 1), (0, 0, 1), (1, 0, 0), (0, 5))
    write_scn(tmp_path / "plant.sce", [sub, sub])
    tree = load_scene_tree(tmp_path / "plant.sce", {1: tmp_path / "head.sce"})
    assert len(tree) == 2 and tree[(tmp_path / "head.sce").resolve()] == [leaf]
    # head instantiates plant: plant -> head -> plant
    back_ref = Placement("rba", 2, (0, 0, 0), (1, 1, 1), (0, 0, 1), (1, 0, 0), (0, 5))
    write_scn(tmp_path / "head.sce", [back_ref])
    with pytest.raises(ValueError, match=r"recursive scene reference: plant\.sce -> head\.sce -> plant\.sce"):
        load_scene_tree(tmp_path / "plant.sce", {1: tmp_path / "head.sce", 2: tmp_path / "plant.sce"})
    with pytest.raises(ValueError, match="names no rigid body animation"):
        load_scene_tree(tmp_path / "plant.sce", {1: tmp_path / "head.sce"})


def test_dynamic_pattern_to_scn_and_rba_round_trip(tmp_path):
    dyn = DynamicPhyllotaxis(mode="segregation", inner_area=0.02, inner_rate=0.02,
                             primordium_area=lambda a: 0.03 * (1 + 0.1 * a))
    frames = dyn.run(30, 1.0)
    scene, rba = scene_from_frames(frames, object_id=2, opening_frames=20)
    last = frames[-1]
    assert len(scene) == last.n and len(rba) == 30
    assert all(p.kind == "ca" and p.id == 2 for p in scene)
    assert np.allclose([p.scale[0] for p in scene], np.sqrt(last.area / last.area.max()))
    starts = np.array([p.field("frame_start") for p in scene])
    assert np.all(np.diff(starts) > 0)                          # production order = SCN order
    write_scn(tmp_path / "head.sce", scene)
    write_rba_sequence(tmp_path / "rba", rba)
    assert read_scn(tmp_path / "head.sce") == scene
    back = read_rba_sequence(tmp_path / "rba", scene=scene)
    assert back == rba
    assert np.array_equal(back[-1].position, last.position)     # positions exact through the files
    grown = [f.ids.size for f in back]
    assert grown == sorted(grown) and grown[-1] == last.n


def test_bad_arguments():
    with pytest.raises(ValueError, match="kind must be one of"):
        Placement("obj", 0, (0, 0, 0), (1, 1, 1), (0, 1, 0), (1, 0, 0))
    with pytest.raises(ValueError, match="extra must have shape"):
        Placement("ca", 0, (0, 0, 0), (1, 1, 1), (0, 1, 0), (1, 0, 0), (1,))
    with pytest.raises(ValueError, match="frames must hold at least one"):
        scene_from_frames([])
    with pytest.raises(ValueError, match="prefix must be"):
        write_rba_sequence("/tmp/unused_rba", [], prefix="f1")
    with pytest.raises(ValueError, match=r"'o' entries have fields \[\]"):
        Placement("o", 0, (0, 0, 0), (1, 1, 1), (0, 1, 0), (1, 0, 0)).field("frame_end")


def test_hierarchical_florets_to_scn_round_trip(tmp_path):
    from plantvr.flowers.hierarchical import HierarchicalPhyllotaxis, LevelSpec
    from plantvr.flowers.scn import placements_from_arrays
    H = HierarchicalPhyllotaxis([LevelSpec(meristem_area=0.05, max_elements=4),
                                 LevelSpec(primordium_area=0.01, threshold=0.012, max_elements=20)])
    H.run(30, 1.0)
    fl = H.florets()
    kind = (fl["head"] % 2).astype(np.int64)                    # two floret animations
    scene = placements_from_arrays(fl["position"], fl["up"], fl["right"], np.sqrt(fl["area"] / 0.01),
                                   object_id=kind)
    assert len(scene) == 80
    write_scn(tmp_path / "compound.sce", scene)
    back = read_scn(tmp_path / "compound.sce")
    assert back == scene
    assert np.array_equal(np.array([p.position for p in back]), fl["position"])
    with pytest.raises(ValueError, match="extra must have shape"):
        placements_from_arrays(fl["position"], fl["up"], fl["right"], np.ones(80), kind="ca")


def test_rba_at_interpolates_position_scale_and_frame():
    from plantvr.flowers.scn import rba_at
    c, s_ = np.cos(np.pi / 2), np.sin(np.pi / 2)
    a = RigidBodyFrame([0, 1], [[0, 0, 0], [1, 1, 1]], [[1, 1, 1], [1, 1, 1]], [[0, 0, 1]] * 2,
                       [[1, 0, 0]] * 2)
    b = RigidBodyFrame([0, 2], [[2, 0, 0], [5, 5, 5]], [[3, 3, 3], [1, 1, 1]], [[0, 0, 1], [0, 1, 0]],
                       [[c, s_, 0], [1, 0, 0]])
    assert rba_at([a, b], 0.0) is a and rba_at([a, b], 1.0) is b and rba_at([a, b], 0.7, mode="floor") is a
    m = rba_at([a, b], 0.5)
    assert m.ids.tolist() == [0, 1]                          # the newborn id 2 appears with file 1
    assert np.allclose(m.position[0], [1, 0, 0]) and np.allclose(m.scale[0], 2.0)
    assert np.allclose(m.right[0], [np.cos(np.pi / 4), np.sin(np.pi / 4), 0])     # half of the 90 deg turn
    assert np.allclose(m.up[0], [0, 0, 1])
    assert np.array_equal(m.position[1], a.position[1])     # id 1 is absent from file 1: kept
    with pytest.raises(ValueError, match="f must be in"):
        rba_at([a, b], 1.5)
    with pytest.raises(ValueError, match="non-empty sequence of RigidBodyFrame"):
        rba_at([], 0.0)

"""Issue 20 for implicit crowns: every entry point checks its input at the door, saves are atomic, readers
refuse corrupt files, a rejected script leaves the session (and the files it would save) unchanged."""
from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr import implicit as im
from plantvr.commandlog import CommandLog
from plantvr.documents.crown import CrownDocument
from plantvr.implicit import warps as wp
from plantvr.implicit._lane_kernels import PDF_CAP

BAD = [np.nan, np.inf, -np.inf, 1e300, 1e19, -9.3e18, 10**12, -5, 0, 1e-20, -1e-300, "x", None, [], [1.0, 2.0],
       np.zeros((2, 2)), True]
BAD_INT = [np.nan, np.inf, 1e300, 10**12, -5, -1, 0.5, "3", None, [], 2**70]
BAD_POINTS = [np.full((3, 3), np.nan), np.full((2, 3), np.inf), np.full((2, 3), 1e300), np.full((2, 3), 1e19),
              np.zeros((2, 2)), np.zeros((3,)), "abc", None, [[1, 2, "a"]], np.zeros((2, 3), dtype=object),
              [[1, 2], [3]]]
BALL = im.sphere((0, 0, 0), 4.0)
FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _sane_field(node):
    f = node.field([[0.0, 0.0, 0.0], [0.1, 0.2, 0.3]])
    assert f.shape == (2,) and np.all(np.isfinite(f))


# ---------------------------------------------------------------------------------------------- BlobTree
@FUZZ
@given(st.sampled_from(BAD), st.sampled_from(["radius", "rho", "center"]))
def test_fuzz_primitives(fuzz, bad, param):
    kw = {"radius": 1.0, "rho": 1.0, "center": (0, 0, 0)}
    kw[param] = bad
    out = fuzz.call("blobtree.torus", im.torus, center=kw["center"], rho=kw["rho"], radius=kw["radius"], param=param)
    if not isinstance(out, Exception):
        _sane_field(out)
    out = fuzz.call("blobtree.sphere", im.sphere, kw["center"], kw["radius"],
                    param=param if param != "rho" else None)
    if not isinstance(out, Exception):
        _sane_field(out)


@FUZZ
@given(st.sampled_from(BAD_POINTS))
def test_fuzz_points_and_skeletons(fuzz, bad):
    fuzz.call("Node.field", BALL.field, bad, param="points")
    fuzz.call("Node.inside", BALL.inside, bad, param="points")
    fuzz.call("blobtree.segment", im.segment, bad, (0, 1, 0), 1.0, param="a")
    fuzz.call("blobtree.polyline", im.polyline, bad, 1.0, param="vertices")
    fuzz.call("Node.transformed", BALL.transformed, bad, param="matrix")
    fuzz.call("Node.translated", BALL.translated, bad, param="offset")
    fuzz.call("Node.rotated", BALL.rotated, bad, 30.0, param="axis")


@FUZZ
@given(st.sampled_from(BAD), st.integers(0, 2))
def test_fuzz_transforms(fuzz, bad, axis):
    s = [1.0, 1.0, 1.0]
    s[axis] = bad
    out = fuzz.call("Node.scaled", BALL.scaled, *s, param=("sx", "sy", "sz"))
    if not isinstance(out, Exception):
        _sane_field(out)
    out = fuzz.call("Node.rotated", BALL.rotated, (0, 1, 0), bad, param="angle_deg")
    if not isinstance(out, Exception):
        _sane_field(out)


def test_runaway_scale_and_radius_are_refused():
    with pytest.raises(ValueError, match="sx"):
        BALL.scaled(1e300, 1, 1)
    s = BALL
    with pytest.raises(ValueError, match="support box|matrix"):
        for _ in range(10):
            s = s.scaled(1e8, 1e8, 1e8)
    with pytest.raises(ValueError, match="radius"):
        im.sphere(radius=1e-300)            # R**2 underflows to 0: the kernel would divide by zero
    with pytest.raises(ValueError, match="radius"):
        im.sphere(radius=1e300)


@FUZZ
@given(st.sampled_from(BAD + [object()]))
def test_fuzz_operators(fuzz, bad):
    for name, cls in (("Blend", im.Blend), ("Union", im.Union), ("Intersection", im.Intersection)):
        fuzz.call(f"blobtree.{name}", cls, BALL, bad, param=name)
    fuzz.call("blobtree.Difference", im.Difference, BALL, bad, param="Difference")
    fuzz.call("blobtree.TransformNode", im.TransformNode, BALL, bad, param="matrix")
    fuzz.call("Warp", im.Warp, bad, "twist", 1.0, param="child")


# ---------------------------------------------------------------------------------------------- fields, warps
@FUZZ
@given(st.sampled_from(BAD))
def test_fuzz_fields(fuzz, bad):
    for name, fn in (("wyvill", im.wyvill), ("wyvill_derivative", im.wyvill_derivative)):
        out = fuzz.call(f"fields.{name}", fn, bad, param="r")
        if not isinstance(out, Exception):
            assert np.all(np.isfinite(out))
        fuzz.call(f"fields.{name}", fn, 0.3, bad, param="radius")
    out = fuzz.call("fields.blinn", im.blinn, bad, param="r")
    if not isinstance(out, Exception):
        assert np.all(np.isfinite(out))
    fuzz.call("fields.blinn", im.blinn, 0.3, a=bad, param="a")


@FUZZ
@given(st.sampled_from(BAD), st.sampled_from(["twist", "taper", "bend"]))
def test_fuzz_warps(fuzz, bad, kind):
    p = np.array([[0.1, 0.2, 0.3]])
    fuzz.call("warps.twist_forward", wp.twist_forward, p, bad, param="k")
    fuzz.call("warps.taper_inverse", wp.taper_inverse, p, bad, param="k")
    fuzz.call("warps.taper_forward", wp.taper_forward, p, 0.1, bad, param="z0")
    fuzz.call("warps.bend_forward", wp.bend_forward, p, 0.5, bad, param="length")
    fuzz.call("warps.bend_inverse", wp.bend_inverse, p, bad, 1.0, param="k")
    out = fuzz.call("Warp", im.Warp, BALL, kind, bad, param="k")
    if not isinstance(out, Exception):
        _sane_field(out)


# ---------------------------------------------------------------------------------------------- sampling
@FUZZ
@given(st.sampled_from(BAD_INT))
def test_fuzz_sample_counts(fuzz, bad):
    fuzz.call("sampling.sample_inside", im.sample_inside, BALL, bad, rng=0, param="n")
    fuzz.call("sampling.rejection_sample", im.rejection_sample, BALL, 5, f_lo=0.5, max_draws=bad, rng=0,
              param="max_draws")
    fuzz.call("sampling.sample_step_pdf", im.sample_step_pdf, np.ones(4), bad, rng=0, param="n")
    fuzz.call("sampling.lane_sample", im.lane_sample, np.ones((4, 4, 4)), bad, bbox=[[0, 0, 0], [1, 1, 1]],
              kernel=im.poisson_kernel(0.1), rng=0, param="n")
    fuzz.call("sampling.field_pdf", im.field_pdf, BALL, shape=(bad, 8, 8), param="shape")
    fuzz.call("sampling.lane_in_node", im.lane_in_node, BALL, bad, kernel=im.poisson_kernel(0.5), shape=(8, 8, 8),
              rng=0, param="n")
    fuzz.call("band.sample_band", im.sample_band, BALL, bad, rng=0, param="n")
    fuzz.call("polygonize", im.polygonize, BALL, resolution=bad, param="resolution")
    fuzz.call("sample_grid", im.sample_grid, BALL, resolution=8, pad=bad, param="pad")
    fuzz.call("mesh_sampling.sample_mesh_near", im.sample_mesh_near, [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
              [[0, 1, 2]], bad, rng=0, param="n")


@FUZZ
@given(st.sampled_from(BAD))
def test_fuzz_sampling_values(fuzz, bad):
    fuzz.call("sampling.rejection_sample", im.rejection_sample, BALL, 5, f_lo=bad, rng=0, param="f_lo")
    fuzz.call("sampling.poisson_kernel", im.poisson_kernel, bad, param="r_min")
    fuzz.call("sampling.cluster_kernel", im.cluster_kernel, 0.5, bad, param="r1")
    fuzz.call("sampling.cluster_kernel", im.cluster_kernel, 0.5, 1.0, bad, param="alpha")
    fuzz.call("sampling.custom_kernel", im.custom_kernel, [0.1, bad], [0.0, 2.0], param="radii")
    fuzz.call("sampling.custom_kernel", im.custom_kernel, [0.1, 0.2], [0.0, bad], param="values")
    fuzz.call("sampling.icdf_step_1d", im.icdf_step_1d, [1.0, 2.0], [0.5], a=bad, param="a")
    fuzz.call("sampling.icdf_step_1d", im.icdf_step_1d, [1.0, 2.0], bad, param="y")
    fuzz.call("sampling.step_cdf", im.step_cdf, bad, param="values")
    fuzz.call("sampling.sample_step_pdf", im.sample_step_pdf, bad, 3, rng=0, param="pdf")
    fuzz.call("sampling.lane_sample", im.lane_sample, np.ones((4, 4, 4)), 5, bbox=bad,
              kernel=im.poisson_kernel(0.1), rng=0, param="bbox")
    fuzz.call("sampling.lane_sample", im.lane_sample, np.ones((4, 4, 4)), 5, bbox=[[0, 0, 0], [1, 1, 1]],
              kernel=bad, rng=0, param="kernel")
    fuzz.call("sampling.lane_sample", im.lane_sample, np.ones((4, 4, 4)), 5, bbox=[[0, 0, 0], [1, 1, 1]],
              kernel=im.poisson_kernel(0.1), min_distance=bad, rng=0, param="min_distance")
    fuzz.call("sampling.field_pdf", im.field_pdf, BALL, shape=(8, 8, 8), mode="band", band=bad, param="band")
    fuzz.call("sampling.field_pdf", im.field_pdf, BALL, shape=(8, 8, 8), gamma=bad, param="gamma")
    fuzz.call("sampling.field_pdf", im.field_pdf, BALL, shape=(8, 8, 8), mode="band", band=(0.4, 0.6),
              cache=bad, param="cache")
    fuzz.call("sampling.lane_in_node", im.lane_in_node, BALL, 5, kernel=im.poisson_kernel(0.5), shape=(8, 8, 8),
              mode="band", band=bad, rng=0, param="band")
    fuzz.call("band.FieldCache", im.FieldCache, BALL, edge=bad, param="edge")
    fuzz.call("band.FieldCache", im.FieldCache, BALL, band=bad, param="band")
    fuzz.call("band.sample_band", im.sample_band, BALL, 5, band=bad, rng=0, param="band")
    fuzz.call("band.sample_band", im.sample_band, BALL, 5, max_draws=bad, rng=0, param="max_draws")
    fuzz.call("sample_grid", im.sample_grid, BALL, resolution=8, bbox=bad, param="bbox")
    fuzz.call("polygonize", im.polygonize, BALL, resolution=8, iso=bad, param="iso")


def test_grids_that_would_allocate_terabytes_are_refused():
    with pytest.raises(ValueError, match="shape"):
        im.field_pdf(BALL, shape=(4096, 4096, 4096))
    with pytest.raises(ValueError, match="resolution"):
        im.polygonize(BALL, resolution=1024)
    with pytest.raises(ValueError, match="edge"):
        im.FieldCache(BALL, edge=1e-300)
    with pytest.raises(ValueError, match="edge"):
        im.FieldCache(BALL, edge=1e-3)
    with pytest.raises(ValueError, match="bbox"):
        im.sample_inside(BALL, 3, bbox=[[0, 0, 0], [1e-300, 1, 1]])


def test_lane_pdf_never_overflows_with_boosting_kernels():
    """A cluster kernel multiplies cells by alpha per nearby point: without a cap the pdf reaches inf, inf * 0
    gives NaN and the cell picks index -1 (a point outside the box)."""
    k = im.cluster_kernel(0.05, 1.0, 1e6)
    box = np.array([[0.0, 0, 0], [1, 1, 1]])
    for backend in ("numba", "numpy"):
        r = im.lane_sample(np.ones((6, 6, 6)), 400, bbox=box, kernel=k, rng=1, backend=backend)
        assert np.all(np.isfinite(r.pdf)) and r.pdf.max() <= PDF_CAP
        assert np.all((r.points >= box[0]) & (r.points <= box[1]))
    a = im.lane_sample(np.ones((6, 6, 6)), 400, bbox=box, kernel=k, rng=1, backend="numba")
    b = im.lane_sample(np.ones((6, 6, 6)), 400, bbox=box, kernel=k, rng=1, backend="numpy")
    np.testing.assert_array_equal(a.points, b.points)


def test_lane_extremes_inside_the_door_stay_in_bounds():
    """Input that passes the door never makes the numba kernels index out of bounds (run under
    NUMBA_BOUNDSCHECK=1 too): tiny and huge cells, huge supports, a single cell, points outside the box."""
    for box, kr in (([[0, 0, 0], [1e-9, 1e-9, 1e-9]], 1e6), ([[-1e6] * 3, [1e6] * 3], 1e-6),
                    ([[0, 0, 0], [1, 1, 1]], 1e6)):
        for shape in ((1, 1, 1), (3, 1, 7)):
            r = im.lane_sample(np.ones(shape), 20, bbox=box, kernel=im.poisson_kernel(kr), rng=0,
                               existing=[[1e6, -1e6, 0.0]])
            assert np.all(np.isfinite(r.points)) and len(r.points) <= 20


def test_variational_degenerate_constraints_are_clear_errors():
    b = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    with pytest.raises(ValueError, match="boundary and interior"):
        im.Variational(b + b, [[0.5, 0.5, 0.5]])
    with pytest.raises(ValueError, match="boundary and interior"):
        im.Variational(b, [[0.5, 0.5, 0.0]])            # all coplanar: singular with a linear tail


@FUZZ
@given(st.sampled_from(BAD_POINTS + BAD))
def test_fuzz_skinning_and_mesh(fuzz, bad):
    fuzz.call("skinning.Polygon2D", im.Polygon2D, bad, param="vertices")
    fuzz.call("skinning.Circle2D", im.Circle2D, bad, param="r")
    fuzz.call("skinning.SkinPath", im.SkinPath, bad, param="points")
    fuzz.call("skinning.SkinPath", im.SkinPath, [[0, 0, 0], [0, 0, 1]], normal=bad, param="normal")
    fuzz.call("skinning.Revolution", im.Revolution, [[0, 0], [1, 0], [1, 1], [0, 1]], radius=bad, param="radius")
    fuzz.call("skinning.Revolution", im.Revolution, bad, param="vertices")
    fuzz.call("skinning.sweep", im.sweep, im.Circle2D(0.3), [[0, 0, 0], [0, 0, 1]], radius=bad, param="radius")
    fuzz.call("Variational", im.Variational, bad, [[0, 0, 0]], param="boundary")
    fuzz.call("mesh_sampling.face_cdf", im.face_cdf, bad, [[0, 1, 2]], param="vertices")
    fuzz.call("mesh_sampling.face_cdf", im.face_cdf, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], bad, param="faces")
    fuzz.call("crown.default_roots", im.default_roots, bad, param="points")
    fuzz.call("crown.pipe_radii", im.pipe_radii, bad, param="parent")
    fuzz.call("crown.pipe_radii", im.pipe_radii, [-1, 0], r0=bad, param="r0")


def test_zero_length_polygon_edge_is_refused():
    with pytest.raises(ValueError, match="zero-length"):
        im.Polygon2D([[0, 0], [0, 0], [1, 0], [0, 1]])


@FUZZ
@given(st.sampled_from(BAD))
def test_fuzz_grow_in_crown(fuzz, bad):
    m = np.random.default_rng(0).random((30, 3)) * 4 + [0, 3, 0]
    for param in ("step_size", "kill_radius", "influence_radius", "max_steps", "children_limit", "stall_steps"):
        kw = {"step_size": 0.5, "kill_radius": 1.0, "max_steps": 5, param: bad}
        fuzz.call("crown.grow_in_crown", im.grow_in_crown, m, **kw, param=param)
    fuzz.call("crown.grow_in_crown", im.grow_in_crown, np.full((3, 3), bad) if isinstance(bad, float) else bad,
              step_size=0.5, kill_radius=1.0, param="markers")


# ---------------------------------------------------------------------------------------------- point sets
@FUZZ
@given(bad=st.sampled_from(BAD + BAD_POINTS))
def test_fuzz_point_sets(fuzz, tmp_path_factory, bad):
    tmp = tmp_path_factory.mktemp("ps")
    fuzz.call("PointSet", im.PointSet, bad, param=("points", "tags"))
    fuzz.call("PointSet", im.PointSet, np.zeros((2, 3)), bad, ["a"], param="tags")
    ps = im.PointSet.from_points(np.zeros((2, 3)), "a")
    fuzz.call("PointSet.add", ps.add, bad, "b", param="points")
    fuzz.call("PointSet.select", ps.select, bad, param="mask")
    fuzz.call("pointsets.thin", im.thin, ps, BALL, bad, param="percent")
    fuzz.call("pointsets.densify", im.densify, ps, BALL, bad, param="n")
    fuzz.call("pointsets.save_point_set", im.save_point_set, tmp / "p.txt", bad, param="points")
    fuzz.call("pointsets.save_point_set", im.save_point_set, tmp / "p.txt", ps, header=bad, param="header")
    fuzz.call("pointsets.write_props", im.write_props, tmp / "a.props", {"num_points": bad}, param="num_points")
    fuzz.call("pointsets.write_props", im.write_props, tmp / "a.props", {"min_distance": bad},
              param="min_distance")
    fuzz.call("pointsets.read_props", im.read_props, bad, param=("path_or_text", "props file"))
    assert not [p for p in os.listdir(tmp) if p.endswith(".tmp")]


def test_tags_must_index_sources():
    with pytest.raises(ValueError, match="tags"):
        im.PointSet(np.zeros((2, 3)), [0, -1], ["a"])
    with pytest.raises(ValueError, match="tags"):
        im.PointSet(np.zeros((2, 3)), [0, 3], ["a"])


def test_point_set_round_trip_is_byte_identical(tmp_path):
    pts = np.random.default_rng(0).random((50, 3)) * 10
    ps = im.PointSet.from_points(pts, "crown:poisson").add(pts[:5] + 1, "a b").add(pts[:2], "")
    p1, p2 = tmp_path / "a.txt", tmp_path / "b.txt"
    im.save_point_set(p1, ps, header={"seed": 3})
    back = im.load_point_set(p1)
    assert back.sources == ["crown:poisson", "a_b", "_"] and np.array_equal(back.tags, ps.tags)
    im.save_point_set(p2, back, header={"seed": 3})
    assert p1.read_bytes() == p2.read_bytes()


def test_props_round_trip_is_byte_identical(tmp_path):
    props = {"min_distance": 0.75, "num_points": 1234, "grid": (32, 48, 64), "seed": 9, "exact": True,
             "band": (0.5, 0.55), "gamma": 2.0, "offset": (0.01, 0.2), "alpha": 4.0, "r1": 1.5}
    im.write_props(tmp_path / "a.props", props)
    back = im.read_props(tmp_path / "a.props")
    im.write_props(tmp_path / "b.props", {k: back[k] for k in props})
    assert (tmp_path / "a.props").read_bytes() == (tmp_path / "b.props").read_bytes()
    assert {k: back[k] for k in props} == props


def test_failed_saves_keep_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "p.txt"
    ps = im.PointSet.from_points(np.ones((3, 3)), "a")
    im.save_point_set(path, ps)
    old = path.read_bytes()
    with pytest.raises(ValueError, match="header"):
        im.save_point_set(path, ps, header={"x": "two\nlines"})
    with pytest.raises(ValueError, match="num_points"):
        im.write_props(tmp_path / "a.props", {"num_points": "5\nseed = 3"})
    s = CrownDocument()
    s.run("sphere s 4\n")
    s.log.save(tmp_path / "s.log")
    old_log = (tmp_path / "s.log").read_bytes()
    s.run("sphere t 2\n")

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "fsync", boom)
    for fn in (lambda: im.save_point_set(path, im.PointSet.from_points(np.zeros((9, 3)), "b")),
               lambda: s.log.save(tmp_path / "s.log")):
        with pytest.raises(OSError):
            fn()
    monkeypatch.undo()
    assert path.read_bytes() == old and (tmp_path / "s.log").read_bytes() == old_log
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]


CORRUPT_POINTS = [
    b"1 2\n",                                  # wrong count
    b"1 2 3 4 5\n",
    b"1 2 nan\n", b"1 2 inf\n", b"1e300 0 0\n",  # non-finite / huge
    b"1 2 3 -1\n",                             # negative tag
    b"1 2 3 1000000000000000000\n",            # tag that would make 10**18 source names
    b"# sources = a\n1 2 3 1\n",               # tag without a source name
    b"1 2 3 x\n", b"\xff\xfe\x00\x01 2 3\n",   # not a number / not UTF-8
    b"1 2 3.5 0.5\n",
]


@pytest.mark.parametrize("data", CORRUPT_POINTS)
def test_corrupt_point_files_are_rejected(tmp_path, data):
    p = tmp_path / "p.txt"
    p.write_bytes(data)
    with pytest.raises(ValueError):
        im.load_point_set(p)


def test_point_file_truncations_and_bit_flips_never_crash(tmp_path):
    src = tmp_path / "good.txt"
    im.save_point_set(src, im.PointSet.from_points(np.random.default_rng(1).random((20, 3)), "a"))
    data = src.read_bytes()
    bad = tmp_path / "bad.txt"
    rng = np.random.default_rng(0)
    for k in list(range(0, len(data), 7)) + [-1]:
        bad.write_bytes(data[:k])
        try:
            im.load_point_set(bad)
        except ValueError:
            pass
    for _ in range(60):
        b = bytearray(data)
        i = int(rng.integers(len(b)))
        b[i] ^= 1 << int(rng.integers(8))
        bad.write_bytes(bytes(b))
        try:
            ps = im.load_point_set(bad)
        except ValueError:
            continue
        assert np.all(np.isfinite(ps.points)) and ps.tags.min(initial=0) >= 0


@pytest.mark.parametrize("text", ["num_points = 1e300", "grid = 5000", "grid = 1 2", "band = 0.5", "band = nan 1",
                                  "min_distance = inf", "seed = -1", "exact = maybe", "gamma = 1e9", "unknown = 1",
                                  "num_points = 5 6", "r1 = 1e300"])
def test_corrupt_props_are_rejected(text):
    with pytest.raises(ValueError):
        im.read_props(text)


# ---------------------------------------------------------------------------------------------- commands
TOKENS = ["sphere", "line", "torus", "scale", "translate", "rotate", "twist", "taper", "bend", "diff", "union",
          "blend", "copy", "delete", "seed", "point_set_gen", "point_set_thin", "point_set_clear", "grow",
          "s", "t", "u", "uniform", "poisson", "cluster", "near_boundary", "outside_near", "num_points=20",
          "grid=8", "min_distance=0.5", "min_distance=1e-300", "num_points=1e12", "grid=1024", "step=0.5",
          "kill=1", "max_steps=3", "root=0,0", "1", "0", "-1", "nan", "inf", "1e300", "1e19", "1e-20", "4", "|",
          "x"]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.lists(st.sampled_from(TOKENS), min_size=1, max_size=6), min_size=1, max_size=4))
def test_fuzz_command_scripts(fuzz, lines):
    s = CrownDocument(seed=1)
    s.run("sphere s 4\nsphere t 2 1 0 0\n")
    before = (s.state_bytes(), len(s.log), len(s.history.undo_stack))
    text = "\n".join(" ".join(line) for line in lines)
    out = fuzz.call("CrownDocument.run", s.run, text)
    if isinstance(out, Exception):
        assert isinstance(out, im.CommandError)
        assert (s.state_bytes(), len(s.log), len(s.history.undo_stack)) == before
    for name, node in s.surfaces.items():
        _sane_field(node)


def test_rejected_script_writes_no_file_and_leaves_session(tmp_path):
    s = CrownDocument(base_dir=tmp_path, seed=2)
    s.run("sphere s 6\npoint_set_gen s uniform num_points=30\nsave_point_set a.txt\n")
    old = (tmp_path / "a.txt").read_bytes()
    state = (s.state_bytes(), s.log.to_text())
    with pytest.raises(im.CommandError, match="line 4"):
        s.run("point_set_clear\nsave_point_set a.txt\nsave_point_set b.txt\nscale s 0 1 1\n")
    assert (tmp_path / "a.txt").read_bytes() == old and not (tmp_path / "b.txt").exists()
    assert (s.state_bytes(), s.log.to_text()) == state
    # a script that saves then loads the same file sees what it saved
    s.run("point_set_gen s uniform num_points=5\nsave_point_set c.txt\npoint_set_clear\nload_point_set c.txt\n")
    assert len(s.points) == 35 and (tmp_path / "c.txt").is_file()


def test_replayed_log_reproduces_the_session_and_resaves_identically(tmp_path):
    s = CrownDocument(base_dir=tmp_path, seed=5)
    s.run("sphere s 8 0 4 0\nscale s 1 1.5 1\npoint_set_gen s poisson num_points=80 min_distance=0.8 grid=24\n"
          "sphere sec 3 0 4 0\npoint_set_thin s sec 50\nseed 3\npoint_set_gen sec uniform num_points=10\n")
    s.log.save(tmp_path / "a.log")
    again = CrownDocument(base_dir=tmp_path, seed=5)
    again.replay(CommandLog.load(tmp_path / "a.log", CrownDocument.COMMANDS, document="crown"))
    assert again.points.points.tobytes() == s.points.points.tobytes() and again.points.sources == s.points.sources
    assert again.state_bytes() == s.state_bytes()
    assert [(e.command, e.kwargs) for e in again.log] == [(e.command, e.kwargs) for e in s.log]


@pytest.mark.parametrize("data", [b"\xff\xfe\xfa garbage", b"sphere s 4\x00\n", b"sphere s 4\nbogus 1\n",
                                  b"sphere s 1e300\n", b"sphere s 4\nscale s 1e300 1 1\n"])
def test_corrupt_scripts_are_rejected(tmp_path, data):
    p = tmp_path / "s.cmd"
    p.write_bytes(data)
    s = CrownDocument(base_dir=tmp_path)
    with pytest.raises(ValueError):
        s.run_file(p)
    assert s.surfaces == {} and len(s.log) == 0


def test_corrupt_mesh_is_a_command_error(tmp_path):
    (tmp_path / "m.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    (tmp_path / "n.obj").write_bytes(b"\x00\x01garbage")
    s = CrownDocument(base_dir=tmp_path)
    for f in ("m.obj", "n.obj"):
        with pytest.raises(im.CommandError):
            s.run(f"load_mesh m {f}\n")
    assert s.meshes == {}


def test_session_constructor_checks(fuzz):
    for bad in BAD:
        fuzz.call("CrownDocument", CrownDocument, default_radius=bad, param="default_radius")
        fuzz.call("CrownDocument", CrownDocument, seed=bad, param="seed")

"""V20, V21, V29 and file round trips: thinning, densifying, composite sets, points.txt and .props (spec 003 §3.8-3.9)."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantvr.implicit.blobtree import sphere
from plantvr.implicit.pointsets import (PROPS_DEFAULTS, PointSet, densify, load_point_set, read_props,
                                        save_point_set, thin, write_props)
from plantvr.implicit.sampling import sample_inside

CROWN = sphere(radius=8.0)                       # radius 4
SECONDARY = sphere((2.0, 0, 0), 4.0)             # radius 2


def test_v20_thin_first_points_inside_secondary():
    ps = PointSet.from_points(sample_inside(CROWN, 3000, rng=20), "crown:uniform")
    inside = SECONDARY.inside(ps.points)
    n_in = int(inside.sum())
    out = thin(ps, SECONDARY, 80)
    assert len(ps) - len(out) == int(np.floor(0.8 * n_in))
    assert int((~SECONDARY.inside(out.points)).sum()) == int((~inside).sum())
    removed = np.flatnonzero(inside)[: int(np.floor(0.8 * n_in))]
    keep = np.ones(len(ps), bool)
    keep[removed] = False
    assert np.array_equal(out.points, ps.points[keep])


def test_v21_densify_respects_existing():
    ps = PointSet.from_points(sample_inside(CROWN, 300, rng=21), "crown")
    out = densify(ps, SECONDARY, 200, r_min=0.3, respect_existing=True, shape=(32, 32, 32), rng=1)
    assert np.array_equal(out.points[: len(ps)], ps.points)
    new = out.points[len(ps):]
    assert len(new) > 0 and np.all(SECONDARY.inside(new))
    d_new, _ = cKDTree(new).query(new, k=2)
    d_old, _ = cKDTree(ps.points).query(new)
    assert d_new[:, 1].min() >= 0.3 and d_old.min() >= 0.3
    assert out.sources == ["crown", "densify"] and np.all(out.tags[len(ps):] == 1)


def test_points_txt_round_trip(tmp_path):
    ps = PointSet.from_points(sample_inside(CROWN, 100, rng=0), "a").add(np.array([[1.5, 2.25, -3.0]]), "b")
    save_point_set(tmp_path / "points.txt", ps, header={"seed": 0, "distribution": "uniform"})
    back = load_point_set(tmp_path / "points.txt")
    assert np.allclose(back.points, np.array([[float(f"{v:.6g}") for v in row] for row in ps.points]), rtol=0,
                       atol=0)
    assert back.sources == ["a", "b"] and np.array_equal(back.tags, ps.tags)
    (tmp_path / "bad.txt").write_text("1 2 x\n")
    with pytest.raises(ValueError, match="line 1: not a number"):
        load_point_set(tmp_path / "bad.txt")


def test_v29_props(tmp_path):
    (tmp_path / "poisson.props").write_text("# comment\nmin_distance = 2.5\nnum_points = 300\ngrid = 32 32 48\n"
                                            "exact = true\n")
    p = read_props(tmp_path / "poisson.props")
    assert p["min_distance"] == 2.5 and p["num_points"] == 300 and p["grid"] == (32, 32, 48) and p["exact"]
    assert p["seed"] == PROPS_DEFAULTS["seed"]
    write_props(tmp_path / "out.props", p)
    assert read_props(tmp_path / "out.props") == p
    (tmp_path / "bad.props").write_text("min_distance = 1\ncolour = red\n")
    with pytest.raises(ValueError, match="line 2: unknown key 'colour'"):
        read_props(tmp_path / "bad.props")
    with pytest.raises(ValueError, match="bad value for 'num_points'"):
        read_props("num_points = many")


def test_pointset_bad_input():
    with pytest.raises(ValueError, match="percent"):
        thin(PointSet(), SECONDARY, 120)
    with pytest.raises(ValueError, match="tags must have one entry per point"):
        PointSet(np.zeros((2, 3)), np.zeros(3))
    with pytest.raises(ValueError, match="r_min must be given"):
        densify(PointSet(), SECONDARY, 3, respect_existing=True)

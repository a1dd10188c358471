"""The shared door checks of plantvr/_validation.py that several parts call (issue 21: one copy each)."""
import numpy as np
import pytest

from plantvr._validation import MAX_COORD, check_tree_arrays, check_values
from plantvr.geometry.mesh import build_branch_mesh
from plantvr.io.tree import tree_skeleton
from plantvr.subdivision.graph import graph_from_arrays

POS = [[0, 0, 0], [0, 1, 0], [0, 2, 0], [1, 2, 0]]
PAR = [-1, 0, 1, 1]
RAD = [0.3, 0.2, 0.1, 0.1]


def test_check_tree_arrays_returns_typed_copies():
    pos, parent, radius = check_tree_arrays(POS, np.array(PAR, np.int32), RAD)
    assert pos.dtype == np.float64 and pos.shape == (4, 3)
    assert parent.dtype == np.int64 and parent.tolist() == PAR
    assert radius.dtype == np.float64 and radius.tolist() == RAD


@pytest.mark.parametrize(("pos", "par", "rad", "match"), [
    (POS[:1], PAR[:1], RAD[:1], "pos must have at least 2 rows"),
    (np.zeros((4, 2)), PAR, RAD, r"pos must have shape \(N, 3\)"),
    (POS, PAR[:3], RAD, r"parent must have shape \(4,\)"),
    (POS, [-1, 0, 1, 4], RAD, r"parent entries must lie in \[-1, 3\]"),
    (POS, [0, 0, 1, 1], RAD, r"parent\[0\] must be -1"),
    (POS, [-1, 0, 3, 1], RAD, r"parent must satisfy .*cycles.*parent\[2\] = 3"),
    (POS, [-1, -1, 1, 1], RAD, r"parent must satisfy .*parent\[1\] = -1"),
    (POS, PAR, [0.3, np.nan, 0.1, 0.1], "radius must contain only finite"),
    (POS, PAR, [0.3, 2 * MAX_COORD, 0.1, 0.1], "radius values must lie in"),
])
def test_check_tree_arrays_rejects(pos, par, rad, match):
    with pytest.raises(ValueError, match=match):
        check_tree_arrays(pos, par, rad)


def test_check_tree_arrays_max_radius_none_leaves_the_range_to_the_caller():
    check_tree_arrays(POS, PAR, [0.3, 2 * MAX_COORD, 0.1, 0.1], max_radius=None)
    with pytest.raises(ValueError, match=r"radius must be > 0 \(in"):  # graph's own range check
        graph_from_arrays(POS, PAR, [0.3, 2 * MAX_COORD, 0.1, 0.1])


@pytest.mark.parametrize("entry", [
    lambda par: build_branch_mesh(POS, par, RAD),
    lambda par: tree_skeleton(POS, par, RAD),
    lambda par: graph_from_arrays(POS, par, RAD),
])
def test_every_tree_entry_point_gives_the_same_parent_errors(entry):
    with pytest.raises(ValueError, match=r"parent\[0\] must be -1"):
        entry([1, 0, 1, 1])
    with pytest.raises(ValueError, match=r"parent must satisfy .*parent\[3\] = 3"):
        entry([-1, 0, 1, 3])


def test_check_tree_arrays_forest_allows_extra_roots_only_when_asked():
    par = [-1, 0, -1, 2]
    assert check_tree_arrays(POS, par, RAD, forest=True)[1].tolist() == par
    with pytest.raises(ValueError, match=r"0 <= parent\[i\] < i .*tree.*parent\[2\] = -1"):
        check_tree_arrays(POS, par, RAD)
    with pytest.raises(ValueError, match=r"-1 <= parent\[i\] < i .*forest.*parent\[3\] = 3"):
        check_tree_arrays(POS, [-1, 0, -1, 3], RAD, forest=True)
    with pytest.raises(ValueError, match=r"parent\[0\] must be -1"):
        check_tree_arrays(POS, [0, -1, -1, 2], RAD, forest=True)


def test_check_values_any_shape_finite():
    assert check_values("x", 2).shape == () and check_values("x", [[1, 2]]).dtype == np.float64
    assert np.isnan(check_values("t", [np.nan], finite=False)[0])
    with pytest.raises(ValueError, match="chi must contain only finite values"):
        check_values("chi", [0.0, np.inf])
    with pytest.raises(ValueError, match="d must be a number or an array of numbers, got str"):
        check_values("d", "far")
    with pytest.raises(ValueError, match="d must be a number or an array of numbers, got list"):
        check_values("d", [1, [2, 3]])

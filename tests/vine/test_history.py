import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from plantvr.documents.labels import Segmentation


@pytest.fixture
def seg(surface):
    return Segmentation(surface.vertices, surface.faces)


def _random_center(seg, rng):
    return seg.vertices[rng.integers(seg.n_vertices)].astype(np.float64)


def test_tw_v4_twenty_levels_and_identity(seg):
    rng = np.random.default_rng(0)
    snapshots = [seg.labels.copy()]
    for k in range(25):
        with seg.stroke():
            for _ in range(3):
                seg.paint(_random_center(seg, rng), 4.0, 1 + k % 9)
        snapshots.append(seg.labels.copy())
    assert len(seg.history.undo_stack) == 20
    for e in seg.history.undo_stack:                      # sorted unique indices
        assert np.all(np.diff(e.indices) > 0) and np.all(e.old != e.new)
    for k in range(20):
        assert seg.undo() is not None
        assert np.array_equal(seg.labels, snapshots[24 - k])
    assert seg.undo() is None
    for k in range(20):
        seg.redo()
    assert np.array_equal(seg.labels, snapshots[-1])
    seg.undo()
    assert np.array_equal(seg.labels, snapshots[-2])
    seg.paint(_random_center(seg, rng), 3.0, 5)           # new operation clears redo
    assert seg.redo() is None and len(seg.history.redo_stack) == 0


def test_tw_v4_vertex_painted_twice_restores_pre_operation_label(seg):
    c = seg.vertices[500].astype(np.float64)
    seg.paint(c, 5.0, 2)
    before = seg.labels.copy()
    with seg.stroke():
        seg.paint(c, 5.0, 3)
        seg.paint(c, 5.0, 4)
    seg.undo()
    assert np.array_equal(seg.labels, before)
    # painting back to the original value in one stroke records nothing for those vertices
    with seg.stroke():
        seg.paint(c, 5.0, 6)
        seg.paint(c, 5.0, 2)
    assert len(seg.history.redo_stack) == 0


def test_undo_memory_is_proportional_to_change(seg):
    n = seg.paint(seg.vertices[10].astype(np.float64), 3.0, 1)
    e = seg.history.undo_stack[-1]
    assert len(e) == n and e.nbytes == n * (4 + 1 + 1)


def test_byte_budget_drops_oldest(surface):
    seg = Segmentation(surface.vertices, surface.faces, max_undo_bytes=2000)
    rng = np.random.default_rng(1)
    for k in range(10):
        seg.paint(_random_center(seg, rng), 6.0, 1 + k % 5)
    assert seg.history.nbytes <= 2000


def test_abort_stroke_restores_labels(seg):
    before = seg.labels.copy()
    with pytest.raises(RuntimeError), seg.stroke():
        seg.paint(seg.vertices[0].astype(np.float64), 6.0, 3)
        raise RuntimeError("controller lost")
    assert np.array_equal(seg.labels, before) and not seg.history.undo_stack


@settings(max_examples=25, deadline=None)
@given(ops=st.lists(st.tuples(st.integers(0, 10**6), st.floats(0.5, 8.0), st.integers(0, 12),
                              st.booleans()), min_size=1, max_size=12))
def test_undo_all_and_redo_all_hypothesis(surface, ops):
    seg = Segmentation(surface.vertices, surface.faces, max_undo=100)
    original = seg.labels.copy()
    for v, r, label, hide in ops:
        if hide and label != 0:
            seg.toggle_visible(label)
        if seg.colors.visible[label]:
            seg.paint(seg.vertices[v % seg.n_vertices].astype(np.float64), r, label)
    final = seg.labels.copy()
    while seg.undo() is not None:
        pass
    assert np.array_equal(seg.labels, original)
    while seg.redo() is not None:
        pass
    assert np.array_equal(seg.labels, final)


def test_radix_sort_kernel_equals_numpy_twin():
    from plantvr.vine.stamps import _first_of_runs, _radix_sort_pairs, _sort_pairs_numpy
    rng = np.random.default_rng(7)
    for n_bits in (5, 17, 31):
        idx = rng.integers(0, 2 ** n_bits, 5000).astype(np.int64)
        old = rng.integers(0, 256, 5000).astype(np.uint8)
        a_i, a_o = _radix_sort_pairs(idx, old, n_bits)
        k = _first_of_runs(a_i, a_o)
        b_i, b_o = _sort_pairs_numpy(idx, old)
        assert np.array_equal(a_i[:k], b_i) and np.array_equal(a_o[:k], b_o)

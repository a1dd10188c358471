"""The shared counting sort equals numpy's stable argsort (its readable twin)."""
import numpy as np
import pytest

from plantvr._sorting import counting_sort


@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_counting_sort_is_stable_argsort(dtype):
    keys = np.random.default_rng(3).integers(0, 97, 5000)
    order, start = counting_sort(keys, 97, dtype)
    assert order.dtype == dtype and start.dtype == dtype
    np.testing.assert_array_equal(order, np.argsort(keys, kind="stable"))
    np.testing.assert_array_equal(start, np.concatenate([[0], np.cumsum(np.bincount(keys, minlength=97))]))


def test_counting_sort_empty_keys():
    order, start = counting_sort(np.zeros(0, np.int64), 4, np.int64)
    assert len(order) == 0 and start.tolist() == [0, 0, 0, 0, 0]

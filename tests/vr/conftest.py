"""Fixtures for headset-mode tests: the fake openvr runtime and a small grown model."""
import pytest

from plantvr.documents.treewand import Model
from plantvr.vr import fake_openvr


@pytest.fixture
def fake():
    """``openvr`` replaced by :mod:`plantvr.vr.fake_openvr` for the test; its runtime is returned."""
    fake_openvr.install()
    yield fake_openvr.runtime
    fake_openvr.uninstall()


@pytest.fixture
def model():
    """A seeded model with a small tree (a vertical stroke, 12 steps)."""
    m = Model(seed=0)
    m.paint_stroke([[0.0, y, 0.0] for y in range(2, 7)], radius=1.5)
    m.step(12)
    return m

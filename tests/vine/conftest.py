"""Shared fixtures for the ViNE tests: one small synthetic flower head, meshed once per session."""
import pytest

from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.vine.synth import synth_flowerhead, vertex_labels_from_volume


@pytest.fixture(scope="session")
def head():
    return synth_flowerhead(64, rng=1)


@pytest.fixture(scope="session")
def surface(head):
    return extract_isosurface(head.volume, head.level, slab=16)


@pytest.fixture(scope="session")
def truth(head, surface):
    return vertex_labels_from_volume(surface.vertices, head.volume, head.labels)

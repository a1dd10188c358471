import numpy as np
import pytest

from plantvr.vine.synth import COMPONENTS, synth_flowerhead, tile_mesh


def test_synth_has_every_component_and_is_deterministic(head):
    counts = np.bincount(head.labels.ravel(), minlength=len(COMPONENTS))
    assert np.all(counts[1:] > 0), dict(zip(COMPONENTS, counts))
    again = synth_flowerhead(64, rng=1)
    assert np.array_equal(again.volume, head.volume) and np.array_equal(again.labels, head.labels)
    assert head.volume.dtype == np.uint8 and head.labels.dtype == np.uint8


def test_synth_labels_sit_inside_the_iso_surface(head):
    inside = head.volume > head.level
    lab = head.labels > 0
    # labelled voxels are bright; bright voxels are labelled (up to the noise and the ramp edge)
    assert (inside & lab).sum() / lab.sum() > 0.95
    assert (inside & lab).sum() / inside.sum() > 0.95


def test_vertex_truth_covers_components(surface, truth):
    present = set(np.unique(truth).tolist())
    assert {1, 3, 4, 5, 6, 7, 8}.issubset(present)
    assert (truth == 0).mean() < 0.02          # intensity-noise specks near surfaces


def test_synth_rejects_bad_input():
    with pytest.raises(ValueError, match="shape"):
        synth_flowerhead(4)
    with pytest.raises(ValueError, match="noise_level"):
        synth_flowerhead(32, noise_level=-1)
    with pytest.raises(ValueError, match="n_veins"):
        synth_flowerhead(32, n_veins=0)


def test_tile_mesh_reaches_target(surface):
    v, f = tile_mesh(surface.vertices, surface.faces, 3 * len(surface.vertices) + 1)
    assert len(v) == 4 * len(surface.vertices) and len(f) == 4 * len(surface.faces)
    assert f.max() == len(v) - 1 and v.dtype == np.float32 and f.dtype == np.uint32

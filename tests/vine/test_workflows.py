"""Scripted segmentation workflows of thesis Ch. 6 against the synthetic ground truth (spec §5.2 V12a–d)."""
import itertools

import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantvr.documents.labels import Segmentation
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.vine.synth import COMPONENTS, synth_flowerhead, vertex_labels_from_volume

L = {name: i for i, name in enumerate(COMPONENTS)}


def _greedy_cover(seg, truth, label, radius, *, avoid=None, max_stamps=100000):
    """Painter bot: stamp at any not-yet-correct vertex of ``label`` until none is left; returns stamps."""
    stamps = 0
    avoid_tree = cKDTree(seg.vertices[avoid]) if avoid is not None and avoid.any() else None
    with seg.stroke():
        while stamps < max_stamps:
            todo = np.nonzero((truth == label) & (seg.labels != label) & seg.vertex_visible())[0]
            if todo.size == 0:
                break
            v = seg.vertices[todo[0]].astype(float)
            r = radius
            if avoid_tree is not None:                  # paint around the things to keep
                d, _ = avoid_tree.query(v)
                r = min(radius, max(0.0, 0.999 * d))
            seg.paint(v, r, label)
            stamps += 1
    return stamps


def _paint_exact(seg, truth):
    for lab in np.unique(truth):
        if lab:
            seg.paint_stroke(seg.vertices[truth == lab].astype(float), 0.0, int(lab))


def test_v12_a_component_segmentation_accuracy(surface, truth):
    seg = Segmentation(surface.vertices, surface.faces)
    # broad tissues first with a big brush, then veins with small brushes (thesis §6.1: broad, then fix)
    order = [("receptacle", 3.0), ("disk_floret", 2.0), ("ray_floret", 2.0), ("bract", 1.5), ("stem", 2.0),
             ("centrifugal", 1.0), ("centripetal", 1.0), ("floret_vein", 0.8), ("noise", 1.0)]
    for name, r in order:
        _greedy_cover(seg, truth, L[name], r)
    acc = {name: float((seg.labels[truth == L[name]] == L[name]).mean()) for name, _ in order}
    overall = float((seg.labels == truth)[truth > 0].mean())
    assert overall > 0.9, acc
    assert min(acc.values()) > 0.5, acc


def test_v12_b_unwrapping_layer_by_layer(surface, truth):
    seg = Segmentation(surface.vertices, surface.faces)
    _paint_exact(seg, truth)
    assert np.array_equal(seg.labels, truth)
    hidden = []
    n_faces = [len(seg.visible_faces())]
    for layer in ("bract", "ray_floret", "disk_floret"):
        seg.hide(L[layer])
        hidden.append(L[layer])
        assert np.array_equal(seg.vertex_visible(), ~np.isin(truth, hidden))
        n_faces.append(len(seg.visible_faces()))
    assert all(a > b for a, b in itertools.pairwise(n_faces))


def test_v12_c_isolating_one_vein(surface, truth, head):
    seg = Segmentation(surface.vertices, surface.faces)
    _paint_exact(seg, truth)
    # one centrifugal vein = the centrifugal vertices in the angular sector around one vein direction
    c = (np.array(head.volume.shape[:2]) - 1) / 2
    v = surface.vertices
    ang = np.arctan2(v[:, 1] - c[1], v[:, 0] - c[0])
    cf = np.nonzero(truth == L["centrifugal"])[0]
    ref = ang[cf[np.argmax(np.linalg.norm(v[cf, :2] - c, axis=1))]]
    sector = cf[np.abs(np.angle(np.exp(1j * (ang[cf] - ref)))) < 0.2]
    iso = seg.add_color((255, 0, 255))
    seg.paint_stroke(v[sector].astype(float), 0.0, iso)
    for lab in range(len(seg.colors)):
        if lab != iso:
            seg.hide(lab)
    assert np.array_equal(np.nonzero(seg.vertex_visible())[0], np.sort(sector))
    assert len(seg.visible_faces()) > 0


@pytest.fixture(scope="module")
def noisy():
    h = synth_flowerhead(64, noise_blobs=60, rng=4)
    s = extract_isosurface(h.volume, h.level, slab=16)
    return s, vertex_labels_from_volume(s.vertices, h.volume, h.labels)


def test_v12_d_noise_removal_with_selective_visibility_needs_fewer_stamps(noisy):
    s, truth = noisy
    noise = truth == L["noise"]
    assert noise.sum() > 50
    results = {}
    for mode in ("without_sv", "with_sv"):
        seg = Segmentation(s.vertices, s.faces)
        keep = (truth > 0) & ~noise
        _paint_exact(seg, np.where(keep, truth, 0).astype(np.uint8))
        if mode == "with_sv":
            for lab in np.unique(truth[keep]):
                seg.hide(int(lab))
            stamps = _greedy_cover(seg, truth, L["noise"], 6.0)
        else:
            stamps = _greedy_cover(seg, truth, L["noise"], 6.0, avoid=keep)
        acc = float((seg.labels[noise] == L["noise"]).mean())
        assert acc >= 0.99, (mode, acc)
        assert np.array_equal(seg.labels[keep], truth[keep])        # veins untouched either way
        results[mode] = stamps
    assert results["with_sv"] * 2 <= results["without_sv"], results

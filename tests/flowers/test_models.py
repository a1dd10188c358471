"""The remaining example models of spec 002 §6.2 / C28: each model's defining property."""
import time

import numpy as np
import pytest
from scipy.spatial import cKDTree

from plantvr.flowers import fate
from plantvr.flowers.composer import grow
from plantvr.flowers.models import (
    RAY,
    dahlia_head,
    dyssodia_head,
    lilac_panicle,
    orlaya_umbel,
    yarrow_corymb,
)

KW = {"detail": 0.5, "n_frames": 3}


def test_dahlia_ball_of_quills_on_a_sphere():
    h = dahlia_head(60, radius=5.0, **KW)
    assert h.n_rays == 60                                   # almost exclusively ray florets: all quills
    p = h.canopy.position
    rho = np.linalg.norm(p - [0, 0, 0], axis=1)             # hemisphere of radius 5 centred at the origin
    np.testing.assert_allclose(rho, 5.0, atol=1e-6)
    assert p[:, 2].min() < 1.0 and p[:, 2].max() > 4.5       # from the apex down to the equator
    np.testing.assert_allclose(h.canopy.rot[:, :, 2], p / rho[:, None], atol=1e-3)   # florets face outward


def _coverage(x, faces, face_instance, *, max_polar_deg=80.0, n_dirs=3000):
    """Over outward directions from the head centre (polar angle <= max_polar_deg): the fraction that meet a
    floret and the mean number of distinct florets each one meets (layers)."""
    i = np.arange(n_dirs) + 0.5
    z = 1 - 2 * i / n_dirs
    phi = i * np.pi * (3 - np.sqrt(5))
    d = np.column_stack([np.sqrt(1 - z**2) * np.cos(phi), np.sqrt(1 - z**2) * np.sin(phi), z])
    d = d[d[:, 2] >= np.cos(np.deg2rad(max_polar_deg))]
    w = np.array([(a, b) for a in range(6) for b in range(6 - a)]) / 5.0
    bary = np.column_stack([w, 1 - w.sum(1)])
    pts = np.einsum("sk,fkd->fsd", bary, x[faces]).reshape(-1, 3)
    inst = np.repeat(face_instance, len(bary))
    u = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    hits = cKDTree(u).query_ball_point(d, 0.5 * np.sqrt(4 * np.pi / n_dirs))
    layers = np.array([np.unique(inst[h]).size for h in hits])
    return float(np.mean(layers > 0)), float(layers.mean())


def test_dahlia_is_a_dense_layered_ball():
    h = dahlia_head(300, **KW)
    can = h.canopy
    assert can.n_instances == 300 and h.n_rays == 300
    x = can.initial_positions(np.ones(300))                 # every floret open
    cover, layers = _coverage(x, can.faces, can.face_instance)
    assert cover > 0.97 and layers > 2.0                     # closed ball of overlapping scales
    rho = np.linalg.norm(x, axis=1)
    assert np.percentile(rho, 99) < 1.6 * 10.0               # a ball, not a burst of spikes
    assert 28_000 <= len(dahlia_head(300, n_frames=2).canopy.faces) <= 36_000   # Table 4.1: 30,000 triangles


def test_dahlia_grows_collision_free_in_reasonable_time():
    h = dahlia_head(120, radius=6.0, **KW)
    t0 = time.process_time()                                 # CPU time: robust to a busy machine
    x, log = grow(h.canopy, h.schedule(4), sanity_every=4)
    assert time.process_time() - t0 < 20.0                   # ~0.5 s; the quill head of the same size took ~8 s
    assert log[-1]["intersections"] == 0
    cover, _ = _coverage(x, h.canopy.faces, h.canopy.face_instance)
    assert cover > 0.9                                       # still a closed ball after the collisions


def test_dyssodia_rays_at_the_level_of_the_whole_inflorescence():
    h = dyssodia_head(34, **KW)
    per = np.bincount(h.head, weights=(h.kind == RAY), minlength=6).astype(int)
    assert len(h.centres) == 6 and per[0] == 0               # 1 + 5 heads; no rays in the central head
    assert np.all(per[1:] >= 3)
    # rays sit on the outer side of their head
    out = h.centres[h.head] / np.linalg.norm(h.centres[h.head], axis=1, keepdims=True).clip(1e-12)
    side = np.einsum("ij,ij->i", h.canopy.position - h.centres[h.head], out)
    assert np.all(side[h.kind == RAY] > 0)


def test_yarrow_heads_differentiate_rays_independently_and_branch_to_one_base():
    h = yarrow_corymb(**KW)
    alone = yarrow_corymb(n_heads=1, **KW).n_rays
    per = np.bincount(h.head, weights=(h.kind == RAY)).astype(int)
    assert alone == 5 and np.all(per == alone)               # Fig. 6.4a: Th_a isolates the heads
    z = h.centres[:, 2]
    assert np.ptp(z) == 0                                    # heads in a single plane
    t = h.tree
    assert len(t.tips) == len(h.centres)
    for tip in t.tips:                                       # every head reaches the base
        v, k = tip, 0
        while t.parent[v] >= 0 and k < t.n_nodes:
            v, k = t.parent[v], k + 1
        assert v == 0
    np.testing.assert_allclose(t.pos[t.tips], h.centres, atol=1e-9)


def test_orlaya_two_levels_and_three_floret_sizes():
    h = orlaya_umbel(13, 8, **KW)
    assert set(np.unique(h.level)) == {1, 2}                 # two branching levels (Fig. 7.2b)
    assert h.canopy.n_instances == 13 * 8
    counts = np.bincount(h.fate, minlength=3)
    assert counts.min() > 0                                  # disc, small ray and large ray florets
    r_umb = np.linalg.norm(h.centres[:, :2], axis=1)
    large = np.bincount(h.head, weights=h.fate == fate.LARGE_RAY, minlength=13)
    assert large[np.argmin(r_umb)] == 0 and large[np.argmax(r_umb)] > 0   # large rays on the periphery
    small = h.fate == fate.SMALL_RAY
    d = fate.cone_dmin(h.canopy.position * [1, 1, 0], alpha_deg=53.0, centres=h.centres[h.head] * [1, 1, 0])
    o = np.argsort(d[small])
    assert np.all(np.diff(h.size[small][o]) >= 0)            # petal size grows with available space
    assert np.all(h.canopy.scale[small] <= h.canopy.scale[h.fate == fate.LARGE_RAY].min())


def test_lilac_panicle_structure_and_collision_free_growth():
    h = lilac_panicle(3, **KW)
    assert h.canopy.n_instances == 3 * (2 * 3 + 1)
    assert set(np.unique(h.level)) == {1, 2, 3}
    t = h.tree
    lat = np.flatnonzero(h.level == 2)
    L = np.linalg.norm(t.pos[lat] - t.pos[t.parent[lat]], axis=1)
    assert np.all(np.diff(L[::2]) < 0)                       # conical: laterals shorten upward
    dirs = (t.pos[lat] - t.pos[t.parent[lat]])[::2, :2]
    cos = np.einsum("ij,ij->i", dirs[:-1], dirs[1:])
    assert np.allclose(cos, 0, atol=1e-9)                    # decussate pairs
    _, log = grow(h.canopy, h.schedule(3), sanity_every=1)
    assert all(st["intersections"] == 0 for st in log)


def test_bad_input_models():
    with pytest.raises(ValueError, match="ring"):
        dyssodia_head(ring=1.0)
    with pytest.raises(ValueError, match="head_spacing"):
        yarrow_corymb(head_spacing=1.0)
    with pytest.raises(ValueError, match="th_b"):
        orlaya_umbel(th_a=5.0, th_b=1.0)
    with pytest.raises(ValueError, match="cyme"):
        lilac_panicle(cyme=0)

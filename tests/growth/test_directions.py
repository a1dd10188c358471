"""TW-V2 (bud headings, lateral frame), TW-V3 (tropism vector), TW-V4 (Eq. 9.5 limits), TW-V15 (lengths)."""
import numpy as np
import pytest

from plantvr.growth.directions import bud_headings, growth_directions, transport_lateral, tropism_vectors
from plantvr.growth.lengths import internode_lengths


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


H = np.array([[0.0, 1.0, 0.0]])
L = np.array([[1.0, 0.0, 0.0]])


def _angle(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(a * b, -1), -1, 1)))


def test_tw_v2_bud_angles():
    b = bud_headings(np.repeat(H, 3, 0), np.repeat(L, 3, 0), np.array([0, 1, 2]), main_angle=np.radians(12),
                     lateral_angle=np.radians(45), opposite=True)
    assert np.allclose(_angle(b, H), [12, 45, 45], atol=1e-9)
    assert b[0, 0] < 0 and b[1, 0] > 0 and b[2, 0] < 0  # main deflects away from slot 1; slot 2 mirrors slot 1


def test_tw_v2_divergence_on_straight_axis():
    lat = L.copy()
    for _ in range(5):
        nxt = transport_lateral(lat, H, H, np.radians(137.5))
        assert np.isclose(_angle(lat, nxt)[0], 137.5, atol=1e-9)
        assert abs(np.sum(nxt * H)) < 1e-12
        lat = nxt


def test_tw_v2_frame_follows_heading():
    rng = np.random.default_rng(1)
    h0, h1, l0 = unit(rng.normal(size=(50, 3))), unit(rng.normal(size=(50, 3))), None
    l0 = unit(np.cross(h0, rng.normal(size=(50, 3))))
    l1 = transport_lateral(l0, h0, h1, 0.3)
    assert np.allclose(np.sum(l1 * h1, 1), 0, atol=1e-12) and np.allclose(np.linalg.norm(l1, axis=1), 1)


def test_tw_v3_tropism_vector():
    rng = np.random.default_rng(2)
    b = unit(rng.normal(size=(200, 3)))
    for phi in (0.0, 30.0, 90.0, 150.0):
        t = tropism_vectors(b, unit(rng.normal(size=(200, 3))), np.radians(phi))
        assert np.allclose(_angle(t, np.array([0, 1, 0.0])), phi, atol=1e-9)
        assert np.allclose(np.einsum("ij,ij->i", np.cross(b, [0, 1, 0]), t), 0, atol=1e-9)  # t in span(b, y)
    # t is the nearest point to b on the cone: compare with random cone samples
    phi = np.radians(60)
    cone = np.stack([np.sin(phi) * np.cos(a := np.linspace(0, 2 * np.pi, 100000)), np.full_like(a, np.cos(phi)),
                     np.sin(phi) * np.sin(a)], 1)
    t = tropism_vectors(b[:5], b[:5], phi)
    assert np.all(np.sum(t * b[:5], 1)[:, None] >= (b[:5] @ cone.T).max(1)[:, None] - 1e-9)
    vertical = tropism_vectors(H, L, np.radians(90))
    assert np.allclose(vertical, L)  # deterministic fallback: the lateral vector


def test_tw_v4_eq95_limits():
    b, t, e = unit([[1, 2, 0.0]]), unit([[0, 1, 1.0]]), unit([[1, 0, 1.0]])
    assert np.allclose(growth_directions(b, t, e, 1, 0, 0), b)
    assert np.allclose(growth_directions(b, t, e, 0, 1, 0), t)
    assert np.allclose(growth_directions(b, t, e, 0, 0, 1), e)
    assert np.allclose(growth_directions(b, -b, b * 0, 1, 1, 0), b)  # vanishing sum falls back to b


def test_tw_v15_lengths():
    lo = internode_lengths("order", base=1.0, mult=3.0, order=np.array([0, 1, 2]))
    assert np.allclose(lo, [3.0, 2.0, 1.5])
    v = np.array([0.1, 0.5, 2.0])
    lv = internode_lengths("vigor", base=1.0, mult=3.0, vigor=v, vmax=2.0)
    assert lv.min() >= 1.0 and lv.max() == 3.0 and np.argmax(lv) == 2
    assert np.all(internode_lengths("constant", base=0.5, mult=3.0, order=np.zeros(4)) == 0.5)
    with pytest.raises(ValueError, match="length_mode must be one of"):
        internode_lengths("spiral", base=1.0, mult=2.0, order=np.zeros(1))

"""Bud headings, the lateral frame, tropism and the growth direction (spec 000_treewand §2.1, §2.4).

Vectorised over buds: every function takes (B, 3) arrays of unit vectors.
"""
from __future__ import annotations

import numpy as np

__all__ = ["bud_headings", "tropism_vectors", "growth_directions", "transport_lateral", "normalize"]

_Y = np.array([0.0, 1.0, 0.0])


def normalize(v: np.ndarray, fallback: np.ndarray | None = None, eps: float = 1e-12) -> np.ndarray:
    """Return the rows of ``v`` scaled to unit length; rows shorter than ``eps`` take ``fallback``."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    out = v / np.where(n < eps, 1.0, n)
    if fallback is not None:
        out = np.where(n < eps, fallback, out)
    return out


def bud_headings(head: np.ndarray, lat: np.ndarray, slot: np.ndarray, *, main_angle: float,
                 lateral_angle: float, opposite: bool = False, opposite_main: str = "eq9.1") -> np.ndarray:
    """Initial heading of each bud (Eqs. 9.1, 9.2); angles in radians.

    Slot 0: b = cos θ_main h − sin θ_main l (Eq. 9.1). Slot 1: b = cos θ_lat h + sin θ_lat l (Eq. 9.2);
    slot 2 (opposite mode) flips the sine. In opposite mode the main bud follows ``opposite_main``
    (ambiguity A.3): ``"eq9.1"`` as above, ``"perpendicular"`` rotates h about l, ``"none"`` keeps h.
    """
    slot = np.asarray(slot)[:, None]
    main = np.cos(main_angle) * head - np.sin(main_angle) * lat
    if opposite and opposite_main == "perpendicular":
        main = np.cos(main_angle) * head + np.sin(main_angle) * np.cross(lat, head)
    elif opposite and opposite_main == "none":
        main = head
    sign = np.where(slot == 2, -1.0, 1.0)
    lateral = np.cos(lateral_angle) * head + sign * np.sin(lateral_angle) * lat
    return np.where(slot == 0, main, lateral)


def tropism_vectors(b: np.ndarray, lat: np.ndarray, phi: float) -> np.ndarray:
    """Tropism vector at angle ``phi`` (radians) from vertical nearest to each heading ``b`` (§2.4, Fig. 9.5).

    t = cos φ ŷ + sin φ ĥ⊥ with ĥ⊥ the horizontal part of b; when b is vertical the horizontal part of
    the node's lateral vector is used, else x̂ ([INFERRED] fallback).
    """
    hp = b - (b @ _Y)[:, None] * _Y
    lp = lat - (lat @ _Y)[:, None] * _Y
    lp = normalize(lp, fallback=np.array([1.0, 0.0, 0.0]))
    hp = normalize(hp, fallback=lp)
    return np.cos(phi) * _Y + np.sin(phi) * hp


def growth_directions(b: np.ndarray, t: np.ndarray, e: np.ndarray, H: float, T, E: float) -> np.ndarray:
    """Eq. 9.5: d = (H b + T t + E e) / ||·||; falls back to b when the sum vanishes. ``T`` may be per bud."""
    T = np.asarray(T, dtype=float).reshape(-1, 1) if np.ndim(T) else T
    return normalize(H * b + T * t + E * e, fallback=b)


def _rotate(v: np.ndarray, axis: np.ndarray, angle) -> np.ndarray:
    """Rodrigues rotation of rows ``v`` about unit rows ``axis`` by ``angle`` (scalar or per row)."""
    c, s = np.cos(angle), np.sin(angle)
    c = np.asarray(c).reshape(-1, 1) if np.ndim(c) else c
    s = np.asarray(s).reshape(-1, 1) if np.ndim(s) else s
    return v * c + np.cross(axis, v) * s + axis * (np.sum(axis * v, axis=1, keepdims=True)) * (1 - c)


def transport_lateral(lat: np.ndarray, h_prev: np.ndarray, h_next: np.ndarray, divergence: float) -> np.ndarray:
    """Eq. 9.3: rotate l by θ_div about h_prev, then by the minimal rotation h_prev → h_next.

    The result is re-orthonormalised against h_next ([INFERRED], stops drift); q_head is skipped when
    h_prev × h_next vanishes.
    """
    l1 = _rotate(lat, h_prev, divergence)
    axis = np.cross(h_prev, h_next)
    norm = np.linalg.norm(axis, axis=1)
    ang = np.arctan2(norm, np.sum(h_prev * h_next, axis=1))
    ok = norm > 1e-12
    l2 = l1.copy()
    if ok.any():
        l2[ok] = _rotate(l1[ok], axis[ok] / norm[ok, None], ang[ok])
    l2 = l2 - np.sum(l2 * h_next, axis=1, keepdims=True) * h_next
    return normalize(l2)

"""Warps: twist, taper and bend as inverse maps before evaluation (spec 003_implicit_sca §2.5, C-4).

``F_warped(p) = F(w^-1(p))`` ([EXT] Barr 1984); the axis is the local z axis. The bounding box of a warped node
is the box of the forward-mapped child box (sampled on a dense lattice of the box) grown by a safety margin.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import check_choice, check_points, check_range

#: Bounds of the warp parameters (rad or 1/unit for k, units for z0 and L).
MAX_K = 1e6
MAX_LEN = 1e12


def _k(k):
    return check_range("k", k, -MAX_K, MAX_K)

from .blobtree import Node

__all__ = ["twist_forward", "twist_inverse", "taper_forward", "taper_inverse", "bend_forward", "bend_inverse",
           "Warp", "twist", "taper", "bend"]


def twist_forward(p: np.ndarray, k: float) -> np.ndarray:
    """Twist about z by ``theta = k z`` (k in rad per unit length)."""
    p = check_points("p", p)
    k = _k(k)
    th = k * p[:, 2]
    c, s = np.cos(th), np.sin(th)
    return np.column_stack([p[:, 0] * c - p[:, 1] * s, p[:, 0] * s + p[:, 1] * c, p[:, 2]])


def twist_inverse(p: np.ndarray, k: float) -> np.ndarray:
    """Inverse twist, spec §2.5: ``(x cos t + y sin t, -x sin t + y cos t, z)``, ``t = k z``."""
    return twist_forward(p, -k)


def _taper_s(z, k, z0):
    return 1.0 + k * (z - z0)


def taper_forward(p: np.ndarray, k: float, z0: float = 0.0) -> np.ndarray:
    """Taper ``(x s(z), y s(z), z)`` with ``s(z) = 1 + k (z - z0)``."""
    p = check_points("p", p)
    s = _taper_s(p[:, 2], _k(k), check_range("z0", z0, -MAX_LEN, MAX_LEN))
    return np.column_stack([p[:, 0] * s, p[:, 1] * s, p[:, 2]])


def taper_inverse(p: np.ndarray, k: float, z0: float = 0.0) -> np.ndarray:
    """Inverse taper ``(x/s(z), y/s(z), z)``; rows with ``s(z) <= 0`` become NaN (no preimage)."""
    p = check_points("p", p)
    s = _taper_s(p[:, 2], _k(k), check_range("z0", z0, -MAX_LEN, MAX_LEN))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.column_stack([p[:, 0] / s, p[:, 1] / s, p[:, 2]])
    out[s <= 0] = np.nan
    return out


def _bend_mirrored(p, k, length, bend_positive) -> np.ndarray:
    """Run a bend map written for ``k > 0`` on any k: mirror x for ``k < 0``, identity for ``k = 0``.

    ``bend_positive(x, z, k, length, out)`` gets the (mirrored) x and z columns, ``|k|`` and the output (a copy
    of the mirrored points) and writes the bent rows of ``out``.
    """
    p = check_points("p", p)
    k = _k(k)
    length = check_range("length", length, 0.0, MAX_LEN)
    sign = 1.0 if k >= 0 else -1.0
    k = abs(k)
    x, y, z = sign * p[:, 0], p[:, 1], p[:, 2]
    out = np.column_stack([x, y, z]).copy()
    if k > 0:
        bend_positive(x, z, k, length, out)
    out[:, 0] *= sign
    return out


def _bend_forward_positive(x, z, k, length, out):
    rho = 1.0 / k
    zc = np.clip(z, 0.0, length)
    th = k * zc
    extra = np.where(z > length, z - length, 0.0)
    a = rho - x
    X = rho - a * np.cos(th) + extra * np.sin(th)
    Z = a * np.sin(th) + extra * np.cos(th)
    bent = z >= 0
    out[bent, 0] = X[bent]
    out[bent, 2] = Z[bent]


def _bend_inverse_positive(X, Z, k, length, out):
    rho = 1.0 / k
    dx = rho - X
    phi = np.arctan2(Z, dx)
    th = k * length
    arc = (phi >= 0) & (phi <= th)
    out[arc, 0] = rho - np.hypot(dx[arc], Z[arc])
    out[arc, 2] = phi[arc] / k
    end = phi > th
    a = dx[end] * np.cos(th) + Z[end] * np.sin(th)
    b = -dx[end] * np.sin(th) + Z[end] * np.cos(th)
    out[end, 0] = rho - a
    out[end, 2] = length + b


def bend_forward(p: np.ndarray, k: float, length: float) -> np.ndarray:
    """Bend the segment 0 <= z <= L toward +x with curvature k (rho = 1/k); rigid beyond L, identity below 0.

    References
    ----------
    .. [1] Spec 003 §2.5 (forward map ``X = rho - (rho - x) cos(kz)``, ``Z = (rho - x) sin(kz)``) [INFERRED].
    """
    return _bend_mirrored(p, k, length, _bend_forward_positive)


def bend_inverse(p: np.ndarray, k: float, length: float) -> np.ndarray:
    """Inverse bend (spec §2.5): ``phi = atan2(Z, rho - X)`` selects identity, arc or rigid end region."""
    return _bend_mirrored(p, k, length, _bend_inverse_positive)


class Warp(Node):
    """Warped node ``F(p) = F_child(w^-1(p))`` for ``kind`` in twist, taper, bend.

    Parameters
    ----------
    child : Node
        The node to deform.
    kind : {"twist", "taper", "bend"}
        The deformation.
    k : float
        Twist rate (rad/unit), taper slope (1/unit) or bend curvature (1/unit).
    z0 : float
        Taper reference height where s = 1.
    length : float
        Bent length L (bend only).

    References
    ----------
    .. [1] Kochhar 2010, §4.1 ("bending, tapering, and twisting"); spec 003 §2.5, [EXT] Barr 1984.
    """

    def __init__(self, child: Node, kind: str, k: float, *, z0: float = 0.0, length: float = 1.0):
        if not isinstance(child, Node):
            raise ValueError(f"child must be a BlobTree Node, got {type(child).__name__}")
        self.child = child
        self.kind = check_choice("kind", kind, ("twist", "taper", "bend"))
        self.k = _k(k)
        self.z0 = check_range("z0", z0, -MAX_LEN, MAX_LEN)
        self.length = check_range("length", length, 0.0, MAX_LEN)
        lo, hi = child.bbox
        if self.kind == "taper":
            s_ends = _taper_s(np.array([lo[2], hi[2]]), self.k, self.z0)
            if np.any(s_ends <= 0):
                raise ValueError(f"k gives a non-positive taper scale s(z) inside the child's box: s = {s_ends}")
        g = [np.linspace(lo[i], hi[i], 17) for i in range(3)]
        lattice = np.stack(np.meshgrid(*g, indexing="ij"), -1).reshape(-1, 3)
        mapped = self.forward(lattice)
        margin = 0.02 * np.linalg.norm(hi - lo) + 1e-9
        if self.kind == "twist":
            rmax = np.max(np.hypot(lattice[:, 0], lattice[:, 1]))
            bbox = np.array([[-rmax, -rmax, lo[2]], [rmax, rmax, hi[2]]])
        else:
            bbox = np.array([mapped.min(axis=0) - margin, mapped.max(axis=0) + margin])
        from .blobtree import _check_box

        self.bbox = _check_box("Warp", bbox)

    def forward(self, p):
        """Forward map w(p) (for bounding boxes and tests)."""
        return self._warp(p, twist_forward, taper_forward, bend_forward)

    def inverse(self, p):
        """Inverse map w^-1(p)."""
        return self._warp(p, twist_inverse, taper_inverse, bend_inverse)

    def _warp(self, p, twist, taper, bend):
        """``p`` through the map of this warp's kind: ``twist(p, k)``, ``taper(p, k, z0)`` or
        ``bend(p, k, length)``."""
        if self.kind == "twist":
            return twist(p, self.k)
        if self.kind == "taper":
            return taper(p, self.k, self.z0)
        return bend(p, self.k, self.length)

    def _eval_inside(self, p, backend):
        q = self.inverse(p)
        ok = np.all(np.isfinite(q), axis=1)
        out = np.zeros(len(p))
        out[ok] = self.child._eval(q[ok], backend)
        return out

    def primitives(self):
        return self.child.primitives()


def twist(child: Node, k: float) -> Warp:
    """Twist ``child`` about z at ``k`` rad per unit length."""
    return Warp(child, "twist", k)


def taper(child: Node, k: float, *, z0: float = 0.0) -> Warp:
    """Taper ``child`` with ``s(z) = 1 + k (z - z0)``."""
    return Warp(child, "taper", k, z0=z0)


def bend(child: Node, k: float, *, length: float = 1.0) -> Warp:
    """Bend ``child`` toward +x with curvature ``k`` over ``0 <= z <= length``."""
    return Warp(child, "bend", k, length=length)

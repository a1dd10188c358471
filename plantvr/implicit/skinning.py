"""Implicit skinning along a path, surfaces of revolution and sweeps (spec 003_implicit_sca §2.6-2.7; C-5, C-6).

A point p is projected onto the path (Eq. 4.1, Newton-Raphson seeded by the nearest dense path sample); the local
2D coordinates are taken in the plane spanned by N(p') and B(p') of a rotation-minimizing frame (ERRATUM A.3), and
the distance is interpolated over the cross-sections (Eq. 4.2) linearly (ERRATUM A.2: d_i with d_{i+1}) or by a
uniform quadratic/cubic B-spline (Fig. 4.9). Cross-section distances are signed (negative inside) and mapped to
``d_i = max(0, delta_i + R/2)`` so the surface passes through each associated curve ([INFERRED], spec §2.7).
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline
from scipy.spatial import cKDTree

from plantvr._validation import (MAX_COORD, check_array, check_choice, check_int, check_point, check_points,
                                 check_range)

from .blobtree import MIN_RADIUS, Node, _check_box
from .fields import wyvill_from_sq

__all__ = ["Polygon2D", "Circle2D", "SkinPath", "Skin", "Revolution", "sweep", "rmf_double_reflection"]


class Polygon2D:
    """Closed planar cross-section curve (M >= 3 vertices) with a signed distance, negative inside."""

    def __init__(self, vertices):
        self.vertices = check_array("vertices", vertices, shape=(None, 2), min_rows=3, max_abs=MAX_COORD)
        if len(self.vertices) > 100_000:
            raise ValueError(f"vertices must have at most 100000 rows, got {len(self.vertices)}")
        e = np.roll(self.vertices, -1, axis=0) - self.vertices
        if np.any(np.einsum("ij,ij->i", e, e) <= 0):
            raise ValueError("vertices must not repeat consecutively (a zero-length polygon edge was found)")

    @property
    def extent(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices, axis=1)))

    def signed_distance(self, uv: np.ndarray) -> np.ndarray:
        """Signed 2D distance of ``uv`` (N, 2) to the polygon: negative inside (even-odd rule)."""
        v = self.vertices
        w = np.roll(v, -1, axis=0)
        best = np.full(len(uv), np.inf)
        inside = np.zeros(len(uv), dtype=bool)
        for a, b in zip(v, w):
            e = b - a
            d = uv - a
            t = np.clip(d @ e / float(e @ e), 0.0, 1.0)
            r = d - t[:, None] * e
            best = np.minimum(best, np.einsum("ij,ij->i", r, r))
            cond = (a[1] > uv[:, 1]) != (b[1] > uv[:, 1])
            with np.errstate(divide="ignore", invalid="ignore"):
                xc = a[0] + (uv[:, 1] - a[1]) * e[0] / e[1]
            inside ^= cond & (uv[:, 0] < xc)
        dist = np.sqrt(best)
        return np.where(inside, -dist, dist)


class Circle2D:
    """Circular cross-section of radius ``r`` centred at ``center`` (2,) in the section plane."""

    def __init__(self, r: float, center=(0.0, 0.0)):
        self.r = check_range("r", r, 0.0, MAX_COORD, low_open=True)
        self.center = check_array("center", center, shape=(2,), max_abs=MAX_COORD)

    @property
    def extent(self) -> float:
        return float(self.r + np.linalg.norm(self.center))

    def signed_distance(self, uv):
        return np.linalg.norm(uv - self.center, axis=1) - self.r


def rmf_double_reflection(x: np.ndarray, t: np.ndarray, r0: np.ndarray) -> np.ndarray:
    """Rotation-minimizing normals along sampled points by the double-reflection method.

    Parameters
    ----------
    x : (M, 3) float64 ndarray
        Path samples.
    t : (M, 3) float64 ndarray
        Unit tangents at the samples.
    r0 : (3,) float64 ndarray
        Initial unit normal, orthogonal to ``t[0]``.

    Returns
    -------
    (M, 3) float64 ndarray
        Unit normals N_i; B_i = T_i x N_i.

    References
    ----------
    .. [1] Wang, Jüttler, Zheng, Liu 2008 (double reflection), [EXT]; spec 003 §2.7 (equivalent to Bloomenthal [13]).
    """
    r = np.empty_like(x)
    r[0] = r0
    for i in range(len(x) - 1):
        v1 = x[i + 1] - x[i]
        c1 = v1 @ v1
        if c1 < 1e-300:
            r[i + 1] = r[i]
            continue
        rl = r[i] - (2.0 / c1) * (v1 @ r[i]) * v1
        tl = t[i] - (2.0 / c1) * (v1 @ t[i]) * v1
        v2 = t[i + 1] - tl
        c2 = v2 @ v2
        r[i + 1] = rl if c2 < 1e-300 else rl - (2.0 / c2) * (v2 @ rl) * v2
    return r


class SkinPath:
    """Path curve: interpolating spline through ``points`` with arc-length parameter s and an RMF frame.

    Parameters
    ----------
    points : (M, 3) float64 array_like
        Path points (M >= 2); a cubic spline for M >= 4, lower degree otherwise.
    normal : (3,) array_like, optional
        Initial normal N(0); any vector orthogonal to T(0) by default.
    samples : int
        Dense samples for the arc-length table, the Newton seed and the frames.
    """

    def __init__(self, points, *, normal=None, samples: int = 1024):
        pts = check_points("points", points, min_rows=2)
        samples = check_int("samples", samples, 16, 10**6)
        chord = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
        if chord[-1] <= 0 or np.any(np.diff(chord) <= 0):
            raise ValueError("points must be distinct consecutive path points (a zero-length step was found)")
        u = chord / chord[-1]
        self.spline = make_interp_spline(u, pts, k=min(3, len(pts) - 1))
        self.d1 = self.spline.derivative(1)
        if self.spline.k >= 2:
            self.d2 = self.spline.derivative(2)
        else:
            self.d2 = lambda u: np.zeros((len(np.atleast_1d(u)), 3))
        self.u = np.linspace(0.0, 1.0, samples + 1)
        self.x = self.spline(self.u)
        speed = np.linalg.norm(self.d1(self.u), axis=1)
        arc = np.r_[0.0, np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(self.u))]
        self.length = float(arc[-1])
        self.s = arc / arc[-1]
        self.t = self.d1(self.u) / speed[:, None]
        t0 = self.t[0]
        if normal is None:
            axis = np.eye(3)[np.argmin(np.abs(t0))]
        else:
            axis = check_point("normal", normal)
        n0 = axis - (axis @ t0) * t0
        if np.linalg.norm(n0) < 1e-12:
            raise ValueError("normal must not be parallel to the path tangent at its start")
        self.n = rmf_double_reflection(self.x, self.t, n0 / np.linalg.norm(n0))
        self._tree = cKDTree(self.x)

    @property
    def bbox(self):
        return np.array([self.x.min(axis=0), self.x.max(axis=0)])

    def frames(self, u: np.ndarray):
        """Point, unit T, N, B and arc-length s at spline parameters ``u`` (K,)."""
        c = self.spline(u)
        t = self.d1(u)
        t /= np.linalg.norm(t, axis=1)[:, None]
        n = np.column_stack([np.interp(u, self.u, self.n[:, i]) for i in range(3)])
        n -= np.einsum("ij,ij->i", n, t)[:, None] * t
        n /= np.linalg.norm(n, axis=1)[:, None]
        b = np.cross(t, n)
        return c, t, n, b, np.interp(u, self.u, self.s)

    def project(self, p: np.ndarray, *, iterations: int = 40) -> np.ndarray:
        """Spline parameter u of the projection p' of each point, solving Eq. 4.1 ``T(p').(p' - p) = 0``.

        References
        ----------
        .. [1] Kochhar 2010, §4.2.3, Eq. 4.1 (Newton-Raphson); seed = nearest dense sample (spec §2.7).
        """
        _, idx = self._tree.query(p)
        u = self.u[idx].copy()
        active = np.ones(len(p), dtype=bool)
        for _ in range(iterations):
            if not active.any():
                break
            ua = u[active]
            r = self.spline(ua) - p[active]
            c1 = self.d1(ua)
            h = np.einsum("ij,ij->i", c1, r)
            hp = np.einsum("ij,ij->i", self.d2(ua), r) + np.einsum("ij,ij->i", c1, c1)
            step = np.where(hp > 1e-12, h / np.where(hp > 1e-12, hp, 1.0), 0.0)
            un = np.clip(ua - step, 0.0, 1.0)
            done = np.abs(un - ua) < 1e-15
            u[active] = un
            idx_active = np.flatnonzero(active)
            active[idx_active[done]] = False
        return u


class Skin(Node):
    """Implicit skinned surface through planar cross-sections associated with path points (Eqs. 4.1-4.2).

    Parameters
    ----------
    path : SkinPath
        The path curve.
    sections : list of (float, curve or list of curves)
        ``(s_i, C_i)``: normalized arc-length association and one curve (Polygon2D/Circle2D) or several (2D union,
        Fig. 4.10). For B-spline interpolation the list is the control sequence; repeat an entry ``degree`` times to
        make the surface pass through it (Fig. 4.9).
    radius : float
        Wyvill radius of influence R.
    interpolation : {"linear", "quadratic", "cubic"}
        The blend g of Eq. 4.2.

    References
    ----------
    .. [1] Kochhar 2010, §4.2, Eqs. 4.1, 4.2, Figs. 4.8-4.10; spec 003 §2.7, ERRATA A.1-A.3.
    """

    _plane = "NB"  # ERRATUM A.3: the literal "T and N" plane is kept only for the V32 errata guard test

    def __init__(self, path: SkinPath, sections, *, radius: float = 1.0, interpolation: str = "linear"):
        if not isinstance(path, SkinPath):
            raise ValueError(f"path must be a SkinPath, got {type(path).__name__}")
        self.path = path
        self.radius = check_range("radius", radius, MIN_RADIUS, MAX_COORD)
        self.interpolation = check_choice("interpolation", interpolation, ("linear", "quadratic", "cubic"))
        secs = []
        for i, entry in enumerate(sections):
            try:
                s, curves = entry
            except (TypeError, ValueError):
                raise ValueError(f"sections[{i}] must be a pair (s, curve), got {entry!r}") from None
            s = check_range(f"sections[{i}] s", s, 0.0, 1.0)
            curves = list(curves) if isinstance(curves, (list, tuple)) else [curves]
            if not curves:
                raise ValueError(f"sections[{i}] must hold at least one curve")
            for c in curves:
                if not hasattr(c, "signed_distance"):
                    raise ValueError(f"sections[{i}] curve must be a Polygon2D or Circle2D, got {type(c).__name__}")
            secs.append((s, curves))
        degree = {"linear": 1, "quadratic": 2, "cubic": 3}[self.interpolation]
        if len(secs) < max(2, degree + 1):
            raise ValueError(f"sections needs at least {max(2, degree + 1)} entries for {interpolation}, "
                             f"got {len(secs)}")
        if np.any(np.diff([s for s, _ in secs]) < 0):
            raise ValueError("sections must be ordered by non-decreasing s")
        self.sections = secs
        self.degree = degree
        ext = max(c.extent for _, cs in secs for c in cs)
        lo, hi = path.bbox
        self.bbox = _check_box("Skin", np.array([lo - ext - self.radius, hi + ext + self.radius]))

    def _weights(self, s: np.ndarray) -> np.ndarray:
        m = len(self.sections)
        w = np.zeros((m, len(s)))
        if self.degree == 1:
            knots = np.array([sk for sk, _ in self.sections])
            s = np.clip(s, knots[0], knots[-1])
            i = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, m - 2)
            span = knots[i + 1] - knots[i]
            frac = np.where(span > 0, (s - knots[i]) / np.where(span > 0, span, 1.0), 0.0)
            w[i, np.arange(len(s))] = 1.0 - frac
            w[i + 1, np.arange(len(s))] += frac
            return w
        p = self.degree
        knots = np.arange(m + p + 1, dtype=float)
        x = p + np.clip(s, 0.0, 1.0) * (m - p)
        x = np.minimum(x, m - 1e-12)
        for k in range(m):
            c = np.zeros(m)
            c[k] = 1.0
            w[k] = BSpline(knots, c, p, extrapolate=False)(x)
        return np.nan_to_num(w)

    def local_coordinates(self, p: np.ndarray):
        """(u, v) section-plane coordinates, axial offset e and arc-length s of each point."""
        uu = self.path.project(p)
        c, t, n, b, s = self.path.frames(uu)
        w = p - c
        if self._plane == "NB":
            a1, a2 = np.einsum("ij,ij->i", w, n), np.einsum("ij,ij->i", w, b)
        else:  # literal thesis wording, wrong (ERRATUM A.3)
            a1, a2 = np.einsum("ij,ij->i", w, t), np.einsum("ij,ij->i", w, n)
        e = np.einsum("ij,ij->i", w, t)
        return np.column_stack([a1, a2]), e, s

    def distance(self, p: np.ndarray) -> np.ndarray:
        """Eq. 4.2 distance d(p) with end caps ``sqrt(d^2 + e^2)``."""
        uv, e, s = self.local_coordinates(p)
        half = 0.5 * self.radius
        d_i = np.array([np.maximum(0.0, np.min([c.signed_distance(uv) for c in cs], axis=0) + half)
                        for _, cs in self.sections])
        d = np.einsum("ij,ij->j", self._weights(s), d_i)
        return np.sqrt(d**2 + e**2)

    def _eval_inside(self, p, backend):
        return wyvill_from_sq(self.distance(p) ** 2 / self.radius**2)


class Revolution(Node):
    """Implicit surface of revolution about the local z axis from a profile region in the (rho, z) half-plane.

    Parameters
    ----------
    profile : (M, 2) float64 array_like
        Closed profile polygon, columns (rho >= 0, z).
    radius : float
        Wyvill radius of influence R; the surface passes through the profile boundary.

    References
    ----------
    .. [1] Kochhar 2010, Fig. 4.3; spec 003 §2.6 (2D distance of (sqrt(x^2+y^2), z) to the profile) [INFERRED].
    """

    def __init__(self, profile, *, radius: float = 1.0):
        self.profile = Polygon2D(profile)
        if np.any(self.profile.vertices[:, 0] < 0):
            raise ValueError("profile must lie in the half-plane rho >= 0 (first column)")
        self.radius = check_range("radius", radius, MIN_RADIUS, MAX_COORD)
        v = self.profile.vertices
        r = v[:, 0].max() + self.radius
        self.bbox = _check_box("Revolution", np.array([[-r, -r, v[:, 1].min() - self.radius],
                                                         [r, r, v[:, 1].max() + self.radius]]))

    def _eval_inside(self, p, backend):
        rz = np.column_stack([np.hypot(p[:, 0], p[:, 1]), p[:, 2]])
        d = np.maximum(0.0, self.profile.signed_distance(rz) + 0.5 * self.radius)
        return wyvill_from_sq(d**2 / self.radius**2)


def sweep(section, path_points, *, radius: float = 1.0, normal=None) -> Skin:
    """Sweep surface: one cross-section carried along a path (Fig. 4.1); a straight path gives an extrusion.

    Parameters
    ----------
    section : Polygon2D or Circle2D
        The cross-section curve.
    path_points : (M, 3) float64 array_like
        Path points.
    radius : float
        Wyvill radius of influence R.
    normal : (3,) array_like, optional
        Initial frame normal.

    Returns
    -------
    Skin
        A skinned surface with the same section at s = 0 and s = 1.
    """
    return Skin(SkinPath(path_points, normal=normal), [(0.0, section), (1.0, section)], radius=radius)

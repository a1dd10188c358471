"""Floret editor core: petals, corolla, key-pose blending, repolygonization, OBJ sequences (spec 002 §2; C1–C4).

Petals are clamped B-spline surfaces (cubic by default) over a control net ``ctrl[nu, nv, 3]`` with u across
the petal and v from base (0) to tip (1). A corolla replicates one petal n-fold about the floret axis (z),
optionally fusing the first m boundary control rows onto the inter-petal symmetry planes. Key poses are
blended intrinsically (rotation-minimizing frames, lerped lengths, slerped rotations; §2.2) and the surface
is sampled at one fixed set of (u, v) points (Eq. 2.1, odd rows, Delaunay in parameter space), so every
frame of the animation shares one face array.
"""
from __future__ import annotations

import os
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline
from scipy.spatial import Delaunay, QhullError, cKDTree
from scipy.spatial.transform import Rotation, Slerp

from plantvr._fileio import read_text
from plantvr._validation import MAX_COORD, check_array, check_int, check_range
from plantvr.params import Param, ParamTable
from plantvr.types import TriMesh

__all__ = [
    "FLORET",
    "GROWTH_KINDS",
    "POSE_KEYS",
    "POSE_NAMES",
    "Corolla",
    "FloretMesh",
    "blend_nets",
    "build_floret",
    "clamped_knots",
    "eval_surface",
    "fuse_rows",
    "growth_function",
    "make_bilateral",
    "petal_net",
    "polygonize_uv",
    "read_obj_sequence",
    "roll_margins",
]

#: Names of the three key poses; with two poses the middle one is not used.
POSE_NAMES = ("bud", "middle", "open")
#: Petal settings that differ between key poses (the topology settings are shared, spec 002 §2.2).
POSE_KEYS = ("length", "width", "opening_deg", "curl_deg", "roll_deg")
#: Time-warp growth functions: :func:`growth_function`'s two, and t**warp as knots ("power").
GROWTH_KINDS = ("linear", "sinusoidal", "power")

_WINDOWS = {"petal": ("Petal", "#e8a33d"), "corolla": ("Corolla", "#c0392b"), "poses": ("Key poses", "#8e44ad"),
            "growth": ("Growth", "#2e6fd0"), "mesh": ("Mesh", "#777777")}


def _row(name, kind, default, window, ref, doc, **kw) -> Param:
    return Param(name=name, kind=kind, default=default, window=window, ref=ref, doc=doc, **kw)


# one row per pose setting; each key pose gets a copy named "<pose>_<key>" (bud_length, ..., open_roll_deg)
_POSE_ROWS = {
    "length": {"kind": float, "unit": "", "range": (0.01, 5.0), "step": 0.01, "doc": "petal length"},
    "width": {"kind": float, "unit": "", "range": (0.01, 3.0), "step": 0.01, "doc": "petal width"},
    "opening_deg": {"kind": float, "unit": "deg", "range": (-90.0, 150.0), "step": 1.0,
                    "doc": "opening angle from the axis"},
    "curl_deg": {"kind": float, "unit": "deg", "range": (-180.0, 180.0), "step": 1.0, "doc": "curl along the petal"},
    "roll_deg": {"kind": float, "unit": "deg", "range": (0.0, 175.0), "step": 1.0, "doc": "roll of the margins"},
}
_POSE_DEFAULTS = ({"length": 0.35, "width": 0.07, "opening_deg": 6.0, "curl_deg": 0.0, "roll_deg": 0.0},
                  {"length": 0.6, "width": 0.25, "opening_deg": 25.0, "curl_deg": 10.0, "roll_deg": 0.0},
                  {"length": 0.8, "width": 0.42, "opening_deg": 55.0, "curl_deg": 25.0, "roll_deg": 0.0})

#: The floret editor's settings, declared once (spec 002 §2.1-§2.4): petal net, corolla, the three key poses,
#: development and polygonization, and the growth time a view shows.
FLORET = ParamTable("floret", (
    _row("nu", int, 5, "petal", "§2.1", "control points across a petal", range=(3, 15), step=1),
    _row("nv", int, 6, "petal", "§2.1", "control points along a petal (control rows)", range=(3, 15), step=1),
    _row("base_radius", float, 0.06, "petal", "§2.1", "distance of the petal base from the floret axis",
         range=(0.0, 0.5), step=0.005),
    _row("base_width", float, 0.3, "petal", "§2.1", "petal width at the base, as a fraction of its width",
         range=(0.0, 1.0), step=0.01),
    _row("n_fold", int, 5, "corolla", "§2.1", "petals replicated about the floret axis", range=(1, 12), step=1),
    _row("fused_rows", int, 3, "corolla", "§2.1", "control rows fused with the neighbouring petals",
         range=(0, 15), step=1),
    _row("weld", bool, True, "corolla", "§2.3", "weld coincident vertices (fused seams, shared base points)",
         range=(0, 1)),
    _row("weld_tol", float, 1e-9, "corolla", "§2.3", "welding distance, as a fraction of the floret size",
         range=(0.0, 0.05), step=1e-4),
    _row("n_poses", int, 2, "poses", "§2.2", "key poses: 2 (bud, open) or 3 (bud, middle, open)", range=(2, 3),
         step=1),
    *(_row(f"{pose}_{key}", window="poses", ref="§2.2", default=_POSE_DEFAULTS[i][key],
           **{**_POSE_ROWS[key], "doc": f"{pose} pose: {_POSE_ROWS[key]['doc']}"})
      for i, pose in enumerate(POSE_NAMES) for key in POSE_KEYS),
    _row("growth", str, "sinusoidal", "growth", "§2.2", "time-warp growth function", choices=GROWTH_KINDS),
    _row("warp", float, 2.0, "growth", "§2.2", "exponent of the 'power' growth function t**warp",
         range=(0.2, 5.0), step=0.05),
    _row("n_frames", int, 8, "growth", "§2.4", "frames of the animation", range=(2, 60), step=1),
    _row("time", float, 1.0, "growth", "§2.4", "growth time shown by views", range=(0.0, 1.0), step=0.01),
    _row("lam", float, 0.2, "mesh", "§2.3 Eq. 2.1", "lambda of Eq. 2.1: spacing between sample rows",
         range=(0.02, 1.0), step=0.005),
    _row("eta", float, 5.0, "mesh", "§2.3 Eq. 2.1", "eta: samples per row (rounded up to odd)", range=(1.0, 31.0),
         step=1.0),
), _WINDOWS)

#: Most frames of one OBJ sequence and largest OBJ / weight file a reader accepts (bytes).
MAX_OBJ_FRAMES = 100_000
MAX_OBJ_BYTES = 1 << 30


def clamped_knots(n_ctrl: int, degree: int) -> np.ndarray:
    """Clamped (open-uniform) knot vector on [0, 1] for ``n_ctrl`` control points."""
    inner = np.linspace(0, 1, n_ctrl - degree + 1)
    return np.concatenate([np.zeros(degree), inner, np.ones(degree)])


def eval_surface(ctrl: np.ndarray, u: np.ndarray, v: np.ndarray, *, degree: tuple[int, int] = (3, 3)
                 ) -> np.ndarray:
    """Evaluate a clamped B-spline surface at parameter points (spec 002 §2.1, V1).

    Parameters
    ----------
    ctrl : (nu, nv, 3) float64 array_like
        Control net.
    u, v : (N,) float64 array_like
        Parameters in [0, 1].
    degree : (int, int)
        Degrees in u and v (lowered to n_ctrl - 1 where the net is small).

    Returns
    -------
    (N, 3) float64 ndarray
    """
    ctrl = check_array("ctrl", ctrl, shape=(None, None, 3))
    nu, nv = ctrl.shape[:2]
    if nu < 2 or nv < 2:
        raise ValueError(f"ctrl must have at least 2 x 2 control points, got {nu} x {nv}")
    u = np.clip(check_array("u", u, shape=(None,)), 0, 1)
    v = np.clip(check_array("v", v, shape=(u.size,)), 0, 1)
    ku, kv = min(degree[0], nu - 1), min(degree[1], nv - 1)
    Bu = BSpline.design_matrix(u, clamped_knots(nu, ku), ku).toarray()
    Bv = BSpline.design_matrix(v, clamped_knots(nv, kv), kv).toarray()
    return np.einsum("ni,nj,ijk->nk", Bu, Bv, ctrl)


def petal_net(*, length: float = 1.0, width: float = 0.3, opening_deg: float = 45.0, curl_deg: float = 0.0,
              nu: int = 5, nv: int = 6, base_radius: float = 0.05, base_width: float = 0.3,
              roll_deg: float = 0.0) -> np.ndarray:
    """A bilaterally symmetric petal control net in floret coordinates (petal 0 along +x, axis +z).

    The midrib starts at ``base_radius`` from the axis and leaves it at ``opening_deg`` from the floret
    axis, bending by ``curl_deg`` in total towards the tip. Width follows a rounded profile; ``roll_deg``
    rolls the margins toward the upper side (:func:`roll_margins`).
    """
    length = check_range("length", length, 0.0, 1e6, low_open=True)
    width = check_range("width", width, 0.0, 1e6, low_open=True)
    opening_deg = check_range("opening_deg", opening_deg, -180.0, 180.0)
    curl_deg = check_range("curl_deg", curl_deg, -360.0, 360.0)
    nu = check_int("nu", nu, 3, 64)
    nv = check_int("nv", nv, 3, 64)
    base_radius = check_range("base_radius", base_radius, 0.0, 1e6)
    base_width = check_range("base_width", base_width, 0.0, 1.0)
    roll_deg = check_range("roll_deg", roll_deg, 0.0, 175.0)
    t = np.linspace(0, 1, nv)
    mid = midrib(length, opening_deg, curl_deg, nv, base_radius)
    prof = width * (base_width + (1 - base_width) * np.sin(np.pi * np.clip(0.15 + 0.85 * t, 0, 1)) ** 0.8)
    s = np.linspace(-1, 1, nu)
    ctrl = np.repeat(mid[None], nu, axis=0)
    ctrl[:, :, 1] = s[:, None] * prof[None, :] / 2
    return roll_margins(ctrl, roll_deg) if roll_deg > 0 else make_bilateral(ctrl)


def midrib(length: float, opening_deg: float, curl_deg: float, nv: int, base_radius: float) -> np.ndarray:
    """(nv, 3) midrib of a petal in the x-z plane: ``nv`` equal steps of total ``length`` from (base_radius, 0, 0),
    leaning ``opening_deg`` from the floret axis (+z) at the base and ``curl_deg`` more at the tip (linear in
    arc length, midpoint angle per step). Inputs are checked by the callers."""
    ang = np.deg2rad(opening_deg + curl_deg * np.linspace(0, 1, nv))
    a = 0.5 * (ang[:-1] + ang[1:])
    steps = np.zeros((nv, 3))
    steps[0, 0] = base_radius
    steps[1:, 0] = length / (nv - 1) * np.sin(a)
    steps[1:, 2] = length / (nv - 1) * np.cos(a)
    return np.cumsum(steps, axis=0)                             # sequential sums, as stepping along the rib


def roll_margins(ctrl: np.ndarray, roll_deg: float | np.ndarray) -> np.ndarray:
    """Roll a petal net's margins toward its upper (adaxial) side: a cupped, incurved petal (spec 002 §2.1).

    Each v-row of a net built along +x (midrib = middle u-column in the x-z plane, width along y) is bent
    onto a circular arc about the midrib whose half-width subtends ``roll_deg``; the arc length across the
    row is kept, so a roll changes the petal's shape, not its width. The result is made bilateral.

    Parameters
    ----------
    ctrl : (nu, nv, 3) float64 array_like
        Petal net (as :func:`petal_net` builds it).
    roll_deg : float or (nv,) float64 array_like
        Roll half-angle per row in degrees, in [0, 175].

    Returns
    -------
    (nu, nv, 3) float64 ndarray
    """
    ctrl = check_array("ctrl", ctrl, shape=(None, None, 3)).copy()
    nu, nv = ctrl.shape[:2]
    if nu < 2 or nv < 2:
        raise ValueError(f"ctrl must have at least 2 x 2 control points, got {nu} x {nv}")
    roll = np.asarray(roll_deg, dtype=np.float64)
    if roll.ndim == 0:
        roll = np.full(nv, float(check_range("roll_deg", roll, 0.0, 175.0)))
    roll = check_array("roll_deg", roll, shape=(nv,))
    if np.any((roll < 0) | (roll > 175)):
        raise ValueError(f"roll_deg must be in [0, 175] on every row, got {roll.tolist()!r}")
    roll = np.deg2rad(roll)
    mid = ctrl[nu // 2].copy()
    for j in range(nv):
        t = mid[min(j + 1, nv - 1)] - mid[max(j - 1, 0)]
        n = np.linalg.norm(t)
        if n < 1e-15:
            continue
        adaxial = np.cross(t / n, [0.0, 1.0, 0.0])           # toward the floret axis for an opening petal
        y = ctrl[:, j, 1]
        hw = np.abs(y).max()
        if hw < 1e-12 or roll[j] < 1e-9:
            continue
        R = hw / roll[j]
        phi = y / R
        ctrl[:, j, 1] = R * np.sin(phi)
        ctrl[:, j] += (R * (1.0 - np.cos(phi)))[:, None] * adaxial
    return make_bilateral(ctrl)


def make_bilateral(ctrl: np.ndarray) -> np.ndarray:
    """Impose bilateral symmetry about the plane y = 0: ctrl[nu-1-i] = mirror(ctrl[i]) (spec 002 §2.1)."""
    ctrl = check_array("ctrl", ctrl, shape=(None, None, 3)).copy()
    mir = ctrl[::-1] * np.array([1.0, -1.0, 1.0])
    out = 0.5 * (ctrl + mir)
    if ctrl.shape[0] % 2 == 1:
        out[ctrl.shape[0] // 2, :, 1] = 0.0
    return out


def fuse_rows(ctrl: np.ndarray, n_fold: int, m: int) -> np.ndarray:
    """Constrain the boundary control points of the first ``m`` rows to the inter-petal planes (C1, V3).

    The u = nu-1 boundary goes onto the half-plane at +pi/n, the u = 0 boundary onto -pi/n.
    """
    ctrl = check_array("ctrl", ctrl, shape=(None, None, 3)).copy()
    n_fold = check_int("n_fold", n_fold, 2, 1000)
    m = check_int("m", m, 0, ctrl.shape[1])
    for col, sgn in ((ctrl.shape[0] - 1, 1.0), (0, -1.0)):
        phi = sgn * np.pi / n_fold
        d = np.array([np.cos(phi), np.sin(phi), 0.0])            # in-plane radial direction
        pts = ctrl[col, :m]
        radial = np.maximum(pts @ d, 0.0)
        ctrl[col, :m] = radial[:, None] * d + pts[:, 2:3] * np.array([0.0, 0.0, 1.0])
    return ctrl


# -------------------------------------------------------------------------------------------------------
# Intrinsic blending (spec 002 §2.2)


def _min_rot(a, b):
    ax = np.cross(a, b)
    s = np.linalg.norm(ax)
    ang = np.arctan2(s, a.dot(b))
    if s < 1e-15:
        return Rotation.identity()
    return Rotation.from_rotvec(ax / s * ang)


def _encode(P, ref):
    d = np.diff(P, axis=0)
    L = np.linalg.norm(d, axis=1)
    t = d[0] / L[0]
    n = ref - ref.dot(t) * t
    if np.linalg.norm(n) < 1e-9:
        n = np.array([1.0, 0, 0]) - t[0] * t
    n /= np.linalg.norm(n)
    F = Rotation.from_matrix(np.column_stack([t, n, np.cross(t, n)]))
    F0 = F
    rs = []
    for i in range(1, len(d)):
        R = _min_rot(d[i - 1] / L[i - 1], d[i] / L[i])
        rs.append(F.inv() * R * F)
        F = R * F
    return P[0], F0, L, rs


def _decode(base, F0, L, rs):
    P = [base]
    F = F0
    P.append(base + L[0] * F.apply([1.0, 0, 0]))
    for i, r in enumerate(rs):
        F = F * r
        P.append(P[-1] + L[i + 1] * F.apply([1.0, 0, 0]))
    return np.array(P)


def _slerp(ra, rb, t):
    return Slerp([0.0, 1.0], Rotation.concatenate([ra, rb]))([t])[0]


def blend_nets(poses: list[np.ndarray], t: float, *, ref=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Intrinsic blend of 2 or 3 key-pose control nets at time t in [0, 1] (spec 002 §2.2, C2, V4).

    Each v-polyline is encoded by its base point, a rotation-minimizing first frame, segment lengths
    and relative rotations; lengths are lerped and rotations slerped. With 3 poses, [0, 1/2] blends
    poses 0-1 and [1/2, 1] poses 1-2.

    Raises
    ------
    ValueError
        If the poses do not share one control-net topology.
    """
    if not 2 <= len(poses) <= 3:
        raise ValueError(f"poses must hold 2 or 3 key poses, got {len(poses)}")
    nets = [check_array(f"poses[{i}]", p, shape=(None, None, 3)) for i, p in enumerate(poses)]
    if any(n.shape != nets[0].shape for n in nets):
        raise ValueError("key poses must have the same control-net topology, got shapes "
                         f"{[n.shape for n in nets]}")
    t = check_range("t", t, 0.0, 1.0)
    if len(nets) == 3:
        A, B, t = (nets[0], nets[1], 2 * t) if t <= 0.5 else (nets[1], nets[2], 2 * t - 1)
    else:
        A, B = nets
    if t == 0.0:
        return A.copy()
    if t == 1.0:
        return B.copy()
    ref = np.asarray(ref, dtype=np.float64)
    out = np.empty_like(A)
    for i in range(A.shape[0]):
        ba, Fa, La, ra = _encode(A[i], ref)
        bb, Fb, Lb, rb = _encode(B[i], ref)
        out[i] = _decode((1 - t) * ba + t * bb, _slerp(Fa, Fb, t), (1 - t) * La + t * Lb,
                         [_slerp(x, y, t) for x, y in zip(ra, rb)])
    return out


def growth_function(kind: str | np.ndarray = "linear") -> Callable[[np.ndarray], np.ndarray]:
    """Time-warp growth function [0,1] -> [0,1] (T Ch. 8 b): "linear", "sinusoidal" or (K, 2) knots."""
    if isinstance(kind, str):
        if kind == "linear":
            return lambda t: np.clip(np.asarray(t, dtype=np.float64), 0, 1)
        if kind == "sinusoidal":
            return lambda t: 0.5 * (1 - np.cos(np.pi * np.clip(np.asarray(t, dtype=np.float64), 0, 1)))
        raise ValueError(f"kind must be one of ['linear', 'sinusoidal'] or (K, 2) knots, got {kind!r}")
    k = check_array("kind", kind, shape=(None, 2), min_rows=2)
    if np.any(np.diff(k[:, 0]) <= 0) or np.any(np.diff(k[:, 1]) < 0):
        raise ValueError("growth knots must have increasing x and non-decreasing y")
    return lambda t: np.interp(t, k[:, 0], k[:, 1])


# -------------------------------------------------------------------------------------------------------
# Polygonization (spec 002 §2.3)


#: Sample rows and samples in all that one petal's Eq. 2.1 polygonization may take (issue 20).
MAX_UV_ROWS = 100_000
MAX_UV_SAMPLES = 2_000_000


def polygonize_uv(lam: float | Callable = 0.2, eta: float | Callable = 5, *, grid: int = 4001
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Parameter-space samples and one fixed triangulation (Eq. 2.1, odd rows, Delaunay; C3, V5–V6).

    Parameters
    ----------
    lam : float or callable v -> spacing
        lambda(v) of Eq. 2.1 (positive).
    eta : float or callable v -> count
        eta(v); each row v_i gets ceil(eta(v_i)) samples, rounded up to odd.

    Returns
    -------
    uv : (N, 2) float64 ndarray
    faces : (F, 3) int64 ndarray
        Counter-clockwise in (u, v).
    v_rows : (n+1,) float64 ndarray
        Row parameters v_i (v_0 = 0, v_n = 1).
    """
    vg = np.linspace(0, 1, grid)
    lv = np.full(grid, check_range("lam", lam, 0, 1e6, low_open=True)) if np.isscalar(lam) else \
        np.asarray(lam(vg), dtype=np.float64)
    if lv.shape != vg.shape or np.any(~np.isfinite(lv)) or np.any(lv <= 0):
        raise ValueError("lam(v) must be finite and > 0 on [0, 1]")
    inv = 1 / lv
    G = np.concatenate([[0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(vg))])
    if not G[-1] <= MAX_UV_ROWS:                                   # Eq. 2.1 row count, before allocating
        raise ValueError(f"lam must give at most {MAX_UV_ROWS} sample rows (Eq. 2.1), got {float(G[-1]):.3g}")
    n = max(1, round(float(G[-1])))
    v_rows = np.interp(np.arange(n + 1) * G[-1] / n, G, vg)      # rescaled so v_n = 1 exactly
    v_rows[-1] = 1.0
    et = (np.full(n + 1, float(eta)) if np.isscalar(eta) else np.asarray(eta(v_rows), dtype=np.float64))
    if np.any(~np.isfinite(et)) or np.any(et < 1):
        raise ValueError("eta(v) must be finite and >= 1 on [0, 1]")
    if float(np.sum(np.minimum(et, 1e12))) > MAX_UV_SAMPLES:
        raise ValueError(f"eta must give at most {MAX_UV_SAMPLES} samples in all, "
                         f"got {float(np.sum(et)):.3g}")
    m = np.ceil(et - 1e-12).astype(int)
    m += (m % 2 == 0)                                              # odd: a vertex on u = 1/2
    uv = []
    for vi, mi in zip(v_rows, m):
        u = np.array([0.5]) if mi == 1 else np.linspace(0, 1, mi)
        uv.append(np.column_stack([u, np.full(mi, vi)]))
    uv = np.concatenate(uv)
    if np.all(m == 1):  # one sample per row: the samples lie on u = 1/2 and span no surface
        raise ValueError(f"eta must give more than one sample on some row (eta(v) > 1), got {float(et.max()):.3g}")
    try:
        tri = Delaunay(uv).simplices.astype(np.int64)
    except QhullError as exc:
        raise ValueError(f"lam and eta give samples that span no surface ({str(exc).splitlines()[0]})") from None
    a, b, c = uv[tri[:, 0]], uv[tri[:, 1]], uv[tri[:, 2]]
    cr = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri = tri[np.abs(cr) > 1e-14]
    cr = cr[np.abs(cr) > 1e-14]
    tri[cr < 0] = tri[cr < 0][:, [0, 2, 1]]
    return uv, tri, v_rows


# -------------------------------------------------------------------------------------------------------
# Floret meshes and animation


@dataclass
class Corolla:
    """One key pose of an n-fold corolla: a petal control net, fold count and fused rows (C1)."""

    petal: np.ndarray
    n_fold: int = 5
    fused_rows: int = 0

    def net(self) -> np.ndarray:
        """The petal net with fusion applied."""
        return fuse_rows(self.petal, self.n_fold, self.fused_rows) if self.fused_rows else self.petal


@dataclass(eq=False)
class FloretMesh(TriMesh):
    """A floret animation: one face array, K frames of vertices, the attachment vertices (spec 002 §2.4).

    As a :class:`~plantvr.types.TriMesh` its ``vertices`` are the open floret, the last frame.
    """

    frames: np.ndarray       # (K, V, 3) float64
    fixed: np.ndarray        # (A,) int64 attachment vertices (base row)

    def frame_at(self, t: float) -> np.ndarray:
        """(V, 3) float64 vertices at growth time ``t`` in [0, 1] (0 the first frame, 1 the last), linear
        between frames."""
        t = check_range("t", t, 0.0, 1.0)
        K = self.frames.shape[0]
        x = t * (K - 1)
        i = min(int(np.floor(x)), K - 2) if K > 1 else 0
        f = x - i if K > 1 else 0.0
        return (1.0 - f) * self.frames[i] + f * self.frames[min(i + 1, K - 1)]


def build_floret(poses: list[Corolla], *, n_frames: int = 10, growth: str | np.ndarray = "linear",
                 lam: float | Callable = 0.2, eta: float | Callable = 5, weld_tol: float = 1e-9,
                 weld: bool = True) -> FloretMesh:
    """Sample a floret's development as frames with one fixed topology (spec 002 §2.2–§2.4).

    Vertices closer than ``weld_tol`` times the floret's size in the first frame (fused seams, the shared
    base points of the petals) are welded into one; ``weld=False`` keeps every petal a separate sheet.

    Raises
    ------
    ValueError
        If the key poses differ in control-net shape, fold count or fused rows (mismatched topology).
    """
    if not 2 <= len(poses) <= 3:
        raise ValueError(f"poses must hold 2 or 3 key poses, got {len(poses)}")
    p0 = poses[0]
    for i, p in enumerate(poses):
        if np.shape(p.petal) != np.shape(p0.petal) or p.n_fold != p0.n_fold or p.fused_rows != p0.fused_rows:
            raise ValueError(f"key pose {i} has a different topology (control net {np.shape(p.petal)}, "
                             f"n_fold {p.n_fold}, fused rows {p.fused_rows}) from pose 0 "
                             f"({np.shape(p0.petal)}, {p0.n_fold}, {p0.fused_rows})")
    n_frames = check_int("n_frames", n_frames, 2, 100_000)
    weld_tol = check_range("weld_tol", weld_tol, 0.0, 1.0)
    gf = growth_function(growth)
    uv, tri, _ = polygonize_uv(lam, eta)
    nets = [p.net() for p in poses]
    n = p0.n_fold
    frames_raw = []
    for k in range(n_frames):
        net = blend_nets(nets, float(gf(k / (n_frames - 1))))
        if p0.fused_rows:
            net = fuse_rows(net, n, p0.fused_rows)
        pet = eval_surface(net, uv[:, 0], uv[:, 1])
        allp = [Rotation.from_euler("z", 2 * np.pi * j / n).apply(pet) for j in range(n)]
        frames_raw.append(np.concatenate(allp))
    faces_raw = np.concatenate([tri + j * len(uv) for j in range(n)])
    # weld coincident vertices (fused seams, shared base points), found on the first frame
    X = frames_raw[0]
    scale = float(np.ptp(X, axis=0).max()) or 1.0
    pairs = cKDTree(X).query_pairs(weld_tol * scale, output_type="ndarray") if weld else np.zeros((0, 2), int)
    rep = np.arange(len(X))
    for a, b in sorted(map(tuple, np.sort(pairs, axis=1))):
        ra, rb = rep[a], rep[b]
        while rep[ra] != ra:
            ra = rep[ra]
        while rep[rb] != rb:
            rb = rep[rb]
        if ra != rb:
            rep[max(ra, rb)] = min(ra, rb)
    for i in range(len(rep)):
        while rep[rep[i]] != rep[i]:
            rep[i] = rep[rep[i]]
    keep, new_id = np.unique(rep, return_inverse=True)
    faces = new_id[faces_raw]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    frames = np.stack([f[keep] for f in frames_raw])
    base = np.flatnonzero(np.isin(np.arange(len(X)), np.flatnonzero(np.tile(uv[:, 1] == 0, n))))
    fixed = np.unique(new_id[base])
    return FloretMesh(vertices=frames[-1], faces=faces.astype(np.int64), frames=frames, fixed=fixed.astype(np.int64))


def read_obj_sequence(folder: str, *, prefix: str = "frame") -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Read an OBJ sequence sorted by the numeric suffix; all frames must share faces (spec 002 §2.4, V8).

    Returns
    -------
    faces : (F, 3) int64 ndarray
    frames : (K, V, 3) float64 ndarray
    fixed : (A,) int64 ndarray or None
        From ``weight.txt`` if present.

    Raises
    ------
    ValueError
        Naming the file and line: a missing folder, a non-number, a non-finite or huge coordinate, a face
        index outside the frame's vertices, frames of different topology, a file larger than the cap.
    """
    if not isinstance(prefix, str):
        raise ValueError(f"prefix must be a str, got {type(prefix).__name__}")
    try:
        names = os.listdir(folder)
    except (OSError, TypeError) as exc:
        raise ValueError(f"cannot list OBJ folder {folder!r}: {exc}") from None
    pat = re.compile(re.escape(prefix) + r"_?(\d+)\.obj$")
    files = sorted((int(m.group(1)), f) for f in names if (m := pat.search(f)))
    if not files:
        raise ValueError(f"no '{prefix}_<n>.obj' files in {folder!r}")
    if len(files) > MAX_OBJ_FRAMES:
        raise ValueError(f"{folder!r} holds {len(files)} frames, more than the {MAX_OBJ_FRAMES} allowed")
    if len({k for k, _ in files}) != len(files):
        raise ValueError(f"{folder!r}: two OBJ files share a frame number")
    faces0, frames = None, []
    for _, f in files:
        vs, fs = [], []
        text = _read_obj_text(os.path.join(folder, f))
        for lineno, line in enumerate(text.splitlines(), 1):
            try:
                if line.startswith("v "):
                    v = [float(t) for t in line.split()[1:4]]
                    if len(v) != 3:
                        raise ValueError("a vertex needs 3 coordinates")
                    vs.append(v)
                elif line.startswith("f "):
                    face = [int(t.split("/")[0]) - 1 for t in line.split()[1:4]]
                    if len(face) != 3:
                        raise ValueError("a face needs 3 vertex indices")
                    fs.append(face)
            except ValueError as exc:
                raise ValueError(f"{f} line {lineno}: {exc} in {line[:80]!r}") from None
        X = np.array(vs, dtype=np.float64).reshape(-1, 3)
        if not np.all(np.isfinite(X)) or (X.size and np.abs(X).max() > MAX_COORD):
            raise ValueError(f"{f}: vertex coordinates must be finite and inside +-{MAX_COORD:g}")
        fs = np.array(fs, np.int64).reshape(-1, 3)
        if fs.size and (fs.min() < 0 or fs.max() >= len(X)):
            raise ValueError(f"{f}: face indices must be in [1, {len(X)}], got range [{fs.min() + 1}, "
                             f"{fs.max() + 1}]")
        if faces0 is None:
            faces0 = fs
        elif fs.shape != faces0.shape or np.any(fs != faces0):
            raise ValueError(f"frame {f!r} has a different topology from the first frame")
        frames.append(X)
    if len({len(v) for v in frames}) != 1:
        raise ValueError("OBJ frames have different vertex counts")
    wpath = os.path.join(folder, "weight.txt")
    fixed = None
    if os.path.exists(wpath):
        tokens = _read_obj_text(wpath).split()
        try:
            fixed = np.array([int(t) for t in tokens], dtype=np.int64)
        except (ValueError, OverflowError):
            raise ValueError(f"weight.txt: expected one vertex index per line in {folder!r}") from None
        if fixed.size and (fixed.min() < 0 or fixed.max() >= len(frames[0])):
            raise ValueError(f"weight.txt: vertex indices must be in [0, {len(frames[0]) - 1}], got range "
                             f"[{fixed.min()}, {fixed.max()}]")
    return faces0, np.stack(frames), fixed


def _read_obj_text(path: str) -> str:
    return read_text(path, what="floret file", max_bytes=MAX_OBJ_BYTES)

"""Headset gestures as geometry: the scene placement, grip translation with momentum, the two-grip handle bar, the
brush-radius thumb circle, the 7-item menu, parameter windows and the colour wheel (spec 000_treewand §4.1–4.6,
000_vine §2.1–2.4). Pure functions and small state machines on numpy arrays; :mod:`plantvr.vr.controls` binds
them to document commands.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np

from .._validation import check_array, check_int, check_range
from ..params import TREEWAND
from ..vine.colors import slice_at
from .math3d import quat_conj, quat_from_axis_angle, quat_mul, quat_to_matrix

__all__ = [
    "MENU_ITEMS",
    "WINDOW_COLORS",
    "BrushGesture",
    "OneGripTranslate",
    "SceneTransform",
    "handlebar_step",
    "menu_item_at",
    "place_window",
    "ray_hits_window",
    "smoothed_velocity",
    "wheel_label",
]

TRIGGER_PREVIEW = 0.1   # [INFERRED] 000_vine §2.4.1: show the brush from ~0.1
TRIGGER_FULL = 0.99     # [INFERRED] paint / prune on the trigger click (>= ~0.99)
MOMENTUM_N = 5          # Eq. 5.2
MOMENTUM_A = 0.98       # Eq. 5.3, per 90-fps frame
MOMENTUM_EPS = 1e-4     # m/s: momentum stops below this [INFERRED]
PAD_DEAD_ZONE = 0.25    # thumb closer to the pad centre gives no reliable angle [INFERRED]
WINDOW_DISTANCE = 1.0   # m, §4.6
WINDOW_SIZE = (0.6, 0.4)  # m (width, height) of a parameter window [INFERRED]
RADIUS_RANGE = TREEWAND["brush_radius"].range
STAMP_SPACING = 0.1     # a stroke adds a stamp once the tip moved this fraction of the radius [INFERRED]

#: The 7 menu functions, counter-clockwise from the green icon (§4.5).
MENU_ITEMS = ("appearance", "tree_form", "light", "prune_mode", "save", "load", "new_tree")
#: Window colour == its menu button colour (§4.5 [INFERRED] mapping in figure order).
WINDOW_COLORS = {"appearance": "#2ecc40", "tree_form": "#e03030", "light": "#3060e0"}


# -- view manipulation ---------------------------------------------------------------------------------
class SceneTransform:
    """Similarity placing the model in the room: ``x_room = s R x_model + t`` (000_vine §2.1).

    Parameters
    ----------
    scale : float
        Model units to metres.
    translation : (3,) array_like
        Room position of the model origin, metres.
    """

    def __init__(self, scale: float = 0.25, translation=(0.0, 0.0, -1.0)):
        self.scale = check_range("scale", scale, 0.0, 1e6, low_open=True)
        self.rotation = np.eye(3)
        self.translation = check_array("translation", translation, shape=(3,)).astype(float)

    @property
    def matrix(self) -> np.ndarray:
        """(4, 4) model-to-room matrix."""
        out = np.eye(4)
        out[:3, :3] = self.scale * self.rotation
        out[:3, 3] = self.translation
        return out

    def to_model(self, p: np.ndarray) -> np.ndarray:
        """Room point to model space, :math:`C_m = R^{-1}(C - P)/s` (000_vine §2.4.3)."""
        return self.rotation.T @ (np.asarray(p, float) - self.translation) / self.scale

    def translate(self, d: np.ndarray) -> None:
        """Move the model by ``d`` metres."""
        self.translation = self.translation + np.asarray(d, float)

    def handlebar(self, k: float, q: np.ndarray, m0: np.ndarray, m1: np.ndarray) -> None:
        """Apply ``x' = M1 + k Q (x - M0)`` to the whole placement (000_vine §2.1.5)."""
        rq = quat_to_matrix(q)
        self.scale = float(np.clip(self.scale * k, 1e-4, 1e4))
        self.rotation = rq @ self.rotation
        u, _, vt = np.linalg.svd(self.rotation)  # keep R orthonormal over many frames
        self.rotation = u @ vt
        self.translation = m1 + k * rq @ (self.translation - m0)


def smoothed_velocity(positions, times, n: int = MOMENTUM_N) -> np.ndarray:
    r"""Release velocity :math:`\bar v_i = (X_i - X_{i-N}) / (t_i - t_{i-N})` (Eq. 5.2, N = 5).

    Parameters
    ----------
    positions : (K, 3) array_like
        Recent controller positions, oldest first, metres.
    times : (K,) array_like
        Their times, seconds.
    n : int
        Smoothing window N; fewer samples use what there is.

    Returns
    -------
    (3,) float64 ndarray
        Velocity, m/s (zero with fewer than two samples).

    References
    ----------
    .. [1] ViNE thesis §5.1.2, Eq. 5.2 (spec 000_vine §2.1.2); with a constant Δt this is
       :math:`(X_i - X_{i-N})/(N\Delta t)`.
    """
    x = np.asarray(positions, float)
    t = np.asarray(times, float)
    if len(x) < 2:
        return np.zeros(3)
    j = max(len(x) - 1 - n, 0)
    dt = t[-1] - t[j]
    return (x[-1] - x[j]) / dt if dt > 0 else np.zeros(3)


class OneGripTranslate:
    """One-grip translation with smoothed momentum (000_vine §2.1.2, Eqs. 5.1–5.3)."""

    def __init__(self, n: int = MOMENTUM_N, a: float = MOMENTUM_A):
        self.n, self.a = n, a
        self.history: deque = deque(maxlen=n + 1)
        self.velocity = np.zeros(3)

    def grab(self, position: np.ndarray, t: float) -> None:
        """Start (or restart) a grab: cancels momentum, clears the history."""
        self.history.clear()
        self.history.append((np.asarray(position, float).copy(), float(t)))
        self.velocity = np.zeros(3)

    def move(self, position: np.ndarray, t: float) -> np.ndarray:
        """Controller moved while gripped: returns ΔP = X_i − X_{i−1} to add to the model position."""
        p = np.asarray(position, float).copy()
        d = p - self.history[-1][0] if self.history else np.zeros(3)
        self.history.append((p, float(t)))
        return d

    def release(self) -> np.ndarray:
        """Grip released: momentum starts with the smoothed velocity (Eq. 5.2); returns it."""
        if self.history:
            xs, ts = zip(*self.history)
            self.velocity = smoothed_velocity(xs, ts, self.n)
        self.history.clear()
        return self.velocity

    def coast(self, dt: float) -> np.ndarray:
        """One free frame: move by v Δt, then decay v ← a^(90 Δt) v (Eq. 5.3, 90-fps-equivalent)."""
        if not np.any(self.velocity):
            return np.zeros(3)
        d = self.velocity * dt
        self.velocity = self.velocity * self.a ** (dt * 90.0)
        if np.linalg.norm(self.velocity) < MOMENTUM_EPS:
            self.velocity = np.zeros(3)
        return d


def handlebar_step(l0, r0, ql0, qr0, l1, r1, ql1, qr1) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    r"""One two-grip handle-bar frame: scale ratio, rotation and the two bar midpoints.

    Parameters
    ----------
    l0, r0, l1, r1 : (3,) array_like
        Left and right controller positions at frames i−1 and i.
    ql0, qr0, ql1, qr1 : (4,) array_like
        Their (w, x, y, z) orientations.

    Returns
    -------
    k : float
        :math:`\|LR_i\| / \|LR_{i-1}\|` (scale change).
    q : (4,) ndarray
        :math:`Q = \Delta q'_{pitch} \otimes q_{yr}`.
    m0, m1 : (3,) ndarray
        Bar midpoints at i−1 and i; the model point update is :math:`x' = M_1 + k Q (x - M_0)`.

    References
    ----------
    .. [1] ViNE thesis §5.1.3, Eqs. 5.4–5.7, spec 000_vine §2.1.3–2.1.5. ERRATUM (000_vine App. A.2):
       the yaw/roll axis is :math:`LR_{i-1} \times LR_i` so the model turns with the hands; ERRATUM A.3:
       the averaged rotation is the pitch; the half-angles :math:`w\theta` of both hands are averaged.
    """
    l0, r0, l1, r1 = (np.asarray(v, float) for v in (l0, r0, l1, r1))
    lr0, lr1 = r0 - l0, r1 - l1
    n0, n1 = np.linalg.norm(lr0), np.linalg.norm(lr1)
    m0, m1 = 0.5 * (l0 + r0), 0.5 * (l1 + r1)
    if n0 < 1e-9 or n1 < 1e-9:
        return 1.0, np.array([1.0, 0, 0, 0]), m0, m1
    # ERRATUM 000_vine A.2: axis LR_{i-1} x LR_i (Eq. 5.4 printed the reverse)
    axis = np.cross(lr0, lr1)
    theta = math.acos(float(np.clip(lr0 @ lr1 / (n0 * n1), -1.0, 1.0)))   # Eq. 5.5
    q_yr = quat_from_axis_angle(axis, theta) if np.linalg.norm(axis) > 1e-12 else np.array([1.0, 0, 0, 0])
    bar = lr1 / n1
    half = []
    for q0, q1 in ((ql0, ql1), (qr0, qr1)):
        dq = quat_mul(np.asarray(q1, float), quat_conj(np.asarray(q0, float)))   # Eq. 5.6
        if dq[0] < 0:
            dq = -dq   # shortest arc
        r = dq[1:]
        nr = np.linalg.norm(r)
        if nr < 1e-12:
            half.append(0.0)
            continue
        w = float(r @ bar) / nr                                                      # Eq. 5.7
        half.append(w * math.acos(float(np.clip(dq[0], -1.0, 1.0))))
    phi = 0.5 * (half[0] + half[1])   # ERRATUM A.3: average pitch of both hands
    q_pitch = np.array([math.cos(phi), *(math.sin(phi) * bar)])
    return n1 / n0, quat_mul(q_pitch, q_yr), m0, m1


# -- brush radius gesture -------------------------------------------------------------------------------
class BrushGesture:
    r"""Thumb circles on the trackpad scale the brush: :math:`R \leftarrow R\,2^{-\Delta\phi/2\pi}`.

    φ is the thumb angle, counter-clockwise positive (pad y up), so one clockwise circle doubles R and one
    counter-clockwise circle halves it; R is clamped to ``bounds`` (default: the ``brush_radius`` parameter range).

    References
    ----------
    .. [1] Tree Wand thesis §11.1 / ViNE §5.4.1; continuous form [INFERRED] spec 000_vine §2.4.1 (the
       000_treewand §4.3 form writes Δφ clockwise-positive: the same rule).
    """

    def __init__(self) -> None:
        self._last: float | None = None

    def update(self, pad: tuple[float, float], touched: bool, radius: float,
               bounds: tuple[float, float] = RADIUS_RANGE) -> float:
        """Return the new radius for this frame's thumb position."""
        x, y = float(pad[0]), float(pad[1])
        if not touched or math.hypot(x, y) < PAD_DEAD_ZONE:
            self._last = None
            return radius
        phi = math.atan2(y, x)
        if self._last is None:
            self._last = phi
            return radius
        d = (phi - self._last + math.pi) % (2 * math.pi) - math.pi
        self._last = phi
        return float(np.clip(radius * 2.0 ** (-d / (2 * math.pi)), *bounds))


# -- menu and windows -----------------------------------------------------------------------------------
def menu_item_at(pad: tuple[float, float]) -> int | None:
    """Menu wedge (0-based index into :data:`MENU_ITEMS`) under the thumb, ``None`` in the dead zone.

    Item 1 (green, Appearance) is centred at the top of the pad; the others follow counter-clockwise
    (§4.5), each wedge 360/7 degrees wide.
    """
    x, y = float(pad[0]), float(pad[1])
    if math.hypot(x, y) < PAD_DEAD_ZONE:
        return None
    k = len(MENU_ITEMS)
    a = (math.atan2(y, x) - math.pi / 2) % (2 * math.pi)
    return int(math.floor(a / (2 * math.pi / k) + 0.5)) % k


def place_window(controller_pose: np.ndarray, distance: float = WINDOW_DISTANCE) -> np.ndarray:
    """Pose of a window opened from a controller (§4.6).

    The window centre is ``distance`` metres ahead along the controller heading; its normal faces the
    controller as much as possible while its up vector stays +y.

    Returns
    -------
    (4, 4) float64 ndarray
        Window-to-room transform: columns x (right), y (up), z (normal, towards the controller), centre.
    """
    pose = check_array("controller_pose", controller_pose, shape=(4, 4))
    heading = -pose[:3, 2]
    centre = pose[:3, 3] + distance * heading
    normal = pose[:3, 3] - centre
    normal[1] = 0.0   # keep up = +y: turn only about the vertical
    if np.linalg.norm(normal) < 1e-9:
        normal = np.array([0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal)
    up = np.array([0.0, 1.0, 0.0])
    right = np.cross(up, normal)
    out = np.eye(4)
    out[:3, 0], out[:3, 1], out[:3, 2], out[:3, 3] = right, up, normal, centre
    return out


def ray_hits_window(origin, direction, window_pose, size=WINDOW_SIZE) -> tuple[float, float] | None:
    """Where the pointing ray meets a window, as (u, v) in [0, 1]² from its lower-left corner, or ``None``."""
    o, d = np.asarray(origin, float), np.asarray(direction, float)
    c, right, up, normal = window_pose[:3, 3], window_pose[:3, 0], window_pose[:3, 1], window_pose[:3, 2]
    den = d @ normal
    if abs(den) < 1e-9:
        return None
    t = ((c - o) @ normal) / den
    if t <= 0:
        return None
    p = o + t * d - c
    u, v = p @ right / size[0] + 0.5, p @ up / size[1] + 0.5
    return (float(u), float(v)) if 0 <= u <= 1 and 0 <= v <= 1 else None


# -- colour wheel (ViNE) ----------------------------------------------------------------------------------
def wheel_label(pad: tuple[float, float], n_labels: int, last: int = 0) -> int:
    """Label under the thumb on the left-pad colour wheel.

    ``k = floor((atan2(y, x) mod 2π) / (2π / K))`` with K = ``n_labels`` slices counter-clockwise from +x
    (slice k is colour-table entry k, 0 = unpainted); within :data:`plantvr.vine.colors.DEAD_ZONE` of the centre the
    ``last`` label is kept: :func:`plantvr.vine.colors.slice_at` of the thumb position, the rule the desktop
    wheel uses.

    Parameters
    ----------
    pad : (float, float)
        Thumb position on the trackpad, [-1, 1]², y up.
    n_labels : int
        K, in [1, 256].
    last : int
        Label returned in the dead zone, in [0, K).

    Returns
    -------
    int
        Label in [0, K).

    References
    ----------
    .. [1] Spec 000_vine §2.4.1 (slice index [INFERRED]); thesis §5.4.1, Fig. 5.9.
    """
    n_labels = check_int("n_labels", n_labels, 1, 256)
    return slice_at(pad[0], pad[1], n_labels, check_int("last", last, 0, n_labels - 1))

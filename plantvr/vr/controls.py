"""Headset control map: controllers in, document commands out (spec 000_treewand §4.1–4.6, 000_vine §2.0–2.6).

Device-independent: :class:`Controls` consumes one :class:`InputFrame` per rendered frame (HMD pose and a
:class:`ControllerState` per hand, from OpenVR, a desktop emulator or a recording) and returns the
:class:`Command` list to issue on a document: ``getattr(doc, cmd.name)(**cmd.kwargs)`` (:func:`issue`), so every
command lands in the document's :class:`~plantvr.commandlog.CommandLog`. One gesture code serves every
document; a :class:`ControlMap` per document kind (``CONTROL_MAPS``, keyed by command name) says which gesture
issues which command. View manipulation (one-grip translation with momentum, two-grip handle bar) edits the
:class:`SceneTransform` that places the document in the room and never touches the document. Nothing here
imports openvr or VTK, so a recorded session replays without a headset (:func:`plantvr.vr.replay`).
"""
from __future__ import annotations

import json
import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from .._validation import check_array, check_int, check_range
from ..params import TREEWAND
from ..vine.colors import slice_at
from ..vine.views import SavedView, load_view, save_view
from .math3d import quat_conj, quat_from_axis_angle, quat_from_matrix, quat_mul, quat_to_matrix

__all__ = [
    "CONTROL_MAPS",
    "GESTURES",
    "MENU_ITEMS",
    "WINDOW_COLORS",
    "BrushGesture",
    "Command",
    "ControlMap",
    "ControllerState",
    "Controls",
    "InputFrame",
    "OneGripTranslate",
    "SceneTransform",
    "control_map",
    "handlebar_step",
    "issue",
    "load_recording",
    "menu_item_at",
    "place_window",
    "ray_hits_window",
    "save_recording",
    "smoothed_velocity",
    "wheel_label",
]

TRIGGER_PREVIEW = 0.1   # [INFERRED] 000_vine §2.4.1: show the brush from ~0.1
TRIGGER_FULL = 0.99     # [INFERRED] paint / prune on the trigger click (>= ~0.99)
MOMENTUM_N = 5          # Eq. 5.2
MOMENTUM_A = 0.98       # Eq. 5.3, per 90-fps frame
MOMENTUM_EPS = 1e-4     # m/s: momentum stops below this [INFERRED]
PAD_DEAD_ZONE = 0.25    # thumb closer to the pad centre gives no reliable angle [INFERRED]
TIP_OFFSET = 0.05       # m from the controller origin along its -z (pointing) axis to the brush centre
WINDOW_DISTANCE = 1.0   # m, §4.6
WINDOW_SIZE = (0.6, 0.4)  # m (width, height) of a parameter window [INFERRED]
RADIUS_RANGE = TREEWAND["brush_radius"].range
STAMP_SPACING = 0.1     # a stroke adds a stamp once the tip moved this fraction of the radius [INFERRED]

#: The 7 menu functions, counter-clockwise from the green icon (§4.5).
MENU_ITEMS = ("appearance", "tree_form", "light", "prune_mode", "save", "load", "new_tree")
#: Window colour == its menu button colour (§4.5 [INFERRED] mapping in figure order).
WINDOW_COLORS = {"appearance": "#2ecc40", "tree_form": "#e03030", "light": "#3060e0"}


@dataclass(frozen=True)
class ControllerState:
    """One hand's input for one frame (000_vine §2.0 "Python input abstraction").

    Parameters
    ----------
    pose : (4, 4) float64 ndarray
        Controller-to-room transform (OpenVR standing space, metres, +y up, -z forward).
    valid : bool
        Tracking is valid this frame.
    trigger : float
        Analogue trigger in [0, 1]; >= 0.99 is the click (full press).
    grip, menu : bool
        Buttons held.
    pad : (float, float)
        Thumb position on the trackpad, [-1, 1]², y up.
    pad_touched, pad_pressed : bool
        Thumb on the pad; pad clicked.
    """

    pose: np.ndarray = field(default_factory=lambda: np.eye(4))
    valid: bool = True
    trigger: float = 0.0
    grip: bool = False
    menu: bool = False
    pad: tuple[float, float] = (0.0, 0.0)
    pad_touched: bool = False
    pad_pressed: bool = False

    @property
    def position(self) -> np.ndarray:
        """(3,) controller origin in the room."""
        return np.asarray(self.pose, float)[:3, 3]

    @property
    def orientation(self) -> np.ndarray:
        """(w, x, y, z) unit quaternion of the controller."""
        return quat_from_matrix(np.asarray(self.pose, float)[:3, :3])

    @property
    def heading(self) -> np.ndarray:
        """(3,) unit pointing direction (the controller's -z axis)."""
        return -np.asarray(self.pose, float)[:3, 2]

    @property
    def tip(self) -> np.ndarray:
        """(3,) brush centre: :data:`TIP_OFFSET` ahead of the controller origin."""
        return self.position + TIP_OFFSET * self.heading

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (for recordings)."""
        return {"pose": np.asarray(self.pose, float).tolist(), "valid": bool(self.valid),
                "trigger": float(self.trigger), "grip": bool(self.grip), "menu": bool(self.menu),
                "pad": [float(self.pad[0]), float(self.pad[1])], "pad_touched": bool(self.pad_touched),
                "pad_pressed": bool(self.pad_pressed)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ControllerState:
        """Inverse of :meth:`to_dict`."""
        return cls(pose=check_array("pose", d["pose"], shape=(4, 4)), valid=bool(d["valid"]),
                   trigger=float(d["trigger"]), grip=bool(d["grip"]), menu=bool(d["menu"]),
                   pad=(float(d["pad"][0]), float(d["pad"][1])), pad_touched=bool(d["pad_touched"]),
                   pad_pressed=bool(d["pad_pressed"]))


@dataclass(frozen=True)
class InputFrame:
    """Everything the control map reads in one frame: time, HMD pose and both hands."""

    t: float
    hmd: np.ndarray = field(default_factory=lambda: np.eye(4))
    left: ControllerState = field(default_factory=ControllerState)
    right: ControllerState = field(default_factory=ControllerState)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        return {"t": float(self.t), "hmd": np.asarray(self.hmd, float).tolist(),
                "left": self.left.to_dict(), "right": self.right.to_dict()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> InputFrame:
        """Inverse of :meth:`to_dict`."""
        return cls(float(d["t"]), check_array("hmd", d["hmd"], shape=(4, 4)),
                   ControllerState.from_dict(d["left"]), ControllerState.from_dict(d["right"]))


@dataclass(frozen=True)
class Command:
    """A document command the control map asks for: ``getattr(doc, name)(**kwargs)`` (:func:`issue`)."""

    name: str
    kwargs: dict[str, Any] = field(default_factory=dict)


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


# -- control maps: which gesture issues which document command ------------------------------------------
#: Every controller gesture a :class:`ControlMap` can bind, with the keyword arguments of its command.
GESTURES: Mapping[str, str] = MappingProxyType({
    "trigger": "full trigger: a brush stamp at the wand tip every frame (center, radius[, label])",
    "trigger_run": "a run of trigger stamps of one radius, merged by the headset's command thread (points, radius)",
    "trigger_press": "full trigger pressed: a stroke opens; its stamps follow only as the tip moves (no kwargs)",
    "trigger_release": "trigger released, or a menu button pressed: the open stroke closes (no kwargs)",
    "sketch_press": "full trigger pressed: a sketch stroke opens at the wand tip (point)",
    "sketch_move": "full trigger held: the sketch brush follows the tip every frame (point, radius, dt)",
    "sketch_release": "trigger released, or a menu button pressed: the sketch stroke closes (no kwargs)",
    "prune_trigger": "full trigger in prune mode; again only once the tip moved a quarter radius (center, radius)",
    "prune_half_trigger": "partial trigger in prune mode: the red preview, not logged (center, radius)",
    "thumb_circle": "thumb circles on the right pad: one clockwise turn doubles the brush radius (brush_radius)",
    "menu_prune_mode": "left-pad menu item 4: the brush prunes / grows (on)",
    "menu_save": "left-pad menu item 5 (path)",
    "menu_load": "left-pad menu item 6 (path)",
    "menu_reset": "left-pad menu item 7 (no kwargs)",
    "wheel_click": "left-pad click on the colour wheel: hide / show the colour under the thumb (label, visible)",
    "right_click": "right-pad click (steps=1)",
    "right_click_up": "right-pad click, upper half: save the current view (view); the lower half loads the next one",
    "left_menu": "left menu button (no kwargs)",
    "right_menu": "right menu button (no kwargs)",
})


@dataclass(frozen=True)
class ControlMap:
    """The commands one document kind gets from the headset, keyed by command name.

    Parameters
    ----------
    kind : str
        The document kind (``Document.KIND``).
    commands : mapping of str to str
        Document command (a method name) → the :data:`GESTURES` entry that issues it.
    labels : bool
        The left pad is the colour wheel (the active label goes into every stamp); otherwise it is the
        7-item menu when a ``menu_*`` gesture is bound (§4.5), else unused.
    """

    kind: str
    commands: Mapping[str, str]
    labels: bool = False

    def __post_init__(self):
        bad = sorted(set(self.commands.values()) - set(GESTURES))
        if bad:
            raise ValueError(f"commands gestures must be among {sorted(GESTURES)}, got {bad[0]!r}")
        gestures = list(self.commands.values())
        dup = sorted({g for g in gestures if gestures.count(g) > 1})
        if dup:
            raise ValueError(f"gesture {dup[0]!r} is bound to more than one command")
        object.__setattr__(self, "commands", MappingProxyType(dict(self.commands)))

    @property
    def by_gesture(self) -> dict[str, str]:
        """Gesture → command name."""
        return {g: c for c, g in self.commands.items()}

    @property
    def left_pad(self) -> str:
        """``"wheel"``, ``"menu"`` or ``"none"``."""
        if self.labels:
            return "wheel"
        return "menu" if any(g.startswith("menu_") for g in self.commands.values()) else "none"


#: The headset's commands per document kind (000_treewand §4.1, §4.5; 000_vine §2.0: the thesis leaves the
#: undo/redo buttons open, "most plausibly the two menu buttons" [INFERRED]; right-pad click = one growth step
#: [INFERRED]). A document kind without an entry gets undo/redo on the menu buttons (:func:`control_map`).
CONTROL_MAPS: Mapping[str, ControlMap] = MappingProxyType({m.kind: m for m in (
    ControlMap("treewand", {"paint": "trigger", "paint_stroke": "trigger_run", "prune": "prune_trigger",
                            "prune_preview": "prune_half_trigger", "set_params": "thumb_circle",
                            "set_prune_mode": "menu_prune_mode", "save": "menu_save", "restore": "menu_load",
                            "reset": "menu_reset", "step": "right_click", "undo": "left_menu",
                            "redo": "right_menu"}),
    ControlMap("vine", {"begin_stroke": "trigger_press", "paint": "trigger", "end_stroke": "trigger_release",
                        "set_visible": "wheel_click", "add_view": "right_click_up", "undo": "left_menu",
                        "redo": "right_menu"}, labels=True),
    ControlMap("treesketch", {"begin_stroke": "sketch_press", "move_stroke": "sketch_move",
                              "end_stroke": "sketch_release", "set_params": "thumb_circle", "grow": "right_click",
                              "undo": "left_menu", "redo": "right_menu"}),
    ControlMap("lsystem", {"grow": "right_click", "undo": "left_menu", "redo": "right_menu"}),
)})


def control_map(doc) -> ControlMap:
    """The :class:`ControlMap` of a document (by its ``KIND``); a kind without a table gets undo/redo on the
    menu buttons when it has those commands, and view manipulation only otherwise."""
    kind = getattr(doc, "KIND", None)
    if kind in CONTROL_MAPS:
        return CONTROL_MAPS[kind]
    names = getattr(doc, "COMMANDS", ())
    return ControlMap(str(kind), {c: g for c, g in (("undo", "left_menu"), ("redo", "right_menu")) if c in names})


# -- the control map -------------------------------------------------------------------------------------
class Controls:
    """One control map for every document (§4.1, 000_vine §2.0): :class:`InputFrame` s in, :class:`Command` s out.

    Right hand: brush on the wand (trigger: partial = preview, full = stamp, stroke or prune, as ``cmap`` binds
    them), thumb circles scale the brush, pad click. Left trackpad: the 7-item menu (hover highlights, click
    activates) or the colour wheel (touch selects the label, click hides / shows it). Menu buttons: ``cmap``'s
    ``left_menu`` / ``right_menu`` commands (undo / redo); an open stroke is closed first. Grips move the
    document (one = translate with momentum, two = handle bar). A controller pointing at an open window neither
    paints nor moves the view (§4.1).

    Parameters
    ----------
    cmap : ControlMap
        Which gesture issues which command (default: Tree Wand's).
    brush_radius : float
        Initial brush radius, model units, in ``radius_range``.
    radius_range : (float, float)
        Bounds of the thumb-circle gesture (default: the ``brush_radius`` parameter range).
    prune_mode : bool
        Initial mode (mirrors the document's ``prune_mode``).
    n_labels, label : int
        Colour-table size and active label (colour-wheel maps).
    scene : SceneTransform, optional
        Placement of the document in the room.
    save_path : str
        File of menu items 5 and 6 (``default.tree``, §4.5).

    Attributes
    ----------
    visible : (K,) bool ndarray or None
        Colour visibility (:meth:`follow` points it at ``doc.colors.visible``); a hidden active label does not
        paint (the document would refuse it, 000_vine §2.6).
    views : list of SavedView
        Saved views to cycle through (:meth:`follow` points it at ``doc.views``).
    painting : bool
        A stroke is open (trigger fully pressed).
    """

    def __init__(self, cmap: ControlMap | None = None, *, brush_radius: float = 1.0,
                 radius_range: tuple[float, float] = RADIUS_RANGE, prune_mode: bool = False, n_labels: int = 1,
                 label: int | None = None, scene: SceneTransform | None = None, save_path: str = "default.tree"):
        cmap = CONTROL_MAPS["treewand"] if cmap is None else cmap
        if not isinstance(cmap, ControlMap):
            raise ValueError(f"cmap must be a ControlMap, got {type(cmap).__name__}")  # noqa: TRY004
        lo = check_range("radius_range[0]", radius_range[0], 0.0, math.inf, low_open=True)
        self.radius_range = (lo, check_range("radius_range[1]", radius_range[1], lo, math.inf))
        self.cmap = cmap
        self._cmd = cmap.by_gesture
        self.brush_radius = check_range("brush_radius", brush_radius, *self.radius_range)
        self.prune_mode = bool(prune_mode)
        self.n_labels = check_int("n_labels", n_labels, 1, 256)
        self.label = check_int("label", min(1, self.n_labels - 1) if label is None else label, 0, self.n_labels - 1)
        self.scene = scene or SceneTransform()
        self.save_path = str(save_path)
        self.gesture = BrushGesture()
        self.translate = OneGripTranslate()
        self.windows: dict[str, np.ndarray] = {}     # open windows: name -> pose
        self.menu_hover: int | None = None
        self.wheel_thumb: tuple[float, float] | None = None
        self.pointing: tuple[str, tuple[float, float]] | None = None
        self.brush_visible = False
        self.brush_center_room = np.zeros(3)
        self.visible: np.ndarray | None = None
        self.views: list[SavedView] = []
        self.view_index = -1
        self.painting = False
        self._prev: InputFrame | None = None
        self._grip_mode = 0            # 0, 1 (which hand in _grip_hand) or 2
        self._grip_hand = "right"
        self._last_prune: np.ndarray | None = None
        self._last_stamp: tuple | None = None
        self._seen: dict[str, Any] = {}

    @classmethod
    def for_document(cls, doc, *, brush_radius: float | None = None, **kwargs: Any) -> Controls:
        """Controls with the document's control map (:func:`control_map`) and settings: brush radius and prune
        mode from its traits, the radius range from its parameter table (or ``doc.max_radius``), the colour
        table size."""
        cmap = control_map(doc)
        table = getattr(doc, "PARAMS", None)
        if table is not None and "brush_radius" in table:
            kwargs.setdefault("radius_range", table["brush_radius"].range)
        elif getattr(doc, "max_radius", None) is not None:
            kwargs.setdefault("radius_range", (1e-6 * float(doc.max_radius), float(doc.max_radius)))
        if brush_radius is None:
            brush_radius = getattr(doc, "brush_radius", None)
        if brush_radius is not None:
            lo, hi = kwargs.get("radius_range", RADIUS_RANGE)
            kwargs["brush_radius"] = float(np.clip(brush_radius, lo, hi))
        if hasattr(doc, "prune_mode"):
            kwargs.setdefault("prune_mode", bool(doc.prune_mode))
        if cmap.labels and getattr(doc, "colors", None) is not None:
            kwargs.setdefault("n_labels", len(doc.colors))
        controls = cls(cmap, **kwargs)
        controls.follow(doc)
        return controls

    @property
    def brush_center(self) -> np.ndarray:
        """(3,) brush centre in model space."""
        return self.scene.to_model(self.brush_center_room)

    @property
    def hidden(self) -> bool:
        """The active label is hidden (it does not paint)."""
        return (self.cmap.labels and self.visible is not None and self.label < len(self.visible)
                and not self.visible[self.label])

    def follow(self, doc) -> None:
        """Adopt what changed in the document since the last call (a notebook widget, or one of our own queued
        commands landing): brush radius and prune mode when the map binds them, the colour table's size and
        visibility, the saved views. A headset change still queued is not undone by the document's older value;
        values the controls were built with stay until the document's change."""
        names = []
        if self._cmd.get("thumb_circle") == "set_params":
            names.append("brush_radius")
        if "menu_prune_mode" in self._cmd:
            names.append("prune_mode")
        for name in names:
            if hasattr(doc, name):
                v = getattr(doc, name)
                if name in self._seen and v != self._seen[name]:
                    setattr(self, name, v)
                self._seen[name] = v
        colors = getattr(doc, "colors", None) if self.cmap.labels else None
        if colors is not None:
            self.visible = colors.visible
            self.n_labels = len(colors)
            self.label = min(self.label, self.n_labels - 1)
        views = getattr(doc, "views", None)
        if isinstance(views, list):
            self.views = views

    def update(self, frame: InputFrame) -> list[Command]:
        """Advance one frame; return the commands to issue on the document, in order."""
        prev = self._prev or InputFrame(frame.t, frame.hmd)   # first frame: every button counts as a press
        dt = max(frame.t - prev.t, 0.0)
        cmds: list[Command] = []
        pad = self.cmap.left_pad
        if pad == "menu":
            self._menu(frame.left, prev.left, cmds)
        elif pad == "wheel":
            self._wheel(frame.left, prev.left, cmds)
        self._buttons(frame, prev, cmds)
        self._pointing(frame.right)
        self._view(frame, prev, dt)
        self._brush(frame.right, dt, cmds)
        self._prev = frame
        return cmds

    # - left pad: menu
    def _menu(self, cur: ControllerState, old: ControllerState, cmds: list[Command]) -> None:
        self.menu_hover = menu_item_at(cur.pad) if cur.pad_touched else None
        if cur.pad_pressed and not old.pad_pressed and self.menu_hover is not None:
            self.activate(self.menu_hover, cmds)

    def activate(self, index: int, cmds: list[Command] | None = None,
                 pose: np.ndarray | None = None) -> list[Command]:
        """Run menu item ``index`` (0-based, :data:`MENU_ITEMS`); returns (and appends) its commands."""
        index = check_int("index", index, 0, len(MENU_ITEMS) - 1)
        cmds = [] if cmds is None else cmds
        name = MENU_ITEMS[index]
        if name in WINDOW_COLORS:
            if name in self.windows:
                del self.windows[name]
            else:
                src = pose if pose is not None else (self._prev.right.pose if self._prev else np.eye(4))
                self.windows[name] = place_window(np.asarray(src, float))
            return cmds
        gesture = {"prune_mode": "menu_prune_mode", "save": "menu_save", "load": "menu_load"}.get(name, "menu_reset")
        command = self._cmd.get(gesture)
        if command is None:
            return cmds
        if gesture == "menu_prune_mode":
            self.prune_mode = not self.prune_mode
            cmds.append(Command(command, {"on": self.prune_mode}))
        elif gesture in ("menu_save", "menu_load"):
            cmds.append(Command(command, {"path": self.save_path}))
        else:
            cmds.append(Command(command))
        return cmds

    # - left pad: colour wheel and hide/show
    def _wheel(self, cur: ControllerState, old: ControllerState, cmds: list[Command]) -> None:
        self.wheel_thumb = cur.pad if (cur.pad_touched and cur.valid) else None
        if self.wheel_thumb is None:
            return
        self.label = wheel_label(cur.pad, self.n_labels, self.label)
        command = self._cmd.get("wheel_click")
        if command is not None and cur.pad_pressed and not old.pad_pressed:
            shown = True if self.visible is None or self.label >= len(self.visible) else bool(self.visible[self.label])
            cmds.append(Command(command, {"label": self.label, "visible": not shown}))

    # - menu buttons; right pad click
    def _buttons(self, f: InputFrame, p: InputFrame, cmds: list[Command]) -> None:
        for pressed, was, gesture in ((f.left.menu, p.left.menu, "left_menu"),
                                      (f.right.menu, p.right.menu, "right_menu")):
            if pressed and not was and gesture in self._cmd:
                cmds.extend(self.close_stroke())          # 000_vine §2.5 [INFERRED]: finish the operation first
                cmds.append(Command(self._cmd[gesture]))
        r = f.right
        if not (r.valid and r.pad_pressed and not p.right.pad_pressed):
            return
        if "right_click" in self._cmd:
            cmds.append(Command(self._cmd["right_click"], {"steps": 1}))
        elif "right_click_up" in self._cmd:
            if r.pad[1] >= 0.0:
                view = self.current_view(f.hmd)
                if view is not None:
                    cmds.append(Command(self._cmd["right_click_up"], {"view": view}))
            else:
                self.next_view(f.hmd)

    def current_view(self, hmd: np.ndarray) -> SavedView | None:
        """The placement relative to the head's horizontal facing (000_vine §2.3); ``None`` if looking straight
        up or down (no horizontal facing)."""
        hmd = np.asarray(hmd, float)
        try:
            return save_view(self.scene.translation, self.scene.rotation, self.scene.scale,
                             viewer_position=hmd[:3, 3], view_dir=-hmd[:3, 2])
        except ValueError:
            return None

    def next_view(self, hmd: np.ndarray) -> int | None:
        """Place the document at the next saved view for the current head (000_vine §2.3 load); returns its
        number."""
        if not self.views:
            return None
        hmd = np.asarray(hmd, float)
        k = (self.view_index + 1) % len(self.views)
        try:
            pos, rot, scale = load_view(self.views[k], viewer_position=hmd[:3, 3], view_dir=-hmd[:3, 2])
        except ValueError:
            return None
        self.scene.translation, self.scene.rotation, self.scene.scale = pos, rot, float(scale)
        self.translate.velocity = np.zeros(3)
        self.view_index = k
        return k

    # - windows: pointing ray of the right hand
    def _pointing(self, right: ControllerState) -> None:
        self.pointing = None
        if not right.valid:
            return
        for name, pose in self.windows.items():
            uv = ray_hits_window(right.position, right.heading, pose)
            if uv is not None:
                self.pointing = (name, uv)
                if right.grip:   # hold grip while pointing: re-place the window 1 m ahead (§4.1)
                    self.windows[name] = place_window(right.pose)
                return

    # - grips: translate / handle bar / momentum
    def _view(self, f: InputFrame, p: InputFrame, dt: float) -> None:
        lg = f.left.grip and f.left.valid
        rg = f.right.grip and f.right.valid and self.pointing is None
        mode = 2 if (lg and rg) else 1 if (lg or rg) else 0
        hand = "left" if lg and not rg else "right"
        if mode == 2:
            if self._grip_mode == 2:
                k, q, m0, m1 = handlebar_step(p.left.position, p.right.position, p.left.orientation,
                                              p.right.orientation, f.left.position, f.right.position,
                                              f.left.orientation, f.right.orientation)
                self.scene.handlebar(k, q, m0, m1)
            self.translate.velocity = np.zeros(3)   # no rotational/bar momentum
        elif mode == 1:
            c = getattr(f, hand)
            if self._grip_mode != 1 or self._grip_hand != hand:
                self.translate.grab(c.position, f.t)   # new grab (or 2 -> 1): no jump, momentum cancelled
            else:
                self.scene.translate(self.translate.move(c.position, f.t))
        else:
            if self._grip_mode == 1:
                self.translate.release()
            elif self._grip_mode == 2:
                self.translate.velocity = np.zeros(3)
            self.scene.translate(self.translate.coast(dt))
        self._grip_mode, self._grip_hand = mode, hand

    # - brush (right hand)
    def _brush(self, right: ControllerState, dt: float, cmds: list[Command]) -> None:
        touched = right.pad_touched and right.valid and not right.pad_pressed
        new_r = self.gesture.update(right.pad, touched, self.brush_radius, self.radius_range)
        if new_r != self.brush_radius:
            self.brush_radius = new_r
            if "thumb_circle" in self._cmd:
                cmds.append(Command(self._cmd["thumb_circle"], {"brush_radius": new_r}))
        self.brush_center_room = right.tip
        self.brush_visible = right.valid and right.trigger >= TRIGGER_PREVIEW and self.pointing is None
        if not self.brush_visible:
            self._last_prune = None
            cmds.extend(self.close_stroke())
            return
        c = self.brush_center
        if self.prune_mode and "prune_trigger" in self._cmd:
            if right.trigger < TRIGGER_FULL:
                self._last_prune = None
                if "prune_half_trigger" in self._cmd:
                    cmds.append(Command(self._cmd["prune_half_trigger"], {"center": c, "radius": self.brush_radius}))
            elif self._last_prune is None or np.linalg.norm(c - self._last_prune) > 0.25 * self.brush_radius:
                cmds.append(Command(self._cmd["prune_trigger"], {"center": c, "radius": self.brush_radius}))
                self._last_prune = c
            return
        if right.trigger < TRIGGER_FULL or self.hidden:
            cmds.extend(self.close_stroke())
            return
        self._stamp(c, dt, cmds)

    def _stamp(self, c: np.ndarray, dt: float, cmds: list[Command]) -> None:
        if "sketch_press" in self._cmd:
            if not self.painting:
                self.painting = True
                cmds.append(Command(self._cmd["sketch_press"], {"point": c}))
            elif "sketch_move" in self._cmd:
                cmds.append(Command(self._cmd["sketch_move"], {"point": c, "radius": self.brush_radius, "dt": dt}))
            return
        kw = {"center": c, "radius": self.brush_radius}
        if self.cmap.labels:
            kw["label"] = self.label
        if "trigger_press" not in self._cmd:
            if "trigger" in self._cmd:
                cmds.append(Command(self._cmd["trigger"], kw))
            return
        if not self.painting:
            if "trigger_press" in self._cmd:
                cmds.append(Command(self._cmd["trigger_press"]))
            self.painting = True
            self._last_stamp = None
        elif self._last_stamp is not None and self._last_stamp[1:] == (self.brush_radius, self.label) \
                and np.linalg.norm(c - self._last_stamp[0]) <= STAMP_SPACING * self.brush_radius:
            return   # a wand held still adds nothing to the stroke: do not queue work for the worker
        self._last_stamp = (c, self.brush_radius, self.label)
        if "trigger" in self._cmd:
            cmds.append(Command(self._cmd["trigger"], kw))

    def close_stroke(self) -> list[Command]:
        """Close an open stroke: the command that finishes it (``trigger_release`` / ``sketch_release``); empty
        when no stroke is open."""
        if not self.painting:
            return []
        self.painting = False
        release = self._cmd.get("trigger_release", self._cmd.get("sketch_release"))
        return [Command(release)] if release is not None else []

    def coalesce(self, batch: list[Command]) -> list[Command]:
        """Merge runs of ``trigger`` stamps with one radius into the map's ``trigger_run`` command (a paint
        stroke) and keep only the last ``prune_half_trigger`` preview; other maps pass the batch unchanged."""
        stamp, run = self._cmd.get("trigger"), self._cmd.get("trigger_run")
        preview = self._cmd.get("prune_half_trigger")
        out: list[Command] = []
        last_preview = max((i for i, c in enumerate(batch) if c.name == preview), default=-1)
        for i, c in enumerate(batch):
            if preview is not None and c.name == preview and i != last_preview:
                continue
            if run is not None and c.name == stamp and out and out[-1].name in (stamp, run) \
                    and out[-1].kwargs["radius"] == c.kwargs["radius"]:
                prev = out.pop()
                pts = [prev.kwargs["center"]] if prev.name == stamp else list(prev.kwargs["points"])
                out.append(Command(run, {"points": pts + [c.kwargs["center"]], "radius": c.kwargs["radius"]}))
            else:
                out.append(c)
        return out


def issue(doc, cmd: Command) -> Any:
    """Issue ``cmd`` on ``doc`` through the method of the same name, as notebook code does
    (``getattr(doc, cmd.name)(**cmd.kwargs)``): a replayable command lands in ``doc.log``. A name the document
    does not have raises ``ValueError``."""
    if not isinstance(cmd, Command):
        raise ValueError(f"cmd must be a Command, got {type(cmd).__name__}")  # noqa: TRY004
    fn = getattr(doc, cmd.name, None) if not cmd.name.startswith("_") else None
    if not callable(fn):
        names = [c for c in control_map(doc).commands if callable(getattr(doc, c, None))]
        raise ValueError(f"command must be one of {names} ({type(doc).__name__}), got {cmd.name!r}"[:300])  # noqa: TRY004
    return fn(**cmd.kwargs)


def save_recording(frames: list[InputFrame], path: str | Path) -> Path:
    """Write headset input frames as JSON lines (replay them with :func:`plantvr.vr.replay`)."""
    from .._fileio import write_atomic

    path = Path(path)
    if isinstance(frames, InputFrame) or not all(isinstance(f, InputFrame) for f in frames):
        raise ValueError("frames must be a list of InputFrame")
    text = "".join(json.dumps(f.to_dict(), allow_nan=False) + "\n" for f in _checked_frames(frames))
    write_atomic(path, text)                   # a failed save leaves the old recording (issue 20)
    return path


#: Largest recording read, in bytes (about 20 minutes of 90-fps frames).
MAX_RECORDING_BYTES = 256 * 2**20


def _checked_frames(frames):
    for i, f in enumerate(frames):
        try:
            _check_frame(f)
        except ValueError as exc:
            raise ValueError(f"frames[{i}]: {exc}") from None
        yield f


def _check_frame(f: InputFrame) -> None:
    """A frame as :meth:`InputFrame.to_dict` writes it: finite time and poses, trigger and pad in range."""
    check_range("t", f.t, -1e12, 1e12)
    check_array("hmd", f.hmd, shape=(4, 4), max_abs=1e6)
    for hand in ("left", "right"):
        c = getattr(f, hand)
        check_array(f"{hand}.pose", c.pose, shape=(4, 4), max_abs=1e6)
        check_range(f"{hand}.trigger", c.trigger, 0.0, 1.0)
        for k in (0, 1):
            check_range(f"{hand}.pad[{k}]", c.pad[k], -1.0, 1.0)


def _frame_from_json(d: Any) -> InputFrame:
    hands = ("left", "right")
    keys = ("pose", "valid", "trigger", "grip", "menu", "pad", "pad_touched", "pad_pressed")
    if not isinstance(d, dict) or set(d) != {"t", "hmd", *hands}:
        raise ValueError("expected the keys t, hmd, left, right")
    for h in hands:
        c = d[h]
        if not isinstance(c, dict) or set(c) != set(keys):
            raise ValueError(f"{h} must hold the keys {', '.join(keys)}")
        bad = [k for k in ("valid", "grip", "menu", "pad_touched", "pad_pressed") if not isinstance(c[k], bool)]
        if bad:
            raise ValueError(f"{h}.{bad[0]} must be true or false")
        if not (isinstance(c["pad"], list) and len(c["pad"]) == 2):
            raise ValueError(f"{h}.pad must be a pair of numbers")
        if any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in (c["trigger"], *c["pad"])):
            raise ValueError(f"{h}.trigger and {h}.pad must be numbers")
    if isinstance(d["t"], bool) or not isinstance(d["t"], (int, float)):
        raise ValueError("t must be a number")
    f = InputFrame.from_dict(d)
    _check_frame(f)
    return f


def load_recording(path: str | Path) -> list[InputFrame]:
    """Read frames written by :func:`save_recording`; a corrupt file raises ``ValueError`` (naming the line)."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_RECORDING_BYTES:
            raise ValueError(f"recording {path!s} is larger than the {MAX_RECORDING_BYTES} bytes allowed")
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ValueError(f"recording {path!s} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read recording {path!s}: {exc}") from None
    out = []
    for i, line in enumerate(text.splitlines(), 1):
        try:
            out.append(_frame_from_json(json.loads(line, parse_constant=_no_constant)))
        except (json.JSONDecodeError, KeyError, TypeError, IndexError, ValueError, RecursionError) as exc:
            raise ValueError(f"recording {path!s} line {i} is not a headset input frame ({exc})"[:300]) from None
    return out


def _no_constant(name: str):
    raise ValueError(f"{name} is not a finite number")

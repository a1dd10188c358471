"""Headset input frames and their recordings (spec 000_vine §2.0 "Python input abstraction"; issue 30).

An :class:`InputFrame` is what the control map reads in one rendered frame: the HMD pose and one
:class:`ControllerState` per hand, from OpenVR, a desktop emulator or a recording. A recording is a
:class:`~plantvr.commandlog.CommandLog` of ``frame`` events (document kind ``"headset"``): the one JSON-lines
format of the package, with its checksum trailer, so a truncated or edited recording is refused as a damaged
session log is.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import check_array, check_range
from ..commandlog import CommandLog, Event
from .math3d import quat_from_matrix

__all__ = ["RECORDING_KIND", "TIP_OFFSET", "ControllerState", "InputFrame", "load_recording", "save_recording"]

TIP_OFFSET = 0.05       # m from the controller origin along its -z (pointing) axis to the brush centre
#: The document kind a recording's log names in its trailer; its one event is ``frame``.
RECORDING_KIND = "headset"


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



def save_recording(frames: list[InputFrame], path: str | Path) -> Path:
    """Write headset input frames as a command log of ``frame`` events (replay them with
    :func:`plantvr.vr.replay`); atomic, so a failed save leaves the old recording (issue 20)."""
    if isinstance(frames, InputFrame) or not all(isinstance(f, InputFrame) for f in frames):
        raise ValueError("frames must be a list of InputFrame")
    log = CommandLog(("frame",), document=RECORDING_KIND)
    for i, f in enumerate(frames):
        try:
            _check_frame(f)
        except ValueError as exc:
            raise ValueError(f"frames[{i}]: {exc}") from None
        log.events.append(Event("frame", f.to_dict(), float(f.t)))   # the frame's own clock: saving is repeatable
    return log.save(path)


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
    """Read frames written by :func:`save_recording`; a missing, truncated, edited or foreign file raises
    ``ValueError`` (the log's checksum trailer, then each frame's door check, naming the frame)."""
    log = CommandLog.load(path, ("frame",), document=RECORDING_KIND)
    out = []
    for i, ev in enumerate(log.events):
        try:
            out.append(_frame_from_json(ev.kwargs))
        except (KeyError, TypeError, IndexError, ValueError, RecursionError) as exc:
            raise ValueError(f"recording {str(path)!r} frame {i} is not a headset input frame ({exc})"[:300]) from None
    return out

"""ViNE headset control map: painting, colour wheel, hiding, undo/redo, saved views (spec 000_vine §2.0–2.6).

Device-independent like :mod:`plantvr.vr.controls`: :class:`VineControls` consumes one
:class:`~plantvr.vr.controls.InputFrame` per rendered frame and returns :class:`~plantvr.vr.controls.Command` s
that :func:`apply_vine_command` issues on a :class:`plantvr.vine.Segmentation` through its public methods
only. View manipulation (one grip: translation with momentum; two grips: handle bar) is the Tree Wand
:class:`~plantvr.vr.controls.Controls` code, reused unchanged. Nothing here imports openvr or VTK.

Control map (000_vine §2.0; the thesis leaves the undo/redo and view-loading buttons open):

============================  ==============================================================================
Right trigger, partial        show the brush sphere in the active colour (preview), no paint (§2.4.1)
Right trigger, full           paint at the wand tip; press to release is one stroke = one undo item (§2.5)
Right pad, thumb circles      brush radius, one clockwise turn doubles it (:class:`BrushGesture`, §2.4.1)
Right pad click, upper half   save the current view (``seg.add_view``, §2.3)
Right pad click, lower half   load the next saved view (cycle) [INFERRED: the thesis used the keyboard]
Left pad, touch               choose the label on the colour wheel (:func:`wheel_label`, §2.4.1)
Left pad click                toggle hide/show of the colour under the thumb (§2.6)
Left menu / right menu        undo / redo [INFERRED, §2.0 note: "most plausibly the two menu buttons"]
One grip / both grips         translate with momentum / handle bar (§2.1, :class:`Controls`)
============================  ==============================================================================
"""
from __future__ import annotations

import math

import numpy as np

from .._validation import check_int, check_range
from ..vine.views import SavedView, load_view, save_view
from .controls import (
    TRIGGER_FULL,
    TRIGGER_PREVIEW,
    Command,
    ControllerState,
    Controls,
    InputFrame,
    SceneTransform,
)

__all__ = [
    "VINE_COMMANDS",
    "WHEEL_DEAD_ZONE",
    "VineControls",
    "apply_vine_command",
    "replay_vine",
    "wheel_label",
]

#: Thumb radius below which the wheel keeps the last label (000_vine §2.4.1 [INFERRED] |xy| < 0.15).
WHEEL_DEAD_ZONE = 0.15
#: A new stamp of a stroke is queued only once the tip moved this fraction of the radius [INFERRED].
STAMP_SPACING = 0.1
VINE_COMMANDS = ("begin_stroke", "paint", "end_stroke", "undo", "redo", "toggle_visible", "add_view")


def wheel_label(pad: tuple[float, float], n_labels: int, last: int = 0) -> int:
    """Label under the thumb on the left-pad colour wheel.

    ``k = floor((atan2(y, x) mod 2π) / (2π / K))`` with K = ``n_labels`` slices counter-clockwise from +x
    (slice k is colour-table entry k, 0 = unpainted); within :data:`WHEEL_DEAD_ZONE` of the centre the
    ``last`` label is kept. The same rule as :func:`plantvr.ui.wheel.slice_at` (which lives in a widget
    module that imports anywidget, so the headset thread keeps this pure copy; a test asserts they agree).

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
    last = check_int("last", last, 0, n_labels - 1)
    x = check_range("pad x", pad[0], -math.inf, math.inf)
    y = check_range("pad y", pad[1], -math.inf, math.inf)
    if math.hypot(x, y) < WHEEL_DEAD_ZONE:
        return last
    return min(int((math.atan2(y, x) % (2 * math.pi)) / (2 * math.pi / n_labels)), n_labels - 1)


class VineControls(Controls):
    """ViNE control map (module docstring table): :class:`InputFrame` s in, segmentation commands out.

    Parameters
    ----------
    n_labels : int
        Colour-table size (wheel slices), in [1, 256].
    label : int
        Initially active label.
    brush_radius : float
        Brush radius, model units, in (0, max_radius].
    max_radius : float
        Largest radius the gesture may reach (``seg.max_radius``).
    scene : SceneTransform, optional
        Placement of the model in the room.

    Attributes
    ----------
    label : int
        Active label (the extruded wheel slice).
    visible : (K,) bool ndarray or None
        Colour visibility (the bridge points it at ``seg.colors.visible``); a hidden active label does not
        paint (the segmentation would refuse it, §2.6).
    views : list of SavedView
        Saved views to cycle through (the bridge points it at ``seg.views``).
    painting : bool
        A stroke is open (trigger fully pressed).
    """

    def __init__(self, *, n_labels: int, label: int = 1, brush_radius: float = 1.0, max_radius: float = 1e6,
                 scene: SceneTransform | None = None):
        super().__init__(scene=scene)
        self.n_labels = check_int("n_labels", n_labels, 1, 256)
        self.label = check_int("label", label, 0, self.n_labels - 1)
        self.max_radius = check_range("max_radius", max_radius, 0.0, math.inf, low_open=True)
        self.brush_radius = check_range("brush_radius", brush_radius, 0.0, self.max_radius, low_open=True)
        self.min_radius = 1e-6 * self.max_radius
        self.visible: np.ndarray | None = None
        self.views: list[SavedView] = []
        self.view_index = -1
        self.painting = False
        self.wheel_thumb: tuple[float, float] | None = None
        self._last_stamp: tuple | None = None

    def update(self, frame: InputFrame) -> list[Command]:
        """Advance one frame; return the segmentation commands to issue, in order."""
        prev = self._prev or InputFrame(frame.t, frame.hmd)   # first frame: every button counts as a press
        dt = max(frame.t - prev.t, 0.0)
        cmds: list[Command] = []
        self._wheel(frame.left, prev.left, cmds)
        self._buttons(frame, prev, cmds)
        self._view(frame, prev, dt)
        self._vine_brush(frame.right, cmds)
        self._prev = frame
        return cmds

    # - left pad: colour wheel and hide/show
    def _wheel(self, cur: ControllerState, old: ControllerState, cmds: list[Command]) -> None:
        self.wheel_thumb = cur.pad if (cur.pad_touched and cur.valid) else None
        if self.wheel_thumb is None:
            return
        self.label = wheel_label(cur.pad, self.n_labels, self.label)
        if cur.pad_pressed and not old.pad_pressed:
            cmds.append(Command("toggle_visible", {"label": self.label}))

    # - menus: undo/redo; right pad click: save / cycle views
    def _buttons(self, f: InputFrame, p: InputFrame, cmds: list[Command]) -> None:
        for pressed, was, name in ((f.left.menu, p.left.menu, "undo"), (f.right.menu, p.right.menu, "redo")):
            if pressed and not was:
                self._close_stroke(cmds)            # §2.5 [INFERRED]: finish the operation first
                cmds.append(Command(name))
        r = f.right
        if r.valid and r.pad_pressed and not p.right.pad_pressed:
            if r.pad[1] >= 0.0:
                view = self.current_view(f.hmd)
                if view is not None:
                    cmds.append(Command("add_view", {"view": view}))
            else:
                self.next_view(f.hmd)

    def current_view(self, hmd: np.ndarray) -> SavedView | None:
        """The model placement relative to the head's horizontal facing (§2.3); ``None`` if looking straight
        up or down (no horizontal facing)."""
        hmd = np.asarray(hmd, float)
        try:
            return save_view(self.scene.translation, self.scene.rotation, self.scene.scale,
                             viewer_position=hmd[:3, 3], view_dir=-hmd[:3, 2])
        except ValueError:
            return None

    def next_view(self, hmd: np.ndarray) -> int | None:
        """Place the model at the next saved view for the current head (§2.3 load); returns its number."""
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

    # - right hand: brush
    def _close_stroke(self, cmds: list[Command]) -> None:
        if self.painting:
            cmds.append(Command("end_stroke"))
            self.painting = False

    def _vine_brush(self, right: ControllerState, cmds: list[Command]) -> None:
        k = self.gesture.update(right.pad, right.pad_touched and right.valid and not right.pad_pressed, 1.0)
        if k != 1.0:
            self.brush_radius = float(np.clip(self.brush_radius * k, self.min_radius, self.max_radius))
        self.brush_center_room = right.tip
        self.brush_visible = right.valid and right.trigger >= TRIGGER_PREVIEW
        hidden = self.visible is not None and self.label < len(self.visible) and not self.visible[self.label]
        if not (right.valid and right.trigger >= TRIGGER_FULL) or hidden:
            self._close_stroke(cmds)
            return
        c = self.brush_center
        if not self.painting:
            cmds.append(Command("begin_stroke"))
            self.painting = True
            self._last_stamp = None
        elif self._last_stamp is not None and self._last_stamp[1:] == (self.brush_radius, self.label) \
                and np.linalg.norm(c - self._last_stamp[0]) <= STAMP_SPACING * self.brush_radius:
            return   # a wand held still adds nothing to the stroke: do not queue work for the worker
        cmds.append(Command("paint", {"center": c, "radius": self.brush_radius, "label": self.label}))
        self._last_stamp = (c, self.brush_radius, self.label)


def apply_vine_command(seg, cmd: Command):
    """Issue ``cmd`` on a segmentation through its public methods.

    ``begin_stroke``/``end_stroke`` → :meth:`Segmentation.begin_stroke`/:meth:`~Segmentation.end_stroke`,
    ``paint`` → :meth:`~Segmentation.paint`, ``undo``/``redo``, ``toggle_visible`` →
    :meth:`~Segmentation.toggle_visible`, ``add_view`` → :meth:`~Segmentation.add_view`.
    """
    k = cmd.kwargs
    if cmd.name == "paint":
        return seg.paint(k["center"], k["radius"], k["label"])
    if cmd.name == "begin_stroke":
        return seg.begin_stroke()
    if cmd.name == "end_stroke":
        return seg.end_stroke()
    if cmd.name == "undo":
        return seg.undo()
    if cmd.name == "redo":
        return seg.redo()
    if cmd.name == "toggle_visible":
        return seg.toggle_visible(k["label"])
    if cmd.name == "add_view":
        return seg.add_view(k["view"])
    raise ValueError(f"command must be one of {', '.join(VINE_COMMANDS)}; got {cmd.name!r}")


def replay_vine(seg, frames: list[InputFrame], controls: VineControls | None = None) -> VineControls:
    """Feed recorded headset frames through :class:`VineControls` into ``seg``, synchronously, no headset."""
    controls = controls or VineControls(n_labels=len(seg.colors), label=min(1, len(seg.colors) - 1),
                                        max_radius=seg.max_radius,
                                        brush_radius=min(1.0, seg.max_radius))
    controls.views = seg.views
    for f in frames:
        controls.visible = seg.colors.visible
        controls.n_labels = len(seg.colors)
        for cmd in controls.update(f):
            apply_vine_command(seg, cmd)
    if controls.painting:
        seg.end_stroke()
        controls.painting = False
    return controls

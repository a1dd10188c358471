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

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from .._validation import check_int, check_range
from ..vine.views import SavedView, load_view, save_view
from .frames import ControllerState, InputFrame
from .gestures import (MENU_ITEMS, RADIUS_RANGE, STAMP_SPACING, TRIGGER_FULL,
                       TRIGGER_PREVIEW, WINDOW_COLORS, BrushGesture, OneGripTranslate, SceneTransform, handlebar_step,
                       menu_item_at, place_window, ray_hits_window, wheel_label)

__all__ = ["CONTROL_MAPS", "GESTURES", "Command", "ControlMap", "Controls", "control_map", "issue"]


@dataclass(frozen=True)
class Command:
    """A document command the control map asks for: ``getattr(doc, name)(**kwargs)`` (:func:`issue`)."""

    name: str
    kwargs: dict[str, Any] = field(default_factory=dict)


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

"""Headset mode for any document: OpenVR bridge, stereo rendering, one control map (spec 000_treewand §4,
000_vine §2.1–2.6, §4).

``plantvr.vr.attach(doc)`` returns the :class:`Headset` of a :class:`~plantvr.document.Document` (Tree Wand,
ViNE labels, TreeSketch, or any other: it draws ``doc.scene()`` and issues ``doc``'s commands by name through
the control map of its kind, :data:`CONTROL_MAPS`); ``headset.start()`` opens headset mode and
``headset.stop()`` ends it. ``plantvr.vr.replay(doc, frames)`` replays a recording of input frames without a
headset. ``openvr`` (pyopenvr, extra ``plantvr[vr]``) is imported only by ``start()``; without it, or without
SteamVR, ``start()`` raises a ``RuntimeError`` that says what to install. :mod:`plantvr.vr.fake_openvr` stands
in for it in tests.
"""
from .bridge import HISTOGRAM_EDGES_MS, Headset, attach, replay
from .controls import (
    CONTROL_MAPS,
    GESTURES,
    MENU_ITEMS,
    BrushGesture,
    Command,
    ControllerState,
    ControlMap,
    Controls,
    InputFrame,
    OneGripTranslate,
    SceneTransform,
    control_map,
    handlebar_step,
    issue,
    load_recording,
    menu_item_at,
    place_window,
    save_recording,
    smoothed_velocity,
    wheel_label,
)

__all__ = [
    "CONTROL_MAPS",
    "GESTURES",
    "HISTOGRAM_EDGES_MS",
    "MENU_ITEMS",
    "BrushGesture",
    "Command",
    "ControlMap",
    "ControllerState",
    "Controls",
    "Headset",
    "InputFrame",
    "OneGripTranslate",
    "SceneTransform",
    "attach",
    "control_map",
    "handlebar_step",
    "issue",
    "load_recording",
    "menu_item_at",
    "place_window",
    "replay",
    "save_recording",
    "smoothed_velocity",
    "wheel_label",
]

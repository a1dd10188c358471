"""Headset mode: OpenVR bridge, stereo rendering, controller map (spec 000_treewand §4, 000_vine §2.1, §4).

``plantvr.vr.attach(model)`` returns the model's :class:`VRBridge` (the notebook's ``model.vr``);
``plantvr.vr.attach_segmentation(seg, proxy=None)`` the ViNE-mode :class:`VineBridge` of a segmentation;
``bridge.start()`` opens headset mode and ``bridge.stop()`` ends it. ``openvr`` (pyopenvr, extra
``plantvr[vr]``) is imported only by ``start()``; without it, or without SteamVR, ``start()`` raises a
``RuntimeError`` that says what to install. :mod:`plantvr.vr.fake_openvr` stands in for it in tests.
"""
from .bridge import HISTOGRAM_EDGES_MS, VRBridge, attach
from .controls import (
                       MENU_ITEMS,
                       BrushGesture,
                       Command,
                       ControllerState,
                       Controls,
                       InputFrame,
                       OneGripTranslate,
                       SceneTransform,
                       apply_command,
                       handlebar_step,
                       load_recording,
                       menu_item_at,
                       place_window,
                       replay,
                       save_recording,
                       smoothed_velocity,
)
from .vine_controls import VineControls, apply_vine_command, replay_vine, wheel_label
from .vine_mode import VineBridge, attach_segmentation

__all__ = [
                       "HISTOGRAM_EDGES_MS",
                       "MENU_ITEMS",
                       "BrushGesture",
                       "Command",
                       "ControllerState",
                       "Controls",
                       "InputFrame",
                       "OneGripTranslate",
                       "SceneTransform",
                       "VRBridge",
                       "VineBridge",
                       "VineControls",
                       "apply_command",
                       "apply_vine_command",
                       "attach",
                       "attach_segmentation",
                       "handlebar_step",
                       "load_recording",
                       "menu_item_at",
                       "place_window",
                       "replay",
                       "replay_vine",
                       "save_recording",
                       "smoothed_velocity",
                       "wheel_label",
]

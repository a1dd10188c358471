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
from . import controls as _controls
from . import frames as _frames
from . import gestures as _gestures
from .bridge import HISTOGRAM_EDGES_MS, Headset, attach, replay
from .controls import *  # noqa: F403  (the control map)
from .frames import *  # noqa: F403  (input frames and recordings)
from .gestures import *  # noqa: F403  (gesture geometry)

__all__ = ["HISTOGRAM_EDGES_MS", "Headset", "attach", "replay"] + _controls.__all__ + _frames.__all__ \
    + _gestures.__all__

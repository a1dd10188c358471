"""A headset session replays from the document's own log (issue 30): for every document kind with a control map,
a session on the fake OpenVR runtime, with a file load (the headset's menu item 6, or ``restore`` from the
notebook while the headset is attached) and saved views where the kind has them, replays from ``doc.log`` onto a
fresh document to identical ``state_bytes()``."""
import numpy as np
import pytest
import trimesh

from plantvr import vr
from plantvr.documents.labels import Segmentation
from plantvr.documents.lsystem import LSystemDocument
from plantvr.documents.treesketch import SketchDocument
from plantvr.documents.treewand import Model
from plantvr.vr import CONTROL_MAPS, TIP_OFFSET


def _mesh():
    ico = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    return np.asarray(ico.vertices, np.float32), np.asarray(ico.faces)


FRESH = {"treewand": lambda: Model(seed=0), "vine": lambda: Segmentation(*_mesh()),
         "treesketch": lambda: SketchDocument(seed=0, activation_threshold=0.0), "lsystem": LSystemDocument}


def _tip(h, target) -> np.ndarray:
    s = h.controls.scene
    pose = np.eye(4)
    pose[:3, 3] = s.matrix[:3, :3] @ np.asarray(target, float) + s.translation + [0, 0, TIP_OFFSET]
    return pose


def _stroke(h, fake, target):
    fake.right.pose = _tip(h, target)
    fake.right.trigger = 1.0
    h.wait_frames(4)
    fake.right.pose = fake.right.pose @ np.array([[1, 0, 0, 0.02], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    h.wait_frames(3)
    fake.right.trigger = 0.0
    h.wait_frames(2)
    h.wait_commands()


def _right_click(h, fake, y=-0.8):
    fake.right.pad, fake.right.pad_touched, fake.right.pad_pressed = (0.0, y), True, True
    h.wait_frames(2)
    fake.right.pad_touched = fake.right.pad_pressed = False
    h.wait_frames(2)
    h.wait_commands()


def _menu(h, fake, index):
    a = np.pi / 2 + index * 2 * np.pi / 7
    fake.left.pad, fake.left.pad_touched = (0.9 * np.cos(a), 0.9 * np.sin(a)), True
    h.wait_frames(2)
    fake.left.pad_pressed = True
    h.wait_frames(2)
    fake.left.pad_pressed = False
    fake.left.pad_touched = False
    h.wait_frames(2)
    h.wait_commands()


def _button(h, fake, hand):
    hand.menu = True
    h.wait_frames(2)
    hand.menu = False
    h.wait_frames(2)
    h.wait_commands()


def _session(kind, doc, h, fake, tmp_path):
    h.wait_frames(2)
    if kind == "treewand":
        _stroke(h, fake, [0.0, 3.0, 0.0])
        _right_click(h, fake)                         # one growth step
        _menu(h, fake, 4)                             # save (default.tree)
        _stroke(h, fake, [0.5, 4.0, 0.0])
        _right_click(h, fake)
        _menu(h, fake, 5)                             # load: the saved tree comes back
        _right_click(h, fake)
        _button(h, fake, fake.left)                   # undo the step
    elif kind == "vine":
        other = Segmentation(*_mesh())
        other.paint(other.vertices[10], 0.4, 3)
        path = other.save(tmp_path / "labels.npz", include_mesh=False)
        _stroke(h, fake, doc.vertices[0])
        _right_click(h, fake, y=0.8)                  # upper half: save the current view
        doc.restore(path)                             # a load from the notebook, the headset attached
        h.wait_frames(2)
        _stroke(h, fake, doc.vertices[0])
        _right_click(h, fake, y=0.8)
        _button(h, fake, fake.left)
        _button(h, fake, fake.right)
    elif kind == "treesketch":
        lib = SketchDocument(seed=5, activation_threshold=0.0)
        lib.paint([0.0, 3.0, 0.0], radius=1.5)
        lib.grow(3)
        path = lib.save(tmp_path / "oak.tree")
        _stroke(h, fake, [0.0, 3.0, 0.0])
        _right_click(h, fake)                         # grow
        doc.restore(path)                             # a library tree loaded from the notebook
        h.wait_frames(2)
        _stroke(h, fake, [0.0, 3.0, 0.0])
        _right_click(h, fake)
        _button(h, fake, fake.left)
        _button(h, fake, fake.right)
    else:
        _right_click(h, fake)                         # grow
        _right_click(h, fake)
        doc.set_grammar(doc.text, step=1)             # the grammar loaded again from the notebook
        _right_click(h, fake)
        _button(h, fake, fake.left)
        _button(h, fake, fake.right)


@pytest.mark.parametrize("kind", sorted(CONTROL_MAPS))
def test_headset_session_with_loads_and_views_replays_from_the_log(kind, fake, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                       # the headset's menu saves and loads default.tree here
    doc = FRESH[kind]()
    n0 = len(doc.log)
    h = vr.attach(doc)
    h.start()
    try:
        _session(kind, doc, h, fake, tmp_path)
    finally:
        h.stop()
    assert h.command_errors == [] and h.error is None
    issued = [e.command for e in doc.log.events[n0:]]
    assert set(issued) <= set(doc.COMMANDS)
    assert {"treewand": {"restore", "step", "undo"}, "vine": {"restore", "add_view", "undo", "redo"},
            "treesketch": {"restore", "grow", "undo", "redo"}, "lsystem": {"grow", "set_grammar", "undo"}}[kind] \
        <= set(issued)
    if kind == "vine":
        assert len(doc.views) == 1                    # the load took the file's views (none), then one more
    fresh = FRESH[kind]()
    fresh.replay(doc.log)
    assert fresh.state_bytes() == doc.state_bytes()

"""One headset bridge, one control map, one recorder and one replay for any document (issue 21): a Tree Wand Model,
a ViNE Segmentation and a TreeSketch document driven through the fake OpenVR runtime."""
import numpy as np
import pytest
import trimesh

from plantvr import vr
from plantvr.document import Document
from plantvr.documents.labels import Segmentation
from plantvr.documents.treesketch import SketchDocument
from plantvr.documents.treewand import Model
from plantvr.types import Points, TriMesh
from plantvr.vr import CONTROL_MAPS, TIP_OFFSET, Command, Controls, control_map


def make(kind: str, *, grown: bool = True):
    if kind == "treewand":
        m = Model(seed=0)
        if not grown:
            return m
        m.paint_stroke([[0.0, y, 0.0] for y in range(2, 6)], radius=1.5)
        m.step(4)
        return m
    if kind == "vine":
        ico = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
        return Segmentation(np.asarray(ico.vertices, np.float32), np.asarray(ico.faces))
    return SketchDocument(seed=0)


def tip_pose(headset, kind: str) -> np.ndarray:
    """A controller pose (pointing -z) whose brush tip is inside the document's content."""
    target = headset.doc.vertices[0].astype(float) if kind == "vine" else np.array([0.0, 3.0, 0.0])
    s = headset.controls.scene
    pose = np.eye(4)
    pose[:3, 3] = s.matrix[:3, :3] @ target + s.translation + [0, 0, TIP_OFFSET]
    return pose


def _frames(h, n=2):
    h.wait_frames(n)


def session(h, fake, kind: str) -> None:
    """Trigger stroke, right-pad click (lower half), undo, redo: the same gestures for every document."""
    _frames(h)
    fake.right.pose = tip_pose(h, kind)
    fake.right.trigger = 1.0
    _frames(h, 4)
    fake.right.pose = fake.right.pose @ np.array([[1, 0, 0, 0.02], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    _frames(h, 3)
    fake.right.trigger = 0.0
    _frames(h)
    h.wait_commands()
    fake.right.pad, fake.right.pad_touched, fake.right.pad_pressed = (0.0, -0.8), True, True
    _frames(h)
    fake.right.pad_touched = fake.right.pad_pressed = False
    _frames(h)
    h.wait_commands()
    for hand in (fake.left, fake.right):        # left menu = undo, right menu = redo
        hand.menu = True
        _frames(h)
        hand.menu = False
        _frames(h)
        h.wait_commands()


EXPECTED = {"treewand": {"step", "undo", "redo"},   # plus paint, or paint_stroke when stamps queue up
            "vine": {"begin_stroke", "paint", "end_stroke", "undo", "redo"},
            "treesketch": {"begin_stroke", "move_stroke", "end_stroke", "grow", "undo", "redo"}}


@pytest.mark.parametrize("kind", ["treewand", "vine", "treesketch"])
def test_one_control_map_drives_every_document_and_the_session_replays(kind, fake):
    doc = make(kind)
    before = doc.state_bytes()
    n0 = len(doc.log)
    h = vr.attach(doc, record=True)
    assert h.controls.cmap is CONTROL_MAPS[kind] is control_map(doc)
    h.start()
    try:
        session(h, fake, kind)
    finally:
        h.stop()
    assert h.command_errors == [] and h.error is None
    issued = {e.command for e in doc.log.events[n0:]}
    assert EXPECTED[kind] <= issued <= set(doc.COMMANDS)          # every headset command is in the document's log
    assert kind != "treewand" or issued & {"paint", "paint_stroke"}
    after = doc.state_bytes()
    assert after != before
    # the recorded input frames replay through the same control map and command path, without a headset
    again = make(kind)
    vr.replay(again, h.recording)
    assert again.state_bytes() == after
    # and the document's own log (setup and headset session) replays into a fresh document
    fresh = make(kind, grown=False)
    fresh.replay(doc.log)
    assert fresh.state_bytes() == after


class Crown(Document):
    """A document kind without a control-map table: a triangle and its corner points."""

    KIND = "test_crown"
    COMMANDS = ("scale", "undo", "redo")
    EVENTS = ("mesh",)

    def __init__(self):
        super().__init__()
        self.v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])

    def _check_scale(self, k):
        if not 0 < k < 10:
            raise ValueError(f"k must be in (0, 10), got {k}")
        return k

    def scale(self, k):
        k = self._check_scale(k)
        with self._lock, self.undoable("mesh"):
            self.v = self.v * k
            self.log.record("scale", k=k)
        self.changed("mesh", command="scale")

    def get_state(self):
        return self.v.copy()

    def set_state(self, state):
        self.v = state.copy()

    def state_bytes(self):
        return self.v.tobytes()

    def scene(self):
        mesh = TriMesh(self.v, np.array([[0, 1, 2]]))
        mesh.colors = np.array([[255, 0, 0, 255]] * 3, np.uint8)
        return {"crown": mesh, "tips": Points(self.v)}


def test_any_document_is_shown_and_gets_undo_redo(fake):
    doc = Crown()
    doc.scale(2.0)
    h = vr.Headset(doc, readback=True)
    assert set(h.controls.cmap.commands) == {"undo", "redo"} and not h.ground
    h.start()
    try:
        h.wait_content()
        layers = h.content[1]
        assert layers["crown"][0].n_points == 3 and "colors" in layers["crown"][0].point_data   # the View's layers
        assert layers["tips"][0].n_points == 3 and layers["tips"][1].GetProperty().GetRenderPointsAsSpheres()
        fake.left.menu = True
        h.wait_frames(2)
        fake.left.menu = False
        h.wait_frames(2)
        h.wait_commands()
        h.wait_frames(3)
    finally:
        h.stop()
    np.testing.assert_array_equal(doc.v, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert [e.command for e in doc.log] == ["scale", "undo"]
    assert np.ptp(np.concatenate(h.last_images), axis=None) > 0


def test_control_map_table_checks():
    with pytest.raises(ValueError, match="gestures must be among"):
        vr.ControlMap("x", {"paint": "wave"})
    with pytest.raises(ValueError, match="more than one command"):
        vr.ControlMap("x", {"undo": "left_menu", "redo": "left_menu"})
    with pytest.raises(ValueError, match="cmap must be a ControlMap"):
        Controls({"paint": "trigger"})
    with pytest.raises(ValueError, match="doc must be a plantvr Document"):
        vr.Headset(object())
    with pytest.raises(ValueError, match="cmd must be a Command"):
        vr.issue(Crown(), ("undo", {}))
    assert vr.issue(Crown(), Command("undo")) is None

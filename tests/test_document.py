"""The document base: one change path, one history, one command log, parameters from one table (issue 21)."""
import numpy as np
import pytest
import trimesh

from plantvr.commandlog import CommandLog
from plantvr.document import Document
from plantvr.history import ArrayEdit, History, StateAtom
from plantvr.params import Param, ParamTable
from plantvr.types import TreeArrays, TriMesh

TOY = ParamTable("toy", [Param("gain", float, 1.0, "Gain.", "§0", "main", range=(0.0, 10.0))])


class Toy(Document):
    KIND = "toy"
    COMMANDS = ("paint", "grow", "set_params", "undo", "redo")
    EVENTS = ("labels", "total")
    PARAMS = TOY

    def __init__(self, **kw):
        super().__init__(**kw)
        self.labels = np.zeros(10, np.uint8)
        self.total = 0.0

    def _check_paint(self, i, v):
        if not isinstance(i, int) or not 0 <= i < 10:
            raise ValueError(f"i must be an int in [0, 9], got {i!r}")
        return i, v

    def paint(self, i, v):
        i, v = self._check_paint(i, v)
        with self._lock:
            old = self.labels[[i]].copy()
            self.labels[i] = v
            self.history.push(ArrayEdit(np.array([i]), old, np.array([v], np.uint8)))
            self.log.record("paint", i=i, v=v)
        self.changed("labels", [i], command="paint")

    def _check_grow(self):
        return None

    def grow(self):
        with self._lock, self.undoable("total"):
            self.total += self.gain
            self.log.record("grow")
        self.changed("total", command="grow")

    def get_state(self):
        return {"params": self.params, "total": np.array([self.total])}

    def set_state(self, state):
        self.restore_params(state["params"])
        self.total = float(state["total"][0])

    def state_bytes(self):
        return self.labels.tobytes() + np.float64(self.total).tobytes() + repr(self.params).encode()


def _session(d):
    d.paint(3, 5)
    d.gain = 2.0
    d.grow()
    d.set_params(gain=0.5)
    d.paint(4, 1)
    d.grow()
    d.undo()


def test_change_events_carry_kind_ids_and_version():
    d = Toy()
    seen = []
    d.observe(lambda c: seen.append(c["new"]), names="change")
    d.paint(3, 5)
    assert seen[-1].kind == "labels" and seen[-1].ids.tolist() == [3] and seen[-1].version == d.version == 1
    d.gain = 3.0
    assert seen[-1].kind == "params" and d.log.events[-1].command == "set_params"


def test_replay_gives_identical_state_bytes():
    d = Toy()
    _session(d)
    e = Toy()
    e.replay(d.log)
    assert e.state_bytes() == d.state_bytes()
    f = Toy()
    CommandLog.from_text(d.log.to_text(), commands=Toy.COMMANDS, document="toy").replay(f)
    assert f.state_bytes() == d.state_bytes()


def test_undo_to_start_and_redo_to_end_identical_bytes():
    d = Toy()
    states = [d.state_bytes()]
    for i in range(4):
        d.paint(i, i + 1)
        d.grow()
        states.append(d.state_bytes())
    while d.undo() is not None:
        pass
    assert d.labels.tobytes() + np.float64(d.total).tobytes() == states[0][:18]
    while d.redo() is not None:
        pass
    assert d.state_bytes() == states[-1]
    assert d.history.nbytes <= d.history.max_bytes and not d.can_redo and d.can_undo


def test_replay_checks_every_event_first():
    d = Toy()
    log = CommandLog(Toy.COMMANDS)
    log.record("paint", i=1, v=1)
    log.record("paint", i=12, v=1)
    with pytest.raises(ValueError, match=r"event 1 \(paint\): i must be"):
        d.replay(log)
    assert d.labels.sum() == 0 and d.version == 0
    with pytest.raises(ValueError, match="command must be one of"):
        log.record("os.system")


def test_log_trailer_names_the_document():
    d = Toy()
    d.paint(1, 2)
    text = d.log.to_text()
    with pytest.raises(ValueError, match="records a 'toy' session"):
        CommandLog.from_text(text, document="treewand")
    with pytest.raises(ValueError, match="checksum"):
        CommandLog.from_text(text.replace('"toy"', '"toz"'))


def test_stage_commit_abort_group_atoms():
    d = Toy()
    d.history.stage()
    d.paint(1, 1)
    d.paint(2, 2)
    d.history.commit()
    assert len(d.history.undo_stack) == 1
    d.undo()
    assert d.labels.sum() == 0
    d.history.stage()
    d.paint(5, 9)
    d.history.abort(d)
    assert d.labels.sum() == 0 and not d.history.staging


def test_history_budget_drops_oldest():
    h = History(max_items=100, max_bytes=200)
    for i in range(10):
        h.push(StateAtom(b"x" * 40, b"y" * 40))
    assert h.nbytes <= 200 and len(h.undo_stack) == 2


def test_params_are_generated_from_the_table_and_checked(tmp_path):
    d = Toy(gain=4.0)
    assert d.gain == 4.0
    with pytest.raises(ValueError, match="gain"):
        d.set_params(gain=11.0)
    with pytest.raises(ValueError, match="unknown parameter"):
        Toy(loss=1.0)
    path = d.save_preset(tmp_path / "p.json")
    e = Toy()
    assert e.load_preset(path) == {"gain": 4.0} and e.gain == 4.0
    assert "| `gain` |" in TOY.reference()


def test_autosave_writes_the_session_after_each_command_and_it_reopens(tmp_path, monkeypatch):
    d = Toy()
    d.enable_autosave(tmp_path / "a.jsonl")
    _session(d)
    assert Toy.from_log(tmp_path / "a.jsonl").state_bytes() == d.state_bytes()
    saves = []
    monkeypatch.setattr(Toy, "save", lambda self, path: saves.append(path))
    e = Toy()
    e.enable_autosave(tmp_path / "b.jsonl")
    e.replay(d.log)
    assert len(saves) == 2  # once when enabled, once at the end of the replay


def test_trimesh_type_matches_trimesh_library():
    m = trimesh.creation.icosphere(2)
    t = TriMesh.from_arrays(m.vertices, m.faces)
    assert t.is_watertight and np.isclose(t.area, m.area) and len(t.edges) == len(m.edges_unique)
    np.testing.assert_allclose(t.face_normals, m.face_normals, atol=1e-12)
    np.testing.assert_allclose(t.bounds, m.bounds)
    open_mesh = TriMesh.from_arrays(m.vertices, m.faces[1:])
    assert not open_mesh.is_watertight
    with pytest.raises(ValueError, match="faces must index"):
        TriMesh.from_arrays(m.vertices, m.faces + 10_000)


def test_tree_arrays_derive_orders_and_check_parents():
    t = TreeArrays.from_arrays([[0, 0, 0], [0, 1, 0], [0, 2, 0], [1, 2, 0]], [-1, 0, 1, 1])
    assert t.order.tolist() == [0, 0, 0, 1] and t.main_child.tolist() == [1, 2, -1, -1]
    assert t.n_internodes == 3 and not t.pos.flags.writeable
    with pytest.raises(ValueError, match=r"parent\[1\]"):
        TreeArrays.from_arrays([[0, 0, 0], [0, 1, 0]], [-1, 1])
    with pytest.raises(ValueError, match="pos"):
        TreeArrays.from_arrays([[0, 0, np.nan]], [-1])


def test_history_block_is_one_undo_item_and_one_logged_command():
    """Issue 31/30: napari-style block_history on the base; undo never crosses into the command before it."""
    d = Toy()
    d.paint(0, 1)
    first = d.state_bytes()
    with d.history_block():
        d.paint(1, 2)
        d.grow()
        with d.history_block():
            d.paint(2, 3)
        with pytest.raises(ValueError, match="inside a history block"):
            d.undo()
    assert len(d.history) == 2 and [e.command for e in d.log] == ["paint", "block"]
    block = d.state_bytes()
    d.undo()
    assert d.state_bytes() == first
    d.redo()
    assert d.state_bytes() == block
    d.gain = 3.0                                  # a parameter change is one item ...
    with d.history_block(amend=True):             # ... and what it caused joins it
        d.grow()
    d.undo()
    assert d.gain == 1.0 and d.state_bytes() == block and d.log.events[-1].command == "undo"
    e = Toy()
    e.replay(d.log)
    assert e.state_bytes() == d.state_bytes() and len(e.history) == len(d.history)
    with pytest.raises(ValueError, match="events"):
        d.block([["undo", {}]])
    with pytest.raises(ValueError, match="amend"), d.history_block(amend="yes"):
        pass


# -- named events (issue 30) ----------------------------------------------------------------------------------
def test_every_document_declares_the_kinds_it_publishes():
    """Each ``changed("kind")`` / ``undoable("kind")`` / ``StateAtom(..., "kind")`` in a document's module names
    a kind of that document's EVENTS (a rerunnable scan; undeclared kinds also raise at run time)."""
    import ast
    import inspect

    import plantvr.documents as D
    from plantvr.document import Document as Base
    docs = [c for c in vars(D).values() if isinstance(c, type) and issubclass(c, Base) and c is not Base]
    assert len(docs) >= 7
    for cls in docs:
        tree = ast.parse(inspect.getsource(inspect.getmodule(cls)))
        used = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and node.args:
                name = getattr(node.func, "attr", getattr(node.func, "id", ""))
                arg = node.args[-1] if name.endswith("Atom") and len(node.args) == 3 else node.args[0]
                if name in ("changed", "undoable") or name.endswith("Atom"):
                    if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                        used.add(arg.value)
        assert used, cls.__name__
        assert used <= set(cls.EVENTS), (cls.__name__, used - set(cls.EVENTS))
        assert cls.EVENTS[:2] == ("all", "params")


def test_on_delivers_the_kinds_asked_for_and_off_stops_it():
    d = Toy()
    got, every = [], []
    d.on(lambda c: got.append(c.kind), "total")
    fn = d.on(every.append)
    d.paint(1, 3)
    d.grow()
    d.flush()
    assert got == ["total"] and [c.kind for c in every] == ["labels", "total"]
    d.off(fn)
    d.off(fn)                                    # twice: a no-op
    d.undo()
    d.flush()
    assert got == ["total", "total"] and len(every) == 2
    with pytest.raises(ValueError, match="kinds"):
        d.on(print, "labelz")
    with pytest.raises(ValueError, match="EVENTS"):
        d.changed("labelz")

"""Every state change is a command (issue 30): a public method of a document that changes state is in its
``COMMANDS`` (door check ``_check_<name>``, logged), and file loads and saved views replay from ``doc.log``.

``python -m pytest tests/test_commands.py -q -k scan`` prints nothing and passes when no document has a public
state-changing method outside its ``COMMANDS`` (``state_changes_not_in_commands()`` lists them otherwise).
"""
import importlib
import inspect
import pkgutil
import re

import numpy as np
import pytest
import trimesh

import plantvr.documents
from plantvr.document import Document
from plantvr.documents.labels import Segmentation
from plantvr.documents.treesketch import SketchDocument
from plantvr.documents.treewand import Model
from plantvr.vine.views import SavedView
from plantvr.vr import CONTROL_MAPS

#: What a state change looks like in a method's source: it publishes a change, replaces the engine, clears the
#: undo history or appends to the saved views.
_MUTATES = re.compile(r"self\.changed\(|self\._engine\s*=[^=]|self\.history\.clear\(|self\.views\.append\(|"
                      r"self\._adopt\(")
#: Hooks the document base calls from inside a command (never called on their own).
_HOOKS = {"apply_param", "on_snapshot", "set_state", "set_transient_state", "restore_params", "before_undo",
          "replay"}     # replay issues logged commands by name (all or nothing): the log it adopts is theirs
#: Headset-bound names that change no state (a file written, a preview drawn).
_READ_ONLY = {"save", "prune_preview"}


def _document_classes() -> list[type]:
    for m in pkgutil.iter_modules(plantvr.documents.__path__):
        importlib.import_module(f"plantvr.documents.{m.name}")
    out, todo = [], list(Document.__subclasses__())
    while todo:
        c = todo.pop()
        todo.extend(c.__subclasses__())
        if c.__module__.startswith("plantvr."):
            out.append(c)
    return sorted(out, key=lambda c: c.__qualname__)


def state_changes_not_in_commands() -> list[str]:
    """``Class.method`` for every public method (of the class, or inherited from a plantvr document) whose source
    changes state (:data:`_MUTATES`) and which is not one of the class's ``COMMANDS``."""
    bad = []
    for cls in _document_classes():
        for name, fn in inspect.getmembers(cls, inspect.isfunction):
            if name.startswith("_") or name in _HOOKS or name in cls.COMMANDS:
                continue
            owner = next(k for k in cls.__mro__ if name in vars(k))
            if not owner.__module__.startswith("plantvr."):
                continue
            if _MUTATES.search(inspect.getsource(fn)):
                bad.append(f"{cls.__name__}.{name}")
    return bad


def test_scan_every_state_change_is_a_command():
    assert state_changes_not_in_commands() == []


@pytest.mark.parametrize("cls", _document_classes(), ids=lambda c: c.__name__)
def test_every_command_has_a_door_check(cls):
    assert all(callable(getattr(cls, f"_check_{c}", None)) for c in cls.COMMANDS), cls


@pytest.mark.parametrize("kind", sorted(CONTROL_MAPS))
def test_every_headset_command_that_changes_state_is_a_command(kind):
    cls = next(c for c in _document_classes() if c.KIND == kind)
    assert set(CONTROL_MAPS[kind].commands) - _READ_ONLY <= set(cls.COMMANDS)


def _grown(seed=0) -> Model:
    m = Model(seed=seed)
    m.paint_stroke([[0.0, y, 0.0] for y in range(2, 6)], radius=1.5)
    m.step(3)
    return m


@pytest.mark.parametrize("suffix", [".tree", ".npz"])
def test_model_restore_is_logged_undoable_and_replays(tmp_path, suffix):
    src = _grown(1)
    src.step(2)
    path = src.save(tmp_path / f"saved{suffix}")
    m = _grown()
    before = m.state_bytes()
    m.restore(path)
    m.step(1)
    ev = [e for e in m.log.events if e.command == "restore"]
    assert len(ev) == 1 and ev[0].kwargs["path"] == str(path.absolute()) and len(ev[0].kwargs["digest"]) == 64
    after = m.state_bytes()
    fresh = Model(seed=0)
    fresh.replay(m.log)
    assert fresh.state_bytes() == after
    m.undo()
    m.undo()                                        # the step, then the restore: the tree before it
    assert m.state_bytes() == before
    # the file changed since: the replay is refused at its door and changes nothing
    _grown(2).save(path)
    other = Model(seed=0)
    with pytest.raises(ValueError, match="changed since the session was recorded"):
        other.replay(m.log)
    assert other.state_bytes() == Model(seed=0).state_bytes() and len(other.log) == 0


def test_model_restore_refuses_a_wrong_digest_and_a_missing_file(tmp_path):
    path = _grown().save(tmp_path / "t.tree")
    m = Model(seed=0)
    with pytest.raises(ValueError, match="digest must be a 64-character"):
        m.restore(path, digest="abc")
    with pytest.raises(ValueError, match="changed since"):
        m.restore(path, digest="0" * 64)
    with pytest.raises(ValueError, match="no such file"):
        m.restore(tmp_path / "missing.tree")
    assert len(m.log) == 0


def _seg() -> Segmentation:
    ico = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    return Segmentation(np.asarray(ico.vertices, np.float32), np.asarray(ico.faces))


def test_segmentation_add_view_and_restore_replay(tmp_path):
    seg = _seg()
    seg.paint(seg.vertices[0], 0.5, 2)
    path = seg.save(tmp_path / "s.npz", include_mesh=False)
    view = SavedView(np.array([1.0, 2.0, 3.0]), np.eye(3), 2.0)
    seg2 = _seg()
    assert seg2.add_view(view) == 0
    seg2.restore(path)
    seg2.add_view(view.to_array())
    seg2.paint(seg2.vertices[5], 0.4, 3)
    assert [e.command for e in seg2.log.events] == ["add_view", "restore", "add_view", "paint"]
    fresh = _seg()
    fresh.replay(seg2.log)
    assert fresh.state_bytes() == seg2.state_bytes() and len(fresh.views) == 1
    with pytest.raises(ValueError, match="view must be a SavedView"):
        seg2.add_view("front")


def test_sketch_restore_is_logged_and_replays(tmp_path):
    a = SketchDocument(seed=3, activation_threshold=0.0)
    a.paint([0.0, 3.0, 0.0], radius=1.5)
    a.grow(4)
    path = a.save(tmp_path / "oak.tree")
    b = SketchDocument(seed=0)
    b.restore(path)
    b.grow(2)
    fresh = SketchDocument(seed=0)
    fresh.replay(b.log)
    assert fresh.state_bytes() == b.state_bytes()


def test_model_regrow_skips_undone_commands_and_is_one_undo_item():
    m = Model(seed=0)
    m.paint_stroke([[0.0, y, 0.0] for y in range(2, 7)], radius=1.5)
    m.step(4)
    m.paint([3.0, 5.0, 0.0], radius=1.5)            # undone: not regrown
    m.undo()
    m.set_params(tropism_angle=120.0)
    n_items = len(m.history.undo_stack)
    assert m.regrow(amend=True) == 2
    assert len(m.history.undo_stack) == n_items          # joined to the parameter's item
    ref = Model(seed=0, tropism_angle=120.0)
    ref.paint_stroke([[0.0, y, 0.0] for y in range(2, 7)], radius=1.5)
    ref.step(4)
    assert m.state_bytes() == ref.state_bytes()
    assert m.log.events[-1].command == "regrow"
    fresh = Model(seed=0)
    fresh.replay(m.log)
    assert fresh.state_bytes() == m.state_bytes()
    m.undo()                                            # parameter and tree together
    assert m.tropism_angle != 120.0 and m.steps_done == 4
    with pytest.raises(ValueError, match="amend must be True or False"):
        m.regrow(amend="yes")

"""The L-system document (issue 23): a session of commands recorded through the log replays to identical state
bytes (also from a saved file), undo to the start and redo to the end are bit-identical under the byte budget, a
bad grammar is refused with the engine's line and column and changes nothing, the derivation is cached and
extended step by step (the same strings as the engine's), and the scene is the interpreted tree, y-up, for the
view, the headset and the exporters."""
import numpy as np
import pytest

import plantvr
from plantvr.commandlog import CommandLog
from plantvr.documents.lsystem import DEFAULT_GRAMMAR, LSystemDocument, y_up
from plantvr.lsystem.engine import LSystem, LSystemError
from plantvr.lsystem.turtle import turtle
from plantvr.types import TreeArrays

from ._history import undo_all_redo_all

#: ABOP fig. 1.24 b (edge rewriting, 25.7 degrees), its angle a declared parameter.
FIG_124B = """\
extern(delta=25.7)
Axiom: F
derivation length: 5
production:
F --> F[+(delta)F]F[-(delta)F][F]
endlsystem
"""
#: ABOP fig. 2.6 (Honda's monopodial tree), parametric, 3-D, with declared parameters.
MONOPODIAL = """\
extern(r1=0.9, r2=0.6, a0=45.0, a2=45.0, d=137.5, wr=0.707)
Axiom: A(1, 0.1)
derivation length: 6
production:
A(l, w) --> _(w)F(l)[&(a0)B(l*r2, w*wr)]/(d)A(l*r1, w*wr)
B(l, w) --> _(w)F(l)[-(a2)$C(l*r2, w*wr)]C(l*r1, w*wr)
C(l, w) --> _(w)F(l)[+(a2)$B(l*r2, w*wr)]B(l*r1, w*wr)
endlsystem
"""


def _session(doc: LSystemDocument) -> None:
    doc.set_step(2)
    doc.set_step(4)                                   # forward: derived on from step 2
    doc.set_step(1)                                   # back: from the cache
    doc.set_externs({"angle": 35.0})
    doc.set_grammar(FIG_124B)
    doc.grow(-2)
    doc.set_externs({"delta": 30.0})
    doc.set_seed(7)
    doc.set_grammar(MONOPODIAL, step=4)
    doc.set_externs({"r1": 0.8, "a0": 30.0})
    doc.grow()
    doc.undo()
    doc.redo()


def test_replay_of_the_log_gives_identical_state_bytes(tmp_path):
    doc = LSystemDocument()
    _session(doc)
    assert [e.command for e in doc.log][:2] == ["reset", "set_step"]       # the constructor logs the start
    assert {e.command for e in doc.log} == set(LSystemDocument.COMMANDS) - {"block"}   # block: the base's
    fresh = LSystemDocument()
    fresh.replay(doc.log)
    assert fresh.state_bytes() == doc.state_bytes()
    log = CommandLog.from_text(doc.log.to_text(), commands=LSystemDocument.COMMANDS, document="lsystem")
    again = LSystemDocument(FIG_124B, step=1)                 # any starting point: the log starts with reset
    again.replay(log)
    assert again.state_bytes() == doc.state_bytes()
    path = doc.save(tmp_path / "session.jsonl")               # save / load through the base: the command log
    back = LSystemDocument.from_log(path)
    assert back.state_bytes() == doc.state_bytes()
    assert (back.text, back.step, back.overrides, back.seed) == (MONOPODIAL, 5, {"r1": 0.8, "a0": 30.0}, 7)


def test_undo_to_the_start_and_redo_to_the_end_are_bit_identical():
    doc = LSystemDocument()
    start = doc.state_bytes()
    assert not doc.can_undo
    _session(doc)
    assert undo_all_redo_all(doc, start, doc.state_bytes()) == 11
    while doc.can_undo:
        doc.undo()
    assert (doc.text, doc.step, doc.overrides, doc.seed) == (DEFAULT_GRAMMAR, 5, {}, 0)


def test_a_bad_command_is_refused_with_line_and_column_and_changes_nothing():
    doc = LSystemDocument(FIG_124B, step=3)
    before, log, version = doc.state_bytes(), doc.log.to_text(), doc.version
    bad = FIG_124B.replace("F --> F[", "F --> F(1,,2)[")
    with pytest.raises(LSystemError) as info:
        doc.set_grammar(bad)
    assert info.value.line == 5 and info.value.column >= 1 and "line 5" in str(info.value)
    with pytest.raises(LSystemError):
        doc.check_command("set_grammar", {"text": bad})        # the door check reads the grammar
    with pytest.raises(ValueError, match="step must be an integer"):
        doc.set_step(-1)
    with pytest.raises(ValueError, match="'angle' is not a declared parameter"):
        doc.set_externs({"angle": 3.0})
    with pytest.raises(ValueError, match=r"externs\['delta'\] must be finite"):
        doc.set_externs({"delta": float("nan")})
    with pytest.raises(ValueError, match="text must be the grammar"):
        doc.set_grammar(None)
    with pytest.raises(ValueError, match="seed"):
        doc.set_seed(-3)
    assert (doc.state_bytes(), doc.log.to_text(), doc.version) == (before, log, version)
    with pytest.raises(LSystemError):
        LSystemDocument(bad)
    events = CommandLog(LSystemDocument.COMMANDS, document="lsystem")
    events.record("set_step", step=2)
    events.record("set_grammar", text=bad)
    fresh = LSystemDocument(FIG_124B, step=3)
    with pytest.raises(ValueError, match="event 1"):         # the whole log is checked before anything runs
        fresh.replay(events)
    assert fresh.state_bytes() == before


def test_the_derivation_is_cached_and_extended_step_by_step():
    doc = LSystemDocument(MONOPODIAL, step=0)
    ref = LSystem(MONOPODIAL)
    for n in (3, 1, 6, 2):
        doc.set_step(n)
        s, r = doc.string, ref.derive(n)
        assert np.array_equal(s.ids, r.ids) and np.array_equal(s.args, r.args) and s.names == r.names
    cache = doc._derivation(doc.text, doc.overrides, doc.seed, doc.trusted)
    assert len(cache.strings) == 7                              # steps 0..6 derived once, kept
    strings = list(cache.strings)
    doc.set_step(4)
    assert all(a is b for a, b in zip(cache.strings, strings)) and doc.string is strings[4]
    tree = turtle(ref.interpret(ref.derive(4)), **ref.turtle_options)
    assert np.array_equal(doc.tree.pos, tree.pos) and np.array_equal(doc.tree.parent, tree.parent)
    doc.set_externs({"r1": 0.5})                                # a new parameter value: a new derivation
    assert doc._derivation(doc.text, doc.overrides, doc.seed, doc.trusted) is not cache
    assert np.array_equal(doc.string.args, LSystem(MONOPODIAL, r1=0.5).derive(4).args)
    assert doc.externs == {**LSystem(MONOPODIAL).externs, "r1": 0.5} and doc.defaults == LSystem(MONOPODIAL).externs
    doc.undo()                                                  # the old cache is still there
    assert doc._derivation(doc.text, doc.overrides, doc.seed, doc.trusted) is cache


def test_parameters_survive_a_grammar_edit_that_still_declares_them():
    doc = LSystemDocument(MONOPODIAL, step=3)
    doc.set_externs({"r1": 0.7, "d": 90.0})
    doc.set_grammar(MONOPODIAL.replace("d=137.5, ", "").replace("/(d)", "/(137.5)"))
    assert doc.overrides == {"r1": 0.7} and doc.step == 6       # d is no longer declared; step: the new length


def test_scene_is_the_interpreted_tree_y_up_for_views_headset_and_exporters(tmp_path):
    from plantvr import vr
    from plantvr.io.tree import export_tree, tree_geometry
    from plantvr.params import TREEWAND

    doc = LSystemDocument(MONOPODIAL, step=5)
    seen = []
    doc.observe(lambda ch: seen.append(ch["new"]), names="change")
    tree = doc.scene()["tree"]
    assert isinstance(tree, TreeArrays) and tree.n_internodes == doc.tree.n_internodes > 20
    assert np.allclose(tree.pos[:, 1], doc.tree.pos[:, 2]) and np.allclose(tree.pos[:, 2], -doc.tree.pos[:, 1])
    assert tree.pos[:, 1].max() > 3 and np.array_equal(y_up(doc.tree).order, doc.tree.order)
    doc.grow()
    assert seen[-1].kind == "lsystem" and seen[-1].command == "grow" and doc.latest is doc.tree
    view = plantvr.View(doc, off_screen=True, window_size=(160, 120))
    assert view.tree is not None and len(view.tree.pos) == len(doc.tree.pos)
    assert "tree" in view.snapshot()                           # what a headset draws: the View's layers
    view.close()
    headset = vr.attach(doc)                                   # the headset's control map: undo / redo
    assert set(headset.controls.cmap.commands) >= {"undo", "redo"}
    branches, _ = tree_geometry(doc.scene()["tree"], TREEWAND.defaults(), leaves=False)
    for suffix in (".ply", ".glb"):
        path = export_tree(tmp_path / f"plant{suffix}", branches)
        assert path.stat().st_size > 1000


#: ABOP fig. 1.27, the stochastic bush, as L-Py writes it.
STOCHASTIC = """\
Axiom: F
derivation length: 5
production:
F :
    r = random()
    if r < 0.33:
        produce F[+(25.7)F]F[-(25.7)F]F
    elif r < 0.66:
        produce F[+(25.7)F]F
    else:
        produce F[-(25.7)F]F
endlsystem
"""


def test_seeded_stochastic_steps_are_the_engines_however_they_are_reached():
    doc = LSystemDocument(STOCHASTIC, step=0, seed=11, trusted=True)
    for n in (2, 1, 3, 4):                        # dragged back and forth: each step is derive(n) of the seed
        doc.set_step(n)
        assert np.array_equal(doc.string.ids, LSystem(STOCHASTIC, seed=11, trusted=True).derive(n).ids)
    at4 = doc.state_bytes()
    direct = LSystemDocument(STOCHASTIC, step=4, seed=11, trusted=True)
    assert direct.state_bytes() == doc.state_bytes() == at4
    doc.set_seed(12)
    assert doc.string.count("F") != direct.string.count("F") or not np.array_equal(doc.string.ids,
                                                                                     direct.string.ids)
    doc.undo()
    assert doc.state_bytes() == at4
    doc.set_step(1)
    doc.set_step(4)                               # back to step 4 from the cache: the same tree
    assert doc.state_bytes() == at4


def test_a_step_that_does_not_derive_is_refused_and_changes_nothing():
    grammar = "Axiom: A(3)\nderivation length: 2\nproduction:\nA(x) --> A(x-1)B(1/(x-1))\nendlsystem\n"
    doc = LSystemDocument(grammar)
    assert str(doc.string) == "A(1)B(1)B(0.5)"
    before, log = doc.state_bytes(), doc.log.to_text()
    for step in (3, 4, 3):                            # step 3 divides by zero; it fails the same way each time
        with pytest.raises(LSystemError, match="line 4, column 1: rule 'A\\(x\\)' raised ZeroDivisionError"):
            doc.set_step(step)
    with pytest.raises(LSystemError):
        doc.set_grammar(grammar.replace("A(3)", "A(4)"), step=4)
    assert (doc.state_bytes(), doc.log.to_text()) == (before, log)
    doc.set_step(1)
    assert str(doc.string) == "A(2)B(0.5)"


#: A grammar with Python code (a function and a rule body): it runs only trusted (issue 34).
CODE = """\
def side():
    nproduce [+F]
Axiom: A(2)
derivation length: 3
production:
A(n) :
    if n > 0:
        side()
        produce F A(n - 1)
endlsystem
"""


def test_grammars_are_code_trusted_is_part_of_the_state_and_the_log(tmp_path):
    doc = LSystemDocument(FIG_124B, step=2)
    before, log = doc.state_bytes(), doc.log.to_text()
    with pytest.raises(LSystemError, match=r"line 1, column 1: a function definition runs Python code.*trusted=True"):
        doc.set_grammar(CODE)
    for hostile in ("x = open('/etc/passwd')\nAxiom: F\n", "import os\nAxiom: F\n",
                    "x = ().__class__.__subclasses__()\nAxiom: F\n", "Axiom: F\nderivation length: 9**9**9\n",
                    "Axiom: A\nproduction:\nA :\n    while True: pass\n    produce A\nendlsystem\n"):
        with pytest.raises(LSystemError) as err:
            doc.set_grammar(hostile)
        assert err.value.line >= 1
    assert doc.state_bytes() == before and doc.log.to_text() == log and not doc.trusted
    doc.set_grammar(CODE, trusted=True)
    assert doc.trusted and str(doc.string) == "[+F]F[+F]FA(0)"
    assert doc.log.events[-1].kwargs == {"text": CODE, "step": 3, "trusted": True}
    doc.set_seed(3)                                           # later commands keep the grammar's trust
    assert doc.trusted
    doc.set_grammar(FIG_124B)                                 # each grammar is trusted on its own
    assert not doc.trusted
    doc.undo()
    assert doc.trusted and str(doc.string) == "[+F]F[+F]FA(0)"
    path = doc.save(tmp_path / "session.jsonl")
    with pytest.raises(ValueError, match=r"event 1 \(set_grammar\): this log trusted its grammar.*trusted=True"):
        LSystemDocument.from_log(path)
    with pytest.raises(ValueError, match="this log trusted its grammar"):
        LSystemDocument().replay(CommandLog.load(path, LSystemDocument.COMMANDS, document="lsystem"))
    again = LSystemDocument.from_log(path, trusted=True)
    assert again.state_bytes() == doc.state_bytes()


def test_trusted_documents_from_the_constructor_and_files(tmp_path):
    with pytest.raises(LSystemError, match="trusted=True"):
        LSystemDocument(CODE)
    doc = LSystemDocument(CODE, trusted=True)
    assert doc.trusted and doc.log.events[0].kwargs["trusted"] is True
    p = tmp_path / "code.lpy"
    p.write_text(CODE)
    with pytest.raises(LSystemError, match="trusted=True"):
        LSystemDocument.from_file(p)
    assert LSystemDocument.from_file(p, trusted=True).state_bytes() == doc.state_bytes()
    with pytest.raises(ValueError, match="trusted must be True or False"):
        doc.set_grammar(CODE, trusted="yes")
    with pytest.raises(LSystemError, match="line 2, column 1: derivation length 5000 is more than"):
        doc.set_grammar("Axiom: F\nderivation length: 5000\n")
    slow = LSystemDocument(time_budget=0.5)
    with pytest.raises(LSystemError, match="time budget of 0.5 s exceeded"):
        slow.set_grammar("Axiom: A\nproduction:\nA :\n    while True: pass\n    produce A\nendlsystem\n",
                         trusted=True)
    assert not slow.trusted and slow.text == DEFAULT_GRAMMAR


def test_from_file_takes_unsupported_and_names_a_file_that_is_not_utf8(tmp_path):
    """Issue 33: ``LSystemDocument.from_file(..., unsupported=)`` as ``LSystem``'s; bad bytes name the file."""
    p = tmp_path / "flower.lpy"
    p.write_text("Axiom: F(1)Arrow(0.5)F(1)\n")
    with pytest.raises(LSystemError, match="line 1, column 12: unsupported module Arrow"):
        LSystemDocument.from_file(p)
    with pytest.warns(UserWarning, match=r"not drawn .*Arrow \(line 1\)"):
        doc = LSystemDocument.from_file(p, unsupported="warn")
    assert doc.tree.n_internodes == LSystem("Axiom: F(1)F(1)\n").tree().n_internodes
    with pytest.raises(ValueError, match="unsupported must be one of"):
        LSystemDocument.from_file(p, unsupported="skip")
    bad = tmp_path / "latin1.lpy"
    bad.write_bytes("# café\nAxiom: F\n".encode("latin-1"))
    with pytest.raises(LSystemError, match=r"line 1, column 6: grammar '.*latin1.lpy' is not UTF-8 text"):
        LSystemDocument.from_file(bad)

"""V28, V31 and command errors: the thesis command language run in a crown document, sessions logged and replayed
(spec 003 §5.1)."""
import numpy as np
import pytest

from plantvr.commandlog import CommandLog
from plantvr.documents.crown import CrownDocument
from plantvr.implicit import CommandError, Difference, load_point_set, parse_script

SCRIPT1 = "sphere s1\nline s2\ndiff s1 s2 s3\n"
SCRIPT2 = "sphere s\nscale s 50 80 50\npoint_set_gen s poisson poisson.props\nsave_point_set points.txt\n"
SCRIPT3 = "point_set_thin crown secondary 80\n"


@pytest.fixture
def session(tmp_path):
    (tmp_path / "poisson.props").write_text("min_distance = 3\nnum_points = 400\ngrid = 32\n")
    return CrownDocument(base_dir=tmp_path, seed=1)


def test_v28_thesis_scripts_run_verbatim(session, tmp_path):
    session.run(SCRIPT1)
    assert isinstance(session.surface("s3"), Difference)
    session.run(SCRIPT2)
    # Lane without exact mode: points may leave the enabled cells by up to one cell diagonal (spec §3.4 caveat)
    assert len(session.points) == 400 and np.mean(session.surface("s").inside(session.points.points)) > 0.95
    back = load_point_set(tmp_path / "points.txt")
    assert np.allclose(back.points, session.points.points, rtol=1e-5, atol=1e-4)
    lines = [ln for ln in (tmp_path / "points.txt").read_text().splitlines() if not ln.startswith("#")]
    assert len(lines) == 400
    session.run("sphere crown 60\nsphere secondary 30\npoint_set_gen crown uniform num_points=1000\n")
    n_crown_before = int(np.sum(session.points.tags == session.points.sources.index("crown:uniform")))
    inside = session.surface("secondary").inside(session.points.points)
    crown_tag = session.points.tags == session.points.sources.index("crown:uniform")
    n_in = int((inside & crown_tag).sum())
    session.run(SCRIPT3)
    n_crown_after = int(np.sum(session.points.tags == session.points.sources.index("crown:uniform")))
    assert n_crown_before - n_crown_after == int(np.floor(0.8 * n_in))


def test_v31_session_replay_is_identical(session, tmp_path):
    session.run(SCRIPT1 + SCRIPT2 + "sphere sec 40\npoint_set_densify sec 50 min_distance=2\n")
    session.log.save(tmp_path / "session.log")
    log = CommandLog.load(tmp_path / "session.log", CrownDocument.COMMANDS, document="crown")
    again = CrownDocument(base_dir=tmp_path, seed=1)
    again.replay(log)
    assert again.points.points.tobytes() == session.points.points.tobytes()
    other = CrownDocument(base_dir=tmp_path, seed=2)
    other.replay(log)
    assert not np.array_equal(other.points.points, session.points.points)


def test_v31_script_files_run_as_input(session, tmp_path):
    (tmp_path / "script.cmd").write_text(SCRIPT1 + SCRIPT2)
    session.run_file(tmp_path / "script.cmd")
    again = CrownDocument(base_dir=tmp_path, seed=1).run(SCRIPT1 + SCRIPT2)
    assert again.state_bytes() == session.state_bytes()
    assert [e.kwargs["text"] for e in session.log] == [SCRIPT1 + SCRIPT2]


def test_all_modeling_commands(session):
    session.run("""
        sphere a 2 0 0 0
        line b 1 0 0 0 0 2 0
        torus t 1.5 0.8
        polyline p 0.6 0 0 0 1 0 0 1 1 0
        revolve r 0.5 0 0 1 0 0.5 1 0 1.5
        sweep w 0.4 0.3 0 0 0 0 1 0 0.5 2 0
        skin k 0.6 linear 0 0 0 0 1 0 0 2 0 | 0 0.3 0.5 0.2 1 0.3
        blend a b c
        union a t u
        inter a b i
        diff2 a b d2
        copy c c2
        translate c2 1 0 0
        rotate c2 0 1 0 45
        twist c2 0.5
        taper b 0.1
        bend p 0.3 1.0
        delete i
    """)
    assert {"a", "b", "c", "t", "p", "r", "w", "k", "u", "d2", "c2"} <= set(session.surfaces)
    assert "i" not in session.surfaces
    for name in ("c", "r", "w", "k", "c2"):
        node = session.surface(name)
        lo, hi = node.bbox
        g = np.random.default_rng(0).uniform(lo, hi, (4000, 3))
        assert node.inside(g).any()


@pytest.mark.parametrize("dist", ["uniform", "cluster", "near_boundary", "inverse_field", "outside_near"])
def test_distributions(session, dist):
    exact = " exact=true" if dist == "near_boundary" else ""     # a thin band needs the exact test
    session.run(f"sphere s 20\npoint_set_gen s {dist} num_points=200 min_distance=0.5 grid=32{exact}\n")
    assert len(session.points) == 200
    f = session.surface("s").field(session.points.points)
    if dist == "outside_near":
        assert np.all((f > 0.4) & (f < 0.5))
    else:
        assert np.mean(f > 0.5) > 0.95


def test_errors_name_line_and_token_and_leave_state(session):
    session.run("sphere a")
    before = dict(session.surfaces)
    with pytest.raises(CommandError, match=r"line 2: token 'x': expected a number"):
        session.run("sphere b\nscale b 1 x 2")
    assert session.surfaces == before and session.lines == ["sphere a"]
    with pytest.raises(CommandError, match=r"line 1: token 'sphre': unknown command"):
        session.run("sphre q")
    with pytest.raises(CommandError, match=r"line 1: token 'zz': no surface"):
        session.run("diff a zz c")
    with pytest.raises(CommandError, match=r"line 1: token 'nope.props': props file does not exist"):
        session.run("point_set_gen a poisson nope.props")
    with pytest.raises(CommandError, match=r"token 'gaussian': unknown distribution"):
        session.run("point_set_gen a gaussian")
    with pytest.raises(CommandError, match="token 'grow': no attraction points"):
        session.run("grow")
    with pytest.raises(CommandError, match="empty"):
        session.run("sphere far 1 100 100 100\ninter a far e\npoint_set_gen e poisson")
    with pytest.raises(CommandError, match="token 'diff': expected diff A B RESULT"):
        session.run("diff a a")
    assert session.surfaces == before


def test_parse_script_comments_and_counts():
    cmds = parse_script("# crown\nsphere s  # primitive\n\nscale s 1 2 1\n")
    assert [c.name for c in cmds] == ["sphere", "scale"] and cmds[1].lineno == 4

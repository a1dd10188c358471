"""Fuzzing every CLI subcommand: each bad argument or input file ends in one line + exit code 2 (issue 20)."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantvr import cli

BAD = {"--steps": ["-1", "0", "nan", "inf", "-inf", "1e300", "10000000000000", "x", "", "1.5"],
       "--seed": ["-1", "nan", "inf", "-inf", "1e300", "100000000000000000000", "x", "", "1.5"]}


def _run(argv):
    """rc and stderr of ``plantvr argv`` (argparse's usage errors are SystemExit(2))."""
    try:
        return cli.main(argv)
    except SystemExit as exc:
        return exc.code


def _assert_clear(capsys, argv, rc):
    err = capsys.readouterr().err
    assert rc == 2, (argv, rc, err)
    assert "Traceback" not in err, (argv, err)
    last = err.strip().splitlines()[-1] if err.strip() else ""
    assert last.startswith("plantvr") and "error:" in last, (argv, err)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_demo_bad_numbers(capsys, data):
    flag = data.draw(st.sampled_from(sorted(BAD)))
    value = data.draw(st.sampled_from(BAD[flag]))
    argv = ["demo", flag, value, "--no-install"]
    _assert_clear(capsys, argv, _run(argv))


@pytest.fixture(scope="module")
def saved_tree(tmp_path_factory):
    import plantvr
    d = tmp_path_factory.mktemp("tree")
    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 6)], radius=1.5)
    m.step(5)
    return m.save(d / "t.tree")


def _export_cases(tree, tmp):
    (tmp / "garbage.tree").write_bytes(b"\x00\xffnot a tree")
    (tmp / "empty.tree").write_text("")
    (tmp / "trunc.tree").write_text(tree.read_text()[: len(tree.read_text()) // 2])
    (tmp / "a_dir.tree").mkdir(exist_ok=True)
    return [
        [str(tmp / "missing.tree")], [str(tmp / "garbage.tree")], [str(tmp / "empty.tree")],
        [str(tmp / "trunc.tree")], [str(tmp / "a_dir.tree")], [str(tree), "--format", "stl"],
        [str(tree), "--lod", "-1"], [str(tree), "--lod", "99"], [str(tree), "--lod", "x"],
        [str(tree), "-o", str(tmp / "missing" / "o.ply")], [str(tree), "-o", str(tmp / "o.xyz")],
        [str(tmp / "t.txt")],
    ]


def test_export_bad_input(capsys, saved_tree, tmp_path):
    for args in _export_cases(saved_tree, tmp_path):
        _assert_clear(capsys, ["export", *args], _run(["export", *args]))


def test_segment_bad_input(capsys, tmp_path):
    np.save(tmp_path / "empty.npy", np.zeros((0, 4, 4), np.uint8))
    np.save(tmp_path / "flat.npy", np.zeros((8, 8, 8), np.uint8))
    np.save(tmp_path / "twod.npy", np.zeros((8, 8), np.uint8))
    (tmp_path / "junk.tif").write_bytes(b"II*\x00garbage")
    (tmp_path / "junk.npz").write_bytes(b"PK\x03\x04" + b"\0" * 30)
    out = str(tmp_path / "o")
    cases = [
        ["synth:16", "--faces", "-1", "--out", out], ["synth:16", "--stamps", "0", "--out", out],
        ["synth:16", "--lod", "-5", "--out", out], ["synth:16", "--level", "nan", "--out", out],
        ["synth:16", "--port", "99999999", "--out", out], ["synth:0", "--out", out], ["synth:x", "--out", out],
        [str(tmp_path / "empty.npy"), "--out", out], [str(tmp_path / "flat.npy"), "--out", out],
        [str(tmp_path / "twod.npy"), "--out", out], [str(tmp_path / "junk.tif"), "--out", out],
        [str(tmp_path / "junk.npz"), "--out", out], [str(tmp_path / "missing.npy"), "--out", out],
        [str(tmp_path / "file.xyz"), "--out", out],
    ]
    for args in cases:
        _assert_clear(capsys, ["segment", *args], _run(["segment", *args]))


def test_unknown_subcommand(capsys):
    _assert_clear(capsys, ["frobnicate"], _run(["frobnicate"]))

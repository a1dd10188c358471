"""Bad command-line input ends in one line on stderr and exit code 2, never a traceback (issue 20 item 10)."""
import pytest

from plantvr import cli


def _one_line_error(capsys, argv, match):
    try:
        rc = cli.main(argv)
    except SystemExit as exc:  # argparse's usage errors
        rc = exc.code
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("plantvr ") and "error:" in last and match in last, err
    return last


@pytest.mark.parametrize("argv, match", [
    (["demo", "--seed", "-1"], "--seed"),
    (["demo", "--seed", "x"], "--seed"),
    (["demo", "--steps", "0"], "--steps must be >= 1"),
    (["demo", "--steps", "10000000000"], "--steps"),
])
def test_demo_arguments(capsys, argv, match):
    _one_line_error(capsys, argv, match)


def test_demo_out_that_cannot_be_made(capsys, tmp_path):
    (tmp_path / "file").write_text("x")
    _one_line_error(capsys, ["demo", "--out", str(tmp_path / "file" / "sub"), "--no-install"], "--out")


def test_value_errors_from_a_command_are_one_line(capsys, monkeypatch):
    def bad(*a, **k):
        raise ValueError("radius must be in (0, 1e6], got -1")
    monkeypatch.setattr(cli, "demo", bad)
    last = _one_line_error(capsys, ["demo"], "radius must be")
    assert last == "plantvr demo: error: radius must be in (0, 1e6], got -1"


def test_os_errors_name_the_file(capsys, monkeypatch):
    def bad(*a, **k):
        raise FileNotFoundError(2, "No such file or directory", "/missing/o.ply")
    monkeypatch.setattr(cli, "demo", bad)
    _one_line_error(capsys, ["demo"], "/missing/o.ply")


def test_no_install_only_says_what_is_missing(capsys, monkeypatch):
    calls = []
    monkeypatch.setattr(cli, "_egl_missing", lambda: True)
    monkeypatch.setattr(cli.subprocess, "run", lambda *a, **k: calls.append(a))
    cli.ensure_system_packages(browser=False, install=False)
    err = capsys.readouterr().err
    assert calls == [] and "libegl1" in err and "offscreen" in err


def test_install_says_what_and_why_first(capsys, monkeypatch):
    calls = []
    monkeypatch.setattr(cli, "_egl_missing", lambda: True)
    monkeypatch.setattr(cli.shutil, "which", lambda name: "/usr/bin/" + name)
    monkeypatch.setattr(cli.os, "geteuid", lambda: 0)
    monkeypatch.setattr(cli.subprocess, "run", lambda args, **k: calls.append(args))
    cli.ensure_system_packages(browser=False)
    out = capsys.readouterr().out
    assert "installing" in out and "libegl1" in out and "--no-install" in out
    assert calls[-1][:2] == ["apt-get", "install"] and "libegl1" in calls[-1]
    assert out.startswith("plantvr: installing")  # said before apt-get ran


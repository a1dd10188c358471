"""Shared test fixtures: offscreen rendering and deterministic seeds."""
import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")


# -- soak test (issue 31): 200 operations in the suite (< 60 s), --soak for a long run ------------------------
def pytest_addoption(parser):
    parser.addoption("--soak", action="store_true", default=False,
                     help="run the soak test (tests/ui/test_soak.py) long: 1000 operations instead of 200")


# -- fuzz harness (issue 20): every fuzzed call ends in a result or a clear error raised by PlantVR --------
import json  # noqa: E402
import traceback  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

_FUZZ = {"entries": set(), "inputs": 0, "errors": 0}
_PLANTVR = str(Path(__file__).resolve().parent.parent / "plantvr")


class Fuzz:
    """Record fuzzed calls of public entry points and assert each one ends well.

    ``fuzz.call("Model.paint", m.paint, center, radius=r)`` returns the result, or the exception when the
    call raised a ``ValueError``/``TypeError`` from PlantVR's own code (a clear error at the door). Any other
    exception, or one raised inside numpy/numba/scipy rather than by PlantVR, fails the test. ``param``
    (a name or a tuple of names) must appear in the error message when given.
    """

    def call(self, entry: str, fn, *args, param=None, **kwargs):
        _FUZZ["entries"].add(entry)
        _FUZZ["inputs"] += 1
        try:
            return fn(*args, **kwargs)
        except (ValueError, TypeError) as exc:
            frames = traceback.extract_tb(exc.__traceback__)
            where = frames[-1].filename if frames else ""
            if not where.startswith(_PLANTVR):
                pytest.fail(f"{entry}: {type(exc).__name__} raised outside PlantVR ({where}:"
                            f"{frames[-1].lineno if frames else '?'}): {exc}")
            names = (param,) if isinstance(param, str) else (param or ())
            if names and not any(n in str(exc) for n in names):
                pytest.fail(f"{entry}: error does not name {names}: {exc}")
            _FUZZ["errors"] += 1
            return exc


@pytest.fixture
def fuzz() -> Fuzz:
    """The fuzz harness (see :class:`Fuzz`)."""
    return Fuzz()


def pytest_sessionfinish(session):
    """An xdist worker hands its fuzz counts to the controller (``pytest_testnodedown``)."""
    out = getattr(session.config, "workeroutput", None)
    if out is not None:
        out["fuzz"] = {**_FUZZ, "entries": sorted(_FUZZ["entries"])}


@pytest.hookimpl(optionalhook=True)       # an xdist hook: -p no:xdist runs without it
def pytest_testnodedown(node, error):
    got = getattr(node, "workeroutput", {}).get("fuzz")
    if got:
        _FUZZ["entries"].update(got["entries"])
        _FUZZ["inputs"] += got["inputs"]
        _FUZZ["errors"] += got["errors"]


def pytest_terminal_summary(terminalreporter):
    if _FUZZ["inputs"]:
        line = (f"fuzz: {len(_FUZZ['entries'])} entry points, {_FUZZ['inputs']} inputs, "
                f"{_FUZZ['errors']} clear errors, 0 crashes")
        terminalreporter.write_line(line)
        out = os.environ.get("PLANTVR_FUZZ_REPORT")
        if out:
            Path(out).write_text(json.dumps({**_FUZZ, "entries": sorted(_FUZZ["entries"])}, indent=1))

"""Command line: ``plantvr demo | lab | info | params | test | export | segment | warmup``."""
from __future__ import annotations

import argparse
import importlib
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["main"]

ROOT = Path(__file__).resolve().parent.parent


def demo(out: Path, steps: int, seed: int, *, install: bool = True) -> dict:
    """Grow a tree from the built-in strokes and write tree.ply, tree.glb and tree.png to ``out``.

    With ``install`` (the default, so the README's first command sets up a fresh machine), Debian's EGL/Mesa
    packages are installed through ``apt-get`` when offscreen rendering would otherwise be impossible.
    """
    from tqdm import tqdm

    from . import Model
    from .io.tree import export_model, tree_geometry
    from .growth.scenarios import demo_session, run

    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out {str(out)!r} cannot be created: {exc.strerror or exc}") from None
    ensure_system_packages(browser=False, install=install)
    model = Model(seed=seed)
    t0 = time.perf_counter()
    stats = run(model, demo_session(), steps, tqdm(range(steps), desc="growing", unit="step"))
    grow_s = time.perf_counter() - t0
    parts = [m for m in tree_geometry(model.snapshot, model.params) if m is not None]
    export_model(model, out / "tree.ply")
    export_model(model, out / "tree.glb")
    model.save(out / "tree.tree")
    from .view import View
    view = View(model, off_screen=True, window_size=(1000, 1000))
    view.screenshot(out / "tree.png")
    view.close()
    ms = [s.ms for s in stats]
    print(f"{model.n_internodes} internodes after {steps} steps; {1e3 * grow_s / max(steps, 1):.2f} ms/step "
          f"(median growth step {sorted(ms)[len(ms) // 2]:.2f} ms, max {max(ms):.2f} ms)")
    print(f"mesh: {sum(m.n_vertices for m in parts)} vertices, {sum(m.n_faces for m in parts)} faces")
    for name in ("tree.ply", "tree.glb", "tree.tree", "tree.png"):
        print(f"wrote {out / name}")
    return {"internodes": model.n_internodes, "ms_per_step": 1e3 * grow_s / max(steps, 1)}


def info() -> None:
    """Print versions and which optional parts work here."""
    from . import __version__
    print(f"plantvr {__version__}  python {platform.python_version()}  {platform.platform()}")
    for mod in ("numpy", "scipy", "numba", "skimage", "trimesh", "pyvista", "vtk", "trame", "ipywidgets",
                "anywidget", "openvr", "dask", "distributed"):
        try:
            m = importlib.import_module(mod)
            print(f"  {mod:12s} {getattr(m, '__version__', 'ok')}")
        except Exception as exc:  # report, never fail
            print(f"  {mod:12s} missing ({type(exc).__name__})")
    try:
        from .types import TriMesh
        from .view import View
        v = View({"triangle": TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])}, off_screen=True,
                 window_size=(64, 64))
        v.screenshot()
        v.close()
        print("  offscreen rendering: ok")
    except Exception as exc:
        print(f"  offscreen rendering: FAILED ({exc})")
    print(f"  chromium (browser tests): {shutil.which('chromium') or 'missing'}")


def _egl_missing() -> bool:
    import ctypes.util  # noqa: PLC0415
    return ctypes.util.find_library("EGL") is None


_WHY = {"libegl1": "EGL, for offscreen VTK rendering", "libgl1-mesa-dri": "Mesa's software OpenGL driver",
        "chromium": "headless Chromium, for the browser tests"}


def ensure_system_packages(*, browser: bool = True, install: bool = True) -> None:
    """Install Debian's EGL/Mesa (offscreen VTK) and, for tests, chromium, when missing and possible.

    Says what it installs and why before running ``apt-get`` (as root only); ``install=False``
    (``--no-install``) only says what is missing.
    """
    need = ["libegl1", "libgl1-mesa-dri"] if _egl_missing() else []
    if browser and not shutil.which("chromium"):
        need.append("chromium")
    if not need:
        return
    why = "; ".join(f"{n} ({_WHY[n]})" for n in need)
    if not install or not shutil.which("apt-get") or os.geteuid() != 0:
        print(f"plantvr: missing system packages: {why}. Install them with `apt-get install {' '.join(need)}`; "
              "until then rendering or browser tests may be skipped", file=sys.stderr)
        return
    print(f"plantvr: installing system packages with apt-get (pass --no-install to skip): {why}", flush=True)
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    subprocess.run(["apt-get", "update", "-qq"], check=False, env=env)
    subprocess.run(["apt-get", "install", "-y", "-qq", *need], check=False, env=env)


#: The bounds-checked pass of ``plantvr test``: every test that drives numba kernels, recompiled with
#: ``NUMBA_BOUNDSCHECK=1`` into a cache of its own (issue 20), so an out-of-bounds index fails as IndexError.
BOUNDSCHECK_TESTS = ["tests", "-m", "not browser and not slow", "--ignore=tests/ui", "--ignore=tests/view",
                     "--ignore=tests/test_benchmarks.py", "--ignore=tests/test_cli.py", "--ignore=tests/test_view.py"]


def test(extra: list[str], *, install: bool = True, boundscheck: bool = True) -> int:
    """Install system packages the tests need, run pytest on tests/ and the notebooks (nbval), then the
    kernel tests once more with numba bounds checking."""
    ensure_system_packages(install=install)
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    os.environ.setdefault("MPLBACKEND", "Agg")
    common = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--timeout", "900", *_workers(extra)]
    args = [*common, "tests", "notebooks", "--nbval-lax", *extra]
    print("+", " ".join(args), flush=True)
    rc = subprocess.call(args, cwd=ROOT)
    if rc != 0 or extra or not boundscheck:
        return rc
    import tempfile  # noqa: PLC0415
    with tempfile.TemporaryDirectory(prefix="plantvr-nbc-") as cache:
        env = {**os.environ, "NUMBA_BOUNDSCHECK": "1", "NUMBA_CACHE_DIR": cache}
        args = [*common, "-q", *BOUNDSCHECK_TESTS]
        print("+ NUMBA_BOUNDSCHECK=1", " ".join(args), flush=True)
        return subprocess.call(args, cwd=ROOT, env=env)


def _workers(extra: list[str]) -> list[str]:
    """pytest-xdist options: one worker per core (at most 4), a test file per worker so module fixtures and a
    notebook's cells stay together; none when ``extra`` chooses (``-n``/``-p no:xdist``) or on one core."""
    n = min(4, os.cpu_count() or 1)
    if n < 2 or any(a.startswith(("-n", "--numprocesses", "--dist")) or a == "no:xdist" for a in extra):
        return []
    return ["-n", str(n), "--dist", "loadfile"]


def lab(notebooks: Path) -> int:
    """Open JupyterLab on the notebooks folder."""
    return subprocess.call([sys.executable, "-m", "jupyter", "lab", str(notebooks)])


def export_main(argv: list[str] | None = None) -> int:
    """``plantvr export TREE_FILE --format usd|glb|ply|obj [--lod N] [-o OUT] [--no-leaves] [--unskinned]``.

    Parameters
    ----------
    argv : list of str, optional
        Arguments after ``export``; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 on success, 2 when the tree file or an option is rejected (the reason is printed to stderr).
    """
    from . import Model
    from .io.tree import BILLBOARD_LOD, EXPORT_FORMATS, SUFFIX_FORMAT, export_model_as

    ap = argparse.ArgumentParser(prog="plantvr export",
                                 description="Write a saved tree (.tree or .npz) as USD, glTF (.glb), PLY or OBJ.")
    ap.add_argument("tree_file", metavar="TREE_FILE", help="a tree saved by Model.save (.tree or .npz)")
    ap.add_argument("--format", choices=tuple(EXPORT_FORMATS), default=None,
                    help="output format (default: from the suffix of -o, else glb)")
    ap.add_argument("--lod", type=int, default=0,
                    help="LOD level 0 (full) to 3 (coarsest), 4 = billboard (glb/obj); default 0")
    ap.add_argument("-o", "--output", default=None, help="output file (default: TREE_FILE with the format's suffix)")
    ap.add_argument("--no-leaves", action="store_true", help="branches only")
    ap.add_argument("--unskinned", action="store_true", help="glb without skeleton and growth animation")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)

    def fail(msg: str) -> int:                # one line, no traceback (cli.main prints the same way)
        print(f"plantvr export: error: {msg}".replace("\n", " "), file=sys.stderr)
        return 2

    src = Path(args.tree_file)
    if args.output is not None:
        out = Path(args.output)
        fmt = SUFFIX_FORMAT.get(out.suffix.lower())
        if args.format is not None and fmt != args.format:
            if fmt is None:
                out = out.with_suffix(EXPORT_FORMATS[args.format])
            else:
                return fail(f"--format {args.format} does not match the output suffix {out.suffix!r}")
    else:
        out = src.with_suffix(EXPORT_FORMATS[args.format or "glb"])
    try:
        if SUFFIX_FORMAT.get(out.suffix.lower()) is None:
            raise ValueError(f"-o {str(out)!r}: the output suffix must be one of {sorted(SUFFIX_FORMAT)}")
        if not 0 <= args.lod <= BILLBOARD_LOD:
            raise ValueError(f"lod must be an integer in [0, {BILLBOARD_LOD}], got {args.lod}")
        if args.lod == BILLBOARD_LOD and out.suffix.lower() not in (".glb", ".obj"):
            raise ValueError(f"lod {BILLBOARD_LOD} (the billboard) is written as .glb or .obj, got {out.suffix!r}")
        folder = out.parent if str(out.parent) else Path(".")
        if not folder.is_dir():
            raise ValueError(f"-o {str(out)!r}: the folder {str(folder)!r} does not exist")
        if not os.access(folder, os.W_OK):
            raise ValueError(f"-o {str(out)!r}: the folder {str(folder)!r} is not writable")
        if not src.is_file():
            raise ValueError(f"TREE_FILE {str(src)!r} does not exist")
        model = Model.load(src)
        t0 = time.perf_counter()
        if args.lod == BILLBOARD_LOD:
            from .view.billboard import export_billboard
            path = export_billboard(model.snapshot, model.params, out)
        else:
            path = export_model_as(model, out, lod=args.lod, leaves=not args.no_leaves, skinned=not args.unskinned)
    except ValueError as exc:
        return fail(str(exc))
    except OSError as exc:                     # disk full, permission denied while writing
        return fail(f"{exc.strerror or exc}{f': {exc.filename}' if exc.filename else ''}")
    print(f"wrote {path} ({model.snapshot.n_internodes} internodes, LOD {args.lod}, "
          f"{time.perf_counter() - t0:.2f} s)")
    return 0


def parameter_reference(kind: str | None = None) -> str:
    """The parameter reference page: every document's table (name, symbol, default, range, unit, thesis
    reference, meaning) as Markdown, generated from the tables themselves; ``kind`` picks one document."""
    from . import documents
    from .document import Document

    docs = [c for c in (getattr(documents, n) for n in documents.__all__)
            if isinstance(c, type) and issubclass(c, Document) and c.PARAMS is not None]
    kinds = sorted(c.KIND for c in docs)
    if kind is not None and kind not in kinds:
        raise ValueError(f"kind must be one of {kinds}, got {kind!r}")
    pages = [f"# {c.KIND} ({c.__name__})\n\n{c.PARAMS.reference()}" for c in docs if kind in (None, c.KIND)]
    return "\n\n".join(pages)


def _segment(argv: list[str]) -> int:
    from .view.vine_cli import main_segment  # noqa: PLC0415 (static, so the layer contract sees it)
    return main_segment(argv)


def _warmup(argv: list[str]) -> int:
    from ._warmup import main as warmup_main  # noqa: PLC0415
    return warmup_main(argv)


_DELEGATED = {  # sub-commands whose own parsers live beside their code: (entry point, help)
    "export": (export_main, "export a saved tree: usd | glb | ply | obj, at an LOD level"),
    "segment": (_segment, "ViNE: isosurface a volume and review/paint it in the browser"),
    "warmup": (_warmup, "compile and cache every numba kernel once (run at install)"),
}


def _int_in(flag: str, low: int, high: int):
    """argparse type: an integer in [low, high]; argparse prints the message as a one-line usage error."""
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            v = None
        if v is None or not low <= v <= high:
            raise argparse.ArgumentTypeError(f"{flag} must be >= {low} and <= {high}, got {text!r}")
        return v
    return parse


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``plantvr`` command.

    A bad argument or input file ends in one line on stderr (``plantvr CMD: error: ...``) and exit code 2,
    never a traceback.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    cmd = argv[0] if argv else ""
    try:
        return _main(argv)
    except (ValueError, OSError) as exc:
        msg = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        if isinstance(exc, OSError) and exc.filename:
            msg = f"{msg}: {exc.filename!s}"
        print(f"plantvr {cmd}: error: {msg}".replace("\n", " "), file=sys.stderr)
        return 2


def _main(argv: list[str]) -> int:
    if argv and argv[0] in _DELEGATED:
        entry, _ = _DELEGATED[argv[0]]
        return int(entry(argv[1:]) or 0)
    ap = argparse.ArgumentParser(prog="plantvr", description=__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name, (_, text) in _DELEGATED.items():
        sub.add_parser(name, help=f"{text} (plantvr {name} --help)")
    d = sub.add_parser("demo", help="grow a tree from built-in strokes; write tree.ply, tree.glb, tree.png")
    d.add_argument("--out", type=Path, default=Path("demo_out"))
    d.add_argument("--steps", type=_int_in("--steps", 1, 100_000), default=80)
    d.add_argument("--seed", type=_int_in("--seed", 0, 2**63 - 1), default=0)
    d.add_argument("--no-install", action="store_true", help="never run apt-get (only say what is missing)")
    la = sub.add_parser("lab", help="open JupyterLab on the notebooks")
    la.add_argument("notebooks", nargs="?", type=Path, default=ROOT / "notebooks")
    sub.add_parser("info", help="versions and optional features")
    pa = sub.add_parser("params", help="the parameter reference of every document (Markdown), or of one kind")
    pa.add_argument("kind", nargs="?", default=None, help="a document kind, e.g. treewand, treesketch")
    t = sub.add_parser("test", help="install test prerequisites and run the test suite")
    t.add_argument("--no-install", action="store_true", help="never run apt-get (only say what is missing)")
    t.add_argument("--no-boundscheck", action="store_true", help="skip the NUMBA_BOUNDSCHECK=1 pass")
    t.add_argument("pytest_args", nargs=argparse.REMAINDER)
    a = ap.parse_args(argv)
    if a.cmd == "demo":
        demo(a.out, a.steps, a.seed, install=not a.no_install)
        return 0
    if a.cmd == "lab":
        return lab(a.notebooks)
    if a.cmd == "info":
        info()
        return 0
    if a.cmd == "params":
        print(parameter_reference(a.kind))
        return 0
    return test(a.pytest_args, install=not a.no_install, boundscheck=not a.no_boundscheck)


if __name__ == "__main__":
    sys.exit(main())

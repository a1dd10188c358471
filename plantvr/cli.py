"""Command line: ``plantvr demo | lab | info | test | export | segment``."""
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


def demo(out: Path, steps: int, seed: int) -> dict:
    """Grow a tree from the built-in strokes and write tree.ply, tree.glb and tree.png to ``out``."""
    from tqdm import tqdm

    from . import Model
    from .export import export_model, tree_trimesh
    from .growth.scenarios import demo_session, run

    out.mkdir(parents=True, exist_ok=True)
    ensure_system_packages(browser=False)
    model = Model(seed=seed)
    t0 = time.perf_counter()
    stats = run(model, demo_session(), steps, tqdm(range(steps), desc="growing", unit="step"))
    grow_s = time.perf_counter() - t0
    mesh = tree_trimesh(model, leaves=True)
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
    print(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces")
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
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
        import pyvista as pv
        p = pv.Plotter(off_screen=True, window_size=(64, 64))
        p.add_mesh(pv.Sphere())
        p.screenshot(return_img=True)
        p.close()
        print("  offscreen rendering: ok")
    except Exception as exc:
        print(f"  offscreen rendering: FAILED ({exc})")
    print(f"  chromium (browser tests): {shutil.which('chromium') or 'missing'}")


def _egl_missing() -> bool:
    import ctypes.util  # noqa: PLC0415
    return ctypes.util.find_library("EGL") is None


def ensure_system_packages(*, browser: bool = True) -> None:
    """Install Debian's EGL/Mesa (offscreen VTK) and, for tests, chromium, when missing and possible."""
    need = ["libegl1", "libgl1-mesa-dri"] if _egl_missing() else []
    if browser and not shutil.which("chromium"):
        need.append("chromium")
    if not need:
        return
    if not shutil.which("apt-get") or os.geteuid() != 0:
        print(f"plantvr: please install {' '.join(need)} (apt-get); rendering or browser tests may be skipped")
        return
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    subprocess.run(["apt-get", "update", "-qq"], check=False, env=env)
    subprocess.run(["apt-get", "install", "-y", "-qq", *need], check=False, env=env)


def test(extra: list[str]) -> int:
    """Install system packages the tests need, then run pytest on tests/ and the notebooks (nbval)."""
    ensure_system_packages()
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    os.environ.setdefault("MPLBACKEND", "Agg")
    args = [sys.executable, "-m", "pytest", "tests", "notebooks", "--nbval-lax", "-p", "no:cacheprovider",
            "--timeout", "900", *extra]
    print("+", " ".join(args), flush=True)
    return subprocess.call(args, cwd=ROOT)


def lab(notebooks: Path) -> int:
    """Open JupyterLab on the notebooks folder."""
    return subprocess.call([sys.executable, "-m", "jupyter", "lab", str(notebooks)])


_DELEGATED = {  # sub-commands whose own parsers live beside their code
    "export": ("plantvr.export", "export_main", "export a saved tree: usd | glb | ply | obj, at an LOD level"),
    "segment": ("plantvr.view.vine_app", "main_segment", "ViNE: isosurface a volume and review/paint it in the browser"),
}


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``plantvr`` command."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in _DELEGATED:
        mod, fn, _ = _DELEGATED[argv[0]]
        return int(getattr(importlib.import_module(mod), fn)(argv[1:]) or 0)
    ap = argparse.ArgumentParser(prog="plantvr", description=__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name, (_, _, text) in _DELEGATED.items():
        sub.add_parser(name, help=f"{text} (plantvr {name} --help)")
    d = sub.add_parser("demo", help="grow a tree from built-in strokes; write tree.ply, tree.glb, tree.png")
    d.add_argument("--out", type=Path, default=Path("demo_out"))
    d.add_argument("--steps", type=int, default=80)
    d.add_argument("--seed", type=int, default=0)
    la = sub.add_parser("lab", help="open JupyterLab on the notebooks")
    la.add_argument("notebooks", nargs="?", type=Path, default=ROOT / "notebooks")
    sub.add_parser("info", help="versions and optional features")
    t = sub.add_parser("test", help="install test prerequisites and run the test suite")
    t.add_argument("pytest_args", nargs=argparse.REMAINDER)
    a = ap.parse_args(argv)
    if a.cmd == "demo":
        if a.steps < 1:
            ap.error(f"--steps must be >= 1, got {a.steps}")
        demo(a.out, a.steps, a.seed)
        return 0
    if a.cmd == "lab":
        return lab(a.notebooks)
    if a.cmd == "info":
        info()
        return 0
    return test(a.pytest_args)


if __name__ == "__main__":
    sys.exit(main())

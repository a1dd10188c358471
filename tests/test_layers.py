"""The import contracts (import-linter, configured in pyproject.toml; issues 21 and 30): cli > warmup > ui |
vr > view > io > documents > adapters > numeric cores > lsystem > base, no import cycles at any package level, cores
that import no UI, VTK or matplotlib, every module of the package in a layer, and PolyData and plotters built
in ``plantvr/view/`` only.

import-linter is a ``[dev]`` dependency, so a missing ``lint-imports`` fails here instead of skipping: a contract
that is never checked is no contract.
"""
import ast
import pkgutil
import shutil
import subprocess
from pathlib import Path

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

import plantvr

ROOT = Path(__file__).resolve().parent.parent


def _layers() -> list[str]:
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    (layers,) = [c["layers"] for c in conf if c["type"] == "layers"]
    return [m.strip() for layer in layers for m in layer.replace("|", ":").split(":")]


def test_layers_no_cycles_and_cores_without_ui():
    exe = shutil.which("lint-imports")
    assert exe is not None, "lint-imports (import-linter, a [dev] dependency) must be installed"
    res = subprocess.run([exe], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:]
    assert "0 broken" in res.stdout and "3 kept" in res.stdout


def test_every_module_is_in_a_layer():
    named = set(_layers())
    modules = {f"plantvr.{m.name}" for m in pkgutil.iter_modules(plantvr.__path__)}
    assert modules - named == set(), "modules in no layer of pyproject.toml's contract"
    assert named - modules == set(), "layers naming modules that do not exist"


def test_no_dynamic_imports_of_the_package():
    """``importlib.import_module("plantvr...")`` is invisible to the contract; only the root package's lazy
    re-exports (``plantvr.Model``, ``plantvr.View``) may use it."""
    for path in (ROOT / "plantvr").rglob("*.py"):
        if path == ROOT / "plantvr" / "__init__.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "import_module" and node.args:
                arg = node.args[0]
                assert not (isinstance(arg, ast.Constant) and str(arg.value).startswith(("plantvr", "."))), (
                    f"{path.relative_to(ROOT)}:{node.lineno} imports a package module dynamically")


def _name(node) -> str | None:
    return getattr(node, "attr", getattr(node, "id", None))


#: pyvista's geometric sources (each returns a new PolyData)
PV_SOURCES = {"Sphere", "Disc", "Plane", "Line", "Cube", "Cylinder", "Arrow", "Box", "Cone", "Circle", "Polygon",
              "Text3D", "Tube", "Spline"}


def test_polydata_and_plotters_are_built_in_view_only():
    """Issue 30: ``PolyData`` / ``vtkPolyData`` (also by ``PolyData.from_regular_faces`` and the like), VTK and
    pyvista geometric sources (``vtkSphereSource``, ``pv.Sphere``, ...) and ``pyvista.Plotter`` are built in
    ``plantvr/view/`` only; ``vr``, ``ui`` and ``cli`` call its helpers (the headset's ground, brush, ray and windows
    too)."""
    built = {"PolyData", "vtkPolyData", "Plotter"}
    found = []
    for path in sorted((ROOT / "plantvr").rglob("*.py")):
        if (ROOT / "plantvr" / "view") in path.parents:
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            f = node.func if isinstance(node, ast.Call) else None
            if f is None:
                continue
            name, owner = _name(f), _name(getattr(f, "value", None))
            source = (name or "").startswith("vtk") and (name or "").endswith("Source") or (
                owner in ("pv", "pyvista") and name in PV_SOURCES)
            if source or built & {name, owner}:
                found.append((str(path.relative_to(ROOT)), node.lineno))
    assert found == [], "PolyData or Plotter built outside plantvr/view/:\n" + "\n".join(
        f"{f}:{line}" for f, line in sorted(found))

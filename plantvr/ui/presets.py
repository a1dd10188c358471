"""Parameter presets: a JSON file of parameter values (spec 000_treewand §4.11 tables).

A preset is ``{"plantvr_preset": 1, "params": {name: value}}``. Loading checks every value against
the parameter table before anything is set, so a bad preset leaves the model untouched.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .._fileio import read_json as _read_json, write_atomic
from ..params import PARAMS, validate

__all__ = ["save_preset", "load_preset", "read_preset"]

_FORMAT = 1


# -- PlantVR JSON files (presets here, stroke files in .strokes): one set of path and I/O errors
def _json_path(path: str | Path, kind: str) -> Path:
    """``path`` as a Path; a ValueError naming the ``kind`` of file unless it ends in ``.json``."""
    path = Path(path)
    if path.suffix != ".json":
        raise ValueError(f"{kind} path must end in .json, got {path.suffix!r}")
    return path


def _write_text(path: Path, text: str, kind: str) -> Path:
    """Write ``text`` to ``path`` atomically (a failed save leaves the old file and no temporary file); an
    OSError becomes a ValueError naming the ``kind`` of file."""
    try:
        write_atomic(path, text)
    except OSError as exc:
        raise ValueError(f"cannot write {kind} {path!s}: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"cannot write {kind} {path!s}: {exc}") from None
    return path


def save_preset(model, path: str | Path, *, windows: tuple[str, ...] | None = None) -> Path:
    """Write the model's parameters (optionally only those of ``windows``) as a JSON preset.

    Parameters
    ----------
    model : plantvr.Model
    path : str or Path
        Destination, ``.json``.
    windows : tuple of str, optional
        Restrict to parameters of these windows (``"form"``, ``"appearance"``, ``"light"``, ``"hidden"``).

    Returns
    -------
    Path
    """
    path = _json_path(path, "preset")
    values = {p.name: getattr(model, p.name) for p in PARAMS if windows is None or p.window in windows}
    return _write_text(path, json.dumps({"plantvr_preset": _FORMAT, "params": values}, indent=1), "preset")


def read_preset(path: str | Path) -> dict[str, Any]:
    """Read and validate a preset file; returns ``{name: value}`` (checked against the table)."""
    path = Path(path)
    data = _read_json(path, "preset")
    if not isinstance(data, dict) or data.get("plantvr_preset") != _FORMAT or not isinstance(data.get("params"), dict):
        raise ValueError(f"preset {path!s} is not a PlantVR preset "
                         f"(expected {{'plantvr_preset': {_FORMAT}, 'params': {{...}}}})")
    try:
        return validate(data["params"])
    except ValueError as exc:
        raise ValueError(f"preset {path!s}: {exc}") from None


def load_preset(model, path: str | Path) -> dict[str, Any]:
    """Apply a preset to ``model`` (all values checked first); returns the values set."""
    values = read_preset(path)
    model.set_params(**values)
    return values

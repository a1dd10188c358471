"""Parameter presets: a JSON file of parameter values (spec 000_treewand §4.11 tables).

A preset is ``{"plantvr_preset": 1, "params": {name: value}}``. Loading checks every value against
the parameter table before anything is set, so a bad preset leaves the model untouched.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .._fileio import write_atomic
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


#: Largest PlantVR JSON file (preset, stroke file) read, in bytes.
MAX_JSON_BYTES = 64 * 2**20


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


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a finite number")


def _read_json(path: Path, kind: str) -> Any:
    """The parsed JSON of a PlantVR file (preset, stroke file); a ValueError naming the ``kind`` of file and
    its path when it is missing, too large, unreadable, not JSON, or holds NaN/Infinity or nesting too deep."""
    try:
        if path.stat().st_size > MAX_JSON_BYTES:
            raise ValueError(f"{kind} {path!s} is larger than the {MAX_JSON_BYTES} bytes allowed")
        return json.loads(path.read_text(encoding="utf-8"), parse_constant=_reject_constant)
    except FileNotFoundError:
        raise ValueError(f"{kind} {path!s} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read {kind} {path!s}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{kind} {path!s} is not valid JSON ({exc.msg}, line {exc.lineno})") from None
    except RecursionError:
        raise ValueError(f"{kind} {path!s} is nested too deeply") from None
    except ValueError as exc:
        if str(exc).startswith(kind):
            raise
        raise ValueError(f"{kind} {path!s}: {exc}") from None


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

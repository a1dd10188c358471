"""Parameter presets: a JSON file of parameter values (spec 000_treewand §4.11 tables).

A preset is ``{"plantvr_preset": 1, "params": {name: value}}``. Loading checks every value against
the parameter table before anything is set, so a bad preset leaves the model untouched.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..params import PARAMS, validate

__all__ = ["save_preset", "load_preset", "read_preset"]

_FORMAT = 1


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
    path = Path(path)
    if path.suffix != ".json":
        raise ValueError(f"preset path must end in .json, got {path.suffix!r}")
    values = {p.name: getattr(model, p.name) for p in PARAMS if windows is None or p.window in windows}
    try:
        path.write_text(json.dumps({"plantvr_preset": _FORMAT, "params": values}, indent=1))
    except OSError as exc:
        raise ValueError(f"cannot write preset {path!s}: {exc}") from None
    return path


def read_preset(path: str | Path) -> dict[str, Any]:
    """Read and validate a preset file; returns ``{name: value}`` (checked against the table)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"preset {path!s} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"cannot read preset {path!s}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"preset {path!s} is not valid JSON ({exc.msg}, line {exc.lineno})") from None
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

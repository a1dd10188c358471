"""Locate the front-end ESM/CSS sources of the notebook widgets (spec 000_treewand §4.6–§4.9).

Sources live in the top-level ``widgets/`` folder of a checkout and are shipped in the wheel as
``plantvr/_widgets``; both places are searched, the checkout first (so ``ANYWIDGET_HMR=1`` reloads edits).
"""
from __future__ import annotations

from pathlib import Path

__all__ = ["asset"]

_CANDIDATES = (Path(__file__).resolve().parents[2] / "widgets", Path(__file__).resolve().parents[1] / "_widgets")


def asset(name: str) -> Path:
    """Return the path of the front-end file ``name`` (e.g. ``"influence_triangle.js"``).

    Raises
    ------
    ValueError
        If the file is in neither ``widgets/`` nor ``plantvr/_widgets``.
    """
    for folder in _CANDIDATES:
        path = folder / name
        if path.is_file():
            return path
    raise ValueError(f"widget asset {name!r} not found in {[str(c) for c in _CANDIDATES]}; "
                     "reinstall plantvr (the wheel ships widgets/ as plantvr/_widgets)")

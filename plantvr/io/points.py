"""Point clouds in (issue 22 "Trees from scans"): .xyz/.txt/.csv columns, .ply, .las/.laz as (N, 3) float64.

:func:`read_points` reads the coordinates a terrestrial or airborne laser scanner writes; the result goes to a
Tree Wand model as a marker set (:func:`points_as_markers`, i.e. ``Model.add_markers``) or to a crown envelope
(:func:`plantvr.implicit.envelope.crown_from_points`).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from plantvr._validation import check_int, check_points

__all__ = ["POINT_SUFFIXES", "points_as_markers", "read_points"]

POINT_SUFFIXES = (".xyz", ".txt", ".csv", ".pts", ".ply", ".las", ".laz")
"""Suffixes :func:`read_points` reads."""

#: Most points one file may give.
MAX_POINTS = 100_000_000


def _text_points(p: Path, columns) -> np.ndarray:
    delim = "," if p.suffix.lower() == ".csv" else None
    try:
        with open(p, encoding="utf-8", errors="strict") as fh:
            first = fh.readline()
        tokens = first.replace(",", " ").split()
        try:
            [float(t) for t in tokens[:3]]
            skip = 0
        except ValueError:
            skip = 1  # a header line
        if p.suffix.lower() == ".pts" and len(tokens) == 1:
            skip = 1  # Leica .pts: the point count first
        a = np.loadtxt(p, delimiter=delim, skiprows=skip, usecols=columns, ndmin=2, comments=("#", "//"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"cannot read points from {str(p)!r}: {exc}"[:300]) from None
    return a


def read_points(path, *, columns=None, max_points: int = MAX_POINTS) -> np.ndarray:
    """Read a point cloud's coordinates.

    Parameters
    ----------
    path : str or path-like
        ``.xyz``/``.txt``/``.pts`` (whitespace columns; a header line is skipped), ``.csv`` (comma columns),
        ``.ply`` (vertices, read by trimesh; meshes give their vertices), ``.las``/``.laz`` (laspy; scaled and
        offset coordinates).
    columns : 3 ints, optional
        Text formats only: the x, y, z columns (default ``(0, 1, 2)``); refused for ``.ply``/``.las``/``.laz``,
        whose coordinates are named fields.
    max_points : int
        Refuse files with more points, in [1, MAX_POINTS].

    Returns
    -------
    (N, 3) float64 ndarray
        Finite coordinates in the file's units.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or path-like, got {type(path).__name__}")
    p = Path(path)
    suf = p.suffix.lower()
    if suf not in POINT_SUFFIXES:
        raise ValueError(f"path must end in one of {list(POINT_SUFFIXES)}, got {str(p)!r}")
    if not p.is_file():
        raise ValueError(f"point file {str(p)!r} does not exist")
    cap = check_int("max_points", max_points, 1, MAX_POINTS)
    if columns is not None and suf in (".ply", ".las", ".laz"):
        raise ValueError(f"columns picks the x, y, z columns of a text file; a {suf} file names its coordinates, "
                         f"so columns={columns!r} does not apply to {str(p)!r}")
    try:
        cols = (0, 1, 2) if columns is None else tuple(int(c) for c in columns)
    except (TypeError, ValueError):
        cols = ()
    if len(cols) != 3 or min(cols) < 0:
        raise ValueError(f"columns must be 3 non-negative column indices, got {columns!r}")
    if suf in (".las", ".laz"):
        try:
            import laspy
        except ImportError:
            raise ValueError("reading .las/.laz needs laspy (pip install laspy; lazrs for .laz)") from None
        try:
            las = laspy.read(str(p))
            a = np.column_stack([np.asarray(las.x, np.float64), np.asarray(las.y, np.float64),
                                 np.asarray(las.z, np.float64)])
        except Exception as exc:  # laspy raises its own LaspyException and many decoder errors
            raise ValueError(f"cannot read points from {str(p)!r}: {exc}"[:300]) from None
    elif suf == ".ply":
        import trimesh
        try:
            obj = trimesh.load(str(p), process=False)
            a = np.asarray(obj.vertices, np.float64)
        except Exception as exc:  # trimesh raises many kinds on a corrupt file
            raise ValueError(f"cannot read points from {str(p)!r}: {exc}"[:300]) from None
    else:
        a = _text_points(p, cols)
    if len(a) > cap:
        raise ValueError(f"{str(p)!r} holds {len(a)} points, more than max_points = {cap}")
    try:
        return check_points("points", np.ascontiguousarray(a, np.float64), min_rows=1)
    except ValueError as exc:
        raise ValueError(f"{str(p)!r}: {exc}") from None


def points_as_markers(model, points) -> int:
    """Add ``points`` (an array or a file for :func:`read_points`) to a Tree Wand model as markers
    (``Model.add_markers``, one undoable command); returns the number added."""
    if isinstance(points, (str, os.PathLike)):
        points = read_points(points)
    pts = check_points("points", points, min_rows=1)
    model.add_markers(pts)
    return len(pts)

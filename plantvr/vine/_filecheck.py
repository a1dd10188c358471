"""Mesh-sized bounds on ViNE's zip-based files, checked before anything is inflated (issue 20: zip bombs).

:func:`plantvr._fileio.read_npz` / :func:`~plantvr._fileio.read_zip` cap the *declared* size of a file; a
session or bundle also knows how large each array may be for its mesh (labels: one byte per vertex, the colour
table: at most 256 entries, ...). :func:`plantvr._fileio.npy_headers` reads only the ``.npy`` header of each
member, so :func:`check_elements` can refuse an array larger than its mesh allows before it is inflated.
"""
from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

__all__ = ["check_elements"]


def _error(what: str, path, msg: str) -> ValueError:
    return ValueError(f"cannot read {what} {os.fspath(path)!r}: {msg}")


def check_elements(headers: Mapping[str, tuple[tuple, np.dtype]], bounds: Mapping[str, int], *, what: str,
                   path) -> None:
    """Refuse an array whose declared element count exceeds its bound (names missing from ``bounds`` pass)."""
    for name, (shape, _dtype) in headers.items():
        if name not in bounds:
            continue
        n = int(np.prod(shape, dtype=object))
        if n > bounds[name]:
            raise _error(what, path, f"array {name!r} declares {n} elements {list(shape)}, more than the "
                                     f"{bounds[name]} its mesh allows")

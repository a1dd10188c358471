"""Door checks shared by the Yggdrasil and tree-geometry cores: triangle meshes (issue 20).

Faces go through :func:`plantvr._validation.check_index`, so a numba kernel never sees an index outside
the vertex table.
"""
from __future__ import annotations

import numpy as np

from plantvr._validation import MAX_COORD, MAX_COUNT, check_array, check_index

__all__ = ["check_mesh", "MAX_JOINT_POINTS"]

#: Largest point set of one joint hull (the incremental kernel keeps an n × n edge table per joint).
MAX_JOINT_POINTS = 4096


def check_mesh(vertices, faces, *, max_abs: float = 10 * MAX_COORD) -> tuple[np.ndarray, np.ndarray]:
    """``(V, 3)`` finite vertices inside ``±max_abs`` and ``(F, 3)`` faces indexing them, as float64/int64."""
    V = check_array("vertices", vertices, shape=(None, 3), max_abs=max_abs)
    if len(V) > MAX_COUNT:
        raise ValueError(f"vertices must have at most {MAX_COUNT} rows, got {len(V)}")
    F = check_index("faces", faces, shape=(None, 3), low=0, high=len(V) - 1, table="vertices")
    if len(F) > MAX_COUNT:
        raise ValueError(f"faces must have at most {MAX_COUNT} rows, got {len(F)}")
    return V, F

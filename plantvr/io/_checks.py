"""Door checks shared by the tree writers of :mod:`plantvr.io` (issue 20: check everything before writing)."""
from __future__ import annotations

import numpy as np

from plantvr.subdivision._checks import check_mesh

__all__ = ["check_tree_meshes"]


def check_tree_meshes(branches, leaves) -> None:
    """Branch and leaf meshes must be consistent (faces index their vertices) before anything is written."""
    for name, m in (("branches", branches), ("leaves", leaves)):
        if m is None:
            continue
        if not all(hasattr(m, a) for a in ("vertices", "faces", "normals", "uv")):
            raise ValueError(f"{name} must be a BranchMesh or LeafMesh, got {type(m).__name__}")
        try:
            V, _ = check_mesh(m.vertices, m.faces)
        except ValueError as exc:
            raise ValueError(f"{name}: {exc}") from None
        for a, k in (("normals", 3), ("uv", 2)):
            arr = np.asarray(getattr(m, a))
            if arr.shape != (len(V), k) or not np.all(np.isfinite(arr)):
                raise ValueError(f"{name}.{a} must be a finite ({len(V)}, {k}) array, got shape {arr.shape}")

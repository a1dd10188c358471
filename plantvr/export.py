"""Tree meshes for files: the model's branches as a trimesh (PLY, OBJ, glTF through trimesh exporters)."""
from __future__ import annotations

import numpy as np
import trimesh

from .model import Model

__all__ = ["tree_trimesh"]


def tree_trimesh(model: Model) -> trimesh.Trimesh:
    """Return the branch mesh of ``model``'s latest snapshot as a ``trimesh.Trimesh`` (vertex order kept)."""
    from .view import branch_mesh  # noqa: PLC0415  (pyvista tubes until the geometry package lands)
    poly = branch_mesh(model.snapshot).triangulate()
    faces = poly.faces.reshape(-1, 4)[:, 1:] if poly.n_cells else np.zeros((0, 3), np.int64)
    mesh = trimesh.Trimesh(np.asarray(poly.points, float), faces, process=False)
    mesh.visual.vertex_colors = np.tile([139, 90, 43, 255], (len(mesh.vertices), 1)).astype(np.uint8)
    return mesh

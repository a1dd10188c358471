"""A document's scene to one mesh file through the writer registry (issue 33: the L-system's shapes; issue 30:
one writer per format).

:func:`export_scene` writes what :meth:`plantvr.document.Document.scene` holds: each
:class:`~plantvr.types.TriMesh` with per-vertex colours (an L-system's shapes, one mesh per L-Py material) as a
part of its own, coloured by its material, and each :class:`~plantvr.types.TreeArrays` as its
generalized-cylinder branch mesh (:func:`plantvr.io.tree.tree_geometry`, Tree Wand's appearance defaults).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..params import TREEWAND
from ..types import TreeArrays, TriMesh
from .tree import tree_geometry
from .writers import Part, save

__all__ = ["SCENE_FORMATS", "export_scene"]

#: Formats :func:`export_scene` writes: binary and text glTF (one mesh and material per part), PLY (the coloured
#: meshes merged, per-vertex colours; no branches, which carry no colours).
SCENE_FORMATS = ("glb", "gltf", "ply")


def export_scene(doc, path: str | os.PathLike, *, branches: bool = True) -> Path:
    """Write ``doc.scene()`` (y-up, as the views draw it) to ``path``: ``.glb``/``.gltf`` or ``.ply``.

    Parameters
    ----------
    doc : Document
        Any document (its :meth:`~plantvr.document.Document.scene`).
    path : path-like
        Output file; its folder must exist.
    branches : bool
        glTF: also the trees' branch meshes (``"branches"``, or ``"<name> branches"`` for a tree not named
        ``tree``), first.

    Returns
    -------
    pathlib.Path
    """
    scene = doc.scene()
    if not isinstance(scene, dict):
        raise ValueError(f"doc must be a document with a scene(), got {type(doc).__name__}")
    fmt = Path(path).suffix.lower().lstrip(".")
    shapes = [Part(name, m.vertices, m.faces, colors=m.colors,
                   material={"name": name, "rgba": (*(np.asarray(m.colors[0], float)[:3] / 255.0), 1.0),
                             "double_sided": True})
              for name, m in scene.items()
              if isinstance(m, TriMesh) and getattr(m, "colors", None) is not None and len(m.faces)]
    if fmt == "ply":
        if not shapes:
            raise ValueError("the scene has no coloured meshes to write as PLY (the skeleton needs .glb)")
        return save(path, shapes, allowed=SCENE_FORMATS, comment="PlantVR scene")
    trees = []
    if branches:
        for name, t in scene.items():
            if isinstance(t, TreeArrays) and t.n_internodes:
                bm, _ = tree_geometry(t, TREEWAND.defaults(), leaves=False)
                trees.append(Part("branches" if name == "tree" else f"{name} branches", bm.vertices, bm.faces))
    parts = trees + shapes
    if not parts:
        raise ValueError("the scene is empty: nothing to export")
    return save(path, parts, allowed=SCENE_FORMATS, generator="PlantVR scene")

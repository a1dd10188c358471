"""Any triangle mesh to PLY, OBJ or glTF/GLB through the writer registry (spec 001_subdivision §2.7; issue 21;
issue 30)."""
from __future__ import annotations

from pathlib import Path

from .writers import Part, save, writer_for

__all__ = ["MESH_FORMATS", "export_mesh"]

MESH_FORMATS = ("ply", "obj", "gltf", "glb")
"""Formats :func:`export_mesh` writes."""


def export_mesh(mesh, path, *, file_type: str | None = None) -> Path:
    """Write a mesh to PLY, OBJ or glTF/GLB through the writer registry, vertex order kept.

    Parameters
    ----------
    mesh : TriMesh, trimesh.Trimesh or ControlMesh
        Anything with ``vertices`` (V, 3) and ``faces`` (F, 3).
    path : str or Path
        Output file; the suffix picks the format unless ``file_type`` is given.
    file_type : {"ply", "obj", "gltf", "glb"}, optional
        Format.

    Returns
    -------
    Path
        The written path (a ``.gltf`` also writes its buffer ``<stem>.bin`` beside it).

    Raises
    ------
    ValueError
        For an unknown format, an object without vertices and faces, or a folder that does not exist
        (:func:`plantvr._fileio.check_target`: no writer creates folders).
    """
    path = Path(path)
    fmt = writer_for(path, file_type, allowed=MESH_FORMATS).format
    if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
        raise ValueError(f"mesh must be a TriMesh, trimesh.Trimesh or ControlMesh, got {type(mesh).__name__}")
    return save(path, Part("mesh", mesh.vertices, mesh.faces), file_type=fmt, double=True, normals=False,
                comment="PlantVR mesh")

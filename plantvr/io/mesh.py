"""Any triangle mesh to PLY, OBJ or glTF/GLB through the one writer of each format (spec 001_subdivision §2.7;
issue 21)."""
from __future__ import annotations

from pathlib import Path

from plantvr._fileio import check_target
from plantvr._validation import check_choice

from .gltf import write_mesh
from .obj import write_obj
from .ply import write_ply

__all__ = ["export_mesh"]


def export_mesh(mesh, path, *, file_type: str | None = None) -> Path:
    """Write a mesh to PLY, OBJ or glTF/GLB, vertex order kept.

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
    ft = check_choice("file_type", (file_type or path.suffix.lstrip(".")).lower(), ("ply", "obj", "gltf", "glb"))
    if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
        raise ValueError(f"mesh must be a TriMesh, trimesh.Trimesh or ControlMesh, got {type(mesh).__name__}")
    check_target(path)
    if ft == "ply":
        write_ply(path, mesh.vertices, mesh.faces, double=True, comment="PlantVR mesh")
    elif ft == "obj":
        write_obj(path, mesh.vertices, mesh.faces, normals=False, name="mesh", comment="PlantVR mesh")
    else:
        write_mesh(path, mesh.vertices, mesh.faces, binary=ft == "glb")
    return path

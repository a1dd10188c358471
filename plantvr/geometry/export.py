"""Export of tree meshes to PLY, OBJ and binary glTF through trimesh (spec 000_treewand §3, §8.1 items 16–22).

glTF carries UVs, vertex normals and two PBR materials with the procedural bark and leaf textures; OBJ writes
its .mtl and texture images beside the .obj; PLY carries positions, normals and per-vertex colours.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from plantvr._fileio import write_atomic
from plantvr._validation import check_choice

from .leaves import LeafMesh
from .mesh import BranchMesh
from .textures import BARK_TEXTURES, LEAF_TEXTURES, bark_texture, leaf_texture

__all__ = ["tree_scene", "export_tree", "FORMATS"]

FORMATS = (".ply", ".obj", ".glb")
_BARK_RGB = (96, 66, 40)
_LEAF_RGB = (70, 140, 45)


def _textured(mesh, image, name: str, leaf: bool):
    import trimesh
    from PIL import Image

    mat = trimesh.visual.material.PBRMaterial(
        name=name, baseColorTexture=Image.fromarray(np.asarray(image)), metallicFactor=0.0, roughnessFactor=0.9,
        doubleSided=leaf, alphaMode="MASK" if leaf else "OPAQUE", alphaCutoff=0.5 if leaf else None)
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, vertex_normals=mesh.normals, process=False,
                         visual=trimesh.visual.TextureVisuals(uv=mesh.uv, material=mat))
    return tm


def tree_scene(branches: BranchMesh, leaves: LeafMesh | None = None, *, bark: str = "furrowed",
               leaf: str = "ovate"):
    """A ``trimesh.Scene`` with a textured bark mesh and, if given, a textured leaf mesh.

    Parameters
    ----------
    branches : BranchMesh
    leaves : LeafMesh, optional
    bark : {"furrowed", "birch"}
        Bark texture (B.2 "Bark texture select").
    leaf : {"ovate", "lobed"}
        Leaf texture (B.2 "Leaf texture select").

    Returns
    -------
    trimesh.Scene
        Geometry names ``"bark"`` and ``"leaves"``.
    """
    import trimesh

    check_choice("bark", bark, BARK_TEXTURES)
    check_choice("leaf", leaf, LEAF_TEXTURES)
    scene = trimesh.Scene()
    scene.add_geometry(_textured(branches, bark_texture(bark), "bark", False), geom_name="bark")
    if leaves is not None and len(leaves.faces):
        scene.add_geometry(_textured(leaves, leaf_texture(leaf), "leaves", True), geom_name="leaves")
    return scene


def export_tree(path, branches: BranchMesh, leaves: LeafMesh | None = None, *, bark: str = "furrowed",
                leaf: str = "ovate") -> Path:
    """Write a tree mesh to ``path``; the format follows the suffix (.ply, .obj or .glb).

    Parameters
    ----------
    path : str or pathlib.Path
        Output file. OBJ also writes ``<stem>.mtl`` and the texture PNGs beside it.
    branches : BranchMesh
    leaves : LeafMesh, optional
    bark, leaf : str
        Texture choices, as in :func:`tree_scene`.

    Returns
    -------
    pathlib.Path
        The written file.
    """
    import trimesh

    path = Path(path)
    suffix = check_choice("path suffix", path.suffix.lower(), FORMATS)
    _check_meshes(branches, leaves)
    scene = tree_scene(branches, leaves, bark=bark, leaf=leaf)
    if suffix == ".glb":
        write_atomic(path, trimesh.exchange.gltf.export_glb(scene, include_normals=True))
    elif suffix == ".ply":
        parts = [branches] + ([leaves] if leaves is not None and len(leaves.faces) else [])
        rgb = [_BARK_RGB, _LEAF_RGB]
        verts = np.concatenate([p.vertices for p in parts])
        offs = np.cumsum([0] + [len(p.vertices) for p in parts])
        faces = np.concatenate([p.faces + o for p, o in zip(parts, offs)])
        cols = np.concatenate([np.tile(np.array([*c, 255], np.uint8), (len(p.vertices), 1)) for p, c in zip(parts, rgb)])
        mesh = trimesh.Trimesh(verts, faces, vertex_normals=np.concatenate([p.normals for p in parts]),
                               vertex_colors=cols, process=False)
        write_atomic(path, trimesh.exchange.ply.export_ply(mesh, encoding="binary", include_attributes=False))
    else:
        mesh = trimesh.util.concatenate(list(scene.geometry.values()))
        text, tex = trimesh.exchange.obj.export_obj(mesh, include_normals=True, include_texture=True,
                                                    return_texture=True, mtl_name=path.stem + ".mtl")
        if not (path.parent if str(path.parent) else Path(".")).is_dir():
            raise ValueError(f"cannot write {str(path)!r}: folder {str(path.parent)!r} does not exist")
        for name, data in tex.items():            # material and textures first, the .obj that names them last
            write_atomic(path.parent / name, data)
        write_atomic(path, text)
    return path


def _check_meshes(branches, leaves) -> None:
    """Branch and leaf meshes must be consistent (faces index their vertices) before anything is written."""
    from plantvr.subdivision._checks import check_mesh

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

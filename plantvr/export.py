"""The model's tree as meshes and files: generalized-cylinder branches and leaves (spec 000_treewand §3)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import trimesh

from .geometry.export import export_tree
from .geometry.leaves import LeafMesh, build_leaves
from .geometry.mesh import BranchMesh, build_branch_mesh
from .model import Model, Snapshot

__all__ = ["tree_geometry", "tree_trimesh", "export_model"]

def tree_geometry(snap: Snapshot, params: dict[str, Any], *, leaves: bool = True,
                  lod: tuple[int, int] = (6, 32)) -> tuple[BranchMesh, LeafMesh | None]:
    """Branch mesh and leaf mesh of a snapshot, with the appearance parameters of ``params`` (§4.11 B.2)."""
    branches = build_branch_mesh(snap.pos, snap.parent, snap.radius, main_child=snap.main_child,
                                 bezier_w=params["bezier_weight"], lod=lod, tip_radius=params["tip_radius"],
                                 bark_rate=params["bark_rate"])
    leaf = None
    if leaves and params["leaf_size"] > 0 and len(snap.buds["pos"]):
        leaf = build_leaves(snap.buds["pos"], snap.buds["dir"], snap.buds["radius"], bud_up=snap.buds["up"],
                            leaf_size=params["leaf_size"], radius_threshold=3 * params["tip_radius"],
                            petiole_length=params["petiole_length"], e_twist=params["petiole_twist"],
                            e_up=params["petiole_bend_up"], e_right=params["petiole_bend_right"],
                            iterations=params["leaf_iterations"],
                            leaf_shape=params["leaf_texture"], rng=0)
    return branches, leaf


def tree_trimesh(model: Model, *, leaves: bool = False) -> trimesh.Trimesh:
    """The branches (and optionally leaves) of ``model``'s latest snapshot as one ``trimesh.Trimesh``."""
    branches, leaf = tree_geometry(model.snapshot, model.params, leaves=leaves)
    parts = [branches.to_trimesh()] + ([leaf.to_trimesh()] if leaf is not None else [])
    return trimesh.util.concatenate(parts) if len(parts) > 1 else parts[0]


def export_model(model: Model, path: str | Path) -> Path:
    """Write the model's tree (branches, leaves, textures where the format has them) to .ply, .obj or .glb."""
    branches, leaf = tree_geometry(model.snapshot, model.params)
    return export_tree(path, branches, leaf, bark=model.bark_texture, leaf=model.leaf_texture)
